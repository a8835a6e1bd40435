//! Host-side BVH: obvhs builds a BVH2 on every core (PLOC, then reinsertion optimisation and leaf
//! collapsing, both driven by the surface-area heuristic), which we flatten into nodes (encoded
//! for the GPU in `gpu::bvh_nodes`) and a triangle order in which every leaf's triangles are
//! contiguous.

use crate::scene::Triangle;
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

/// A node of the tree as built. Inner node (count == 0): children at `nodes[first]` and
/// `nodes[first + 1]`. Leaf: triangles `[first, first + count)` of `Bvh::order`. The kernels read
/// it re-encoded, each node with its children's boxes (`gpu::bvh_nodes`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    pub count: u32,
}

pub struct Bvh {
    /// Root first.
    pub nodes: Vec<BvhNode>,
    /// `order[i]` is the scene triangle stored at position i of the GPU triangle arrays.
    pub order: Vec<u32>,
    pub build_time: Duration,
    /// SAH cost with unit traversal and intersection costs, relative to the root's area.
    pub sah_cost: f32,
}

/// obvhs's medium preset with leaves collapsed at a node cost of 2 triangle tests instead of 3:
/// smaller leaves. Measured with Mesa 25's lavapipe, 256×256, 32 spp, medians of 3: Cornell box
/// 0.90-0.92× the render time (light, mis, mis-lobes), Veach scene 0.96-0.99×, textured scene
/// within the spread (Mesa 22.3: 0.93-0.98×); 7 more bytes per triangle (49 at 1M triangles)
/// (docs/performance.md, "Smaller BVH leaves").
fn build_params() -> BvhBuildParams {
    BvhBuildParams { collapse_traversal_cost: 2.0, ..BvhBuildParams::medium_build() }
}

pub fn build_bvh(triangles: &[Triangle]) -> Bvh {
    build_bvh_with(triangles, build_params())
}

/// obvhs's own medium preset: leaves collapsed at a node cost of 3 triangle tests, about a third
/// fewer nodes than `build_bvh`'s (`gpu::bvh_nodes::build_bvh_fitting`).
pub fn build_bvh_larger_leaves(triangles: &[Triangle]) -> Bvh {
    build_bvh_with(triangles, BvhBuildParams::medium_build())
}

fn build_bvh_with(triangles: &[Triangle], params: BvhBuildParams) -> Bvh {
    let start = Instant::now();
    if triangles.is_empty() {
        // One leaf holding the zero-area placeholder triangle that `build_scene_arrays` uploads
        // for an empty scene: the watertight test never reports a hit on it.
        let nodes = vec![BvhNode { min: [0.0; 3], first: 0, max: [0.0; 3], count: 1 }];
        return Bvh { nodes, order: Vec::new(), build_time: start.elapsed(), sah_cost: 0.0 };
    }
    let tris: Vec<obvhs::triangle::Triangle> = triangles
        .iter()
        .map(|t| obvhs::triangle::Triangle {
            v0: Vec3A::from(t.p[0]),
            v1: Vec3A::from(t.p[1]),
            v2: Vec3A::from(t.p[2]),
        })
        .collect();
    let mut core_time = Duration::ZERO;
    let bvh2 = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut core_time);
    let nodes: Vec<BvhNode> = bvh2
        .nodes
        .iter()
        .map(|n| BvhNode {
            min: n.aabb.min.to_array(),
            first: n.first_index,
            max: n.aabb.max.to_array(),
            count: n.prim_count,
        })
        .collect();
    let sah_cost = sah_cost(&nodes);
    Bvh { nodes, order: bvh2.primitive_indices, build_time: start.elapsed(), sah_cost }
}

impl Bvh {
    /// Does a triangle of `triangles` (the ones the tree was built over) that `counts` have its
    /// bounding box within `radius` of `centre`? Boxes stand in for triangles, so a yes may be a
    /// near miss; a no is certain.
    pub fn any_triangle_near(
        &self,
        triangles: &[Triangle],
        centre: Vec3,
        radius: f32,
        counts: impl Fn(u32, &Triangle) -> bool,
    ) -> bool {
        let reaches = |min: Vec3, max: Vec3| (centre.clamp(min, max) - centre).length_squared() <= radius * radius;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let Some(n) = self.nodes.get(i) else { continue };
            if !reaches(Vec3::from(n.min), Vec3::from(n.max)) {
                continue;
            }
            if n.count == 0 {
                stack.extend([n.first as usize, n.first as usize + 1]);
                continue;
            }
            let leaf = &self.order[n.first as usize..(n.first + n.count) as usize];
            for &t in leaf {
                let Some(tri) = triangles.get(t as usize) else { continue };
                let (min, max) = (tri.p[0].min(tri.p[1]).min(tri.p[2]), tri.p[0].max(tri.p[1]).max(tri.p[2]));
                if reaches(min, max) && counts(t, tri) {
                    return true;
                }
            }
        }
        false
    }
}

pub(crate) fn half_area(n: &BvhNode) -> f32 {
    let d = [n.max[0] - n.min[0], n.max[1] - n.min[1], n.max[2] - n.min[2]];
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// Σ inner A(n)/A(root) + Σ leaves A(n)/A(root) · count: the expected node and triangle tests of
/// a random ray that hits the root (MacDonald & Booth 1990).
fn sah_cost(nodes: &[BvhNode]) -> f32 {
    let root = half_area(&nodes[0]).max(f32::MIN_POSITIVE);
    nodes.iter().map(|n| half_area(n) / root * if n.count > 0 { n.count as f32 } else { 1.0 }).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn grid(n: usize) -> Vec<Triangle> {
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let o = Vec3::new(i as f32, j as f32, (i * j % 7) as f32 * 0.1);
                let p = [o, o + Vec3::X, o + Vec3::Y];
                out.push(Triangle { p, n: [Vec3::Z; 3], uv: Default::default(), material: 0 });
            }
        }
        out
    }

    #[test]
    fn every_triangle_is_in_exactly_one_leaf_and_inside_its_bounds() {
        let tris = grid(40);
        let bvh = build_bvh(&tris);
        let mut seen = vec![0u32; tris.len()];
        for node in bvh.nodes.iter().filter(|n| n.count > 0) {
            for slot in node.first..node.first + node.count {
                let t = bvh.order[slot as usize] as usize;
                seen[t] += 1;
                for p in tris[t].p {
                    for k in 0..3 {
                        assert!(p[k] >= node.min[k] - 1e-5 && p[k] <= node.max[k] + 1e-5);
                    }
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "a triangle is missing or duplicated");
    }

    #[test]
    fn children_lie_inside_their_parent() {
        let bvh = build_bvh(&grid(30));
        for n in bvh.nodes.iter().filter(|n| n.count == 0) {
            for c in [&bvh.nodes[n.first as usize], &bvh.nodes[n.first as usize + 1]] {
                for k in 0..3 {
                    assert!(c.min[k] >= n.min[k] && c.max[k] <= n.max[k]);
                }
            }
        }
    }

    /// obvhs builds in parallel (its `parallel` feature, rayon): the tree must not depend on how
    /// the threads were scheduled, or the same scene would render differently from run to run.
    /// 40,000 triangles, so that the parallel paths split their work into many chunks.
    #[test]
    fn the_parallel_build_gives_the_same_tree_every_time() {
        let tris = grid(200);
        let first = build_bvh(&tris);
        for _ in 0..3 {
            let again = build_bvh(&tris);
            assert_eq!(again.nodes, first.nodes);
            assert_eq!(again.order, first.order);
        }
    }
}

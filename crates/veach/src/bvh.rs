//! Host-side BVH: obvhs builds a BVH2 on every core (PLOC, then reinsertion optimisation and leaf
//! collapsing, both driven by the surface-area heuristic), which we flatten into nodes (encoded
//! for the GPU in `gpu::bvh_nodes`) and a triangle order in which every leaf's triangles are
//! contiguous. Where that tree is poor, long thin triangles are split into pieces with tighter
//! boxes, and a triangle may then appear in several leaves (`split_triangle_boxes`).

use crate::scene::Triangle;
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
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

/// obvhs's medium preset with two changes (docs/performance.md, "Smaller BVH leaves" and
/// "Reinsertion over every node"):
/// - leaves collapsed at a node cost of 2 triangle tests instead of 3: smaller leaves. Measured
///   with Mesa 25's lavapipe, 256×256, 32 spp, medians of 3: Cornell box 0.90-0.92× the render
///   time, Veach scene 0.96-0.99× (Mesa 22.3: 0.93-0.98×); 7 more bytes per triangle;
/// - reinsertion (Meister & Bittner 2018) offered every node before the collapse, not a twentieth
///   of them: the SAH cost of the zoo's overlapping scenes falls 9-11% (instanced rocks 58.8 →
///   53.7, grass 166 → 151) and their render time 7-10%, for 4-7× the build time (a million
///   triangles 0.5 → 3.5-3.9 s on 2 cores).
fn build_params(collapse_traversal_cost: f32) -> BvhBuildParams {
    BvhBuildParams { collapse_traversal_cost, reinsertion_batch_ratio: 1.0, ..BvhBuildParams::medium_build() }
}

pub fn build_bvh(triangles: &[Triangle]) -> Bvh {
    build_bvh_with(triangles, build_params(2.0))
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
    let boxes: Vec<Aabb> = tris.iter().map(|t| t.aabb()).collect();
    let mut bvh = flatten(build_over_boxes(&boxes, (0..tris.len() as u32).collect(), false, params));
    if bvh.sah_cost > SPLIT_TRY_COST && SPLIT_PIECES * tris.len() <= MAX_REFERENCES {
        let (split_boxes, split_indices) = split_triangle_boxes(&tris, boxes);
        let split = flatten(build_over_boxes(&split_boxes, split_indices, true, params));
        if split.sah_cost < SPLIT_SAH_GAIN * bvh.sah_cost {
            bvh = split;
        }
    }
    bvh.build_time = start.elapsed();
    bvh
}

/// Triangles are split only where the tree over whole ones has an SAH cost above this: a ray that
/// enters the scene's box tests over 100 nodes and triangles. Trying the split takes 6-8 times
/// the build time; on the zoo only the grass (215) is above, its meshes and lights are at 3-60.
const SPLIT_TRY_COST: f32 = 100.0;
/// At most this many triangle references in a tree with split triangles (64 MiB of the kernels'
/// 16-byte triangles: half of the 128 MiB per binding that wgpu's default limits give).
const MAX_REFERENCES: usize = 1 << 22;
/// The most pieces `split_triangle_boxes` cuts a triangle's box into.
const SPLIT_PIECES: usize = 4;
/// The tree over split boxes is kept where its SAH cost is below this fraction of the other's.
const SPLIT_SAH_GAIN: f32 = 0.9;

/// Early split clipping (Ernst & Greiner 2007, "Early Split Clipping for Bounding Volume
/// Hierarchies"): each triangle's box is cut in two, twice, along its longest axis where the two
/// boxes of the clipped triangle have the least area (obvhs's `split_aabbs_precise`, 12
/// positions), wherever that takes a sixth of the area away. Long thin triangles lying
/// diagonally (grass blades) fill a small part of their boxes, and in a dense field the boxes
/// overlap so much that a ray tests many; their pieces' boxes are tighter. Returns the boxes and
/// the triangle each belongs to, a triangle's first box in its own place.
fn split_triangle_boxes(tris: &[obvhs::triangle::Triangle], mut boxes: Vec<Aabb>) -> (Vec<Aabb>, Vec<u32>) {
    let mut indices: Vec<u32> = (0..tris.len() as u32).collect();
    let (any_area, cut_when_smaller_by, rounds, positions) = (0.0, 1.2, 2, 12);
    obvhs::splits::split_aabbs_precise(
        &mut boxes,
        &mut indices,
        tris,
        any_area,
        any_area,
        cut_when_smaller_by,
        cut_when_smaller_by,
        rounds,
        positions,
    );
    (boxes, indices)
}

/// obvhs's PLOC build over `boxes`, each standing for triangle `indices[i]`, then its reinsertion
/// optimisation and leaf collapsing (what `build_bvh2_from_tris` does, for boxes of our own).
fn build_over_boxes(boxes: &[Aabb], indices: Vec<u32>, split: bool, params: BvhBuildParams) -> obvhs::bvh2::Bvh2 {
    let mut bvh2 = obvhs::ploc::PlocBuilder::with_capacity(boxes.len()).build(
        params.ploc_search_distance,
        boxes,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    bvh2.uses_spatial_splits = split;
    let mut reinsertion = obvhs::bvh2::reinsertion::ReinsertionOptimizer::default();
    reinsertion.run(&mut bvh2, params.reinsertion_batch_ratio, None);
    obvhs::bvh2::leaf_collapser::collapse(
        &mut bvh2,
        params.max_prims_per_leaf.clamp(1, 255),
        params.collapse_traversal_cost,
    );
    reinsertion.run(
        &mut bvh2,
        params.reinsertion_batch_ratio * params.post_collapse_reinsertion_batch_ratio_multiplier,
        None,
    );
    bvh2
}

fn flatten(bvh2: obvhs::bvh2::Bvh2) -> Bvh {
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
    Bvh { nodes, order: bvh2.primitive_indices, build_time: Duration::ZERO, sah_cost }
}

impl Bvh {
    /// Does a triangle of `triangles` (the ones the tree was built over) that `counts` have its
    /// bounding box, and the box of its piece in a leaf, within `radius` of `centre`? Boxes stand
    /// in for triangles, so a yes may be a near miss; a no is certain.
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

impl Bvh {
    /// The nearest triangle of `triangles` (the ones the tree was built over) along a ray from
    /// `origin` along `dir`, where `hit` gives the distance to a triangle it meets: that distance
    /// and the triangle's index. On the host, for the tests and `crate::lit_boxes`.
    pub fn closest_hit(
        &self,
        triangles: &[Triangle],
        origin: Vec3,
        dir: Vec3,
        hit: impl Fn(&Triangle) -> Option<f32>,
    ) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let Some(n) = self.nodes.get(i) else { continue };
            // Slab test, its exit widened as the kernels' (Ize 2013).
            let (mut t0, mut t1) = (0.0f32, best.map_or(f32::INFINITY, |(b, _)| b));
            for k in 0..3 {
                let (a, b) = ((n.min[k] - origin[k]) / dir[k], (n.max[k] - origin[k]) / dir[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            if t0 > t1 * 1.0000004 {
                continue;
            }
            if n.count == 0 {
                stack.extend([n.first as usize, n.first as usize + 1]);
                continue;
            }
            for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                if let Some(d) = triangles.get(t as usize).and_then(&hit)
                    && best.is_none_or(|(b, _)| d < b)
                {
                    best = Some((d, t));
                }
            }
        }
        best
    }
}

/// Half a node box's surface area (the SAH's measure of how often a ray enters it).
pub fn half_area(n: &BvhNode) -> f32 {
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
    use veach_scenes::SplitMix64;

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

    /// A dense field of grass blades (long thin triangles, leaning at random) in a 2 m square.
    fn grass(blades: usize) -> Vec<Triangle> {
        let mut rng = SplitMix64(1);
        let mut random = move || rng.next_f32();
        (0..blades)
            .map(|_| {
                let root = Vec3::new(2.0 * random(), 0.0, 2.0 * random());
                let a = std::f32::consts::TAU * random();
                let side = Vec3::new(a.cos(), 0.0, a.sin()) * 0.025;
                let tip = root + Vec3::new(0.3 * random() - 0.15, 0.3 + 0.3 * random(), 0.3 * random() - 0.15);
                Triangle { p: [root - side, root + side, tip], n: [Vec3::Y; 3], uv: Default::default(), material: 0 }
            })
            .collect()
    }

    /// The distance along a ray to its hit on `tri`, by Möller–Trumbore.
    fn hit(tri: &Triangle, origin: Vec3, dir: Vec3) -> Option<f32> {
        let (e1, e2) = (tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
        let p = dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = origin - tri.p[0];
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = dir.dot(q) / det;
        let t = e2.dot(q) / det;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
    }

    /// Where the tree over whole blades is poor, the blades' boxes are split (early split
    /// clipping): the tree keeps a blade in several leaves, each leaf's box around a part of
    /// it. Every ray must still find the closest blade that a test of all blades finds.
    #[test]
    fn split_blades_are_found_by_every_ray_that_hits_them() {
        let tris = grass(20_000);
        let bvh = build_bvh(&tris);
        assert!(bvh.order.len() > tris.len(), "the blades were not split (SAH cost {})", bvh.sah_cost);
        let mut seen = vec![false; tris.len()];
        for &t in &bvh.order {
            seen[t as usize] = true;
        }
        assert!(seen.iter().all(|&s| s), "a blade is in no leaf");
        let mut rng = SplitMix64(2);
        let mut random = move || rng.next_f32();
        let mut hits = 0;
        for _ in 0..2000 {
            // From above the field towards a point in it, and grazing through it.
            let origin = Vec3::new(4.0 * random() - 1.0, 0.2 + 1.5 * random(), 4.0 * random() - 1.0);
            let target = Vec3::new(2.0 * random(), 0.5 * random(), 2.0 * random());
            let dir = (target - origin).normalize();
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| hit(t, origin, dir).map(|d| (d, i as u32)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(
                bvh.closest_hit(&tris, origin, dir, |t| hit(t, origin, dir)),
                brute,
                "ray from {origin} along {dir}"
            );
            hits += brute.is_some() as u32;
        }
        assert!(hits > 1000, "only {hits} of 2000 rays hit a blade: the test checks little");
    }

    /// A tree over split boxes is kept only where the SAH says it pays: a plain grid is not split.
    #[test]
    fn well_shaped_meshes_are_not_split() {
        let tris = grid(100);
        assert_eq!(build_bvh(&tris).order.len(), tris.len());
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
        let blades = grass(20_000);
        let split = build_bvh(&blades);
        let again = build_bvh(&blades);
        assert_eq!((again.nodes, again.order), (split.nodes, split.order));
    }
}

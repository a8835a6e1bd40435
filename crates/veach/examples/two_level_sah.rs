//! The SAH cost of a two-level BVH (one tree per mesh in its own space, a tree over the placed
//! instances above them) against the flat tree `veach render` builds over every placed triangle,
//! for the instanced meshes of a glTF scene. Measures whether instancing would pay before it is
//! built: the same cost model as `bvh::sah_cost` (MacDonald & Booth 1990, unit node and triangle
//! tests), relative to the flat tree's root, plus one unit to move a ray into an instance's space.
//!
//!     cargo run --release -p veach --example two_level_sah -- target/zoo/instanced-rocks.gltf
//!
//! Only meshes placed more than once count; a ray that enters an instance's transformed box
//! reaches a node with probability proportional to the half area of the parallelepiped the
//! transform makes of the node's box (Cauchy: the mean projected area of a convex body is a
//! quarter of its surface area).

use glam::{Mat4, Vec3};
use std::collections::HashMap;
use veach::bvh::{BvhNode, build_bvh, half_area};
use veach::scene::Triangle;

fn triangle(p: [Vec3; 3]) -> Triangle {
    Triangle { p, n: [Vec3::Z; 3], uv: Default::default(), material: 0 }
}

/// Half the surface area of the parallelepiped `m` makes of the box.
fn placed_half_area(m: &Mat4, n: &BvhNode) -> f32 {
    let d = Vec3::from(n.max) - Vec3::from(n.min);
    let a = m.transform_vector3(Vec3::X * d.x);
    let b = m.transform_vector3(Vec3::Y * d.y);
    let c = m.transform_vector3(Vec3::Z * d.z);
    a.cross(b).length() + b.cross(c).length() + c.cross(a).length()
}

/// Σ over the nodes of (half area × tests there): one at an inner node, one per triangle (or
/// instance) at a leaf. `Bvh::sah_cost` is this over the root's half area.
fn absolute_cost(nodes: &[BvhNode], area: impl Fn(&BvhNode) -> f32) -> f32 {
    nodes.iter().map(|n| area(n) * if n.count > 0 { n.count as f32 } else { 1.0 }).sum()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: two_level_sah SCENE.gltf")?;
    let (doc, buffers, _) = gltf::import(&path)?;
    // Each mesh's triangles in its own space, and where it is placed (root nodes' transforms; the
    // zoo's scenes have no hierarchy).
    let mut meshes: HashMap<usize, Vec<[Vec3; 3]>> = HashMap::new();
    let mut placements: HashMap<usize, Vec<Mat4>> = HashMap::new();
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        placements.entry(mesh.index()).or_default().push(Mat4::from_cols_array_2d(&node.transform().matrix()));
        meshes.entry(mesh.index()).or_insert_with(|| {
            let mut tris = Vec::new();
            for prim in mesh.primitives() {
                let reader = prim.reader(|b| Some(&buffers[b.index()]));
                let Some(positions) = reader.read_positions() else { continue };
                let p: Vec<Vec3> = positions.map(Vec3::from).collect();
                let idx: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..p.len() as u32).collect(),
                };
                tris.extend(idx.chunks_exact(3).map(|t| [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]]));
            }
            tris
        });
    }
    placements.retain(|_, v| v.len() > 1);
    if placements.is_empty() {
        return Err(format!("{path}: no mesh is placed more than once").into());
    }
    // The flat tree over every placed triangle of the instanced meshes.
    let mut flat = Vec::new();
    for (mesh, ms) in &placements {
        for m in ms {
            flat.extend(meshes[mesh].iter().map(|t| triangle(t.map(|p| m.transform_point3(p)))));
        }
    }
    let flat_bvh = build_bvh(&flat);
    let root_area = half_area(&flat_bvh.nodes[0]);
    // Two levels: a tree per mesh, and one over the instances' world boxes (a triangle spanning a
    // box's corners has that box), each leaf item one unit to enter an instance.
    let mut bottom_cost = 0.0;
    let mut bottom_nodes = 0;
    let mut instance_boxes = Vec::new();
    for (mesh, ms) in &placements {
        let own: Vec<Triangle> = meshes[mesh].iter().map(|&p| triangle(p)).collect();
        let bvh = build_bvh(&own);
        bottom_nodes += bvh.nodes.len();
        let r = &bvh.nodes[0];
        for m in ms {
            bottom_cost += absolute_cost(&bvh.nodes, |n| placed_half_area(m, n));
            let corners = (0..8).map(|i| {
                let pick = |k: usize| if i >> k & 1 == 1 { r.max[k] } else { r.min[k] };
                m.transform_point3(Vec3::new(pick(0), pick(1), pick(2)))
            });
            let (lo, hi) = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
            instance_boxes.push(triangle([lo, hi, lo]));
        }
    }
    let top = build_bvh(&instance_boxes);
    let top_cost = top.sah_cost * half_area(&top.nodes[0]);
    let placed: usize = placements.values().map(Vec::len).sum();
    println!("{path}: {placed} instances of {} meshes, {} placed triangles", placements.len(), flat.len());
    println!("flat tree:       SAH cost {:.1} ({} nodes)", flat_bvh.sah_cost, flat_bvh.nodes.len());
    println!(
        "two levels:      SAH cost {:.1} (instances' tree {:.1}, meshes' trees {:.1}; {} + {} nodes)",
        (top_cost + bottom_cost) / root_area,
        top_cost / root_area,
        bottom_cost / root_area,
        top.nodes.len(),
        bottom_nodes,
    );
    Ok(())
}

//! Shadow rays towards a convex light skip the BVH subtrees that only its triangles fill (tagged
//! in the GPU nodes, `BvhNode::lights_01`, `lights_23`). A shadow ray from x to a
//! point y on a light whose triangle at y faces x cannot meet that light anywhere else when the
//! light's triangles bound a convex body (each lies in a plane with all of the light behind it):
//! the segment lies in front of y's plane, the light behind it. Traversal then need not descend
//! into the boxes around y, which it otherwise must, since they reach the shadow ray's end: on the
//! Veach scene (four spheres of 960 triangles each) the shadow rays took half the render time.

use crate::bvh::Bvh;

/// A light tag for each host node of `bvh`: 1 + the light whose triangles alone fill the node's
/// subtree where that light is `convex`, else 0. `triangle_light[t]` is the light of scene
/// triangle t, or `NO_LIGHT`. A light that shares leaves with other triangles is tagged in the
/// subtrees that it fills alone (on the Veach scene the two large spheres in 9-12 pieces each).
pub fn node_lights(bvh: &Bvh, triangle_light: &[u32], convex: &[bool]) -> Vec<u32> {
    // Per node: the one light all of its triangles belong to, or MIXED (several, or any unlit).
    const MIXED: u32 = u32::MAX;
    if bvh.order.is_empty() {
        // An empty scene: one leaf over a placeholder triangle.
        return vec![0; bvh.nodes.len()];
    }
    let lights = convex.len();
    let light_of = |position: u32| {
        let l = triangle_light[bvh.order[position as usize] as usize];
        if (l as usize) < lights { l } else { MIXED }
    };
    let nodes = &bvh.nodes;
    // Parents before children (depth first from the root), then swept in reverse, so that both
    // children of a node are done before it, whatever order the builder left the nodes in.
    let mut parents_first = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        parents_first.push(i);
        if nodes[i].count == 0 {
            stack.extend([nodes[i].first as usize, nodes[i].first as usize + 1]);
        }
    }
    let mut owner = vec![MIXED; nodes.len()];
    for &i in parents_first.iter().rev() {
        let n = &nodes[i];
        owner[i] = if n.count > 0 {
            let first = light_of(n.first);
            if (n.first..n.first + n.count).all(|p| light_of(p) == first) { first } else { MIXED }
        } else {
            let (a, b) = (owner[n.first as usize], owner[n.first as usize + 1]);
            if a == b { a } else { MIXED }
        };
    }
    owner.iter().map(|&o| if o != MIXED && convex[o as usize] { o + 1 } else { 0 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build_bvh;
    use crate::gpu::layout::NO_LIGHT;
    use crate::scene::Triangle;
    use glam::Vec3;
    use std::collections::HashSet;
    use veach_scenes::gltf_writer::MeshData;

    fn triangles(mesh: &MeshData) -> Vec<[Vec3; 3]> {
        mesh.indices.chunks(3).map(|i| [0, 1, 2].map(|k| mesh.positions[i[k] as usize])).collect()
    }

    fn scene_triangle(p: [Vec3; 3]) -> Triangle {
        Triangle { p, n: [Vec3::Z; 3], uv: Default::default(), material: 0 }
    }

    #[test]
    fn nodes_are_tagged_with_the_convex_light_that_alone_fills_them() {
        let mut tris = Vec::new();
        let mut light = Vec::new();
        for (l, x) in [(0u32, -5.0f32), (1, 5.0)] {
            for t in triangles(&MeshData::sphere(Vec3::new(x, 1.0, 0.0), 0.5, 16, 8)) {
                tris.push(scene_triangle(t));
                light.push(l);
            }
        }
        let floor = MeshData::quad(
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::Y,
        );
        for t in triangles(&floor) {
            tris.push(scene_triangle(t));
            light.push(NO_LIGHT);
        }
        let bvh = build_bvh(&tris);
        // The scene triangles under each node.
        let held = |root: usize| {
            let mut stack = vec![root];
            let mut held = Vec::new();
            while let Some(i) = stack.pop() {
                let n = bvh.nodes[i];
                if n.count > 0 {
                    held.extend((n.first..n.first + n.count).map(|p| bvh.order[p as usize]));
                } else {
                    stack.extend([n.first as usize, n.first as usize + 1]);
                }
            }
            held
        };
        let tags = node_lights(&bvh, &light, &[true, false]);
        let mut tagged = 0;
        for (i, &tag) in tags.iter().enumerate() {
            let lights_under: HashSet<u32> = held(i).iter().map(|&t| light[t as usize]).collect();
            if tag > 0 {
                assert_eq!(lights_under, HashSet::from([tag - 1]), "node {i}");
                assert_eq!(tag, 1, "light 1 is not convex here");
                tagged += 1;
            } else {
                assert!(lights_under != HashSet::from([0]), "node {i} holds only light 0 but is untagged");
            }
        }
        assert!(tagged > 0);
    }

    #[test]
    fn the_veach_scenes_spheres_are_convex_round_and_their_subtrees_tagged() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/veach-mis.gltf");
        let scene = crate::load_gltf(&path).unwrap();
        let bvh = build_bvh(&scene.triangles);
        let features = crate::features::SceneFeatures::detect(&scene);
        assert!(features.round_lights);
        let arrays = crate::gpu::scene_buffers::build_scene_arrays(&scene, &features, &bvh);
        assert_eq!(arrays.lights.len(), 4);
        for (l, light) in arrays.lights.iter().enumerate() {
            assert_eq!(light.convex, 1, "light {l}");
            assert_eq!(light.round, 1, "light {l} is a sphere: sampled by its cone");
            let tags =
                arrays.bvh_nodes.iter().flat_map(|n| [n.lights_01, n.lights_23]).flat_map(|w| [w & 0xffff, w >> 16]);
            assert!(tags.filter(|&t| t == l as u32 + 1).count() > 0, "no subtree tagged with light {l}");
        }
    }
}

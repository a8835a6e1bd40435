//! The BVH as the kernels read it: its inner nodes, each holding its two children's boxes and
//! references, so that a traversal step loads one 64-byte node (14 words) instead of the node
//! and both children (24 words of three 32-byte nodes). `shaders/traverse_bvh.wgsl` reads it.

use crate::bvh::BvhNode as HostNode;
use crate::gpu::layout::BvhNode;

/// A child reference (`BvhNode::left`, `right`): an inner node's index, or a leaf with this bit,
/// its triangle count in bits 27-30 and its first triangle in bits 0-26.
pub const LEAF_BIT: u32 = 1 << 31;
pub const MAX_LEAF_TRIANGLES: u32 = 15;
pub const MAX_FIRST_TRIANGLE: u32 = (1 << 27) - 1;

/// The GPU nodes of a BVH: its inner nodes, in the same order, root first, each with its two
/// children's boxes and references, and the children's light tags (`node_lights`, one per host
/// node: 1 + the convex light that alone fills it, or 0; `gpu::light_subtrees`). A tree that is
/// a single leaf gets a root over that leaf and an empty one.
pub fn encode_bvh_nodes(nodes: &[HostNode], node_lights: &[u32]) -> Vec<BvhNode> {
    assert_eq!(nodes.len(), node_lights.len(), "a light tag for every node");
    if let [leaf] = nodes {
        // The empty leaf (count 0 in its reference) shares the leaf's box: it costs a box test.
        return vec![encode_inner(leaf, leaf, leaf_reference(leaf), LEAF_BIT)];
    }
    // Host index -> GPU index of every inner node.
    let mut inner_index = vec![u32::MAX; nodes.len()];
    let mut inner = 0;
    for (i, n) in nodes.iter().enumerate() {
        if n.count == 0 {
            inner_index[i] = inner;
            inner += 1;
        }
    }
    let reference = |i: u32| {
        let n = &nodes[i as usize];
        if n.count == 0 {
            return inner_index[i as usize];
        }
        leaf_reference(n)
    };
    nodes
        .iter()
        .filter(|n| n.count == 0)
        .map(|n| {
            let (left, right) = (&nodes[n.first as usize], &nodes[n.first as usize + 1]);
            BvhNode {
                left_light: node_lights[n.first as usize],
                right_light: node_lights[n.first as usize + 1],
                ..encode_inner(left, right, reference(n.first), reference(n.first + 1))
            }
        })
        .collect()
}

fn leaf_reference(leaf: &HostNode) -> u32 {
    // obvhs makes leaves of at most 8 triangles; `Renderer::upload_scene` refuses scenes of more
    // than MAX_FIRST_TRIANGLE + 1 triangles.
    assert!(
        leaf.count <= MAX_LEAF_TRIANGLES && leaf.first <= MAX_FIRST_TRIANGLE,
        "leaf {leaf:?} does not fit a reference"
    );
    LEAF_BIT | leaf.count << 27 | leaf.first
}

fn encode_inner(left: &HostNode, right: &HostNode, left_ref: u32, right_ref: u32) -> BvhNode {
    BvhNode {
        left_min: left.min,
        left: left_ref,
        left_max: left.max,
        right: right_ref,
        right_min: right.min,
        right_max: right.max,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build_bvh;
    use crate::scene::Triangle;
    use glam::Vec3;

    #[test]
    fn every_inner_node_holds_its_childrens_boxes_and_references() {
        let tris: Vec<Triangle> = (0..2000)
            .map(|i| {
                let o = Vec3::new((i as f32 * 7.31).sin(), (i as f32 * 3.17).cos(), (i as f32 * 1.13).sin()) * 10.0;
                let p = [o, o + Vec3::X * 0.1, o + Vec3::Y * 0.1];
                Triangle { p, n: [Vec3::Z; 3], uv: Default::default(), material: 0 }
            })
            .collect();
        let bvh = build_bvh(&tris);
        let lights: Vec<u32> = (0..bvh.nodes.len() as u32).map(|i| i % 3).collect();
        let gpu = encode_bvh_nodes(&bvh.nodes, &lights);
        let inner: Vec<&HostNode> = bvh.nodes.iter().filter(|n| n.count == 0).collect();
        assert_eq!(gpu.len(), inner.len());
        assert_eq!(gpu.len(), bvh.gpu_nodes());
        assert!(std::ptr::eq(inner[0], &bvh.nodes[0]), "the root comes first");
        for (n, g) in inner.iter().zip(&gpu) {
            let children = [&bvh.nodes[n.first as usize], &bvh.nodes[n.first as usize + 1]];
            assert_eq!([g.left_light, g.right_light], [lights[n.first as usize], lights[n.first as usize + 1]]);
            let boxes = [(g.left_min, g.left_max), (g.right_min, g.right_max)];
            for ((child, (min, max)), reference) in children.into_iter().zip(boxes).zip([g.left, g.right]) {
                assert_eq!((min, max), (child.min, child.max));
                if child.count > 0 {
                    assert_eq!(reference, LEAF_BIT | child.count << 27 | child.first);
                } else {
                    assert!(std::ptr::eq(inner[reference as usize], child), "reference {reference} names another node");
                }
            }
        }
    }

    #[test]
    fn a_single_leaf_gets_a_root_over_it_and_an_empty_leaf() {
        let leaf = HostNode { min: [0.0; 3], first: 0, max: [1.0; 3], count: 3 };
        let gpu = encode_bvh_nodes(&[leaf], &[0]);
        assert_eq!(gpu.len(), 1);
        assert_eq!((gpu[0].left, gpu[0].right), (LEAF_BIT | 3 << 27, LEAF_BIT));
        assert_eq!((gpu[0].left_min, gpu[0].left_max), ([0.0; 3], [1.0; 3]));
    }
}

//! The BVH as the kernels read it: its inner nodes, each holding its two children's boxes and
//! references, so that a traversal step loads one node instead of the node and both children.
//! The boxes are quantised to 8-bit cells of a per-node grid (Ylitie, Karras & Laine 2017, §3.1):
//! a node is 48 bytes, of which a closest-hit step loads 9 words where unquantised boxes took 14.
//! `shaders/traverse_bvh.wgsl` reads it.

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
    let mut node = BvhNode { left: left_ref, right: right_ref, ..Default::default() };
    for k in 0..3 {
        let bounds = [left.min[k], right.min[k], left.max[k], right.max[k]];
        match axis_grid(bounds) {
            Some(grid) => {
                node.origin[k] = grid.origin;
                node.exponents |= grid.biased_exponent << (8 * k);
                node.bounds[k] = u32::from_le_bytes(grid.cells.map(|c| c as u8));
            }
            None => {
                node.origin[k] = bounds[0].min(bounds[1]);
                node.exponents |= UNBOUNDED_AXIS << k;
            }
        }
    }
    node
}

/// One axis's grid for bounds [left low, right low, left high, right high]: its origin, the
/// cell size's biased exponent and the four cells, or None where no grid spans them. Of the grids
/// anchored at the lowest bound or at one that makes a flat child's plane exact (walls, a light
/// just below a ceiling: a box rounded outwards would give them a thickness that rays ending just
/// short of them enter), the one with the least slack, flat children's counted twice.
fn axis_grid(bounds: [f32; 4]) -> Option<AxisGrid> {
    let low = bounds[0].min(bounds[1]);
    let top = bounds[2].max(bounds[3]);
    let flat = [bounds[0] == bounds[2], bounds[1] == bounds[3]];
    let mut best: Option<(f64, AxisGrid)> = None;
    let first = cell_exponent(low, top)?;
    let anchors = [Some(low), flat[0].then_some(bounds[0]), flat[1].then_some(bounds[1])];
    for anchor in anchors.into_iter().flatten() {
        // The finest cells that fit from this anchor: the lowest bound's always fit `first`; a
        // flat child's origin may lie up to a cell lower and need cells twice the size.
        for biased in [first, first + 1] {
            if biased as i32 - 127 > MAX_CELL_EXPONENT {
                break;
            }
            let cell = f32::from_bits(biased << 23);
            let Some(origin) = anchored_origin(low, anchor, cell) else { continue };
            let cells = [
                low_cell(origin, cell, bounds[0]),
                low_cell(origin, cell, bounds[1]),
                high_cell(origin, cell, bounds[2]),
                high_cell(origin, cell, bounds[3]),
            ];
            if cells.iter().any(|&c| c > 255) {
                continue;
            }
            let slack = |i: usize| (grid_bound(origin, cell, cells[i]) as f64 - bounds[i] as f64).abs();
            let weight = |child: usize| if flat[child] { 2.0 } else { 1.0 };
            let total = weight(0) * (slack(0) + slack(2)) + weight(1) * (slack(1) + slack(3));
            if best.as_ref().is_none_or(|(b, _)| total < *b) {
                best = Some((total, AxisGrid { origin, biased_exponent: biased, cells }));
            }
            break;
        }
    }
    best.map(|(_, grid)| grid)
}

/// One axis of a node's grid: bound q lies at origin + q · 2^(biased_exponent - 127).
struct AxisGrid {
    origin: f32,
    biased_exponent: u32,
    cells: [u32; 4],
}

/// A grid origin at or below `low` from which `anchor` lies a whole number of cells away, exactly
/// as the kernel computes it; None where rounding allows no such origin.
fn anchored_origin(low: f32, anchor: f32, cell: f32) -> Option<f32> {
    let steps = ((anchor as f64 - low as f64) / cell as f64).ceil();
    if !(0.0..=255.0).contains(&steps) {
        return None;
    }
    let origin = (anchor as f64 - steps * cell as f64) as f32;
    let exact = origin <= low && grid_bound(origin, cell, steps as u32) == anchor;
    exact.then_some(origin)
}

/// Bit 24 + k of `BvhNode::exponents`: axis k spans more than 255 cells of the largest size.
const UNBOUNDED_AXIS: u32 = 1 << 24;

/// The largest cell size: 255 cells of 2^120 stay below f32::MAX, so q · 2^e is exact for every
/// cell q, and origin + q · 2^e rounds the same whether the kernel fuses the multiply-add or not.
const MAX_CELL_EXPONENT: i32 = 120;

/// A grid bound as the kernel computes it.
fn grid_bound(origin: f32, cell: f32, q: u32) -> f32 {
    origin + q as f32 * cell
}

/// The largest cell whose bound lies at or below `low` (origin <= low, so cell 0 does).
fn low_cell(origin: f32, cell: f32, low: f32) -> u32 {
    let mut q = (((low as f64 - origin as f64) / cell as f64).floor().clamp(0.0, 255.0)) as u32;
    while q > 0 && grid_bound(origin, cell, q) > low {
        q -= 1;
    }
    while q < 255 && grid_bound(origin, cell, q + 1) <= low {
        q += 1;
    }
    q
}

/// The smallest cell whose bound lies at or above `high`, or 256 where none of 0..=255 does.
fn high_cell(origin: f32, cell: f32, high: f32) -> u32 {
    let mut q = (((high as f64 - origin as f64) / cell as f64).ceil().clamp(0.0, 256.0)) as u32;
    while q <= 255 && grid_bound(origin, cell, q) < high {
        q += 1;
    }
    while q > 0 && grid_bound(origin, cell, q - 1) >= high {
        q -= 1;
    }
    q
}

/// The biased f32 exponent of the smallest power-of-two cell whose 255 cells from `origin` reach
/// `top`, or None past `MAX_CELL_EXPONENT`.
fn cell_exponent(origin: f32, top: f32) -> Option<u32> {
    let span = top as f64 - origin as f64;
    let mut e = if span > 0.0 { (span / 255.0).log2().ceil() as i32 } else { -126 };
    e = e.clamp(-126, MAX_CELL_EXPONENT + 1);
    while e <= MAX_CELL_EXPONENT {
        let biased = (e + 127) as u32;
        if high_cell(origin, f32::from_bits(biased << 23), top) <= 255 {
            return Some(biased);
        }
        e += 1;
    }
    None
}

/// The children's boxes as the kernel decodes them (`child_boxes` in traverse_bvh.wgsl), for
/// tests: (left min, left max, right min, right max).
#[cfg(test)]
fn decode_child_boxes(node: &BvhNode) -> [[f32; 3]; 4] {
    let mut boxes = [[0.0f32; 3]; 4];
    #[allow(clippy::needless_range_loop)] // k indexes four arrays and shifts by axis
    for k in 0..3 {
        let cell = f32::from_bits(((node.exponents >> (8 * k)) & 0xff) << 23);
        let [left_low, right_low, left_high, right_high] = node.bounds[k].to_le_bytes();
        let unbounded = node.exponents & (UNBOUNDED_AXIS << k) != 0;
        let bound =
            |q: u8, sign: f32| if unbounded { sign * f32::MAX } else { grid_bound(node.origin[k], cell, q as u32) };
        boxes[0][k] = bound(left_low, -1.0);
        boxes[1][k] = bound(left_high, 1.0);
        boxes[2][k] = bound(right_low, -1.0);
        boxes[3][k] = bound(right_high, 1.0);
    }
    boxes
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
            let [left_min, left_max, right_min, right_max] = decode_child_boxes(g);
            let boxes = [(left_min, left_max), (right_min, right_max)];
            for ((child, (min, max)), reference) in children.into_iter().zip(boxes).zip([g.left, g.right]) {
                assert_box_holds(min, max, child, n);
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
        let [left_min, left_max, ..] = decode_child_boxes(&gpu[0]);
        assert_eq!((left_min, left_max), ([0.0; 3], [1.0; 3]), "a box on the grid's cells is exact");
    }

    /// A decoded child box holds the child's box, and is not much larger: at most four of the
    /// smallest cells that span the parent (1/255 of its extent, rounded up to a power of two)
    /// each side (`axis_grid` may take cells twice that size, and an origin a cell lower).
    fn assert_box_holds(min: [f32; 3], max: [f32; 3], child: &HostNode, parent: &HostNode) {
        for k in 0..3 {
            assert!(min[k] <= child.min[k] && max[k] >= child.max[k], "axis {k}: {min:?}..{max:?} misses {child:?}");
            let extent = (parent.max[k] as f64 - parent.min[k] as f64).max(f32::MIN_POSITIVE as f64);
            // Cells are no smaller than f32's least normal, 2^-126.
            let cell = 2f64.powf((extent / 255.0).log2().ceil()).max(f32::MIN_POSITIVE as f64);
            let magnitude = parent.max[k].abs().max(parent.min[k].abs()) as f64;
            let slack = 4.0 * cell + 4.0 * f32::EPSILON as f64 * magnitude;
            assert!(
                child.min[k] as f64 - min[k] as f64 <= slack && max[k] as f64 - child.max[k] as f64 <= slack,
                "axis {k}: {min:?}..{max:?} is loose around {child:?} (slack {slack})"
            );
        }
    }

    #[test]
    fn a_flat_childs_plane_is_exact() {
        // The Cornell box's light, 5 mm below its ceiling, beside the room: on y the light's plane
        // is kept exact (rounded outwards it would be a slab that shadow rays ending short of the
        // light enter), on x and z its box holds it.
        let light = HostNode { min: [2.13, 5.483, 2.27], first: 0, max: [3.43, 5.483, 3.32], count: 2 };
        let room = HostNode { min: [0.0, 0.0, 0.0], first: 2, max: [5.56, 5.488, 5.592], count: 4 };
        for (left, right) in [(&light, &room), (&room, &light)] {
            let node = encode_inner(left, right, 0, 0);
            let [lmin, lmax, rmin, rmax] = decode_child_boxes(&node);
            let (min, max) = if std::ptr::eq(left, &light) { (lmin, lmax) } else { (rmin, rmax) };
            assert_eq!((min[1], max[1]), (5.483, 5.483), "the light's plane");
            assert!(min[0] <= 2.13 && max[0] >= 3.43 && min[2] <= 2.27 && max[2] >= 3.32);
        }
    }

    #[test]
    fn quantised_boxes_hold_their_children_at_any_scale() {
        // Boxes near zero, subnormal, at 1e5 with a tiny extent, flat, and spanning f32's range.
        type Boxes = ([f32; 3], [f32; 3], [f32; 3], [f32; 3]);
        let cases: [Boxes; 5] = [
            ([0.0, -1.0, 2.0], [0.3, 0.5, 2.5], [0.1, -0.25, 2.0], [1.0, 1.0, 3.0]),
            ([1.0e-45, -1.0e-40, 0.0], [2.0e-45, 1.0e-40, 1.0e-38], [-1.0e-44, 0.0, 0.0], [0.0, 3.0e-40, 1.0e-38]),
            (
                [1.0e5, 1.0e5, -1.0e5],
                [100000.01, 100000.02, -99999.99],
                [100_000.01, 1.0e5, -1.0e5],
                [100000.01, 100000.03, -99999.98],
            ),
            ([0.0, 1.0, 0.0], [1.0, 1.0, 1.0], [0.5, 1.0, 0.25], [2.0, 1.0, 0.75]),
            ([-f32::MAX, 0.0, -3.0e38], [f32::MAX, 1.0, 0.0], [-1.0, -f32::MAX, 1.0e38], [1.0, f32::MAX, 3.0e38]),
        ];
        for (lmin, lmax, rmin, rmax) in cases {
            let left = HostNode { min: lmin, first: 0, max: lmax, count: 1 };
            let right = HostNode { min: rmin, first: 1, max: rmax, count: 1 };
            let parent = HostNode {
                min: std::array::from_fn(|k| lmin[k].min(rmin[k])),
                first: 1,
                max: std::array::from_fn(|k| lmax[k].max(rmax[k])),
                count: 0,
            };
            let node = encode_inner(&left, &right, 0, 0);
            let [a, b, c, d] = decode_child_boxes(&node);
            for (min, max, child) in [(a, b, &left), (c, d, &right)] {
                for k in 0..3 {
                    assert!(
                        min[k] <= child.min[k] && max[k] >= child.max[k],
                        "axis {k}: {min:?}..{max:?} misses {child:?}"
                    );
                }
            }
            if parent.max.iter().chain(&parent.min).all(|x| x.abs() < 1.0e38) {
                assert_box_holds(a, b, &left, &parent);
                assert_box_holds(c, d, &right, &parent);
            }
        }
    }
}

//! The BVH as the kernels read it: a 4-wide tree collapsed from the built BVH2 (each wide node
//! takes up to four of the BVH2's nodes below it as children, Wald et al. 2008's "getting rid
//! of packets": half the depth), each node holding its children's boxes and references, so that
//! a traversal step loads one node. The boxes are quantised to 8-bit cells of a per-node grid
//! (Ylitie, Karras & Laine 2017, §3.1): a node is 64 bytes. `shaders/traverse_bvh.wgsl` reads it.

use crate::bvh::{Bvh, BvhNode as HostNode, half_area};
use crate::gpu::layout::BvhNode;

/// A child reference (`BvhNode::children`): an inner node's index, or a leaf with this bit,
/// its triangle count in bits 27-30 and its first triangle in bits 0-26.
pub const LEAF_BIT: u32 = 1 << 31;
pub const MAX_LEAF_TRIANGLES: u32 = 15;
pub const MAX_FIRST_TRIANGLE: u32 = (1 << 27) - 1;
/// An empty child slot: no leaf has this reference, since its triangles would end past
/// MAX_FIRST_TRIANGLE + 1.
pub const NO_CHILD: u32 = u32::MAX;
/// Children per node.
pub const WIDTH: usize = 4;
/// The kernels' traversal stack (`BVH_STACK_SIZE` in traverse_bvh.wgsl) where a tree's worst case
/// fits it (a million-triangle sphere's needs 74); kernels for deeper trees get a larger one
/// (`stack_size_for`).
pub const BVH_STACK_SIZE: u32 = 96;
/// Light tags are 16 bits (`BvhNode::lights`); lights past this are never skipped.
const MAX_LIGHT_TAG: u32 = 0xffff;

/// The BVH2 nodes (indices into `nodes`) that become the children of one wide node.
#[derive(Clone, Copy, Debug)]
struct WideChildren {
    slots: [usize; WIDTH],
    len: usize,
}

impl WideChildren {
    fn as_slice(&self) -> &[usize] {
        &self.slots[..self.len]
    }
}

/// The children of the wide node over inner node `parent`: its two children, then, while there
/// are fewer than four, the inner child of largest surface area (the one a ray most likely
/// enters) replaced by its two children.
fn wide_children(nodes: &[HostNode], parent: &HostNode) -> WideChildren {
    let first = parent.first as usize;
    let mut children = WideChildren { slots: [first, first + 1, 0, 0], len: 2 };
    while children.len < WIDTH {
        let largest = (0..children.len)
            .filter(|&slot| nodes[children.slots[slot]].count == 0)
            .max_by(|&a, &b| half_area(&nodes[children.slots[a]]).total_cmp(&half_area(&nodes[children.slots[b]])));
        let Some(slot) = largest else { break };
        let first = nodes[children.slots[slot]].first as usize;
        // Its two children take its slot and the next; the slots after it move up one.
        children.slots.copy_within(slot + 1..children.len, slot + 2);
        children.slots[slot] = first;
        children.slots[slot + 1] = first + 1;
        children.len += 1;
    }
    children
}

/// The BVH2 node under each wide node, in the kernels' order (breadth first, the root first),
/// and each one's children.
fn collapse(nodes: &[HostNode]) -> Vec<(usize, WideChildren)> {
    if nodes.len() == 1 {
        return vec![(0, WideChildren { slots: [0; WIDTH], len: 1 })];
    }
    let mut wide = vec![(0, wide_children(nodes, &nodes[0]))];
    let mut i = 0;
    while i < wide.len() {
        let children = wide[i].1;
        for &c in children.as_slice().iter().filter(|&&c| nodes[c].count == 0) {
            wide.push((c, wide_children(nodes, &nodes[c])));
        }
        i += 1;
    }
    wide
}

/// Nodes the kernels read for `bvh`: the wide nodes collapsed from it, each holding its children's
/// boxes.
pub fn gpu_node_count(bvh: &Bvh) -> usize {
    wide_node_count(&bvh.nodes)
}

/// How many nodes the kernels read for this BVH2 (`encode_bvh_nodes`'s length): one for each
/// inner node that no wide node opens, that is the root and every inner child of a wide node.
pub fn wide_node_count(nodes: &[HostNode]) -> usize {
    if nodes.len() == 1 {
        return 1;
    }
    let mut count = 0;
    let mut todo = vec![0];
    while let Some(n) = todo.pop() {
        count += 1;
        todo.extend(wide_children(nodes, &nodes[n]).as_slice().iter().filter(|&&c| nodes[c].count == 0));
    }
    count
}

/// The GPU nodes of a BVH2: wide nodes, the root first, each with up to four children's boxes,
/// references and light tags (`node_lights`, one per host node: 1 + the convex light that alone
/// fills it, or 0; `gpu::light_subtrees`). A tree that is a single leaf gets a root over it.
pub fn encode_bvh_nodes(nodes: &[HostNode], node_lights: &[u32]) -> Vec<BvhNode> {
    assert_eq!(nodes.len(), node_lights.len(), "a light tag for every node");
    let wide = collapse(nodes);
    // Host index -> GPU index of every host node that heads a wide node.
    let mut wide_index = vec![u32::MAX; nodes.len()];
    for (i, (host, _)) in wide.iter().enumerate() {
        wide_index[*host] = i as u32;
    }
    wide.iter()
        .map(|(_, children)| {
            let children = children.as_slice();
            let boxes: Vec<&HostNode> = children.iter().map(|&c| &nodes[c]).collect();
            let references: Vec<u32> = children
                .iter()
                .map(|&c| if nodes[c].count == 0 { wide_index[c] } else { leaf_reference(&nodes[c]) })
                .collect();
            let lights: Vec<u32> =
                children.iter().map(|&c| if node_lights[c] <= MAX_LIGHT_TAG { node_lights[c] } else { 0 }).collect();
            encode_wide(&boxes, &references, &lights)
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

/// A wide node over `children` (one to four), with their references and light tags; the other
/// slots empty (`NO_CHILD`, cells 0).
fn encode_wide(children: &[&HostNode], references: &[u32], lights: &[u32]) -> BvhNode {
    let mut node = BvhNode { children: [NO_CHILD; WIDTH], ..Default::default() };
    node.children[..children.len()].copy_from_slice(references);
    let mut tags = [0u32; WIDTH];
    tags[..lights.len()].copy_from_slice(lights);
    node.lights_01 = tags[0] | tags[1] << 16;
    node.lights_23 = tags[2] | tags[3] << 16;
    for k in 0..3 {
        let lows: Vec<f32> = children.iter().map(|c| c.min[k]).collect();
        let highs: Vec<f32> = children.iter().map(|c| c.max[k]).collect();
        match axis_grid(&lows, &highs) {
            Some(grid) => {
                node.origin[k] = grid.origin;
                node.exponents |= grid.biased_exponent << (8 * k);
                let pack = |cells: &[u32]| cells.iter().enumerate().map(|(i, &c)| c << (8 * i)).sum::<u32>();
                node.low[k] = pack(&grid.low);
                node.high[k] = pack(&grid.high);
            }
            None => {
                node.origin[k] = lows.iter().copied().fold(f32::INFINITY, f32::min);
                node.exponents |= UNBOUNDED_AXIS << k;
            }
        }
    }
    node
}

/// One axis's grid for the children's bounds: its origin, the cell size's biased exponent and
/// each child's low and high cells, or None where no grid spans them. Of the grids anchored at the
/// lowest bound or at one that makes a flat child's plane exact (walls, a light just below a
/// ceiling: a box rounded outwards would give them a thickness that rays ending just short of them
/// enter), the one with the least slack, flat children's counted twice.
fn axis_grid(lows: &[f32], highs: &[f32]) -> Option<AxisGrid> {
    let low = lows.iter().copied().fold(f32::INFINITY, f32::min);
    let top = highs.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let flat: Vec<bool> = lows.iter().zip(highs).map(|(l, h)| l == h).collect();
    let mut best: Option<(f64, AxisGrid)> = None;
    let first = cell_exponent(low, top)?;
    let anchors = std::iter::once(low).chain(lows.iter().zip(&flat).filter(|&(_, &f)| f).map(|(&l, _)| l));
    for anchor in anchors {
        // The finest cells that fit from this anchor: the lowest bound's always fit `first`; a
        // flat child's origin may lie up to a cell lower and need cells twice the size.
        for biased in [first, first + 1] {
            if biased as i32 - 127 > MAX_CELL_EXPONENT {
                break;
            }
            let cell = f32::from_bits(biased << 23);
            let Some(origin) = anchored_origin(low, anchor, cell) else { continue };
            let mut grid = AxisGrid { origin, biased_exponent: biased, low: [0; WIDTH], high: [0; WIDTH] };
            for (i, (&l, &h)) in lows.iter().zip(highs).enumerate() {
                grid.low[i] = low_cell(origin, cell, l);
                grid.high[i] = high_cell(origin, cell, h);
            }
            if grid.high.iter().any(|&c| c > 255) {
                continue;
            }
            let slack = |q: u32, bound: f32| (grid_bound(origin, cell, q) as f64 - bound as f64).abs();
            let total: f64 = (0..lows.len())
                .map(|i| {
                    let weight = if flat[i] { 2.0 } else { 1.0 };
                    weight * (slack(grid.low[i], lows[i]) + slack(grid.high[i], highs[i]))
                })
                .sum();
            if best.as_ref().is_none_or(|(b, _)| total < *b) {
                best = Some((total, grid));
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
    low: [u32; WIDTH],
    high: [u32; WIDTH],
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

/// The children's boxes as the kernel decodes them (`child_distances` in traverse_bvh.wgsl), for
/// tests: (min, max) of each slot.
#[cfg(test)]
fn decode_child_boxes(node: &BvhNode) -> [([f32; 3], [f32; 3]); WIDTH] {
    let mut boxes = [([0.0f32; 3], [0.0f32; 3]); WIDTH];
    for k in 0..3 {
        let cell = f32::from_bits(((node.exponents >> (8 * k)) & 0xff) << 23);
        let unbounded = node.exponents & (UNBOUNDED_AXIS << k) != 0;
        let bound =
            |q: u8, sign: f32| if unbounded { sign * f32::MAX } else { grid_bound(node.origin[k], cell, q as u32) };
        let (low, high) = (node.low[k].to_le_bytes(), node.high[k].to_le_bytes());
        for (i, b) in boxes.iter_mut().enumerate() {
            b.0[k] = bound(low[i], -1.0);
            b.1[k] = bound(high[i], 1.0);
        }
    }
    boxes
}

/// The most entries the kernels' traversal stack can hold on this tree: at each node it descends
/// into one child and pushes at most the others, so a leaf's bound is the sum over its ancestors
/// of their children less one. The kernel's stack must not be smaller: a push past its end is
/// dropped, and with it the subtree.
pub fn stack_bound(nodes: &[BvhNode]) -> u32 {
    let mut deepest = 0;
    let mut todo = vec![(0u32, 0u32)];
    while let Some((node, pushed)) = todo.pop() {
        let children: Vec<u32> = nodes[node as usize].children.into_iter().filter(|&c| c != NO_CHILD).collect();
        let depth = pushed + children.len() as u32 - 1;
        deepest = deepest.max(depth);
        todo.extend(children.into_iter().filter(|&c| c & LEAF_BIT == 0).map(|c| (c, depth)));
    }
    deepest
}

/// The traversal stack a kernel needs for a tree of this `stack_bound`: `BVH_STACK_SIZE`, or for
/// deeper trees (geometry nested over many scales) the bound rounded up to a multiple of 32, so
/// that trees of similar depth share a kernel.
pub fn stack_size_for(bound: u32) -> u32 {
    if bound <= BVH_STACK_SIZE { BVH_STACK_SIZE } else { bound.next_multiple_of(32) }
}

/// Slot i's light tag.
#[cfg(test)]
fn light_tag(node: &BvhNode, i: usize) -> u32 {
    [node.lights_01, node.lights_23][i / 2] >> (16 * (i % 2)) & 0xffff
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build_bvh;
    use crate::scene::Triangle;
    use glam::Vec3;

    #[test]
    fn every_wide_node_holds_its_childrens_boxes_references_and_tags() {
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
        assert_eq!(gpu.len(), gpu_node_count(&bvh));
        // Walk the wide tree from the root: every BVH2 leaf is reached exactly once, through a
        // box that holds it, and every wide node exactly once.
        let mut leaves_seen = vec![0u32; bvh.nodes.len()];
        let mut nodes_seen = vec![0u32; gpu.len()];
        let mut stack = vec![(0u32, 0usize)]; // (GPU node, host node it stands for)
        let mut slots_used = 0;
        while let Some((g, host)) = stack.pop() {
            nodes_seen[g as usize] += 1;
            let node = &gpu[g as usize];
            let parent = &bvh.nodes[host];
            let children = wide_children(&bvh.nodes, parent);
            let children = children.as_slice();
            assert!((2..=WIDTH).contains(&children.len()));
            slots_used += children.len();
            let boxes = decode_child_boxes(node);
            for (i, &reference) in node.children.iter().enumerate() {
                let Some(&c) = children.get(i) else {
                    assert_eq!(reference, NO_CHILD, "slot {i} of node {g}");
                    continue;
                };
                let child = &bvh.nodes[c];
                assert_box_holds(boxes[i].0, boxes[i].1, child, parent);
                assert_eq!(light_tag(node, i), lights[c], "slot {i} of node {g}");
                if child.count > 0 {
                    assert_eq!(reference, LEAF_BIT | child.count << 27 | child.first);
                    leaves_seen[c] += 1;
                } else {
                    stack.push((reference, c));
                }
            }
        }
        assert!(nodes_seen.iter().all(|&n| n == 1), "a wide node unreached or reached twice");
        for (n, seen) in bvh.nodes.iter().zip(&leaves_seen) {
            assert_eq!(*seen, (n.count > 0) as u32, "{n:?}");
        }
        // Four-wide in the main: at least 3 children a node on average.
        assert!(slots_used as f64 >= 3.0 * gpu.len() as f64, "{slots_used} slots over {} nodes", gpu.len());
    }

    #[test]
    fn the_traversal_stack_holds_a_million_triangle_trees_worst_case() {
        // `veach scale`'s largest scene: a sphere of a million triangles (the Cornell box around it
        // adds a few nodes near the root).
        let stacks = 500;
        let m = veach_scenes::gltf_writer::MeshData::sphere(Vec3::new(1.8, 3.6, 2.0), 0.8, 2 * stacks, stacks);
        let tris: Vec<Triangle> = m
            .indices
            .chunks(3)
            .map(|c| Triangle {
                p: [0, 1, 2].map(|k| m.positions[c[k] as usize]),
                n: [Vec3::Z; 3],
                uv: Default::default(),
                material: 0,
            })
            .collect();
        let bvh = build_bvh(&tris);
        let bound = stack_bound(&encode_bvh_nodes(&bvh.nodes, &vec![0; bvh.nodes.len()]));
        // 74 measured: 10 to spare for the box's nodes above the sphere and other builds. Deeper
        // trees render too, with a kernel of a larger stack; this keeps common scenes on one kernel.
        assert!(
            bound + 10 <= BVH_STACK_SIZE,
            "{} triangles may need {bound} stack entries of {BVH_STACK_SIZE}",
            tris.len()
        );
    }

    #[test]
    fn a_single_leaf_gets_a_root_over_it() {
        let leaf = HostNode { min: [0.0; 3], first: 0, max: [1.0; 3], count: 3 };
        let gpu = encode_bvh_nodes(&[leaf], &[0]);
        assert_eq!(gpu.len(), 1);
        assert_eq!(gpu[0].children, [LEAF_BIT | 3 << 27, NO_CHILD, NO_CHILD, NO_CHILD]);
        assert_eq!(decode_child_boxes(&gpu[0])[0], ([0.0; 3], [1.0; 3]), "a box on the grid's cells is exact");
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
        for (children, slot) in [([&light, &room], 0), ([&room, &light], 1)] {
            let node = encode_wide(&children, &[0, 0], &[0, 0]);
            let (min, max) = decode_child_boxes(&node)[slot];
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
            let node = encode_wide(&[&left, &right], &[0, 0], &[0, 0]);
            let [(a, b), (c, d), ..] = decode_child_boxes(&node);
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

//! The light tree: a binary tree over the lights' bounds (box, power, and the cone of directions
//! they emit into), by which a shading point chooses a light in proportion to an estimate of what
//! each subtree sends it (Conty Estevez & Kulla, "Importance Sampling of Many Lights with
//! Adaptive Tree Splitting", HPG 2018; pbrt-v4's `BVHLightSampler`, §12.6.3). The host builds the
//! tree here; `shaders/light_tree.wgsl` walks it, and `LightBounds::importance` is the same
//! estimate in Rust, for the tests.
//!
//! Directional lights have no position to bound and stay out of the tree (as pbrt-v4's infinite
//! lights): each is chosen with probability 1 / (directional lights + 1), the tree with the rest.
//! Lights without power stay out too: no point chooses them (as with selection by power).

use crate::gpu::layout::{
    LIGHT_TREE_INDEX, LIGHT_TREE_LEAF, LIGHT_TREE_TWO_SIDED, LightTreeNode, decode_normal, encode_normal,
};
use crate::lit_boxes::LitBox;
use glam::{Quat, Vec3};
use std::f32::consts::PI;

/// What the tree knows of a light or a subtree: a box around its emitters, its power `phi`, and
/// the directions it emits into: normals within `cos_o` of `axis`, each emitting up to `cos_e`
/// around itself (pbrt-v4's `LightBounds`); and where known, a box around every point it lights
/// (`crate::lit_boxes`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub min: Vec3,
    pub max: Vec3,
    pub phi: f32,
    pub axis: Vec3,
    pub cos_o: f32,
    pub cos_e: f32,
    pub two_sided: bool,
    pub lit: Option<LitBox>,
}

/// A cone of directions: `axis` and the cosine of its half-angle (-1: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionCone {
    pub axis: Vec3,
    pub cos_theta: f32,
}

/// A cone's angle is widened by this much wherever it is computed (the union of cones, in f32),
/// so that rounding can never leave an emitter's normal outside its node's cone.
const CONE_MARGIN: f32 = 1.0e-3;

impl DirectionCone {
    pub fn of(axis: Vec3) -> DirectionCone {
        DirectionCone { axis, cos_theta: 1.0 }
    }

    pub const ENTIRE_SPHERE: DirectionCone = DirectionCone { axis: Vec3::Z, cos_theta: -1.0 };

    /// The smallest cone around both (pbrt-v4's `Union(DirectionCone, DirectionCone)`).
    pub fn union(self, other: DirectionCone) -> DirectionCone {
        let theta_a = self.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_b = other.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_d = self.axis.angle_between(other.axis);
        if (theta_d + theta_b).min(PI) <= theta_a {
            return self;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return other;
        }
        let theta_o = (theta_a + theta_d + theta_b) / 2.0 + CONE_MARGIN;
        if theta_o >= PI {
            return DirectionCone::ENTIRE_SPHERE;
        }
        let wr = self.axis.cross(other.axis);
        if wr.length_squared() < 1.0e-12 {
            return DirectionCone::ENTIRE_SPHERE;
        }
        let axis = Quat::from_axis_angle(wr.normalize(), theta_o - CONE_MARGIN - theta_a) * self.axis;
        DirectionCone { axis: axis.normalize(), cos_theta: theta_o.cos() }
    }
}

/// cos(max(0, a − b)) from the sines and cosines of a and b in [0, π].
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 1.0 } else { cos_a * cos_b + sin_a * sin_b }
}

/// sin(max(0, a − b)), likewise.
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b { 0.0 } else { sin_a * cos_b - cos_a * sin_b }
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

impl LightBounds {
    pub fn union(&self, other: &LightBounds) -> LightBounds {
        let cone = DirectionCone { axis: self.axis, cos_theta: self.cos_o }
            .union(DirectionCone { axis: other.axis, cos_theta: other.cos_o });
        LightBounds {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            phi: self.phi + other.phi,
            axis: cone.axis,
            cos_o: cone.cos_theta,
            cos_e: self.cos_e.min(other.cos_e),
            two_sided: self.two_sided || other.two_sided,
            lit: self.lit.zip(other.lit).map(|(a, b)| a.union(&b)),
        }
    }

    fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// What these emitters may send to point `p` of a surface with normal `n`:
    /// `NodeBounds::importance` of their node.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        NodeBounds::from(self).importance(p, n)
    }
}

/// A node's bounds as the walk reads them: the sphere around the box (centre, radius = half the
/// diagonal), power, emission cone with its sine (LightTreeNode on the GPU).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeBounds {
    pub centre: Vec3,
    pub radius: f32,
    pub axis: Vec3,
    pub phi: f32,
    pub cos_o: f32,
    pub sin_o: f32,
    pub cos_e: f32,
    pub two_sided: bool,
    pub lit: Option<LitBox>,
}

impl From<&LightBounds> for NodeBounds {
    fn from(b: &LightBounds) -> NodeBounds {
        NodeBounds {
            centre: 0.5 * (b.min + b.max),
            radius: 0.5 * (b.max - b.min).length(),
            axis: b.axis,
            phi: b.phi,
            cos_o: b.cos_o,
            sin_o: safe_sqrt(1.0 - b.cos_o * b.cos_o),
            cos_e: b.cos_e,
            two_sided: b.two_sided,
            lit: b.lit,
        }
    }
}

impl NodeBounds {
    /// An estimate of the light that the node's emitters send to point `p` of a surface with
    /// normal `n` (the same float operations as `light_bounds_importance` in
    /// shaders/light_tree.wgsl): phi · cos θ' / d² times cos θ'_i, where θ' is the smallest angle
    /// between an emitter normal in the cone and a direction from the node's sphere to p, and θ'_i
    /// the smallest angle between n and a direction from p into the sphere (pbrt-v4's
    /// `LightBounds::Importance`). Zero where no emitter can face p, or the whole sphere lies
    /// below p's horizon (veach's BSDFs reflect only: light from below the shading normal adds
    /// nothing). pbrt-v4 keeps d² above half the box's diagonal; here above the sphere's radius
    /// squared, so that both sides are areas (and above 1e-20, for a point light at p).
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let to_p = p - self.centre;
        let dist_sq = to_p.dot(to_p);
        let radius_sq = self.radius * self.radius;
        let d2 = dist_sq.max(radius_sq).max(1.0e-20);
        let inv_dist = 1.0 / dist_sq.max(1.0e-30).sqrt();
        let wi = to_p * inv_dist;
        let mut cos_w = self.axis.dot(wi);
        if self.two_sided {
            cos_w = cos_w.abs();
        }
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        let inside = dist_sq < radius_sq;
        let sin_b = if inside { 0.0 } else { (self.radius * inv_dist).min(1.0) };
        let cos_b = if inside { -1.0 } else { safe_sqrt(1.0 - sin_b * sin_b) };
        let cos_x = cos_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        if cos_p <= self.cos_e {
            return 0.0;
        }
        let cos_i = -wi.dot(n);
        let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
        let cos_pi = cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
        if cos_pi <= 0.0 {
            return 0.0;
        }
        self.phi * cos_p * cos_pi / d2
    }
}

/// Bounds of an emitter that lies at `points` with face normals `normals` (one-sided unless
/// `two_sided`), emitting `phi`: each normal's side up to the horizon (θ_e = π/2).
pub fn area_light_bounds(
    points: impl IntoIterator<Item = Vec3>,
    normals: &[Vec3],
    phi: f32,
    two_sided: bool,
) -> LightBounds {
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in points {
        min = min.min(p);
        max = max.max(p);
    }
    let cone = normals.iter().fold(None, |acc: Option<DirectionCone>, &n| {
        let c = DirectionCone::of(n);
        Some(acc.map_or(c, |a| a.union(c)))
    });
    let cone = cone.unwrap_or(DirectionCone::ENTIRE_SPHERE);
    LightBounds { min, max, phi, axis: cone.axis, cos_o: cone.cos_theta, cos_e: 0.0, two_sided, lit: None }
}

/// A point light: every direction (θ_o = π, θ_e = π/2, as pbrt-v4's `PointLight::Bounds`).
pub fn point_light_bounds(position: Vec3, phi: f32) -> LightBounds {
    LightBounds {
        min: position,
        max: position,
        phi,
        axis: Vec3::Z,
        cos_o: -1.0,
        cos_e: 0.0,
        two_sided: false,
        lit: None,
    }
}

/// A spot light: directions within its outer cone's angle of its axis (θ_o = 0, θ_e = the outer
/// angle; pbrt-v4 splits the angle at the inner cone, which gives θ_e = 0 and no light at all
/// where the two cones are one).
pub fn spot_light_bounds(position: Vec3, direction: Vec3, cos_outer: f32, phi: f32) -> LightBounds {
    LightBounds {
        min: position,
        max: position,
        phi,
        axis: direction.normalize(),
        cos_o: 1.0,
        cos_e: cos_outer.clamp(-1.0, 1.0),
        two_sided: false,
        lit: None,
    }
}

/// The tree as the GPU reads it: nodes with the root at 0 and each inner node's two children
/// side by side, then one leaf per directional light (`directional`); and per light the path
/// from the root to its leaf (bit d: the second child at depth d; `NOT_IN_TREE` for lights the
/// tree leaves out).
pub struct LightTree {
    pub nodes: Vec<LightTreeNode>,
    /// Nodes of the tree proper (0: every light with power is directional, or there is none).
    pub tree_nodes: u32,
    pub directional: u32,
    pub trails: Vec<u32>,
    /// Each tree node's lit box (`None`: it may light anything). Where any node has one, `nodes`
    /// holds after the directional leaves one more element per tree node: its box, encoded by
    /// `lit_box_node`.
    pub lit: Vec<Option<LitBox>>,
    /// The lights in the tree that have a lit box.
    pub sealed_lights: u32,
}

/// How much of its importance a node keeps at a point outside its lit box: none, since its lights
/// light nothing there (`crate::lit_boxes`). LIGHT_OUTSIDE_LIT_BOX in shaders/light_tree.wgsl.
pub const LIGHT_OUTSIDE_LIT_BOX: f32 = 0.0;

/// A node's importance factor at p: 1 inside its lit box (or without one), else
/// `LIGHT_OUTSIDE_LIT_BOX`.
pub fn lit_factor(lit: &Option<LitBox>, p: Vec3) -> f32 {
    match lit {
        Some(b) if !b.contains(p) => LIGHT_OUTSIDE_LIT_BOX,
        _ => 1.0,
    }
}

/// A lit box as light_tree.wgsl's `lit_factor` reads it, in a node's place: `centre` the low
/// corner, `radius`, `phi` and `axis`'s bits the high one; without a box, the whole f32 range.
fn lit_box_node(lit: &Option<LitBox>) -> LightTreeNode {
    let b = lit.unwrap_or(LitBox { min: Vec3::splat(-f32::MAX), max: Vec3::splat(f32::MAX) });
    LightTreeNode {
        centre: b.min.to_array(),
        radius: b.max.x,
        phi: b.max.y,
        axis: b.max.z.to_bits(),
        ..Default::default()
    }
}

pub const NOT_IN_TREE: u32 = u32::MAX;
/// The deepest a leaf may lie: its path is a 32-bit word. Past `MEDIAN_SPLIT_DEPTH` a set is split
/// at its median, so that even a degenerate set of lights stays within it (2^12 lights per
/// subtree below that depth would be needed to reach 32).
const MAX_DEPTH: u32 = 32;
const MEDIAN_SPLIT_DEPTH: u32 = 20;
/// Buckets per axis of the binned split search (pbrt-v4's 12).
const BUCKETS: usize = 12;

/// Builds the tree over the lights with `Some` bounds and positive power; `directional` are the
/// indices of the directional lights.
pub fn build_light_tree(bounds: &[Option<LightBounds>], directional: &[u32]) -> LightTree {
    let mut items: Vec<(u32, LightBounds)> = bounds
        .iter()
        .enumerate()
        .filter_map(|(i, b)| b.filter(|b| b.phi > 0.0 && b.phi.is_finite()).map(|b| (i as u32, b)))
        .collect();
    let sealed_lights = items.iter().filter(|(_, b)| b.lit.is_some()).count() as u32;
    let mut nodes = Vec::new();
    let mut lit = Vec::new();
    let mut trails = vec![NOT_IN_TREE; bounds.len()];
    if !items.is_empty() {
        nodes.push(LightTreeNode::default());
        lit.push(None);
        build(&mut items, 0, 0, 0, &mut Built { nodes: &mut nodes, lit: &mut lit, trails: &mut trails });
    }
    let tree_nodes = nodes.len() as u32;
    for &light in directional {
        nodes.push(LightTreeNode { child_or_light: light | LIGHT_TREE_LEAF, ..Default::default() });
    }
    if lit.iter().any(Option::is_some) {
        nodes.extend(lit.iter().map(lit_box_node));
    } else {
        lit.clear();
    }
    LightTree { nodes, tree_nodes, directional: directional.len() as u32, trails, lit, sealed_lights }
}

/// A cosine as the node stores it: unorm16 of (cos + 1) / 2, rounded down (a wider cone).
fn encode_cosine(c: f32) -> u32 {
    let mut q = (((c.clamp(-1.0, 1.0) + 1.0) / 2.0) * 65535.0).floor() as u32;
    while q > 0 && decode_cosine(q) > c {
        q -= 1;
    }
    q
}

/// `unpack2x16unorm(x) * 2 - 1`, as light_tree.wgsl reads it.
fn decode_cosine(q: u32) -> f32 {
    (q & 0xffff) as f32 / 65535.0 * 2.0 - 1.0
}

fn node_of(b: &LightBounds) -> LightTreeNode {
    let n = NodeBounds::from(b);
    // The axis as decoded, and the cone widened by the angle the encoding moved it.
    let axis = encode_normal(n.axis.to_array());
    let moved = Vec3::from(decode_normal(axis)).as_dvec3().angle_between(n.axis.as_dvec3());
    let theta_o = (n.cos_o.clamp(-1.0, 1.0) as f64).acos() + moved + 1.0e-6;
    let cos_o = if theta_o >= std::f64::consts::PI { -1.0 } else { theta_o.cos() as f32 };
    LightTreeNode {
        centre: n.centre.to_array(),
        radius: n.radius,
        phi: n.phi,
        axis,
        cosines: encode_cosine(cos_o) | encode_cosine(n.cos_e) << 16,
        child_or_light: if n.two_sided { LIGHT_TREE_TWO_SIDED } else { 0 },
    }
}

/// pbrt-v4's split cost of a subtree (`BVHLightSampler::EvaluateCost`): power times the measure
/// of its emission cone M_Ω times its box's surface area, times how thin the parent box is along
/// the split axis.
fn split_cost(b: &LightBounds, parent_extent: Vec3, axis: usize) -> f32 {
    let theta_o = b.cos_o.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let sin_o = safe_sqrt(1.0 - b.cos_o * b.cos_o);
    let m_omega = 2.0 * PI * (1.0 - b.cos_o)
        + PI / 2.0 * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o + b.cos_o);
    let d = b.max - b.min;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    let kr = parent_extent.max_element() / parent_extent[axis].max(1.0e-30);
    b.phi * m_omega * kr * area
}

fn union_all(items: &[(u32, LightBounds)]) -> LightBounds {
    items[1..].iter().fold(items[0].1, |acc, (_, b)| acc.union(b))
}

/// The tree as `build` fills it: nodes and their lit boxes side by side, and the lights' paths.
struct Built<'a> {
    nodes: &'a mut Vec<LightTreeNode>,
    lit: &'a mut Vec<Option<LitBox>>,
    trails: &'a mut [u32],
}

/// Fills node `at` with the subtree over `items`, at `depth` along `trail`.
fn build(items: &mut [(u32, LightBounds)], at: usize, depth: u32, trail: u32, out: &mut Built) {
    let all = union_all(items);
    let mut node = node_of(&all);
    out.lit[at] = all.lit;
    if items.len() == 1 {
        node.child_or_light |= items[0].0 | LIGHT_TREE_LEAF;
        out.nodes[at] = node;
        out.trails[items[0].0 as usize] = trail;
        return;
    }
    let mid = split(items, depth);
    let first_child = out.nodes.len();
    out.nodes.extend([LightTreeNode::default(); 2]);
    out.lit.extend([None; 2]);
    node.child_or_light |= first_child as u32;
    out.nodes[at] = node;
    assert!(depth + 1 < MAX_DEPTH, "light tree deeper than its 32-bit paths");
    let (left, right) = items.split_at_mut(mid);
    build(left, first_child, depth + 1, trail, out);
    build(right, first_child + 1, depth + 1, trail | (1 << depth), out);
}

/// Where to split `items` (sorted in place so that the split is an index): the cheapest of the
/// bucket boundaries on each axis of the centroids' box, or the median where no boundary
/// separates them or the tree is already deep.
fn split(items: &mut [(u32, LightBounds)], depth: u32) -> usize {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (_, b) in items.iter() {
        lo = lo.min(b.centroid());
        hi = hi.max(b.centroid());
    }
    let extent = hi - lo;
    let widest = extent.max_position();
    let median = |items: &mut [(u32, LightBounds)], axis: usize| {
        items.sort_by(|a, b| a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis]));
        items.len() / 2
    };
    if depth >= MEDIAN_SPLIT_DEPTH || extent.max_element() <= 0.0 {
        return median(items, widest);
    }
    let parent = union_all(items);
    let parent_extent = parent.max - parent.min;
    let bucket_of = |b: &LightBounds, axis: usize| {
        let t = (b.centroid()[axis] - lo[axis]) / extent[axis];
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket_of(b, axis);
            buckets[k] = Some(buckets[k].map_or(*b, |acc| acc.union(b)));
        }
        for boundary in 1..BUCKETS {
            let side = |range: std::ops::Range<usize>| {
                buckets[range]
                    .iter()
                    .flatten()
                    .fold(None, |acc: Option<LightBounds>, b| Some(acc.map_or(*b, |a| a.union(b))))
            };
            let (Some(below), Some(above)) = (side(0..boundary), side(boundary..BUCKETS)) else { continue };
            let cost = split_cost(&below, parent_extent, axis) + split_cost(&above, parent_extent, axis);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, boundary));
            }
        }
    }
    let Some((_, axis, boundary)) = best else { return median(items, widest) };
    items.sort_by_key(|(_, b)| bucket_of(b, axis));
    items.iter().position(|(_, b)| bucket_of(b, axis) >= boundary).unwrap_or(items.len() / 2)
}

impl LightTree {
    fn bounds_at(&self, index: usize) -> NodeBounds {
        let n = &self.nodes[index];
        let cos_o = decode_cosine(n.cosines);
        NodeBounds {
            centre: n.centre.into(),
            radius: n.radius,
            axis: decode_normal(n.axis).into(),
            phi: n.phi,
            cos_o,
            sin_o: safe_sqrt(1.0 - cos_o * cos_o),
            cos_e: decode_cosine(n.cosines >> 16),
            two_sided: n.child_or_light & LIGHT_TREE_TWO_SIDED != 0,
            lit: self.lit.get(index).copied().flatten(),
        }
    }

    /// The probability that a point p with normal n chooses `light` (the host's copy of
    /// `light_tree_pmf` in shaders/light_tree.wgsl, for the tests): the directional share, or the
    /// tree's share times, at each node on the light's path, its child's part of the two
    /// children's importance (by power where both are zero).
    pub fn pmf(&self, light: u32, is_directional: bool, p: Vec3, n: Vec3) -> f32 {
        let has_tree = (self.tree_nodes > 0) as u32;
        let share = 1.0 / (self.directional + has_tree) as f32;
        if is_directional {
            return share;
        }
        let mut trail = self.trails[light as usize];
        if trail == NOT_IN_TREE {
            return 0.0;
        }
        let mut pmf = share;
        let mut at = 0usize;
        while self.nodes[at].child_or_light & LIGHT_TREE_LEAF == 0 {
            let child = (self.nodes[at].child_or_light & LIGHT_TREE_INDEX) as usize;
            let p0 = first_child_share(&self.bounds_at(child), &self.bounds_at(child + 1), p, n);
            let second = trail & 1 == 1;
            pmf *= if second { 1.0 - p0 } else { p0 };
            at = child + second as usize;
            trail >>= 1;
        }
        pmf
    }
}

/// The first child's probability at a node: its share of the two importances, each times its
/// `lit_factor`, or of the two powers where both are zero (or underflow), so that every light with
/// power keeps a positive probability wherever the estimate fails.
pub fn first_child_share(a: &NodeBounds, b: &NodeBounds, p: Vec3, n: Vec3) -> f32 {
    let (ia, ib) = (a.importance(p, n) * lit_factor(&a.lit, p), b.importance(p, n) * lit_factor(&b.lit, p));
    if ia + ib > 0.0 { ia / (ia + ib) } else { a.phi / (a.phi + b.phi) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use veach_scenes::SplitMix64;

    fn random_lights(n: usize, seed: u64) -> Vec<Option<LightBounds>> {
        let mut rng = SplitMix64(seed);
        let mut r = move || rng.next_f32();
        (0..n)
            .map(|i| {
                let p = Vec3::new(r() * 10.0, r() * 10.0, r() * 10.0);
                let phi = 10f32.powf(r() * 6.0 - 3.0);
                Some(match i % 3 {
                    0 => point_light_bounds(p, phi),
                    1 => spot_light_bounds(p, Vec3::new(r() - 0.5, -1.0, r() - 0.5), 0.7, phi),
                    _ => {
                        let normal = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
                        let corner = p + Vec3::splat(0.1 + r());
                        area_light_bounds([p, corner], &[normal], phi, i % 5 == 0)
                    }
                })
            })
            .collect()
    }

    #[test]
    fn every_light_with_power_has_a_path_to_its_own_leaf() {
        for n in [1, 2, 3, 17, 1000] {
            let lights = random_lights(n, n as u64);
            let tree = build_light_tree(&lights, &[]);
            for (i, trail) in tree.trails.iter().enumerate() {
                let (mut at, mut t) = (0usize, *trail);
                while tree.nodes[at].child_or_light & LIGHT_TREE_LEAF == 0 {
                    at = (tree.nodes[at].child_or_light & LIGHT_TREE_INDEX) as usize + (t & 1) as usize;
                    t >>= 1;
                }
                assert_eq!(tree.nodes[at].child_or_light & LIGHT_TREE_INDEX, i as u32, "{n} lights: light {i}'s path");
            }
            assert_eq!(tree.tree_nodes as usize, 2 * n - 1);
        }
    }

    #[test]
    fn the_probabilities_of_all_lights_sum_to_one_at_any_point() {
        let mut lights = random_lights(300, 7);
        lights.push(None); // a directional light
        lights.push(Some(point_light_bounds(Vec3::ONE, 0.0))); // no power: never chosen
        let tree = build_light_tree(&lights, &[300]);
        let mut rng = SplitMix64(9);
        for _ in 0..200 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 12.0 - 1.0;
            let n = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let sum: f64 = (0..lights.len()).map(|i| tree.pmf(i as u32, i == 300, p, n) as f64).sum();
            assert!((sum - 1.0).abs() < 1e-4, "at {p}: probabilities sum to {sum}");
            assert_eq!(tree.pmf(301, false, p, n), 0.0);
            assert!((tree.pmf(300, true, p, n) - 0.5).abs() < 1e-7);
        }
    }

    #[test]
    fn a_surface_does_not_choose_lights_behind_it() {
        // Two quads facing down over a floor, and one below the floor facing up.
        let quad = |y: f32, normal: Vec3| {
            Some(area_light_bounds([Vec3::new(-1.0, y, -1.0), Vec3::new(1.0, y, 1.0)], &[normal], 1.0, false))
        };
        let lights = [quad(2.0, Vec3::NEG_Y), quad(3.0, Vec3::NEG_Y), quad(-2.0, Vec3::Y)];
        let tree = build_light_tree(&lights, &[]);
        let (p, n) = (Vec3::ZERO, Vec3::Y);
        assert_eq!(tree.pmf(2, false, p, n), 0.0, "the light below the floor");
        // The nearer light above gets more than the farther one.
        assert!(tree.pmf(0, false, p, n) > tree.pmf(1, false, p, n));
        // Lights facing away from a point give it nothing: seen from above both upper quads.
        assert_eq!(lights[0].unwrap().importance(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y), 0.0);
    }

    #[test]
    fn the_union_of_cones_holds_both() {
        let mut rng = SplitMix64(3);
        for _ in 0..1000 {
            let mut dir = || Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let (a, b) = (DirectionCone { axis: dir(), cos_theta: 0.9 }, DirectionCone { axis: dir(), cos_theta: 0.5 });
            let u = a.union(b);
            for c in [a, b] {
                // Every direction of c: its axis tilted by its angle, towards and away from u's axis.
                let angle = c.axis.angle_between(u.axis) + c.cos_theta.acos();
                assert!(angle.min(PI) <= u.cos_theta.clamp(-1.0, 1.0).acos() + 1e-5, "{a:?} ∪ {b:?} = {u:?}");
            }
        }
    }
}

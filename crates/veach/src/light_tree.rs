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
    LIGHT_TREE_INDEX, LIGHT_TREE_LEAF, LIGHT_TREE_TWO_SIDED, LightTreeSlot, decode_normal, encode_normal,
};
use crate::lit_boxes::LitBox;
use glam::{DVec3, Quat, Vec3};
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
/// diagonal), power, emission cone with its sine (a child decoded from its slot, `LightTree::child_bounds`;
/// `tree_child` on the GPU).
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

/// The tree as the GPU reads it (`LightTreeSlot`): slot 0 the root's sphere (`root_slot`), slot 1
/// the root, and each inner node's slot its two children's bounds (`encode_children`), the
/// children's slots side by side; then one slot per directional light (`directional`); and per
/// light the path from the root to its leaf (bit d: the second child at depth d; `NOT_IN_TREE` for
/// lights the tree leaves out).
pub struct LightTree {
    pub slots: Vec<LightTreeSlot>,
    /// Slots of the tree proper (0: every light with power is directional, or there is none).
    pub tree_slots: u32,
    pub directional: u32,
    pub trails: Vec<u32>,
    /// Each tree slot's lit box (`None`: it may light anything). Where any node has one, `slots`
    /// holds after the directional leaves one more slot per tree slot: its box, encoded by
    /// `lit_box_slot`.
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

/// A lit box as light_tree.wgsl's `lit_factor` reads it, in a slot's place: the low corner in
/// `children`, `centre_a` and `centre_b`, the high one in `radii_cos_e`, `axis_a` and `axis_b`
/// (f32 bits); without a box, the whole f32 range.
fn lit_box_slot(lit: &Option<LitBox>) -> LightTreeSlot {
    let b = lit.unwrap_or(LitBox { min: Vec3::splat(-f32::MAX), max: Vec3::splat(f32::MAX) });
    let [lx, ly, lz] = b.min.to_array().map(f32::to_bits);
    let [hx, hy, hz] = b.max.to_array().map(f32::to_bits);
    LightTreeSlot {
        children: lx,
        centre_a: ly,
        centre_b: lz,
        radii_cos_e: hx,
        axis_a: hy,
        axis_b: hz,
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

/// A node of the tree as built, before its bounds are quantised: the root at 0, each inner node's
/// children side by side.
struct TreeNode {
    bounds: LightBounds,
    /// The first child, or in a leaf its light.
    child_or_light: u32,
    leaf: bool,
}

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
    let mut trails = vec![NOT_IN_TREE; bounds.len()];
    if !items.is_empty() {
        nodes.push(TreeNode { bounds: items[0].1, child_or_light: 0, leaf: true });
        build(&mut items, 0, 0, 0, &mut Built { nodes: &mut nodes, trails: &mut trails });
    }
    let (mut slots, mut lit) = encode_tree(&nodes);
    let tree_slots = slots.len() as u32;
    for &light in directional {
        slots.push(LightTreeSlot { children: light, ..Default::default() });
    }
    if lit.iter().any(Option::is_some) {
        slots.extend(lit.iter().map(lit_box_slot));
    } else {
        lit.clear();
    }
    LightTree { slots, tree_slots, directional: directional.len() as u32, trails, lit, sealed_lights }
}

/// A cosine as the tree stores it: unorm16 of (cos + 1) / 2, rounded down (a wider cone).
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

/// cos θ_e as snorm8, rounded down (a wider cone; 0, a surface's horizon, is exact).
fn encode_cos_e(c: f32) -> u32 {
    let mut q = (c.clamp(-1.0, 1.0) * 127.0).floor() as i32;
    while q > -127 && decode_cos_e(q as u32) > c {
        q -= 1;
    }
    q as i8 as u8 as u32
}

/// `unpack4x8snorm`'s lane.
fn decode_cos_e(q: u32) -> f32 {
    ((q & 0xff) as u8 as i8 as f32 / 127.0).max(-1.0)
}

/// A child's radius is at most its parent's (its box lies in the parent's), and its quantised
/// sphere at most this many times the parent's decoded one: the unorm8's unit is
/// parent radius · LIGHT_TREE_RADIUS_SCALE / 255.
pub const LIGHT_TREE_RADIUS_SCALE: f32 = 1.0 + 1.0 / 64.0;

/// How far the GPU's decoding may stray from the host's, relative to the root's radius per
/// node (f32 rounding, contracted multiply-adds; about 2^-22 a level over at most 32 levels) and
/// to a radius; each decoded sphere is grown by it so that it holds its lights on either side.
const SPHERE_MARGIN: f64 = 1.0e-5;

/// The least share of its node's power a child keeps: f16's least normal number (2^-14), so that
/// no light loses its probability to rounding and the walk decodes shares by a bit shift.
const MIN_SHARE: u16 = 0x0400;

/// A node's sphere as the walk decodes it, its centre relative to the root's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: Vec3,
    pub radius: f32,
}

/// A child's centre from its 10-bit offsets in its parent's decoded sphere (light_tree.wgsl's
/// `tree_child`, the same float operations).
fn decode_centre(bits: u32, parent: Sphere) -> Vec3 {
    let q = Vec3::new((bits & 1023) as f32, (bits >> 10 & 1023) as f32, (bits >> 20 & 1023) as f32);
    parent.centre + parent.radius * (q * (2.0 / 1023.0) - Vec3::ONE)
}

/// A child's radius from its unorm8 (`tree_child`).
fn decode_radius(q: u32, parent: Sphere) -> f32 {
    parent.radius * (((q & 0xff) as f32 / 255.0) * LIGHT_TREE_RADIUS_SCALE)
}

/// Slot 0: the root's centre (the origin of every decoded centre, in world space) in `centre_a`,
/// `centre_b`, `radii_cos_e`, its radius in `axis_a` (f32 bits); in `children` the root's slot
/// (1), with `LIGHT_TREE_LEAF` where the root is a leaf.
fn root_slot(origin: Vec3, radius: f32, leaf: bool) -> LightTreeSlot {
    let [x, y, z] = origin.to_array().map(f32::to_bits);
    let children = 1 | if leaf { LIGHT_TREE_LEAF } else { 0 };
    LightTreeSlot { children, centre_a: x, centre_b: y, radii_cos_e: z, axis_a: radius.to_bits(), ..Default::default() }
}

/// The sphere around a node's box, its centre relative to `origin` (in f64).
fn sphere_of(b: &LightBounds, origin: DVec3) -> (DVec3, f64) {
    let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
    (0.5 * (min + max) - origin, 0.5 * (max - min).length())
}

/// Quantises the tree's nodes into slots, each inner node's children within its decoded sphere,
/// and gives each slot its lit box.
fn encode_tree(nodes: &[TreeNode]) -> (Vec<LightTreeSlot>, Vec<Option<LitBox>>) {
    let Some(root) = nodes.first() else { return (Vec::new(), Vec::new()) };
    let centre = 0.5 * (root.bounds.min + root.bounds.max);
    let (offset, radius) = sphere_of(&root.bounds, centre.as_dvec3());
    // Lights beyond f32's range stay finite: inf would decode to NaN.
    let root_radius =
        (((offset.length() + radius) * (1.0 + SPHERE_MARGIN)) as f32 * (1.0 + f32::EPSILON)).min(f32::MAX);
    let margin = SPHERE_MARGIN * root_radius as f64;
    // Node i sits in slot i + 1.
    let mut slots = vec![root_slot(centre, root_radius, root.leaf)];
    let mut lit = vec![None];
    let mut decoded = vec![Sphere { centre: Vec3::ZERO, radius: root_radius }; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        lit.push(node.bounds.lit);
        if node.leaf {
            slots.push(LightTreeSlot { children: node.child_or_light, ..Default::default() });
            continue;
        }
        let first = node.child_or_light as usize;
        let (slot, a, b) = encode_children(decoded[i], [&nodes[first], &nodes[first + 1]], centre.as_dvec3(), margin);
        decoded[first] = a;
        decoded[first + 1] = b;
        slots.push(LightTreeSlot { children: slot.children | (first as u32 + 1), ..slot });
    }
    (slots, lit)
}

/// Two children's bounds quantised within their parent's decoded sphere (`LightTreeSlot`), and
/// their own decoded spheres. Each decoded sphere holds the child's sphere with `margin` and
/// `SPHERE_MARGIN` to spare; power as each child's share, in f16 (at least `MIN_SHARE`); cones
/// widened by their rounding.
fn encode_children(
    parent: Sphere,
    children: [&TreeNode; 2],
    origin: DVec3,
    margin: f64,
) -> (LightTreeSlot, Sphere, Sphere) {
    let mut slot = LightTreeSlot::default();
    let mut decoded = [parent; 2];
    let phi = children[0].bounds.phi as f64 + children[1].bounds.phi as f64;
    for (c, child) in children.into_iter().enumerate() {
        let b = &child.bounds;
        let (centre, radius) = sphere_of(b, origin);
        let q = if parent.radius > 0.0 {
            let t = (centre - parent.centre.as_dvec3()) / parent.radius as f64;
            let q = ((t + 1.0) / 2.0 * 1023.0).round().clamp(DVec3::ZERO, DVec3::splat(1023.0));
            q.x as u32 | (q.y as u32) << 10 | (q.z as u32) << 20
        } else {
            511 | 511 << 10 | 511 << 20
        };
        let decoded_centre = decode_centre(q, parent);
        let needed = ((centre - decoded_centre.as_dvec3()).length() + radius + margin) * (1.0 + SPHERE_MARGIN);
        let unit = parent.radius as f64 * LIGHT_TREE_RADIUS_SCALE as f64 / 255.0;
        let mut r = if unit > 0.0 { (needed / unit).ceil().min(255.0) as u32 } else { 0 };
        while r < 255 && (decode_radius(r, parent) as f64) < needed {
            r += 1;
        }
        decoded[c] = Sphere { centre: decoded_centre, radius: decode_radius(r, parent) };
        // The axis as decoded, and the cone widened by the angle the encoding moved it.
        let axis = encode_normal(b.axis.to_array());
        let moved = Vec3::from(decode_normal(axis)).as_dvec3().angle_between(b.axis.as_dvec3());
        let theta_o = (b.cos_o.clamp(-1.0, 1.0) as f64).acos() + moved + 1.0e-6;
        let cos_o = if theta_o >= std::f64::consts::PI { -1.0 } else { theta_o.cos() as f32 };
        let share = half::f16::from_f64(b.phi as f64 / phi).to_bits().max(MIN_SHARE) as u32;
        let shift = 16 * c as u32;
        if c == 0 {
            slot.centre_a = q;
            slot.axis_a = axis;
        } else {
            slot.centre_b = q;
            slot.axis_b = axis;
        }
        slot.radii_cos_e |= r << (8 * c) | encode_cos_e(b.cos_e) << (16 + 8 * c);
        slot.cos_o |= encode_cosine(cos_o) << shift;
        slot.phi |= share << shift;
        slot.children |=
            if child.leaf { LIGHT_TREE_LEAF << c } else { 0 } | if b.two_sided { LIGHT_TREE_TWO_SIDED << c } else { 0 };
    }
    (slot, decoded[0], decoded[1])
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

/// The tree as `build` fills it: the nodes and the lights' paths.
struct Built<'a> {
    nodes: &'a mut Vec<TreeNode>,
    trails: &'a mut [u32],
}

/// Fills node `at` with the subtree over `items`, at `depth` along `trail`.
fn build(items: &mut [(u32, LightBounds)], at: usize, depth: u32, trail: u32, out: &mut Built) {
    let bounds = union_all(items);
    if items.len() == 1 {
        out.nodes[at] = TreeNode { bounds, child_or_light: items[0].0, leaf: true };
        out.trails[items[0].0 as usize] = trail;
        return;
    }
    let mid = split(items, &bounds, depth);
    let first_child = out.nodes.len();
    for _ in 0..2 {
        out.nodes.push(TreeNode { bounds, child_or_light: 0, leaf: true });
    }
    out.nodes[at] = TreeNode { bounds, child_or_light: first_child as u32, leaf: false };
    assert!(depth + 1 < MAX_DEPTH, "light tree deeper than its 32-bit paths");
    let (left, right) = items.split_at_mut(mid);
    build(left, first_child, depth + 1, trail, out);
    build(right, first_child + 1, depth + 1, trail | (1 << depth), out);
}

/// Where to split `items` (sorted in place so that the split is an index): the cheapest of the
/// bucket boundaries on each axis of the centroids' box, or the median where no boundary
/// separates them or the tree is already deep.
fn split(items: &mut [(u32, LightBounds)], parent: &LightBounds, depth: u32) -> usize {
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
    /// The root's centre (world space), its decoded sphere, and whether it is a leaf.
    fn root(&self) -> (Vec3, Sphere, bool) {
        let s = &self.slots[0];
        let origin = Vec3::new(f32::from_bits(s.centre_a), f32::from_bits(s.centre_b), f32::from_bits(s.radii_cos_e));
        (origin, Sphere { centre: Vec3::ZERO, radius: f32::from_bits(s.axis_a) }, s.children & LIGHT_TREE_LEAF != 0)
    }

    /// Child `c` of the inner node in slot `at` whose decoded sphere is `parent`, as the walk
    /// decodes it (light_tree.wgsl's `tree_child`), with its lit box.
    pub fn child_bounds(&self, at: usize, c: usize, parent: Sphere) -> NodeBounds {
        let s = &self.slots[at];
        let shift = 16 * c as u32;
        let centre = decode_centre(if c == 0 { s.centre_a } else { s.centre_b }, parent);
        let radius = decode_radius(s.radii_cos_e >> (8 * c), parent);
        let cos_o = decode_cosine(s.cos_o >> shift);
        NodeBounds {
            centre,
            radius,
            axis: decode_normal(if c == 0 { s.axis_a } else { s.axis_b }).into(),
            phi: half::f16::from_bits((s.phi >> shift) as u16).to_f32(),
            cos_o,
            sin_o: safe_sqrt(1.0 - cos_o * cos_o),
            cos_e: decode_cos_e(s.radii_cos_e >> (16 + 8 * c)),
            two_sided: (s.children >> c) & LIGHT_TREE_TWO_SIDED != 0,
            lit: self.lit.get((s.children & LIGHT_TREE_INDEX) as usize + c).copied().flatten(),
        }
    }

    /// The probability that a point p with normal n chooses `light` (the host's copy of
    /// `light_tree_pmf` in shaders/light_tree.wgsl, for the tests): the directional share, or the
    /// tree's share times, at each node on the light's path, its child's part of the two
    /// children's importance (by power where both are zero).
    pub fn pmf(&self, light: u32, is_directional: bool, p: Vec3, n: Vec3) -> f32 {
        let has_tree = (self.tree_slots > 0) as u32;
        let share = 1.0 / (self.directional + has_tree) as f32;
        if is_directional {
            return share;
        }
        let mut trail = self.trails[light as usize];
        if trail == NOT_IN_TREE {
            return 0.0;
        }
        let (origin, mut sphere, mut leaf) = self.root();
        let p_rel = p - origin;
        let mut pmf = share;
        let mut at = 1usize;
        while !leaf {
            let (a, b) = (self.child_bounds(at, 0, sphere), self.child_bounds(at, 1, sphere));
            let p0 = first_child_share(&a, &b, p_rel, p, n);
            let second = (trail & 1) as usize;
            pmf *= if second == 1 { 1.0 - p0 } else { p0 };
            sphere = if second == 1 {
                Sphere { centre: b.centre, radius: b.radius }
            } else {
                Sphere { centre: a.centre, radius: a.radius }
            };
            let children = self.slots[at].children;
            leaf = (children >> second) & LIGHT_TREE_LEAF != 0;
            at = (children & LIGHT_TREE_INDEX) as usize + second;
            trail >>= 1;
        }
        pmf
    }

    /// The slots from the root to the leaf a light's path (`trails`) leads to, for the tests.
    #[cfg(test)]
    fn path(&self, mut trail: u32) -> Vec<usize> {
        let (mut at, mut path) = (1usize, vec![1usize]);
        let mut leaf = self.slots[0].children & LIGHT_TREE_LEAF != 0;
        while !leaf {
            let children = self.slots[at].children;
            leaf = (children >> (trail & 1)) & LIGHT_TREE_LEAF != 0;
            at = (children & LIGHT_TREE_INDEX) as usize + (trail & 1) as usize;
            path.push(at);
            trail >>= 1;
        }
        path
    }

    /// Every node's slot and decoded sphere, for the tests.
    #[cfg(test)]
    fn decoded_spheres(&self) -> Vec<(usize, Sphere)> {
        let (_, root, leaf) = self.root();
        let mut out = Vec::new();
        let mut stack = vec![(1usize, root, leaf)];
        while let Some((at, sphere, leaf)) = stack.pop() {
            out.push((at, sphere));
            if !leaf {
                let children = self.slots[at].children;
                for c in 0..2 {
                    let b = self.child_bounds(at, c, sphere);
                    let child = (children & LIGHT_TREE_INDEX) as usize + c;
                    stack.push((
                        child,
                        Sphere { centre: b.centre, radius: b.radius },
                        (children >> c) & LIGHT_TREE_LEAF != 0,
                    ));
                }
            }
        }
        out
    }
}

/// The first child's probability at a node: its share of the two importances at `p_rel` (p
/// relative to the root's centre, where the spheres decode), each times its `lit_factor` at p, or
/// of the two powers where both are zero (or underflow), so that every light with power keeps a
/// positive probability wherever the estimate fails.
pub fn first_child_share(a: &NodeBounds, b: &NodeBounds, p_rel: Vec3, p: Vec3, n: Vec3) -> f32 {
    let (ia, ib) = (a.importance(p_rel, n) * lit_factor(&a.lit, p), b.importance(p_rel, n) * lit_factor(&b.lit, p));
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
                let leaf = *tree.path(*trail).last().unwrap();
                assert_eq!(tree.slots[leaf].children, i as u32, "{n} lights: light {i}'s path");
            }
            assert_eq!(tree.tree_slots as usize, 2 * n);
        }
    }

    /// Every node's decoded sphere holds the lights below it with room to spare for the GPU's
    /// rounding: the quantised bounds only grow (else a light could get probability 0 where it
    /// lights a point). Lights spread over six decades of size, far from the origin, and many
    /// at one point (spheres of radius 0 inside wider ones).
    #[test]
    fn decoded_spheres_hold_their_lights() {
        let mut lights = random_lights(2000, 11);
        let mut rng = SplitMix64(12);
        for i in 0..500 {
            let p = Vec3::new(1000.0 + rng.next_f32() * 1e-3, 5.0, rng.next_f32() * 1e-2);
            let size = 10f32.powf(-6.0 + rng.next_f32() * 6.0);
            lights.push(Some(area_light_bounds([p, p + Vec3::splat(size)], &[Vec3::Y], 1.0, false)));
            if i < 50 {
                lights.push(Some(point_light_bounds(Vec3::new(3.0, 3.0, 3.0), 1.0)));
            }
        }
        let tree = build_light_tree(&lights, &[]);
        // The slots along each light's path.
        let paths: Vec<Vec<usize>> = tree.trails.iter().map(|&trail| tree.path(trail)).collect();
        let (origin, root, _) = tree.root();
        // What the GPU's rounding may take: half the margin each sphere was given.
        let spare = SPHERE_MARGIN / 2.0 * root.radius as f64;
        let spheres = tree.decoded_spheres();
        assert_eq!(spheres.len(), tree.tree_slots as usize - 1);
        for (at, sphere) in spheres {
            for (light, _) in paths.iter().enumerate().filter(|(_, path)| path.contains(&at)) {
                let b = lights[light].unwrap();
                for corner in 0..8 {
                    let pick = |axis: usize| if corner >> axis & 1 == 0 { b.min[axis] } else { b.max[axis] };
                    let q = DVec3::new(pick(0) as f64, pick(1) as f64, pick(2) as f64) - origin.as_dvec3();
                    let d = (q - sphere.centre.as_dvec3()).length();
                    assert!(
                        d + spare <= sphere.radius as f64,
                        "slot {at}: light {light}'s corner {q} lies {d} from {}, radius {}",
                        sphere.centre,
                        sphere.radius
                    );
                }
            }
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

// light_tree.wgsl: choosing a light per shading point by the light tree (SELECT_TREE; Conty
// Estevez & Kulla, "Importance Sampling of Many Lights with Adaptive Tree Splitting", HPG 2018;
// pbrt-v4's BVHLightSampler). The host builds the tree (crates/veach/src/light_tree.rs, whose
// LightBounds::importance is light_bounds_importance in Rust, for the tests). From the root, each
// step takes a child with probability proportional to what its bounds promise the point; the
// probability of a light is the product along its path, which light_tree_pmf retraces for the MIS
// weight of a direction sample that finds the light.

// `light_tree` (binding 26) is declared by the host (gpu/bindings.rs, wgsl_declarations) and
// read by light_tree_slot.

// The shading point and normal the tree chooses for, set by prepare_point_selection; and the point
// relative to the root's centre, where the tree's spheres decode (set by tree_root).
var<private> tree_point: vec3f;
var<private> tree_normal: vec3f;
var<private> tree_point_rel: vec3f;

fn uses_light_tree() -> bool {
    return active_light_selection() == SELECT_TREE && !SINGLE_LIGHT;
}

// The deepest leaf (light_tree.rs, MAX_DEPTH).
const MAX_LIGHT_TREE_DEPTH: u32 = 32u;

// cos(max(0, a − b)) and sin(max(0, a − b)) from the sines and cosines of angles a, b in [0, π].
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    return select(cos_a * cos_b + sin_a * sin_b, 1.0, cos_a > cos_b);
}

fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    return select(sin_a * cos_b - cos_a * sin_b, 0.0, cos_a > cos_b);
}

fn safe_sqrt(x: f32) -> f32 {
    return sqrt(max(x, 0.0));
}

// A node's bounds as the importance reads them (a child decoded by tree_child).
struct NodeBounds {
    centre: vec3f,
    radius: f32,
    phi: f32,
    axis: vec3f,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    two_sided: bool,
}

// A normal, non-negative f16's value from its bits (its exponent rebiased into an f32's), exactly:
// the host keeps the shares normal (light_tree.rs, MIN_SHARE). unpack2x16float would need a
// capability some adapters lack, and ldexp costs lavapipe more than this.
fn f16_bits_to_f32(h: u32) -> f32 {
    return bitcast<f32>(((h & 0x7fffu) << 13u) + 0x38000000u);
}

// Child c (0 or 1) of the node in slot s, whose decoded sphere is (parent_centre, parent_radius):
// its centre from three 10-bit offsets in that sphere, its radius a fraction of it, its cone and
// share of the node's power (light_tree.rs, encode_children and LightTree::child_bounds, the same
// float operations).
fn tree_child(s: LightTreeSlot, c: u32, parent_centre: vec3f, parent_radius: f32) -> NodeBounds {
    let second = c == 1u;
    let q = select(s.centre_a, s.centre_b, second);
    let offset = vec3f(vec3u(q, q >> 10u, q >> 20u) & vec3u(1023u)) * (2.0 / 1023.0) - 1.0;
    let radii = unpack4x8unorm(s.radii_cos_e);
    let cos_e = unpack4x8snorm(s.radii_cos_e);
    let cos_o = unpack2x16unorm(s.cos_o) * 2.0 - 1.0;
    let phi = vec2f(f16_bits_to_f32(s.phi & 0xffffu), f16_bits_to_f32(s.phi >> 16u));
    let co = select(cos_o.x, cos_o.y, second);
    return NodeBounds(
        parent_centre + parent_radius * offset,
        parent_radius * (select(radii.x, radii.y, second) * LIGHT_TREE_RADIUS_SCALE),
        select(phi.x, phi.y, second),
        decode_normal(select(s.axis_a, s.axis_b, second)),
        co,
        safe_sqrt(1.0 - co * co),
        select(cos_e.z, cos_e.w, second),
        ((s.children >> c) & LIGHT_TREE_TWO_SIDED) != 0u,
    );
}

// What a node's lights may send to point p with normal n: phi cos θ' / d² times cos θ'_i, θ' the
// least angle between an emitter normal of the cone and a direction from the node's sphere to p,
// θ'_i the least angle between n and a direction from p into the sphere (pbrt-v4's
// LightBounds::Importance, with d² kept above the sphere's radius squared). Zero where no emitter
// faces p or the whole sphere lies below p's horizon (veach's BSDFs only reflect). The sphere's
// angular radius comes as its sine, radius / distance.
fn light_bounds_importance(b: NodeBounds, p: vec3f, n: vec3f) -> f32 {
    let to_p = p - b.centre;
    let dist_sq = dot(to_p, to_p);
    let radius_sq = b.radius * b.radius;
    let d2 = max(max(dist_sq, radius_sq), 1.0e-20);
    let inv_dist = inverseSqrt(max(dist_sq, 1.0e-30));
    let wi = to_p * inv_dist;
    var cos_w = dot(b.axis, wi);
    if b.two_sided {
        cos_w = abs(cos_w);
    }
    let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
    // The cone of directions from p that the sphere subtends (every direction from inside it).
    let inside = dist_sq < radius_sq;
    let sin_b = select(min(b.radius * inv_dist, 1.0), 0.0, inside);
    let cos_b = select(safe_sqrt(1.0 - sin_b * sin_b), -1.0, inside);
    let cos_x = cos_sub_clamped(sin_w, cos_w, b.sin_o, b.cos_o);
    let sin_x = sin_sub_clamped(sin_w, cos_w, b.sin_o, b.cos_o);
    let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if cos_p <= b.cos_e {
        return 0.0;
    }
    let cos_i = -dot(wi, n);
    let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
    let cos_pi = cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    if cos_pi <= 0.0 {
        return 0.0;
    }
    return b.phi * cos_p * cos_pi / d2;
}

// How much of its importance a node keeps at a point outside its lit box: none, since its
// lights light nothing there (light_tree.rs).
const LIGHT_OUTSIDE_LIT_BOX: f32 = 0.0;

// Slot i's importance factor at the tree point: LIGHT_OUTSIDE_LIT_BOX outside the box around
// every point its lights light (crate::lit_boxes), else 1. The boxes follow the directional
// leaves, one per tree slot, encoded as light_tree.rs's lit_box_slot says.
fn lit_factor(i: u32) -> f32 {
    if !LIT_BOXES || frame.light_tree_lit_boxes == 0u {
        return 1.0;
    }
    let b = light_tree_slot(frame.light_tree_slots + frame.directional_lights + i);
    let low = bitcast<vec3f>(vec3u(b.children, b.centre_a, b.centre_b));
    let high = bitcast<vec3f>(vec3u(b.radii_cos_e, b.axis_a, b.axis_b));
    let inside = all(tree_point >= low) && all(tree_point <= high);
    return select(LIGHT_OUTSIDE_LIT_BOX, 1.0, inside);
}

// The first of two children (in slots i and i + 1) at the point: its share of their importance,
// each times its lit_factor, or of their power where both are zero (or underflow), so that every
// light with power keeps a positive probability wherever the estimate fails (light_tree.rs,
// first_child_share).
fn first_child_share(a: NodeBounds, b: NodeBounds, i: u32) -> f32 {
    let ia = light_bounds_importance(a, tree_point_rel, tree_normal) * lit_factor(i);
    let ib = light_bounds_importance(b, tree_point_rel, tree_normal) * lit_factor(i + 1u);
    if ia + ib > 0.0 {
        return ia / (ia + ib);
    }
    return a.phi / (a.phi + b.phi);
}

// Where the walk stands: a node's slot, its decoded sphere, and whether it is a leaf.
struct TreeAt {
    slot: u32,
    centre: vec3f,
    radius: f32,
    leaf: bool,
}

// The root (light_tree.rs, root_slot): slot 0 holds its centre, the origin of every decoded
// sphere, and radius; sets tree_point_rel.
fn tree_root() -> TreeAt {
    let s = light_tree_slot(0u);
    tree_point_rel = tree_point - bitcast<vec3f>(vec3u(s.centre_a, s.centre_b, s.radii_cos_e));
    return TreeAt(s.children & LIGHT_TREE_INDEX, vec3f(0.0), bitcast<f32>(s.axis_a), (s.children & LIGHT_TREE_LEAF) != 0u);
}

// One step of the walk, and of its retracing: the inner node `at`'s children decoded from its one
// slot, and the first one's probability at the tree point.
struct TreeStep {
    first: NodeBounds,
    second: NodeBounds,
    p0: f32,
    children: u32,
}

fn tree_step(at: TreeAt) -> TreeStep {
    let s = light_tree_slot(at.slot);
    let first = tree_child(s, 0u, at.centre, at.radius);
    let second = tree_child(s, 1u, at.centre, at.radius);
    return TreeStep(first, second, first_child_share(first, second, s.children & LIGHT_TREE_INDEX), s.children);
}

// Child c of the step's node, as where the walk stands next.
fn tree_descend(step: TreeStep, c: u32) -> TreeAt {
    let second = c == 1u;
    let centre = select(step.first.centre, step.second.centre, second);
    let radius = select(step.first.radius, step.second.radius, second);
    return TreeAt((step.children & LIGHT_TREE_INDEX) + c, centre, radius, ((step.children >> c) & LIGHT_TREE_LEAF) != 0u);
}

// The probability of choosing any one directional light: each gets one share and the tree one
// (pbrt-v4's pInfinite).
fn directional_share() -> f32 {
    return 1.0 / f32(frame.directional_lights + select(0u, 1u, frame.light_tree_slots > 0u));
}

// A light chosen at the tree point, with its probability; u is remapped at every step (as
// alias_pick remaps) so that the sample's stratification carries over to the point on the light.
fn select_light_from_tree(u_in: f32) -> SelectedLight {
    if frame.light_tree_slots == 0u && frame.directional_lights == 0u {
        // No light has power: nothing to choose.
        return SelectedLight(DiscretePick(0u, u_in), 0.0);
    }
    var u = u_in;
    let share = directional_share();
    let directional = f32(frame.directional_lights) * share;
    if u < directional {
        let k = min(u32(u / share), frame.directional_lights - 1u);
        let light = light_tree_slot(frame.light_tree_slots + k).children;
        let start = f32(k) * share;
        return SelectedLight(DiscretePick(light, clamp((u - start) / share, 0.0, ONE_MINUS_EPSILON)), share);
    }
    u = remap_above(u, directional);
    var pmf = share;
    var at = tree_root();
    // A leaf lies at most MAX_LIGHT_TREE_DEPTH steps down (a light's path is 32 bits); the bound
    // keeps a malformed tree from looping.
    var depth = 0u;
    if !at.leaf {
        // Tested at its end (megakernel.wgsl's `render` says why).
        loop {
            let step = tree_step(at);
            var c = 0u;
            if u < step.p0 {
                u = remap_below(u, step.p0);
                pmf *= step.p0;
            } else {
                u = remap_above(u, step.p0);
                pmf *= 1.0 - step.p0;
                c = 1u;
            }
            at = tree_descend(step, c);
            depth++;
            if at.leaf || depth >= MAX_LIGHT_TREE_DEPTH {
                break;
            }
        }
    }
    // A leaf's slot holds its light.
    let light = light_tree_slot(at.slot).children;
    return SelectedLight(DiscretePick(light, u), select(0.0, pmf, at.leaf));
}

// The probability that select_light_from_tree chooses light `index` at the tree point: down the
// light's path (LightPick.tree_trail), the same shares it would have drawn from.
fn light_tree_pmf(index: u32) -> f32 {
    if light_at(index).kind == LIGHT_DIRECTIONAL {
        return directional_share();
    }
    var trail = light_pick_at(index).tree_trail;
    if trail == 0xffffffffu || frame.light_tree_slots == 0u {
        return 0.0;
    }
    var pmf = directional_share();
    var at = tree_root();
    var depth = 0u;
    if !at.leaf {
        loop {
            let step = tree_step(at);
            let c = trail & 1u;
            pmf *= select(step.p0, 1.0 - step.p0, c == 1u);
            at = tree_descend(step, c);
            trail >>= 1u;
            depth++;
            if at.leaf || depth >= MAX_LIGHT_TREE_DEPTH {
                break;
            }
        }
    }
    return select(0.0, pmf, at.leaf);
}

// traverse.wgsl: BVH2 traversal with a closest-hit query (camera and BRDF rays) and an any-hit
// query (shadow rays), over a watertight ray/triangle test.

const BVH_STACK_SIZE: u32 = 64u;
const RAY_INF: f32 = 3.0e38;

// The traversal stack, shared by both traversals (a ray's traversal ends before the next begins).
// At module scope it is zeroed once per invocation, as WGSL requires of every variable; declared
// in trace_closest and trace_occluded it was zeroed at every call, 64 stores per traversal, which Mesa
// 22.3's lavapipe does not optimise away: 0.75-0.84x the render time there (docs/performance.md,
// "The traversal stack at module scope").
var<private> bvh_stack: array<u32, BVH_STACK_SIZE>;

struct Hit {
    t: f32,
    // Barycentrics of p1 and p2.
    b1: f32,
    b2: f32,
    tri: u32,
    found: bool,
}

// A triangle's corner positions, gathered from the shared vertices.
struct TrianglePositions {
    p0: vec3f,
    p1: vec3f,
    p2: vec3f,
}

fn triangle_positions(t: IndexedTriangle) -> TrianglePositions {
    return TrianglePositions(vertices[t.v0].p, vertices[t.v1].p, vertices[t.v2].p);
}

// The same for triangle i, loading only its vertex indices.
fn triangle_corners(i: u32) -> TrianglePositions {
    return TrianglePositions(vertices[triangles[i].v0].p, vertices[triangles[i].v1].p, vertices[triangles[i].v2].p);
}

// Precomputed per-ray constants of the watertight test.
struct RayShear {
    kx: u32,
    ky: u32,
    kz: u32,
    s: vec3f,
}

fn max_dim(v: vec3f) -> u32 {
    if v.x > v.y {
        return select(2u, 0u, v.x > v.z);
    }
    return select(2u, 1u, v.y > v.z);
}

// v[i] by selects: dynamic indexing of a vector spills it to memory on some drivers (lavapipe).
fn component(v: vec3f, i: u32) -> f32 {
    return select(select(v.z, v.y, i == 1u), v.x, i == 0u);
}

// Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013, §3.
fn ray_shear(dir: vec3f) -> RayShear {
    let kz = max_dim(abs(dir));
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    // Swap kx and ky to keep the winding of the triangle when the dominant axis is negative.
    if component(dir, kz) < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    let dz = component(dir, kz);
    let s = vec3f(component(dir, kx) / dz, component(dir, ky) / dz, 1.0 / dz);
    return RayShear(kx, ky, kz, s);
}

// Returns (t, b1, b2) on a hit with t in (0, t_max), otherwise t = -1.
fn intersect_triangle(origin: vec3f, sh: RayShear, p0: vec3f, p1: vec3f, p2: vec3f, t_max: f32) -> vec3f {
    let a = p0 - origin;
    let b = p1 - origin;
    let c = p2 - origin;
    let az = component(a, sh.kz);
    let bz = component(b, sh.kz);
    let cz = component(c, sh.kz);
    let ax = component(a, sh.kx) - sh.s.x * az;
    let ay = component(a, sh.ky) - sh.s.y * az;
    let bx = component(b, sh.kx) - sh.s.x * bz;
    let by = component(b, sh.ky) - sh.s.y * bz;
    let cx = component(c, sh.kx) - sh.s.x * cz;
    let cy = component(c, sh.ky) - sh.s.y * cz;
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    // Edge functions exactly zero: recompute in double precision, as the paper prescribes.
    // WGSL has no portable f64, so we fall back to treating the edge as inside; the
    // consistent sign test below still makes shared edges watertight.
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec3f(-1.0, 0.0, 0.0);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec3f(-1.0, 0.0, 0.0);
    }
    let t_scaled = u * sh.s.z * az + v * sh.s.z * bz + w * sh.s.z * cz;
    // t = t_scaled / det must lie in (0, t_max); compare without dividing, sign-aware.
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return vec3f(-1.0, 0.0, 0.0);
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return vec3f(-1.0, 0.0, 0.0);
    }
    let inv_det = 1.0 / det;
    return vec3f(t_scaled * inv_det, v * inv_det, w * inv_det);
}

// Slab test; returns the entry distance or RAY_INF on a miss. The exit distance is scaled by
// 1 + 2 * gamma(3) so that rounding cannot make a box the ray grazes look missed
// (Ize, "Robust BVH Ray Traversal", JCGT 2(2), 2013).
fn intersect_aabb(origin: vec3f, inv_dir: vec3f, bmin: vec3f, bmax: vec3f, t_max: f32) -> f32 {
    let t0 = (bmin - origin) * inv_dir;
    let t1 = (bmax - origin) * inv_dir;
    let tnear = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let tfar = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), t_max)) * 1.0000004;
    return select(RAY_INF, tnear, tnear <= tfar);
}

fn safe_inverse(d: vec3f) -> vec3f {
    // A zero component would give inf * 0 = NaN in the slab test when the origin lies on a slab.
    let tiny = 1.0e-30;
    let dd = select(d, select(vec3f(-tiny), vec3f(tiny), d >= vec3f(0.0)), abs(d) < vec3f(tiny));
    return 1.0 / dd;
}

// A traversal's position: an inner node's index, or a leaf's reference (LEAF_BIT set; see
// BvhNode), or NO_NODE (LEAF_BIT set too) once the stack is empty. The stack holds the same.
const LEAF_BIT: u32 = 0x80000000u;
const NO_NODE: u32 = 0xffffffffu;

fn leaf_first(position: u32) -> u32 {
    return position & 0x07ffffffu;
}

fn leaf_count(position: u32) -> u32 {
    return (position >> 27u) & 0xfu;
}

// One step from inner node `node`, given the ray's entry distances to its children (RAY_INF where
// it misses one): the nearer child it enters, with the farther pushed on the stack; the one it
// enters; or, entering neither, the position on top of the stack, or NO_NODE when that is empty.
fn next_node(node: BvhNode, tl: f32, tr: f32, sp: ptr<function, u32>) -> u32 {
    if tl != RAY_INF && tr != RAY_INF {
        let near_is_left = tl <= tr;
        if *sp < BVH_STACK_SIZE {
            bvh_stack[*sp] = select(node.left, node.right, near_is_left);
            *sp += 1u;
        }
        return select(node.right, node.left, near_is_left);
    }
    if tl != RAY_INF {
        return node.left;
    }
    if tr != RAY_INF {
        return node.right;
    }
    if *sp == 0u {
        return NO_NODE;
    }
    *sp -= 1u;
    return bvh_stack[*sp];
}

// Both traversals below are "while-while" loops (Aila & Laine, "Understanding the Efficiency of
// Ray Traversal on GPUs", HPG 2009): the inner loop walks inner nodes until the ray reaches a
// leaf, the outer one tests that leaf's triangles. Rays that run side by side in SIMD lanes
// (lavapipe runs 8 per instruction) then test their triangles together, instead of one lane's
// leaf holding up the others' descent.

// Closest hit along origin + t * dir, t in (0, t_max).
fn trace_closest(origin: vec3f, dir: vec3f, t_max: f32) -> Hit {
    var hit = Hit(t_max, 0.0, 0.0, 0u, false);
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    var sp = 0u;
    var position = 0u;
    loop {
        while position < LEAF_BIT {
            // Ordered traversal: visit the nearer child first, push the farther one.
            let node = bvh_nodes[position];
            let tl = intersect_aabb(origin, inv_dir, node.left_min, node.left_max, hit.t);
            let tr = intersect_aabb(origin, inv_dir, node.right_min, node.right_max, hit.t);
            position = next_node(node, tl, tr, &sp);
        }
        if position == NO_NODE {
            break;
        }
        let first = leaf_first(position);
        for (var i = first; i < first + leaf_count(position); i++) {
            let tri = triangle_corners(i);
            let r = intersect_triangle(origin, sh, tri.p0, tri.p1, tri.p2, hit.t);
            if r.x > 0.0 {
                hit = Hit(r.x, r.y, r.z, i, true);
            }
        }
        if sp == 0u {
            break;
        }
        sp--;
        position = bvh_stack[sp];
    }
    return hit;
}

// Any hit along origin + t * dir, t in (0, t_max): true when the segment is blocked.
fn trace_occluded(origin: vec3f, dir: vec3f, t_max: f32) -> bool {
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    var sp = 0u;
    var position = 0u;
    loop {
        while position < LEAF_BIT {
            let node = bvh_nodes[position];
            let tl = intersect_aabb(origin, inv_dir, node.left_min, node.left_max, t_max);
            let tr = intersect_aabb(origin, inv_dir, node.right_min, node.right_max, t_max);
            position = next_node(node, tl, tr, &sp);
        }
        if position == NO_NODE {
            break;
        }
        let first = leaf_first(position);
        for (var i = first; i < first + leaf_count(position); i++) {
            let tri = triangle_corners(i);
            if intersect_triangle(origin, sh, tri.p0, tri.p1, tri.p2, t_max).x > 0.0 {
                return true;
            }
        }
        if sp == 0u {
            break;
        }
        sp--;
        position = bvh_stack[sp];
    }
    return false;
}

// Ray origin pushed off a surface along its geometric normal, on the side `dir` leaves by.
// Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing
// Gems, ch. 6, 2019: offset in integer ULPs far from the origin, by a fixed epsilon near it.
// Their int_scale of 256 ULPs is for hit points computed as o + t d; ours interpolate the
// vertices with barycentrics, whose error is a few ULPs of |p| (pbrt-v4 §6.8.3 bounds it by
// γ7 Σ|b_i p_i|, about 3.5 ULPs). 32 ULPs keeps a 9× margin; 256 ULPs is 2 units at 1e5 and
// made the Cornell box moved there 13% darker by its contact edges (tests/stress.rs).
fn offset_ray_origin(p: vec3f, ng: vec3f, dir: vec3f) -> vec3f {
    let n = select(-ng, ng, dot(ng, dir) >= 0.0);
    let origin_eps = 1.0 / 32.0;
    let float_scale = 1.0 / 65536.0;
    let int_scale = 32.0;
    let of_i = vec3i(int_scale * n);
    let p_i = vec3f(
        bitcast<f32>(bitcast<i32>(p.x) + select(of_i.x, -of_i.x, p.x < 0.0)),
        bitcast<f32>(bitcast<i32>(p.y) + select(of_i.y, -of_i.y, p.y < 0.0)),
        bitcast<f32>(bitcast<i32>(p.z) + select(of_i.z, -of_i.z, p.z < 0.0)),
    );
    return select(p_i, p + float_scale * n, abs(p) < vec3f(origin_eps));
}

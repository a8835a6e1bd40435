// traverse.wgsl: what both traversals share, traverse_bvh.wgsl's 4-wide BVH and traverse_baked.wgsl's
// triangles compiled into the kernel: the watertight ray/triangle test, the slab test, and rays'
// origins offset off surfaces. Each of the two defines trace_closest (camera and BRDF rays) and
// trace_occluded (shadow rays).

const RAY_INF: f32 = 3.0e38;

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
    return TrianglePositions(vertex_at(t.v0).p, vertex_at(t.v1).p, vertex_at(t.v2).p);
}

// The same for triangle i.
fn triangle_corners(i: u32) -> TrianglePositions {
    return triangle_positions(triangle_at(i));
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

// The watertight test's edge functions in the ray's sheared frame (u, v, w: the weights of p0, p1
// and p2, unnormalised), the corners' scaled z, and the distance scaled by u + v + w.
struct ShearedTriangle {
    u: f32,
    v: f32,
    w: f32,
    z: vec3f,
    t_scaled: f32,
}

fn sheared_triangle(origin: vec3f, sh: RayShear, p0: vec3f, p1: vec3f, p2: vec3f) -> ShearedTriangle {
    let a = p0 - origin;
    let b = p1 - origin;
    let c = p2 - origin;
    // z scaled per corner (the paper's Az = Sz * A[kz]), which triangles sharing a corner share.
    let az = component(a, sh.kz);
    let bz = component(b, sh.kz);
    let cz = component(c, sh.kz);
    let ax = component(a, sh.kx) - sh.s.x * az;
    let ay = component(a, sh.ky) - sh.s.y * az;
    let bx = component(b, sh.kx) - sh.s.x * bz;
    let by = component(b, sh.ky) - sh.s.y * bz;
    let cx = component(c, sh.kx) - sh.s.x * cz;
    let cy = component(c, sh.ky) - sh.s.y * cz;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let z = sh.s.z * vec3f(az, bz, cz);
    return ShearedTriangle(u, v, w, z, u * z.x + v * z.y + w * z.z);
}

// Returns (t, b1, b2) on a hit with t in (0, t_max), otherwise t = -1.
fn intersect_triangle(origin: vec3f, sh: RayShear, p0: vec3f, p1: vec3f, p2: vec3f, t_max: f32) -> vec3f {
    let e = sheared_triangle(origin, sh, p0, p1, p2);
    // Edge functions exactly zero: recompute in double precision, as the paper prescribes.
    // WGSL has no portable f64, so we fall back to treating the edge as inside; the
    // consistent sign test below still makes shared edges watertight. Outside: signs differ.
    let outside = (e.u < 0.0 || e.v < 0.0 || e.w < 0.0) && (e.u > 0.0 || e.v > 0.0 || e.w > 0.0);
    let det = e.u + e.v + e.w;
    // The paper compares t_scaled with t_max * det, sign-aware, to divide only for hits; without
    // branches the division runs anyway, and testing t itself is 8 instructions fewer (Cornell box
    // 0.94x on lavapipe). det = 0 gives t = inf or NaN, which fails the range test.
    let inv_det = 1.0 / det;
    let t = e.t_scaled * inv_det;
    let in_front = t > 0.0 && t < t_max;
    // Tests and selects, no branches: a branch per test costs lavapipe's 8 lanes a mask check each,
    // which made the baked triangles (traverse_baked.wgsl) 1.45x slower; neutral in BVH leaves.
    return select(vec3f(-1.0, 0.0, 0.0), vec3f(t, e.v * inv_det, e.w * inv_det), !outside && in_front);
}

// (t, b1, b2) of the point of the triangle's plane nearest the ray's crossing inside the triangle,
// for a ray known to meet it (traverse_baked.wgsl's camera list): intersect_triangle's values bit
// for bit where that test finds the ray inside (the signs flipped to det's are exact negations),
// and where rounding puts the ray just outside (within rounding of an edge) the edge functions
// clamped to zero, a point on that edge. t = -1 where all three clamp away.
fn intersect_triangle_clamped(origin: vec3f, sh: RayShear, p0: vec3f, p1: vec3f, p2: vec3f) -> vec3f {
    let e = sheared_triangle(origin, sh, p0, p1, p2);
    let s = select(1.0, -1.0, e.u + e.v + e.w < 0.0);
    let u = max(s * e.u, 0.0);
    let v = max(s * e.v, 0.0);
    let w = max(s * e.w, 0.0);
    let det = u + v + w;
    let inv_det = 1.0 / det;
    let clamped = s * e.u < 0.0 || s * e.v < 0.0 || s * e.w < 0.0;
    let t_scaled = select(s * e.t_scaled, u * e.z.x + v * e.z.y + w * e.z.z, clamped);
    return select(vec3f(-1.0, 0.0, 0.0), vec3f(t_scaled * inv_det, v * inv_det, w * inv_det), det > 0.0);
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

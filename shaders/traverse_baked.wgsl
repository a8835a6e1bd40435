// traverse_baked.wgsl: the traversal of a scene small enough to need no BVH, on CPU adapters
// (crates/veach/src/gpu/baked_triangles.rs decides): every ray tests every triangle, and the
// triangles' corners are constants in the kernel. The host writes one line per triangle, in the
// BVH's triangle order, where the `{baked ...}` lines stand. On lavapipe a BVH step gathers its
// node lane by lane, some 600 instructions; a triangle whose corners are constants costs about 50,
// with no loads at all (the same corners read from a uniform array at constant indices cost more
// than the BVH): the Cornell box's 36 triangles render in 0.68x the BVH's time, the same image bit
// for bit (docs/performance.md, "Small scenes compiled into the kernel"). Where the driver branches
// around code no lane runs (Mesa 25, not 22.3), each compact group of triangles (a block in a room:
// a small BVH subtree) is tested only where the ray meets its box, the text after ` | ` in those
// lines (Cornell box 0.86-0.89x on Mesa 25).

// Closest hit along origin + t * dir, t in (0, t_max).
fn trace_closest(origin: vec3f, dir: vec3f, t_max: f32) -> Hit {
    var hit = Hit(t_max, 0.0, 0.0, 0u, false);
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    {baked closest_candidate(&hit, origin, sh, p0, p1, p2, triangle); | intersect_aabb(origin, inv_dir, lo, hi, hit.t) < RAY_INF}
    return with_barycentrics(hit, origin, sh);
}

// The closest hit of a camera ray, in kernels where CAMERA_LIST says the camera's eye o is the one
// the list was built for. With a = p0 - o, b = p1 - o, c = p2 - o, the ray o + t d
// crosses the triangle where the signed volumes u = d · (b × c), v = d · (c × a), w = d · (a × b)
// share a sign, at t = a · (b × c) / (u + v + w): Plücker's edge test with the edges' moments taken
// about the eye, where each becomes a plane through it (Jones, "Intersecting a Ray and a Triangle
// with Plücker Coordinates", Ray Tracing News 13(1), 2000). The host computes the three normals
// and the volume once per triangle, oriented so that inside means all three >= 0
// (BakedTriangles::set_camera_eye): per triangle three dot products and a division, where the
// watertight test shears all three corners per ray. A shared edge's two planes are exact negatives
// of each other, so the list is as watertight as that test. The winner's t and barycentrics are
// then the watertight test's (intersect_triangle_clamped): the BVH's hit bit for bit wherever the
// two tests pick the same triangle, which they may not for a ray within rounding of an edge or of
// two surfaces at the same distance.
fn trace_camera(dir: vec3f) -> Hit {
    let origin = frame.camera.origin;
    var hit = Hit(RAY_INF, 0.0, 0.0, 0u, false);
    let inv_dir = safe_inverse(dir);
    {baked camera: camera_candidate(&hit, dir, n0, n1, n2, volume, triangle); | intersect_aabb(origin, inv_dir, lo, hi, hit.t) < RAY_INF}
    let v = triangle_corners(hit.tri);
    let r = intersect_triangle_clamped(origin, ray_shear(dir), v.p0, v.p1, v.p2);
    return Hit(select(hit.t, r.x, r.x > 0.0), r.y, r.z, hit.tri, hit.found);
}

// Triangle `triangle` is the camera ray's new closest hit if it lies inside the three edge planes
// n0, n1, n2 (through the eye) before the closest so far. volume / (u + v + w) is +inf where all
// three are zero (a ray along the triangle's plane), which is no hit.
fn camera_candidate(hit: ptr<function, Hit>, dir: vec3f, n0: vec3f, n1: vec3f, n2: vec3f, volume: f32, triangle: u32) {
    let u = dot(dir, n0);
    let v = dot(dir, n1);
    let w = dot(dir, n2);
    let t = volume / (u + v + w);
    let nearer = min(min(u, v), w) >= 0.0 && t < (*hit).t;
    *hit = Hit(select((*hit).t, t, nearer), 0.0, 0.0, select((*hit).tri, triangle, nearer), (*hit).found || nearer);
}

// The closest hit along origin + t * dir, t in (0, t_max), among the emitting triangles alone: what
// a direction sample meets where EMITTER_LIST (features.wgsl) says so; the list is empty otherwise.
// Behind boxes like the other lists.
fn trace_emitters(origin: vec3f, dir: vec3f, t_max: f32) -> Hit {
    var hit = Hit(t_max, 0.0, 0.0, 0u, false);
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    {baked emitters: closest_candidate(&hit, origin, sh, p0, p1, p2, triangle); | intersect_aabb(origin, inv_dir, lo, hi, hit.t) < RAY_INF}
    return with_barycentrics(hit, origin, sh);
}

// Any hit along origin + t * dir, t in (0, t_max): true when the segment is blocked.
// Each test returns where it blocks the ray: once all of lavapipe's 8 lanes have returned, the
// rest is skipped (0.97x the render time of or-ing every test into one flag).
// `skip` (traverse_bvh.wgsl) is for the BVH; these kernels leave out, once and for all, the
// triangles that no shadow ray can meet (BakedTriangles::mark_blockers: the walls of a room, a
// planar light).
fn trace_occluded(origin: vec3f, dir: vec3f, t_max: f32, skip: u32) -> bool {
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    {baked blockers: if intersect_triangle(origin, sh, p0, p1, p2, t_max).x > 0.0 { return true; } | intersect_aabb(origin, inv_dir, lo, hi, t_max) < RAY_INF}
    return false;
}

// Triangle `triangle` (an index into `triangles`) is the new closest hit if the ray meets it before
// the closest so far. Selects, no branch (see intersect_triangle). Only t and the triangle are kept
// through the list; with_barycentrics finds the winner's barycentrics after it: two fewer values
// live across the list, where Mesa 22.3's LLVM spills (Cornell box 0.92-0.97x there,
// docs/performance.md, "Barycentrics after the baked list").
fn closest_candidate(hit: ptr<function, Hit>, origin: vec3f, sh: RayShear, p0: vec3f, p1: vec3f, p2: vec3f, triangle: u32) {
    let r = intersect_triangle(origin, sh, p0, p1, p2, (*hit).t);
    let nearer = r.x > 0.0;
    *hit = Hit(select((*hit).t, r.x, nearer), 0.0, 0.0, select((*hit).tri, triangle, nearer), (*hit).found || nearer);
}

// The closest hit with its barycentrics: the watertight test run again on the winning triangle, its
// corners read from the vertex buffer (the values the baked constants spell), gives the (b1, b2) it
// gave in the list: the same inputs, and its t_max only decides whether it reports a hit.
fn with_barycentrics(hit: Hit, origin: vec3f, sh: RayShear) -> Hit {
    let v = triangle_corners(hit.tri);
    let r = intersect_triangle(origin, sh, v.p0, v.p1, v.p2, RAY_INF);
    return Hit(hit.t, r.y, r.z, hit.tri, hit.found);
}

// Camera rays by their pixel's footprint list (crates/veach/src/gpu/camera_footprints.rs), in
// kernels where FOOTPRINT_SLOTS (below, written by the host) is not zero: the few triangles a ray
// through the pixel can meet first, of those trace_camera tests, in the same order and by the same
// edge planes, so the same winner. Each invocation reads its pixel's list once (load_camera_slots)
// into private slots that every camera sample's ray then tests: FOOTPRINT_SLOTS plane tests a
// ray where trace_camera makes one per triangle. An empty slot (triangle 255) reads the table's
// last entry, all zeros, which no ray meets (camera_candidate: t = volume / 0 is not below t).
struct CameraSlot {
    n0: vec3f,
    n1: vec3f,
    n2: vec3f,
    volume: f32,
    tri: u32,
}

// Indexed by constants only, so that the driver keeps them in registers.
var<private> camera_slots: array<CameraSlot, 8>;

{footprint declarations}

fn camera_slot(tri: u32) -> CameraSlot {
    let i = min(tri, FOOTPRINT_TRIANGLES) * 12u;
    let a = vec4f(bitcast<f32>(footprint_word(i)), bitcast<f32>(footprint_word(i + 1u)), bitcast<f32>(footprint_word(i + 2u)), bitcast<f32>(footprint_word(i + 3u)));
    let b = vec3f(bitcast<f32>(footprint_word(i + 4u)), bitcast<f32>(footprint_word(i + 5u)), bitcast<f32>(footprint_word(i + 6u)));
    let c = vec3f(bitcast<f32>(footprint_word(i + 8u)), bitcast<f32>(footprint_word(i + 9u)), bitcast<f32>(footprint_word(i + 10u)));
    return CameraSlot(a.xyz, b, c, a.w, tri);
}

// `pixel`: the pixel's index in the render's rows (the lists are built for them).
fn load_camera_slots(pixel: u32) {
    if FOOTPRINT_SLOTS == 0u {
        return;
    }
    let base = FOOTPRINT_LISTS_OFFSET + pixel * FOOTPRINT_WORDS;
    let w0 = footprint_word(base);
    var w1 = 0xffffffffu;
    if FOOTPRINT_WORDS > 1u {
        w1 = footprint_word(base + 1u);
    }
    camera_slots[0] = camera_slot(w0 & 0xffu);
    if FOOTPRINT_SLOTS > 1u { camera_slots[1] = camera_slot((w0 >> 8u) & 0xffu); }
    if FOOTPRINT_SLOTS > 2u { camera_slots[2] = camera_slot((w0 >> 16u) & 0xffu); }
    if FOOTPRINT_SLOTS > 3u { camera_slots[3] = camera_slot(w0 >> 24u); }
    if FOOTPRINT_SLOTS > 4u { camera_slots[4] = camera_slot(w1 & 0xffu); }
    if FOOTPRINT_SLOTS > 5u { camera_slots[5] = camera_slot((w1 >> 8u) & 0xffu); }
    if FOOTPRINT_SLOTS > 6u { camera_slots[6] = camera_slot((w1 >> 16u) & 0xffu); }
    if FOOTPRINT_SLOTS > 7u { camera_slots[7] = camera_slot(w1 >> 24u); }
}

fn slot_candidate(hit: ptr<function, Hit>, dir: vec3f, s: CameraSlot) {
    camera_candidate(hit, dir, s.n0, s.n1, s.n2, s.volume, s.tri);
}

// trace_camera over the pixel's slots: the same winner, then the same watertight hit.
fn trace_camera_slots(dir: vec3f) -> Hit {
    let origin = frame.camera.origin;
    var hit = Hit(RAY_INF, 0.0, 0.0, 0u, false);
    slot_candidate(&hit, dir, camera_slots[0]);
    if FOOTPRINT_SLOTS > 1u { slot_candidate(&hit, dir, camera_slots[1]); }
    if FOOTPRINT_SLOTS > 2u { slot_candidate(&hit, dir, camera_slots[2]); }
    if FOOTPRINT_SLOTS > 3u { slot_candidate(&hit, dir, camera_slots[3]); }
    if FOOTPRINT_SLOTS > 4u { slot_candidate(&hit, dir, camera_slots[4]); }
    if FOOTPRINT_SLOTS > 5u { slot_candidate(&hit, dir, camera_slots[5]); }
    if FOOTPRINT_SLOTS > 6u { slot_candidate(&hit, dir, camera_slots[6]); }
    if FOOTPRINT_SLOTS > 7u { slot_candidate(&hit, dir, camera_slots[7]); }
    let v = triangle_corners(hit.tri);
    let r = intersect_triangle_clamped(origin, ray_shear(dir), v.p0, v.p1, v.p2);
    return Hit(select(hit.t, r.x, r.x > 0.0), r.y, r.z, hit.tri, hit.found);
}

// traverse_bvh.wgsl: 4-wide BVH traversal with a closest-hit query (camera and BRDF rays) and an
// any-hit query (shadow rays), over traverse.wgsl's watertight ray/triangle test. Scenes of at
// most 64 triangles on CPU adapters use traverse_baked.wgsl instead (BAKED_TRIANGLES_MAX).

// The emitters' grid (crates/veach/src/gpu/emitter_grid.rs), where the kernel has one
// (DriverTuning::emitter_grid; EMITTER_LIST, features.wgsl), read by emitter_grid_word (declared with
// the bindings, gpu/bindings.rs).
fn emitter_grid_vec3f(i: u32) -> vec3f {
    return vec3f(bitcast<f32>(emitter_grid_word(i)), bitcast<f32>(emitter_grid_word(i + 1u)), bitcast<f32>(emitter_grid_word(i + 2u)));
}

// Words before the cells' starts (emitter_grid::HEADER_WORDS): lo, res.x, hi, res.y, scale, res.z.
const EMITTER_GRID_HEADER: u32 = 12u;

// The nearest emitting triangle along origin + t * dir, t in (0, t_max), from the emitters' grid:
// the cells the ray crosses in order (Amanatides & Woo 1987), each cell's triangles by the same
// watertight test as trace_closest, until the nearest hit lies within the cell the walk is in.
// A triangle is listed in every cell its box, grown by a margin far above the rounding of these
// distances, overlaps (emitter_grid.rs), so a hit just past a boundary is in the cell before it too.
fn trace_emitters(origin: vec3f, dir: vec3f, t_max: f32) -> Hit {
    var hit = Hit(t_max, 0.0, 0.0, 0u, false);
    let lo = emitter_grid_vec3f(0u);
    let hi = emitter_grid_vec3f(4u);
    let scale = emitter_grid_vec3f(8u);
    let res = vec3i(vec3u(emitter_grid_word(3u), emitter_grid_word(7u), emitter_grid_word(11u)));
    let inv_dir = safe_inverse(dir);
    // The ray's part inside the grid's box (as intersect_aabb).
    let t_lo = (lo - origin) * inv_dir;
    let t_hi = (hi - origin) * inv_dir;
    let t_enter = max(max(min(t_lo.x, t_hi.x), min(t_lo.y, t_hi.y)), max(min(t_lo.z, t_hi.z), 0.0));
    let t_leave = min(min(max(t_lo.x, t_hi.x), max(t_lo.y, t_hi.y)), min(max(t_lo.z, t_hi.z), t_max)) * 1.0000004;
    if !(t_enter <= t_leave) {
        return hit;
    }
    let ahead = dir >= vec3f(0.0);
    let step = select(vec3i(-1), vec3i(1), ahead);
    var cell = clamp(vec3i(floor((origin + t_enter * dir - lo) * scale)), vec3i(0), res - vec3i(1));
    // Where the ray crosses the cell's next boundary along each axis, and the distance between
    // boundaries (safe_inverse keeps both finite where a component is zero, and far).
    var t_next = (lo + vec3f(cell + select(vec3i(0), vec3i(1), ahead)) / scale - origin) * inv_dir;
    let t_delta = abs(inv_dir / scale);
    let cells_start = EMITTER_GRID_HEADER;
    let entries_start = cells_start + u32(res.x * res.y * res.z) + 1u;
    let sh = ray_shear(dir);
    // Like every loop here, tested at the end of its body (megakernel.wgsl's `render` says why).
    loop {
        let c = u32((cell.z * res.y + cell.y) * res.x + cell.x);
        var i = emitter_grid_word(cells_start + c);
        let end = emitter_grid_word(cells_start + c + 1u);
        if i < end {
            loop {
                let tri = emitter_grid_word(entries_start + i);
                let p = triangle_corners(tri);
                let r = intersect_triangle(origin, sh, p.p0, p.p1, p.p2, hit.t);
                if r.x > 0.0 {
                    hit = Hit(r.x, r.y, r.z, tri, true);
                }
                i++;
                if i >= end {
                    break;
                }
            }
        }
        let t_cell_exit = min(t_next.x, min(t_next.y, t_next.z));
        // The nearest hit (or t_max) lies within this cell, or the ray leaves the box here.
        if hit.t <= t_cell_exit || t_cell_exit > t_leave {
            break;
        }
        if t_next.x <= t_next.y && t_next.x <= t_next.z {
            cell.x += step.x;
            t_next.x += t_delta.x;
        } else if t_next.y <= t_next.z {
            cell.y += step.y;
            t_next.y += t_delta.y;
        } else {
            cell.z += step.z;
            t_next.z += t_delta.z;
        }
        if any(cell < vec3i(0)) || any(cell >= res) {
            break;
        }
    }
    return hit;
}

// Nor do they have a camera list: CAMERA_LIST is false for them, and this is never called.
fn trace_camera(dir: vec3f) -> Hit {
    return Hit(RAY_INF, 0.0, 0.0, 0u, false);
}

// Nor footprint lists (traverse_baked.wgsl): FOOTPRINT_SLOTS is zero, and these are never called.
const FOOTPRINT_SLOTS: u32 = 0u;
fn load_camera_slots(pixel: u32) {}
fn trace_camera_slots(dir: vec3f) -> Hit {
    return Hit(RAY_INF, 0.0, 0.0, 0u, false);
}

// BVH_STACK_SIZE is declared with the bindings (gpu/bindings.rs, wgsl_declarations): deeper
// trees get a larger stack.

// The traversal stack's entries below the top WINDOW (TraversalStack), shared by both traversals
// (a ray's traversal ends before the next begins). At module scope it is zeroed once per
// invocation, as WGSL requires of every variable; declared in trace_closest and trace_occluded it
// was zeroed at every call, 64 stores per traversal, which Mesa 22.3's lavapipe does not optimise
// away: 0.75-0.84x the render time there (docs/performance.md, "The traversal stack at module
// scope").
var<private> bvh_stack: array<u32, BVH_STACK_SIZE>;

// A traversal's position: an inner node's index, or a leaf's reference (LEAF_BIT set; see
// BvhNode), or NO_NODE (LEAF_BIT set too) once the stack is empty. The stack holds the same.
// NO_NODE is also an empty child slot's reference (NO_CHILD on the host).
const LEAF_BIT: u32 = 0x80000000u;
const NO_NODE: u32 = 0xffffffffu;

fn leaf_first(position: u32) -> u32 {
    return position & 0x07ffffffu;
}

fn leaf_count(position: u32) -> u32 {
    return (position >> 27u) & 0xfu;
}

// The ray's entry distances to node n's four children (RAY_INF where it misses one): traverse.wgsl's
// slab test on four boxes at once, decoded from their 8-bit cells (layout.wgsl's BvhNode). A bound
// is origin + q * 2^e, exact in the product (q <= 255, e <= 120), so the host's outward rounding
// holds whether or not the driver fuses the multiply-add.
fn child_distances(n: BvhNode, origin: vec3f, inv_dir: vec3f, t_max: f32) -> vec4f {
    let grid = n.origin;
    let exponents = n.exponents;
    let low = n.low;
    let high = n.high;
    let cell = vec3f(
        bitcast<f32>((exponents & 0xffu) << 23u),
        bitcast<f32>(((exponents >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((exponents >> 16u) & 0xffu) << 23u),
    );
    let shifts = vec4u(0u, 8u, 16u, 24u);
    var lo_x = grid.x + vec4f((vec4u(low.x) >> shifts) & vec4u(0xffu)) * cell.x;
    var lo_y = grid.y + vec4f((vec4u(low.y) >> shifts) & vec4u(0xffu)) * cell.y;
    var lo_z = grid.z + vec4f((vec4u(low.z) >> shifts) & vec4u(0xffu)) * cell.z;
    var hi_x = grid.x + vec4f((vec4u(high.x) >> shifts) & vec4u(0xffu)) * cell.x;
    var hi_y = grid.y + vec4f((vec4u(high.y) >> shifts) & vec4u(0xffu)) * cell.y;
    var hi_z = grid.z + vec4f((vec4u(high.z) >> shifts) & vec4u(0xffu)) * cell.z;
    // Axes no grid spans (coordinates near f32's limits): unbounded for every child.
    if (exponents >> 24u) != 0u {
        let big = vec4f(3.4028235e38);
        let unbounded = (vec3u(exponents) & vec3u(0x1000000u, 0x2000000u, 0x4000000u)) != vec3u(0u);
        lo_x = select(lo_x, -big, unbounded.x);
        hi_x = select(hi_x, big, unbounded.x);
        lo_y = select(lo_y, -big, unbounded.y);
        hi_y = select(hi_y, big, unbounded.y);
        lo_z = select(lo_z, -big, unbounded.z);
        hi_z = select(hi_z, big, unbounded.z);
    }
    let t0x = (lo_x - origin.x) * inv_dir.x;
    let t1x = (hi_x - origin.x) * inv_dir.x;
    let t0y = (lo_y - origin.y) * inv_dir.y;
    let t1y = (hi_y - origin.y) * inv_dir.y;
    let t0z = (lo_z - origin.z) * inv_dir.z;
    let t1z = (hi_z - origin.z) * inv_dir.z;
    let tnear = max(max(min(t0x, t1x), min(t0y, t1y)), max(min(t0z, t1z), vec4f(0.0)));
    // As intersect_aabb: the exit scaled by 1 + 2 * gamma(3) (Ize 2013).
    let tfar = min(min(max(t0x, t1x), max(t0y, t1y)), min(max(t0z, t1z), vec4f(t_max))) * 1.0000004;
    return select(vec4f(RAY_INF), tnear, tnear <= tfar);
}

// Entries (distance's bits, reference) a and b in ascending order of distance: distances are
// non-negative, so their bits order as they do.
fn order_pair(a: ptr<function, vec2u>, b: ptr<function, vec2u>) {
    let swap = (*b).x < (*a).x;
    let low = select(*a, *b, swap);
    *b = select(*b, *a, swap);
    *a = low;
}

// The traversal stack: its top WINDOW entries in registers (one vec4u, read and written by
// selects), the entries below them in bvh_stack, which lavapipe stores to and loads from lane by
// lane (a mask test, a branch and a scalar access each). Entries [bottom, sp) are in the window,
// entry k in slot k % WINDOW; entries [0, bottom) in bvh_stack. A push onto a full window first
// spills its oldest entry, in a loop of zero or one turn: Mesa 22.3 runs an `if`'s code under a
// mask whether a lane takes it or not, lane-by-lane store included, but ends a loop once no lane
// goes on. A pop from an empty window reads memory under an `if` (as fast, and an `if` spends
// none of Mesa 22's loop budget, loop_budget_held; the spill's loop spends one a push). Veach
// scene 0.85-0.86x on Mesa 22.3, 0.80x on Mesa 25 (docs/performance.md, "The stack's top in
// registers").
const WINDOW: u32 = 4u;

struct TraversalStack {
    window: vec4u,
    sp: u32,
    bottom: u32,
}

fn empty_stack() -> TraversalStack {
    return TraversalStack(vec4u(NO_NODE), 0u, 0u);
}

// Slot k % WINDOW of the window, by selects (a vector indexed at run time goes to memory).
fn window_slot(s: ptr<function, TraversalStack>, k: u32) -> u32 {
    let w = (*s).window;
    let slot = k % WINDOW;
    return select(select(select(w.w, w.z, slot == 2u), w.y, slot == 1u), w.x, slot == 0u);
}

fn push(node: u32, s: ptr<function, TraversalStack>) {
    let k = (*s).sp;
    if k >= BVH_STACK_SIZE + WINDOW {
        return;
    }
    // A full window's oldest entry, `bottom`, is in the slot entry k takes.
    if k - (*s).bottom == WINDOW {
        bvh_stack[(*s).bottom] = window_slot(s, k);
        (*s).bottom += 1u;
    }
    (*s).window = select((*s).window, vec4u(node), vec4u(k % WINDOW) == vec4u(0u, 1u, 2u, 3u));
    (*s).sp = k + 1u;
}

// The entry on top of a non-empty stack, taken off it.
fn pop(s: ptr<function, TraversalStack>) -> u32 {
    (*s).sp -= 1u;
    var node = window_slot(s, (*s).sp);
    // An empty window: the entry is the top of memory's.
    if (*s).sp < (*s).bottom {
        node = bvh_stack[(*s).sp];
        (*s).bottom = (*s).sp;
    }
    return node;
}

// One step from inner node `n`, given the ray's entry distances to its children (RAY_INF where
// it misses one): the nearest child it enters, with the others it enters pushed on the stack,
// farthest first; or, entering none, the position on top of the stack, or NO_NODE when that is
// empty. Ordered traversal: the closest hit found in a near child culls the far ones.
fn next_node(n: BvhNode, t: vec4f, stack: ptr<function, TraversalStack>) -> u32 {
    let children = n.children;
    let hit = select(vec4f(RAY_INF), t, children != vec4u(NO_NODE));
    // A sorting network of four (Knuth, TAOCP vol. 3, §5.3.4) on (distance, reference) pairs.
    let bits = bitcast<vec4u>(hit);
    var e0 = vec2u(bits.x, children.x);
    var e1 = vec2u(bits.y, children.y);
    var e2 = vec2u(bits.z, children.z);
    var e3 = vec2u(bits.w, children.w);
    order_pair(&e0, &e1);
    order_pair(&e2, &e3);
    order_pair(&e0, &e2);
    order_pair(&e1, &e3);
    order_pair(&e1, &e2);
    let missed = bitcast<u32>(RAY_INF);
    // The entered children past the nearest (e1, e2, e3 in order), pushed farthest first by one
    // push in a loop: Mesa 22.3 runs every `if`'s code under a mask whether a lane takes it or
    // not, but ends a loop once no lane goes on (the Veach scene 0.97-0.98x there, when every push
    // went to memory; three pushes under `if`s before). Like every loop here it tests its end as
    // the last statement of its body, or Mesa 22.3 runs the body once more with no lane active
    // (megakernel.wgsl's `render`).
    var k = u32(e1.x != missed) + u32(e2.x != missed) + u32(e3.x != missed);
    if k > 0u {
        loop {
            push(select(select(e3.y, e2.y, k == 2u), e1.y, k == 1u), stack);
            k--;
            if k == 0u {
                break;
            }
        }
    }
    if e0.x != missed {
        return e0.y;
    }
    if (*stack).sp == 0u {
        return NO_NODE;
    }
    return pop(stack);
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
    var stack = empty_stack();
    var position = 0u;
    loop {
        if position < LEAF_BIT {
            loop {
                let n = bvh_node(position);
                position = next_node(n, child_distances(n, origin, inv_dir, hit.t), &stack);
                if position >= LEAF_BIT {
                    break;
                }
            }
        }
        if position == NO_NODE {
            break;
        }
        // A leaf holds at least one triangle.
        var i = leaf_first(position);
        let end = i + leaf_count(position);
        loop {
            let tri = triangle_corners(i);
            let r = intersect_triangle(origin, sh, tri.p0, tri.p1, tri.p2, hit.t);
            if r.x > 0.0 {
                hit = Hit(r.x, r.y, r.z, i, true);
            }
            i++;
            if i >= end {
                break;
            }
        }
        if stack.sp == 0u {
            break;
        }
        position = pop(&stack);
    }
    return hit;
}

// Any hit along origin + t * dir, t in (0, t_max): true when the segment is blocked. Subtrees
// that only the triangles of light `skip - 1` fill are left out (skip 0: none): the light is
// convex, and cannot block a shadow ray towards a point of it that faces the receiver.
fn trace_occluded(origin: vec3f, dir: vec3f, t_max: f32, skip: u32) -> bool {
    // No node's light tag is all ones.
    let skipped = select(0xffffffffu, skip, skip != 0u);
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    var stack = empty_stack();
    var position = 0u;
    loop {
        if position < LEAF_BIT {
            loop {
                let n = bvh_node(position);
                let lights_01 = n.lights_01;
                let lights_23 = n.lights_23;
                let tags = vec4u(lights_01 & 0xffffu, lights_01 >> 16u, lights_23 & 0xffffu, lights_23 >> 16u);
                let t = child_distances(n, origin, inv_dir, t_max);
                position = next_node(n, select(t, vec4f(RAY_INF), tags == vec4u(skipped)), &stack);
                if position >= LEAF_BIT {
                    break;
                }
            }
        }
        if position == NO_NODE {
            break;
        }
        var i = leaf_first(position);
        let end = i + leaf_count(position);
        loop {
            let tri = triangle_corners(i);
            if intersect_triangle(origin, sh, tri.p0, tri.p1, tri.p2, t_max).x > 0.0 {
                return true;
            }
            i++;
            if i >= end {
                break;
            }
        }
        if stack.sp == 0u {
            break;
        }
        position = pop(&stack);
    }
    return false;
}

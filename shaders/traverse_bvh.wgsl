// traverse_bvh.wgsl: BVH2 traversal with a closest-hit query (camera and BRDF rays) and an any-hit
// query (shadow rays), over traverse.wgsl's watertight ray/triangle test. Scenes of at most 64
// triangles on CPU adapters use traverse_baked.wgsl instead (BAKED_TRIANGLES_MAX).

const BVH_STACK_SIZE: u32 = 64u;

// The traversal stack, shared by both traversals (a ray's traversal ends before the next begins).
// At module scope it is zeroed once per invocation, as WGSL requires of every variable; declared
// in trace_closest and trace_occluded it was zeroed at every call, 64 stores per traversal, which Mesa
// 22.3's lavapipe does not optimise away: 0.75-0.84x the render time there (docs/performance.md,
// "The traversal stack at module scope").
var<private> bvh_stack: array<u32, BVH_STACK_SIZE>;

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

struct ChildBoxes {
    left_min: vec3f,
    left_max: vec3f,
    right_min: vec3f,
    right_max: vec3f,
}

// Node i's children's boxes, decoded from their 8-bit cells (layout.wgsl's BvhNode): a bound is
// origin + q * 2^e, exact in the product (q <= 255, e <= 120), so the host's outward rounding
// holds whether or not the driver fuses the multiply-add. Only the words used are loaded: 9 a
// step, where lavapipe gathers each word lane by lane.
fn child_boxes(i: u32) -> ChildBoxes {
    let origin = bvh_nodes[i].origin;
    let exponents = bvh_nodes[i].exponents;
    let bounds = bvh_nodes[i].bounds;
    let cell = vec3f(
        bitcast<f32>((exponents & 0xffu) << 23u),
        bitcast<f32>(((exponents >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((exponents >> 16u) & 0xffu) << 23u),
    );
    // Per axis: left low, right low, left high, right high.
    let shifts = vec4u(0u, 8u, 16u, 24u);
    let x = origin.x + vec4f((vec4u(bounds.x) >> shifts) & vec4u(0xffu)) * cell.x;
    let y = origin.y + vec4f((vec4u(bounds.y) >> shifts) & vec4u(0xffu)) * cell.y;
    let z = origin.z + vec4f((vec4u(bounds.z) >> shifts) & vec4u(0xffu)) * cell.z;
    // Axes no grid spans (coordinates near f32's limits): unbounded for both children.
    let unbounded = (vec3u(exponents) & vec3u(0x1000000u, 0x2000000u, 0x4000000u)) != vec3u(0u);
    let big = vec3f(3.4028235e38);
    return ChildBoxes(
        select(vec3f(x.x, y.x, z.x), -big, unbounded),
        select(vec3f(x.z, y.z, z.z), big, unbounded),
        select(vec3f(x.y, y.y, z.y), -big, unbounded),
        select(vec3f(x.w, y.w, z.w), big, unbounded),
    );
}

// One step from inner node `node`, given the ray's entry distances to its children (RAY_INF where
// it misses one): the nearer child it enters, with the farther pushed on the stack; the one it
// enters; or, entering neither, the position on top of the stack, or NO_NODE when that is empty.
fn next_node(node: u32, tl: f32, tr: f32, sp: ptr<function, u32>) -> u32 {
    let left = bvh_nodes[node].left;
    let right = bvh_nodes[node].right;
    if tl != RAY_INF && tr != RAY_INF {
        let near_is_left = tl <= tr;
        if *sp < BVH_STACK_SIZE {
            bvh_stack[*sp] = select(left, right, near_is_left);
            *sp += 1u;
        }
        return select(right, left, near_is_left);
    }
    if tl != RAY_INF {
        return left;
    }
    if tr != RAY_INF {
        return right;
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
            let b = child_boxes(position);
            let tl = intersect_aabb(origin, inv_dir, b.left_min, b.left_max, hit.t);
            let tr = intersect_aabb(origin, inv_dir, b.right_min, b.right_max, hit.t);
            position = next_node(position, tl, tr, &sp);
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

// Any hit along origin + t * dir, t in (0, t_max): true when the segment is blocked. Subtrees
// that only the triangles of light `skip - 1` fill are left out (skip 0: none): the light is
// convex, and cannot block a shadow ray towards a point of it that faces the receiver.
fn trace_occluded(origin: vec3f, dir: vec3f, t_max: f32, skip: u32) -> bool {
    // No node's light tag is all ones.
    let skipped = select(0xffffffffu, skip, skip != 0u);
    let sh = ray_shear(dir);
    let inv_dir = safe_inverse(dir);
    var sp = 0u;
    var position = 0u;
    loop {
        while position < LEAF_BIT {
            let b = child_boxes(position);
            let tl = select(intersect_aabb(origin, inv_dir, b.left_min, b.left_max, t_max), RAY_INF, bvh_nodes[position].left_light == skipped);
            let tr = select(intersect_aabb(origin, inv_dir, b.right_min, b.right_max, t_max), RAY_INF, bvh_nodes[position].right_light == skipped);
            position = next_node(position, tl, tr, &sp);
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

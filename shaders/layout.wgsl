// layout.wgsl: the Rust <-> GPU data layout, read by both sides.
// Every struct here has a #[repr(C)] twin in crates/veach/src/gpu/layout.rs with the same name;
// the unit test `layout_matches_wgsl` checks sizes and member offsets with naga's layouter,
// so the two cannot drift apart silently.

// Strategy, heuristic and light-selection codes (FrameParams.strategy etc.).
const STRATEGY_UNIFORM: u32 = 0u;
const STRATEGY_BRDF: u32 = 1u;
const STRATEGY_LIGHT: u32 = 2u;
const STRATEGY_MIS: u32 = 3u;
const STRATEGY_MIS_LOBES: u32 = 4u;

const HEURISTIC_BALANCE: u32 = 0u;
const HEURISTIC_POWER: u32 = 1u;

const SELECT_EACH: u32 = 0u;
const SELECT_UNIFORM: u32 = 1u;
const SELECT_POWER: u32 = 2u;
const SELECT_BSDF: u32 = 3u;
const SELECT_TREE: u32 = 4u;

const LIGHT_SAMPLING_AREA: u32 = 0u;
const LIGHT_SAMPLING_SOLID_ANGLE: u32 = 1u;
const LIGHT_SAMPLING_CONE: u32 = 2u;
const LIGHT_SAMPLING_AUTO: u32 = 3u;
const SAMPLER_SOBOL: u32 = 0u;
const SAMPLER_INDEPENDENT: u32 = 1u;

// Light.parallelogram's bit for a rectangle.
const RECTANGLE_LIGHT: u32 = 4u;

const LIGHT_AREA: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
const LIGHT_DIRECTIONAL: u32 = 3u;

const NO_LIGHT: u32 = 0xffffffffu;
const NO_TEXTURE: u32 = 0xffffffffu;

// Pinhole camera: a primary ray through film position (sx, sy) in [-1, 1]^2 has the direction
// forward + sx * right + sy * up (right and up already scaled by tan(fov/2) and the aspect).
struct Camera {
    origin: vec3f,
    _pad0: f32,
    forward: vec3f,
    _pad1: f32,
    right: vec3f,
    _pad2: f32,
    up: vec3f,
    _pad3: f32,
}

struct FrameParams {
    camera: Camera,
    // The pixel buffers' size: the image's, or a tile's (rows of it, from tile_row).
    width: u32,
    height: u32,
    // Rows [row_start, row_start + row_count) are rendered by this dispatch.
    row_start: u32,
    row_count: u32,
    // Camera samples [sample_start, sample_start + sample_count) of every pixel in those rows.
    sample_start: u32,
    sample_count: u32,
    seed: u32,
    strategy: u32,
    light_samples: u32,
    brdf_samples: u32,
    heuristic: u32,
    light_selection: u32,
    light_count: u32,
    // 1: also accumulate the light-sample and BRDF-sample contributions (aov_light, aov_brdf).
    write_aovs: u32,
    // 1: leave out emission seen directly by camera rays (direct lighting only).
    hide_emitters: u32,
    // LIGHT_SAMPLING_*: how a point on an emitter triangle is sampled.
    light_sampling: u32,
    // A sphere around every area light's triangles (radius 0: none), for emitter_reach.
    emitter_centre: vec3f,
    emitter_radius: f32,
    // SAMPLER_*: where a camera sample's numbers come from (shaders/sampler.wgsl).
    sampler: u32,
    // At least 2 (the host sets 2): loop_budget_held's trip count, read at run time.
    loop_check: u32,
    // 1: the unshadowed diffuse light is a control variate (control_variate.wgsl).
    control_variate: u32,
    // 1: this dispatch is its rows' first pass, whose sums are still zero (Accumulation::submit).
    fresh_sums: u32,
    // A box around every area light's triangles, for emitter_reach: the sphere's companion,
    // tighter for lights that lie in a plane or along a line.
    emitter_min: vec3f,
    // The image row of the buffers' first row (0 unless the image is rendered in tiles, whose
    // buffers each fit the adapter's binding size: Renderer::render), and the image's height.
    // The camera and the sample streams see image rows, so a tiled image is the untiled one.
    tile_row: u32,
    emitter_max: vec3f,
    image_height: u32,
    // 1: no direction ray is held for the end of a run (deferred_rays.wgsl,
    // take_samples_deferred): set where samples cut short are taken again.
    finish_samples: u32,
    // The sequence index of a pixel's sample 0 (--first-sample): counts and sums stay per
    // render, only the sample streams are offset (megakernel.wgsl, pixel_sample_stream).
    first_sample: u32,
    // SELECT_TREE: the light tree's slots (0: none), then this many directional lights' leaves
    // (light_tree.wgsl).
    light_tree_slots: u32,
    directional_lights: u32,
    // 1: the tree's array holds each tree slot's lit box after the directional leaves
    // (light_tree.wgsl, lit_factor).
    light_tree_lit_boxes: u32,
}

// A node of the 4-wide BVH, 64 bytes (crates/veach/src/gpu/bvh_nodes.rs): up to four children's
// boxes, quantised, and references to them: an inner node's index, a leaf (LEAF_BIT, in
// traverse_bvh.wgsl) with its triangle count in bits 27-30 and its first triangle of the
// BVH-ordered `triangles` in bits 0-26, or NO_CHILD in an empty slot. Node 0 is the root. The
// boxes lie on a grid of 8-bit cells (Ylitie, Karras & Laine, "Efficient Incoherent Ray Traversal
// on GPUs Through Compressed Wide BVHs", HPG 2017, §3.1): on axis k a bound is
// origin[k] + q * 2^e_k, q in 0..=255, rounded outwards by the host so that each box holds its
// child's (traverse_bvh.wgsl's child_distances).
struct BvhNode {
    origin: vec3f,
    // Byte k: e_k's biased f32 exponent (the cell size's bits >> 23); byte 3: bit k where axis k
    // spans more than cells can (coordinates near f32's limits): every child is unbounded on it.
    exponents: u32,
    // Per axis, child i's low cell in byte i.
    low: vec3u,
    // 1 + the convex light whose triangles alone fill the subtree of child 0 (bits 0-15) and of
    // child 1, or 0: shadow rays towards a point of that light skip it
    // (crates/veach/src/gpu/light_subtrees.rs).
    lights_01: u32,
    // Per axis, child i's high cell in byte i.
    high: vec3u,
    // The same for children 2 and 3.
    lights_23: u32,
    children: vec4u,
}

// A vertex in world space, shared by the triangles that index it: its position and its shading
// normal, octahedral-encoded in two snorm16 (decode_normal below). 16 bytes.
struct Vertex {
    p: vec3f,
    normal: u32,
}

// A triangle, in BVH order: its corners (indices into `vertices`) and its material, 16 bytes:
// one texel or vec4u load (its area light is in `triangle_lights`).
struct IndexedTriangle {
    v0: u32,
    v1: u32,
    v2: u32,
    material: u32,
}

// Octahedral unit-vector decoding (Cigolle et al., "A Survey of Efficient Representations for
// Independent Unit Vectors", JCGT 3(2), 2014, §3.1; the fold without branches is Rune Stubbe's).
// The host's encoder is `layout::encode_normal`; 16 bits a component bound the angular error by
// about 1e-4 rad.
fn decode_normal(bits: u32) -> vec3f {
    let e = unpack2x16snorm(bits);
    var n = vec3f(e, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

// glTF metallic-roughness material with KHR_materials_specular and emission.
struct Material {
    base_color: vec3f,
    metallic: f32,
    // Emitted radiance: emissiveFactor * KHR_materials_emissive_strength.
    emission: vec3f,
    roughness: f32,
    specular_color: vec3f,
    specular: f32,
    // 1 when the material is doubleSided: emitters then emit from both faces.
    double_sided: u32,
    // normalTexture.scale: multiplies the x and y of the tangent-space normal.
    normal_scale: f32,
    _pad1: u32,
    _pad2: u32,
    // Textures (index NO_TEXTURE: none), read by shaders/textures.wgsl.
    base_color_texture: TextureRef,
    metallic_roughness_texture: TextureRef,
    emissive_texture: TextureRef,
    normal_texture: TextureRef,
}

// A material's use of a texture: which one, which TEXCOORD set, and the KHR_texture_transform
// as the rows of a 2x3 affine map, uv' = (dot(row0, (u, v, 1)), dot(row1, (u, v, 1))).
struct TextureRef {
    row0: vec3f,
    index: u32,
    row1: vec3f,
    tex_coord: u32,
}

// One texture in `texels`: RGBA8 texels [offset, offset + width * height), rows top first.
// sampling: bits 0-1 wrapS, 2-3 wrapT (WRAP_*), bit 4 magFilter NEAREST.
struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    sampling: u32,
}

// One light. Area lights own emitter triangles [first_tri, first_tri + tri_count).
// `intensity` is radiance (area), radiant intensity in W/sr (point, spot) or irradiance in
// W/m^2 (directional). `direction` is where spot and directional light travels. `position` is
// the point or spot light's position, and an area light's bounding-sphere centre (radius
// `bound_radius`).
struct Light {
    kind: u32,
    first_tri: u32,
    tri_count: u32,
    double_sided: u32,
    position: vec3f,
    area: f32,
    direction: vec3f,
    cos_inner: f32,
    intensity: vec3f,
    cos_outer: f32,
    bound_radius: f32,
    // 1 where the area light is convex (crates/veach/src/gpu/light_subtrees.rs): a shadow ray
    // towards a point of it that faces the receiver skips the subtrees only its triangles fill.
    convex: u32,
    // 1 where the area light is convex and fills at least half of its bounding sphere's surface
    // (light_subtrees.rs, is_round): LIGHT_SAMPLING_CONE samples it by the cone the sphere subtends.
    round: u32,
    // 1 + the corner of the light's first emitter triangle opposite the edge it shares with the
    // second where the two make a parallelogram (light_subtrees.rs, parallelogram_corner), else 0;
    // plus RECTANGLE_LIGHT where its edges there are perpendicular (light_shape.rs, is_rectangle).
    parallelogram: u32,
}

// Triangle i of an area light (an index into `triangles`, whose corners it has), and bucket i of
// the light's alias table over its triangles by area (crates/veach/src/alias.rs): the bucket keeps
// `triangle` with probability alias_prob, else gives `alias_triangle`. 16 bytes, without corners
// (docs/performance.md, "Emitter triangles by their mesh triangle"): one load gives the bucket's
// whole choice.
struct EmitterTriangle {
    alias_prob: f32,
    triangle: u32,
    alias_triangle: u32,
    _pad0: u32,
}

// Light i chosen by power: its probability, and bucket i of the alias table over the lights.
struct LightPick {
    pdf: f32,
    alias_prob: f32,
    alias_index: u32,
    // The light's path down the light tree: bit d set where it takes the second child at depth d.
    tree_trail: u32,
}

// A slot of the light tree (crates/veach/src/light_tree.rs), 32 bytes: the walk loads one a step.
// An inner node's slot holds both children's bounds, quantised within the node's decoded sphere
// (light_tree.wgsl, tree_child): the first child's slot (the second follows it) and flags, each
// child's centre as three 10-bit offsets, their radii and cos θ_e, emission axes, cos θ_o and
// shares of the node's power. A leaf's slot holds its light in `children`; slot 0, the root's
// sphere.
struct LightTreeSlot {
    // The first child's slot; LIGHT_TREE_LEAF << c and LIGHT_TREE_TWO_SIDED << c for child c.
    children: u32,
    // Per axis 10 bits (x lowest): the child's centre at the node's centre plus its radius times
    // (2 q / 1023 − 1).
    centre_a: u32,
    centre_b: u32,
    // The children's radii as unorm8 of radius / (node radius · LIGHT_TREE_RADIUS_SCALE) (bytes
    // 0, 1) and their cos θ_e as snorm8 (bytes 2, 3), rounded by the host so that bounds only grow.
    radii_cos_e: u32,
    // The emission cones' axes, decode_normal'd.
    axis_a: u32,
    axis_b: u32,
    // cos θ_o of each as unorm16 of (cos + 1) / 2, rounded down (θ_o widened by the axis's
    // encoding error).
    cos_o: u32,
    // Each child's share of the node's power, f16 (normal: at least 2^-14).
    phi: u32,
}

const LIGHT_TREE_LEAF: u32 = 0x10000000u;
const LIGHT_TREE_TWO_SIDED: u32 = 0x40000000u;
const LIGHT_TREE_INDEX: u32 = 0x0fffffffu;
const LIGHT_TREE_RADIUS_SCALE: f32 = 1.015625;

// Parameters of the test kernels (shaders/test_kernels.wgsl).
struct TestParams {
    routine: u32,
    count: u32,
    seed: u32,
    light_index: u32,
    wo: vec3f,
    _pad0: f32,
    point: vec3f,
    _pad1: f32,
    material: Material,
}

// Per-pixel counters kept by the kernel.
struct PixelCounters {
    rays: u32,
    nonfinite: u32,
    // Camera samples cut short by the driver's loop limit, left out and taken again.
    truncated: u32,
}

// The frame's parameters (binding 0), the scene's arrays (1-7), triangle_lights (23) with
// triangle_light(), the emitters' grid (25) with emitter_grid_word() and BVH_STACK_SIZE are
// declared per kernel by crates/veach/src/gpu/bindings.rs (wgsl_declarations), from the table the
// bind group layout is made of: storage or uniform, a private copy of the frame or none, as the
// kernel's plan says. Every entry point calls load_frame() first.
// Running sums per pixel: (sum of radiance, number of camera samples) and (sum of squares, 0).
@group(0) @binding(8) var<storage, read_write> accum: array<vec4f>;
@group(0) @binding(9) var<storage, read_write> accum_sq: array<vec4f>;
@group(0) @binding(10) var<storage, read_write> counters: array<PixelCounters>;
// Contribution images: sums of the (MIS-weighted) light-sample and BRDF-sample estimates, so
// that aov_light + aov_brdf = accum. Directly seen emission counts with the BRDF image;
// aov_brdf.w sums its luminance.
@group(0) @binding(11) var<storage, read_write> aov_light: array<vec4f>;
@group(0) @binding(12) var<storage, read_write> aov_brdf: array<vec4f>;

// Wavefront kernels (shaders/wavefront.wgsl): a camera sample whose direction samples wait for
// the second kernel, with what the first one found. One per pixel per dispatch at most.
struct DeferredSample {
    // Emission seen directly, and the light samples' estimate.
    emitted: vec3f,
    pixel: u32,
    light: vec3f,
    // The sample stream's next request (shaders/sampler.wgsl), where the light samples left it.
    stream_dim: u32,
    // The camera ray's hit.
    tri: u32,
    b1: f32,
    b2: f32,
    // The sample plan's n, and the rays traced so far.
    light_samples: u32,
    rays: u32,
    // The camera sample's index (the pixel's own count of samples when its round began).
    sample: u32,
    // The plan's light_weighting (sample_plan.wgsl's LIGHT_*), for its cone light samples.
    light_weighting: u32,
    // The sample plan's m (each count 2^20 at most: settings.rs, MAX_SAMPLES_PER_CAMERA_SAMPLE).
    direction_samples: u32,
}

// A dispatch runs rounds of the wavefront kernels, one camera sample per pixel each: the pixel's
// next (its count of samples), until it has the dispatch's last. `count` samples deferred by
// this round's first kernel; prepare_direction_pass moves it to `pending` for the second.
struct DeferredHeader {
    count: atomic<u32>,
    pending: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(17) var<storage, read_write> deferred: array<DeferredSample>;
@group(0) @binding(18) var<storage, read_write> deferred_header: DeferredHeader;
// The workgroup counts of the kernel that takes them: an indirect dispatch's arguments, written
// by prepare_direction_pass. That kernel's own bind group has a placeholder here, since a buffer
// may not be bound for writing where the same dispatch reads its arguments.
@group(0) @binding(19) var<storage, read_write> deferred_dispatch: array<u32, 3>;

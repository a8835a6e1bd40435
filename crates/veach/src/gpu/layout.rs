//! Rust twins of the structs in `shaders/layout.wgsl`, the one place that defines the data the
//! host uploads and the kernels read. Field names match the WGSL member names, and the test
//! `layout_matches_wgsl` checks every size and offset against naga's layouter.

use bytemuck::{Pod, Zeroable};

pub const STRATEGY_UNIFORM: u32 = 0;
pub const STRATEGY_BRDF: u32 = 1;
pub const STRATEGY_LIGHT: u32 = 2;
pub const STRATEGY_MIS: u32 = 3;
pub const STRATEGY_MIS_LOBES: u32 = 4;

pub const HEURISTIC_BALANCE: u32 = 0;
pub const HEURISTIC_POWER: u32 = 1;

pub const SELECT_EACH: u32 = 0;
pub const SELECT_UNIFORM: u32 = 1;
pub const SELECT_POWER: u32 = 2;
pub const SELECT_BSDF: u32 = 3;
pub const SELECT_TREE: u32 = 4;

pub const LIGHT_SAMPLING_AREA: u32 = 0;
pub const LIGHT_SAMPLING_SOLID_ANGLE: u32 = 1;
pub const LIGHT_SAMPLING_CONE: u32 = 2;
pub const LIGHT_SAMPLING_AUTO: u32 = 3;
/// `Light::parallelogram`'s bit for a rectangle.
pub const RECTANGLE_LIGHT: u32 = 4;
pub const SAMPLER_SOBOL: u32 = 0;
pub const SAMPLER_INDEPENDENT: u32 = 1;

pub const LIGHT_AREA: u32 = 0;
pub const LIGHT_POINT: u32 = 1;
pub const LIGHT_SPOT: u32 = 2;
pub const LIGHT_DIRECTIONAL: u32 = 3;

pub const NO_LIGHT: u32 = u32::MAX;
pub const NO_TEXTURE: u32 = u32::MAX;

/// Threads per workgroup of the `render` and `render_light_pass` entry points by default
/// (shaders/features.wgsl's RENDER_WORKGROUP_*; `GpuContext::render_workgroup`).
pub const WORKGROUP_SIZE: (u32, u32) = (8, 8);
/// Threads per workgroup of `render_direction_pass` (shaders/wavefront.wgsl's DEFERRED_WORKGROUP).
pub const DEFERRED_WORKGROUP: u32 = 64;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Camera {
    pub origin: [f32; 3],
    pub _pad0: f32,
    pub forward: [f32; 3],
    pub _pad1: f32,
    pub right: [f32; 3],
    pub _pad2: f32,
    pub up: [f32; 3],
    pub _pad3: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct FrameParams {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub row_start: u32,
    pub row_count: u32,
    pub sample_start: u32,
    pub sample_count: u32,
    pub seed: u32,
    pub strategy: u32,
    pub light_samples: u32,
    pub brdf_samples: u32,
    pub heuristic: u32,
    pub light_selection: u32,
    pub light_count: u32,
    pub write_aovs: u32,
    pub hide_emitters: u32,
    pub light_sampling: u32,
    pub emitter_centre: [f32; 3],
    pub emitter_radius: f32,
    pub sampler: u32,
    /// At least 2: the trip count of `loop_budget_held` (megakernel.wgsl), read at run time so
    /// that the compiler cannot unroll it.
    pub loop_check: u32,
    /// 1: the unshadowed diffuse light is a control variate (shaders/control_variate.wgsl).
    pub control_variate: u32,
    /// 1: this dispatch is its rows' first pass, whose sums are still zero: `render` writes them
    /// without reading them first.
    pub fresh_sums: u32,
    /// A box around every area light's triangles (min > max: none), for emitter_reach.
    pub emitter_min: [f32; 3],
    /// The image row of the pixel buffers' first row (a tile's; 0 for the whole image).
    pub tile_row: u32,
    pub emitter_max: [f32; 3],
    /// The image's height; `height` is the pixel buffers' (a tile's rows).
    pub image_height: u32,
    /// 1: no direction ray is held for the end of a run (`take_samples_deferred` in
    /// deferred_rays.wgsl): set where samples cut short are taken again.
    pub finish_samples: u32,
    /// The camera sample index of a pixel's sample 0: a render of samples [first_sample,
    /// first_sample + spp) of the one sample sequence (`--first-sample`, for renders split
    /// across machines and merged).
    pub first_sample: u32,
    /// The light tree's slots (0: none) and the directional lights after them
    /// (SELECT_TREE; crate::light_tree).
    pub light_tree_slots: u32,
    pub directional_lights: u32,
    /// 1: the light tree's array holds its slots' lit boxes after the directional leaves
    /// (`LightTree::lit`).
    pub light_tree_lit_boxes: u32,
    /// To the struct's WGSL size, a multiple of its vec3f's alignment.
    pub _pad: [u32; 3],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BvhNode {
    /// The children's boxes on a grid of 8-bit cells (`gpu::bvh_nodes`): its corner, the cell
    /// sizes' biased exponents (bytes 0-2) and the axes no grid spans (bits 24-26), and per axis
    /// the cells of each child's low and high bound (byte i: child i).
    pub origin: [f32; 3],
    pub exponents: u32,
    pub low: [u32; 3],
    /// 1 + the convex light that alone fills child 0's (bits 0-15) and child 1's subtree, or 0
    /// (`gpu::light_subtrees`).
    pub lights_01: u32,
    pub high: [u32; 3],
    pub lights_23: u32,
    /// Up to four child references (`gpu::bvh_nodes::LEAF_BIT`), empty slots `NO_CHILD`.
    pub children: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Vertex {
    pub p: [f32; 3],
    /// The shading normal, `encode_normal`d.
    pub normal: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct IndexedTriangle {
    pub v0: u32,
    pub v1: u32,
    pub v2: u32,
    pub material: u32,
}

/// Octahedral encoding of a unit vector in two snorm16, as WGSL's `pack2x16snorm` packs them
/// (x in the low half); `decode_normal` in layout.wgsl undoes it. Cigolle et al., "A Survey of
/// Efficient Representations for Independent Unit Vectors", JCGT 3(2), 2014, §3.1.
pub fn encode_normal(n: [f32; 3]) -> u32 {
    let [x, y, z] = n;
    let l1 = x.abs() + y.abs() + z.abs();
    if l1.is_nan() || l1 <= 0.0 {
        return encode_normal([0.0, 0.0, 1.0]);
    }
    let (x, y, z) = (x / l1, y / l1, z / l1);
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    let (u, v) = if z >= 0.0 { (x, y) } else { ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y)) };
    let snorm16 = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    snorm16(u) | snorm16(v) << 16
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Material {
    pub base_color: [f32; 3],
    pub metallic: f32,
    pub emission: [f32; 3],
    pub roughness: f32,
    pub specular_color: [f32; 3],
    pub specular: f32,
    pub double_sided: u32,
    pub normal_scale: f32,
    pub _pad1: u32,
    pub _pad2: u32,
    pub base_color_texture: TextureRef,
    pub metallic_roughness_texture: TextureRef,
    pub emissive_texture: TextureRef,
    pub normal_texture: TextureRef,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TextureRef {
    pub row0: [f32; 3],
    pub index: u32,
    pub row1: [f32; 3],
    pub tex_coord: u32,
}

impl Default for TextureRef {
    /// No texture.
    fn default() -> Self {
        TextureRef { row0: [1.0, 0.0, 0.0], index: NO_TEXTURE, row1: [0.0, 1.0, 0.0], tex_coord: 0 }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub sampling: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Light {
    pub kind: u32,
    pub first_tri: u32,
    pub tri_count: u32,
    pub double_sided: u32,
    pub position: [f32; 3],
    pub area: f32,
    pub direction: [f32; 3],
    pub cos_inner: f32,
    pub intensity: [f32; 3],
    pub cos_outer: f32,
    pub bound_radius: f32,
    /// 1 where the area light is convex (`scene::light_shape::is_convex`): its shadow rays skip
    /// the subtrees that only its triangles fill.
    pub convex: u32,
    /// 1 where the area light is convex and fills at least half of its bounding sphere's surface
    /// (`scene::light_shape::is_round`): `LightSampling::Cone` samples it by the cone that sphere
    /// subtends.
    pub round: u32,
    /// 1 + the corner of the light's first emitter triangle opposite the edge it shares with the
    /// second where the two make a parallelogram (`scene::light_shape::parallelogram_corner`),
    /// else 0: area samples then map the unit square onto the parallelogram linearly. Plus
    /// RECTANGLE_LIGHT where its edges there are perpendicular (`scene::light_shape::is_rectangle`).
    pub parallelogram: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct EmitterTriangle {
    pub alias_prob: f32,
    /// Indices into the triangles array (BVH order): the light's triangle i, and what bucket i of
    /// its alias table gives with probability 1 - alias_prob.
    pub triangle: u32,
    pub alias_triangle: u32,
    pub _pad0: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct LightPick {
    pub pdf: f32,
    pub alias_prob: f32,
    pub alias_index: u32,
    /// The light's path from the light tree's root to its leaf (crate::light_tree): bit d set
    /// where it takes the second child at depth d; light_tree::NOT_IN_TREE where it has no leaf.
    pub tree_trail: u32,
}

/// A slot of the light tree (crate::light_tree, shaders/light_tree.wgsl), 32 bytes: the walk
/// loads one a step. An inner node's slot holds its two children's bounds, each quantised within
/// the node's own decoded sphere (`light_tree::encode_children`): the children's slots (side by
/// side from `children`) and flags; each child's centre as three 10-bit offsets; their radii
/// (unorm8) and cos θ_e (snorm8); their emission axes `encode_normal`d; cos θ_o as unorm16 each;
/// their shares of the node's power as f16 each. A leaf's slot holds its light in `children`.
/// Slot 0 holds the root's sphere (`light_tree::root_slot`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightTreeSlot {
    pub children: u32,
    pub centre_a: u32,
    pub centre_b: u32,
    pub radii_cos_e: u32,
    pub axis_a: u32,
    pub axis_b: u32,
    pub cos_o: u32,
    pub phi: u32,
}

/// `children`'s flags: child c (0 or 1) is a leaf (`LIGHT_TREE_LEAF << c`), emits from both
/// sides (`LIGHT_TREE_TWO_SIDED << c`); the rest is the first child's slot.
pub const LIGHT_TREE_LEAF: u32 = 1 << 28;
pub const LIGHT_TREE_TWO_SIDED: u32 = 1 << 30;
pub const LIGHT_TREE_INDEX: u32 = (1 << 28) - 1;

/// `encode_normal` undone, as `decode_normal` in layout.wgsl does it.
pub fn decode_normal(bits: u32) -> [f32; 3] {
    let snorm = |h: u32| ((h as u16 as i16) as f32 / 32767.0).max(-1.0);
    let (ex, ey) = (snorm(bits & 0xffff), snorm(bits >> 16));
    let (mut x, mut y, z) = (ex, ey, 1.0 - ex.abs() - ey.abs());
    let t = (-z).max(0.0);
    x += if x >= 0.0 { -t } else { t };
    y += if y >= 0.0 { -t } else { t };
    let l = (x * x + y * y + z * z).sqrt();
    [x / l, y / l, z / l]
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TestParams {
    pub routine: u32,
    pub count: u32,
    pub seed: u32,
    pub light_index: u32,
    pub wo: [f32; 3],
    pub _pad0: f32,
    pub point: [f32; 3],
    pub _pad1: f32,
    pub material: Material,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PixelCounters {
    pub rays: u32,
    pub nonfinite: u32,
    /// Camera samples cut short by the driver's loop limit and taken again (`loop_budget_held`).
    pub truncated: u32,
}

/// A camera sample whose direction samples wait for the wavefront's second kernel
/// (`shaders/wavefront.wgsl`); written and read on the GPU only.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DeferredSample {
    pub emitted: [f32; 3],
    pub pixel: u32,
    pub light: [f32; 3],
    pub stream_dim: u32,
    pub tri: u32,
    pub b1: f32,
    pub b2: f32,
    pub light_samples: u32,
    pub rays: u32,
    pub sample: u32,
    pub light_weighting: u32,
    pub direction_samples: u32,
}

/// The wavefront's rounds: samples deferred by one, waiting for the next (shaders/layout.wgsl);
/// zeroed before each dispatch.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct DeferredHeader {
    pub count: u32,
    pub pending: u32,
    pub _pad: [u32; 2],
}

/// Name, size and (member, offset) list of a struct.
pub type StructLayout = (&'static str, usize, Vec<(&'static str, usize)>);

/// The layout of every struct above, for the layout test.
pub fn rust_layouts() -> Vec<StructLayout> {
    macro_rules! layout {
        ($t:ident { $($f:ident),* $(,)? }) => {
            (
                stringify!($t),
                std::mem::size_of::<$t>(),
                vec![$((stringify!($f), std::mem::offset_of!($t, $f))),*],
            )
        };
    }
    vec![
        layout!(Camera { origin, forward, right, up }),
        layout!(FrameParams {
            camera,
            width,
            height,
            row_start,
            row_count,
            sample_start,
            sample_count,
            seed,
            strategy,
            light_samples,
            brdf_samples,
            heuristic,
            light_selection,
            light_count,
            write_aovs,
            hide_emitters,
            light_sampling,
            emitter_centre,
            emitter_radius,
            sampler,
            loop_check,
            control_variate,
            fresh_sums,
            emitter_min,
            tile_row,
            emitter_max,
            image_height,
            finish_samples,
            first_sample,
            light_tree_slots,
            directional_lights,
            light_tree_lit_boxes
        }),
        layout!(LightTreeSlot { children, centre_a, centre_b, radii_cos_e, axis_a, axis_b, cos_o, phi }),
        layout!(BvhNode { origin, exponents, low, lights_01, high, lights_23, children }),
        layout!(Vertex { p, normal }),
        layout!(IndexedTriangle { v0, v1, v2, material }),
        layout!(Material {
            base_color,
            metallic,
            emission,
            roughness,
            specular_color,
            specular,
            double_sided,
            normal_scale,
            base_color_texture,
            metallic_roughness_texture,
            emissive_texture,
            normal_texture
        }),
        layout!(TextureRef { row0, index, row1, tex_coord }),
        layout!(TextureInfo { offset, width, height, sampling }),
        layout!(Light {
            kind,
            first_tri,
            tri_count,
            double_sided,
            position,
            area,
            direction,
            cos_inner,
            intensity,
            cos_outer,
            bound_radius,
            convex,
            round,
            parallelogram
        }),
        layout!(EmitterTriangle { alias_prob, triangle, alias_triangle }),
        layout!(LightPick { pdf, alias_prob, alias_index, tree_trail }),
        layout!(TestParams { routine, count, seed, light_index, wo, point, material }),
        layout!(PixelCounters { rays, nonfinite, truncated }),
        layout!(DeferredSample {
            emitted,
            pixel,
            light,
            stream_dim,
            tri,
            b1,
            b2,
            light_samples,
            rays,
            sample,
            light_weighting,
            direction_samples
        }),
        layout!(DeferredHeader { count, pending }),
    ]
}

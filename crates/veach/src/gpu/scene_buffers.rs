//! Scene + BVH → the arrays the kernel reads (see `shaders/layout.wgsl`).

use super::bvh_nodes::encode_bvh_nodes;
use super::layout::{self, NO_LIGHT};
use super::light_subtrees::node_lights;
use crate::alias::alias_table;
use crate::bvh::Bvh;
use crate::features::SceneFeatures;
use crate::light_tree::{
    LightBounds, LightTree, area_light_bounds, build_light_tree, point_light_bounds, spot_light_bounds,
};
use crate::lit_boxes::lit_boxes;
use crate::scene::light_shape::{AreaLightShape, area_light_shape, bounding_sphere, point_bounds};
use crate::scene::{LightKind, Scene, TextureRef};
use glam::Vec3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

pub struct SceneArrays {
    pub bvh_nodes: Vec<layout::BvhNode>,
    /// Shared by the triangles, in order of first use along `triangles`.
    pub vertices: Vec<layout::Vertex>,
    /// In BVH order.
    pub triangles: Vec<layout::IndexedTriangle>,
    /// Each triangle's area light (an index into `lights`) or NO_LIGHT, in BVH order.
    pub triangle_lights: Vec<u32>,
    pub materials: Vec<layout::Material>,
    pub lights: Vec<layout::Light>,
    pub emitter_tris: Vec<layout::EmitterTriangle>,
    pub light_picks: Vec<layout::LightPick>,
    pub light_tree: crate::light_tree::LightTree,
    /// Centre and radius of a sphere around every area light's triangles; radius 0 without any.
    pub emitter_bound: ([f32; 3], f32),
    /// A box around the same triangles (min, max; min > max where there are none).
    pub emitter_box: ([f32; 3], [f32; 3]),
    /// Only for scenes with textures (`shaders/textures.wgsl`).
    pub textures: Option<TextureArrays>,
}

pub struct TextureArrays {
    /// Texture coordinates of each vertex, (TEXCOORD_0.xy, TEXCOORD_1.xy).
    pub vertex_uvs: Vec<[f32; 4]>,
    pub texture_infos: Vec<layout::TextureInfo>,
    /// RGBA8 texels of every texture, one u32 each (red in the low byte, as unpack4x8unorm reads).
    pub texels: Vec<u32>,
}

fn texture_ref(r: &Option<TextureRef>) -> layout::TextureRef {
    match r {
        Some(r) => layout::TextureRef {
            row0: r.transform[0].to_array(),
            index: r.texture,
            row1: r.transform[1].to_array(),
            tex_coord: r.tex_coord,
        },
        None => layout::TextureRef::default(),
    }
}

fn texture_arrays(scene: &Scene, vertex_uvs: Vec<[f32; 4]>) -> TextureArrays {
    let mut texture_infos = Vec::new();
    let mut texels = Vec::new();
    for t in &scene.textures {
        texture_infos.push(layout::TextureInfo {
            offset: texels.len() as u32,
            width: t.width,
            height: t.height,
            sampling: t.wrap_s as u32 | (t.wrap_t as u32) << 2 | (t.nearest as u32) << 4,
        });
        texels.extend(t.texels.iter().map(|&c| u32::from_le_bytes(c)));
    }
    TextureArrays { vertex_uvs, texture_infos, texels }
}

fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Emitted power of each light (luminance-weighted), for selection by power.
/// Area: Φ = π A L (Lambertian emitter, ×2 if double-sided); point: 4π I; spot: 2π I (1 − ½(cos θi + cos θo))
/// (pbrt-v4 §12.2.1, SpotLight::Phi); directional: π r² E over the scene's bounding disc.
pub fn light_powers(scene: &Scene) -> Vec<f32> {
    let radius = scene.bounds().radius();
    scene
        .lights
        .iter()
        .map(|l| match &l.kind {
            LightKind::Area { triangles, radiance, double_sided } => {
                let area: f32 = triangles.iter().map(|&t| scene.triangles[t as usize].area()).sum();
                std::f32::consts::PI * area * luminance(*radiance) * if *double_sided { 2.0 } else { 1.0 }
            }
            LightKind::Point { intensity, .. } => 4.0 * std::f32::consts::PI * luminance(*intensity),
            LightKind::Spot { intensity, inner_cone, outer_cone, .. } => {
                2.0 * std::f32::consts::PI * luminance(*intensity) * (1.0 - 0.5 * (inner_cone.cos() + outer_cone.cos()))
            }
            LightKind::Directional { irradiance, .. } => {
                std::f32::consts::PI * radius * radius * luminance(*irradiance)
            }
        })
        .collect()
}

/// The box around `points`, grown as bounding_sphere grows its radius, so that rounding cannot put
/// an emitter's point outside it.
fn bounding_box(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    let (lo, hi) = point_bounds(points);
    let pad = 1e-5 * (hi - lo).max_element() + 1e-5 * lo.abs().max(hi.abs()).max_element();
    (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
}

pub fn build_scene_arrays(scene: &Scene, features: &SceneFeatures, bvh: &Bvh) -> SceneArrays {
    // Scene triangle t is triangles[position_in_bvh[t]] on the GPU.
    let mut position_in_bvh = vec![0u32; scene.triangles.len()];
    for (i, &t) in bvh.order.iter().enumerate() {
        position_in_bvh[t as usize] = i as u32;
    }
    let mut triangle_light = vec![NO_LIGHT; scene.triangles.len()];
    let mut lights = Vec::with_capacity(scene.lights.len());
    let mut emitter_tris = Vec::new();
    // The scene triangle of each emitter triangle.
    let mut emitter_scene_tris = Vec::new();
    for (li, light) in scene.lights.iter().enumerate() {
        let mut g = layout::Light::default();
        match &light.kind {
            LightKind::Area { triangles, radiance, double_sided } => {
                g.kind = layout::LIGHT_AREA;
                g.first_tri = emitter_tris.len() as u32;
                g.tri_count = triangles.len() as u32;
                g.double_sided = *double_sided as u32;
                g.intensity = radiance.to_array();
                let total: f64 = triangles.iter().map(|&t| scene.triangles[t as usize].area() as f64).sum();
                g.area = total as f32;
                let (centre, radius) = bounding_sphere(triangles.iter().flat_map(|&t| scene.triangles[t as usize].p));
                g.position = centre.to_array();
                g.bound_radius = radius;
                let areas: Vec<f64> = triangles.iter().map(|&t| scene.triangles[t as usize].area() as f64).collect();
                for (&t, bucket) in triangles.iter().zip(alias_table(&areas)) {
                    triangle_light[t as usize] = li as u32;
                    emitter_scene_tris.push(t);
                    emitter_tris.push(layout::EmitterTriangle {
                        alias_prob: bucket.prob,
                        triangle: position_in_bvh[t as usize],
                        alias_triangle: position_in_bvh[triangles[bucket.alias as usize] as usize],
                        ..Default::default()
                    });
                }
            }
            LightKind::Point { position, intensity } => {
                g.kind = layout::LIGHT_POINT;
                g.position = position.to_array();
                g.intensity = intensity.to_array();
            }
            LightKind::Spot { position, direction, intensity, inner_cone, outer_cone } => {
                g.kind = layout::LIGHT_SPOT;
                g.position = position.to_array();
                g.direction = direction.to_array();
                g.intensity = intensity.to_array();
                g.cos_inner = inner_cone.cos();
                g.cos_outer = outer_cone.cos();
            }
            LightKind::Directional { direction, irradiance } => {
                g.kind = layout::LIGHT_DIRECTIONAL;
                g.direction = direction.to_array();
                g.intensity = irradiance.to_array();
            }
        }
        lights.push(g);
    }

    // Shadow rays towards a point of a convex light skip the subtrees it alone fills; round lights
    // may be sampled by their cones.
    let shapes: Vec<AreaLightShape> = scene
        .lights
        .iter()
        .map(|light| match &light.kind {
            LightKind::Area { triangles, .. } => area_light_shape(scene, triangles),
            _ => AreaLightShape::default(),
        })
        .collect();
    for (g, shape) in lights.iter_mut().zip(&shapes) {
        g.convex = shape.convex as u32;
        g.round = shape.round as u32;
        g.parallelogram =
            shape.parallelogram.map_or(0, |k| k + 1) | if shape.rectangle { layout::RECTANGLE_LIGHT } else { 0 };
    }
    let convex: Vec<bool> = shapes.iter().map(|s| s.convex).collect();

    // Lights by power; all dark (or no power at all): uniformly.
    let powers = selection_powers(scene);
    let total: f64 = powers.iter().sum();
    let mut light_picks: Vec<layout::LightPick> = powers
        .iter()
        .zip(alias_table(&powers))
        .map(|(&p, bucket)| layout::LightPick {
            pdf: if total > 0.0 { (p / total) as f32 } else { 1.0 / powers.len() as f32 },
            alias_prob: bucket.prob,
            alias_index: bucket.alias,
            ..Default::default()
        })
        .collect();

    let light_tree = scene_light_tree(scene, &powers, bvh);
    for (pick, &trail) in light_picks.iter_mut().zip(&light_tree.trails) {
        pick.tree_trail = trail;
    }

    let emitter_points = emitter_scene_tris.iter().flat_map(|&t| scene.triangles[t as usize].p);
    let (emitter_bound, emitter_box) = if emitter_scene_tris.is_empty() {
        (([0.0; 3], 0.0), ([1.0; 3], [-1.0; 3]))
    } else {
        let (centre, radius) = bounding_sphere(emitter_points.clone());
        let (lo, hi) = bounding_box(emitter_points);
        ((centre.to_array(), radius), (lo.to_array(), hi.to_array()))
    };
    let with_uvs = features.textures();
    let (vertices, vertex_uvs, triangles, triangle_lights) = indexed_triangles(scene, bvh, &triangle_light, with_uvs);

    let materials = scene
        .materials
        .iter()
        .map(|m| layout::Material {
            base_color: m.base_color.to_array(),
            metallic: m.metallic,
            emission: m.emission.to_array(),
            roughness: m.roughness,
            specular_color: m.specular_color.to_array(),
            specular: m.specular,
            double_sided: m.double_sided as u32,
            normal_scale: m.normal_scale,
            base_color_texture: texture_ref(&m.base_color_texture),
            metallic_roughness_texture: texture_ref(&m.metallic_roughness_texture),
            emissive_texture: texture_ref(&m.emissive_texture),
            normal_texture: texture_ref(&m.normal_texture),
            ..Default::default()
        })
        .collect();
    let textures = with_uvs.then(|| texture_arrays(scene, vertex_uvs));

    SceneArrays {
        bvh_nodes: encode_bvh_nodes(&bvh.nodes, &node_lights(bvh, &triangle_light, &convex)),
        vertices,
        triangles,
        triangle_lights,
        materials,
        lights,
        emitter_tris,
        light_picks,
        light_tree,
        emitter_bound,
        emitter_box,
        textures,
    }
}

/// The light tree over the scene's lights (`crate::light_tree`), each with its share of
/// `powers` (the lights' powers, as selection by power takes them) and its lit box, found by
/// tracing rays through `bvh` (`crate::lit_boxes`).
pub fn scene_light_tree(scene: &Scene, powers: &[f64], bvh: &Bvh) -> LightTree {
    let total: f64 = powers.iter().sum();
    let lit = lit_boxes(scene, bvh);
    let mut directional = Vec::new();
    let light_bounds: Vec<Option<LightBounds>> = scene
        .lights
        .iter()
        .enumerate()
        .map(|(li, light)| {
            let phi = if total > 0.0 { (powers[li] / total) as f32 } else { 0.0 };
            let bounds = match &light.kind {
                LightKind::Area { triangles, double_sided, .. } => {
                    let normals: Vec<Vec3> = triangles
                        .iter()
                        .filter_map(|&t| {
                            let [p0, p1, p2] = scene.triangles[t as usize].p;
                            (p1 - p0).cross(p2 - p0).try_normalize()
                        })
                        .collect();
                    let corners = triangles.iter().flat_map(|&t| scene.triangles[t as usize].p);
                    Some(area_light_bounds(corners, &normals, phi, *double_sided))
                }
                LightKind::Point { position, .. } => Some(point_light_bounds(*position, phi)),
                LightKind::Spot { position, direction, outer_cone, .. } => {
                    Some(spot_light_bounds(*position, *direction, outer_cone.cos(), phi))
                }
                LightKind::Directional { .. } => {
                    directional.push(li as u32);
                    None
                }
            };
            bounds.map(|b| LightBounds { lit: lit[li], ..b })
        })
        .collect();
    build_light_tree(&light_bounds, &directional)
}

/// The lights' powers as selection by power and the light tree take them: not finite or
/// negative counts as none.
pub fn selection_powers(scene: &Scene) -> Vec<f64> {
    light_powers(scene).iter().map(|&p| if p.is_finite() { p.max(0.0) as f64 } else { 0.0 }).collect()
}

/// The triangles in BVH order over shared vertices: one vertex for all the corners with the same
/// position, shading normal (as encoded) and, with `with_uvs`, texture coordinates. A closed mesh
/// has about half as many vertices as triangles, so a triangle costs 20 bytes (16 and its light's
/// index) plus about 8 of
/// vertices instead of 96 bytes of its own corners (docs/performance.md, memory per triangle).
/// Returns the vertices, their texture coordinates (empty without `with_uvs`), the triangles and
/// their lights.
fn indexed_triangles(
    scene: &Scene,
    bvh: &Bvh,
    triangle_light: &[u32],
    with_uvs: bool,
) -> (Vec<layout::Vertex>, Vec<[f32; 4]>, Vec<layout::IndexedTriangle>, Vec<u32>) {
    let mut index_of: HashMap<[u32; 8], u32, BuildHasherDefault<VertexKeyHasher>> = HashMap::default();
    index_of.reserve(bvh.order.len());
    let mut vertices = Vec::with_capacity(bvh.order.len() / 2 + 1);
    let mut vertex_uvs = Vec::new();
    let mut triangles = Vec::with_capacity(bvh.order.len().max(1));
    let mut lights = Vec::with_capacity(bvh.order.len().max(1));
    for &t in &bvh.order {
        let tri = &scene.triangles[t as usize];
        let corner = |k: usize| {
            let p = tri.p[k].to_array();
            let normal = layout::encode_normal(tri.n[k].to_array());
            let uv = if with_uvs { [tri.uv[0][k].x, tri.uv[0][k].y, tri.uv[1][k].x, tri.uv[1][k].y] } else { [0.0; 4] };
            let key = [p[0], p[1], p[2], f32::from_bits(normal), uv[0], uv[1], uv[2], uv[3]].map(f32::to_bits);
            (key, layout::Vertex { p, normal }, uv)
        };
        let mut v = [0u32; 3];
        for (k, index) in v.iter_mut().enumerate() {
            let (key, vertex, uv) = corner(k);
            *index = *index_of.entry(key).or_insert_with(|| {
                vertices.push(vertex);
                if with_uvs {
                    vertex_uvs.push(uv);
                }
                (vertices.len() - 1) as u32
            });
        }
        triangles.push(layout::IndexedTriangle { v0: v[0], v1: v[1], v2: v[2], material: tri.material });
        lights.push(triangle_light[t as usize]);
    }
    if triangles.is_empty() {
        // Placeholder for an empty scene (see `build_bvh`): zero area, so it is never hit.
        vertices.push(layout::Vertex::default());
        triangles.push(layout::IndexedTriangle::default());
        lights.push(NO_LIGHT);
    }
    if with_uvs && vertex_uvs.is_empty() {
        vertex_uvs.push([0.0; 4]);
    }
    (vertices, vertex_uvs, triangles, lights)
}

/// A multiply-rotate hash for vertex keys (FxHash's scheme): SipHash's resistance to chosen keys
/// is not needed here, and with it a million triangles uploaded in 0.55 s instead of 0.49 s.
#[derive(Default)]
struct VertexKeyHasher(u64);

impl Hasher for VertexKeyHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.0 = (self.0.rotate_left(5) ^ u64::from_le_bytes(word)).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
        }
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

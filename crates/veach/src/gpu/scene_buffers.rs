//! Scene + BVH → the arrays the kernel reads (see `shaders/layout.wgsl`).

use super::layout::{self, NO_LIGHT};
use crate::bvh::Bvh;
use crate::scene::{LightKind, Scene, TextureRef};
use glam::Vec3;

pub struct SceneArrays {
    pub bvh_nodes: Vec<layout::BvhNode>,
    pub tri_verts: Vec<layout::TriangleVerts>,
    pub tri_shading: Vec<layout::TriangleShading>,
    pub materials: Vec<layout::Material>,
    pub lights: Vec<layout::Light>,
    pub emitter_tris: Vec<layout::EmitterTriangle>,
    pub light_power_cdf: Vec<f32>,
    /// Only for scenes with textures (`shaders/textures.wgsl`).
    pub textures: Option<TextureArrays>,
}

pub struct TextureArrays {
    pub tri_uvs: Vec<layout::TriangleUvs>,
    pub texture_infos: Vec<layout::TextureInfo>,
    /// RGBA8 texels of every texture, one u32 each (red in the low byte, as unpack4x8unorm reads).
    pub texels: Vec<u32>,
    pub emitter_source: Vec<u32>,
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

fn texture_arrays(scene: &Scene, bvh: &Bvh, emitter_scene_tris: &[u32]) -> TextureArrays {
    let mut position_in_bvh = vec![0u32; scene.triangles.len()];
    for (i, &t) in bvh.order.iter().enumerate() {
        position_in_bvh[t as usize] = i as u32;
    }
    let mut tri_uvs: Vec<layout::TriangleUvs> = bvh
        .order
        .iter()
        .map(|&t| {
            let uv = &scene.triangles[t as usize].uv;
            let v = |k: usize| [uv[0][k].x, uv[0][k].y, uv[1][k].x, uv[1][k].y];
            layout::TriangleUvs { v0: v(0), v1: v(1), v2: v(2) }
        })
        .collect();
    if tri_uvs.is_empty() {
        tri_uvs.push(layout::TriangleUvs::default());
    }
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
    let emitter_source = emitter_scene_tris.iter().map(|&t| position_in_bvh[t as usize]).collect();
    TextureArrays { tri_uvs, texture_infos, texels, emitter_source }
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

/// A sphere around `points`: the centre of their bounding box, the farthest point's distance
/// (not the smallest sphere, but within a factor sqrt(3) of it), grown by a relative 1e-5 so that
/// rounding never leaves a point outside.
fn bounding_sphere(points: impl Iterator<Item = Vec3> + Clone) -> (Vec3, f32) {
    let (lo, hi) = points
        .clone()
        .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(p), hi.max(p)));
    let centre = 0.5 * (lo + hi);
    let radius = points.map(|p| p.distance(centre)).fold(0.0f32, f32::max);
    (centre, radius * (1.0 + 1e-5) + 1e-5 * centre.abs().max_element())
}

pub fn build_scene_arrays(scene: &Scene, bvh: &Bvh) -> SceneArrays {
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
                let mut running = 0.0f64;
                for (k, &t) in triangles.iter().enumerate() {
                    let tri = &scene.triangles[t as usize];
                    running += tri.area() as f64;
                    triangle_light[t as usize] = li as u32;
                    emitter_scene_tris.push(t);
                    emitter_tris.push(layout::EmitterTriangle {
                        p0: tri.p[0].to_array(),
                        // The last entry is exactly 1 so that u < 1 always finds a triangle.
                        cdf: if k + 1 == triangles.len() { 1.0 } else { (running / total) as f32 },
                        e1: (tri.p[1] - tri.p[0]).to_array(),
                        area: tri.area(),
                        e2: (tri.p[2] - tri.p[0]).to_array(),
                        light: li as u32,
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

    let powers = light_powers(scene);
    let total: f64 = powers.iter().map(|&p| p.max(0.0) as f64).sum();
    let mut running = 0.0f64;
    let light_power_cdf: Vec<f32> = powers
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            running += p.max(0.0) as f64;
            if i + 1 == powers.len() {
                1.0
            } else if total > 0.0 {
                (running / total) as f32
            } else {
                (i + 1) as f32 / powers.len() as f32
            }
        })
        .collect();

    let mut tri_verts = Vec::with_capacity(bvh.order.len().max(1));
    let mut tri_shading = Vec::with_capacity(bvh.order.len().max(1));
    for &t in &bvh.order {
        let tri = &scene.triangles[t as usize];
        tri_verts.push(layout::TriangleVerts {
            p0: tri.p[0].to_array(),
            p1: tri.p[1].to_array(),
            p2: tri.p[2].to_array(),
            ..Default::default()
        });
        tri_shading.push(layout::TriangleShading {
            n0: tri.n[0].to_array(),
            material: tri.material,
            n1: tri.n[1].to_array(),
            light: triangle_light[t as usize],
            n2: tri.n[2].to_array(),
            _pad: 0,
        });
    }

    if tri_verts.is_empty() {
        // Placeholder for an empty scene (see `build_bvh`); zero area, so it is never hit.
        tri_verts.push(layout::TriangleVerts::default());
        tri_shading.push(layout::TriangleShading { light: NO_LIGHT, ..Default::default() });
    }

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
    let textures = crate::features::SceneFeatures::detect(scene)
        .textures()
        .then(|| texture_arrays(scene, bvh, &emitter_scene_tris));

    SceneArrays {
        bvh_nodes: bvh.nodes.clone(),
        tri_verts,
        tri_shading,
        materials,
        lights,
        emitter_tris,
        light_power_cdf,
        textures,
    }
}

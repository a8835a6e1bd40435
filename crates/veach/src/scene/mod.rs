//! The scene as the renderer sees it: world-space triangles with materials, lights and cameras.
//! Loaded from glTF by `gltf_loader`; independent of the GPU layout.

mod camera;
mod content_hash;
mod gltf_loader;
mod gltf_resources;
pub mod light_shape;
mod texture;

pub use camera::Camera;
pub use gltf_loader::{MAX_NODE_INSTANCES, MAX_TRIANGLES, load_gltf};
pub use gltf_resources::{MAX_IMAGE_FILE_BYTES, MAX_TEXTURE_BYTES};
pub use texture::{Encoding, Texture, TextureRef, Wrap, srgb_to_linear, wrap_index};

use glam::{Vec2, Vec3};

/// A world-space triangle. Vertices are counter-clockwise seen from the front face.
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    pub p: [Vec3; 3],
    /// Shading normals at the vertices (the geometric normal where the mesh has none).
    pub n: [Vec3; 3],
    /// Texture coordinates TEXCOORD_0 and TEXCOORD_1 at the vertices (zero where absent).
    pub uv: [[Vec2; 3]; 2],
    pub material: u32,
}

impl Triangle {
    pub fn area(&self) -> f32 {
        0.5 * (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0]).length()
    }

    pub fn geometric_normal(&self) -> Vec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0]).normalize_or_zero()
    }
}

/// glTF metallic-roughness material (with KHR_materials_specular and emissive strength).
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    pub specular: f32,
    pub specular_color: Vec3,
    /// Emitted radiance: emissiveFactor × emissive_strength.
    pub emission: Vec3,
    pub double_sided: bool,
    /// Textures (glTF 2.0 §3.9): base colour (sRGB, multiplies base_color), metallic-roughness
    /// (linear; B multiplies metallic, G roughness), emissive (sRGB, multiplies emission) and
    /// normal (linear tangent-space normal, xy scaled by `normal_scale`).
    pub base_color_texture: Option<TextureRef>,
    pub metallic_roughness_texture: Option<TextureRef>,
    pub emissive_texture: Option<TextureRef>,
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
}

impl Default for Material {
    /// glTF's default material (specification §3.9.2): white, metallic 1, roughness 1.
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            emission: Vec3::ZERO,
            double_sided: false,
            base_color_texture: None,
            metallic_roughness_texture: None,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
        }
    }
}

impl Material {
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    pub fn texture_refs(&self) -> impl Iterator<Item = &TextureRef> {
        [&self.base_color_texture, &self.metallic_roughness_texture, &self.emissive_texture, &self.normal_texture]
            .into_iter()
            .flatten()
    }
}

#[derive(Clone, Debug)]
pub enum LightKind {
    /// The emissive triangles of one mesh primitive instance, or of one part of a curved one
    /// (`light_shape::light_parts`); radiance comes from the material.
    Area { triangles: Vec<u32>, radiance: Vec3, double_sided: bool },
    /// Radiant intensity in W/sr.
    Point { position: Vec3, intensity: Vec3 },
    /// Radiant intensity on the axis, cone half-angles in radians.
    Spot { position: Vec3, direction: Vec3, intensity: Vec3, inner_cone: f32, outer_cone: f32 },
    /// Irradiance in W/m² on a surface facing the light; `direction` is where light travels.
    Directional { direction: Vec3, irradiance: Vec3 },
}

#[derive(Clone, Debug)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
}

impl Light {
    pub fn is_delta(&self) -> bool {
        !matches!(self.kind, LightKind::Area { .. })
    }
}

#[derive(Clone, Debug, Default)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Bounds {
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }
    pub fn radius(&self) -> f32 {
        0.5 * (self.max - self.min).length()
    }
}

#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
    /// Textures the materials use (`TextureRef::texture` indexes this).
    pub textures: Vec<Texture>,
    /// Things in the file that veach does not render, said once to the user.
    pub warnings: Vec<String>,
}

impl Scene {
    pub fn bounds(&self) -> Bounds {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.triangles {
            for p in t.p {
                min = min.min(p);
                max = max.max(p);
            }
        }
        for l in &self.lights {
            if let LightKind::Point { position, .. } | LightKind::Spot { position, .. } = l.kind {
                min = min.min(position);
                max = max.max(position);
            }
        }
        if min.x > max.x {
            return Bounds { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) };
        }
        Bounds { min, max }
    }

    pub fn emissive_triangle_count(&self) -> usize {
        self.lights
            .iter()
            .map(|l| match &l.kind {
                LightKind::Area { triangles, .. } => triangles.len(),
                _ => 0,
            })
            .sum()
    }

    pub fn has_delta_lights(&self) -> bool {
        self.lights.iter().any(Light::is_delta)
    }

    /// The camera named `name`, or the first one, or one framing the scene's bounds.
    pub fn camera(&self, name: Option<&str>) -> Result<Camera, String> {
        match name {
            Some(n) => self.cameras.iter().find(|c| c.name == n).cloned().ok_or_else(|| {
                let names: Vec<_> = self.cameras.iter().map(|c| format!("'{}'", c.name)).collect();
                if names.is_empty() {
                    format!("no camera named '{n}': the scene has no perspective cameras")
                } else {
                    format!("no camera named '{n}'; the scene has {}", names.join(", "))
                }
            }),
            None => Ok(self.cameras.first().cloned().unwrap_or_else(|| Camera::framing(&self.bounds()))),
        }
    }
}

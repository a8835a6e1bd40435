//! Scene features, detected on load: what a scene contains that a kernel may need code for
//! (`kernel_plan` turns them, with a render's settings, into the kernel it runs).

use crate::scene::{LightKind, Scene};
use serde::Serialize;

/// Lights that lights.wgsl's `emitter_reach` bounds one by one, each by its sphere; past this many
/// it takes one sphere and one box around all of them (lights.wgsl's `MAX_REACH_LIGHTS`).
pub const MAX_REACH_LIGHTS: usize = 16;

/// What a scene contains that the kernel may need code for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct SceneFeatures {
    pub area_lights: bool,
    pub point_lights: bool,
    pub spot_lights: bool,
    pub directional_lights: bool,
    /// Exactly one light.
    pub single_light: bool,
    /// Every material that triangles use is Lambertian (metallic 0, specular 0).
    pub all_diffuse: bool,
    /// Some used material has metallic > 0.
    pub any_metal: bool,
    /// Some used material has a GGX lobe (metallic > 0 or specular > 0).
    pub any_glossy: bool,
    /// Some used material is a perfect mirror (roughness 0).
    pub any_mirror: bool,
    pub double_sided_emitters: bool,
    /// Some area light is round (`scene::light_shape::area_light_shape`), which
    /// `LightSampling::Cone` samples by its bounding cone.
    pub round_lights: bool,
    /// Every light is a round area light (and there is one).
    pub all_lights_round: bool,
    /// Some area light is one parallelogram of two triangles, which area samples map the unit
    /// square onto linearly.
    pub parallelogram_lights: bool,
    /// Every area light is a parallelogram (true where there are none).
    pub all_area_lights_parallelograms: bool,
    /// Some parallelogram light is a rectangle, which `LightSampling::spherical_rectangles`
    /// samples by its solid angle; the upload, which has the BVH, clears it where no surface comes
    /// near enough to any to see it at 0.01 sr (`light_shape::rectangle_lights_seen_wide`).
    pub rectangle_lights: bool,
    /// More lights than `emitter_reach` (lights.wgsl) bounds one by one (`MAX_REACH_LIGHTS`): a
    /// direction sample's ray is then traced wherever it crosses one sphere and box around all
    /// of them, which lets through many more rays than the lights' own spheres.
    pub many_lights: bool,
    /// Textures in use, by kind.
    pub base_color_texture: bool,
    pub metallic_roughness_texture: bool,
    pub emissive_texture: bool,
    pub normal_texture: bool,
}

impl SceneFeatures {
    pub fn detect(scene: &Scene) -> SceneFeatures {
        let mut used = vec![false; scene.materials.len()];
        for t in &scene.triangles {
            used[t.material as usize] = true;
        }
        let materials = || scene.materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);
        let glossy = |m: &&crate::scene::Material| m.metallic > 0.0 || m.specular > 0.0;
        let has = |f: fn(&LightKind) -> bool| scene.lights.iter().any(|l| f(&l.kind));
        let shapes: Vec<Option<crate::scene::light_shape::AreaLightShape>> = scene
            .lights
            .iter()
            .map(|l| match &l.kind {
                LightKind::Area { triangles, .. } => {
                    Some(crate::scene::light_shape::area_light_shape(scene, triangles))
                }
                _ => None,
            })
            .collect();
        let round: Vec<bool> = shapes.iter().map(|s| s.is_some_and(|s| s.round)).collect();
        SceneFeatures {
            area_lights: has(|k| matches!(k, LightKind::Area { .. })),
            point_lights: has(|k| matches!(k, LightKind::Point { .. })),
            spot_lights: has(|k| matches!(k, LightKind::Spot { .. })),
            directional_lights: has(|k| matches!(k, LightKind::Directional { .. })),
            single_light: scene.lights.len() == 1,
            all_diffuse: !materials().any(|m| glossy(&m)),
            any_metal: materials().any(|m| m.metallic > 0.0),
            any_glossy: materials().any(|m| glossy(&m)),
            any_mirror: materials().any(|m| glossy(&m) && m.roughness <= 0.0),
            double_sided_emitters: has(|k| matches!(k, LightKind::Area { double_sided: true, .. })),
            round_lights: round.iter().any(|&r| r),
            all_lights_round: !round.is_empty() && round.iter().all(|&r| r),
            parallelogram_lights: shapes.iter().any(|s| s.is_some_and(|s| s.parallelogram.is_some())),
            all_area_lights_parallelograms: shapes.iter().flatten().all(|s| s.parallelogram.is_some()),
            rectangle_lights: shapes.iter().any(|s| s.is_some_and(|s| s.rectangle)),
            many_lights: scene.lights.len() > MAX_REACH_LIGHTS,
            base_color_texture: materials().any(|m| m.base_color_texture.is_some()),
            metallic_roughness_texture: materials().any(|m| m.metallic_roughness_texture.is_some()),
            // An emissive texture matters only where the emissive factor is not zero.
            emissive_texture: materials().any(|m| m.emissive_texture.is_some() && m.is_emissive()),
            normal_texture: materials().any(|m| m.normal_texture.is_some()),
        }
    }

    pub fn textures(&self) -> bool {
        self.base_color_texture || self.metallic_roughness_texture || self.emissive_texture || self.normal_texture
    }

    pub fn delta_lights(&self) -> bool {
        self.point_lights || self.spot_lights || self.directional_lights
    }

    /// "area lights, point lights, glossy, 1 light"
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        let mut add = |on: bool, name: &str| {
            if on {
                parts.push(name.to_owned())
            }
        };
        add(self.area_lights, "area lights");
        add(self.round_lights, "round lights");
        add(self.parallelogram_lights, "parallelogram lights");
        add(self.rectangle_lights, "rectangle lights");
        add(self.point_lights, "point lights");
        add(self.spot_lights, "spot lights");
        add(self.directional_lights, "directional lights");
        add(self.single_light, "one light");
        add(self.all_diffuse, "all diffuse");
        add(self.any_glossy, "glossy");
        add(self.any_metal, "metal");
        add(self.any_mirror, "mirrors");
        add(self.double_sided_emitters, "double-sided emitters");
        add(self.base_color_texture, "base colour textures");
        add(self.metallic_roughness_texture, "metallic-roughness textures");
        add(self.emissive_texture, "emissive textures");
        add(self.normal_texture, "normal textures");
        if parts.is_empty() { "nothing to light".into() } else { parts.join(", ") }
    }
}

/// Where a kernel reads the scene's arrays from, as the scene's upload chose (`GpuScene`,
/// `BvhMemory`). GPUs read storage buffers. CPU adapters read every array that the kernels read
/// through a reader function (the BVH's nodes, vertices, triangles, lights, emitter triangles,
/// light picks, `triangle_lights` and the light tree) from a read-only `rgba32uint` storage
/// texture (`gpu::bindings::TEXEL_ROW`): Mesa 22.3's lavapipe loads a storage buffer's word lane
/// by lane, each through the stack, and gathers a storage texture's texels in a few vector
/// instructions, faster than it gathers a uniform array's elements (docs/performance.md, "Scene
/// arrays in storage textures").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SceneArrayMemory {
    /// The materials, read by index where they are used, as a uniform array of this many (0:
    /// storage): on CPU adapters, where they fit in 64 KiB.
    pub uniform_materials: u32,
    /// The arrays read through reader functions are storage textures (CPU adapters).
    pub texels: bool,
}

#[cfg(test)]
mod tests {
    use super::MAX_REACH_LIGHTS;

    /// `SceneFeatures::many_lights` is what lights.wgsl's emitter_reach tests.
    #[test]
    fn many_lights_is_where_emitter_reach_stops_bounding_each() {
        let lights = crate::shaders::SHADER_FILES.iter().find(|(name, _)| *name == "lights.wgsl").unwrap().1;
        assert!(lights.contains(&format!("const MAX_REACH_LIGHTS: u32 = {MAX_REACH_LIGHTS}u;")));
        assert!(lights.contains("if light_count() > MAX_REACH_LIGHTS {"));
    }
}

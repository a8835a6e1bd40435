//! Which renders may take the unshadowed diffuse light as a control variate
//! (`RenderSettings::control_variate`, `shaders/control_variate.wgsl`).
//!
//! The kernel adds A, the light a Lambertian lobe would receive with nothing in the way, in closed
//! form (Lambert's formula per emitter triangle, or per parallelogram light), and estimates only f L_e V cos − k L_e cos with the
//! strategy's own samples: unbiased, and without variance wherever a diffuse surface sees a light
//! unblocked. A is exact only for lights of constant radiance, and it costs a loop over every
//! emitter polygon at each shading point and direction sample, so the renders that may take it are
//! checked here: by `Accumulation::new` for every render, and by `veach render` and `veach info`
//! first, to name the scene.

use crate::error::{Error, Result};
use crate::features::SceneFeatures;
use crate::kernel_plan::effective_strategy;
use crate::settings::{LightSampling, RenderSettings, Strategy};

/// Emitter triangles the kernel integrates one by one at each shading point.
pub const MAX_CONTROL_VARIATE_TRIANGLES: u32 = 32;

/// Whether `settings` may take the control variate on a scene with these features and emitter
/// triangles: an error that says why not, where it is asked for and cannot be.
pub fn check(features: &SceneFeatures, emitter_triangles: u32, settings: &RenderSettings) -> Result<()> {
    if !settings.control_variate {
        return Ok(());
    }
    let refuse = |why: String| Err(Error::Options(format!("--control-variate: {why}")));
    if effective_strategy(features, settings).0 == Strategy::MisLobes {
        return refuse("works with the uniform, brdf, light and mis strategies, not mis-lobes".into());
    }
    if features.emissive_texture {
        return refuse("needs lights of constant radiance; this scene has emission textures".into());
    }
    if features.any_mirror {
        return refuse("does not take mirrors (roughness 0), which this scene has".into());
    }
    if emitter_triangles > MAX_CONTROL_VARIATE_TRIANGLES {
        return refuse(format!(
            "integrates every emitter triangle at each shading point, so it takes scenes of at most \
             {MAX_CONTROL_VARIATE_TRIANGLES}; this one has {emitter_triangles}"
        ));
    }
    // Cones last: the default (auto) takes them on round lights, and where the scene rules the
    // control variate out anyway, that is what the user needs to hear.
    if settings.light_sampling == LightSampling::Cone
        || (settings.light_sampling == LightSampling::Auto && features.round_lights)
    {
        return refuse(
            "works with area and solid-angle light sampling, not cones (cone, or auto on round lights): \
             add --light-sampling area or solid-angle"
                .into(),
        );
    }
    Ok(())
}

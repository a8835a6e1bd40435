//! The `--stats` JSON report of a render.

use crate::output::RenderOutput;
use crate::render::{GpuScene, Renderer};
use crate::scene::{Camera, Scene};
use crate::settings::RenderSettings;
use serde::Serialize;

#[derive(Serialize)]
pub struct RenderStats {
    pub adapter: String,
    /// Driver name and version (lavapipe's adapter name does not change with the Mesa release).
    pub driver: String,
    pub backend: String,
    pub device_type: String,
    pub scene: SceneCounts,
    pub settings: SettingsReport,
    /// What the scene needs, and the kernel's specialisation.
    pub features: crate::features::SceneFeatures,
    pub kernel: String,
    pub timings_seconds: Timings,
    pub samples_per_pixel: SamplesReport,
    pub rays: u64,
    pub rays_per_second: f64,
    pub nonfinite_samples_dropped: u64,
    /// Camera samples cut short by the driver's loop limit (Mesa 22's lavapipe) and taken again.
    pub truncated_samples_retaken: u64,
    pub dispatches: u32,
    pub interrupted: bool,
}

#[derive(Serialize)]
pub struct SceneCounts {
    pub triangles: usize,
    pub emissive_triangles: usize,
    pub lights: usize,
    pub area_lights: usize,
    pub delta_lights: usize,
    pub materials: usize,
    pub bvh_nodes: usize,
    pub bvh_sah_cost: f32,
    /// Triangles in the BVH's leaves: more than `triangles` where long thin ones were split.
    pub bvh_triangle_references: usize,
    pub gpu_scene_bytes: u64,
}

#[derive(Serialize)]
pub struct SettingsReport {
    pub width: u32,
    pub height: u32,
    pub strategy: String,
    pub light_samples: u32,
    pub brdf_samples: u32,
    pub heuristic: String,
    pub light_selection: String,
    pub light_sampling: String,
    /// The unshadowed diffuse light as a control variate (`--control-variate`).
    pub control_variate: bool,
    pub sampler: String,
    pub seed: u32,
    /// The sequence index of each pixel's first camera sample (`--first-sample`).
    pub first_sample: u32,
    pub camera: String,
}

impl SettingsReport {
    pub fn new(settings: &RenderSettings, camera_name: &str) -> SettingsReport {
        SettingsReport {
            width: settings.width,
            height: settings.height,
            strategy: settings.strategy.name().into(),
            light_samples: settings.light_samples,
            brdf_samples: settings.brdf_samples,
            heuristic: format!("{:?}", settings.heuristic).to_lowercase(),
            light_selection: format!("{:?}", settings.light_selection).to_lowercase(),
            light_sampling: settings.light_sampling.name().into(),
            control_variate: settings.control_variate,
            sampler: settings.sampler.name().into(),
            seed: settings.seed,
            first_sample: settings.first_sample,
            camera: camera_name.into(),
        }
    }

    /// Each setting as (name, value) text, named as in the JSON (an EXR header's attributes).
    pub fn fields(&self) -> Vec<(String, String)> {
        let serde_json::Value::Object(map) = serde_json::to_value(self).expect("plain fields") else {
            unreachable!("a struct serialises to an object")
        };
        map.into_iter()
            .map(|(name, value)| match value {
                serde_json::Value::String(s) => (name, s),
                other => (name, other.to_string()),
            })
            .collect()
    }
}

/// What made an image, for its file's header (EXR text attributes, PNG iTXt chunks; read back with
/// `image_io::read_metadata`): the settings as `--stats` names them, and what the render reached.
/// Every name carries the `veach:` prefix.
pub fn image_metadata(
    settings: &RenderSettings,
    camera: &Camera,
    scene_path: &std::path::Path,
    scene: &Scene,
    out: &RenderOutput,
    renderer: &Renderer,
) -> Vec<(String, String)> {
    let mut fields = SettingsReport::new(settings, &camera.name).fields();
    // Where the camera was: the viewer's orbit moves it away from the scene camera it is named after.
    let vector = |v: glam::Vec3| format!("{} {} {}", v.x + 0.0, v.y + 0.0, v.z + 0.0); // + 0.0: no "-0"
    fields.extend([
        ("camera_position".into(), vector(camera.position)),
        ("camera_forward".into(), vector(camera.forward)),
        ("camera_up".into(), vector(camera.up)),
        ("camera_yfov_degrees".into(), camera.yfov.to_degrees().to_string()),
        ("version".into(), env!("CARGO_PKG_VERSION").to_string()),
        ("scene".into(), scene_path.display().to_string()),
        ("scene_hash".into(), format!("{:016x}", scene.content_hash())),
        ("hide_emitters".into(), settings.hide_emitters.to_string()),
        ("spp".into(), format!("{:.3}", out.mean_samples())),
        ("render_seconds".into(), format!("{:.6}", out.render_time.as_secs_f64())),
        ("adapter".into(), renderer.gpu.describe()),
    ]);
    fields.into_iter().map(|(name, value)| (format!("veach:{name}"), value)).collect()
}

#[derive(Serialize)]
pub struct Timings {
    pub load: f64,
    pub bvh_build: f64,
    pub upload: f64,
    pub pipeline_creation: f64,
    /// Wall clock from submit to completion, summed over dispatches, plus `camera_footprints`.
    pub render: f64,
    /// Building the camera footprint lists, where the kernel reads them (0 otherwise).
    pub camera_footprints: f64,
    /// Summed GPU timestamps of the dispatches (null where the adapter has no timestamps).
    pub render_gpu: Option<f64>,
}

#[derive(Serialize)]
pub struct SamplesReport {
    pub requested: u32,
    pub min: u32,
    pub mean: f64,
}

pub fn render_stats(
    scene: &Scene,
    renderer: &Renderer,
    gpu_scene: &GpuScene,
    settings: &RenderSettings,
    camera_name: &str,
    load_seconds: f64,
    out: &RenderOutput,
) -> RenderStats {
    let info = &renderer.gpu.adapter_info;
    let setup = &gpu_scene.stats;
    let render = out.render_time.as_secs_f64();
    let delta = scene.lights.iter().filter(|l| l.is_delta()).count();
    RenderStats {
        adapter: info.name.clone(),
        driver: renderer.gpu.driver(),
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        scene: SceneCounts {
            triangles: scene.triangles.len(),
            emissive_triangles: scene.emissive_triangle_count(),
            lights: scene.lights.len(),
            area_lights: scene.lights.len() - delta,
            delta_lights: delta,
            materials: scene.materials.len(),
            bvh_nodes: setup.bvh_nodes,
            bvh_sah_cost: setup.bvh_sah_cost,
            bvh_triangle_references: setup.bvh_triangle_references,
            gpu_scene_bytes: setup.gpu_scene_bytes,
        },
        features: gpu_scene.features,
        // The generic kernel reads the strategy at run time; a specialised one has it fixed.
        kernel: match (out.kernel.strategy, out.kernel.wavefront) {
            (None, false) => "generic".into(),
            (None, true) => "generic, wavefront".into(),
            (Some(_), _) => format!("specialised {:?}", out.kernel),
        },
        settings: SettingsReport::new(settings, camera_name),
        timings_seconds: Timings {
            load: load_seconds,
            bvh_build: setup.bvh_build.as_secs_f64(),
            upload: setup.upload.as_secs_f64(),
            pipeline_creation: out.kernel_creation.as_secs_f64(),
            render,
            camera_footprints: out.footprint_build.as_secs_f64(),
            render_gpu: out.gpu_time.map(|t| t.as_secs_f64()),
        },
        samples_per_pixel: SamplesReport { requested: settings.spp, min: out.min_samples(), mean: out.mean_samples() },
        rays: out.rays,
        rays_per_second: if render > 0.0 { out.rays as f64 / render } else { 0.0 },
        nonfinite_samples_dropped: out.nonfinite_samples,
        truncated_samples_retaken: out.truncated_samples,
        dispatches: out.dispatches,
        interrupted: out.interrupted,
    }
}

//! What a render is asked for: the strategy and its sample counts, light selection and sampling,
//! the sampler, image size and budget (`RenderSettings`), and the limits those are held to.

use crate::error::{Error, Result};
use std::time::Duration;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Strategy {
    Uniform,
    Brdf,
    Light,
    Mis,
    /// MIS per BSDF lobe: the diffuse lobe by light sampling alone (n + m light samples where
    /// there is no glossy lobe), the glossy lobe by MIS of n light and m glossy-lobe samples.
    MisLobes,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heuristic {
    Balance,
    Power,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LightSelection {
    /// Every light gets the light samples (the estimator sums over lights).
    Each,
    /// One light per sample, chosen uniformly.
    Uniform,
    /// One light per sample, chosen with probability proportional to its power.
    Power,
    /// One light per sample, chosen per shading point: a quarter by power, three quarters by
    /// power times the BSDF and cosine towards the light over its squared distance
    /// (`prepare_point_selection` in shaders/lights.wgsl). By power where a scene has more than
    /// 16 lights.
    Bsdf,
    /// One light per sample, chosen per shading point by walking the light tree: at each node
    /// the child whose bounds (box, power, emission cone) promise more light to the point and its
    /// normal is more likely (`crate::light_tree`, shaders/light_tree.wgsl; Conty Estevez &
    /// Kulla 2018).
    Tree,
}

/// How light sampling picks a point on an area light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampling {
    /// Uniform on the light's area: p_ω = r² / (|cos θ_l| A). An emitter triangle chosen by area,
    /// then a point on it; a light of two triangles making one parallelogram through the linear
    /// map of the unit square onto it (the same density, better stratified).
    #[default]
    Area,
    /// A direction uniform in the light's solid angle, bounded where area sampling's
    /// r² / cos θ_l blows up (contact edges, grazing angles): a rectangle as a whole (Ureña et al.
    /// 2013), p_ω = 1 / Ω; any other light by an emitter triangle chosen by area, then a direction
    /// uniform in its solid angle (Arvo 1995), p_ω = P(triangle) / Ω. Lights and triangles that
    /// subtend less than 0.01 sr keep area sampling.
    SolidAngle,
    /// Round lights (convex, filling at least half of their bounding sphere's surface: a
    /// tessellated sphere, a cube): a direction uniform in the cone that sphere subtends
    /// (pbrt-v4's `Sphere::Sample`; every direction from inside it), p_ω = P(light) / Ω, traced
    /// to its closest hit. Every other light by area.
    Cone,
    /// Each light by the technique its shape suits: round lights by their cones (as `Cone`),
    /// rectangles by their solid angle (as `SolidAngle`), every other light by area.
    Auto,
}

impl LightSampling {
    /// Are round lights sampled by their bounding cones?
    pub fn cones(self) -> bool {
        matches!(self, LightSampling::Cone | LightSampling::Auto)
    }

    /// Are rectangle lights sampled by their solid angle?
    pub fn spherical_rectangles(self) -> bool {
        matches!(self, LightSampling::SolidAngle | LightSampling::Auto)
    }
}

/// Where a camera sample's random numbers come from (shaders/sampler.wgsl).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampler {
    /// Owen-scrambled Sobol points (Burley 2020): each 1D/2D request stratified over a pixel's
    /// camera samples. Unbiased, and less error per sample wherever the integrand is smooth
    /// (docs/performance.md, "Owen-scrambled Sobol samples").
    #[default]
    Sobol,
    /// Independent uniform numbers: plain Monte Carlo, whose per-pixel sample variance / n is the
    /// variance of the pixel's mean (the statistical tests rely on that).
    Independent,
}

impl Sampler {
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Sobol => "sobol",
            Sampler::Independent => "independent",
        }
    }
}

/// How a camera sample's work is split over kernels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Execution {
    /// Whichever measured faster on the adapter's driver (`features::AutoExecution`): on Mesa 22's
    /// lavapipe the megakernel in straight-line code where it applies (light, uniform and brdf
    /// with one direction sample at most, MIS on textured scenes), else the wavefront for cone
    /// light sampling and on textured scenes; the megakernel otherwise
    /// (docs/performance.md, "Camera samples in straight-line code", "Megakernel against
    /// wavefront").
    #[default]
    Auto,
    /// `render`: the camera ray, light samples and direction samples in one kernel.
    Megakernel,
    /// The light samples in one kernel; the points that take direction samples queued for a
    /// second, which takes them (shaders/wavefront.wgsl).
    Wavefront,
}

impl LightSelection {
    pub const ALL: [LightSelection; 5] = [
        LightSelection::Each,
        LightSelection::Uniform,
        LightSelection::Power,
        LightSelection::Bsdf,
        LightSelection::Tree,
    ];

    /// Its code in the frame's parameters and the kernels' LIGHT_SELECTION (SELECT_* in
    /// shaders/layout.wgsl).
    pub fn gpu_code(self) -> u32 {
        use crate::gpu::layout;
        match self {
            LightSelection::Each => layout::SELECT_EACH,
            LightSelection::Uniform => layout::SELECT_UNIFORM,
            LightSelection::Power => layout::SELECT_POWER,
            LightSelection::Bsdf => layout::SELECT_BSDF,
            LightSelection::Tree => layout::SELECT_TREE,
        }
    }
}

impl LightSampling {
    pub fn name(self) -> &'static str {
        match self {
            LightSampling::Area => "area",
            LightSampling::SolidAngle => "solid-angle",
            LightSampling::Cone => "cone",
            LightSampling::Auto => "auto",
        }
    }
}

impl Strategy {
    pub const ALL: [Strategy; 5] =
        [Strategy::Uniform, Strategy::Brdf, Strategy::Light, Strategy::Mis, Strategy::MisLobes];

    /// Its code in the frame's parameters and the kernels' STRATEGY (STRATEGY_* in
    /// shaders/layout.wgsl).
    pub fn gpu_code(self) -> u32 {
        use crate::gpu::layout;
        match self {
            Strategy::Uniform => layout::STRATEGY_UNIFORM,
            Strategy::Brdf => layout::STRATEGY_BRDF,
            Strategy::Light => layout::STRATEGY_LIGHT,
            Strategy::Mis => layout::STRATEGY_MIS,
            Strategy::MisLobes => layout::STRATEGY_MIS_LOBES,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Uniform => "uniform",
            Strategy::Brdf => "brdf",
            Strategy::Light => "light",
            Strategy::Mis => "mis",
            Strategy::MisLobes => "mis-lobes",
        }
    }
    /// Whether the strategy samples lights (and so can see point, spot and directional lights).
    pub fn samples_lights(self) -> bool {
        matches!(self, Strategy::Light | Strategy::Mis | Strategy::MisLobes)
    }
    /// Default (light samples, BRDF-or-uniform samples) per camera sample: the classic
    /// comparison of MIS with 32 + 32 against 1024 uniform directions.
    pub fn default_sample_counts(self) -> (u32, u32) {
        match self {
            Strategy::Uniform => (0, 1024),
            Strategy::Brdf => (0, 64),
            Strategy::Light => (64, 0),
            Strategy::Mis | Strategy::MisLobes => (32, 32),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Camera samples per pixel. Each one takes `light_samples` light samples and
    /// `brdf_samples` BRDF samples (uniform: `brdf_samples` hemisphere directions).
    pub spp: u32,
    /// The sequence index of each pixel's first camera sample: the render takes samples
    /// [first_sample, first_sample + spp) of the sequence a render from 0 takes, so that renders
    /// of disjoint ranges (on other machines) merge into one (`veach merge`).
    pub first_sample: u32,
    pub strategy: Strategy,
    pub light_samples: u32,
    pub brdf_samples: u32,
    pub heuristic: Heuristic,
    pub light_selection: LightSelection,
    pub light_sampling: LightSampling,
    pub sampler: Sampler,
    pub seed: u32,
    /// Stop once this much render time is spent (whole dispatches), even before `spp`.
    pub time_limit: Option<Duration>,
    /// Aim for dispatches of about this long (a tenth of `time_limit` at most).
    pub dispatch_target: Duration,
    /// Also accumulate the light-sample and BRDF-sample contribution images.
    pub write_aovs: bool,
    /// Leave out emission seen directly by camera rays: the image is reflected direct light only.
    pub hide_emitters: bool,
    /// Use a kernel specialised to the scene's features and the strategy (else the generic one).
    pub specialise: bool,
    /// One kernel per camera sample, or the wavefront split (shaders/wavefront.wgsl).
    pub execution: Execution,
    /// Add the unshadowed diffuse light in closed form and estimate only the difference from it
    /// (`crate::control_variate`, shaders/control_variate.wgsl).
    pub control_variate: bool,
}

impl RenderSettings {
    /// MIS with 1 light + 1 BRDF sample per camera sample, the power heuristic, one light chosen
    /// per shading point by the light tree per light sample, and each light sampled by its shape:
    /// `veach render`'s defaults (measured on the scene zoo), the viewer's start and `veach
    /// scale`'s setting.
    pub fn recommended() -> RenderSettings {
        RenderSettings {
            strategy: Strategy::Mis,
            light_samples: 1,
            brdf_samples: 1,
            heuristic: Heuristic::Power,
            light_selection: LightSelection::Tree,
            light_sampling: LightSampling::Auto,
            ..Default::default()
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        let (light_samples, brdf_samples) = Strategy::Mis.default_sample_counts();
        RenderSettings {
            width: 256,
            height: 256,
            spp: 1,
            first_sample: 0,
            strategy: Strategy::Mis,
            light_samples,
            brdf_samples,
            heuristic: Heuristic::Balance,
            light_selection: LightSelection::Each,
            light_sampling: LightSampling::Area,
            sampler: Sampler::Sobol,
            seed: 0,
            time_limit: None,
            dispatch_target: DEFAULT_DISPATCH_TARGET,
            write_aovs: false,
            hide_emitters: false,
            specialise: true,
            execution: Execution::Auto,
            control_variate: false,
        }
    }
}

/// Half a second: the progress bar moves twice a second, and Ctrl-C waits at most about that long,
/// while lavapipe's 10–20 ms per dispatch beyond its samples stays a few percent of a render (it
/// was 150 ms, whose dispatches cost the Veach scene at 32 spp 1.10x the time;
/// docs/performance.md, "No short last dispatch"). GPUs' watchdogs allow seconds.
pub(crate) const DEFAULT_DISPATCH_TARGET: Duration = Duration::from_millis(500);

/// The largest image `render` takes: 2^28 pixels (16384 × 16384). Its sums come back to the host
/// at 32 bytes a pixel and more (8 GiB here), and the kernels index an image's pixels in 32 bits.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// Refuses an image above `MAX_IMAGE_PIXELS` (`render` does; the CLI before it loads anything).
pub fn check_image_size(width: u32, height: u32) -> Result<()> {
    let pixels = width as u64 * height as u64;
    if pixels > MAX_IMAGE_PIXELS {
        return Err(Error::Options(format!(
            "{width}x{height} is {pixels} pixels; veach renders at most {MAX_IMAGE_PIXELS} (16384x16384)"
        )));
    }
    Ok(())
}

/// Refuses a range of camera samples that runs past the sequence's 2^32 indices.
pub fn check_sample_range(first_sample: u32, spp: u32) -> Result<()> {
    if first_sample.checked_add(spp).is_none() {
        return Err(Error::Options(format!(
            "samples {first_sample} + {spp} run past the last camera sample index ({})",
            u32::MAX
        )));
    }
    Ok(())
}

/// The most light samples, and the most BRDF samples, one camera sample takes: 2^20. Their sum,
/// a pixel's ray count and the kernels' loop counters are 32-bit; past this, more camera samples
/// (`spp`) are the way to more samples.
pub const MAX_SAMPLES_PER_CAMERA_SAMPLE: u32 = 1 << 20;

/// Refuses sample counts above `MAX_SAMPLES_PER_CAMERA_SAMPLE` (`Accumulation` does; the CLI
/// before it loads anything).
pub fn check_sample_counts(light_samples: u32, brdf_samples: u32) -> Result<()> {
    for (flag, n) in [("--light-samples", light_samples), ("--brdf-samples", brdf_samples)] {
        if n > MAX_SAMPLES_PER_CAMERA_SAMPLE {
            return Err(Error::Options(format!(
                "{flag} {n}: at most {MAX_SAMPLES_PER_CAMERA_SAMPLE} per camera sample; take more camera samples (--spp) instead"
            )));
        }
    }
    Ok(())
}

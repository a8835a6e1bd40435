//! `veach view`: the interactive viewer, its options checked before a window opens.

use crate::options::{
    HeuristicArg, LightSamplingArg, SamplerArg, SelectionArg, StrategyArg, heuristic_of, light_sampling_of, sampler_of,
    selection_of, strategy_of,
};
use anyhow::{Result, bail};
use std::path::PathBuf;
use std::time::Duration;
use veach::RenderSettings;

#[derive(clap::Args)]
#[command(after_long_help = "MOUSE AND KEYS
  Drag: orbit. Right or middle drag: pan. Wheel: zoom. Arrows orbit, +/- zoom, R resets the camera.
  Drop a .gltf/.glb on the window to open it, or a linear .exr/.pfm to use it as the reference.

The image accumulates until --max-spp camera samples per pixel (0: never stops) and starts
again whenever a setting or the camera changes. With --screenshot the window renders --frames
frames, saves what it shows as PNG and closes (for docs and smoke tests; on a machine without a
display, run it under xvfb-run).")]
pub struct ViewArgs {
    /// glTF scene (.gltf or .glb)
    scene: PathBuf,
    /// Image width before the resolution scale
    #[arg(long, default_value_t = 256)]
    width: u32,
    /// Image height before the resolution scale
    #[arg(long, default_value_t = 256)]
    height: u32,
    #[arg(long, value_enum, default_value_t = StrategyArg::Mis)]
    strategy: StrategyArg,
    /// Light samples per camera sample [default: 1 for mis, 2 for light]
    #[arg(long)]
    light_samples: Option<u32>,
    /// BRDF samples (uniform: directions) per camera sample [default: 1 for mis, 2 otherwise]
    #[arg(long)]
    brdf_samples: Option<u32>,
    #[arg(long, value_enum, default_value_t = HeuristicArg::Power)]
    heuristic: HeuristicArg,
    #[arg(long, value_enum, default_value_t = SelectionArg::Power)]
    light_selection: SelectionArg,
    /// How a light sample picks its point on an emitter triangle, or its direction towards a round light
    #[arg(long, value_enum, default_value_t = LightSamplingArg::Auto)]
    light_sampling: LightSamplingArg,
    /// Where the camera samples' random numbers come from
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    sampler: SamplerArg,
    /// The unshadowed diffuse light as a control variate (see `veach render --help`)
    #[arg(long)]
    control_variate: bool,
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Stop accumulating at this many camera samples per pixel (0: never)
    #[arg(long, default_value_t = 4096)]
    max_spp: u32,
    /// Camera to start from, by name [default: the scene's first, or one framing the scene]
    #[arg(long)]
    camera: Option<String>,
    /// Reference image (linear .exr or .pfm, same size) for the live relMSE plot
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Exposure in stops
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Render time per frame in milliseconds (dispatches are sized to fit it)
    #[arg(long, default_value_t = 40)]
    frame_ms: u64,
    /// Save a screenshot of the window after --frames frames, then close
    #[arg(long, value_name = "FILE.png")]
    screenshot: Option<PathBuf>,
    /// Frames to render before the screenshot
    #[arg(long, default_value_t = 60)]
    frames: u32,
    /// Use the adapter whose name contains this text (also VEACH_ADAPTER)
    #[arg(long)]
    adapter: Option<String>,
}

pub fn view(args: ViewArgs) -> Result<()> {
    if args.width == 0 || args.height == 0 {
        bail!("--width and --height must be at least 1");
    }
    if !args.exposure.is_finite() {
        bail!("--exposure must be a finite number of stops");
    }
    if let Some(path) = &args.screenshot
        && path.extension().and_then(|e| e.to_str()).is_none_or(|e| !e.eq_ignore_ascii_case("png"))
    {
        bail!("{}: --screenshot writes PNG; give a .png file", path.display());
    }
    veach::settings::check_sample_counts(args.light_samples.unwrap_or(0), args.brdf_samples.unwrap_or(0))?;
    // Fail on a bad scene or reference here, with the file's name, before opening a window.
    let scene = veach::load_gltf(&args.scene)?;
    scene.camera(args.camera.as_deref()).map_err(|m| anyhow::anyhow!("{}: {m}", args.scene.display()))?;
    if let Some(r) = &args.reference {
        veach::image_io::read_reference(r)?;
    }
    let strategy = strategy_of(args.strategy);
    let (light_default, brdf_default) = veach_viewer::app::interactive_sample_counts(strategy);
    let mut options = veach_viewer::ViewerOptions::new(args.scene.clone());
    options.settings = RenderSettings {
        width: args.width,
        height: args.height,
        spp: args.max_spp,
        strategy,
        light_samples: args.light_samples.unwrap_or(light_default),
        brdf_samples: args.brdf_samples.unwrap_or(brdf_default),
        heuristic: heuristic_of(args.heuristic),
        light_selection: selection_of(args.light_selection),
        light_sampling: light_sampling_of(args.light_sampling),
        sampler: sampler_of(args.sampler),
        seed: args.seed,
        control_variate: args.control_variate,
        ..options.settings
    };
    options.camera = args.camera;
    options.reference = args.reference;
    options.exposure = args.exposure;
    options.frame_budget = Duration::from_millis(args.frame_ms.max(1));
    options.screenshot = args.screenshot.map(|p| (p, args.frames.max(1)));
    veach_viewer::run(options, args.adapter).map_err(|e| anyhow::anyhow!("viewer: {e}"))
}

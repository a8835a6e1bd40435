//! `veach`: the command-line front end. `veach render` renders a glTF scene headless.

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use veach::{
    Execution, GpuContext, Heuristic, LightSampling, LightSelection, RenderSettings, Renderer, Sampler, Strategy,
};

#[derive(Parser)]
#[command(
    name = "veach",
    version,
    about = "Direct illumination on the GPU: uniform, BRDF, light and MIS sampling compared"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene (.gltf or .glb) to an image.
    Render(RenderArgs),
    /// Open a scene in the interactive viewer: progressive render, strategy toggles, error plot.
    View(ViewArgs),
    /// Measure error against render time for every strategy (results.csv, plots, report.md).
    Bench(BenchArgs),
    /// Measure how load, BVH build, GPU memory and render time grow with the triangle count,
    /// and render time with the light count (generated scenes; scale.csv and a table).
    Scale(ScaleArgs),
    /// Print what veach sees in a scene: counts, materials, lights, cameras.
    Info {
        /// glTF scene (.gltf or .glb)
        scene: PathBuf,
    },
    /// Write one of the scenes veach generates as .gltf: the ones shipped in assets/, and the
    /// stiff and extreme scenes of the stability suite (stress-*)
    Generate {
        /// Scene name
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(veach::assets::scene_names()))]
        name: String,
        /// Output file (.gltf)
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Write a scene for Mitsuba 3 (scene.xml and PLY meshes), for the peer comparison in
    /// bench/peer_mitsuba.py; refuses materials and lights that would not render the same
    ExportMitsuba {
        /// glTF scene (.gltf or .glb)
        scene: PathBuf,
        /// Output folder
        #[arg(short, long)]
        output: PathBuf,
        /// Camera by name [default: the scene's first]
        #[arg(long)]
        camera: Option<String>,
        /// Write each round light (a tessellated sphere) as an analytic Mitsuba sphere of the same
        /// area, which Mitsuba samples by its cone as `--light-sampling cone` does
        #[arg(long)]
        round_lights_as_spheres: bool,
    },
}

#[derive(clap::Args)]
#[command(after_long_help = "Triangle sweep: the Cornell box around a UV sphere tessellated to about N triangles. \
Light sweep: a floor under a grid of --light-grid small triangles of which K emit (each its own light), with a \
total power that does not depend on K: the geometry is the same for every K. \
Every point is written as glTF to DIR/scenes, loaded back, built and uploaded, rendered once untimed (the \
kernel's compile), then --repeats times with MIS 1 + 1, lights chosen by power; the median render time is \
reported (GPU timestamps where the adapter has them, else wall clock). GPU bytes per triangle count every \
buffer of the scene (BVH nodes, triangle positions and shading data, materials, lights).")]
struct ScaleArgs {
    /// Output directory (generated scenes and scale.csv)
    #[arg(short, long, default_value = "scale-out")]
    output: PathBuf,
    /// Triangle counts to measure, comma-separated (0: skip this sweep)
    #[arg(long, value_delimiter = ',', default_value = "1000,10000,100000,1000000")]
    triangles: Vec<usize>,
    /// Light counts to measure, comma-separated (0: skip this sweep)
    #[arg(long, value_delimiter = ',', default_value = "1,10,100,1000,10000")]
    lights: Vec<usize>,
    /// Triangles in the light sweep's grid (raised to the largest light count)
    #[arg(long, default_value_t = 10000)]
    light_grid: usize,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Camera samples per pixel of each render
    #[arg(long, default_value_t = 8)]
    spp: u32,
    /// Timed renders per point (the median is reported)
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Use the adapter whose name contains this text (also VEACH_ADAPTER)
    #[arg(long)]
    adapter: Option<String>,
}

#[derive(Clone, Copy, ValueEnum)]
enum StrategyArg {
    /// Uniform hemisphere directions (pdf 1/2π)
    Uniform,
    /// glTF BRDF importance sampling
    Brdf,
    /// Light sampling: a point uniform on a light's area
    Light,
    /// Multiple importance sampling of light and BRDF samples
    Mis,
    /// MIS per BSDF lobe: the diffuse lobe by light samples alone (the BRDF samples too become
    /// light samples where there is no glossy lobe), the glossy lobe by MIS of light samples and
    /// samples of that lobe
    MisLobes,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum AovArg {
    Light,
    Brdf,
    Weights,
}

#[derive(Clone, Copy, ValueEnum)]
enum HeuristicArg {
    Balance,
    Power,
}

#[derive(Clone, Copy, ValueEnum)]
enum LightSamplingArg {
    /// A point uniform on the light's area (pdf r² / (|cos θ_l| A)); a quad light through the linear map of the unit square
    Area,
    /// A direction uniform in the emitter triangle's solid angle (Arvo 1995; pdf 1/Ω)
    SolidAngle,
    /// Spheres (round convex lights): a direction uniform in their bounding cone (pdf 1/Ω), traced to the light; other lights by area
    Cone,
}

#[derive(Clone, Copy, ValueEnum)]
enum SamplerArg {
    /// Owen-scrambled Sobol points: each pixel's camera samples stratified (Burley 2020)
    Sobol,
    /// Independent uniform random numbers (plain Monte Carlo)
    Independent,
}

#[derive(Clone, Copy, ValueEnum)]
enum ExecutionArg {
    Auto,
    Megakernel,
    Wavefront,
}

#[derive(Clone, Copy, ValueEnum)]
enum SelectionArg {
    /// Sample every light (the estimator sums over lights)
    Each,
    /// One light per sample, chosen uniformly
    Uniform,
    /// One light per sample, chosen by emitted power
    Power,
    /// One light per sample, chosen per shading point: a quarter by power, three quarters by
    /// power times the BSDF towards the light (by power beyond 16 lights)
    Bsdf,
}

#[derive(clap::Args)]
#[command(after_long_help = "SAMPLE COUNTS
  --spp is the number of camera samples per pixel (jittered over the pixel). At each camera
  sample's first hit, the strategy takes its own samples of the direct-lighting integral:
    uniform: --brdf-samples uniform hemisphere directions      (default 1024)
    brdf:    --brdf-samples BRDF samples                       (default 64)
    light:   --light-samples light samples                     (default 64)
    mis:     --light-samples light + --brdf-samples BRDF samples, MIS-weighted (default 32 + 32)
  With --light-selection each, every light gets --light-samples samples; with uniform or power,
  --light-samples lights are chosen (one per sample). The defaults reproduce the classic
  comparison of MIS with 32 + 32 samples against uniform sampling with 1024. Each count is at
  most 1048576 (2^20) per camera sample; more samples than that are more camera samples.

OUTPUT
  By extension: .exr (linear float RGB), .png (8-bit sRGB after --exposure, clamped), .pfm.
  EXR and PNG headers record the settings that made the image (veach:* text).
  The file is written whole or not at all; Ctrl-C stops early and writes what was accumulated.")]
struct RenderArgs {
    /// glTF scene (.gltf or .glb)
    scene: PathBuf,
    /// Output image: .exr, .png or .pfm
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Camera samples per pixel [default: 1, or unlimited with --time-limit]
    #[arg(long)]
    spp: Option<u32>,
    #[arg(long, value_enum, default_value_t = StrategyArg::Mis)]
    strategy: StrategyArg,
    /// Light samples per camera sample [default: by strategy, see below]
    #[arg(long)]
    light_samples: Option<u32>,
    /// BRDF samples (uniform: hemisphere directions) per camera sample [default: by strategy]
    #[arg(long)]
    brdf_samples: Option<u32>,
    #[arg(long, value_enum, default_value_t = HeuristicArg::Balance)]
    heuristic: HeuristicArg,
    #[arg(long, value_enum, default_value_t = SelectionArg::Each)]
    light_selection: SelectionArg,
    /// How a light sample picks its point on an emitter triangle, or its direction towards a round light
    #[arg(long, value_enum, default_value_t = LightSamplingArg::Area)]
    light_sampling: LightSamplingArg,
    /// Where the camera samples' random numbers come from
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    sampler: SamplerArg,
    /// Leave out emission seen directly by camera rays: reflected light only, as `veach bench`
    /// measures it
    #[arg(long)]
    hide_emitters: bool,
    /// Add the light a diffuse surface would get with nothing in the way, integrated in closed
    /// form per emitter triangle, and estimate only the difference with the strategy's samples:
    /// unbiased, and noiseless wherever a diffuse surface sees a light unblocked (uniform, brdf,
    /// light, mis; at most 32 emitter triangles of constant radiance; pixels of a shadow may come
    /// out slightly below zero at low sample counts)
    #[arg(long)]
    control_variate: bool,
    /// Random seed: the same scene, options and seed give the same image on the same adapter
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Render until this many seconds of render time are spent
    #[arg(long, value_name = "SECONDS")]
    time_limit: Option<f64>,
    /// Camera to render through, by name [default: the scene's first, or one framing the scene]
    #[arg(long)]
    camera: Option<String>,
    /// Exposure in stops for PNG output
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Contribution images of the MIS estimate, written next to OUT: `light` and `brdf`
    /// (OUT.light.EXT, OUT.brdf.EXT: the light-sample and BRDF-sample parts, which add up to
    /// the image) and `weights` (OUT.weights.png: false colour of the share light samples carry,
    /// blue = BRDF samples, red = light samples)
    #[arg(long, value_delimiter = ',', value_name = "light,brdf,weights")]
    aov: Vec<AovArg>,
    /// Write render statistics as JSON
    #[arg(long, value_name = "FILE.json")]
    stats: Option<PathBuf>,
    /// Use the adapter whose name contains this text (also VEACH_ADAPTER)
    #[arg(long)]
    adapter: Option<String>,
    /// Print nothing but errors
    #[arg(short, long)]
    quiet: bool,
    /// Use the generic kernel instead of one specialised to the scene's features and strategy
    #[arg(long)]
    no_specialise: bool,
    /// One kernel per camera sample, or light samples in one and the direction samples of the
    /// points that take some in a second (auto: whichever measured faster on the driver: with Mesa
    /// 22's lavapipe the wavefront for light and mis-lobes and on textured scenes, else megakernel)
    #[arg(long, value_enum, default_value_t = ExecutionArg::Auto)]
    execution: ExecutionArg,
}

#[derive(clap::Args)]
#[command(after_long_help = "MOUSE AND KEYS
  Drag: orbit. Right or middle drag: pan. Wheel: zoom. Arrows orbit, +/- zoom, R resets the camera.
  Drop a .gltf/.glb on the window to open it, or a linear .exr/.pfm to use it as the reference.

The image accumulates until --max-spp camera samples per pixel (0: never stops) and starts
again whenever a setting or the camera changes. With --screenshot the window renders --frames
frames, saves what it shows as PNG and closes (for docs and smoke tests; on a machine without a
display, run it under xvfb-run).")]
struct ViewArgs {
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
    #[arg(long, value_enum, default_value_t = LightSamplingArg::Area)]
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

#[derive(clap::Args)]
#[command(after_long_help = "For each scene: a reference (--reference, or MIS rendered at --reference-spp and cached \
in DIR), then every strategy at budgets 1, 2, 4 ... --max-spp camera samples per pixel (or, with --time-budgets, \
--min-seconds, 2x ... --max-seconds) over --seeds seeds, then every strategy at equal time. Each camera sample \
takes 2 uniform, 2 BRDF, 2 light or 1 + 1 MIS samples (one light chosen by power per light sample), so all \
strategies trace about the same rays per sample. Render time is measured by GPU timestamps where the adapter \
has them (else wall clock), without kernel compilation or uploads.

Writes DIR/results.csv, DIR/report.md, DIR/SCENE-relmse.svg (log-log relMSE against seconds) and \
DIR/SCENE-equal-time.png (reference and every strategy at equal time, with an enlarged crop).")]
struct BenchArgs {
    /// glTF scenes
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// Output directory
    #[arg(short, long, default_value = "bench-out")]
    output: PathBuf,
    #[arg(long, default_value_t = 128)]
    width: u32,
    #[arg(long, default_value_t = 128)]
    height: u32,
    /// Largest budget in camera samples per pixel (budgets double from 1)
    #[arg(long, default_value_t = 64)]
    max_spp: u32,
    /// Budgets in seconds instead of samples
    #[arg(long)]
    time_budgets: bool,
    #[arg(long, default_value_t = 0.05)]
    min_seconds: f64,
    #[arg(long, default_value_t = 1.6)]
    max_seconds: f64,
    /// Renders per budget (seeds 1..=N); the report gives the median and spread
    #[arg(long, default_value_t = 3)]
    seeds: u32,
    /// Reference image (linear .exr or .pfm, same size) instead of rendering one
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Camera samples per pixel of the rendered reference [default: 16 × --max-spp, at least 256]
    #[arg(long)]
    reference_spp: Option<u32>,
    /// Strategies to compare, comma-separated [default: uniform,brdf,light,mis-balance,mis-power,
    /// mis-lobes]; add -solid-angle to a light-sampling one for solid-angle sampling of
    /// emitter triangles (e.g. light-solid-angle), -cone for round lights by their bounding cones,
    /// or -cv to any but mis-lobes for the unshadowed light as a control variate (e.g.
    /// mis-power-cv), then -independent for independent random numbers instead of Sobol points
    /// (e.g. mis-power-independent, light-solid-angle-independent)
    #[arg(long, value_name = "NAMES")]
    strategies: Option<String>,
    /// Seconds of the equal-time comparison [default: mis-balance's time at the largest budget]
    #[arg(long)]
    equal_time: Option<f64>,
    /// Use the adapter whose name contains this text (also VEACH_ADAPTER)
    #[arg(long)]
    adapter: Option<String>,
}

fn main() {
    let cli = Cli::parse();
    quiet_mesa_runtime_dir_warning();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::View(args) => view(args),
        Command::Bench(args) => bench(args),
        Command::Scale(args) => scale(args),
        Command::Info { scene } => info(&scene),
        Command::Generate { name, output } => generate(&name, &output),
        Command::ExportMitsuba { scene, output, camera, round_lights_as_spheres } => {
            export_mitsuba(&scene, &output, camera.as_deref(), round_lights_as_spheres)
        }
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid" when it is unset, which reads like
/// an error of ours: point it at a private directory of our own.
fn quiet_mesa_runtime_dir_warning() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let dir = std::env::temp_dir().join("veach-xdg-runtime");
    #[cfg(unix)]
    let created = {
        use std::os::unix::fs::DirBuilderExt;
        std::fs::DirBuilder::new().mode(0o700).create(&dir).is_ok() || dir.is_dir()
    };
    #[cfg(not(unix))]
    let created = false;
    if created {
        // SAFETY: called at the start of main, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

fn settings_from(args: &RenderArgs) -> Result<RenderSettings> {
    let strategy = strategy_of(args.strategy);
    let (default_light, default_brdf) = strategy.default_sample_counts();
    let light_samples = args.light_samples.unwrap_or(default_light);
    let brdf_samples = args.brdf_samples.unwrap_or(default_brdf);
    if args.width == 0 || args.height == 0 {
        bail!("--width and --height must be at least 1");
    }
    veach::settings::check_image_size(args.width, args.height)?;
    veach::settings::check_sample_counts(light_samples, brdf_samples)?;
    let time_limit = match args.time_limit {
        Some(t) if !(t.is_finite() && t > 0.0) => {
            bail!("--time-limit must be a positive number of seconds")
        }
        Some(t) => {
            Some(Duration::try_from_secs_f64(t).map_err(|_| anyhow::anyhow!("--time-limit {t}: too many seconds"))?)
        }
        None => None,
    };
    if !args.exposure.is_finite() {
        bail!("--exposure must be a finite number of stops");
    }
    let spp = match (args.spp, time_limit) {
        (Some(0), _) => bail!("--spp must be at least 1"),
        (Some(n), _) => n,
        (None, Some(_)) => u32::MAX,
        (None, None) => 1,
    };
    match strategy {
        Strategy::Uniform | Strategy::Brdf if brdf_samples == 0 => {
            bail!("--brdf-samples must be at least 1 for {}", strategy.name())
        }
        Strategy::Light if light_samples == 0 => {
            bail!("--light-samples must be at least 1 for light")
        }
        Strategy::Mis if light_samples + brdf_samples == 0 => {
            bail!("mis needs --light-samples or --brdf-samples above 0")
        }
        Strategy::MisLobes if light_samples == 0 => {
            bail!("--light-samples must be at least 1 for mis-lobes (the diffuse lobe has no other estimator)")
        }
        _ => {}
    }
    Ok(RenderSettings {
        width: args.width,
        height: args.height,
        spp,
        strategy,
        light_samples,
        brdf_samples,
        heuristic: heuristic_of(args.heuristic),
        light_selection: selection_of(args.light_selection),
        light_sampling: light_sampling_of(args.light_sampling),
        sampler: sampler_of(args.sampler),
        seed: args.seed,
        time_limit,
        hide_emitters: args.hide_emitters,
        write_aovs: !args.aov.is_empty(),
        control_variate: args.control_variate,
        specialise: !args.no_specialise,
        execution: match args.execution {
            ExecutionArg::Auto => Execution::Auto,
            ExecutionArg::Megakernel => Execution::Megakernel,
            ExecutionArg::Wavefront => Execution::Wavefront,
        },
        ..Default::default()
    })
}

fn view(args: ViewArgs) -> Result<()> {
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
        veach::image_io::read_image(r)?;
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

fn strategy_of(arg: StrategyArg) -> Strategy {
    match arg {
        StrategyArg::Uniform => Strategy::Uniform,
        StrategyArg::Brdf => Strategy::Brdf,
        StrategyArg::Light => Strategy::Light,
        StrategyArg::Mis => Strategy::Mis,
        StrategyArg::MisLobes => Strategy::MisLobes,
    }
}

fn heuristic_of(arg: HeuristicArg) -> Heuristic {
    match arg {
        HeuristicArg::Balance => Heuristic::Balance,
        HeuristicArg::Power => Heuristic::Power,
    }
}

fn light_sampling_of(arg: LightSamplingArg) -> LightSampling {
    match arg {
        LightSamplingArg::Area => LightSampling::Area,
        LightSamplingArg::SolidAngle => LightSampling::SolidAngle,
        LightSamplingArg::Cone => LightSampling::Cone,
    }
}

fn sampler_of(arg: SamplerArg) -> Sampler {
    match arg {
        SamplerArg::Sobol => Sampler::Sobol,
        SamplerArg::Independent => Sampler::Independent,
    }
}

fn selection_of(arg: SelectionArg) -> LightSelection {
    match arg {
        SelectionArg::Each => LightSelection::Each,
        SelectionArg::Uniform => LightSelection::Uniform,
        SelectionArg::Power => LightSelection::Power,
        SelectionArg::Bsdf => LightSelection::Bsdf,
    }
}

fn render(args: RenderArgs) -> Result<()> {
    let settings = settings_from(&args)?;
    // Refuse an unknown output type before spending time on the render.
    veach::image_io::ImageFormat::from_path(&args.output)?;
    // And an output (or --stats file) that could not be written.
    veach::image_io::check_writable(&args.output)?;
    if let Some(path) = &args.stats {
        veach::image_io::check_writable(path)?;
    }
    let say = |msg: String| {
        if !args.quiet {
            eprintln!("{msg}");
        }
    };

    let load_start = Instant::now();
    let scene = veach::load_gltf(&args.scene)?;
    let load_seconds = load_start.elapsed().as_secs_f64();
    for w in &scene.warnings {
        say(format!("warning: {}: {w}", args.scene.display()));
    }
    let camera = scene.camera(args.camera.as_deref()).map_err(|m| anyhow::anyhow!("{}: {m}", args.scene.display()))?;
    if scene.lights.is_empty() {
        say(format!(
            "warning: {}: the scene has no lights; only emitters seen directly would show",
            args.scene.display()
        ));
    }
    if !args.aov.is_empty() && !matches!(settings.strategy, Strategy::Mis | Strategy::MisLobes) {
        say(format!(
            "note: contribution images split the {} estimate into light-sample and BRDF-sample parts; \
             they show MIS weighting only with --strategy mis or mis-lobes",
            settings.strategy.name()
        ));
    }
    if !settings.strategy.samples_lights() && scene.has_delta_lights() {
        say(format!(
            "warning: the {} strategy cannot reach point, spot or directional lights (they are deltas); \
             {} of the scene's lights are left out of this image",
            settings.strategy.name(),
            scene.lights.iter().filter(|l| l.is_delta()).count()
        ));
    }

    let gpu = GpuContext::new(args.adapter.as_deref())?;
    say(format!("adapter: {}; driver: {}", gpu.describe(), gpu.driver()));
    let renderer = Renderer::new(gpu)?;
    let gpu_scene = renderer.upload_scene(&scene)?;
    // Before any kernel is built, and naming the scene.
    veach::control_variate::check(&gpu_scene.features, gpu_scene.emitter_triangles(), &settings)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene.display()))?;
    say(format!(
        "scene features: {}; kernel: {}{}",
        gpu_scene.features.describe(),
        match (settings.specialise, gpu_scene.baked_triangles()) {
            (false, _) => "generic".to_string(),
            (true, 0) => "specialised".to_string(),
            (true, n) => format!("specialised, {n} triangles compiled in"),
        },
        if veach::features::KernelKey::for_render(&gpu_scene.features, &settings, renderer.gpu.auto_execution())
            .wavefront
        {
            ", wavefront"
        } else {
            ""
        }
    ));

    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // Ctrl-C: finish the dispatch in flight, then write what was accumulated.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(1000) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta} {msg}")
            .expect("valid template"),
    );
    let pixels = settings.width as u64 * settings.height as u64;
    let out = renderer.render(&gpu_scene, &settings, &camera, &mut |p| {
        bar.set_position((p.fraction * 1000.0) as u64);
        bar.set_message(format!("{:.1} spp", p.pixel_samples_done as f64 / pixels as f64));
        !stop.load(Ordering::SeqCst)
    })?;
    bar.finish_and_clear();
    if out.interrupted {
        say("interrupted: writing the samples accumulated so far".into());
    }

    // What made the image, in an EXR or PNG file's header (`veach::image_io::read_metadata`).
    let made_by = veach::stats::image_metadata(&settings, &camera, &args.scene, &out, &renderer);
    let mut metadata = made_by.clone();
    if veach::image_io::ImageFormat::from_path(&args.output)? == veach::image_io::ImageFormat::Png {
        metadata.push(("veach:exposure".into(), args.exposure.to_string()));
    }
    veach::image_io::write_image_with_metadata(
        &args.output,
        out.width,
        out.height,
        &out.mean(),
        args.exposure,
        &metadata,
    )?;
    if let Some(images) = out.contribution_images() {
        let (light, brdf, emitted) = (&images.light, &images.brdf, &images.emitted_luminance);
        let ext = args.output.extension().and_then(|e| e.to_str()).unwrap_or("exr");
        let sibling = |name: &str, ext: &str| args.output.with_extension(format!("{name}.{ext}"));
        let mut written = Vec::new();
        if args.aov.contains(&AovArg::Light) {
            let path = sibling("light", ext);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, light, args.exposure, &metadata)?;
            written.push(path);
        }
        if args.aov.contains(&AovArg::Brdf) {
            let path = sibling("brdf", ext);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, brdf, args.exposure, &metadata)?;
            written.push(path);
        }
        if args.aov.contains(&AovArg::Weights) {
            let path = sibling("weights", "png");
            let colours = veach::image_io::light_share_false_colour(light, brdf, emitted);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, &colours, 0.0, &made_by)?;
            written.push(path);
        }
        let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
        say(format!("contribution images: {}", names.join(", ")));
    }
    let render_s = out.render_time.as_secs_f64();
    say(format!(
        "{}: {}x{}, {:.1} spp ({} {}+{}), render {:.3} s, {:.2} Mrays/s{}",
        args.output.display(),
        out.width,
        out.height,
        out.mean_samples(),
        settings.strategy.name(),
        if settings.strategy.samples_lights() { settings.light_samples } else { 0 },
        if settings.strategy == Strategy::Light { 0 } else { settings.brdf_samples },
        render_s,
        if render_s > 0.0 { out.rays as f64 / render_s / 1e6 } else { 0.0 },
        if out.nonfinite_samples > 0 {
            format!(", {} samples dropped (not finite, or their square overflows f32)", out.nonfinite_samples)
        } else {
            String::new()
        }
    ));
    if let Some(path) = &args.stats {
        let stats =
            veach::stats::render_stats(&scene, &renderer, &gpu_scene, &settings, &camera.name, load_seconds, &out);
        let text = serde_json::to_string_pretty(&stats)?;
        veach::image_io::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(text.as_bytes()).map_err(|e| e.to_string())
        })?;
    }
    Ok(())
}

fn scale(args: ScaleArgs) -> Result<()> {
    use veach::scale::{ScaleConfig, run_scale, scale_csv, scale_report};
    if args.width == 0 || args.height == 0 || args.spp == 0 || args.repeats == 0 {
        bail!("--width, --height, --spp and --repeats must be at least 1");
    }
    let triangles: Vec<usize> = args.triangles.iter().copied().filter(|&n| n > 0).collect();
    let lights: Vec<usize> = args.lights.iter().copied().filter(|&n| n > 0).collect();
    if triangles.is_empty() && lights.is_empty() {
        bail!("--triangles and --lights name no count to measure");
    }
    std::fs::create_dir_all(args.output.join("scenes"))
        .with_context(|| format!("cannot create {}", args.output.join("scenes").display()))?;
    let config = ScaleConfig {
        output: args.output.clone(),
        triangles,
        lights,
        light_grid: args.light_grid,
        width: args.width,
        height: args.height,
        spp: args.spp,
        repeats: args.repeats,
    };
    let gpu = GpuContext::new(args.adapter.as_deref())?;
    eprintln!("adapter: {}; driver: {}", gpu.describe(), gpu.driver());
    let renderer = Renderer::new(gpu)?;
    let bar = ProgressBar::new((config.triangles.len() + config.lights.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg}")
            .expect("valid template"),
    );
    let mut started = false;
    let rows = run_scale(&renderer, &config, &mut |what| {
        if started {
            bar.inc(1);
        }
        started = true;
        bar.set_message(what.to_string());
    })?;
    bar.finish_and_clear();
    let csv_path = args.output.join("scale.csv");
    veach::image_io::write_atomically(&csv_path, |f| {
        use std::io::Write;
        f.write_all(scale_csv(&rows).as_bytes()).map_err(|e| e.to_string())
    })?;
    println!(
        "{}x{}, {} spp, MIS 1 + 1 (the light sweep also light sampling, 2 samples), lights by power, median of {} renders\n",
        config.width, config.height, config.spp, config.repeats
    );
    println!("{}", scale_report(&rows));
    println!("wrote {}", csv_path.display());
    Ok(())
}

/// Whether `t` seconds make a `Duration` (finite, not negative, not beyond u64 seconds).
fn seconds(t: f64) -> bool {
    Duration::try_from_secs_f64(t).is_ok()
}

fn bench(args: BenchArgs) -> Result<()> {
    use veach::bench::Budget;
    use veach::bench_run::{BenchConfig, bench_scene, bench_units, csv, slope_warnings};
    if args.width == 0 || args.height == 0 || args.max_spp == 0 || args.seeds == 0 {
        bail!("--width, --height, --max-spp and --seeds must be at least 1");
    }
    let budgets: Vec<Budget> = if args.time_budgets {
        if !(args.min_seconds > 0.0 && args.max_seconds >= args.min_seconds && seconds(args.max_seconds)) {
            bail!("--min-seconds must be positive and at most --max-seconds, a finite number of seconds");
        }
        std::iter::successors(Some(args.min_seconds), |t| Some(t * 2.0))
            .take_while(|t| *t <= args.max_seconds * 1.0001)
            .map(Budget::Seconds)
            .collect()
    } else {
        std::iter::successors(Some(1u32), |n| n.checked_mul(2))
            .take_while(|n| *n <= args.max_spp)
            .map(Budget::Spp)
            .collect()
    };
    if args.equal_time.is_some_and(|t| !(t > 0.0 && seconds(t))) {
        bail!("--equal-time must be a positive, finite number of seconds");
    }
    if args.strategies.as_deref().is_some_and(|s| s.split(',').all(|n| n.trim().is_empty())) {
        bail!("--strategies names no strategy");
    }
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    let config = BenchConfig {
        width: args.width,
        height: args.height,
        budgets,
        seeds: args.seeds,
        strategies: match &args.strategies {
            Some(names) => veach::bench::strategies_by_name(names).map_err(|e| anyhow::anyhow!(e))?,
            None => veach::bench::default_strategies(),
        },
        reference_spp: args.reference_spp.unwrap_or((16 * args.max_spp).max(256)),
        reference: args.reference.clone(),
        equal_time: args.equal_time,
        out_dir: args.output.clone(),
    };
    // Load every scene first: a bad file fails before any time is spent.
    let mut scenes = Vec::new();
    for path in &args.scenes {
        let scene = veach::load_gltf(path)?;
        let camera = scene.camera(None).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
        scenes.push((path, scene, camera));
    }
    let gpu = GpuContext::new(args.adapter.as_deref())?;
    eprintln!("adapter: {}; driver: {}", gpu.describe(), gpu.driver());
    let renderer = Renderer::new(gpu)?;
    let per_scene = bench_units(&config);
    let total = per_scene * scenes.len() as u64;
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} eta {eta} {msg}")
            .expect("valid template"),
    );
    let mut rows = Vec::new();
    let counts: Vec<String> = config
        .strategies
        .iter()
        .map(|s| match s.strategy {
            Strategy::Uniform | Strategy::Brdf => format!("{} {}", s.name, s.brdf_samples),
            Strategy::Light => format!("{} {}", s.name, s.light_samples),
            Strategy::Mis | Strategy::MisLobes => format!("{} {} + {}", s.name, s.light_samples, s.brdf_samples),
        })
        .collect();
    let mut report = format!(
        "# veach bench\n\nAdapter: {}; driver: {}. Samples per camera sample: {} (one light chosen by power per light \
         sample). Times are render times only ({}).\n\n",
        renderer.gpu.describe(),
        renderer.gpu.driver(),
        counts.join(", "),
        if renderer.gpu.has_timestamps { "GPU timestamps" } else { "wall clock around submit and wait" }
    );
    let mut summaries = Vec::new();
    for (k, (path, scene, camera)) in scenes.iter().enumerate() {
        let gpu_scene = renderer.upload_scene(scene)?;
        let result = bench_scene(
            &renderer,
            scene,
            &gpu_scene,
            camera,
            path,
            &config,
            &mut |done, _, msg| {
                bar.set_position(done);
                bar.set_message(msg.to_owned());
            },
            k as u64 * per_scene,
            total,
        )?;
        rows.extend(result.rows.iter().cloned());
        report.push_str(&result.report);
        summaries.push(result);
    }
    bar.finish_and_clear();
    let write_text = |name: &str, text: &str| -> Result<()> {
        veach::image_io::write_atomically(&args.output.join(name), |f| {
            use std::io::Write;
            f.write_all(text.as_bytes()).map_err(|e| e.to_string())
        })?;
        Ok(())
    };
    write_text("results.csv", &csv(&rows))?;
    write_text("report.md", &report)?;

    println!("{:<16} {:<12} {:>10} {:>12} {:>8}", "scene", "strategy", "spp", "relMSE", "slope");
    for b in &summaries {
        for r in &b.equal_time {
            let slope = b
                .curves
                .iter()
                .find(|c| c.strategy == r.strategy)
                .and_then(veach::bench::fit_convergence)
                .map(|(_, s)| format!("{s:.2}"))
                .unwrap_or_else(|| "-".into());
            println!("{:<16} {:<12} {:>10.1} {:>12.3e} {:>8}", b.scene, r.strategy, r.spp, r.metrics.relmse, slope);
        }
        for w in slope_warnings(b) {
            println!("warning: {w}");
        }
    }
    println!("(equal time per scene; relMSE against the reference; slope of log relMSE vs log seconds)");
    eprintln!("wrote {}", args.output.join("report.md").display());
    Ok(())
}

fn info(path: &Path) -> Result<()> {
    let scene = veach::load_gltf(path)?;
    let b = scene.bounds();
    println!("{}", path.display());
    println!("  triangles: {} ({} emissive)", scene.triangles.len(), scene.emissive_triangle_count());
    println!("  bounds: {:?} .. {:?}", b.min.to_array(), b.max.to_array());
    println!("  materials: {}", scene.materials.len());
    for m in &scene.materials {
        println!(
            "    {}: base {:?} metallic {} roughness {} emission {:?}{}",
            m.name,
            m.base_color.to_array(),
            m.metallic,
            m.roughness,
            m.emission.to_array(),
            if m.double_sided { " double-sided" } else { "" }
        );
    }
    println!("  lights: {}", scene.lights.len());
    for l in &scene.lights {
        let kind = match &l.kind {
            veach::scene::LightKind::Area { triangles, .. } => {
                format!("area, {} triangles", triangles.len())
            }
            veach::scene::LightKind::Point { .. } => "point".into(),
            veach::scene::LightKind::Spot { .. } => "spot".into(),
            veach::scene::LightKind::Directional { .. } => "directional".into(),
        };
        println!("    {} ({kind})", l.name);
    }
    if !scene.textures.is_empty() {
        println!("  textures: {}", scene.textures.len());
        for t in &scene.textures {
            let wrap = format!("{:?} x {:?}", t.wrap_s, t.wrap_t);
            let filter = if t.nearest { "nearest" } else { "bilinear" };
            println!("    {}: {}x{}, {wrap}, {filter}", t.name, t.width, t.height);
        }
    }
    let features = veach::features::SceneFeatures::detect(&scene);
    println!("  features: {}", features.describe());
    // Whether MIS renders of it may take --control-variate (the check `veach render` makes).
    let controlled = RenderSettings { control_variate: true, ..RenderSettings::mis_power() };
    let emitters = scene.emissive_triangle_count() as u32;
    match veach::control_variate::check(&features, emitters, &controlled) {
        Ok(()) => println!("  control variate: takes --control-variate"),
        Err(e) => println!("  control variate: no ({e})"),
    }
    println!("  cameras: {}", scene.cameras.len());
    for c in &scene.cameras {
        println!("    '{}' at {:?}, yfov {:.1}°", c.name, c.position.to_array(), c.yfov.to_degrees());
    }
    for w in &scene.warnings {
        println!("  warning: {w}");
    }
    Ok(())
}

fn export_mitsuba(path: &Path, output: &Path, camera: Option<&str>, round_lights_as_spheres: bool) -> Result<()> {
    let scene = veach::load_gltf(path)?;
    let camera = scene.camera(camera).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
    veach::mitsuba::export(&scene, &camera, output, round_lights_as_spheres)
        .with_context(|| format!("{}", path.display()))?;
    eprintln!("wrote {}", output.join("scene.xml").display());
    Ok(())
}

fn generate(name: &str, output: &Path) -> Result<()> {
    let builder = veach::assets::generate_scene(name).with_context(|| format!("unknown scene '{name}'"))?;
    builder.write(output)?;
    eprintln!("wrote {}", output.display());
    Ok(())
}

//! `veach render`: a glTF scene to an image, headless.

use crate::console::errln;
use crate::options::{
    ExecutionArg, HeuristicArg, LightSamplingArg, SamplerArg, SelectionArg, StrategyArg, execution_of, heuristic_of,
    light_sampling_of, sampler_of, selection_of, strategy_of,
};
use anyhow::{Result, bail};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use veach::{GpuContext, LightSelection, RenderSettings, Renderer, Strategy};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum AovArg {
    Light,
    Brdf,
    Weights,
}

#[derive(clap::Args)]
#[command(after_long_help = "DEFAULTS
  Without --strategy, veach picks what measured best on its scene zoo (bench/zoo.py): MIS with
  1 light + 1 BRDF sample per camera sample, the power heuristic, one light chosen per shading
  point by the light tree per light sample, each light sampled by its shape (--light-sampling
  auto), 32 camera samples per pixel. Each option given replaces its part of that.

SAMPLE COUNTS
  --spp is the number of camera samples per pixel (jittered over the pixel). At each camera
  sample's first hit, the strategy takes its own samples of the direct-lighting integral. Named
  with --strategy, each takes the counts of the classic comparison (and 1 spp, every light
  sampled by area, the balance heuristic):
    uniform: --brdf-samples uniform hemisphere directions      (default 1024)
    brdf:    --brdf-samples BRDF samples                       (default 64)
    light:   --light-samples light samples                     (default 64)
    mis:     --light-samples light + --brdf-samples BRDF samples, MIS-weighted (default 32 + 32)
  With --light-selection each, every light gets --light-samples samples; with uniform or power,
  --light-samples lights are chosen (one per sample). Each count is at most 1048576 (2^20) per
  camera sample; more samples than that are more camera samples.

SPLITTING
  Camera samples are independent: `--first-sample 0 --spp 16`, `--first-sample 16 --spp 48` and
  `veach merge` of the two EXR files give the `--spp 64` render (up to float rounding). Each EXR
  records its range, the scene's content hash and every setting; the merge refuses parts that
  differ or whose ranges overlap or leave a gap. docs/scale-out.md runs it as a Slurm job array.

OUTPUT
  By extension: .exr (linear float RGB), .png (8-bit sRGB after --exposure, clamped), .pfm.
  EXR and PNG headers record the settings that made the image (veach:* text).
  The file is written whole or not at all. Ctrl-C or SIGTERM stops after the pass in progress
  and writes it, every pixel with the same samples; a second one quits without writing.")]
pub struct RenderArgs {
    /// glTF scene (.gltf or .glb)
    scene: PathBuf,
    /// Output image: .exr, .png or .pfm
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Camera samples per pixel [default: 32; 1 with --strategy; unlimited with --time-limit]
    #[arg(long)]
    spp: Option<u32>,
    /// Take camera samples K .. K+spp-1 of the sequence a render from 0 takes: renders of
    /// disjoint ranges, on one machine or many, add up with `veach merge` to the render of them
    /// all (see SPLITTING below)
    #[arg(long, value_name = "K", default_value_t = 0)]
    first_sample: u32,
    /// The estimator [default: mis 1 + 1, see DEFAULTS below]
    #[arg(long, value_enum)]
    strategy: Option<StrategyArg>,
    /// Light samples per camera sample [default: by strategy, see below]
    #[arg(long)]
    light_samples: Option<u32>,
    /// BRDF samples (uniform: hemisphere directions) per camera sample [default: by strategy]
    #[arg(long)]
    brdf_samples: Option<u32>,
    /// MIS weights [default: power; balance with --strategy]
    #[arg(long, value_enum)]
    heuristic: Option<HeuristicArg>,
    /// How light samples choose a light [default: tree; each with --strategy]
    #[arg(long, value_enum)]
    light_selection: Option<SelectionArg>,
    /// How a light sample picks its point on a light, or its direction towards it [default: auto; area with --strategy]
    #[arg(long, value_enum)]
    light_sampling: Option<LightSamplingArg>,
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
    /// 22's lavapipe the wavefront for cone sampling and on textured scenes, but the megakernel
    /// where a camera sample takes one direction sample at most and runs in straight-line code
    /// (light; brdf and uniform; mis on textured scenes); with NVIDIA's the wavefront for mis;
    /// else the megakernel)
    #[arg(long, value_enum, default_value_t = ExecutionArg::Auto)]
    execution: ExecutionArg,
}

/// Where a contribution image goes: beside the output, OUT.light.EXT, OUT.brdf.EXT or
/// OUT.weights.png.
fn aov_path(output: &std::path::Path, aov: AovArg) -> PathBuf {
    let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("exr");
    match aov {
        AovArg::Light => output.with_extension(format!("light.{ext}")),
        AovArg::Brdf => output.with_extension(format!("brdf.{ext}")),
        AovArg::Weights => output.with_extension("weights.png"),
    }
}

/// The camera samples per pixel of a render without --strategy or --spp.
const DEFAULT_SPP: u32 = 32;

pub fn settings_from(args: &RenderArgs) -> Result<RenderSettings> {
    // Without --strategy: MIS 1 + 1, the power heuristic, lights by the light tree, 32 spp. On the
    // scene zoo (35 scenes, 128x96, 16 spp; docs/performance.md, "Defaults on the scene zoo" and
    // "The light tree on the zoo") it was the most robust setting measured: the classic MIS 32 +
    // 32 with every light sampled took 0.40-0.41x the efficiency of lights by power and failed on
    // the 5 scenes of 100 lights or more (Mesa 22's loop limit); choosing lights per point by the
    // BSDF gained 1.06-1.10x over power on average but fell to 0.23-0.35x on point and spot lights
    // and degenerate emitters; the light tree gained 1.36x over power on average (seed 1), 1.2-12x
    // on every scene of 100 lights or more, and chose no worse per sample anywhere but one glossy
    // scene (1.12x power's relMSE there). Lights sampled by shape (auto) over area: see
    // docs/performance.md, "Light sampling by shape".
    let named = args.strategy.is_some();
    let strategy = args.strategy.map_or(Strategy::Mis, strategy_of);
    let (default_light, default_brdf) = if named { strategy.default_sample_counts() } else { (1, 1) };
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
        (None, Some(_)) => u32::MAX - args.first_sample,
        (None, None) if named => 1,
        (None, None) => DEFAULT_SPP,
    };
    veach::settings::check_sample_range(args.first_sample, spp)?;
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
        first_sample: args.first_sample,
        strategy,
        light_samples,
        brdf_samples,
        heuristic: match (args.heuristic, named) {
            (Some(h), _) => heuristic_of(h),
            (None, true) => veach::Heuristic::Balance,
            (None, false) => veach::Heuristic::Power,
        },
        light_selection: match (args.light_selection, named) {
            (Some(l), _) => selection_of(l),
            (None, true) => veach::LightSelection::Each,
            (None, false) => veach::LightSelection::Tree,
        },
        light_sampling: match (args.light_sampling, named) {
            (Some(l), _) => light_sampling_of(l),
            (None, true) => veach::LightSampling::Area,
            (None, false) => veach::LightSampling::Auto,
        },
        sampler: sampler_of(args.sampler),
        seed: args.seed,
        time_limit,
        hide_emitters: args.hide_emitters,
        write_aovs: !args.aov.is_empty(),
        control_variate: args.control_variate,
        specialise: !args.no_specialise,
        execution: execution_of(args.execution),
        ..Default::default()
    })
}

pub fn render(args: RenderArgs) -> Result<()> {
    let settings = settings_from(&args)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // Installed first, so that a signal during loading is not fatal either. Ctrl-C or
        // SIGTERM: finish the pass in flight, then write what was accumulated; a
        // second one quits at once, writing nothing.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    // Refuse an unknown output type before spending time on the render.
    veach::image_io::ImageFormat::from_path(&args.output)?;
    // And an output (or --stats file) that could not be written.
    veach::image_io::check_writable(&args.output)?;
    if let Some(path) = &args.stats {
        for (other, what) in [(&args.output, "the output image"), (&args.scene, "the scene")] {
            if veach::image_io::same_file(path, other) {
                bail!("--stats {} would overwrite {what}; give the statistics a file of their own", path.display());
            }
        }
        for aov in &args.aov {
            if veach::image_io::same_file(path, &aov_path(&args.output, *aov)) {
                bail!(
                    "--stats {} would overwrite a contribution image; give the statistics a file of their own",
                    path.display()
                );
            }
        }
        veach::image_io::check_writable(path)?;
    }
    let say = |msg: String| {
        if !args.quiet {
            errln!("{msg}");
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
        if veach::kernel_plan::runs_wavefront(&gpu_scene.features, &settings, renderer.gpu.auto_execution()) {
            ", wavefront"
        } else {
            ""
        }
    ));
    if gpu_scene.sealed_lights() > 0
        && settings.strategy.samples_lights()
        && settings.light_selection == LightSelection::Tree
    {
        say(format!(
            "{} sealed in a closed surface: no light samples outside it",
            match gpu_scene.sealed_lights() {
                1 => "1 light".to_string(),
                n => format!("{n} lights"),
            }
        ));
    }

    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(1000) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta} {msg}")
            .expect("valid template"),
    );
    let pixels = settings.width as u64 * settings.height as u64;
    let mut told = false;
    let out = renderer.render(&gpu_scene, &settings, &camera, &mut |p| {
        bar.set_position((p.fraction * 1000.0) as u64);
        let stopping = stop.load(Ordering::SeqCst);
        if stopping && !told {
            told = true;
            bar.println("stopping: finishing the pass in progress so that every pixel has the same samples (again to quit without writing)");
        }
        bar.set_message(format!("{:.1} spp", p.pixel_samples_done as f64 / pixels as f64));
        !stopping
    })?;
    bar.finish_and_clear();
    // Every pixel of an image veach writes has the same camera samples (a render stops between
    // passes); only a tiled render stopped before its last tile can miss rows.
    let (fewest, most) = (out.min_samples(), out.max_samples());
    if fewest != most || fewest == 0 {
        bail!(
            "interrupted before every pixel had a camera sample (pixels have {fewest} to {most}); {} not written",
            args.output.display()
        );
    }
    if out.interrupted {
        say(format!("interrupted: writing the {fewest} camera samples per pixel taken so far"));
    }

    // What made the image, in an EXR or PNG file's header (`veach::image_io::read_metadata`).
    let metadata = veach::stats::image_metadata(&settings, &camera, &args.scene, &scene, &out, &renderer);
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
        let mut written = Vec::new();
        if args.aov.contains(&AovArg::Light) {
            let path = aov_path(&args.output, AovArg::Light);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, light, args.exposure, &metadata)?;
            written.push(path);
        }
        if args.aov.contains(&AovArg::Brdf) {
            let path = aov_path(&args.output, AovArg::Brdf);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, brdf, args.exposure, &metadata)?;
            written.push(path);
        }
        if args.aov.contains(&AovArg::Weights) {
            let path = aov_path(&args.output, AovArg::Weights);
            let colours = veach::image_io::light_share_false_colour(light, brdf, emitted);
            veach::image_io::write_image_with_metadata(&path, out.width, out.height, &colours, 0.0, &metadata)?;
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

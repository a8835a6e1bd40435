//! `veach scale`: cost against triangle and light count.

use crate::console::errln;
use crate::console::outln;
use crate::options::{ExecutionArg, execution_of};
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use veach::{GpuContext, Renderer};

#[derive(clap::Args)]
#[command(after_long_help = "Triangle sweep: the Cornell box around a UV sphere tessellated to about N triangles. \
Light sweep: a floor under a grid of --light-grid small triangles of which K emit (each its own light), with a \
total power that does not depend on K: the geometry is the same for every K. \
Every point is written as glTF to DIR/scenes, loaded back, built and uploaded, rendered once untimed (the \
kernel's compile), then --repeats times with MIS 1 + 1, lights chosen by power, each repeat rendering every \
point of the sweep in turn, so that drift in the machine's speed moves every point alike; the median render time is \
reported (GPU timestamps where the adapter has them, else wall clock), and against the sweep's first point the \
median of the repeats' ratios, with the smallest and largest (also in scale.csv). GPU bytes per triangle count every \
buffer of the scene (BVH nodes, triangle positions and shading data, materials, lights).")]
pub struct ScaleArgs {
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
    /// Timed renders per point: the median is reported, and each point's ratio to the first as the
    /// median of the repeats' ratios (the points render in turn, once per repeat)
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Use the adapter whose name contains this text (also VEACH_ADAPTER)
    #[arg(long)]
    adapter: Option<String>,
    /// The kernels every render runs (as `veach render --execution`)
    #[arg(long, value_enum, default_value_t = ExecutionArg::Auto)]
    execution: ExecutionArg,
}

pub fn scale(args: ScaleArgs) -> Result<()> {
    use veach_bench::scale::{ScaleConfig, run_scale, scale_csv, scale_report, scale_steps};
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
        execution: execution_of(args.execution),
    };
    let gpu = GpuContext::new(args.adapter.as_deref())?;
    errln!("adapter: {}; driver: {}", gpu.describe(), gpu.driver());
    let renderer = Renderer::new(gpu)?;
    let bar = ProgressBar::new(scale_steps(&config) as u64);
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
    let execution = match args.execution {
        ExecutionArg::Auto => "",
        ExecutionArg::Megakernel => ", the megakernel",
        ExecutionArg::Wavefront => ", the wavefront kernels",
    };
    outln!(
        "{}x{}, {} spp, MIS 1 + 1 (the light sweep also light sampling, 2 samples), lights by the light tree{execution}, median of {} renders;\n× first: the median of the renders' ratios to the sweep's first point, each rendered in the same turn (smallest–largest)\n",
        config.width,
        config.height,
        config.spp,
        config.repeats
    );
    outln!("{}", scale_report(&rows));
    outln!("wrote {}", csv_path.display());
    Ok(())
}

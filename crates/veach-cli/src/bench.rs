//! `veach bench`: error against render time for every strategy.

use crate::console::errln;
use crate::console::outln;
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;
use veach::{GpuContext, Renderer, Strategy};

#[derive(clap::Args)]
#[command(after_long_help = "For each scene: a reference (--reference, or MIS rendered at --reference-spp and cached \
in DIR), then every strategy at budgets 1, 2, 4 ... --max-spp camera samples per pixel (or, with --time-budgets, \
--min-seconds, 2x ... --max-seconds) over --seeds seeds, then every strategy at equal time. Each camera sample \
takes 2 uniform, 2 BRDF, 2 light or 1 + 1 MIS samples (one light chosen by power per light sample), so all \
strategies trace about the same rays per sample. Render time is measured by GPU timestamps where the adapter \
has them (else wall clock), without kernel compilation or uploads.

Writes DIR/results.csv, DIR/report.md, DIR/SCENE-relmse.svg (log-log relMSE against seconds) and \
DIR/SCENE-equal-time.png (reference and every strategy at equal time, with an enlarged crop).

Split across machines: `--task I/N` benches the scenes I, I+N, I+2N ... of the list (scenes are \
independent: each has its own reference and equal time) into a folder of its own; `veach bench --merge \
DIR... -o OUT` checks that every task of the same command is there once and writes one results.csv and \
report.md (scripts/slurm/bench-array.sbatch runs it as a Slurm job array).")]
pub struct BenchArgs {
    /// glTF scenes; with --merge, the task folders to merge
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// Bench only task I of N: the scenes I, I+N, I+2N ... (I from 0), for one task of a job
    /// array; merge the tasks' folders with --merge
    #[arg(long, value_name = "I/N", value_parser = parse_task)]
    task: Option<(u32, u32)>,
    /// Merge the folders of a split bench (`--task`) into the output folder
    #[arg(long, conflicts_with = "task")]
    merge: bool,
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
    /// Reference image (linear .exr or .pfm, same size) instead of rendering one (one scene only).
    /// It is taken to show emitters seen directly, as other renderers' images do, unless
    /// --hide-emitters says it leaves them out
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Leave out emitters seen directly, in the reference and every measured image: errors then
    /// measure reflected light alone
    #[arg(long)]
    hide_emitters: bool,
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

/// `I/N` with I < N.
fn parse_task(text: &str) -> Result<(u32, u32), String> {
    let (i, n) = text.split_once('/').ok_or("expected I/N, e.g. 0/4")?;
    let (i, n): (u32, u32) = (i.parse().map_err(|_| "I is not a number")?, n.parse().map_err(|_| "N is not a number")?);
    if i >= n {
        return Err(format!("task {i} of {n}: I counts from 0 to N-1"));
    }
    Ok((i, n))
}

/// What a task of a split bench records in its folder (`TASK_FILE`) for `--merge`: which task
/// it is, and the command's scenes and settings, which every task of one bench shares.
#[derive(serde::Serialize, serde::Deserialize, PartialEq)]
struct BenchTask {
    task: u32,
    tasks: u32,
    scenes: Vec<String>,
    settings: String,
}

const TASK_FILE: &str = "bench-task.json";

pub fn bench(args: BenchArgs) -> Result<()> {
    if args.merge {
        return merge_tasks(&args.scenes, &args.output);
    }
    use veach_bench::bench::Budget;
    use veach_bench::run::{BenchConfig, bench_scene, bench_units, csv, read_given_reference, slope_warnings};
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
    if args.reference.is_some() && args.scenes.len() > 1 {
        bail!("--reference is one scene's reference; bench one scene with it, or leave it out to render each one");
    }
    let all_scenes = args.scenes.clone();
    let scene_paths: Vec<PathBuf> = match args.task {
        Some((i, n)) => {
            if n as usize > all_scenes.len() {
                bail!("--task {i}/{n}: {} scene(s) make at most {} tasks", all_scenes.len(), all_scenes.len());
            }
            all_scenes.iter().skip(i as usize).step_by(n as usize).cloned().collect()
        }
        None => all_scenes.clone(),
    };
    std::fs::create_dir_all(&args.output).with_context(|| format!("cannot create {}", args.output.display()))?;
    // The scenes and the reference are read first: a bad file fails before any time is spent.
    let config = BenchConfig {
        width: args.width,
        height: args.height,
        budgets,
        seeds: args.seeds,
        strategies: match &args.strategies {
            Some(names) => veach_bench::bench::strategies_by_name(names).map_err(|e| anyhow::anyhow!(e))?,
            None => veach_bench::bench::default_strategies(),
        },
        reference_spp: args.reference_spp.unwrap_or((16 * args.max_spp).max(256)),
        reference: match &args.reference {
            Some(path) => Some(read_given_reference(path, args.width, args.height, args.hide_emitters)?),
            None => None,
        },
        hide_emitters: args.hide_emitters,
        equal_time: args.equal_time,
        out_dir: args.output.clone(),
    };
    let mut scenes = Vec::new();
    for path in &scene_paths {
        let scene = veach::load_gltf(path)?;
        let camera = scene.camera(None).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
        if scene.lights.is_empty() {
            bail!(
                "{}: the scene has no lights, so every image is black: nothing to measure error against",
                path.display()
            );
        }
        scenes.push((path, scene, camera));
    }
    let gpu = GpuContext::new(args.adapter.as_deref())?;
    errln!("adapter: {}; driver: {}", gpu.describe(), gpu.driver());
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
    if let Some((task, tasks)) = args.task {
        let record = BenchTask {
            task,
            tasks,
            scenes: all_scenes.iter().map(|p| p.display().to_string()).collect(),
            settings: format!(
                "{}x{} budgets {:?} seeds {} strategies {} reference {} spp{} hide_emitters {} equal_time {:?}",
                config.width,
                config.height,
                config.budgets,
                config.seeds,
                counts.join(", "),
                config.reference_spp,
                args.reference.as_ref().map(|p| format!(" ({})", p.display())).unwrap_or_default(),
                config.hide_emitters,
                config.equal_time
            ),
        };
        write_text(TASK_FILE, &serde_json::to_string_pretty(&record)?)?;
    }

    outln!("{:<16} {:<12} {:>10} {:>12} {:>8}", "scene", "strategy", "spp", "relMSE", "slope");
    for b in &summaries {
        for r in &b.equal_time {
            let slope = b
                .curves
                .iter()
                .find(|c| c.strategy == r.strategy)
                .and_then(veach_bench::bench::fit_sample_convergence)
                .map(|(_, s)| format!("{s:.2}"))
                .unwrap_or_else(|| "-".into());
            outln!("{:<16} {:<12} {:>10.1} {:>12.3e} {:>8}", b.scene, r.strategy, r.spp, r.metrics.relmse, slope);
        }
        for w in slope_warnings(b) {
            outln!("warning: {w}");
        }
    }
    outln!("(equal time per scene; relMSE against the reference; slope of log relMSE vs log spp)");
    errln!("wrote {}", args.output.join("report.md").display());
    Ok(())
}

/// Whether `t` seconds make a `Duration` (finite, not negative, not beyond u64 seconds).
fn seconds(t: f64) -> bool {
    Duration::try_from_secs_f64(t).is_ok()
}

/// `veach bench --merge`: the folders of one split bench, checked to be every task of the same
/// command once, into `out`: results.csv (one header, the tasks' rows in scene order), report.md
/// (the first task's preamble, then every scene's section in the command's scene order) and the
/// plots and images beside them.
fn merge_tasks(dirs: &[PathBuf], out: &std::path::Path) -> Result<()> {
    let mut tasks: Vec<(BenchTask, &PathBuf)> = Vec::new();
    for dir in dirs {
        let path = dir.join(TASK_FILE);
        let text = std::fs::read_to_string(&path).with_context(|| {
            format!("{}: not the folder of a `veach bench --task` run (no {TASK_FILE})", dir.display())
        })?;
        let task: BenchTask = serde_json::from_str(&text).with_context(|| format!("{}: malformed", path.display()))?;
        if let Some((first, first_dir)) = tasks.first()
            && (first.tasks, &first.scenes, &first.settings) != (task.tasks, &task.scenes, &task.settings)
        {
            bail!(
                "{} and {} are tasks of different benches (scenes, settings or task counts differ)",
                first_dir.display(),
                dir.display()
            );
        }
        if let Some((_, other)) = tasks.iter().find(|(t, _)| t.task == task.task) {
            bail!("{} and {} are both task {} of {}", other.display(), dir.display(), task.task, task.tasks);
        }
        tasks.push((task, dir));
    }
    let Some((first, _)) = tasks.first() else { bail!("no folders to merge") };
    let (count, scenes) = (first.tasks, first.scenes.clone());
    let missing: Vec<String> = (0..count)
        .filter(|i| !tasks.iter().any(|(t, _)| t.task == *i))
        .map(|i| {
            let of: Vec<&str> = scenes.iter().skip(i as usize).step_by(count as usize).map(String::as_str).collect();
            format!("task {i} of {count} ({})", of.join(", "))
        })
        .collect();
    if !missing.is_empty() {
        bail!("missing: {}; rerun them and merge again", missing.join("; "));
    }
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    // Scene k is task k % N's (k / N)-th section and rows.
    tasks.sort_by_key(|(t, _)| t.task);
    let mut csv_header = None;
    let mut rows_of: Vec<Vec<String>> = Vec::new();
    let mut sections_of: Vec<Vec<String>> = Vec::new();
    let mut preamble = String::new();
    for (task, dir) in &tasks {
        let csv = std::fs::read_to_string(dir.join("results.csv"))
            .with_context(|| format!("{}: no results.csv", dir.display()))?;
        let mut lines = csv.lines();
        let header = lines.next().unwrap_or_default().to_owned();
        if csv_header.get_or_insert_with(|| header.clone()) != &header {
            bail!("{}: results.csv has other columns than the first task's", dir.display());
        }
        rows_of.push(lines.map(str::to_owned).collect());
        let report = std::fs::read_to_string(dir.join("report.md"))
            .with_context(|| format!("{}: no report.md", dir.display()))?;
        let mut parts = report.split("\n## ");
        let head = parts.next().unwrap_or_default();
        if task.task == 0 {
            preamble = head.to_owned();
        }
        sections_of.push(parts.map(|s| format!("## {s}")).collect());
        for entry in std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?.flatten() {
            let name = entry.file_name();
            let keep = name.to_str().is_some_and(|n| n.ends_with(".svg") || n.ends_with("-equal-time.png"));
            if keep {
                std::fs::copy(entry.path(), out.join(&name))
                    .with_context(|| format!("cannot copy {}", entry.path().display()))?;
            }
        }
    }
    let mut report = preamble;
    for k in 0..scenes.len() {
        let (task, nth) = (k % count as usize, k / count as usize);
        if let Some(section) = sections_of[task].get(nth) {
            report.push('\n');
            report.push_str(section);
        }
    }
    let mut csv = csv_header.unwrap_or_default();
    csv.push('\n');
    for rows in &rows_of {
        for row in rows {
            csv.push_str(row);
            csv.push('\n');
        }
    }
    for (name, text) in [("results.csv", &csv), ("report.md", &report)] {
        veach::image_io::write_atomically(&out.join(name), |f| {
            use std::io::Write;
            f.write_all(text.as_bytes()).map_err(|e| e.to_string())
        })?;
    }
    errln!("merged {} tasks ({} scenes) into {}", tasks.len(), scenes.len(), out.join("report.md").display());
    Ok(())
}

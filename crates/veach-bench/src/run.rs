//! The whole `veach bench` run for one scene, and its outputs: results.csv rows, a log-log plot
//! of relMSE against seconds, the equal-time image grid and a section of report.md.

use crate::bench::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use veach::error::{Error, Result};
use veach::image_io;
use veach::render::{GpuScene, Renderer};
use veach::scene::{Camera, Scene};
use veach::settings::RenderSettings;

pub struct BenchConfig {
    pub width: u32,
    pub height: u32,
    pub budgets: Vec<Budget>,
    pub seeds: u32,
    pub strategies: Vec<BenchStrategy>,
    /// Camera samples per pixel of a rendered reference.
    pub reference_spp: u32,
    /// A given reference image (`read_given_reference`) instead of rendering one.
    pub reference: Option<Reference>,
    /// Leave out emitters seen directly, in the reference and every image measured against it.
    pub hide_emitters: bool,
    /// Time of the equal-time comparison; default: mis-balance's median time at its largest budget.
    pub equal_time: Option<f64>,
    pub out_dir: PathBuf,
}

/// What a scene's bench produced.
pub struct SceneBench {
    pub scene: String,
    pub rows: Vec<BenchRow>,
    pub curves: Vec<Curve>,
    pub equal_time_seconds: f64,
    /// Per strategy: (name, row of its equal-time render).
    pub equal_time: Vec<BenchRow>,
    pub reference_source: String,
    pub reference_relmse: f64,
    /// Whether emitters seen directly were left out of the reference and the images.
    pub hides_emitters: bool,
    pub target_relmse: f64,
    /// Per image region at equal time: which strategy is best and how MIS compares.
    pub regions: Vec<RegionResult>,
    /// The same, per material seen by the camera.
    pub materials: Vec<RegionResult>,
    pub kernels: KernelComparison,
    pub report: String,
}

/// The specialised kernel against the generic one for mis-balance, measured in one run.
#[derive(Clone, Debug)]
pub struct KernelComparison {
    pub features: String,
    pub generic_creation: f64,
    pub specialised_creation: f64,
    /// Median render seconds over the seeds at the largest budget.
    pub generic_render: f64,
    pub specialised_render: f64,
}

fn compare_kernels(
    renderer: &Renderer,
    scene: &GpuScene,
    camera: &Camera,
    config: &BenchConfig,
) -> Result<KernelComparison> {
    let s = config.strategies.iter().find(|s| s.name == "mis-balance").unwrap_or(&config.strategies[0]);
    let budget = config.budgets.last().cloned().unwrap_or(Budget::Spp(1));
    // Fresh renderers: empty kernel caches, so the first render of each creates its kernel.
    let mut creation = [0.0; 2];
    let mut times: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    for (k, specialise) in [false, true].into_iter().enumerate() {
        let fresh = Renderer::new(renderer.gpu.clone())?;
        let tiny = RenderSettings {
            width: 1,
            height: 1,
            spp: 1,
            specialise,
            ..render_settings(s, 1, 1, &Budget::Spp(1), 1, config.hide_emitters)
        };
        creation[k] = fresh.render(scene, &tiny, camera, &mut |_| true)?.kernel_creation.as_secs_f64();
    }
    // Alternate the two kernels so that drift in the machine's speed hits both alike.
    for seed in 1..=config.seeds {
        for (k, specialise) in [false, true].into_iter().enumerate() {
            let settings = RenderSettings {
                specialise,
                ..render_settings(s, config.width, config.height, &budget, seed, config.hide_emitters)
            };
            let out = renderer.render(scene, &settings, camera, &mut |_| true)?;
            times[k].push(render_seconds(&out));
        }
    }
    let [g, sp] = times;
    Ok(KernelComparison {
        features: scene.features.describe(),
        generic_creation: creation[0],
        specialised_creation: creation[1],
        generic_render: median_spread(&mut g.clone()).0,
        specialised_render: median_spread(&mut sp.clone()).0,
    })
}

/// Side of the grid of image regions in the per-region comparison.
pub const REGION_GRID: u32 = 4;

#[derive(Clone, Debug)]
pub struct RegionResult {
    /// "(row, col)" of a grid region, or the material's name and pixel count.
    pub label: String,
    /// Strategy with the lowest median relMSE, and that median.
    pub best: String,
    pub best_relmse: f64,
    /// The same among the single strategies (every one not named "mis…"), if any was run.
    pub best_single: Option<(String, f64)>,
    pub worst: String,
    /// For each MIS strategy (name starting with "mis"), in the configured order.
    pub mis: Vec<MisRegion>,
}

#[derive(Clone, Debug)]
pub struct MisRegion {
    pub strategy: String,
    /// Its median relMSE over the best strategy's.
    pub ratio: f64,
    /// Its mean over seeds exceeds the best one's by at most two standard errors of the
    /// difference (or it is the best).
    pub within_noise: bool,
    /// The same against the best single strategy (None where no single strategy was run).
    pub vs_single: Option<(f64, bool)>,
}

/// A set of pixels the per-region comparison measures separately.
pub struct Region {
    pub label: String,
    pub pixels: Vec<usize>,
}

/// The image cut into REGION_GRID × REGION_GRID rectangles, row by row.
pub fn grid_regions(w: u32, h: u32) -> Vec<Region> {
    let mut out = Vec::new();
    for ry in 0..REGION_GRID {
        for rx in 0..REGION_GRID {
            let (x0, x1) = (rx * w / REGION_GRID, (rx + 1) * w / REGION_GRID);
            let (y0, y1) = (ry * h / REGION_GRID, (ry + 1) * h / REGION_GRID);
            let pixels = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (y * w + x) as usize)).collect();
            out.push(Region { label: format!("({ry}, {rx})"), pixels });
        }
    }
    out
}

/// Fewest pixels a material needs to get its own row in the by-material comparison.
const MIN_MATERIAL_PIXELS: usize = 64;

/// The pixels whose centre sees each material first (emitters and misses left out), traced on
/// the host with the scene's own BVH builder and obvhs's traversal: which surface a region is
/// made of says more than where it is in the frame (the diffuse walls, each plate).
pub fn material_regions(scene: &Scene, camera: &Camera, w: u32, h: u32) -> Vec<Region> {
    use glam::Vec3A;
    use obvhs::ray::{Ray, RayHit};
    let tris: Vec<obvhs::triangle::Triangle> = scene
        .triangles
        .iter()
        .map(|t| obvhs::triangle::Triangle { v0: t.p[0].into(), v1: t.p[1].into(), v2: t.p[2].into() })
        .collect();
    if tris.is_empty() {
        return Vec::new();
    }
    let mut core_time = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, obvhs::BvhBuildParams::fast_build(), &mut core_time);
    let g = camera.to_gpu(w, h);
    let (f, r, u) = (glam::Vec3::from(g.forward), glam::Vec3::from(g.right), glam::Vec3::from(g.up));
    let mut pixels: Vec<Vec<usize>> = vec![Vec::new(); scene.materials.len()];
    for py in 0..h {
        for px in 0..w {
            // Pixel centre, as camera.wgsl maps (x, y) + 0.5.
            let sx = 2.0 * (px as f32 + 0.5) / w as f32 - 1.0;
            let sy = 1.0 - 2.0 * (py as f32 + 0.5) / h as f32;
            let d = (f + sx * r + sy * u).normalize();
            let ray = Ray::new_inf(Vec3A::from(camera.position), Vec3A::from(d));
            let mut hit = RayHit::none();
            if bvh.ray_traverse(ray, &mut hit, |ray, id| tris[bvh.primitive_indices[id] as usize].intersect(ray)) {
                let tri = &scene.triangles[bvh.primitive_indices[hit.primitive_id as usize] as usize];
                let m = tri.material as usize;
                if m < pixels.len() && !scene.materials[m].is_emissive() {
                    pixels[m].push((py * w + px) as usize);
                }
            }
        }
    }
    pixels
        .into_iter()
        .enumerate()
        .filter(|(_, p)| p.len() >= MIN_MATERIAL_PIXELS)
        .map(|(m, p)| Region { label: format!("{} ({} px)", scene.materials[m].name, p.len()), pixels: p })
        .collect()
}

/// relMSE of `image` against `reference` over each region.
fn region_relmse(image: &[[f32; 3]], reference: &[[f32; 3]], regions: &[Region]) -> Vec<f64> {
    regions
        .iter()
        .map(|region| {
            let img: Vec<[f32; 3]> = region.pixels.iter().map(|&i| image[i]).collect();
            let refr: Vec<[f32; 3]> = region.pixels.iter().map(|&i| reference[i]).collect();
            error_metrics(&img, &refr).relmse
        })
        .collect()
}

fn region_table(strategies: &[BenchStrategy], regions: &[Region], errors: &[Vec<Vec<f64>>]) -> Vec<RegionResult> {
    let mis: Vec<usize> = (0..strategies.len()).filter(|&i| strategies[i].name.starts_with("mis")).collect();
    let n = regions.len();
    let mut out = Vec::new();
    for region in 0..n {
        // Per strategy over seeds: (median, mean, variance of the mean).
        let stats: Vec<(f64, f64, f64)> = errors
            .iter()
            .map(|seeds| {
                let x: Vec<f64> = seeds.iter().map(|e| e[region]).collect();
                let (median, _, _) = median_spread(&mut x.clone());
                let k = x.len() as f64;
                let mean = x.iter().sum::<f64>() / k;
                let var = if x.len() > 1 { x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0) } else { 0.0 };
                (median, mean, var / k)
            })
            .collect();
        let best = (0..stats.len()).min_by(|&a, &b| stats[a].0.total_cmp(&stats[b].0)).unwrap_or(0);
        let best_single =
            (0..stats.len()).filter(|i| !mis.contains(i)).min_by(|&a, &b| stats[a].0.total_cmp(&stats[b].0));
        let worst = (0..stats.len()).max_by(|&a, &b| stats[a].0.total_cmp(&stats[b].0)).unwrap_or(0);
        // Median of m over b's, and Welch's comparison of the two means over seeds at two
        // standard errors: m is within noise of b unless its mean is larger by more than that.
        let compare = |m: usize, b: usize| {
            (
                stats[m].0 / stats[b].0.max(f64::MIN_POSITIVE),
                stats[m].1 - stats[b].1 <= 2.0 * (stats[m].2 + stats[b].2).sqrt(),
            )
        };
        let mis = mis
            .iter()
            .map(|&m| {
                let (ratio, within_noise) = compare(m, best);
                MisRegion {
                    strategy: strategies[m].name.clone(),
                    ratio,
                    within_noise,
                    vs_single: best_single.map(|b| compare(m, b)),
                }
            })
            .collect();
        out.push(RegionResult {
            label: regions[region].label.clone(),
            best: strategies[best].name.clone(),
            best_relmse: stats[best].0,
            best_single: best_single.map(|b| (strategies[b].name.clone(), stats[b].0)),
            worst: strategies[worst].name.clone(),
            mis,
        });
    }
    out
}

/// Progress of a bench: (units done, units in all, what is running).
pub type BenchProgress<'a> = &'a mut dyn FnMut(u64, u64, &str);

pub fn bench_units(config: &BenchConfig) -> u64 {
    (config.strategies.len() * (config.budgets.len() + 1) * config.seeds as usize + 2) as u64
}

/// A reference image given to the bench (`--reference`): linear radiance (EXR or PFM; a PNG's
/// 8-bit sRGB display values are not), finite pixels (`image_io::read_reference`) at the bench's
/// size, read once, before anything renders. `hides_emitters`: whether it leaves out emitters
/// seen directly (another renderer's reference shows them), as the bench's images will.
pub fn read_given_reference(path: &Path, width: u32, height: u32, hides_emitters: bool) -> Result<Reference> {
    match image_io::ImageFormat::from_path(path) {
        Ok(image_io::ImageFormat::Exr | image_io::ImageFormat::Pfm) => {}
        _ => {
            return Err(Error::Output {
                path: path.to_owned(),
                message: "a reference must hold linear radiance: give an .exr or .pfm file (a PNG or JPEG holds \
                          display values: tone-mapped, sRGB-encoded and clamped)"
                    .into(),
            });
        }
    }
    let (rw, rh, pixels) = image_io::read_reference(path)?;
    if (rw, rh) != (width, height) {
        return Err(Error::Options(format!(
            "{}: the reference is {rw}x{rh} but the bench renders {width}x{height}",
            path.display()
        )));
    }
    Ok(Reference { pixels, source: path.display().to_string(), own_relmse: 0.0, hides_emitters })
}

#[allow(clippy::too_many_arguments)]
pub fn bench_scene(
    renderer: &Renderer,
    host_scene: &Scene,
    scene: &GpuScene,
    camera: &Camera,
    scene_path: &Path,
    config: &BenchConfig,
    progress: BenchProgress,
    units_before: u64,
    units_total: u64,
) -> Result<SceneBench> {
    let name = scene_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    let (w, h) = (config.width, config.height);
    let mut done = units_before;

    // Reference: given, cached, or rendered now.
    let reference = match &config.reference {
        Some(given) => given.clone(),
        None => {
            let shown = if config.hide_emitters { "-emitters-hidden" } else { "" };
            let cache = config.out_dir.join(format!("reference-{name}-{w}x{h}-{}spp{shown}.pfm", config.reference_spp));
            let meta = cache.with_extension("txt");
            match (image_io::read_reference(&cache), std::fs::read_to_string(&meta)) {
                (Ok((cw, ch, pixels)), Ok(own)) if (cw, ch) == (w, h) => Reference {
                    pixels,
                    source: format!(
                        "MIS 4+4, every light (16+4 by power past {MAX_LIGHTS_SAMPLED_EACH} lights), {} spp \
                         (cached in {})",
                        config.reference_spp,
                        cache.display()
                    ),
                    own_relmse: own.trim().parse().unwrap_or(f64::NAN),
                    hides_emitters: config.hide_emitters,
                },
                _ => {
                    progress(done, units_total, &format!("{name}: reference, {} spp", config.reference_spp));
                    let r = render_reference(
                        renderer,
                        scene,
                        camera,
                        w,
                        h,
                        config.reference_spp,
                        config.hide_emitters,
                        &mut |_| true,
                    )?;
                    image_io::write_image(&cache, w, h, &r.pixels, 0.0)?;
                    image_io::write_atomically(&meta, |f| {
                        use std::io::Write;
                        write!(f, "{}", r.own_relmse).map_err(|e| e.to_string())
                    })?;
                    r
                }
            }
        }
    };
    // relMSE divides by the reference: a black one (lights that reach nothing the camera sees)
    // leaves every error undefined.
    if reference.pixels.iter().flatten().all(|&v| v <= 0.0) {
        return Err(Error::Options(format!(
            "{}: the reference ({}) is black: no light reaches what the camera sees, so there is no error to measure",
            scene_path.display(),
            reference.source
        )));
    }
    done += 1;

    // The sweep. Strategies take turns within each budget and seed, so that a slow spell of the
    // machine (lavapipe shares the CPU with everything else) falls on all of them alike rather
    // than on one strategy's renders: run one after the other, two identical kernels reached 8%
    // different sample counts at equal time.
    let mut rows = Vec::new();
    for budget in &config.budgets {
        for seed in 1..=config.seeds {
            for s in &config.strategies {
                progress(done, units_total, &format!("{name}: {} {budget:?} seed {seed}", s.name));
                let (row, _) = measure(renderer, scene, camera, &name, &reference, s, budget, seed, w, h)?;
                rows.push(row);
                done += 1;
            }
        }
    }
    let curves = curves(&rows);

    // Equal time.
    let equal_time_seconds = config.equal_time.unwrap_or_else(|| {
        curves
            .iter()
            .find(|c| c.strategy == "mis-balance")
            .or(curves.first())
            .and_then(|c| c.points.last())
            .map(|p| p.seconds)
            .unwrap_or(1.0)
    });
    // Every strategy at equal time, over the seeds: whole-image rows (first seed) for the
    // table and grid, and per-region errors of every seed for the region table.
    let mut equal_time = Vec::new();
    let mut images = Vec::new();
    let grid = grid_regions(w, h);
    let by_material = material_regions(host_scene, camera, w, h);
    // [strategy][seed][region]
    let mut region_errors: Vec<Vec<Vec<f64>>> = vec![Vec::new(); config.strategies.len()];
    let mut material_errors: Vec<Vec<Vec<f64>>> = vec![Vec::new(); config.strategies.len()];
    let budget = Budget::Seconds(equal_time_seconds);
    // Strategies take turns here too (see the sweep).
    for seed in 1..=config.seeds {
        for (i, s) in config.strategies.iter().enumerate() {
            progress(done, units_total, &format!("{name}: {} at {equal_time_seconds:.3} s, seed {seed}", s.name));
            let (row, out) = measure(renderer, scene, camera, &name, &reference, s, &budget, 1000 + seed, w, h)?;
            let mean = out.mean();
            region_errors[i].push(region_relmse(&mean, &reference.pixels, &grid));
            material_errors[i].push(region_relmse(&mean, &reference.pixels, &by_material));
            if seed == 1 {
                images.push((s.name.clone(), mean));
                equal_time.push(row);
            }
            done += 1;
        }
    }
    let regions = region_table(&config.strategies, &grid, &region_errors);
    let materials = region_table(&config.strategies, &by_material, &material_errors);

    // Target error: what mis-balance reaches at its largest budget.
    let target_relmse = curves
        .iter()
        .find(|c| c.strategy == "mis-balance")
        .or(curves.first())
        .and_then(|c| c.points.last())
        .map(|p| p.relmse)
        .unwrap_or(f64::NAN);

    // Specialised against generic kernel: creation (fresh kernel caches) and render time.
    progress(done, units_total, &format!("{name}: specialised against generic kernel"));
    let kernels = compare_kernels(renderer, scene, camera, config)?;

    let plot = config.out_dir.join(format!("{name}-relmse.svg"));
    write_plot(&plot, &name, &curves)?;
    let grid = config.out_dir.join(format!("{name}-equal-time.png"));
    let crop = write_grid(&grid, w, h, &reference.pixels, &images)?;

    let bench = SceneBench {
        scene: name,
        rows,
        curves,
        equal_time_seconds,
        equal_time,
        reference_source: reference.source.clone(),
        reference_relmse: reference.own_relmse,
        hides_emitters: reference.hides_emitters,
        target_relmse,
        regions,
        materials,
        kernels,
        report: String::new(),
    };
    let report = report_section(&bench, config, &plot, &grid, crop);
    Ok(SceneBench { report, ..bench })
}

pub fn csv(rows: &[BenchRow]) -> String {
    let mut s = String::from(
        "scene,strategy,budget,spp,seconds,rmse,relmse,mae,efficiency,seed,max_value,nonfinite,rays,rays_per_s\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{:.3},{:.6},{:.6e},{:.6e},{:.6e},{:.6e},{},{:.6e},{},{},{:.0}",
            r.scene,
            r.strategy,
            r.budget,
            r.spp,
            r.seconds,
            r.metrics.rmse,
            r.metrics.relmse,
            r.metrics.mae,
            r.efficiency(),
            r.seed,
            r.max_value,
            r.nonfinite,
            r.rays,
            r.rays_per_second()
        );
    }
    s
}

fn write_plot(path: &Path, scene: &str, curves: &[Curve]) -> Result<()> {
    use plotters::prelude::*;
    let err = |e: String| Error::Output { path: path.to_owned(), message: e };
    let pts = curves.iter().flat_map(|c| c.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for p in pts {
        if p.seconds > 0.0 && p.relmse_min > 0.0 {
            x0 = x0.min(p.seconds);
            x1 = x1.max(p.seconds);
            y0 = y0.min(p.relmse_min);
            y1 = y1.max(p.relmse_max);
        }
    }
    if x0 >= x1 || y0 >= y1 {
        // Every error is zero (a scene that is black for every strategy, such as a camera sealed
        // in a box): a log-log plot has nothing to show; say so in the file the report links.
        let svg = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"640\" height=\"80\"><text x=\"10\" y=\"40\">\
             {scene}: every relMSE is zero or every time is zero: nothing to plot</text></svg>\n"
        );
        return image_io::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(svg.as_bytes()).map_err(|e| e.to_string())
        });
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{scene}: relMSE against render time"), ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d((x0 / 1.5..x1 * 1.5).log_scale(), (y0 / 1.5..y1 * 1.5).log_scale())
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("render seconds")
            .y_desc("relMSE")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for (i, c) in curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let line: Vec<(f64, f64)> = c.points.iter().map(|p| (p.seconds, p.relmse)).collect();
            chart
                .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
                .map_err(|e| err(e.to_string()))?
                .label(c.strategy.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
            chart
                .draw_series(line.iter().map(|&(x, y)| Circle::new((x, y), 3, color.filled())))
                .map_err(|e| err(e.to_string()))?;
            // Spread over seeds.
            chart
                .draw_series(
                    c.points
                        .iter()
                        .map(|p| PathElement::new(vec![(p.seconds, p.relmse_min), (p.seconds, p.relmse_max)], color)),
                )
                .map_err(|e| err(e.to_string()))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    image_io::write_atomically(path, |f| {
        use std::io::Write;
        f.write_all(svg.as_bytes()).map_err(|e| e.to_string())
    })
}

/// The equal-time grid: a column per image (reference first, then the strategies), the full
/// image on top and a 4× crop below, from the quarter-size window where the strategies' errors
/// are largest. Returns the crop window (x, y, size).
fn write_grid(
    path: &Path,
    w: u32,
    h: u32,
    reference: &[[f32; 3]],
    images: &[(String, Vec<[f32; 3]>)],
) -> Result<(u32, u32, u32)> {
    let crop = (w.min(h) / 4).max(1);
    let mut best = (0, 0, f64::NEG_INFINITY);
    let step = (crop / 2).max(1);
    let mut y = 0;
    while y + crop <= h {
        let mut x = 0;
        while x + crop <= w {
            let mut e = 0.0;
            for (_, img) in images {
                for yy in y..y + crop {
                    for xx in x..x + crop {
                        let i = (yy * w + xx) as usize;
                        for c in 0..3 {
                            let d = (img[i][c] - reference[i][c]) as f64;
                            e += d * d / ((reference[i][c] as f64).powi(2) + RELMSE_EPSILON);
                        }
                    }
                }
            }
            if e > best.2 {
                best = (x, y, e);
            }
            x += step;
        }
        y += step;
    }
    let (cx, cy) = (best.0, best.1);
    let gap = 4u32;
    let columns = images.len() as u32 + 1;
    let (gw, gh) = (columns * (w + gap) - gap, 2 * h + gap);
    let mut grid = vec![[1.0f32; 3]; (gw * gh) as usize];
    let all = std::iter::once(reference).chain(images.iter().map(|(_, img)| img.as_slice()));
    for (col, img) in all.enumerate() {
        let ox = col as u32 * (w + gap);
        for y in 0..h {
            for x in 0..w {
                grid[(y * gw + ox + x) as usize] = img[(y * w + x) as usize];
                // Crop, scaled to the image's size (nearest neighbour).
                let sx = cx + x * crop / w;
                let sy = cy + y * crop / h;
                grid[((h + gap + y) * gw + ox + x) as usize] = img[(sy * w + sx) as usize];
            }
        }
    }
    image_io::write_image(path, gw, gh, &grid, 0.0)?;
    Ok((cx, cy, crop))
}

fn report_section(b: &SceneBench, config: &BenchConfig, plot: &Path, grid: &Path, crop: (u32, u32, u32)) -> String {
    let file = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut s = String::new();
    let _ = writeln!(s, "## {}\n", b.scene);
    let _ = writeln!(
        s,
        "{}×{}, {} seed(s) per point, reference: {} (its own expected relMSE {:.2e}).\n",
        config.width, config.height, config.seeds, b.reference_source, b.reference_relmse
    );
    let best_final = b.curves.iter().filter_map(|c| c.points.last().map(|p| p.relmse)).fold(f64::INFINITY, f64::min);
    if b.reference_relmse > 0.1 * best_final {
        let _ = writeln!(
            s,
            "**Warning:** the reference's own noise ({:.2e}) is not well below the smallest error measured \
             ({best_final:.2e}); raise --reference-spp.\n",
            b.reference_relmse
        );
    }
    let _ = writeln!(s, "### Error at equal time ({:.3} s)\n", b.equal_time_seconds);
    let _ = writeln!(s, "| strategy | spp reached | relMSE | RMSE | MAE | efficiency 1/(relMSE·s) | Mrays/s |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    let best = b.equal_time.iter().map(|r| r.metrics.relmse).fold(f64::INFINITY, f64::min);
    for r in &b.equal_time {
        let mark = if r.metrics.relmse == best { " **(best)**" } else { "" };
        let _ = writeln!(
            s,
            "| {}{mark} | {:.1} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.2} |",
            r.strategy,
            r.spp,
            r.metrics.relmse,
            r.metrics.rmse,
            r.metrics.mae,
            r.efficiency(),
            r.rays_per_second() / 1e6
        );
    }
    let _ = writeln!(
        s,
        "\n### Convergence\n\nTarget error: relMSE {:.3e} (what mis-balance reaches at its largest budget). \
         Slope: least-squares fit of log relMSE against log camera samples per pixel over the median \
         points; about −1 for a finite-variance estimator. Shallower than {SHALLOW_SLOPE} is flagged: \
         as heavy tails (infinite variance) where the line stays straight, as a bias floor where the \
         error levels off at a constant.\n",
        b.target_relmse
    );
    let _ = writeln!(
        s,
        "| strategy | slope | seconds to target | median relMSE at each budget | max pixel | non-finite dropped |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for c in &b.curves {
        let slope = fit_sample_convergence(c).map(|(_, b)| b);
        let slope_text = match (slope, diagnose_convergence(c)) {
            (Some(v), Convergence::HeavyTails { .. }) => format!("{v:.2} ⚠ shallower than −1: infinite variance?"),
            (Some(v), Convergence::BiasFloor { floor }) => {
                format!("{v:.2} ⚠ levels off near relMSE {floor:.2e}: converges to something other than the reference")
            }
            (Some(v), Convergence::Finite) => format!("{v:.2}"),
            (None, _) => "–".into(),
        };
        let time = match time_to_reach(c, b.target_relmse) {
            Some((t, true)) => format!("{t:.3} (extrapolated)"),
            Some((t, false)) => format!("{t:.3}"),
            None => "–".into(),
        };
        let per_budget: Vec<String> = c.points.iter().map(|p| format!("{:.2e}", p.relmse)).collect();
        // Over every render of the sweep: the brightest pixel and the samples dropped.
        let sweep = b.rows.iter().filter(|r| r.strategy == c.strategy);
        let (max_value, nonfinite) = sweep.fold((0.0f32, 0u64), |(m, n), r| (m.max(r.max_value), n + r.nonfinite));
        let _ = writeln!(
            s,
            "| {} | {slope_text} | {time} | {} | {max_value:.3e} | {nonfinite} |",
            c.strategy,
            per_budget.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "\n### By region, at equal time\n\nThe image cut into {g}×{g} regions; relMSE per region, median over \
         {} seeds (the best is the lowest median). A MIS strategy is *within noise* of the best where its \
         mean over the seeds exceeds the best one's by at most two standard errors of the difference \
         (sqrt(s²_mis/k + s²_best/k), s² the variance over the k seeds). *Single* strategies are those \
         that are not MIS (uniform, brdf, light); each MIS column gives its median over the best single \
         strategy's, marked **(no)** where it is not below it or within noise.\n",
        config.seeds,
        g = REGION_GRID
    );
    region_report(&mut s, "region (row, col)", &b.regions);
    let _ = writeln!(
        s,
        "\n### By material, at equal time\n\nThe pixels whose centre sees each material first (traced on the \
         host; materials on fewer than {MIN_MATERIAL_PIXELS} pixels and emitters left out), compared as above.\n"
    );
    region_report(&mut s, "material", &b.materials);
    let k = &b.kernels;
    let _ = writeln!(
        s,
        "\n### Specialised against generic kernel\n\nmis-balance at the largest budget, median of {} seeds, \
         both kernels in one run. Scene features: {}. Kernel creation includes the driver's compile \
         at the first dispatch; Mesa's on-disk shader cache, when warm, shortens it.\n",
        config.seeds, k.features
    );
    let _ = writeln!(s, "| kernel | creation s | render s |");
    let _ = writeln!(s, "|---|---|---|");
    let _ = writeln!(s, "| generic | {:.3} | {:.3} |", k.generic_creation, k.generic_render);
    let _ = writeln!(s, "| specialised | {:.3} | {:.3} |", k.specialised_creation, k.specialised_render);
    let _ = writeln!(
        s,
        "| specialised / generic | {:.2} | {:.2} |",
        k.specialised_creation / k.generic_creation,
        k.specialised_render / k.generic_render
    );
    let names: Vec<&str> = b.equal_time.iter().map(|r| r.strategy.as_str()).collect();
    let _ = writeln!(
        s,
        "\n![relMSE against time]({})\n\n![equal time]({})\n\nEqual-time images, left to right: reference, {}. \
         Bottom row: the {}×{} window at ({}, {}) where the errors are largest, enlarged.\n",
        file(plot),
        file(grid),
        names.join(", "),
        crop.2,
        crop.2,
        crop.0,
        crop.1
    );
    s
}

/// Convergence warnings for the terminal: heavy tails, or an error that levels off.
pub fn slope_warnings(b: &SceneBench) -> Vec<String> {
    b.curves
        .iter()
        .filter_map(|c| match diagnose_convergence(c) {
            Convergence::Finite => None,
            Convergence::HeavyTails { slope } => Some(format!(
                "{}: {} converges with slope {slope:.2} (shallower than −1): a sign of infinite variance",
                b.scene, c.strategy
            )),
            Convergence::BiasFloor { floor } => Some(format!(
                "{}: {}'s error levels off near relMSE {floor:.2e} instead of falling: its images converge to \
                 something other than the reference (a bias, or a reference that shows or leaves out something \
                 else: emitters seen directly are {} here)",
                b.scene,
                c.strategy,
                if b.hides_emitters { "left out (--hide-emitters)" } else { "shown" }
            )),
        })
        .collect()
}

/// Summary lines per MIS strategy and a table of `regions`: the best strategy, the best single
/// one, the worst, and each MIS strategy's ratio to the best single strategy (to the best one
/// where no single strategy was run).
fn region_report(s: &mut String, what: &str, regions: &[RegionResult]) {
    let mis_names: Vec<&str> =
        regions.first().map(|r| r.mis.iter().map(|m| m.strategy.as_str()).collect()).unwrap_or_default();
    let has_single = regions.first().is_some_and(|r| r.best_single.is_some());
    for name in &mis_names {
        let of = |r: &RegionResult| r.mis.iter().find(|m| m.strategy == *name).cloned();
        let within = regions.iter().filter(|r| of(r).is_some_and(|m| m.within_noise)).count();
        let within_single =
            regions.iter().filter(|r| of(r).and_then(|m| m.vs_single).is_some_and(|(_, ok)| ok)).count();
        if has_single {
            let _ = writeln!(
                s,
                "- {name}: below or within noise of the best single strategy on **{within_single} of {n}**; \
                 of the best strategy of all on {within} of {n}",
                n = regions.len()
            );
        } else {
            let _ = writeln!(s, "- {name}: best or within noise of the best on {within} of {}", regions.len());
        }
    }
    let against = if has_single { "best single" } else { "best" };
    let mis_headers: Vec<String> = mis_names.iter().map(|n| format!("{n} / {against}")).collect();
    let _ = writeln!(
        s,
        "\n| {what} | best | best relMSE | best single | its relMSE | worst | {} |",
        mis_headers.join(" | ")
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|{}", "---|".repeat(mis_names.len()));
    for r in regions {
        let cells: Vec<String> = r
            .mis
            .iter()
            .map(|m| {
                let (ratio, ok) = m.vs_single.unwrap_or((m.ratio, m.within_noise));
                format!("{ratio:.2}{}", if ok { "" } else { " **(no)**" })
            })
            .collect();
        let (single, single_relmse) = match &r.best_single {
            Some((name, e)) => (name.as_str(), format!("{e:.2e}")),
            None => ("–", "–".into()),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.2e} | {single} | {single_relmse} | {} | {} |",
            r.label,
            r.best,
            r.best_relmse,
            r.worst,
            cells.join(" | ")
        );
    }
}

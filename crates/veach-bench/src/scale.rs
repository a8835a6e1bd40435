//! `veach scale`: how loading, BVH build, GPU memory and render time grow with the triangle
//! count, and how render time grows with the light count under power-based light selection.
//! A benchmark (it prints a table and writes CSV); the scenes come from `veach_scenes::scale_scenes`.

use crate::bench::{median_spread, render_seconds};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;
use veach::error::{Error, Result};
use veach::gpu::layout::BvhNode;
use veach::render::Renderer;
use veach::settings::{RenderSettings, Strategy};
use veach_scenes::scale_scenes::{light_scene, triangle_scene};

pub struct ScaleConfig {
    /// Where the generated scenes and scale.csv go.
    pub output: PathBuf,
    pub triangles: Vec<usize>,
    pub lights: Vec<usize>,
    /// Triangles of the light sweep's grid (`veach_scenes::scale_scenes::light_scene`).
    pub light_grid: usize,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Renders per point; the median time is reported.
    pub repeats: u32,
    /// The kernels every render runs.
    pub execution: veach::settings::Execution,
}

#[derive(Clone, Debug)]
pub struct ScaleRow {
    /// "triangles" or "lights": which sweep the row belongs to.
    pub sweep: &'static str,
    /// The settings it rendered with (`scale_strategies`).
    pub strategy: &'static str,
    pub triangles: usize,
    pub lights: usize,
    pub load_seconds: f64,
    pub bvh_build_seconds: f64,
    pub bvh_nodes: usize,
    /// Every buffer of the scene on the GPU (BVH, triangles, materials, lights).
    pub gpu_scene_bytes: u64,
    /// Median render time over the repeats (GPU timestamps where there are any).
    pub render_seconds: f64,
    pub spp: u32,
    /// Rays traced by the kernel in one render: camera, shadow and BRDF rays.
    pub rays: u64,
    /// Render time against the sweep's first point with the same strategy, repeat by repeat
    /// (both rendered in the same turn of `time_points`): the median over the repeats, and the
    /// smallest and largest.
    pub ratio_to_first: RepeatRatio,
}

/// A ratio of render times taken repeat by repeat: its median, smallest and largest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RepeatRatio {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl RepeatRatio {
    /// The ratios `times[r] / firsts[r]` over the repeats r both have (at least one).
    pub fn of(times: &[f64], firsts: &[f64]) -> RepeatRatio {
        let mut ratios: Vec<f64> = times.iter().zip(firsts).map(|(t, f)| t / f.max(f64::MIN_POSITIVE)).collect();
        let (median, min, max) = median_spread(&mut ratios);
        RepeatRatio { median, min, max }
    }
}

impl ScaleRow {
    pub fn bytes_per_triangle(&self) -> f64 {
        self.gpu_scene_bytes as f64 / self.triangles.max(1) as f64
    }

    pub fn bvh_bytes_per_triangle(&self) -> f64 {
        (self.bvh_nodes * std::mem::size_of::<BvhNode>()) as f64 / self.triangles.max(1) as f64
    }

    pub fn rays_per_second(&self) -> f64 {
        if self.render_seconds > 0.0 { self.rays as f64 / self.render_seconds } else { 0.0 }
    }
}

/// The settings every point renders with: `RenderSettings::recommended` at the configured size.
pub fn scale_settings(config: &ScaleConfig) -> RenderSettings {
    RenderSettings {
        width: config.width,
        height: config.height,
        spp: config.spp,
        execution: config.execution,
        ..RenderSettings::recommended()
    }
}

/// What each sweep renders: both sweeps MIS 1 + 1 (`scale_settings`); the light sweep also light
/// sampling alone, 2 light samples chosen by the light tree, whose cost is all light selection,
/// light sampling and shadow rays (MIS also traces BRDF rays, which find light only where there are
/// lights to find: see docs/performance.md).
pub fn scale_strategies(config: &ScaleConfig, sweep: &str) -> Vec<(&'static str, RenderSettings)> {
    let mis = scale_settings(config);
    let mut list = vec![("mis-power 1+1", mis.clone())];
    if sweep == "lights" {
        let light = RenderSettings { strategy: Strategy::Light, light_samples: 2, brdf_samples: 0, ..mis };
        list.push(("light 2", light));
    }
    list
}

/// One point of a sweep: its scene written, loaded back as a user's file would be, built and
/// uploaded, and each of the sweep's settings rendered once untimed (the kernel's compile).
struct ScalePoint {
    sweep: &'static str,
    triangles: usize,
    lights: usize,
    load_seconds: f64,
    gpu_scene: veach::render::GpuScene,
    camera: veach::scene::Camera,
    settings: Vec<(&'static str, RenderSettings)>,
    /// Per setting: the timed renders' seconds, and the rays of the last.
    times: Vec<Vec<f64>>,
    rays: Vec<u64>,
}

fn prepare_point(
    renderer: &Renderer,
    config: &ScaleConfig,
    sweep: &'static str,
    name: &str,
    builder: veach_scenes::gltf_writer::GltfBuilder,
) -> Result<ScalePoint> {
    let path = config.output.join("scenes").join(format!("{name}.gltf"));
    builder.write(&path).map_err(|e| Error::Output { path: path.clone(), message: e.to_string() })?;
    let load_start = Instant::now();
    let scene = veach::load_gltf(&path)?;
    let load_seconds = load_start.elapsed().as_secs_f64();
    let camera = scene.camera(None).map_err(|m| Error::scene(&path, m))?;
    // Every size in storage memory, so that the sweep compares traversals alike: the smallest
    // would otherwise get the uniform BVH of lavapipe (`BvhMemory::Auto`).
    let gpu_scene = renderer.upload_scene_with(&scene, veach::render::BvhMemory::Storage)?;
    let settings = scale_strategies(config, sweep);
    for (_, s) in &settings {
        renderer.render(&gpu_scene, &RenderSettings { spp: 1, ..s.clone() }, &camera, &mut |_| true)?;
    }
    Ok(ScalePoint {
        sweep,
        triangles: scene.triangles.len(),
        lights: scene.lights.len(),
        load_seconds,
        gpu_scene,
        camera,
        times: vec![Vec::new(); settings.len()],
        rays: vec![0; settings.len()],
        settings,
    })
}

/// Times every point of a sweep `repeats` times, each repeat rendering every point and setting
/// once in turn (as `veach bench` alternates its kernels): a drift in the machine's speed over the
/// sweep then moves every point alike instead of the last ones. Noise faster than one repeat
/// (seconds) is what the median is for; on the 2-core VM that noise dominates, and seven runs of
/// the light sweep spread as widely in order as in turn (MIS 1 + 1: 1.12-1.70x against 1.44-1.89x).
fn time_points(renderer: &Renderer, config: &ScaleConfig, points: &mut [ScalePoint]) -> Result<()> {
    for _ in 0..config.repeats.max(1) {
        for p in points.iter_mut() {
            for (k, (_, settings)) in p.settings.iter().enumerate() {
                let out = renderer.render(&p.gpu_scene, settings, &p.camera, &mut |_| true)?;
                p.times[k].push(render_seconds(&out));
                p.rays[k] = out.rays;
            }
        }
    }
    Ok(())
}

/// A point's rows, one per setting, with the median of its renders and its ratio to `first` (the
/// sweep's first point), repeat by repeat.
fn point_rows(p: &ScalePoint, first: &ScalePoint) -> Vec<ScaleRow> {
    let stats = &p.gpu_scene.stats;
    p.settings
        .iter()
        .enumerate()
        .map(|(k, (strategy, settings))| {
            // Both points render the same strategies in the same order (`scale_strategies`).
            let firsts = first.times.get(k).map_or(&p.times[k], |t| t);
            ScaleRow {
                sweep: p.sweep,
                strategy,
                triangles: p.triangles,
                lights: p.lights,
                load_seconds: p.load_seconds,
                bvh_build_seconds: stats.bvh_build.as_secs_f64(),
                bvh_nodes: stats.bvh_nodes,
                gpu_scene_bytes: stats.gpu_scene_bytes,
                render_seconds: median_spread(&mut p.times[k].clone()).0,
                spp: settings.spp,
                rays: p.rays[k],
                ratio_to_first: RepeatRatio::of(&p.times[k], firsts),
            }
        })
        .collect()
}

/// Both sweeps; `progress` hears what is being done: each point's preparation, then each sweep's
/// timed renders (`scale_steps` of them in all).
pub fn run_scale(renderer: &Renderer, config: &ScaleConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<ScaleRow>> {
    let mut rows = Vec::new();
    for (sweep, counts) in [("triangles", &config.triangles), ("lights", &config.lights)] {
        if counts.is_empty() {
            continue;
        }
        let mut points = Vec::new();
        for &n in counts {
            progress(&format!("{n} {sweep}: build and compile"));
            let scene = if sweep == "triangles" { triangle_scene(n) } else { light_scene(n, config.light_grid) };
            points.push(prepare_point(renderer, config, sweep, &format!("scale-{sweep}-{n}"), scene)?);
        }
        progress(&format!("{sweep}: {} renders of each point, in turn", config.repeats.max(1)));
        time_points(renderer, config, &mut points)?;
        rows.extend(points.iter().flat_map(|p| point_rows(p, &points[0])));
    }
    Ok(rows)
}

/// How many messages run_scale sends `progress`: one per point and one per sweep.
pub fn scale_steps(config: &ScaleConfig) -> usize {
    let sweeps = [&config.triangles, &config.lights].iter().filter(|c| !c.is_empty()).count();
    config.triangles.len() + config.lights.len() + sweeps
}

pub fn scale_csv(rows: &[ScaleRow]) -> String {
    let mut s = String::from(
        "sweep,strategy,triangles,lights,load_s,bvh_build_s,bvh_nodes,gpu_scene_bytes,bytes_per_triangle,\
         bvh_bytes_per_triangle,render_s,spp,rays,rays_per_s,ratio_to_first,ratio_min,ratio_max\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{:.6},{},{},{:.2},{:.2},{:.6},{},{},{:.0},{:.4},{:.4},{:.4}",
            r.sweep,
            r.strategy,
            r.triangles,
            r.lights,
            r.load_seconds,
            r.bvh_build_seconds,
            r.bvh_nodes,
            r.gpu_scene_bytes,
            r.bytes_per_triangle(),
            r.bvh_bytes_per_triangle(),
            r.render_seconds,
            r.spp,
            r.rays,
            r.rays_per_second(),
            r.ratio_to_first.median,
            r.ratio_to_first.min,
            r.ratio_to_first.max
        );
    }
    s
}

/// Markdown tables of both sweeps, each render time also against the sweep's first point: the
/// median of the repeats' ratios, and their range where there are several repeats.
pub fn scale_report(rows: &[ScaleRow]) -> String {
    let ratio = |r: &ScaleRow| {
        let q = r.ratio_to_first;
        if q.min == q.max {
            format!("{:.2}", q.median)
        } else {
            format!("{:.2} ({:.2}–{:.2})", q.median, q.min, q.max)
        }
    };
    let mut s = String::new();
    let tri: Vec<&ScaleRow> = rows.iter().filter(|r| r.sweep == "triangles").collect();
    if !tri.is_empty() {
        let _ = writeln!(
            s,
            "| triangles | load s | BVH build s | GPU bytes / triangle (BVH) | render s | × first | Mrays/s |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for r in &tri {
            let _ = writeln!(
                s,
                "| {} | {:.3} | {:.3} | {:.0} ({:.0}) | {:.3} | {} | {:.2} |",
                r.triangles,
                r.load_seconds,
                r.bvh_build_seconds,
                r.bytes_per_triangle(),
                r.bvh_bytes_per_triangle(),
                r.render_seconds,
                ratio(r),
                r.rays_per_second() / 1e6
            );
        }
    }
    let lights: Vec<&ScaleRow> = rows.iter().filter(|r| r.sweep == "lights").collect();
    if !lights.is_empty() {
        let _ = writeln!(s, "\n| lights | triangles | strategy | render s | × first | rays | Mrays/s |");
        let _ = writeln!(s, "|---|---|---|---|---|---|---|");
        for r in &lights {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.3} | {} | {} | {:.2} |",
                r.lights,
                r.triangles,
                r.strategy,
                r.render_seconds,
                ratio(r),
                r.rays,
                r.rays_per_second() / 1e6
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_are_taken_repeat_by_repeat() {
        // A machine twice as slow in the second repeat moves both points alike: every repeat's
        // ratio is 1.5, where the medians of the two points' own times would give 3 / 2.
        let q = RepeatRatio::of(&[3.0, 6.0, 3.3], &[2.0, 4.0, 2.0]);
        assert_eq!(q, RepeatRatio { median: 1.5, min: 1.5, max: 1.65 });
        assert_eq!(RepeatRatio::of(&[1.0, 2.0], &[1.0, 1.0]).median, 1.5);
    }
}

//! Shared helpers of the GPU tests: one renderer per test binary, scenes written and loaded
//! through the real glTF path, and statistics of rendered regions.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::OnceLock;
use veach::assets::gltf_writer::GltfBuilder;
use veach::output::RenderOutput;
use veach::render::GpuScene;
use veach::scene::{Camera, Scene};
use veach::{GpuContext, RenderSettings, Renderer};

/// The renderer on the machine's adapter (lavapipe in CI). Compiled once per test binary.
pub fn renderer() -> &'static Renderer {
    static RENDERER: OnceLock<Renderer> = OnceLock::new();
    RENDERER.get_or_init(|| {
        let gpu = GpuContext::new(None).unwrap_or_else(|e| panic!("{e}"));
        eprintln!("adapter: {}", gpu.describe());
        Renderer::new(gpu).unwrap_or_else(|e| panic!("{e}"))
    })
}

/// Where tests leave files to look at (images of a failed comparison, histograms).
pub fn output_dir(test: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("veach-tests").join(test);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A deterministic stream in [0, 1): a 64-bit LCG (Knuth's MMIX constants), its top 24 bits.
pub fn uniforms(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Writes the scene as glTF and loads it back, so tests go through the real loader.
pub fn load(builder: &GltfBuilder, name: &str) -> Scene {
    let path = output_dir("scenes").join(format!("{name}.gltf"));
    builder.write(&path).unwrap();
    veach::load_gltf(&path).unwrap_or_else(|e| panic!("{e}"))
}

pub fn shipped_scene(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets").join(format!("{name}.gltf"));
    veach::load_gltf(&path).unwrap_or_else(|e| panic!("{e}"))
}

pub fn render(scene: &GpuScene, settings: &RenderSettings, camera: &Camera) -> RenderOutput {
    renderer().render(scene, settings, camera, &mut |_| true).unwrap_or_else(|e| panic!("{e}"))
}

pub fn upload(scene: &Scene) -> GpuScene {
    renderer().upload_scene(scene).unwrap_or_else(|e| panic!("{e}"))
}

/// Mean over a pixel rectangle of the per-pixel means, and the variance of that mean
/// (Σ per-pixel variance of the mean / P²: pixels are independent).
#[derive(Clone, Copy, Debug)]
pub struct RegionEstimate {
    pub mean: [f64; 3],
    pub var: [f64; 3],
}

pub fn region(out: &RenderOutput, x0: u32, y0: u32, x1: u32, y1: u32) -> RegionEstimate {
    let mean = out.mean();
    let var = out.variance_of_mean();
    let mut m = [0.0f64; 3];
    let mut v = [0.0f64; 3];
    let mut count = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * out.width + x) as usize;
            for c in 0..3 {
                m[c] += mean[i][c] as f64;
                v[c] += var[i][c] as f64;
            }
            count += 1.0;
        }
    }
    RegionEstimate { mean: m.map(|s| s / count), var: v.map(|s| s / (count * count)) }
}

/// erfc with fractional error below 1.2e-7 (Numerical Recipes, 2nd ed., §6.2, `erfcc`).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    // The recipe's nested polynomial in t, evaluated inside out (Horner): the same operations in
    // the same order. Written as a fold because rustfmt takes seconds on the nine-deep nesting.
    const C: [f64; 9] =
        [1.00002368, 0.37409196, 0.09678418, -0.18628806, 0.27886807, -1.13520398, 1.48851587, -0.82215223, 0.17087277];
    let poly = C[..8].iter().rev().fold(C[8], |p, &c| c + t * p);
    let r = t * (-z * z - 1.26551223 + t * poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// Student's t with ν degrees of freedom: P(|T| > t). Abramowitz & Stegun 26.7.3-4: with
/// θ = atan(t / √ν), P(|T| ≤ t) is sin θ Σ_{k<ν/2} c_k cos^{2k} θ (c_0 = 1, c_k = c_{k−1} (2k − 1) / 2k)
/// for even ν, and (2/π) (θ + sin θ Σ_{k<(ν−1)/2} d_k cos^{2k+1} θ) (d_0 = 1, d_k = d_{k−1} 2k / (2k + 1))
/// for odd ν.
pub fn student_t_two_sided_tail(t: f64, nu: u32) -> f64 {
    assert!(nu >= 1);
    let theta = (t / (nu as f64).sqrt()).atan();
    let (sin, cos) = (theta.sin(), theta.cos());
    let inside = if nu.is_multiple_of(2) {
        let (mut term, mut sum) = (1.0, 1.0);
        for k in 1..nu / 2 {
            term *= cos * cos * (2 * k - 1) as f64 / (2 * k) as f64;
            sum += term;
        }
        sin * sum
    } else {
        let (mut term, mut sum) = (cos, if nu > 1 { cos } else { 0.0 });
        for k in 1..(nu - 1) / 2 {
            term *= cos * cos * (2 * k) as f64 / (2 * k + 1) as f64;
            sum += term;
        }
        2.0 / std::f64::consts::PI * (theta + sin * sum)
    };
    (1.0 - inside).clamp(0.0, 1.0)
}

/// Two-sided critical t for ν degrees of freedom: P(|T| > t) = tail, by bisection.
pub fn student_t_critical(tail: f64, nu: u32) -> f64 {
    let (mut lo, mut hi) = (0.0, 1e6);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_two_sided_tail(mid, nu) > tail { lo = mid } else { hi = mid }
    }
    hi
}

/// Two-sided critical z for `comparisons` tests at family-wise significance `alpha`
/// (Bonferroni): P(|Z| > z) = alpha / comparisons.
pub fn bonferroni_z(alpha: f64, comparisons: usize) -> f64 {
    let target = alpha / comparisons as f64;
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        // P(|Z| > z) = erfc(z / sqrt 2)
        if erfc(mid / std::f64::consts::SQRT_2) > target { lo = mid } else { hi = mid }
    }
    hi
}

/// Writes images of a failed comparison next to each other for a person to look at.
pub fn write_failure_images(test: &str, images: &[(&str, u32, u32, Vec<[f32; 3]>)]) -> PathBuf {
    let dir = output_dir(test);
    for (name, w, h, px) in images {
        veach::image_io::write_image(&dir.join(format!("{name}.exr")), *w, *h, px, 0.0).unwrap();
        veach::image_io::write_image(&dir.join(format!("{name}.png")), *w, *h, px, 0.0).unwrap();
    }
    dir
}

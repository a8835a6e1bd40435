//! Shared helpers of the GPU tests: one renderer per test binary, scenes written and loaded
//! through the real glTF path, and statistics of rendered regions.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::OnceLock;
use veach::output::{Contributions, RenderOutput};
use veach::render::GpuScene;
use veach::scene::{Camera, Scene};
use veach::{GpuContext, RenderSettings, Renderer};
use veach_scenes::gltf_writer::GltfBuilder;

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

/// Two images of per-pixel sums that should agree, and their difference (`write_failure_images`).
pub fn write_compared_images(test: &str, a: &[[f32; 4]], b: &[[f32; 4]], width: u32) -> PathBuf {
    let rgb = |img: &[[f32; 4]]| img.iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>();
    let diff = a.iter().zip(b).map(|(p, q)| [0, 1, 2].map(|c| (p[c] - q[c]).abs())).collect();
    let height = a.len() as u32 / width;
    write_failure_images(
        test,
        &[("first", width, height, rgb(a)), ("second", width, height, rgb(b)), ("difference", width, height, diff)],
    )
}

/// Whether two kernels that do the same arithmetic from differently arranged code (specialised or
/// generic, megakernel or wavefront) round it alike, bit for bit. A CPU adapter (lavapipe: LLVM)
/// rounds each WGSL operation by itself wherever it is compiled. A GPU driver may fuse a multiply
/// and an add into one rounding (SPIR-V allows it for any operation not decorated NoContraction,
/// which naga does not emit) and decides where per kernel: on an NVIDIA H200 the specialised and
/// generic kernels' images differed.
pub fn kernels_round_alike() -> bool {
    renderer().gpu.adapter_info.device_type == wgpu::DeviceType::Cpu
}

/// Per-pixel sums of the same render by two kernels (rgb and a fourth channel: the sample count,
/// or a contribution image's emitted luminance) are the same image: bit for bit where the kernels
/// round alike (`kernels_round_alike`). Elsewhere each pixel's four channels agree to 1e-4 of
/// their value, about a thousand times f32's rounding, which fused operations change by an ulp
/// at a time (a sample count of a few thousand at most, so only an equal count passes), except
/// in at most 1% of the pixels (at least one): there one rounding moved a ray across a triangle's
/// edge or a random number across a decision, which changes the pixel by a whole sample. A
/// non-finite value that the other image lacks fails either way. A failure writes both images
/// and their difference.
pub fn assert_same_image(test: &str, what: &str, a: &[[f32; 4]], b: &[[f32; 4]], width: u32) {
    assert_eq!(a.len(), b.len(), "{what}: image sizes differ");
    let exact = kernels_round_alike();
    let agreement = ImageAgreement::of(a, b);
    let same = if exact { agreement.differ == 0 } else { agreement.within_rounding() };
    let ImageAgreement { differ, far, allowed_far, nonfinite, worst } = agreement;
    if same && differ > 0 {
        // Seen with --nocapture (scripts/gpu-tests.sh): how far apart a GPU's kernels round.
        eprintln!("{what}: {differ} of {} pixels differ, {far} beyond 1e-4 (largest {worst:.2e})", a.len());
    }
    if !same {
        let dir = write_compared_images(test, a, b, width);
        let rule = if exact { "bit for bit".to_string() } else { format!("at most {allowed_far} beyond 1e-4") };
        panic!(
            "{what}: images differ ({rule}): {differ} of {} pixels differ, {far} by more than 1e-4 relative \
             (largest {worst:.2e}), {nonfinite} with a non-finite value; images in {}",
            a.len(),
            dir.display()
        );
    }
}

/// `assert_same_image` for both contribution images (light samples', BRDF samples') of a render.
pub fn assert_same_contributions(test: &str, what: &str, a: &Contributions, b: &Contributions, width: u32) {
    assert_same_image(test, &format!("{what}: light contributions"), &a.light, &b.light, width);
    assert_same_image(test, &format!("{what}: BRDF contributions"), &a.brdf, &b.brdf, width);
}

/// How two images of per-pixel sums differ (`assert_same_image`).
#[derive(Debug)]
pub struct ImageAgreement {
    /// Pixels not equal bit for bit.
    pub differ: usize,
    /// Pixels with a channel off by more than 1e-4 of its value.
    pub far: usize,
    /// 1% of the pixels, at least one.
    pub allowed_far: usize,
    /// Pixels that differ where either has a non-finite channel: never rounding.
    pub nonfinite: usize,
    /// The largest relative difference of any channel.
    pub worst: f32,
}

impl ImageAgreement {
    pub fn of(a: &[[f32; 4]], b: &[[f32; 4]]) -> ImageAgreement {
        let scale = a.iter().flat_map(|p| p[..3].iter()).map(|v| v.abs()).fold(0.0f32, f32::max);
        let (mut differ, mut far, mut nonfinite, mut worst) = (0usize, 0usize, 0usize, 0.0f32);
        for (p, q) in a.iter().zip(b) {
            differ += usize::from(p != q);
            nonfinite += usize::from(p != q && !p.iter().chain(q).all(|v| v.is_finite()));
            let rel = (0..4)
                .map(|c| (p[c] - q[c]).abs() / (p[c].abs().max(q[c].abs()) + 1e-6 * scale).max(f32::MIN_POSITIVE))
                .fold(0.0f32, f32::max);
            worst = worst.max(rel);
            far += usize::from(rel.is_nan() || rel > 1e-4);
        }
        ImageAgreement { differ, far, allowed_far: (a.len() / 100).max(1), nonfinite, worst }
    }

    /// The rule where kernels do not round alike.
    pub fn within_rounding(&self) -> bool {
        self.far <= self.allowed_far && self.nonfinite == 0
    }
}

/// Two kernels' ray counts for the same render: equal where kernels round alike; elsewhere within
/// 1%, as `assert_same_image` lets 1% of the pixels take another path.
pub fn assert_same_rays(what: &str, a: u64, b: u64) {
    let ok = if kernels_round_alike() { a == b } else { a.abs_diff(b) as f64 <= 0.01 * a.max(b) as f64 };
    assert!(ok, "{what}: ray counts differ: {a} and {b}");
}

/// Per-pixel sums of the same camera samples, added up in another order (kernels whose direction
/// rays are held: deferred_rays.wgsl, take_samples_deferred) are the same image up to the sums'
/// rounding: every pixel has the same sample count, and each channel of a sum of n non-negative
/// samples differs by at most 2n · 2^-24 of the sum (each of the n - 1 additions of either order
/// rounds by at most 2^-24 of a partial sum no larger than the whole: Higham, "Accuracy and
/// Stability of Numerical Algorithms", §4.2). n is `counts`' fourth channel (the sums' own, or
/// theirs for the sums of squares). Where kernels do not round alike (`kernels_round_alike`)
/// `assert_same_image`'s rule. A failure writes both images and their difference.
pub fn assert_same_samples_reordered(
    test: &str,
    what: &str,
    a: &[[f32; 4]],
    b: &[[f32; 4]],
    counts: &[[f32; 4]],
    width: u32,
) {
    assert_eq!(a.len(), b.len(), "{what}: image sizes differ");
    if !kernels_round_alike() {
        return assert_same_image(test, what, a, b, width);
    }
    let mut worst: Option<(usize, f32, f32)> = None;
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        // 2n · 2^-24, f32::EPSILON being 2^-23.
        let bound = counts[i][3] * f32::EPSILON;
        let counts_differ = p[3] != q[3];
        let rel = (0..3)
            .map(|c| (p[c] - q[c]).abs() / p[c].abs().max(q[c].abs()).max(f32::MIN_POSITIVE))
            .fold(0.0f32, f32::max);
        let bad = counts_differ || rel.is_nan() || rel > bound || p.iter().chain(q).any(|v| !v.is_finite());
        if bad && worst.is_none_or(|(_, r, _)| rel > r) {
            worst = Some((i, rel, bound));
        }
    }
    if let Some((pixel, rel, bound)) = worst {
        let dir = write_compared_images(test, a, b, width);
        panic!(
            "{what}: pixel {pixel} differs beyond reordered sums' rounding: {:?} against {:?} (relative {rel:.2e}, \
             allowed {bound:.2e}); images in {}",
            a[pixel],
            b[pixel],
            dir.display()
        );
    }
}

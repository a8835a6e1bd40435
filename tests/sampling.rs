//! Statistical tests of the WGSL sampling routines, run through `shaders/test_kernels.wgsl` on
//! the GPU (the code that renders, not a Rust copy):
//! - chi-square goodness of fit of sampled directions against the pdf function, for uniform and
//!   cosine hemisphere sampling, GGX visible-normal sampling, the full glTF BRDF mixture,
//!   area-light sampling of a triangle seen from a point, and light selection;
//! - the pdf a sampler returns equals the pdf function at the same direction, and the pdf
//!   integrates to the fraction of valid samples;
//! - white furnace, non-negative finite BRDF values, and the MIS weights;
//! - the sampler's Sobol points are nets in every aligned block, and its requests independent.
//!
//! Chi-square: Pearson's test with bins of low expected count (< 5) pooled, as Mitsuba 3's
//! `chi2` test does, at significance 1% with a Bonferroni correction over all cases of a test.
//! A failing case writes its observed and expected histograms (CSV and PNG) under
//! target/tmp/veach-tests/chi2/.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use veach::gpu::layout::{self, FrameParams, TestParams};
use veach::gpu::test_kernel::{TestKernel, routine};
use veach::render::GpuScene;
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};

const SAMPLES: u32 = 1 << 20;
/// Histogram resolution: bins in the (compressed) polar angle and in azimuth.
const BINS_THETA: usize = 20;
const BINS_PHI: usize = 40;
/// Midpoint sub-cells per bin side when integrating the pdf over a bin; in bins where the pdf
/// varies by more than 50%; and in bins where it jumps (the horizon, a triangle's edge), where
/// the midpoint rule's error is proportional to the sub-cell size.
const SUB: usize = 8;
const SUB_FINE: usize = 48;
const SUB_JUMP: usize = 192;

fn kernel() -> &'static TestKernel<'static> {
    static K: std::sync::OnceLock<TestKernel<'static>> = std::sync::OnceLock::new();
    K.get_or_init(|| TestKernel::new(renderer()).unwrap_or_else(|e| panic!("{e}")))
}

fn empty_scene() -> &'static GpuScene {
    static S: std::sync::OnceLock<GpuScene> = std::sync::OnceLock::new();
    S.get_or_init(|| upload(&veach::Scene::default()))
}

fn frame(scene_lights: u32, selection: u32, heuristic: u32) -> FrameParams {
    FrameParams { light_count: scene_lights, light_selection: selection, heuristic, ..Default::default() }
}

fn material(base: Vec3, metallic: f32, roughness: f32) -> layout::Material {
    layout::Material {
        base_color: base.to_array(),
        metallic,
        roughness,
        specular: 1.0,
        specular_color: [1.0; 3],
        ..Default::default()
    }
}

fn wo_at(theta_degrees: f64) -> Vec3 {
    let t = theta_degrees.to_radians();
    Vec3::new(t.sin() as f32, 0.0, t.cos() as f32)
}

/// Directions parameterised around a centre c: polar angle θ' from c, mapped logarithmically as
/// s = ln(1 + θ'/σ) / ln(1 + π/σ) ∈ [0, 1], so that a lobe of angular width ~σ and a broad lobe
/// around it both spread over several bins; azimuth φ'.
struct SphereBins {
    t: DVec3,
    b: DVec3,
    n: DVec3,
    sigma: f64,
}

impl SphereBins {
    fn new(center: DVec3, sigma: f64) -> Self {
        let n = center.normalize();
        let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        let t = n.cross(helper).normalize();
        SphereBins { t, b: n.cross(t), n, sigma }
    }
    fn log_range(&self) -> f64 {
        (1.0 + PI / self.sigma).ln()
    }
    fn bin(&self, d: DVec3) -> usize {
        let (x, y, z) = (d.dot(self.t), d.dot(self.b), d.dot(self.n));
        let theta = (x * x + y * y).sqrt().atan2(z);
        let phi = y.atan2(x).rem_euclid(2.0 * PI);
        let s = (1.0 + theta / self.sigma).ln() / self.log_range();
        let i = ((s * BINS_THETA as f64) as usize).min(BINS_THETA - 1);
        let j = ((phi / (2.0 * PI) * BINS_PHI as f64) as usize).min(BINS_PHI - 1);
        i * BINS_PHI + j
    }
    /// Direction at (s, φ) and the solid angle per unit s per unit φ there.
    fn direction(&self, s: f64, phi: f64) -> (DVec3, f64) {
        let l = self.log_range();
        let theta = (self.sigma * ((s * l).exp() - 1.0)).min(PI);
        let local = DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
        let d = local.x * self.t + local.y * self.b + local.z * self.n;
        // dω = sin θ' dθ' dφ', dθ'/ds = σ L e^{sL}
        (d, theta.sin().abs() * self.sigma * l * (s * l).exp())
    }
}

/// ln Γ(x), Lanczos approximation (Numerical Recipes 2nd ed., §6.1, gammln).
fn ln_gamma(x: f64) -> f64 {
    let c = [
        76.18009172947146,
        -86.50532032941677,
        24.01409824083091,
        -1.231739572450155,
        0.1208650973866179e-2,
        -0.5395239384953e-5,
    ];
    let mut y = x;
    let tmp = x + 5.5 - (x + 0.5) * (x + 5.5).ln();
    let mut ser = 1.000000000190015;
    for c in c {
        y += 1.0;
        ser += c / y;
    }
    -tmp + (2.5066282746310005 * ser / x).ln()
}

/// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes 2nd ed., §6.2, gammq).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / 1e-300;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < 1e-300 {
                d = 1e-300;
            }
            c = b + an / c;
            if c.abs() < 1e-300 {
                c = 1e-300;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

/// Pearson's chi-square with bins of expected count < 5 pooled into one. Returns (p-value, dof).
fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let (mut chi2, mut dof) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pooled_e >= 5.0 {
        chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
        dof += 1;
    } else if pooled_o > 10.0 * pooled_e.max(0.5) {
        // Many samples where the pdf says there should be almost none.
        return (0.0, dof);
    }
    let dof = dof.saturating_sub(1).max(1);
    (gamma_q(dof as f64 / 2.0, chi2 / 2.0), dof)
}

fn write_histograms(case: &str, observed: &[f64], expected: &[f64], rows: usize, cols: usize) {
    let dir = output_dir("chi2");
    let name: String = case.chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' }).collect();
    let mut csv = String::from("row,col,observed,expected\n");
    for (k, (o, e)) in observed.iter().zip(expected).enumerate() {
        csv.push_str(&format!("{},{},{o},{e}\n", k / cols, k % cols));
    }
    std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
    let max = observed.iter().chain(expected).fold(1e-9f64, |a, &b| a.max(b));
    let mut img = image::GrayImage::new(2 * cols as u32 + 1, rows as u32);
    for (k, (o, e)) in observed.iter().zip(expected).enumerate() {
        let (r, c) = ((k / cols) as u32, (k % cols) as u32);
        img.put_pixel(c, r, image::Luma([(o / max * 255.0) as u8]));
        img.put_pixel(c + cols as u32 + 1, r, image::Luma([(e / max * 255.0) as u8]));
    }
    img.save(dir.join(format!("{name}.png"))).unwrap();
    eprintln!("{case}: histograms (observed | expected) written to {}", dir.join(format!("{name}.png")).display());
}

struct DirectionCase {
    name: String,
    scene: &'static GpuScene,
    frame: FrameParams,
    params: TestParams,
    pdf_routine: u32,
    bins: SphereBins,
}

/// Samples, histograms, integrates the pdf over the bins on the GPU, and checks: sampler pdf =
/// pdf function, ∫ pdf = fraction of valid samples, chi-square p-value above `alpha`.
fn run_direction_case(case: &DirectionCase, alpha: f64) -> Result<(), String> {
    let k = kernel();
    let params = TestParams { count: SAMPLES, ..case.params };
    let out = k.run(case.scene, &case.frame, &params, &[], 2).unwrap();
    let mut observed = vec![0.0f64; BINS_THETA * BINS_PHI];
    let (mut valid, mut mismatched, mut missed) = (0u64, 0u64, 0u64);
    let mut examples = Vec::new();
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.max(b);
    // A sampler that is uniform in each triangle's solid angle returns one pdf per triangle. A
    // direction sampled within rounding of the edge two triangles share can hit the other one;
    // its pdf function value is then that triangle's, which some other sample returned.
    let mut piecewise: Vec<f32> = Vec::new();
    for pair in out.chunks(2) {
        let pdf = pair[0][3];
        if pair[1][2] != 0.0 && piecewise.len() <= 16 && !piecewise.iter().any(|&v| close(v, pdf)) {
            piecewise.push(pdf);
        }
    }
    let piecewise_constant = piecewise.len() <= 16;
    for pair in out.chunks(2) {
        let [x, y, z, pdf] = pair[0];
        let [pdf_eval, _, is_valid, _] = pair[1];
        if is_valid == 0.0 {
            continue;
        }
        valid += 1;
        let neighbour = piecewise_constant && piecewise.iter().any(|&v| close(v, pdf_eval));
        if !pdf.is_finite() || pdf <= 0.0 || (!close(pdf, pdf_eval) && !neighbour) {
            mismatched += 1;
            // A ray that misses the light returns pdf 0: the direction left the light by rounding.
            missed += u64::from(pdf_eval == 0.0);
            if examples.len() < 3 {
                examples.push(format!("({x:.6}, {y:.6}, {z:.6}) pdf {pdf:e}, pdf function {pdf_eval:e}"));
            }
        }
        observed[case.bins.bin(DVec3::new(x as f64, y as f64, z as f64).normalize())] += 1.0;
    }
    // Integrate the pdf function over every bin: SUB × SUB midpoints in (s, φ), then
    // SUB_FINE × SUB_FINE in the bins where the pdf jumps or varies strongly.
    let coarse = integrate_bins(case, &(0..BINS_THETA * BINS_PHI).collect::<Vec<_>>(), SUB);
    // A jump can also cross a bin between its coarse points: refine the zero bins next to
    // non-zero ones too.
    let nonzero = |i: usize, j: usize| coarse[i * BINS_PHI + j % BINS_PHI].2 > 0.0;
    let (mut jumps, mut curved) = (Vec::new(), Vec::new());
    for (b, &(_, lo, hi)) in coarse.iter().enumerate() {
        let (i, j) = (b / BINS_PHI, b % BINS_PHI);
        let next_to_nonzero = nonzero(i, j + 1)
            || nonzero(i, j + BINS_PHI - 1)
            || (i > 0 && nonzero(i - 1, j))
            || (i + 1 < BINS_THETA && nonzero(i + 1, j));
        if (hi > 0.0 && lo == 0.0) || (hi == 0.0 && next_to_nonzero) {
            jumps.push(b);
        } else if hi > 1.5 * lo {
            curved.push(b);
        }
    }
    let mut bin_integral: Vec<f64> = coarse.iter().map(|c| c.0).collect();
    for (bins, sub) in [(&curved, SUB_FINE), (&jumps, SUB_JUMP)] {
        for (k, v) in integrate_bins(case, bins, sub).into_iter().enumerate() {
            bin_integral[bins[k]] = v.0;
        }
    }
    let expected: Vec<f64> = bin_integral.iter().map(|v| v * SAMPLES as f64).collect();
    let integral: f64 = bin_integral.iter().sum();
    let n = SAMPLES as f64;
    let valid_fraction = valid as f64 / n;
    let (p_value, dof) = chi_square(&observed, &expected);
    let mut problems = Vec::new();
    if valid == 0 {
        problems.push("no sample is valid: the case tests nothing (a light seen from behind?)".into());
    }
    // Rays aimed at a sampled point within rounding of a triangle's edge may miss it.
    if mismatched > 10 {
        problems.push(format!(
            "{mismatched} samples whose returned pdf differs from the pdf function ({missed} of them miss the light), e.g. {}",
            examples.join(", ")
        ));
    }
    // Binomial standard error of the valid fraction, plus 2e-3 for the midpoint quadrature.
    let tol = 5.0 * (valid_fraction * (1.0 - valid_fraction) / n).sqrt() + 2e-3;
    if (integral - valid_fraction).abs() > tol {
        problems.push(format!(
            "∫pdf = {integral:.5} but {valid_fraction:.5} of the samples are valid (tolerance {tol:.5})"
        ));
    }
    if p_value < alpha {
        problems.push(format!("chi-square p = {p_value:.3e} < {alpha:.1e} ({dof} dof)"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        write_histograms(&case.name, &observed, &expected, BINS_THETA, BINS_PHI);
        Err(format!("{}: {}", case.name, problems.join("; ")))
    }
}

/// ∫ pdf over each listed bin with sub × sub midpoints, and the smallest and largest pdf seen.
fn integrate_bins(case: &DirectionCase, bins: &[usize], sub: usize) -> Vec<(f64, f64, f64)> {
    let ds = 1.0 / (BINS_THETA * sub) as f64;
    let dphi = 2.0 * PI / (BINS_PHI * sub) as f64;
    let mut dirs = Vec::with_capacity(bins.len() * sub * sub);
    let mut weights = Vec::with_capacity(dirs.capacity());
    for &bin in bins {
        let (bi, bj) = (bin / BINS_PHI, bin % BINS_PHI);
        for i in 0..sub {
            for j in 0..sub {
                let s = (bi * sub + i) as f64 + 0.5;
                let phi = (bj * sub + j) as f64 + 0.5;
                let (d, jac) = case.bins.direction(s * ds, phi * dphi);
                dirs.push([d.x as f32, d.y as f32, d.z as f32, 0.0]);
                weights.push(jac * ds * dphi);
            }
        }
    }
    if dirs.is_empty() {
        return Vec::new();
    }
    let mut pdfs = Vec::with_capacity(dirs.len());
    for chunk in dirs.chunks(1 << 21) {
        let eval = TestParams { routine: case.pdf_routine, count: chunk.len() as u32, ..case.params };
        pdfs.extend(kernel().run(case.scene, &case.frame, &eval, chunk, 1).unwrap());
    }
    pdfs.chunks(sub * sub)
        .zip(weights.chunks(sub * sub))
        .map(|(p, w)| {
            let mut sum = 0.0;
            let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
            for (p, w) in p.iter().zip(w) {
                assert!(p[0].is_finite() && p[0] >= 0.0, "{}: pdf {}", case.name, p[0]);
                sum += p[0] as f64 * w;
                lo = lo.min(p[0] as f64);
                hi = hi.max(p[0] as f64);
            }
            (sum, lo, hi)
        })
        .collect()
}

fn run_all(cases: &[DirectionCase]) {
    let alpha = 0.01 / cases.len() as f64;
    let failures: Vec<String> = cases.iter().filter_map(|c| run_direction_case(c, alpha).err()).collect();
    assert!(failures.is_empty(), "{} of {} cases failed:\n{}", failures.len(), cases.len(), failures.join("\n"));
}

fn bsdf_case(name: String, routine: u32, pdf_routine: u32, m: layout::Material, theta_o: f64) -> DirectionCase {
    let wo = wo_at(theta_o);
    let alpha = (m.roughness * m.roughness).max(1e-4) as f64;
    let mirror = DVec3::new(-wo.x as f64, -wo.y as f64, wo.z as f64);
    DirectionCase {
        name,
        scene: empty_scene(),
        frame: frame(0, layout::SELECT_EACH, layout::HEURISTIC_BALANCE),
        params: TestParams { routine, seed: 17, wo: wo.to_array(), material: m, ..Default::default() },
        pdf_routine,
        bins: SphereBins::new(mirror, 2.0 * alpha),
    }
}

#[test]
fn hemisphere_samplers_match_their_pdfs() {
    let m = material(Vec3::ONE, 0.0, 1.0);
    let mk = |name: &str, r, p| DirectionCase {
        bins: SphereBins::new(DVec3::Z, 1.0),
        ..bsdf_case(name.into(), r, p, m, 0.0)
    };
    run_all(&[
        mk("uniform hemisphere", routine::SAMPLE_UNIFORM, routine::PDF_UNIFORM),
        mk("cosine hemisphere", routine::SAMPLE_COSINE, routine::PDF_COSINE),
    ]);
}

#[test]
fn ggx_visible_normal_sampling_matches_its_pdf() {
    let mut cases = Vec::new();
    for roughness in [0.01, 0.05, 0.2, 0.5, 1.0] {
        for theta in [0.0, 30.0, 60.0, 85.0, 89.5] {
            // At θo = 89.5° the α = 1e-4 lobe moves a unit vector's largest component by
            // ~2e-6, about 30 f32 ulps: directions themselves cannot resolve it. 85° is the
            // most grazing angle where f32 directions resolve that lobe (~3e-4 of its width).
            if roughness == 0.01 && theta > 85.0 {
                continue;
            }
            let m = material(Vec3::ONE, 1.0, roughness);
            cases.push(bsdf_case(
                format!("vndf roughness {roughness} θo {theta}"),
                routine::SAMPLE_GGX_VNDF,
                routine::PDF_GGX_VNDF,
                m,
                theta,
            ));
        }
    }
    run_all(&cases);
}

#[test]
fn gltf_brdf_sampling_matches_its_mixture_pdf() {
    let mut cases = Vec::new();
    for metallic in [0.0, 1.0] {
        for roughness in [0.01, 0.1, 0.5, 1.0] {
            for theta in [0.0, 45.0, 80.0, 89.0] {
                let m = material(Vec3::new(0.8, 0.5, 0.3), metallic, roughness);
                cases.push(bsdf_case(
                    format!("brdf metallic {metallic} roughness {roughness} θo {theta}"),
                    routine::SAMPLE_BSDF,
                    routine::PDF_BSDF,
                    m,
                    theta,
                ));
            }
        }
    }
    run_all(&cases);
}

/// A unit square light at z = 1 facing down.
fn unit_quad_light(name: &str) -> GpuScene {
    light_scene(
        name,
        &[(
            Vec3::new(-0.5, -0.5, 1.0),
            Vec3::new(0.5, -0.5, 1.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(-0.5, 0.5, 1.0),
            -Vec3::Z,
        )],
    )
}

/// A scene of one light, `mesh`, of radiance 1.
fn mesh_light(name: &str, mesh: &MeshData) -> GpuScene {
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::emitter("light", Vec3::ONE));
    g.add_mesh("light", mesh, m, glam::Mat4::IDENTITY);
    upload(&load(&g, name))
}

/// A scene of one light of two triangles, `first` then `second`, of radiance 1.
fn two_triangle_light(name: &str, first: [Vec3; 3], second: [Vec3; 3]) -> GpuScene {
    let mesh = MeshData { positions: [first, second].concat(), normals: None, uvs: None, indices: (0..6).collect() };
    mesh_light(name, &mesh)
}

/// Light scenes for area sampling: (name, light triangles, the receiving point).
fn light_scene(name: &str, quads: &[(Vec3, Vec3, Vec3, Vec3, Vec3)]) -> GpuScene {
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::emitter("light", Vec3::ONE));
    let mut mesh = MeshData::default();
    for &(a, b, c, d, facing) in quads {
        mesh.append(&MeshData::quad(a, b, c, d, facing));
    }
    g.add_mesh("light", &mesh, m, glam::Mat4::IDENTITY);
    upload(&load(&g, name))
}

#[test]
fn area_light_sampling_matches_the_solid_angle_pdf() {
    let leak = |s: GpuScene| -> &'static GpuScene { Box::leak(Box::new(s)) };
    // A unit quad at z = 1 facing down, seen from points near and far, head-on and grazing;
    // and a light of two unequal quads (triangle selection by area).
    let quad = leak(unit_quad_light("chi2-quad"));
    let two = leak(light_scene(
        "chi2-two-quads",
        &[
            (
                Vec3::new(-1.0, -0.2, 1.0),
                Vec3::new(0.0, -0.2, 1.0),
                Vec3::new(0.0, 0.2, 1.0),
                Vec3::new(-1.0, 0.2, 1.0),
                -Vec3::Z,
            ),
            (
                Vec3::new(0.3, -0.1, 0.8),
                Vec3::new(0.5, -0.1, 0.8),
                Vec3::new(0.5, 0.1, 0.8),
                Vec3::new(0.3, 0.1, 0.8),
                -Vec3::Z,
            ),
        ],
    ));
    // A sheared parallelogram of two triangles, its first triangle's corners in each rotation, so
    // that the one opposite the shared edge is once each corner (Light.parallelogram = 1, 2, 3):
    // area samples map the unit square onto it linearly, and must cover it uniformly.
    let (a, b, c) = (Vec3::new(-0.6, -0.3, 1.0), Vec3::new(0.4, -0.3, 1.0), Vec3::new(0.7, 0.4, 1.0));
    let d = a + c - b;
    let sheared = |name: &str, first: [Vec3; 3]| leak(two_triangle_light(name, first, [a, d, c]));
    let corner_first = sheared("chi2-parallelogram-0", [b, a, c]);
    let corner_second = sheared("chi2-parallelogram-1", [c, b, a]);
    let corner_third = sheared("chi2-parallelogram-2", [a, c, b]);
    // A rectangle turned about two axes, its first triangle's right angle once at corner 0 and
    // once at corner 2 (the unit quad has it at corner 1): solid-angle sampling takes it as one
    // spherical rectangle (Ureña et al. 2013).
    let turn = glam::Quat::from_rotation_x(0.4) * glam::Quat::from_rotation_y(-0.7);
    let (r0, r1, r2) =
        (turn * Vec3::new(-0.4, -0.25, 0.0), turn * Vec3::new(0.4, -0.25, 0.0), turn * Vec3::new(0.4, 0.25, 0.0));
    let (r0, r1, r2) = (r0 + Vec3::Z, r1 + Vec3::Z, r2 + Vec3::Z);
    let r3 = r0 + r2 - r1;
    let rectangle = |name: &str, first: [Vec3; 3]| leak(two_triangle_light(name, first, [r0, r2, r3]));
    let rectangle_a = rectangle("chi2-rectangle-a", [r1, r2, r0]);
    let rectangle_b = rectangle("chi2-rectangle-b", [r2, r0, r1]);
    let rectangle_normal = (r2 - r1).cross(r0 - r1).normalize();
    let case = |name: &str, scene: &'static GpuScene, point: Vec3, center: Vec3, radius: f64, sampling: u32| {
        let to_center = (center - point).as_dvec3();
        let mode = match sampling {
            layout::LIGHT_SAMPLING_SOLID_ANGLE => "solid angle",
            layout::LIGHT_SAMPLING_AUTO => "auto",
            _ => "area",
        };
        DirectionCase {
            name: format!("{name}, {mode}"),
            scene,
            frame: FrameParams { light_sampling: sampling, ..frame(1, layout::SELECT_EACH, layout::HEURISTIC_BALANCE) },
            params: TestParams {
                routine: routine::SAMPLE_LIGHT,
                seed: 5,
                point: point.to_array(),
                ..Default::default()
            },
            pdf_routine: routine::PDF_LIGHT,
            bins: SphereBins::new(to_center, radius / to_center.length()),
        }
    };
    // Each case with area sampling, with solid-angle sampling (the quads and rectangles as
    // spherical rectangles, Ureña et al. 2013; the two quads' triangles by Arvo 1995) and with
    // auto (rectangles by solid angle, the two quads by area), whose pdf function (area_light_pdf
    // on the traced hit) must match where the samples land.
    let mut cases = Vec::new();
    for sampling in [layout::LIGHT_SAMPLING_AREA, layout::LIGHT_SAMPLING_SOLID_ANGLE, layout::LIGHT_SAMPLING_AUTO] {
        let z = Vec3::new(0.0, 0.0, 1.0);
        cases.extend([
            case("quad head-on near", quad, Vec3::new(0.0, 0.0, 0.5), z, 0.7, sampling),
            case("quad head-on far", quad, Vec3::new(0.1, 0.0, -20.0), z, 0.7, sampling),
            case("quad off-centre", quad, Vec3::new(1.5, 0.7, 0.0), z, 0.7, sampling),
            case("quad at grazing angle", quad, Vec3::new(4.0, 0.0, 0.9), z, 0.7, sampling),
            case("two unequal quads", two, Vec3::new(0.0, 0.0, 0.0), Vec3::new(-0.2, 0.0, 0.9), 0.8, sampling),
            case(
                "turned rectangle, corner 0",
                rectangle_a,
                Vec3::Z + 0.6 * rectangle_normal + turn * Vec3::new(0.7, 0.2, 0.0),
                Vec3::Z,
                0.6,
                sampling,
            ),
            case(
                "turned rectangle, corner 2",
                rectangle_b,
                Vec3::Z + 0.25 * rectangle_normal + turn * Vec3::new(-0.1, 0.1, 0.0),
                Vec3::Z,
                0.6,
                sampling,
            ),
        ]);
        // 2 mm below the light, inside its outline: the light fills nearly the hemisphere. By
        // solid angle only: area sampling's density r² / |cos θ_l| peaks at the light's horizon
        // more sharply than the test's quadrature of the pdf resolves.
        if sampling != layout::LIGHT_SAMPLING_AREA {
            cases.push(case("quad nearly touching", quad, Vec3::new(0.2, -0.1, 0.998), z, 0.7, sampling));
        }
    }
    // The parallelogram's map is area sampling's (solid-angle sampling keeps its triangles).
    let centre = 0.5 * (a + c);
    let area = layout::LIGHT_SAMPLING_AREA;
    cases.extend([
        case("parallelogram from corner 0, near", corner_first, Vec3::new(0.1, 0.0, 0.6), centre, 0.9, area),
        case("parallelogram from corner 1, off-centre", corner_second, Vec3::new(2.0, -1.2, -0.2), centre, 0.9, area),
        case("parallelogram from corner 2, far", corner_third, Vec3::new(-0.3, 0.2, -6.0), centre, 0.9, area),
    ]);
    run_all(&cases);
}

/// Round lights sampled by their bounding cones (LIGHT_SAMPLING_CONE): a direction uniform in the
/// cone is a sample where its ray finds the light, so the samples must be uniform over the
/// tessellated sphere's silhouette and the pdf function (the cone's 1/Ω, for a direction traced to
/// the light) must integrate to the fraction of them that hit. A coarse sphere (12 × 6), so that
/// the cone's corners around its silhouette are missed often; seen from near (the cone 39° wide)
/// and far. A cube (round too: A / 4πr² = 0.64) from a point inside its bounding sphere, where
/// the directions are uniform over the whole sphere. And a square light, not round: it keeps area
/// sampling in the same mode.
#[test]
fn cone_light_sampling_is_uniform_over_the_spheres_silhouette() {
    let leak = |s: GpuScene| -> &'static GpuScene { Box::leak(Box::new(s)) };
    let centre = Vec3::new(0.2, -0.1, 2.0);
    let sphere = leak(mesh_light("chi2-cone-sphere", &MeshData::sphere(centre, 0.5, 12, 6)));
    let footprint =
        [Vec3::new(-0.5, -0.5, 1.5), Vec3::new(0.5, -0.5, 1.5), Vec3::new(0.5, -0.5, 2.5), Vec3::new(-0.5, -0.5, 2.5)];
    let cube = leak(mesh_light("chi2-cone-cube", &MeshData::prism(footprint, 1.0)));
    let quad = leak(unit_quad_light("chi2-cone-quad"));
    let case = |name: &str, scene: &'static GpuScene, point: Vec3, center: Vec3, radius: f64| {
        let to_center = (center - point).as_dvec3();
        DirectionCase {
            name: format!("{name}, cone"),
            scene,
            frame: FrameParams {
                light_sampling: layout::LIGHT_SAMPLING_CONE,
                ..frame(1, layout::SELECT_EACH, layout::HEURISTIC_BALANCE)
            },
            params: TestParams {
                routine: routine::SAMPLE_LIGHT,
                seed: 7,
                point: point.to_array(),
                ..Default::default()
            },
            pdf_routine: routine::PDF_LIGHT,
            bins: SphereBins::new(to_center, radius / to_center.length()),
        }
    };
    run_all(&[
        case("sphere near", sphere, centre - Vec3::new(0.0, 0.3, 0.7), centre, 0.5),
        case("sphere far", sphere, centre + Vec3::new(3.0, 1.0, -9.0), centre, 0.5),
        // 0.7 from the cube's centre, in front of its face at 0.5; its bounding sphere's radius is 0.87.
        case("cube from inside its bounding sphere", cube, Vec3::new(0.1, 0.0, 1.3), Vec3::new(0.0, 0.0, 2.0), 0.87),
        case("quad (area sampled)", quad, Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.0, 0.0, 1.0), 0.7),
    ]);
}

#[test]
fn light_selection_matches_its_probabilities() {
    // Six point lights whose powers span three orders of magnitude.
    let mut g = GltfBuilder::new();
    let intensities = [1.0f32, 3.0, 10.0, 30.0, 100.0, 1000.0];
    for (i, &v) in intensities.iter().enumerate() {
        let pos = Vec3::new(i as f32, 1.0, 0.0);
        g.punctual_light(&format!("p{i}"), veach_scenes::gltf_writer::Punctual::Point, Vec3::splat(v), pos, Vec3::ZERO);
    }
    let scene = upload(&load(&g, "chi2-selection"));
    let total: f32 = intensities.iter().sum();
    let n = intensities.len();
    for (selection, probabilities) in [
        (layout::SELECT_UNIFORM, vec![1.0 / n as f64; n]),
        (layout::SELECT_POWER, intensities.iter().map(|&v| (v / total) as f64).collect()),
    ] {
        let params = TestParams { routine: routine::SELECT_LIGHT, count: SAMPLES, seed: 3, ..Default::default() };
        let out = kernel().run(&scene, &frame(n as u32, selection, 0), &params, &[], 1).unwrap();
        let mut observed = vec![0.0; n];
        for [index, pdf, _, _] in out {
            let i = index as usize;
            assert!(
                (pdf as f64 - probabilities[i]).abs() < 1e-6,
                "selection pdf of light {i}: {pdf} vs {}",
                probabilities[i]
            );
            observed[i] += 1.0;
        }
        let expected: Vec<f64> = probabilities.iter().map(|p| p * SAMPLES as f64).collect();
        let (p_value, _) = chi_square(&observed, &expected);
        if p_value < 0.01 / 2.0 {
            write_histograms(&format!("selection {selection}"), &observed, &expected, 1, n);
            panic!("selection {selection}: chi-square p = {p_value:.2e}; observed {observed:?}, expected {expected:?}");
        }
    }
}

/// The light tree's choice at a shading point (SELECT_TREE): 41 lights of every kind (quads in
/// several orientations, one two-sided, one sealed in a closed box, points, spots, a directional
/// light and one without power) seen from four points and normals, one of them inside the box.
/// At each, the frequencies must fit the probabilities the walk reports (chi-square, as above);
/// the walk's probability must equal the one retraced down the light's path for MIS weights (the
/// same float operations: 1e-6 relative) and the host's copy of the tree (`LightTree::pmf`, 1e-4
/// relative: f32 rounding along ~6 levels); the host's probabilities of all lights sum to 1; the
/// light without power is never chosen, nor the sealed light outside its box (its lit box).
#[test]
fn the_light_tree_chooses_lights_with_the_probabilities_it_reports() {
    let mut rng = veach_scenes::SplitMix64(5);
    let mut r = move || rng.next_f32();
    let mut g = GltfBuilder::new();
    let mut n_lights = 0;
    for i in 0..24 {
        let c = Vec3::new(r() * 4.0 - 2.0, r() * 2.0 + 0.5, r() * 4.0 - 2.0);
        let normal = Vec3::new(r() - 0.5, -1.0 + r(), r() - 0.5).normalize();
        let t = normal.any_orthonormal_vector() * (0.05 + r() * 0.3);
        let b = normal.cross(t);
        let quad = MeshData::quad(c - t - b, c + t - b, c + t + b, c - t + b, normal);
        let mut desc = MaterialDesc::emitter(&format!("quad {i}"), Vec3::splat(10f32.powf(r() * 3.0)));
        desc.double_sided = i == 3;
        let m = g.material(&desc);
        g.add_mesh(&format!("quad {i}"), &quad, m, glam::Mat4::IDENTITY);
        n_lights += 1;
    }
    use veach_scenes::gltf_writer::Punctual;
    for i in 0..14 {
        let p = Vec3::new(r() * 4.0 - 2.0, r() * 2.0 + 0.5, r() * 4.0 - 2.0);
        let kind = if i % 2 == 0 { Punctual::Point } else { Punctual::Spot { inner: 0.3, outer: 0.6 } };
        let power = if i == 5 { 0.0 } else { 10f32.powf(r() * 3.0) };
        g.punctual_light(&format!("delta {i}"), kind, Vec3::splat(power), p, p + Vec3::new(r() - 0.5, -1.0, r() - 0.5));
        n_lights += 1;
    }
    g.punctual_light("sun", Punctual::Directional, Vec3::splat(2.0), Vec3::ZERO, Vec3::new(0.1, -1.0, 0.2));
    n_lights += 1;
    let walls = g.material(&MaterialDesc::lambert("walls", Vec3::splat(0.5)));
    let corners =
        [Vec3::new(2.5, 0.0, 2.5), Vec3::new(3.0, 0.0, 2.5), Vec3::new(3.0, 0.0, 3.0), Vec3::new(2.5, 0.0, 3.0)];
    g.add_mesh("closed box", &MeshData::prism(corners, 0.5), walls, glam::Mat4::IDENTITY);
    let sealed = g.material(&MaterialDesc::emitter("sealed", Vec3::splat(1000.0)));
    let c = Vec3::new(2.75, 0.3, 2.75);
    let (t, b) = (Vec3::X * 0.05, Vec3::Z * 0.05);
    g.add_mesh(
        "sealed",
        &MeshData::quad(c - t - b, c + t - b, c + t + b, c - t + b, -Vec3::Y),
        sealed,
        glam::Mat4::IDENTITY,
    );
    n_lights += 1;
    let host_scene = load(&g, "chi2-light-tree");
    let scene = upload(&host_scene);
    assert!(scene.light_tree_lit_boxes(), "the sealed light has no lit box");
    let sealed = host_scene.lights.iter().position(|l| l.name.starts_with("sealed")).unwrap();
    let tree = veach::gpu::scene_buffers::scene_light_tree(
        &host_scene,
        &veach::gpu::scene_buffers::selection_powers(&host_scene),
        &veach::bvh::build_bvh(&host_scene.triangles),
    );
    let directional: Vec<bool> =
        host_scene.lights.iter().map(|l| matches!(l.kind, veach::scene::LightKind::Directional { .. })).collect();
    let powerless = host_scene
        .lights
        .iter()
        .position(|l| matches!(l.kind, veach::scene::LightKind::Spot { intensity, .. } if intensity == Vec3::ZERO));
    let views = [
        (Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
        (Vec3::new(1.5, 0.2, -1.0), Vec3::new(-1.0, 1.0, 0.3).normalize()),
        (Vec3::new(-1.0, 1.5, 1.0), Vec3::new(0.2, -1.0, 0.1).normalize()),
        (Vec3::new(2.7, 0.0, 2.8), Vec3::Y),
    ];
    let in_box = |p: Vec3| p.cmpge(Vec3::new(2.5, 0.0, 2.5)).all() && p.cmple(Vec3::new(3.0, 0.5, 3.0)).all();
    for (k, (point, normal)) in views.into_iter().enumerate() {
        let host: Vec<f64> = (0..n_lights).map(|i| tree.pmf(i as u32, directional[i], point, normal) as f64).collect();
        let sum: f64 = host.iter().sum();
        assert!((sum - 1.0).abs() < 1e-4, "view {k}: the host's probabilities sum to {sum}");
        assert_eq!(host[sealed] > 0.0, in_box(point), "view {k}: the sealed light's probability {}", host[sealed]);
        let params = TestParams {
            routine: routine::SELECT_LIGHT,
            count: SAMPLES,
            seed: 3 + k as u32,
            point: point.to_array(),
            wo: normal.to_array(),
            ..Default::default()
        };
        let (light_tree_slots, directional_lights) = scene.light_tree_counts();
        let frame = FrameParams {
            light_tree_slots,
            directional_lights,
            light_tree_lit_boxes: scene.light_tree_lit_boxes() as u32,
            ..frame(n_lights as u32, layout::SELECT_TREE, 0)
        };
        let out = kernel().run(&scene, &frame, &params, &[], 1).unwrap();
        let mut observed = vec![0.0; n_lights];
        for [index, retraced, walked, _] in out {
            let i = index as usize;
            assert!(Some(i) != powerless, "view {k}: the light without power was chosen");
            assert!((retraced - walked).abs() <= 1e-6 * walked, "view {k}, light {i}: walk {walked}, path {retraced}");
            assert!(
                (walked as f64 - host[i]).abs() <= 1e-4 * host[i],
                "view {k}, light {i}: GPU {walked}, host {}",
                host[i]
            );
            observed[i] += 1.0;
        }
        let expected: Vec<f64> = host.iter().map(|p| p * SAMPLES as f64).collect();
        let (p_value, _) = chi_square(&observed, &expected);
        if p_value < 0.01 / views.len() as f64 {
            write_histograms(&format!("light tree view {k}"), &observed, &expected, 1, n_lights);
            panic!("view {k}: chi-square p = {p_value:.2e}; observed {observed:?}, expected {expected:?}");
        }
    }
}

/// The glTF 2.0 Appendix B BRDF (with KHR_materials_specular's weighting) in f64 on the host:
/// an independent reference for the furnace integrals below, written from the specification.
fn reference_brdf(base: f64, metallic: f64, roughness: f64, specular: f64, wo: DVec3, wi: DVec3) -> f64 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let a = (roughness * roughness).max(1e-4);
    let a2 = a * a;
    let h = (wo + wi).normalize();
    let d = a2 / (PI * (h.z * h.z * (a2 - 1.0) + 1.0).powi(2));
    let v = 0.5 / (wi.z * (wo.z * wo.z * (1.0 - a2) + a2).sqrt() + wo.z * (wi.z * wi.z * (1.0 - a2) + a2).sqrt());
    let vh = wo.dot(h).abs();
    let schlick = |f0: f64| f0 + (1.0 - f0) * (1.0 - vh).powi(5);
    let fr = schlick(0.04);
    let dielectric = (1.0 - specular * fr) * base / PI + specular * fr * d * v;
    let metal = schlick(base) * d * v;
    (1.0 - metallic) * dielectric + metallic * metal
}

/// Directional albedo ∫ f cos dω of the reference BRDF, by the midpoint rule on the log-polar
/// grid around the mirror direction (which resolves narrow lobes; f cos is continuous there).
fn reference_albedo(base: f64, metallic: f64, roughness: f64, specular: f64, wo: DVec3) -> f64 {
    let alpha = (roughness * roughness).max(1e-4);
    let grid = SphereBins::new(DVec3::new(-wo.x, -wo.y, wo.z), 2.0 * alpha);
    let (ns, np) = (600, 600);
    let (ds, dphi) = (1.0 / ns as f64, 2.0 * PI / np as f64);
    let mut sum = 0.0;
    for i in 0..ns {
        for j in 0..np {
            let (wi, jac) = grid.direction((i as f64 + 0.5) * ds, (j as f64 + 0.5) * dphi);
            sum += reference_brdf(base, metallic, roughness, specular, wo, wi) * wi.z.max(0.0) * jac * ds * dphi;
        }
    }
    sum
}

/// White furnace: the albedo that BRDF sampling on the GPU estimates (mean of f cos / pdf under
/// unit illumination) equals the albedo of the specification's BRDF, within 5 standard errors
/// plus 1e-3 for the reference quadrature. The Lambertian lobe reflects exactly 1 per sample,
/// conductors at most 1. The dielectric's fresnel_mix weights the diffuse lobe by 1 − F(V·H),
/// which is not energy conserving at grazing view: the specification's BRDF itself reflects
/// more than 1 there (1.149 at 75°, 1.34 at 88° for roughness 0.3); veach follows the
/// specification, and this test pins that value rather than hiding it.
#[test]
fn white_furnace_matches_the_specification_albedo() {
    let mut report = Vec::new();
    for (metallic, specular, roughness) in [
        (0.0, 0.0, 1.0),
        (0.0, 1.0, 0.3),
        (0.0, 1.0, 1.0),
        (1.0, 1.0, 0.05),
        (1.0, 1.0, 0.5),
        (1.0, 1.0, 1.0),
        (0.5, 1.0, 0.2),
    ] {
        for theta in [0.0, 40.0, 75.0, 88.0] {
            let m = layout::Material { specular, ..material(Vec3::ONE, metallic, roughness) };
            let wo = wo_at(theta);
            let params = TestParams {
                routine: routine::SAMPLE_BSDF,
                count: SAMPLES,
                seed: 11,
                wo: wo.to_array(),
                material: m,
                ..Default::default()
            };
            let out = kernel().run(empty_scene(), &frame(0, 0, 0), &params, &[], 2).unwrap();
            let weights: Vec<f64> = out.chunks(2).map(|p| p[1][1] as f64).collect();
            assert!(weights.iter().all(|w| w.is_finite() && *w >= 0.0), "negative or non-finite weight");
            let n = weights.len() as f64;
            let mean = weights.iter().sum::<f64>() / n;
            let var = weights.iter().map(|w| (w - mean) * (w - mean)).sum::<f64>() / (n - 1.0);
            let se = (var / n).sqrt();
            let case = format!("metallic {metallic} specular {specular} roughness {roughness} θo {theta}");
            let reference =
                reference_albedo(1.0, metallic as f64, roughness as f64, specular as f64, wo.as_dvec3().normalize());
            report.push(format!("{case}: GPU {mean:.4} ± {se:.1e}, specification {reference:.4}"));
            if specular == 0.0 && metallic == 0.0 {
                // Lambert: f cos / pdf = (1/π) cos / (cos/π) = 1 for every sample, up to rounding.
                assert!(weights.iter().all(|w| (w - 1.0).abs() < 1e-4), "{case}: Lambert weights differ from 1");
            }
            if metallic == 1.0 {
                assert!(mean <= 1.0 + 5.0 * se, "{case}: a conductor reflects {mean:.5} ± {se:.1e} > 1");
            }
            assert!(
                (mean - reference).abs() <= 5.0 * se + 1e-3,
                "{case}: albedo {mean:.5} ± {se:.1e} but the specification's BRDF gives {reference:.5}"
            );
        }
    }
    eprintln!("{}", report.join("\n"));
}

#[test]
fn brdf_values_are_finite_and_non_negative_everywhere() {
    // wo and wi on a grid over the sphere (both hemispheres), every kind of material.
    let mut dirs = Vec::new();
    for i in 0..24 {
        for j in 0..24 {
            let ct = -1.0 + 2.0 * (i as f32 + 0.5) / 24.0;
            let st = (1.0 - ct * ct).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * j as f32 / 24.0;
            dirs.push(Vec3::new(st * phi.cos(), st * phi.sin(), ct));
        }
    }
    dirs.extend([Vec3::Z, Vec3::X, Vec3::new(1.0, 0.0, 1e-7).normalize()]);
    let mut input = Vec::new();
    for a in &dirs {
        for b in &dirs {
            input.push([a.x, a.y, a.z, 0.0]);
            input.push([b.x, b.y, b.z, 0.0]);
        }
    }
    for (metallic, roughness) in [(0.0, 0.0), (0.0, 0.01), (0.0, 1.0), (1.0, 0.0), (1.0, 0.01), (1.0, 0.5), (0.5, 0.3)]
    {
        let params = TestParams {
            routine: routine::EVAL_BSDF,
            count: (input.len() / 2) as u32,
            material: material(Vec3::new(0.9, 0.6, 0.2), metallic, roughness),
            ..Default::default()
        };
        let out = kernel().run(empty_scene(), &frame(0, 0, 0), &params, &input, 1).unwrap();
        for (k, v) in out.iter().enumerate() {
            assert!(
                v.iter().all(|x| x.is_finite() && *x >= 0.0),
                "metallic {metallic} roughness {roughness}: f, pdf = {v:?} at pair {k}"
            );
        }
    }
}

/// Balance and power heuristics with the sample counts (Veach & Guibas 1995): the weights of the
/// two strategies for one direction sum to one and match the formulas.
#[test]
fn mis_weights_sum_to_one_and_match_the_heuristics() {
    let mut input = Vec::new();
    for nf in [1.0f32, 4.0, 32.0] {
        for ng in [0.0f32, 1.0, 7.0] {
            for pf in [1e-30f32, 1e-3, 0.5, 3.0, 1e6, 1e30] {
                for pg in [0.0f32, 1e-3, 0.5, 3.0, 1e6, 1e30] {
                    input.push([nf, pf, ng, pg]);
                }
            }
        }
    }
    for heuristic in [layout::HEURISTIC_BALANCE, layout::HEURISTIC_POWER] {
        let params = TestParams { routine: routine::MIS_WEIGHTS, count: input.len() as u32, ..Default::default() };
        let out = kernel().run(empty_scene(), &frame(0, 0, heuristic), &params, &input, 1).unwrap();
        for ([nf, pf, ng, pg], [wf, wg, _, _]) in input.iter().zip(&out) {
            let (f, g) = ((nf * pf) as f64, (ng * pg) as f64);
            let expected = if heuristic == layout::HEURISTIC_BALANCE { f / (f + g) } else { f * f / (f * f + g * g) };
            let expected = if expected.is_finite() {
                expected
            } else {
                1.0 / (1.0 + (g / f).powi(if heuristic == 0 { 1 } else { 2 }))
            };
            assert!(
                (*wf as f64 - expected).abs() < 1e-5,
                "h{heuristic} n_f {nf} p_f {pf} n_g {ng} p_g {pg}: w_f {wf} vs {expected}"
            );
            assert!((wf + wg - 1.0).abs() < 1e-5, "h{heuristic} weights sum to {} for {nf} {pf} {ng} {pg}", wf + wg);
        }
    }
}

/// Shading normals are stored octahedral-encoded in two snorm16 (`layout::encode_normal` on the
/// host, `decode_normal` in the kernel): every direction, including the axes, the equator and the
/// folded lower hemisphere, comes back within 1e-4 rad. Bound: rounding moves each octahedral
/// coordinate by at most 1/65534; the unnormalised decoded point then moves by at most √2 times
/// that (the fold is 1-Lipschitz per axis) and lies at distance >= 1/√3 from the origin, so the
/// direction turns by at most √6/65534 ≈ 3.7e-5 rad; 1e-4 leaves room for f32 rounding.
#[test]
fn encoded_normals_decode_within_1e4_radians() {
    let mut normals: Vec<[f32; 3]> = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.6, 0.8, 0.0],
        [-0.6, 0.0, -0.8],
        [1e-7, -1e-7, -1.0],
    ];
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 40) as f32 / (1u64 << 24) as f32
    };
    while normals.len() < 4096 {
        // Uniform on the sphere (Archimedes): z uniform in [-1, 1], azimuth uniform.
        let (z, phi) = (2.0 * next() - 1.0, 2.0 * std::f32::consts::PI * next());
        let r = (1.0 - z * z).max(0.0).sqrt();
        normals.push([r * phi.cos(), r * phi.sin(), z]);
    }
    let input: Vec<[f32; 4]> = normals
        .iter()
        .map(|&n| {
            let bits = layout::encode_normal(n);
            [(bits & 0xffff) as f32, (bits >> 16) as f32, 0.0, 0.0]
        })
        .collect();
    let params = TestParams { routine: routine::DECODE_NORMAL, count: input.len() as u32, ..Default::default() };
    let out = kernel().run(empty_scene(), &frame(0, 0, 0), &params, &input, 1).unwrap();
    for (n, d) in normals.iter().zip(&out) {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() as f64;
        let dot = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) as f64 / len;
        let cross_len = {
            let c = [n[1] * d[2] - n[2] * d[1], n[2] * d[0] - n[0] * d[2], n[0] * d[1] - n[1] * d[0]];
            ((c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) as f64).sqrt() / len
        };
        let angle = cross_len.atan2(dot);
        assert!(angle < 1e-4, "normal {n:?} decoded as {d:?}: {angle:e} rad off");
    }
}

/// The sampler's 2D points (`shaders/sampler.wgsl`, `sample_2d`) for the given (pixel, camera
/// sample index, request) triples.
fn stream_points(frame: &FrameParams, seed: u32, queries: &[(u32, u32, u32)]) -> Vec<[f64; 2]> {
    let input: Vec<[f32; 4]> = queries.iter().map(|&(p, i, d)| [p as f32, i as f32, d as f32, 0.0]).collect();
    let params = TestParams { routine: routine::SAMPLE_STREAM, count: input.len() as u32, seed, ..Default::default() };
    let out = kernel().run(empty_scene(), frame, &params, &input, 1).unwrap();
    out.iter().map(|o| [o[0] as f64, o[1] as f64]).collect()
}

/// Owen-scrambled Sobol points keep the (0,2)-sequence property: every aligned block of 2^m
/// consecutive camera samples of a pixel puts exactly one point in each elementary interval
/// [i/2^a, (i+1)/2^a) × [j/2^b, (j+1)/2^b) with a + b = m (Niederreiter 1992, def. 4.1; kept by
/// nested scrambling, Owen 1995, and by Burley's index shuffle, which maps aligned blocks onto
/// aligned blocks). A wrong direction number, a scramble that is not nested, or a shuffle that
/// breaks blocks puts two points in some interval. Exact, no statistics: every m ≤ 10, every
/// block, for several pixels, requests and seeds.
#[test]
fn sobol_points_are_nets_in_every_aligned_block() {
    const M: u32 = 10;
    let n = 1u32 << M;
    for (pixel, request, seed) in [(0, 0, 0), (1, 1, 7), (65535, 2, 3), (12345, 9, 1_000_003)] {
        let queries: Vec<(u32, u32, u32)> = (0..n).map(|i| (pixel, i, request)).collect();
        let points = stream_points(&FrameParams::default(), seed, &queries);
        for m in 0..=M {
            for block in points.chunks(1 << m) {
                for a in 0..=m {
                    let b = m - a;
                    let mut seen = vec![false; 1 << m];
                    for p in block {
                        assert!(
                            (0.0..1.0).contains(&p[0]) && (0.0..1.0).contains(&p[1]),
                            "point {p:?} outside [0, 1)²"
                        );
                        let i = (p[0] * (1u64 << a) as f64) as usize;
                        let j = (p[1] * (1u64 << b) as f64) as usize;
                        let cell = (i << b) | j;
                        assert!(
                            !seen[cell],
                            "pixel {pixel}, request {request}, seed {seed}: two of a block of 2^{m} samples in the \
                             elementary interval ({i}/2^{a}, {j}/2^{b})"
                        );
                        seen[cell] = true;
                    }
                }
            }
        }
    }
}

/// What the nets above cannot show: that different requests of a camera sample, and the same
/// request in different pixels, are independent. Chi-square of 16×16 histograms against
/// uniform: (x, y) of one request; the x of request 0 against the x of request 1 (the same index
/// with only the values scrambled would put those on a scrambled diagonal: half the cells empty);
/// and sample 0 of 4096 pixels. Stratified marginals make the counts *less* variable than
/// multinomial, so only a too-large chi-square fails, at significance 1e-3 over the cases
/// (Bonferroni). The independent sampler is held to the same test.
#[test]
fn sampler_requests_and_pixels_are_independent() {
    const N: u32 = 4096;
    const BINS: usize = 16;
    let mut failures = Vec::new();
    let samplers = [("sobol", layout::SAMPLER_SOBOL), ("independent", layout::SAMPLER_INDEPENDENT)];
    let cases = 3 * samplers.len();
    for (name, sampler) in samplers {
        let frame = FrameParams { sampler, ..Default::default() };
        let within: Vec<(u32, u32, u32)> = (0..N).flat_map(|i| [(77, i, 0), (77, i, 1)]).collect();
        let w = stream_points(&frame, 5, &within);
        let across: Vec<(u32, u32, u32)> = (0..N).map(|p| (p, 0, 0)).collect();
        let a = stream_points(&frame, 5, &across);
        let pairs: [(&str, Vec<[f64; 2]>); 3] = [
            ("one request's (x, y)", w.chunks(2).map(|c| c[0]).collect()),
            ("x of requests 0 and 1", w.chunks(2).map(|c| [c[0][0], c[1][0]]).collect()),
            ("sample 0 across pixels", a),
        ];
        for (what, points) in pairs {
            let mut observed = vec![0.0; BINS * BINS];
            for p in &points {
                let i = ((p[0] * BINS as f64) as usize).min(BINS - 1);
                let j = ((p[1] * BINS as f64) as usize).min(BINS - 1);
                observed[i * BINS + j] += 1.0;
            }
            let expected = vec![N as f64 / (BINS * BINS) as f64; BINS * BINS];
            let (p_value, _) = chi_square(&observed, &expected);
            if p_value < 1e-3 / cases as f64 {
                write_histograms(&format!("sampler {name} {what}"), &observed, &expected, BINS, BINS);
                failures.push(format!("{name}: {what}: chi-square p = {p_value:.2e}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

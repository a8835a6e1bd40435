//! Renders compared with closed-form answers: a Lambertian plane under a rectangular area light
//! (irradiance from the point-to-rectangle form factor), a point light, a spot light and a
//! directional light. Every strategy's image must match within its own confidence interval.
//! Those intervals take a pixel's sample variance / n as the variance of its mean, which holds for
//! independent samples: the tests render with `Sampler::Independent`. The Sobol sampler's
//! renders are checked against the same closed form with the error estimated across independent
//! scrambles (seeds), as randomised quasi-Monte Carlo is.

mod common;

use common::*;
use glam::Vec3;
use std::f64::consts::PI;
use veach::scene::Camera;
use veach::{Heuristic, LightSelection, RenderSettings, Sampler, Strategy};
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData, Punctual};

const ALBEDO: f64 = 0.5;
const SIZE: u32 = 16;
const BLOCK: u32 = 4;

/// Form factor from a point to a parallel rectangle [0,a]×[0,b] at height h, the point below
/// one corner (Howell, "A Catalog of Radiation Heat Transfer Configuration Factors", C-11).
fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// Form factor from a point (px, pz) on the plane y = 0 to the rectangle [x0,x1]×[z0,z1] at
/// height h facing down, by inclusion-exclusion over the four corner rectangles.
fn rect_form_factor(px: f64, pz: f64, x0: f64, x1: f64, z0: f64, z1: f64, h: f64) -> f64 {
    let f = |dx: f64, dz: f64| dx.signum() * dz.signum() * corner_form_factor(dx.abs(), dz.abs(), h);
    f(x1 - px, z1 - pz) - f(x0 - px, z1 - pz) - f(x1 - px, z0 - pz) + f(x0 - px, z0 - pz)
}

fn plane_camera() -> Camera {
    Camera::look_at("down", Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, Vec3::Z, 60f32.to_radians())
}

/// Average of `value(camera ray direction)` over each pixel (8×8 sub-pixel grid, matching the
/// renderer's box filter), following the camera model of `shaders/camera.wgsl`.
fn pixel_average(camera: &Camera, value: impl Fn(Vec3) -> f64) -> Vec<f64> {
    let g = camera.to_gpu(SIZE, SIZE);
    let (f, r, u) = (Vec3::from(g.forward), Vec3::from(g.right), Vec3::from(g.up));
    let mut out = Vec::new();
    for py in 0..SIZE {
        for px in 0..SIZE {
            let mut sum = 0.0;
            for j in 0..8 {
                for i in 0..8 {
                    let sx = 2.0 * (px as f32 + (i as f32 + 0.5) / 8.0) / SIZE as f32 - 1.0;
                    let sy = 1.0 - 2.0 * (py as f32 + (j as f32 + 0.5) / 8.0) / SIZE as f32;
                    sum += value((f + sx * r + sy * u).normalize());
                }
            }
            out.push(sum / 64.0);
        }
    }
    out
}

/// Average of `radiance(point on the plane y = 0)` over each pixel.
fn expected_image(camera: &Camera, radiance: impl Fn(f64, f64) -> f64) -> Vec<f64> {
    let o = camera.position;
    pixel_average(camera, |d| {
        let p = o + (-o.y / d.y) * d;
        radiance(p.x as f64, p.z as f64)
    })
}

fn plane(g: &mut GltfBuilder) {
    let m = g.material(&MaterialDesc::lambert("plane", Vec3::splat(ALBEDO as f32)));
    let s = 20.0;
    let quad =
        MeshData::quad(Vec3::new(-s, 0., -s), Vec3::new(s, 0., -s), Vec3::new(s, 0., s), Vec3::new(-s, 0., s), Vec3::Y);
    g.add_mesh("plane", &quad, m, glam::Mat4::IDENTITY);
}

struct Case {
    name: String,
    settings: RenderSettings,
    expected: Vec<f64>,
}

/// Checks every BLOCK×BLOCK region of every case against its expected mean, with a z bound
/// from the Bonferroni correction over all comparisons at family-wise significance 1e-4, plus
/// 1e-5 relative for float rounding in the kernel's sums.
fn check_cases(test: &str, scene: &veach::Scene, cases: &[Case]) {
    let gpu_scene = upload(scene);
    let camera = plane_camera();
    let regions = (SIZE / BLOCK) * (SIZE / BLOCK);
    let z = bonferroni_z(1e-4, cases.len() * regions as usize);
    let mut failures = Vec::new();
    for case in cases {
        let out = render(&gpu_scene, &case.settings, &camera);
        assert_eq!(out.nonfinite_samples, 0, "{}: non-finite samples", case.name);
        for by in 0..SIZE / BLOCK {
            for bx in 0..SIZE / BLOCK {
                let est = region(&out, bx * BLOCK, by * BLOCK, (bx + 1) * BLOCK, (by + 1) * BLOCK);
                let mut expected = 0.0;
                for y in by * BLOCK..(by + 1) * BLOCK {
                    for x in bx * BLOCK..(bx + 1) * BLOCK {
                        expected += case.expected[(y * SIZE + x) as usize];
                    }
                }
                expected /= (BLOCK * BLOCK) as f64;
                let sigma = est.var[0].sqrt();
                let tol = z * sigma + 1e-5 * expected;
                if (est.mean[0] - expected).abs() > tol {
                    failures.push(format!(
                        "{}: region ({bx},{by}) mean {:.6} expected {:.6} (σ {:.2e}, |Δ|/σ {:.1}, z {:.2})",
                        case.name,
                        est.mean[0],
                        expected,
                        sigma,
                        (est.mean[0] - expected).abs() / sigma.max(1e-30),
                        z
                    ));
                }
            }
        }
        if failures.iter().any(|f| f.starts_with(&case.name)) {
            let exp: Vec<[f32; 3]> = case.expected.iter().map(|&v| [v as f32; 3]).collect();
            let dir = write_failure_images(
                test,
                &[
                    (&format!("{}-rendered", case.name), SIZE, SIZE, out.mean()),
                    (&format!("{}-expected", case.name), SIZE, SIZE, exp),
                ],
            );
            eprintln!("images written to {}", dir.display());
        }
    }
    assert!(failures.is_empty(), "{} region(s) off:\n{}", failures.len(), failures.join("\n"));
}

fn settings(
    strategy: Strategy,
    spp: u32,
    light: u32,
    brdf: u32,
    selection: LightSelection,
    heuristic: Heuristic,
) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        strategy,
        light_samples: light,
        brdf_samples: brdf,
        light_selection: selection,
        heuristic,
        seed: 7,
        sampler: Sampler::Independent,
        ..Default::default()
    }
}

/// A Lambertian plane under a rectangular area light and a point light, with the closed-form
/// image of the area light alone and of both.
fn area_and_point_scene() -> (veach::Scene, Vec<f64>, Vec<f64>) {
    let (x0, x1, z0, z1, h) = (-0.5, 0.7, -0.6, 0.4, 1.0);
    let le = 4.0;
    let point = Vec3::new(0.1, 0.8, -0.05);
    let intensity = 0.6;
    let mut g = GltfBuilder::new();
    plane(&mut g);
    let light = g.material(&MaterialDesc::emitter("light", Vec3::splat(le as f32)));
    let quad = MeshData::quad(
        Vec3::new(x0 as f32, h as f32, z0 as f32),
        Vec3::new(x1 as f32, h as f32, z0 as f32),
        Vec3::new(x1 as f32, h as f32, z1 as f32),
        Vec3::new(x0 as f32, h as f32, z1 as f32),
        -Vec3::Y,
    );
    g.add_mesh("area light", &quad, light, glam::Mat4::IDENTITY);
    g.punctual_light("point", Punctual::Point, Vec3::splat(intensity), point, Vec3::ZERO);
    let scene = load(&g, "analytic-area-point");
    let camera = plane_camera();

    // Lambert: L_o = ρ/π E; area light E = π L_e F; point light E = I cos θ / r².
    let area = expected_image(&camera, |x, z| ALBEDO * le * rect_form_factor(x, z, x0, x1, z0, z1, h));
    let point_part = expected_image(&camera, |x, z| {
        let d = Vec3::new(point.x - x as f32, point.y, point.z - z as f32).as_dvec3();
        let r2 = d.length_squared();
        ALBEDO / PI * intensity as f64 * (d.y / r2.sqrt()) / r2
    });
    let both: Vec<f64> = area.iter().zip(&point_part).map(|(a, b)| a + b).collect();
    (scene, area, both)
}

#[test]
fn area_and_point_light_on_a_lambertian_plane_match_the_closed_form() {
    let (scene, area, both) = area_and_point_scene();
    use LightSelection::{Each, Uniform};
    let (balance, power) = (Heuristic::Balance, Heuristic::Power);
    let by_power = LightSelection::Power;
    let cases = [
        // Uniform and BRDF sampling cannot reach the point light: they must see the area light alone.
        ("uniform", settings(Strategy::Uniform, 32, 0, 256, Each, balance), &area),
        ("brdf", settings(Strategy::Brdf, 32, 0, 64, Each, balance), &area),
        ("light-each", settings(Strategy::Light, 32, 16, 0, Each, balance), &both),
        ("light-uniform", settings(Strategy::Light, 32, 16, 0, Uniform, balance), &both),
        ("light-power", settings(Strategy::Light, 32, 16, 0, by_power, balance), &both),
        ("mis-balance", settings(Strategy::Mis, 32, 8, 8, Each, balance), &both),
        ("mis-power", settings(Strategy::Mis, 32, 8, 8, by_power, power), &both),
        ("mis-brdf-only", settings(Strategy::Mis, 32, 0, 16, Each, balance), &area),
        ("mis-lobes", settings(Strategy::MisLobes, 32, 8, 8, Each, balance), &both),
        ("mis-lobes-power", settings(Strategy::MisLobes, 32, 8, 8, by_power, balance), &both),
        // Lights chosen per point, by the BSDF and power (two lights here: the table is used).
        ("light-bsdf", settings(Strategy::Light, 32, 16, 0, LightSelection::Bsdf, balance), &both),
        ("mis-bsdf", settings(Strategy::Mis, 32, 8, 8, LightSelection::Bsdf, power), &both),
        ("mis-lobes-bsdf", settings(Strategy::MisLobes, 32, 8, 8, LightSelection::Bsdf, balance), &both),
        // Lights chosen per point by the light tree (two leaves here).
        ("light-tree", settings(Strategy::Light, 32, 16, 0, LightSelection::Tree, balance), &both),
        ("mis-tree", settings(Strategy::Mis, 32, 8, 8, LightSelection::Tree, power), &both),
    ];
    let cases: Vec<Case> =
        cases.into_iter().map(|(n, s, e)| Case { name: n.into(), settings: s, expected: e.clone() }).collect();
    check_cases("area-and-point", &scene, &cases);
}

/// Many lights over the plane, chosen by the light tree: 48 quads facing down in one plane at
/// height 1 (each in a cell of its own, so that none shades another), their radiances over three
/// decades; 3 point lights below them; and two quads that add nothing (one beside them facing
/// up, one under the plane), which the tree must give no probability without losing the others.
/// The closed form is the sum of each light's. Light sampling and MIS by the tree must match it,
/// as selection by power does; a path probability that differed between the tree's walk and the
/// MIS weight's retracing, or a light the walk could not reach, would shift regions by many σ.
#[test]
fn many_lights_chosen_by_the_tree_match_the_closed_form() {
    let mut rng = veach_scenes::SplitMix64(11);
    let mut r = move || rng.next_f32() as f64;
    let mut g = GltfBuilder::new();
    plane(&mut g);
    let mut quads = Vec::new();
    let h = 1.0;
    for i in 0..49 {
        if i == 24 {
            continue; // the middle cell: the quad facing up
        }
        let (cx, cz) = ((i % 7) as f64 * 0.5 - 1.5, (i / 7) as f64 * 0.5 - 1.5);
        let (w, d) = (0.03 + r() * 0.2, 0.03 + r() * 0.2);
        let le = 10f64.powf(r() * 3.0 - 1.0);
        quads.push((cx - w, cx + w, cz - d, cz + d, h, le));
        let m = g.material(&MaterialDesc::emitter(&format!("light {i}"), Vec3::splat(le as f32)));
        let (x0, x1, z0, z1, h) = ((cx - w) as f32, (cx + w) as f32, (cz - d) as f32, (cz + d) as f32, h as f32);
        let quad = MeshData::quad(
            Vec3::new(x0, h, z0),
            Vec3::new(x1, h, z0),
            Vec3::new(x1, h, z1),
            Vec3::new(x0, h, z1),
            -Vec3::Y,
        );
        g.add_mesh(&format!("light {i}"), &quad, m, glam::Mat4::IDENTITY);
    }
    for (name, y) in [("facing up", 1.0f32), ("under the plane", -0.5)] {
        let m = g.material(&MaterialDesc::emitter(name, Vec3::splat(1000.0)));
        let quad = MeshData::quad(
            Vec3::new(-0.2, y, -0.2),
            Vec3::new(-0.2, y, 0.2),
            Vec3::new(0.2, y, 0.2),
            Vec3::new(0.2, y, -0.2),
            Vec3::Y,
        );
        g.add_mesh(name, &quad, m, glam::Mat4::IDENTITY);
    }
    let points =
        [(Vec3::new(0.4, 0.9, -0.2), 0.3f32), (Vec3::new(-0.6, 0.7, 0.5), 2.0), (Vec3::new(0.1, 0.95, 0.9), 5.0)];
    for (i, (p, intensity)) in points.iter().enumerate() {
        g.punctual_light(&format!("point {i}"), Punctual::Point, Vec3::splat(*intensity), *p, Vec3::ZERO);
    }
    let scene = load(&g, "analytic-many-lights");
    let camera = plane_camera();
    let expected = expected_image(&camera, |x, z| {
        let quads: f64 =
            quads.iter().map(|&(x0, x1, z0, z1, h, le)| le * rect_form_factor(x, z, x0, x1, z0, z1, h)).sum();
        let points: f64 = points
            .iter()
            .map(|(p, i)| {
                let d = Vec3::new(p.x - x as f32, p.y, p.z - z as f32).as_dvec3();
                let r2 = d.length_squared();
                *i as f64 * (d.y / r2.sqrt()) / r2 / PI
            })
            .sum();
        ALBEDO * quads + ALBEDO * points
    });
    use LightSelection::{Power, Tree};
    let (balance, power) = (Heuristic::Balance, Heuristic::Power);
    let cases = [
        ("light-tree", settings(Strategy::Light, 32, 8, 0, Tree, balance)),
        ("mis-tree", settings(Strategy::Mis, 32, 4, 4, Tree, power)),
        ("mis-lobes-tree", settings(Strategy::MisLobes, 32, 4, 4, Tree, balance)),
        ("mis-power", settings(Strategy::Mis, 32, 4, 4, Power, power)),
    ];
    let cases: Vec<Case> =
        cases.into_iter().map(|(n, s)| Case { name: n.into(), settings: s, expected: expected.clone() }).collect();
    check_cases("many-lights", &scene, &cases);
}

/// The unshadowed light as a control variate (shaders/control_variate.wgsl) on a plane that sees
/// the area light unblocked everywhere: every strategy's estimate is A, in closed form, plus a
/// difference that is zero sample by sample, and the point light's deterministic part. So each
/// must match the closed form within its own interval plus the 1e-5 of float rounding. Where every
/// light is sampled at every point (and for uniform and BRDF samples, which reach the area light
/// alone) what is left is the spread of A and of the point light's part over a pixel, so the summed
/// pixel variance must be a small part of the same render's without it: 0.02 is far above the
/// ratios measured (printed) and far below the ratio near 1 or above that a g that failed to cancel
/// f L_e cos would leave. (Where one light is chosen per sample, the choice's own variance stays.)
#[test]
fn the_unshadowed_control_variate_matches_the_closed_form_without_the_samples_variance() {
    let (scene, area, both) = area_and_point_scene();
    use LightSelection::{Bsdf, Each, Power};
    let (balance, power) = (Heuristic::Balance, Heuristic::Power);
    let cv = |mut s: RenderSettings| {
        s.control_variate = true;
        s
    };
    let plain = [
        ("uniform", settings(Strategy::Uniform, 16, 0, 16, Each, balance), &area),
        ("brdf", settings(Strategy::Brdf, 16, 0, 4, Each, balance), &area),
        ("light-each", settings(Strategy::Light, 16, 4, 0, Each, balance), &both),
        ("light-power", settings(Strategy::Light, 16, 4, 0, Power, balance), &both),
        ("mis-balance", settings(Strategy::Mis, 16, 2, 2, Each, balance), &both),
        ("mis-power", settings(Strategy::Mis, 16, 1, 1, Power, power), &both),
        ("mis-bsdf", settings(Strategy::Mis, 16, 1, 1, Bsdf, power), &both),
    ];
    let cases: Vec<Case> = plain
        .iter()
        .map(|(n, s, e)| Case { name: format!("{n}-cv"), settings: cv(s.clone()), expected: (*e).clone() })
        .collect();
    check_cases("control-variate", &scene, &cases);
    let gpu_scene = upload(&scene);
    let camera = plane_camera();
    let summed_variance = |s: &RenderSettings| -> f64 {
        render(&gpu_scene, s, &camera).variance_of_mean().iter().map(|v| v[0] as f64).sum()
    };
    for (name, s, _) in plain.iter().filter(|(_, s, _)| s.light_selection == Each) {
        let ratio = summed_variance(&cv(s.clone())) / summed_variance(s);
        eprintln!("{name}: variance with the control variate / without {ratio:.2e}");
        assert!(ratio < 0.02, "{name}: the control variate left {ratio:.3} of the variance");
    }
}

/// The Sobol sampler (the default) is unbiased and has less error than independent samples.
/// Its per-pixel sample variance does not measure its error, so the error is estimated the way
/// randomised QMC's is: R renders with independent scrambles (seeds), each region's mean over
/// them, and the spread between them (Owen 1997; L'Ecuyer & Lemieux 2002). (mean − expected) /
/// (s / √R) is then Student-t with R − 1 degrees of freedom, bounded at family-wise
/// significance 1e-4 over every region and case (Bonferroni).
/// Then, per case, the variance between replicates of each pixel's mean, summed over the pixels,
/// for Sobol against the same renders with independent samples (pixels are scrambled
/// independently, so this is the regions' ratio too). Each sum has about 256 pixels × 16 degrees
/// of freedom, so a measured ratio is within a few % (1σ) of the true one; the bound 0.8 sits
/// many σ above the ratios measured (0.26 light, 0.43 MIS, 0.58 BRDF: the light's edge is a
/// discontinuity, which stratification helps least) and below the ratio of 1 that points without
/// stratification give.
#[test]
fn sobol_renders_match_the_closed_form_with_less_error_than_independent_samples() {
    const REPLICATES: u32 = 17;
    const SPP: u32 = 8;
    let (scene, area, both) = area_and_point_scene();
    let gpu_scene = upload(&scene);
    let camera = plane_camera();
    use LightSelection::{Each, Power};
    let cases = [
        ("light-power", Strategy::Light, 1, 0, Power, &both),
        ("mis-power", Strategy::Mis, 1, 1, Power, &both),
        ("brdf", Strategy::Brdf, 0, 1, Each, &area),
    ];
    let blocks = SIZE / BLOCK;
    let t_max = student_t_critical(1e-4 / (cases.len() * (blocks * blocks) as usize) as f64, REPLICATES - 1);
    let sample_variance = |v: &[f64]| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64
    };
    let mut failures = Vec::new();
    for (name, strategy, light, brdf, selection, expected) in cases {
        let mut summed_variance = [0.0f64; 2];
        for (k, sampler) in [Sampler::Sobol, Sampler::Independent].into_iter().enumerate() {
            // Region means and pixel means (channel 0) per replicate.
            let mut means = vec![Vec::new(); (blocks * blocks) as usize];
            let mut pixels = vec![Vec::new(); (SIZE * SIZE) as usize];
            let mut last = Vec::new();
            for r in 0..REPLICATES {
                let s = RenderSettings {
                    sampler,
                    seed: 1000 + r,
                    ..settings(strategy, SPP, light, brdf, selection, Heuristic::Power)
                };
                let out = render(&gpu_scene, &s, &camera);
                assert_eq!(out.nonfinite_samples, 0, "{name}: non-finite samples");
                for by in 0..blocks {
                    for bx in 0..blocks {
                        let est = region(&out, bx * BLOCK, by * BLOCK, (bx + 1) * BLOCK, (by + 1) * BLOCK);
                        means[(by * blocks + bx) as usize].push(est.mean[0]);
                    }
                }
                last = out.mean();
                for (p, m) in pixels.iter_mut().zip(&last) {
                    p.push(m[0] as f64);
                }
            }
            summed_variance[k] = pixels.iter().map(|p| sample_variance(p)).sum();
            for (i, m) in means.iter().enumerate() {
                let (bx, by) = (i as u32 % blocks, i as u32 / blocks);
                let n = m.len() as f64;
                let mean = m.iter().sum::<f64>() / n;
                let var = sample_variance(m);
                if sampler != Sampler::Sobol {
                    continue;
                }
                let mut e = 0.0;
                for y in by * BLOCK..(by + 1) * BLOCK {
                    for x in bx * BLOCK..(bx + 1) * BLOCK {
                        e += expected[(y * SIZE + x) as usize];
                    }
                }
                e /= (BLOCK * BLOCK) as f64;
                let t = (mean - e).abs() / (var / n).sqrt().max(1e-30);
                if t > t_max {
                    failures.push(format!(
                        "{name}: region ({bx},{by}) mean {mean:.6} expected {e:.6}, |t| {t:.1} > {t_max:.1}"
                    ));
                    let exp: Vec<[f32; 3]> = expected.iter().map(|&v| [v as f32; 3]).collect();
                    write_failure_images(
                        "sobol-closed-form",
                        &[
                            (&format!("{name}-rendered"), SIZE, SIZE, last.clone()),
                            (&format!("{name}-expected"), SIZE, SIZE, exp),
                        ],
                    );
                }
            }
        }
        let ratio = summed_variance[0] / summed_variance[1];
        eprintln!("{name}: variance of Sobol / independent pixel means = {ratio:.3}");
        if ratio.is_nan() || ratio >= 0.8 {
            failures.push(format!("{name}: Sobol's variance is {ratio:.3}× that of independent samples (bound 0.8)"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn spot_and_directional_lights_match_the_closed_form() {
    let spot_pos = Vec3::new(0.0, 0.6, 0.05);
    let (inner, outer) = (20f32.to_radians(), 40f32.to_radians());
    let intensity = 0.8;
    let mut g = GltfBuilder::new();
    plane(&mut g);
    g.punctual_light("spot", Punctual::Spot { inner, outer }, Vec3::splat(intensity), spot_pos, spot_pos - Vec3::Y);
    let spot_scene = load(&g, "analytic-spot");
    let camera = plane_camera();
    // KHR_lights_punctual's recommended falloff, squared smooth step between the cones.
    let spot = expected_image(&camera, |x, z| {
        let d = (spot_pos.as_dvec3() - glam::DVec3::new(x, 0.0, z)).normalize();
        let r2 = (spot_pos.as_dvec3() - glam::DVec3::new(x, 0.0, z)).length_squared();
        let cd = d.y; // angle to the spot's axis (straight down)
        let scale = 1.0 / (inner.cos() as f64 - outer.cos() as f64).max(0.001);
        let a = (cd * scale - outer.cos() as f64 * scale).clamp(0.0, 1.0);
        ALBEDO / PI * intensity as f64 * a * a * d.y / r2
    });
    let mk = |strategy, light, brdf| settings(strategy, 16, light, brdf, LightSelection::Each, Heuristic::Balance);
    check_cases(
        "spot",
        &spot_scene,
        &[
            Case { name: "spot-light".into(), settings: mk(Strategy::Light, 1, 0), expected: spot.clone() },
            Case { name: "spot-mis".into(), settings: mk(Strategy::Mis, 2, 2), expected: spot.clone() },
            Case { name: "spot-mis-lobes".into(), settings: mk(Strategy::MisLobes, 2, 2), expected: spot },
        ],
    );

    let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let irradiance = 2.0;
    let mut g = GltfBuilder::new();
    plane(&mut g);
    g.punctual_light("sun", Punctual::Directional, Vec3::splat(irradiance), Vec3::ZERO, dir);
    let sun_scene = load(&g, "analytic-directional");
    let sun = expected_image(&camera, |_, _| ALBEDO / PI * irradiance as f64 * (-dir.y) as f64);
    check_cases(
        "directional",
        &sun_scene,
        &[
            Case { name: "sun-light".into(), settings: mk(Strategy::Light, 1, 0), expected: sun.clone() },
            Case { name: "sun-mis".into(), settings: mk(Strategy::Mis, 3, 3), expected: sun.clone() },
            Case { name: "sun-mis-lobes".into(), settings: mk(Strategy::MisLobes, 3, 3), expected: sun },
        ],
    );
}

/// A delta light's contribution must not depend on how many light or BRDF samples are taken
/// (Mitsuba 3 issue #1861: delta emitters that skip the 1/n factor).
#[test]
fn delta_light_contribution_is_independent_of_sample_counts() {
    let mut g = GltfBuilder::new();
    plane(&mut g);
    g.punctual_light("point", Punctual::Point, Vec3::splat(1.0), Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO);
    let scene = upload(&load(&g, "delta-counts"));
    let camera = plane_camera();
    let base =
        render(&scene, &settings(Strategy::Light, 2, 1, 0, LightSelection::Each, Heuristic::Balance), &camera).mean();
    for (strategy, light, brdf, sel) in [
        (Strategy::Light, 7, 0, LightSelection::Each),
        (Strategy::Light, 5, 0, LightSelection::Power),
        (Strategy::Mis, 3, 9, LightSelection::Each),
        (Strategy::Mis, 1, 4, LightSelection::Uniform),
    ] {
        let other = render(&scene, &settings(strategy, 2, light, brdf, sel, Heuristic::Power), &camera).mean();
        for (a, b) in base.iter().zip(&other) {
            // Same camera samples (same seed), so the only difference is rounding in n·x/n.
            assert!(
                (a[0] - b[0]).abs() <= 1e-5 * a[0].abs().max(1e-6),
                "{strategy:?} n={light}+{brdf}: {} vs {}",
                a[0],
                b[0]
            );
        }
    }
}

/// A perfect mirror (roughness 0, a delta BRDF) under a large emitter: BRDF and MIS sampling see
/// F(θ) · L_e (Schlick with f0 = base colour), the delta sample with MIS weight 1; light and
/// uniform sampling cannot reach a delta lobe and see nothing.
#[test]
fn a_perfect_mirror_reflects_fresnel_times_radiance_with_mis_weight_one() {
    let le = 3.0f64;
    let base = 0.5f64;
    let mut g = GltfBuilder::new();
    let mirror = g.material(&MaterialDesc::metal("mirror", Vec3::splat(base as f32), 0.0));
    let light = g.material(&MaterialDesc::emitter("sky", Vec3::splat(le as f32)));
    let s = 50.0;
    let floor =
        MeshData::quad(Vec3::new(-s, 0., -s), Vec3::new(s, 0., -s), Vec3::new(s, 0., s), Vec3::new(-s, 0., s), Vec3::Y);
    let sky = MeshData::quad(
        Vec3::new(-s, 5., -s),
        Vec3::new(s, 5., -s),
        Vec3::new(s, 5., s),
        Vec3::new(-s, 5., s),
        -Vec3::Y,
    );
    g.add_mesh("mirror", &floor, mirror, glam::Mat4::IDENTITY);
    g.add_mesh("sky", &sky, light, glam::Mat4::IDENTITY);
    let scene = upload(&load(&g, "mirror"));
    let camera = Camera::look_at("c", Vec3::new(0.0, 1.0, 2.0), Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 20f32.to_radians());
    // Per pixel: F at the angle of the camera ray to the mirror's normal, averaged over the pixel.
    let expected = pixel_average(&camera, |d| {
        let cos = (-d.y) as f64;
        (base + (1.0 - base) * (1.0 - cos).powi(5)) * le
    });
    let settings = |strategy, light, brdf| RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 16,
        strategy,
        light_samples: light,
        brdf_samples: brdf,
        seed: 3,
        sampler: Sampler::Independent,
        ..Default::default()
    };
    let cases = [
        (Strategy::Brdf, 0, 2, true),
        (Strategy::Mis, 2, 2, true),
        (Strategy::MisLobes, 2, 2, true),
        (Strategy::Light, 4, 0, false),
        (Strategy::Uniform, 0, 16, false),
    ];
    // Only the pixel jitter varies. The error over the standard error estimated from the pixel's
    // 16 samples is Student-t with 15 degrees of freedom: bounded at family-wise significance
    // 1e-4 over every pixel and case (Bonferroni), plus f32 rounding.
    let t_max = student_t_critical(1e-4 / (cases.len() * (SIZE * SIZE) as usize) as f64, 15);
    for (strategy, light, brdf, sees_mirror) in cases {
        let out = render(&scene, &settings(strategy, light, brdf), &camera);
        let var = out.variance_of_mean();
        for (i, m) in out.mean().iter().enumerate() {
            let e = if sees_mirror { expected[i] } else { 0.0 };
            let tol = t_max * (var[i][0] as f64).sqrt() + 1e-5 * e;
            assert!((m[0] as f64 - e).abs() <= tol, "{strategy:?} pixel {i}: {} vs {e}", m[0]);
        }
    }
}

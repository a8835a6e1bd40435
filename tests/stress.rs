//! The stability suite on stiff and extreme scenes (`veach_scenes::stress`): no strategy ever
//! accumulates a NaN or Inf; a scene far from the origin renders like the same scene at the
//! origin; a camera sealed in a box sees no light leak in.

mod common;

use common::*;
use veach::{Heuristic, LightSelection, RenderSettings, Sampler, Strategy};
use veach_scenes::stress::{STRESS_SCENES, stress_scene};

fn stress(name: &str) -> veach::Scene {
    load(&stress_scene(name).expect("a stress scene"), &format!("stress-{name}"))
}

fn settings(strategy: Strategy, selection: LightSelection, spp: u32, seed: u32) -> RenderSettings {
    let (light, brdf) = match strategy {
        Strategy::Uniform => (0, 16),
        Strategy::Brdf => (0, 4),
        Strategy::Light => (4, 0),
        Strategy::Mis | Strategy::MisLobes => (2, 2),
    };
    RenderSettings {
        width: 24,
        height: 24,
        spp,
        strategy,
        light_samples: light,
        brdf_samples: brdf,
        light_selection: selection,
        heuristic: Heuristic::Power,
        seed,
        ..Default::default()
    }
}

const STRATEGIES: [(Strategy, LightSelection); 8] = [
    (Strategy::Uniform, LightSelection::Each),
    (Strategy::Brdf, LightSelection::Each),
    (Strategy::Light, LightSelection::Each),
    (Strategy::Mis, LightSelection::Each),
    (Strategy::Mis, LightSelection::Power),
    (Strategy::Mis, LightSelection::Bsdf),
    (Strategy::MisLobes, LightSelection::Each),
    (Strategy::MisLobes, LightSelection::Power),
];

/// Every strategy on every stress scene: the accumulated sums themselves (not only the image,
/// whose mean maps non-finite values to 0) are finite. A sample that is not finite, or whose
/// square is not, is dropped and counted; only the float-limits scene (radiance 1e38) may
/// produce such samples.
#[test]
fn no_strategy_accumulates_a_non_finite_value_on_any_stress_scene() {
    let mut report = Vec::new();
    for name in STRESS_SCENES {
        let scene = stress(name);
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        for (strategy, selection) in STRATEGIES {
            let out = render(&gpu_scene, &settings(strategy, selection, 4, 1), &camera);
            let finite = out.sum.iter().chain(&out.sum_sq).all(|v| v.iter().all(|x| x.is_finite()));
            assert!(finite, "{name} {strategy:?} {selection:?}: a non-finite value was accumulated");
            let max = out.mean().iter().flat_map(|p| *p).fold(0.0f32, f32::max);
            report.push(format!(
                "{name:18} {:8} {selection:?}: max pixel {max:.3e}, non-finite samples dropped {}",
                strategy.name(),
                out.nonfinite_samples
            ));
            if *name != "float-limits" {
                assert_eq!(out.nonfinite_samples, 0, "{name} {strategy:?} {selection:?}: non-finite samples");
            }
        }
    }
    eprintln!("{}", report.join("\n"));
}

/// The Cornell box moved to 1e5 and scaled by 10 must give the same image as at the origin:
/// per 8×8 region and channel, |Δ| within the Bonferroni z (family-wise 1e-3) times σ from both
/// renders' own variances. Self-intersection acne or light leaks from lost precision would
/// darken or brighten whole regions far beyond that.
#[test]
fn a_scene_far_from_the_origin_renders_like_the_same_scene_at_the_origin() {
    let near = shipped_scene("cornell-box");
    let far = stress("far-cornell-box");
    let s = |seed| RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        strategy: Strategy::Mis,
        light_samples: 2,
        brdf_samples: 2,
        seed,
        // σ from each pixel's sample variance / n: true of independent samples only.
        sampler: Sampler::Independent,
        ..Default::default()
    };
    let a = render(&upload(&near), &s(1), &near.camera(None).unwrap());
    let b = render(&upload(&far), &s(2), &far.camera(None).unwrap());
    let z = bonferroni_z(1e-3, 16 * 3);
    let mut worst = 0.0f64;
    for ry in 0..4 {
        for rx in 0..4 {
            let (x0, y0) = (rx * 8, ry * 8);
            let (ra, rb) = (region(&a, x0, y0, x0 + 8, y0 + 8), region(&b, x0, y0, x0 + 8, y0 + 8));
            for c in 0..3 {
                let sigma = (ra.var[c] + rb.var[c]).sqrt();
                let score = (ra.mean[c] - rb.mean[c]).abs() / sigma.max(1e-12);
                worst = worst.max(score);
                if score > z {
                    write_failure_images("stress-far", &[("origin", 32, 32, a.mean()), ("far", 32, 32, b.mean())]);
                }
                assert!(
                    score <= z,
                    "region ({rx},{ry}) channel {c}: origin {:.5}, far {:.5}, |Δ|/σ {score:.2} > {z:.2}",
                    ra.mean[c],
                    rb.mean[c]
                );
            }
        }
    }
    eprintln!("far Cornell box: worst |Δ|/σ {worst:.2} (bound {z:.2})");
}

/// The camera sealed inside a box with the light outside: every pixel is exactly black for
/// every strategy, so no ray leaks through an edge or corner of the box.
#[test]
fn a_camera_sealed_in_a_box_sees_no_light() {
    let scene = stress("camera-inside");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    for (strategy, selection) in STRATEGIES {
        let out = render(&gpu_scene, &settings(strategy, selection, 8, 3), &camera);
        let lit = out.mean().iter().filter(|p| p.iter().any(|&v| v != 0.0)).count();
        assert_eq!(lit, 0, "{strategy:?} {selection:?}: {lit} pixels see light from outside the box");
    }
}

/// Degenerate input loads cleanly: zero-area and collinear emitters are left out of the lights,
/// the sliver, the back-facing emitter and the sealed light stay in.
#[test]
fn degenerate_emitters_are_kept_or_left_out_as_they_should_be() {
    let scene = stress("degenerate");
    let names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(scene.lights.len(), 4, "{names:?}");
    for kept in ["light", "sliver emitter", "back-facing emitter", "sealed light"] {
        assert!(names.iter().any(|n| n.starts_with(kept)), "{kept} missing from {names:?}");
    }
}

/// Whether the adapter is lavapipe from Mesa 22 or older, whose code generator gives each
/// invocation one budget of 65,535 loop iterations (gallivm's loop limiter).
fn loop_limited() -> bool {
    let info = &renderer().gpu.adapter_info;
    veach::kernel_plan::AutoExecution::for_adapter(info) == veach::kernel_plan::AutoExecution::WavefrontWhereMasked
}

/// The light-touching-the-floor stress scene on the GPU, with its camera.
fn touching_light_on_gpu() -> (veach::GpuScene, veach::scene::Camera) {
    let scene = stress("touching-light");
    let camera = scene.camera(None).unwrap();
    (upload(&scene), camera)
}

fn eight_by_eight() -> RenderSettings {
    RenderSettings { width: 8, height: 8, ..Default::default() }
}

/// Many BRDF samples per camera sample and many camera samples per dispatch: on Mesa 22's
/// lavapipe the megakernel's invocations run out of loop iterations, traversals stop early and
/// the image came out dark by up to a third (a floor point under a wall light: 0.207 against a
/// closed form of 0.3025). Samples cut short are now left out and taken again, so the megakernel
/// renders the wavefront's image (whose invocations take one camera sample each) bit for bit,
/// on every driver; and where the limit exists the test shows the path was taken.
#[test]
fn samples_cut_short_by_a_loop_limit_are_taken_again() {
    let (gpu_scene, camera) = touching_light_on_gpu();
    let s = RenderSettings {
        spp: 16,
        strategy: Strategy::Brdf,
        brdf_samples: 1024,
        light_selection: LightSelection::Each,
        sampler: Sampler::Independent,
        seed: 3,
        // One dispatch of every camera sample, so that one invocation takes all 16.
        dispatch_target: std::time::Duration::from_secs(60),
        execution: veach::Execution::Megakernel,
        ..eight_by_eight()
    };
    let mega = render(&gpu_scene, &s, &camera);
    let wave = render(&gpu_scene, &RenderSettings { execution: veach::Execution::Wavefront, ..s.clone() }, &camera);
    assert_same_image("stress-wavefront", "megakernel and wavefront", &mega.sum, &wave.sum, mega.width);
    assert_eq!(mega.truncated_samples > 0, loop_limited(), "{} samples retaken", mega.truncated_samples);
    assert_eq!(wave.truncated_samples, 0);
}

/// One camera sample that alone needs more loop iterations than the limit allows cannot be taken
/// at all there: the render fails with a message, instead of returning a dark image.
#[test]
fn a_camera_sample_over_the_loop_limit_is_an_error_not_a_dark_image() {
    let (gpu_scene, camera) = touching_light_on_gpu();
    let s = RenderSettings {
        spp: 1,
        strategy: Strategy::Uniform,
        brdf_samples: 70_000,
        execution: veach::Execution::Megakernel,
        ..eight_by_eight()
    };
    let result = renderer().render(&gpu_scene, &s, &camera, &mut |_| true);
    if loop_limited() {
        let e = result.err().expect("a render over the loop limit must fail").to_string();
        assert!(e.contains("loop iterations"), "{e}");
    } else {
        assert!(result.is_ok());
    }
}

/// A light whose two panels face each other (a ridge over the floor, emitting inwards): from the
/// floor beside it, the near panel's back shadows part of the far panel. Such a light is not
/// convex, so its shadow rays must not skip its own triangles (crates/veach/src/gpu/light_subtrees.rs):
/// the floor renders as it does with each panel a light of its own (each planar, so convex, and
/// skipping only itself). Traversed through a BVH (`BvhMemory::Storage`), where the skipping is.
/// The loader splits such a mesh into a light per panel; the one light is put back together here.
/// Region means of 16 × 16 pixels × 256 light samples; the tolerance is 5 standard deviations of
/// the difference, from each image's per-pixel sample variance.
#[test]
fn a_light_that_shadows_itself_is_not_skipped() {
    use glam::{Mat4, Vec3};
    use veach::scene::LightKind;
    use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};
    let panel = |x_low: f32, facing: Vec3| {
        MeshData::quad(
            Vec3::new(x_low, 0.2, -1.0),
            Vec3::new(x_low, 0.2, 1.0),
            Vec3::new(0.0, 1.2, 1.0),
            Vec3::new(0.0, 1.2, -1.0),
            facing,
        )
    };
    let (left, right) = (panel(-1.0, Vec3::new(1.0, -1.0, 0.0)), panel(1.0, Vec3::new(-1.0, -1.0, 0.0)));
    let build = |one_light: bool| {
        let mut g = GltfBuilder::new();
        let floor = g.material(&MaterialDesc::lambert("floor", Vec3::splat(0.5)));
        let light = g.material(&MaterialDesc::emitter("ridge", Vec3::splat(4.0)));
        let q = MeshData::quad(
            Vec3::new(-4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, 4.0),
            Vec3::new(-4.0, 0.0, 4.0),
            Vec3::Y,
        );
        g.add_mesh("floor", &q, floor, Mat4::IDENTITY);
        if one_light {
            let mut both =
                MeshData { positions: left.positions.clone(), indices: left.indices.clone(), normals: None, uvs: None };
            both.positions.extend(&right.positions);
            both.indices.extend(right.indices.iter().map(|i| i + 4));
            g.add_mesh("ridge", &both, light, Mat4::IDENTITY);
        } else {
            g.add_mesh("left", &MeshData { normals: None, uvs: None, ..left.clone() }, light, Mat4::IDENTITY);
            g.add_mesh("right", &MeshData { normals: None, uvs: None, ..right.clone() }, light, Mat4::IDENTITY);
        }
        g.camera("camera", Vec3::new(2.5, 3.0, 0.01), Vec3::new(2.5, 0.0, 0.0), 40.0);
        let mut scene = load(&g, if one_light { "self-shadowing-light" } else { "self-shadowing-light-split" });
        // The loader makes each panel of the curved mesh a light (light_shape::light_parts); a
        // Scene built by hand may hold them as one, and that light's shadow rays are tested.
        assert_eq!(scene.lights.len(), 2);
        if one_light {
            let right = scene.lights.pop().unwrap();
            let (LightKind::Area { triangles, .. }, LightKind::Area { triangles: more, .. }) =
                (&mut scene.lights[0].kind, right.kind)
            else {
                unreachable!("area lights")
            };
            triangles.extend(more);
        }
        scene
    };
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 64,
        strategy: Strategy::Light,
        light_samples: 4,
        light_selection: LightSelection::Each,
        hide_emitters: true,
        seed: 11,
        ..Default::default()
    };
    let mut means = Vec::new();
    for one_light in [true, false] {
        let scene = build(one_light);
        assert_eq!(scene.lights.len(), if one_light { 1 } else { 2 });
        let gpu_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::Storage).unwrap();
        let out = render(&gpu_scene, &settings, &scene.camera(None).unwrap());
        means.push(region(&out, 0, 0, 16, 16));
    }
    let (one, split) = (means[0], means[1]);
    for c in 0..3 {
        let z = (one.mean[c] - split.mean[c]) / (one.var[c] + split.var[c]).sqrt();
        assert!(
            z.abs() < 5.0,
            "channel {c}: one light {:.5} against two {:.5} ({z:.1} sigma)",
            one.mean[c],
            split.mean[c]
        );
    }
}

/// A tree whose traversal stack the kernel's default size would not hold: 400 small triangles in
/// the planes x = 1.1^k (k = -200 … 199), each 1/100 of its distance across, which obvhs builds
/// into a chain (the biggest triangle beside the rest at every level). A ray along the chain
/// enters every box it passes and pushes the triangles beside its path, one level's worth at a
/// time; near its end it enters the boxes of triangles it misses (their hypotenuse passes
/// between it and their corner), and must pop what it pushed deepest. Every ray's closest hit
/// and occlusion match a brute-force test of all 400 triangles.
#[test]
fn rays_through_a_tree_deeper_than_the_default_stack_find_their_hits() {
    use glam::Vec3;
    use veach::gpu::layout::{FrameParams, TestParams};
    use veach::gpu::test_kernel::{TestKernel, routine};
    let plane = |k: i32| 1.1f32.powi(k);
    let mut scene = veach::Scene { materials: vec![Default::default()], ..Default::default() };
    for k in -200..200 {
        let (x, e) = (plane(k), plane(k) * 0.01);
        let p = [Vec3::new(x, 0.0, 0.0), Vec3::new(x, e, 0.0), Vec3::new(x, 0.0, e)];
        scene.triangles.push(veach::scene::Triangle { p, n: [Vec3::X; 3], uv: Default::default(), material: 0 });
    }
    let gpu_scene = upload(&scene);
    assert!(
        gpu_scene.bvh_stack_bound() > veach::gpu::bvh_nodes::BVH_STACK_SIZE,
        "the tree is not deep enough to test this: bound {}",
        gpu_scene.bvh_stack_bound()
    );
    // Rays along +x from x = -1 at y = z = d: they hit triangle k where 2d <= e_k (the triangle is
    // y + z <= e_k in its plane) and enter its box where d <= e_k.
    let mut input = Vec::new();
    let mut expected = Vec::new();
    for first in (-190..190).step_by(7) {
        let d = plane(first) * 0.01 * 0.3;
        input.push([-1.0, d, d, f32::MAX]);
        input.push([1.0, 0.0, 0.0, 0.0]);
        let hit = (-200..200).find(|&k| 2.0 * d <= plane(k) * 0.01).map(|k| plane(k) + 1.0);
        expected.push((first, hit));
    }
    let kernel = TestKernel::for_scene(renderer(), &gpu_scene).unwrap_or_else(|e| panic!("{e}"));
    let params = TestParams { routine: routine::TRACE, count: expected.len() as u32, ..Default::default() };
    let out = kernel.run(&gpu_scene, &FrameParams::default(), &params, &input, 1).unwrap();
    let mut wrong = Vec::new();
    for ((first, hit), got) in expected.iter().zip(&out) {
        let want = hit.expect("every ray hits a triangle");
        // The watertight test's t is within a few ulps of the plane's distance.
        if (got[0] - want).abs() > 1e-5 * want || got[1] != 1.0 {
            wrong.push(format!("ray at 1.1^{first}: closest t {} (want {want}), blocked {}", got[0], got[1]));
        }
    }
    assert!(wrong.is_empty(), "{} of {} rays wrong:\n{}", wrong.len(), expected.len(), wrong.join("\n"));
}

/// A soup of 2,000 random triangles in the unit cube, whose 4-wide BVH makes rays push past the
/// traversal stack's top entries kept in registers (`TraversalStack` in traverse_bvh.wgsl: four of
/// them, the rest spilled to memory and read back): every ray's closest hit and occlusion match a
/// brute-force test of all triangles in f64. Rays whose answer rounding could decide (a hit
/// within 1e-4 of a triangle's edge in barycentrics, or a second hit within 1e-4 (1 + t) of the
/// closest) are left out; a subtree dropped or visited in place of another moves t by far more.
#[test]
fn random_rays_through_a_triangle_soup_find_the_brute_force_hits() {
    use glam::{DVec3, Vec3};
    use veach::gpu::layout::{FrameParams, TestParams};
    use veach::gpu::test_kernel::{TestKernel, routine};
    // The same soup and rays on every run.
    let mut next = uniforms(0x853c49e6748fea9b);
    let mut scene = veach::Scene { materials: vec![Default::default()], ..Default::default() };
    for _ in 0..2000 {
        let centre = Vec3::new(next(), next(), next());
        let mut corner = || centre + 0.2 * (Vec3::new(next(), next(), next()) - 0.5);
        let p = [corner(), corner(), corner()];
        scene.triangles.push(veach::scene::Triangle { p, n: [Vec3::X; 3], uv: Default::default(), material: 0 });
    }
    let gpu_scene = upload(&scene);
    // Möller and Trumbore (JGT 2(1), 1997) in f64: (t, the smallest barycentric) of a hit.
    let hit = |o: DVec3, d: DVec3, p: &[Vec3; 3]| -> Option<(f64, f64)> {
        let [a, b, c] = p.map(|v| v.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let q = d.cross(e2);
        let det = e1.dot(q);
        if det.abs() < 1e-300 {
            return None;
        }
        let s = o - a;
        let u = s.dot(q) / det;
        let r = s.cross(e1);
        let v = d.dot(r) / det;
        let t = e2.dot(r) / det;
        let w = 1.0 - u - v;
        (u >= 0.0 && v >= 0.0 && w >= 0.0 && t > 0.0).then_some((t, u.min(v).min(w)))
    };
    let mut input = Vec::new();
    let mut expected = Vec::new();
    while expected.len() < 4096 {
        let o = Vec3::new(next(), next(), next());
        let d = loop {
            let d = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
            if d.length_squared() > 0.01 && d.length_squared() <= 1.0 {
                break d.normalize();
            }
        };
        let mut hits: Vec<(f64, f64)> =
            scene.triangles.iter().filter_map(|t| hit(o.as_dvec3(), d.as_dvec3(), &t.p)).collect();
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        let near_edge = hits.iter().any(|h| h.1 < 1e-4);
        let near_tie = hits.len() > 1 && hits[1].0 - hits[0].0 < 1e-4 * (1.0 + hits[0].0);
        if near_edge || near_tie {
            continue;
        }
        input.push([o.x, o.y, o.z, f32::MAX]);
        input.push([d.x, d.y, d.z, 0.0]);
        expected.push(hits.first().map(|h| h.0));
    }
    let hits = expected.iter().filter(|t| t.is_some()).count();
    assert!(hits > 2000 && hits < 4000, "{hits} of 4096 rays hit: the soup should stop most, not all");
    let kernel = TestKernel::for_scene(renderer(), &gpu_scene).unwrap_or_else(|e| panic!("{e}"));
    let params = TestParams { routine: routine::TRACE, count: expected.len() as u32, ..Default::default() };
    let out = kernel.run(&gpu_scene, &FrameParams::default(), &params, &input, 1).unwrap();
    let mut wrong = Vec::new();
    for (i, (want, got)) in expected.iter().zip(&out).enumerate() {
        let ok = match want {
            // f32 corners and origin near 1: t's error is absolute, a few ulps of 1.
            Some(t) => (got[0] as f64 - t).abs() <= 1e-5 * (1.0 + t) && got[1] == 1.0,
            None => got[0] == -1.0 && got[1] == 0.0,
        };
        if !ok {
            wrong.push(format!("ray {i}: closest t {} (want {want:?}), blocked {}", got[0], got[1]));
        }
    }
    assert!(wrong.is_empty(), "{} of {} rays wrong:\n{}", wrong.len(), expected.len(), wrong.join("\n"));
}

//! Renderer behaviour: determinism, independence from how work is split into dispatches,
//! one-sided emitters, and scenes with nothing in them.

mod common;

use common::*;
use glam::{Mat4, Vec3};
use std::time::Duration;
use veach::scene::Camera;
use veach::{RenderSettings, Strategy};
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};

fn small(strategy: Strategy, seed: u32) -> RenderSettings {
    let (light_samples, brdf_samples) = (2, 2);
    RenderSettings { width: 24, height: 16, spp: 3, strategy, light_samples, brdf_samples, seed, ..Default::default() }
}

#[test]
fn same_seed_gives_the_same_image_whatever_the_dispatch_split() {
    let scene = shipped_scene("cornell-box");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let a = render(&gpu_scene, &small(Strategy::Mis, 5), &camera);
    let b = render(&gpu_scene, &small(Strategy::Mis, 5), &camera);
    assert_eq!(a.sum, b.sum, "same seed, different image");
    // A headless render's first dispatch takes 2^21 rays' worth of camera samples, passes over
    // the image included (Renderer::render): this one's 1,152 samples of 5 rays each.
    assert_eq!(a.dispatches, 1, "a small render took more than one dispatch");
    // Tiny dispatches split the image into bands of rows.
    let tiny = RenderSettings { dispatch_target: Duration::from_nanos(1), ..small(Strategy::Mis, 5) };
    let c = render(&gpu_scene, &tiny, &camera);
    assert!(c.dispatches > a.dispatches, "expected more dispatches: {} vs {}", c.dispatches, a.dispatches);
    assert_eq!(a.sum, c.sum, "the image depends on the dispatch split");
    // Those bands took all 3 samples each (a headless render's bands take up to 8); the viewer's
    // take one sample per pass. Driven that way, one row at a time, the image is the same too.
    let mut acc = veach::Accumulation::new(renderer(), &gpu_scene, &tiny, &camera).unwrap();
    let mut viewer_dispatches = 0;
    while !acc.is_complete() {
        acc.dispatch(Duration::from_nanos(1)).unwrap();
        viewer_dispatches += 1;
    }
    acc.take_left_out_samples().unwrap();
    let v = acc.read().unwrap();
    assert!(viewer_dispatches > c.dispatches, "{viewer_dispatches} passes of one sample vs {} bands", c.dispatches);
    assert_eq!(a.sum, v.sum, "the image depends on the samples a band takes");
    let d = render(&gpu_scene, &small(Strategy::Mis, 6), &camera);
    assert_ne!(a.sum, d.sum, "a different seed gave the same image");
    assert_eq!(a.min_samples(), 3);
    assert!(a.rays > 0);
}

/// An image too large for one pixel buffer on the adapter is rendered in tiles of rows
/// (`Renderer::render`; lavapipe binds at most 128 MiB, 8.4 million pixels): forced here on small
/// images, the tiles give the untiled image bit for bit, sums of squares and contribution images
/// included, in both executions and through a BVH (Veach scene) and a baked list (Cornell box).
#[test]
fn an_image_rendered_in_tiles_is_the_image_rendered_whole() {
    for (name, execution) in [
        ("cornell-box", veach::Execution::Megakernel),
        ("veach-mis", veach::Execution::Megakernel),
        ("veach-mis", veach::Execution::Wavefront),
    ] {
        let scene = shipped_scene(name);
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        let settings = RenderSettings { write_aovs: true, execution, height: 19, ..small(Strategy::Mis, 3) };
        let whole = render(&gpu_scene, &settings, &camera);
        let tiled = renderer().render_in_tiles(&gpu_scene, &settings, &camera, 5, &mut |_| true).unwrap();
        assert_eq!((tiled.width, tiled.height), (whole.width, whole.height));
        assert!(tiled.dispatches >= 4, "{name}: 19 rows in tiles of 5 took {} dispatches", tiled.dispatches);
        assert_eq!(whole.sum, tiled.sum, "{name} {execution:?}: the tiles differ from the whole image");
        assert_eq!(whole.sum_sq, tiled.sum_sq, "{name} {execution:?}");
        let (w, t) = (whole.contributions.unwrap(), tiled.contributions.unwrap());
        assert_eq!((w.light, w.brdf), (t.light, t.brdf), "{name} {execution:?}: contribution images");
        assert_eq!(whole.rays, tiled.rays);
        assert!(!tiled.interrupted);
    }
    assert_eq!(veach::headless::tile_rows(19, 5), [0..4, 4..9, 9..14, 14..19]);
    assert_eq!(veach::headless::tile_rows(8, 8), vec![0..8]);
    assert_eq!(veach::headless::tile_rows(3, 1), [0..1, 1..2, 2..3]);
}

#[test]
fn time_limit_stops_the_render_and_reports_the_samples_reached() {
    let scene = shipped_scene("cornell-box");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let settings = RenderSettings {
        spp: u32::MAX,
        time_limit: Some(Duration::from_millis(300)),
        dispatch_target: Duration::from_millis(20),
        ..small(Strategy::Light, 1)
    };
    let out = render(&gpu_scene, &settings, &camera);
    assert!(out.render_time >= Duration::from_millis(300), "{:?}", out.render_time);
    assert!(out.render_time < Duration::from_secs(3), "{:?}", out.render_time);
    assert!(out.min_samples() >= 1 && out.mean_samples() < u32::MAX as f64);
    // With the default target (half a second) a time limit caps each dispatch at a tenth of it, so
    // 300 ms take several dispatches; uncapped, the first dispatch alone (2^21 rays) would run
    // past the limit.
    let default_target = RenderSettings { dispatch_target: RenderSettings::default().dispatch_target, ..settings };
    let out = render(&gpu_scene, &default_target, &camera);
    assert!(out.dispatches >= 3, "{} dispatches in {:?}", out.dispatches, out.render_time);
    assert!(out.render_time < Duration::from_secs(3), "{:?}", out.render_time);
}

/// A render stopped early (Ctrl-C) keeps what it accumulated, and stops only between passes: with
/// one-nanosecond dispatches (bands of a few rows) it finishes the pass in flight, so every pixel
/// has the same camera samples.
#[test]
fn stopping_early_keeps_what_was_accumulated() {
    let scene = shipped_scene("cornell-box");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let settings = RenderSettings { spp: 1000, dispatch_target: Duration::from_nanos(1), ..small(Strategy::Light, 1) };
    let mut calls = 0;
    let out = renderer()
        .render(&gpu_scene, &settings, &camera, &mut |_| {
            calls += 1;
            calls < 3
        })
        .unwrap();
    assert!(out.interrupted);
    assert!(out.dispatches > 3, "{} dispatches: the first pass was not finished", out.dispatches);
    let (fewest, most) = (out.min_samples(), out.max_samples());
    assert!(fewest == most && (1..1000).contains(&fewest), "pixels have {fewest} to {most} samples");
}

/// A one-sided emitter is dark from behind; a doubleSided one shows its radiance from both sides.
#[test]
fn emitters_are_one_sided_unless_double_sided() {
    for double_sided in [false, true] {
        let mut g = GltfBuilder::new();
        let m = g.material(&MaterialDesc { double_sided, ..MaterialDesc::emitter("light", Vec3::new(3.0, 2.0, 1.0)) });
        // Front face looks towards +Z.
        let quad = MeshData::quad(
            Vec3::new(-1., -1., 0.),
            Vec3::new(1., -1., 0.),
            Vec3::new(1., 1., 0.),
            Vec3::new(-1., 1., 0.),
            Vec3::Z,
        );
        g.add_mesh("light", &quad, m, Mat4::IDENTITY);
        let scene = load(&g, &format!("one-sided-{double_sided}"));
        let gpu_scene = upload(&scene);
        for (side, z) in [("front", 3.0f32), ("back", -3.0)] {
            let camera = Camera::look_at("c", Vec3::new(0.0, 0.0, z), Vec3::ZERO, Vec3::Y, 0.3);
            let out = render(&gpu_scene, &small(Strategy::Mis, 1), &camera);
            let visible = side == "front" || double_sided;
            for p in out.mean() {
                let expected = if visible { [3.0, 2.0, 1.0] } else { [0.0; 3] };
                assert_eq!(p, expected, "double_sided={double_sided}, seen from the {side}");
            }
        }
    }
}

#[test]
fn empty_and_unlit_scenes_render_black() {
    let empty = upload(&veach::Scene::default());
    let camera = Camera::look_at("c", Vec3::Z, Vec3::ZERO, Vec3::Y, 1.0);
    for strategy in Strategy::ALL {
        let out = render(&empty, &small(strategy, 1), &camera);
        assert!(out.mean().iter().all(|p| *p == [0.0; 3]), "{strategy:?}");
        assert_eq!(out.nonfinite_samples, 0);
    }
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("grey", Vec3::splat(0.5)));
    g.add_mesh(
        "box",
        &MeshData::prism(
            [Vec3::new(-1., 0., -1.), Vec3::new(1., 0., -1.), Vec3::new(1., 0., 1.), Vec3::new(-1., 0., 1.)],
            1.0,
        ),
        m,
        Mat4::IDENTITY,
    );
    let unlit = upload(&load(&g, "unlit"));
    let camera = Camera::look_at("c", Vec3::new(0.0, 2.0, 4.0), Vec3::ZERO, Vec3::Y, 1.0);
    for strategy in Strategy::ALL {
        let out = render(&unlit, &small(strategy, 1), &camera);
        assert!(out.mean().iter().all(|p| *p == [0.0; 3]), "{strategy:?}");
    }
}

/// The light-sample and BRDF-sample contribution images add up to the image; without MIS the
/// light strategy puts everything but emission in the light image.
#[test]
fn contribution_images_add_up_to_the_image() {
    let scene = shipped_scene("veach-mis");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    for strategy in [Strategy::Mis, Strategy::Light, Strategy::Brdf] {
        let settings = RenderSettings { write_aovs: true, ..small(strategy, 3) };
        let out = render(&gpu_scene, &settings, &camera);
        let images = out.contribution_images().unwrap();
        let (light, brdf, emitted) = (&images.light, &images.brdf, &images.emitted_luminance);
        let mut light_total = 0.0;
        for (i, m) in out.mean().iter().enumerate() {
            for c in 0..3 {
                let sum = light[i][c] + brdf[i][c];
                assert!((sum - m[c]).abs() <= 1e-4 * m[c].abs().max(1e-3), "{strategy:?} pixel {i}: {sum} vs {}", m[c]);
            }
            light_total += light[i][0];
            if strategy == Strategy::Light {
                let b = 0.2126 * brdf[i][0] + 0.7152 * brdf[i][1] + 0.0722 * brdf[i][2];
                assert!(
                    (b - emitted[i]).abs() <= 1e-4 * b.max(1e-3),
                    "light strategy: BRDF image is not emission only"
                );
            }
        }
        if strategy == Strategy::Brdf {
            assert_eq!(light_total, 0.0);
        } else {
            assert!(light_total > 0.0);
        }
    }
}

/// The control variate is refused, with the reason, where the kernel's closed form does not hold
/// or would cost a loop over too many emitter triangles; nothing is rendered then.
#[test]
fn the_control_variate_is_refused_where_it_does_not_apply() {
    let cv = |strategy| RenderSettings { control_variate: true, ..small(strategy, 1) };
    let attempt = |scene: &veach::Scene, s: &RenderSettings| {
        let gpu_scene = upload(scene);
        let camera = scene.camera(None).unwrap();
        renderer().render(&gpu_scene, s, &camera, &mut |_| true).err().map(|e| e.to_string())
    };
    let veach_scene = shipped_scene("veach-mis");
    let error = attempt(&veach_scene, &cv(Strategy::Mis)).expect("the Veach scene's lights have too many triangles");
    assert!(error.contains("--control-variate") && error.contains("at most 32"), "{error}");
    // (On a scene without glossy lobes mis-lobes is light sampling, which takes it.)
    let error = attempt(&veach_scene, &cv(Strategy::MisLobes)).expect("mis-lobes does not take it");
    assert!(error.contains("mis-lobes"), "{error}");
    let cornell = shipped_scene("cornell-box");
    let cone = RenderSettings { light_sampling: veach::LightSampling::Cone, ..cv(Strategy::Mis) };
    let error = attempt(&cornell, &cone).expect("cone sampling does not take it");
    assert!(error.contains("cone"), "{error}");
    assert_eq!(attempt(&cornell, &cv(Strategy::Mis)), None, "the Cornell box takes it");
}

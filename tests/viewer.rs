//! The viewer driven through its real widgets, headless (egui_kittest), on the renderer's
//! adapter (lavapipe in CI): strategy toggles restart accumulation and change the image, the
//! contribution views show the MIS split, the keys move the camera, the live error curve falls
//! as samples accumulate, and the window matches its snapshot.

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use veach::{GpuContext, Renderer};
use veach_viewer::display::View;
use veach_viewer::{ViewerApp, ViewerOptions};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scratch(name: &str) -> PathBuf {
    let dir = workspace().join("target/tmp/veach-tests/viewer");
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir.join(name)
}

/// The Cornell box at 48×48, accumulating up to `spp` samples.
fn app(spp: u32) -> ViewerApp {
    let gpu = GpuContext::new(None).expect("a wgpu adapter (lavapipe in CI)");
    let renderer = Arc::new(Renderer::new(gpu).expect("renderer"));
    // Relative (cargo runs tests in the crate's folder): the path shows in the snapshot.
    let mut options = ViewerOptions::new(PathBuf::from("../../assets/cornell-box.gltf"));
    options.settings.width = 48;
    options.settings.height = 48;
    options.settings.spp = spp;
    options.frame_budget = Duration::from_millis(30);
    ViewerApp::new(renderer, options).expect("viewer on the shipped Cornell box")
}

fn harness(app: ViewerApp) -> Harness<'static, ViewerApp> {
    Harness::builder().with_size([1100.0, 960.0]).build_ui_state(|ui, app: &mut ViewerApp| app.show(ui), app)
}

/// Steps frames until the accumulation reaches its sample count.
fn run_to_completion(h: &mut Harness<'_, ViewerApp>) {
    for _ in 0..400 {
        h.step();
        if h.state().is_complete() {
            // One more frame shows the final image.
            h.step();
            return;
        }
    }
    panic!("the accumulation did not complete in 400 frames: {}", h.state().status);
}

fn image(h: &Harness<'_, ViewerApp>) -> Vec<[f32; 3]> {
    h.state().session().latest().expect("an image").mean()
}

fn mean_abs_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let diff: f64 = a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs() as f64)).sum();
    let scale: f64 = a.iter().flat_map(|x| x.iter().map(|v| v.abs() as f64)).sum();
    diff / scale.max(1e-12)
}

#[test]
fn toggling_a_strategy_restarts_accumulation_and_changes_the_image() {
    let mut h = harness(app(4));
    run_to_completion(&mut h);
    let mis = image(&h);
    let restarts = h.state().session().restarts;
    assert_eq!(h.state().session().latest().unwrap().min_samples(), 4);

    h.get_by_label("uniform").click();
    h.step();
    assert_eq!(h.state().session().restarts, restarts + 1, "choosing uniform must restart");
    let shown = h.state().session().latest().map(|o| o.kernel.strategy);
    assert_eq!(shown, Some(Some(veach::Strategy::Uniform)), "the image shown is not the new accumulation's");
    run_to_completion(&mut h);
    let uniform = image(&h);
    // Different estimators at 4 spp: the noise alone differs by far more than 1%.
    let d = mean_abs_difference(&mis, &uniform);
    assert!(d > 0.01, "the image did not change when the strategy did (relative difference {d})");

    // Going back to MIS with the same seed reproduces the first image (a cached kernel).
    let kernels = h.state().session().renderer.cached_kernels();
    h.get_by_label("mis").click();
    run_to_completion(&mut h);
    assert_eq!(h.state().session().renderer.cached_kernels(), kernels, "MIS's kernel was compiled again");
    let again = image(&h);
    let d = mean_abs_difference(&mis, &again);
    assert!(d < 1e-5, "MIS with the same seed gave another image (relative difference {d})");

    // The control variate's checkbox restarts with it: another estimate of the same image.
    h.get_by_label("unshadowed light as a control variate").click();
    run_to_completion(&mut h);
    assert!(h.state().session().latest().unwrap().kernel.techniques.control_variate, "{}", h.state().status);
    let controlled = image(&h);
    let d = mean_abs_difference(&mis, &controlled);
    assert!(d > 1e-4, "the control variate left the image as it was (relative difference {d})");
}

#[test]
fn contribution_views_show_the_light_and_brdf_parts() {
    let mut h = harness(app(2));
    run_to_completion(&mut h);
    let restarts = h.state().session().restarts;
    h.get_by_label(View::Contributions.label()).click();
    h.step();
    assert_eq!(h.state().session().restarts, restarts + 1, "contributions need another kernel");
    run_to_completion(&mut h);
    let shown = h.state().shown().expect("shown");
    assert_eq!((shown.width, shown.height), (96, 48), "light | BRDF side by side");
    let out = h.state().session().latest().unwrap();
    let parts = out.contribution_images().expect("contributions written");
    let light: f32 = parts.light.iter().map(|p| p[0] + p[1] + p[2]).sum();
    let brdf: f32 = parts.brdf.iter().map(|p| p[0] + p[1] + p[2]).sum();
    assert!(light > 0.0 && brdf > 0.0, "both parts carry light: {light} {brdf}");

    // The weight view needs the same buffers: no restart.
    h.get_by_label(View::MisWeight.label()).click();
    h.step();
    assert_eq!(h.state().session().restarts, restarts + 1);
    assert_eq!(h.state().shown().unwrap().width, 48);

    h.get_by_label(View::Variance.label()).click();
    run_to_completion(&mut h);
    let shown = h.state().shown().unwrap();
    assert_eq!((shown.width, shown.height), (48, 48));
    // Noisy pixels exist at 2 spp: the variance view is not all one colour.
    let first = &shown.rgba[..4];
    assert!(shown.rgba.chunks(4).any(|p| p != first), "variance view is uniform");
}

#[test]
fn keys_move_the_camera_and_reset_restores_it() {
    let mut h = harness(app(1));
    run_to_completion(&mut h);
    let before = image(&h);
    let restarts = h.state().session().restarts;
    h.key_press(egui::Key::ArrowLeft);
    h.step();
    assert_eq!(h.state().session().restarts, restarts + 1, "orbiting restarts accumulation");
    run_to_completion(&mut h);
    assert!(mean_abs_difference(&before, &image(&h)) > 0.01, "the view did not change");
    h.get_by_label("reset camera").click();
    run_to_completion(&mut h);
    assert!(mean_abs_difference(&before, &image(&h)) < 1e-5, "reset did not return to the scene's camera");
}

#[test]
fn error_curve_falls_as_samples_accumulate_and_saves_as_csv() {
    // 256 spp: enough work that no first frame (dispatches for half its 30 ms budget) can finish
    // it on lavapipe, whatever the Mesa release (64 spp did fit in one frame with Mesa 25).
    let mut h = harness(app(256));
    h.get_by_label(&format!("render reference ({} spp)", veach_viewer::app::REFERENCE_SPP)).click();
    for _ in 0..2000 {
        h.step();
        if h.state().curves.reference.is_some() {
            break;
        }
    }
    assert!(h.state().curves.reference.is_some(), "no reference: {}", h.state().status);
    run_to_completion(&mut h);
    let curve = h.state().curves.curves.last().expect("a curve");
    assert!(curve.points.len() >= 2, "{} points", curve.points.len());
    let (first, last) = (curve.points[0], *curve.points.last().unwrap());
    assert!(last.seconds > first.seconds && last.spp > first.spp);
    // The last point is the error of the image on screen against the reference.
    let reference = &h.state().curves.reference.as_ref().unwrap().pixels;
    let now = veach_bench::bench::error_metrics(&image(&h), reference).relmse;
    assert!((last.relmse - now).abs() <= 1e-9 * now.max(1.0), "curve {} vs image {now}", last.relmse);
    // The error falls as samples accumulate, but not smoothly as 1/spp: at 48×48 one pixel on
    // the floor by the boxes carries 40-90% of relMSE (rare bright samples where the reference
    // is nearly black, ε = 0.01). Measured for this seed against the reference (Sobol samples,
    // the default; `veach render --width 48 --height 48` at every count, same settings), relMSE
    // at 1, 2, 3, 4, 8, 16, 32, 64, 128 spp: 0.025 0.0097 0.0076 0.0053 0.087 0.024 0.0089 0.0017
    // 0.00030; at every count from 1 to 160 spp it is at least 2.3e-4, at 256 spp 8.1e-5. So
    // whichever frame gives the first point (timing decides), if it is at most 160 spp the last
    // is below it.
    assert!(first.spp <= 160.0, "first point at {} spp: too late to see the error fall", first.spp);
    assert!(
        last.relmse < first.relmse,
        "relMSE {} -> {} from {} to {} spp",
        first.relmse,
        last.relmse,
        first.spp,
        last.spp
    );
    for pair in curve.points.windows(2) {
        assert!(pair[1].seconds > pair[0].seconds && pair[1].spp >= pair[0].spp, "{pair:?}");
    }

    let csv = scratch("curves.csv");
    h.state().curves.write_csv(&csv).expect("csv written");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("curve,seconds,spp,relmse\n"));
    assert_eq!(text.lines().count(), 1 + curve.points.len());
    let exr = scratch("image.exr");
    h.state().save_image(&exr).expect("image saved");
    let (w, hgt, pixels) = veach::image_io::read_image(&exr).unwrap();
    assert_eq!((w, hgt), (48, 48));
    assert!(pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    // The saved image records the settings shown, as `veach render` does.
    let meta = veach::image_io::read_metadata(&exr).unwrap();
    let value = |name: &str| meta.iter().find(|(n, _)| n == name).map(|(_, v)| v.to_string());
    assert_eq!(value("veach:width"), Some("48".into()), "{meta:?}");
    let strategy = h.state().controls.strategy.name();
    assert_eq!(value("veach:strategy").as_deref(), Some(strategy), "{meta:?}");
}

#[test]
fn bad_files_give_a_message_not_a_panic() {
    let mut h = harness(app(1));
    run_to_completion(&mut h);
    let missing = scratch("no-such-scene.gltf");
    let err = h.state_mut().open_scene(&missing).unwrap_err().to_string();
    assert!(err.contains("no-such-scene.gltf"), "{err}");
    let err = h.state_mut().load_reference(&scratch("no-such.exr")).unwrap_err().to_string();
    assert!(err.contains("no-such.exr"), "{err}");
    // The viewer keeps rendering the scene it had.
    h.get_by_label("light").click();
    run_to_completion(&mut h);
}

#[test]
fn window_snapshot() {
    let mut h = harness(app(8));
    run_to_completion(&mut h);
    // Timings differ from run to run: mask the line that shows them.
    // Widened to the window's right edge: the text's width changes with the numbers, and a mask
    // that ends short of the edge moves its own edge with them.
    let timing = h.get_by_label_contains("spp/s").rect();
    h.mask(timing.with_max_x(timing.max.x + 10_000.0));
    let options = egui_kittest::SnapshotOptions::new().output_path(workspace().join("tests/snapshots"));
    h.snapshot_options("viewer-cornell-box", &options);
}

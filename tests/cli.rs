//! The `veach` command as a user runs it: outputs by extension, --stats, errors that name the
//! file, and an existing output left alone when a render fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn veach(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_veach")).args(args).output().expect("run veach")
}

fn assets(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets").join(name).to_str().unwrap().to_owned()
}

fn out_dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("veach-tests").join("cli");
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn renders_exr_png_and_pfm_with_stats() {
    let dir = out_dir();
    for ext in ["exr", "png", "pfm"] {
        let out = dir.join(format!("cornell.{ext}"));
        let stats = dir.join(format!("cornell-{ext}.json"));
        let o = veach(&[
            "render",
            &assets("cornell-box.gltf"),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "24",
            "--spp",
            "2",
            "--light-samples",
            "2",
            "--brdf-samples",
            "2",
            "--stats",
            stats.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (w, h, px) = veach::image_io::read_image(&out).unwrap();
        assert_eq!((w, h), (32, 24));
        assert!(px.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        assert!(px.iter().flatten().any(|v| *v > 0.0), "{ext}: black image");
        let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        assert_eq!(s["scene"]["triangles"], 36);
        assert_eq!(s["scene"]["lights"], 1);
        assert_eq!(s["samples_per_pixel"]["min"], 2);
        assert!(s["rays"].as_u64().unwrap() > 32 * 24 * 2);
        assert!(s["rays_per_second"].as_f64().unwrap() > 0.0);
        for key in ["load", "bvh_build", "pipeline_creation", "render", "camera_footprints"] {
            assert!(s["timings_seconds"][key].as_f64().is_some(), "missing timing {key}");
        }
        assert!(s["adapter"].as_str().is_some_and(|a| !a.is_empty()));
    }
    // The same render in both float formats: the same pixels. The EXR's and the PNG's headers
    // name the settings (the PNG's its exposure too).
    let exr = veach::image_io::read_image(&dir.join("cornell.exr")).unwrap();
    assert_eq!(exr, veach::image_io::read_image(&dir.join("cornell.pfm")).unwrap());
    for ext in ["exr", "png"] {
        let meta = veach::image_io::read_metadata(&dir.join(format!("cornell.{ext}"))).unwrap();
        let value = |name: &str| meta.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str());
        assert_eq!(value("veach:strategy"), Some("mis"), "{meta:?}");
        assert_eq!(value("veach:light_samples"), Some("2"), "{meta:?}");
        assert_eq!(value("veach:spp"), Some("2.000"), "{meta:?}");
        assert_eq!(value("veach:camera_yfov_degrees").map(|v| v.parse::<f32>().is_ok()), Some(true), "{meta:?}");
        assert!(value("veach:scene").is_some_and(|s| s.ends_with("cornell-box.gltf")), "{meta:?}");
        assert_eq!(value("veach:exposure").is_some(), ext == "png", "{meta:?}");
    }
    // `veach info` reads them back.
    let o = veach(&["info", dir.join("cornell.png").to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && text.contains("image: 32x24") && text.contains("  light_samples: 2"), "{text}");
    let o = veach(&["info", dir.join("cornell.pfm").to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("no veach settings"), "{}", stderr(&o));
}

/// The bench refuses what it cannot measure: a scene without lights (every image black), and a
/// reference without light, before spending the sweep's time on them.
#[test]
fn the_bench_refuses_scenes_it_cannot_measure() {
    use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};
    let dir = out_dir();
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("grey", glam::Vec3::splat(0.5)));
    let square = MeshData {
        positions: vec![
            glam::Vec3::new(-1.0, -1.0, 0.0),
            glam::Vec3::new(1.0, -1.0, 0.0),
            glam::Vec3::new(0.0, 1.0, 0.0),
        ],
        normals: None,
        uvs: None,
        indices: vec![0, 1, 2],
    };
    g.add_mesh("tri", &square, m, glam::Mat4::IDENTITY);
    let dark = dir.join("dark.gltf");
    g.write(&dark).unwrap();
    let bench_out = dir.join("dark-bench");
    let o = veach(&["bench", dark.to_str().unwrap(), "-o", bench_out.to_str().unwrap(), "--max-spp", "1"]);
    let e = stderr(&o);
    assert!(o.status.code() == Some(1) && e.contains("dark.gltf") && e.contains("no lights"), "{e}");
    assert!(!e.contains("adapter:"), "refused after starting the GPU: {e}");

    // A reference that is black: the same scene's bench against an all-zero image.
    let black = dir.join("black.pfm");
    veach::image_io::write_image(&black, 8, 8, &[[0.0; 3]; 64], 0.0).unwrap();
    let o = veach(&[
        "bench",
        &assets("cornell-box.gltf"),
        "-o",
        bench_out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--max-spp",
        "1",
        "--seeds",
        "1",
        "--reference",
        black.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert!(o.status.code() == Some(1) && e.contains("black.pfm") && e.contains("is black"), "{e}");

    // A reference with a NaN pixel (as another renderer might write; veach writes none), by hand.
    let nan = dir.join("nan.pfm");
    let mut pfm = b"PF\n8 8\n-1.0\n".to_vec();
    for i in 0..64 * 3 {
        pfm.extend_from_slice(&(if i == 100 { f32::NAN } else { 0.5f32 }).to_le_bytes());
    }
    std::fs::write(&nan, pfm).unwrap();
    let reference = ["--reference", nan.to_str().unwrap()];
    let size = ["--width", "8", "--height", "8", "--max-spp", "1", "--seeds", "1"];
    let o = veach(
        &[&["bench", &assets("cornell-box.gltf"), "-o", bench_out.to_str().unwrap()][..], &size, &reference].concat(),
    );
    let e = stderr(&o);
    assert!(o.status.code() == Some(1) && e.contains("nan.pfm") && e.contains("1 pixels are NaN"), "{e}");
    assert!(!e.contains("adapter:"), "refused after starting the GPU: {e}");
    // A reference of another size, or one reference for two scenes: refused up front too.
    let wrong_size = ["--width", "9", "--height", "8", "--reference", black.to_str().unwrap()];
    let o =
        veach(&[&["bench", &assets("cornell-box.gltf"), "-o", bench_out.to_str().unwrap()][..], &wrong_size].concat());
    let e = stderr(&o);
    assert!(
        o.status.code() == Some(1) && e.contains("is 8x8 but the bench renders 9x8") && !e.contains("adapter:"),
        "{e}"
    );
    let two = [assets("cornell-box.gltf"), assets("veach-mis.gltf")];
    let o = veach(
        &[
            &["bench", &two[0], &two[1], "-o", bench_out.to_str().unwrap()][..],
            &size,
            &["--reference", black.to_str().unwrap()],
        ]
        .concat(),
    );
    assert!(o.status.code() == Some(1) && stderr(&o).contains("one scene's reference"), "{}", stderr(&o));
    let o = veach(&[&["view", &assets("cornell-box.gltf")][..], &reference].concat());
    assert!(o.status.code() == Some(1) && stderr(&o).contains("NaN or infinite"), "{}", stderr(&o));
}

#[test]
fn a_bad_scene_is_a_clear_error_and_leaves_the_old_output_alone() {
    let dir = out_dir();
    let out = dir.join("keep.png");
    std::fs::write(&out, b"previous image").unwrap();
    let bad = dir.join("bad.gltf");
    std::fs::write(&bad, b"{ this is not json").unwrap();
    let o = veach(&["render", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("bad.gltf") && e.starts_with("error:"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert_eq!(std::fs::read(&out).unwrap(), b"previous image");

    let o = veach(&["render", "/no/such/scene.glb", "-o", out.to_str().unwrap()]);
    assert!(stderr(&o).contains("/no/such/scene.glb"));
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", dir.join("x.jpg").to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains(".exr"), "{}", stderr(&o));
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), "--camera", "nope"]);
    assert!(!o.status.success() && stderr(&o).contains("'camera'"), "{}", stderr(&o));
    // An output that cannot be written: refused before the render, naming the file.
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", "/no/such/dir/out.png"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("/no/such/dir/out.png") && !e.contains("adapter:"), "{e}");
    let folder = dir.join("folder.png");
    std::fs::create_dir_all(&folder).unwrap();
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", folder.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("is a directory"), "{}", stderr(&o));
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", "x.png", "--stats", "/no/such/dir/s.json"]);
    assert!(!o.status.success() && stderr(&o).contains("/no/such/dir/s.json"), "{}", stderr(&o));
    let size = ["--width", "100000", "--height", "100000"];
    let o = veach(&[&["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap()][..], &size].concat());
    let e = stderr(&o);
    assert!(o.status.code() == Some(1) && e.contains("100000x100000") && !e.contains("adapter:"), "{e}");
    // Values whose sums would wrap in 32 bits among them (4294967295 + 32 light and BRDF samples).
    let refused = [
        ("--time-limit", "1e30"),
        ("--time-limit", "nan"),
        ("--exposure", "inf"),
        ("--light-samples", "4294967295"),
        ("--brdf-samples", "2000000"),
    ];
    for (flag, value) in refused {
        let o = veach(&["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), flag, value]);
        let e = stderr(&o);
        assert!(o.status.code() == Some(1) && e.contains(flag) && !e.contains("panicked"), "{flag} {value}: {e}");
    }
    let o = veach(&["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), "--spp", "0"]);
    assert!(!o.status.success() && stderr(&o).contains("--spp"), "{}", stderr(&o));
    // A setting the scene cannot take: refused before rendering, naming the scene and why.
    let o = veach(&["render", &assets("veach-mis.gltf"), "-o", out.to_str().unwrap(), "--control-variate"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("veach-mis.gltf: --control-variate") && e.contains("3840"), "{e}");
    assert_eq!(std::fs::read(&out).unwrap(), b"previous image");
}

#[test]
fn contribution_images_are_written_next_to_the_output() {
    let dir = out_dir();
    let out = dir.join("mis.exr");
    let o = veach(&[
        "render",
        &assets("veach-mis.gltf"),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "24",
        "--height",
        "16",
        "--light-samples",
        "1",
        "--brdf-samples",
        "1",
        "--aov",
        "light,brdf,weights",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, image) = veach::image_io::read_image(&out).unwrap();
    let (_, _, light) = veach::image_io::read_image(&dir.join("mis.light.exr")).unwrap();
    let (_, _, brdf) = veach::image_io::read_image(&dir.join("mis.brdf.exr")).unwrap();
    let (w, h, _) = veach::image_io::read_image(&dir.join("mis.weights.png")).unwrap();
    assert_eq!((w, h), (24, 16));
    for ((i, l), b) in image.iter().zip(&light).zip(&brdf) {
        for c in 0..3 {
            assert!((l[c] + b[c] - i[c]).abs() <= 1e-4 * i[c].max(1e-3));
        }
    }
}

/// Smoke test of `veach bench` at a tiny size: the outputs exist and results.csv is well formed.
#[test]
fn bench_writes_a_well_formed_report() {
    let dir = out_dir().join("bench");
    let _ = std::fs::remove_dir_all(&dir);
    let o = veach(&[
        "bench",
        &assets("cornell-box.gltf"),
        "-o",
        dir.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--max-spp",
        "4",
        "--seeds",
        "2",
        "--reference-spp",
        "32",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "scene,strategy,budget,spp,seconds,rmse,relmse,mae,efficiency,seed,max_value,nonfinite,rays,rays_per_s"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 6 strategies × budgets 1, 2, 4 × 2 seeds.
    assert_eq!(rows.len(), 6 * 3 * 2);
    for r in &rows {
        assert_eq!(r.len(), 14, "{r:?}");
        assert_eq!(r[0], "cornell-box");
        for v in r[3..9].iter().chain(&r[10..14]) {
            let x: f64 = v.parse().unwrap_or_else(|_| panic!("not a number: {v}"));
            assert!(x.is_finite() && x >= 0.0, "{r:?}");
        }
        assert!(r[4].parse::<f64>().unwrap() > 0.0, "zero render time: {r:?}");
        // At least a camera ray per pixel and camera sample (16 × 16 pixels).
        let spp: f64 = r[3].parse().unwrap();
        assert!(r[12].parse::<f64>().unwrap() >= 256.0 * spp, "too few rays counted: {r:?}");
    }
    let strategies: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(
        strategies.into_iter().collect::<Vec<_>>(),
        ["brdf", "light", "mis-balance", "mis-lobes", "mis-power", "uniform"]
    );
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    for needle in
        ["## cornell-box", "Error at equal time", "Convergence", "By region", "By material", "cornell-box-relmse.svg"]
    {
        assert!(report.contains(needle), "report.md lacks {needle}");
    }
    assert!(std::fs::read_to_string(dir.join("cornell-box-relmse.svg")).unwrap().starts_with("<svg"));
    assert!(image::open(dir.join("cornell-box-equal-time.png")).is_ok());
    // The reference is cached and reused.
    assert!(dir.join("reference-cornell-box-16x16-32spp.pfm").exists());
}

#[test]
fn help_explains_the_sample_counts() {
    let o = veach(&["render", "--help"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for needle in
        ["--spp", "--light-samples", "--brdf-samples", "--strategy", "--time-limit", "camera samples per pixel"]
    {
        assert!(text.contains(needle), "--help lacks {needle}");
    }
}

#[test]
fn generated_assets_match_the_shipped_files() {
    let dir = out_dir();
    for name in veach_scenes::SHIPPED_SCENES {
        let out = dir.join(format!("{name}.gltf"));
        let o = veach(&["generate", name, "-o", out.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read_to_string(&out).unwrap(),
            std::fs::read_to_string(assets(&format!("{name}.gltf"))).unwrap(),
            "assets/{name}.gltf is stale: regenerate it with `veach generate {name} -o assets/{name}.gltf`"
        );
    }
}

/// `veach view` in a real window on a virtual display: renders, saves a screenshot, exits.
/// Needs xvfb-run (scripts/setup-debian.sh installs it); CI sets VEACH_REQUIRE_XVFB=1 so that
/// a missing one fails instead of skipping.
#[test]
fn viewer_window_renders_and_saves_a_screenshot_under_xvfb() {
    let have_xvfb = Command::new("xvfb-run").arg("--help").output().is_ok();
    if !have_xvfb {
        assert!(std::env::var_os("VEACH_REQUIRE_XVFB").is_none(), "VEACH_REQUIRE_XVFB is set but xvfb-run is missing");
        eprintln!("skipped: xvfb-run is not installed (scripts/setup-debian.sh installs it)");
        return;
    }
    let shot = out_dir().join("viewer-window.png");
    let _ = std::fs::remove_file(&shot);
    let o = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x900x24", env!("CARGO_BIN_EXE_veach"), "view"])
        .arg(assets("cornell-box.gltf"))
        .args(["--width", "64", "--height", "64", "--frames", "8", "--screenshot"])
        .arg(&shot)
        .output()
        .expect("run xvfb-run");
    assert!(o.status.success(), "veach view failed: {}", stderr(&o));
    let img = image::open(&shot).expect("the screenshot is a PNG").to_rgba8();
    assert!(img.width() >= 800 && img.height() >= 600, "{}x{}", img.width(), img.height());
    // The render sits right of the controls: it has lit pixels (the red wall) there.
    let red = img.enumerate_pixels().filter(|(x, _, p)| *x > 420 && p[0] > 90 && p[1] < 60 && p[2] < 60).count();
    assert!(red > 500, "no red wall in the window's image area ({red} red pixels)");
}

#[test]
fn viewer_refuses_bad_input_before_opening_a_window() {
    let o = veach(&["view", "no-such-scene.gltf"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no-such-scene.gltf"), "{}", stderr(&o));
    let o = veach(&["view", &assets("cornell-box.gltf"), "--screenshot", "shot.jpg"]);
    assert!(!o.status.success() && stderr(&o).contains("PNG"), "{}", stderr(&o));
    let o = veach(&["view", &assets("cornell-box.gltf"), "--camera", "nope"]);
    assert!(!o.status.success() && stderr(&o).contains("nope"), "{}", stderr(&o));
}

/// Smoke test of `veach scale` at a tiny size: scale.csv is well formed, the generated scenes
/// have the triangle and light counts asked for, and the light sweep keeps its geometry fixed.
#[test]
fn scale_writes_a_well_formed_csv() {
    let dir = out_dir().join("scale");
    let _ = std::fs::remove_dir_all(&dir);
    let o = veach(&[
        "scale",
        "-o",
        dir.to_str().unwrap(),
        "--triangles",
        "1000,4000",
        "--lights",
        "1,9",
        "--light-grid",
        "16",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1",
        "--repeats",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.join("scale.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "sweep,strategy,triangles,lights,load_s,bvh_build_s,bvh_nodes,gpu_scene_bytes,bytes_per_triangle,\
         bvh_bytes_per_triangle,render_s,spp,rays,rays_per_s,ratio_to_first,ratio_min,ratio_max"
    );
    // The strategy column, then the rest without it: numbers after the sweep's name.
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let strategies: Vec<&str> = rows.iter().map(|r| r[1]).collect();
    assert_eq!(strategies, ["mis-power 1+1", "mis-power 1+1", "mis-power 1+1", "light 2", "mis-power 1+1", "light 2"]);
    let rows: Vec<Vec<&str>> = rows.into_iter().map(|r| [&r[..1], &r[2..]].concat()).collect();
    let num = |v: &str| -> f64 { v.parse().unwrap_or_else(|_| panic!("not a number: {v}")) };
    for r in &rows {
        assert_eq!(r.len(), 16, "{r:?}");
        for v in &r[1..] {
            assert!(num(v).is_finite() && num(v) >= 0.0, "{r:?}");
        }
        assert!(num(r[9]) > 0.0, "zero render time: {r:?}");
        // A camera ray per pixel at least (16 × 16, 1 spp).
        assert!(num(r[11]) >= 256.0, "too few rays: {r:?}");
        // One repeat: its ratio is the median, the smallest and the largest.
        assert!(num(r[13]) > 0.0 && num(r[13]) == num(r[14]) && num(r[13]) == num(r[15]), "{r:?}");
    }
    // Each sweep's first point, against itself.
    for r in [&rows[0], &rows[2], &rows[3]] {
        assert_eq!(num(r[13]), 1.0, "{r:?}");
    }
    // Triangle sweep: within 10% of the count asked for; one light (the Cornell box's).
    for (r, wanted) in rows[..2].iter().zip([1000.0, 4000.0]) {
        assert_eq!(r[0], "triangles");
        assert!((num(r[1]) / wanted - 1.0).abs() < 0.1, "{r:?}");
        assert_eq!(r[2], "1");
    }
    // Light sweep: the same 16 grid triangles + 2 floor triangles whatever the light count.
    for (r, lights) in rows[2..].iter().zip(["1", "1", "9", "9"]) {
        assert_eq!((r[0], r[1], r[2]), ("lights", "18", lights), "{r:?}");
    }
}

#[test]
fn info_says_whether_a_scene_takes_the_control_variate() {
    let stdout = |scene: &str| String::from_utf8(veach(&["info", &assets(scene)]).stdout).unwrap();
    assert!(stdout("cornell-box.gltf").contains("control variate: takes --control-variate"));
    let veach_scene = stdout("veach-mis.gltf");
    assert!(veach_scene.contains("control variate: no (") && veach_scene.contains("3840"), "{veach_scene}");
}

/// `veach info` lists a curved mesh light, which the loader splits into a light per part, as one
/// line: the zoo's glowing torus of 3,000 triangles.
#[test]
fn info_lists_a_split_mesh_light_on_one_line() {
    let zoo = veach_scenes::zoo::zoo(1);
    let torus = zoo.iter().find(|z| z.name == "emissive-mesh").expect("the zoo has its glowing torus");
    let path = out_dir().join("info-emissive-mesh.gltf");
    torus.builder.write(&path).unwrap();
    let o = veach(&["info", path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("  lights: 3000\n"), "{text}");
    assert!(text.contains("primitive 0 (3000 area lights, one per part, 3000 triangles)"), "{text}");
    assert!(!text.contains(" part 1"), "{text}");
}

/// `veach render` says when a light is sealed in a closed surface, which the light tree then
/// leaves out of light samples outside it: the stress scene `degenerate` has one; the Cornell box
/// none.
#[test]
fn render_names_lights_sealed_in_closed_surfaces() {
    let path = out_dir().join("sealed-degenerate.gltf");
    veach_scenes::stress::stress_scene("degenerate").unwrap().write(&path).unwrap();
    for (scene, sealed) in [(path.to_str().unwrap().to_owned(), true), (assets("cornell-box.gltf"), false)] {
        let image = out_dir().join("sealed.png");
        let o =
            veach(&["render", &scene, "-o", image.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "1"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let said = stderr(&o).contains("1 light sealed in a closed surface: no light samples outside it");
        assert_eq!(said, sealed, "{scene}: {}", stderr(&o));
    }
}

/// Every pixel of a written image has the same camera samples, however the render stops: a time
/// limit far shorter than one pass finishes the pass (rows left black before), and the header and
/// --stats say how many samples the image holds.
#[test]
fn a_time_limit_keeps_whole_passes() {
    let dir = out_dir();
    let lit = dir.join("time-limit-lit.exr");
    let o = veach(&[
        "render",
        &assets("veach-mis.gltf"),
        "-o",
        lit.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "16",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, reference) = veach::image_io::read_image(&lit).unwrap();
    for (limit, name) in [("0.001", "short"), ("1e-300", "tiny")] {
        let out = dir.join(format!("time-limit-{name}.exr"));
        let stats = dir.join(format!("time-limit-{name}.json"));
        let o = veach(&[
            "render",
            &assets("veach-mis.gltf"),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--time-limit",
            limit,
            "--stats",
            stats.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        let (min, mean) = (&s["samples_per_pixel"]["min"], s["samples_per_pixel"]["mean"].as_f64().unwrap());
        assert!(min.as_u64().unwrap() >= 1 && min.as_f64().unwrap() == mean, "{limit}: {s}");
        let metadata = veach::image_io::read_metadata(&out).unwrap();
        let spp = metadata.iter().find(|(k, _)| k.ends_with("spp")).map(|(_, v)| v.parse::<f64>().unwrap());
        assert_eq!(spp, Some(mean), "{limit}");
        // No row black where the scene is lit: rows whose 16-spp mean is clearly above zero (the
        // backdrop's) must have some light at the one or more samples taken. (The bottom row, a
        // sharp plate, averages 4e-4 and may be black at one sample by chance.)
        let (w, _, px) = veach::image_io::read_image(&out).unwrap();
        for (y, (row, lit)) in px.chunks(w as usize).zip(reference.chunks(w as usize)).enumerate() {
            let lit_mean = lit.iter().flatten().sum::<f32>() / (3 * w) as f32;
            if lit_mean > 0.01 {
                assert!(row.iter().flatten().any(|v| *v > 0.0), "{limit}: row {y} is black (lit: {lit_mean})");
            }
        }
    }
}

/// A reader that goes away (`| head -1`) costs the output lines it would have read, never the
/// render: veach finishes, writes its image and exits 0 instead of panicking on the broken pipe.
#[test]
fn a_closed_pipe_neither_panics_nor_loses_the_render() {
    let dir = out_dir();
    let out = dir.join("closed-pipe.png");
    let _ = std::fs::remove_file(&out);
    let bin = env!("CARGO_BIN_EXE_veach");
    let scene = assets("cornell-box.gltf");
    for (cmd, what) in [
        (
            format!(
                "'{bin}' render '{scene}' -o '{}' --width 16 --height 16 2>&1 | head -c 1 >/dev/null",
                out.display()
            ),
            "render",
        ),
        (format!("'{bin}' info '{scene}' | head -c 1 >/dev/null"), "info"),
    ] {
        // pipefail: the status is veach's, not head's.
        let o = Command::new("bash").args(["-o", "pipefail", "-c", &cmd]).output().unwrap();
        assert!(o.status.success(), "{what}: {:?} {}", o.status, stderr(&o));
    }
    assert!(veach::image_io::read_image(&out).is_ok(), "the render's image was not written");
}

/// --stats never overwrites the image it describes, the scene or a contribution image.
#[test]
fn stats_may_not_overwrite_an_input_or_output() {
    let dir = out_dir();
    let scene_copy = dir.join("stats-scene.gltf");
    std::fs::copy(assets("cornell-box.gltf"), &scene_copy).unwrap();
    let scene_before = std::fs::read(&scene_copy).unwrap();
    let out = dir.join("stats-clash.png");
    let out_str = out.to_str().unwrap();
    let dotted = dir.join(".").join("stats-clash.png");
    let aov = dir.join("stats-clash.light.png");
    for (stats, what) in [
        (out_str.to_owned(), "output image"),
        (dotted.to_str().unwrap().to_owned(), "output image"),
        (scene_copy.to_str().unwrap().to_owned(), "scene"),
        (aov.to_str().unwrap().to_owned(), "contribution image"),
    ] {
        let o = veach(&[
            "render",
            scene_copy.to_str().unwrap(),
            "-o",
            out_str,
            "--width",
            "8",
            "--height",
            "8",
            "--aov",
            "light",
            "--stats",
            &stats,
        ]);
        assert!(!o.status.success(), "{what}: accepted");
        assert!(stderr(&o).contains("would overwrite") && stderr(&o).contains(what), "{what}: {}", stderr(&o));
    }
    assert_eq!(std::fs::read(&scene_copy).unwrap(), scene_before);
}

/// Temporary files are named by veach, short whatever the output's name (a 249-character name
/// was refused), and those a killed veach left behind are removed by the next write there.
#[test]
fn temporary_files_are_short_and_stale_ones_are_cleaned() {
    let dir = out_dir().join("temp-files");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // A process id that runs no process (above Linux's pid_max of 2^22).
    let stale = dir.join(".veach-partial-4999999-0.tmp");
    std::fs::write(&stale, b"half a file").unwrap();
    let long_name = format!("{}.png", "x".repeat(245));
    let out = dir.join(&long_name);
    let o =
        veach(&["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), "--width", "8", "--height", "8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names, vec![long_name], "left in the folder");
}

/// SIGTERM stops a render as Ctrl-C does: the pass in flight ends, the image is written, and no
/// temporary file is left.
#[cfg(unix)]
#[test]
fn sigterm_writes_the_samples_taken() {
    let dir = out_dir().join("sigterm");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("terminated.exr");
    let stats = dir.join("terminated.json");
    let child = Command::new(env!("CARGO_BIN_EXE_veach"))
        .args(["render", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), "--width", "32", "--height", "32"])
        .args(["--spp", "1000000", "--stats", stats.to_str().unwrap()])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Until the render has started (its kernel compiled and a pass under way).
    std::thread::sleep(std::time::Duration::from_secs(4));
    let killed = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{:?}: {}", o.status, stderr(&o));
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(s["interrupted"], true);
    let min = s["samples_per_pixel"]["min"].as_u64().unwrap();
    assert!(min >= 1 && s["samples_per_pixel"]["mean"].as_f64().unwrap() == min as f64, "{s}");
    assert!(veach::image_io::read_image(&out).is_ok());
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

/// An outside reference shows emitters seen directly (as Mitsuba's or pbrt's renders do): by
/// default the bench renders them too. With --hide-emitters it leaves them out of its images; a
/// reference that leaves them out too is then met (the error falls as 1 / samples, no warning),
/// one that shows them is not, and the warning says the error levels off instead of diagnosing
/// infinite variance. A PNG is no reference (display values).
#[test]
fn the_bench_renders_what_an_outside_reference_shows() {
    let dir = out_dir().join("outside-reference");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let size = ["--width", "48", "--height", "48"];
    let reference = |name: &str, extra: &[&str]| -> String {
        let path = dir.join(name).to_str().unwrap().to_owned();
        let o =
            veach(&[&["render", &assets("cornell-box.gltf"), "-o", &path, "--spp", "1024"][..], &size, extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        path
    };
    let (shown, hidden) = (reference("shown.exr", &[]), reference("hidden.exr", &["--hide-emitters"]));
    // (relMSE of mis-balance at 1 and at 32 spp, the brightest pixel of any image, what it said)
    let bench = |out: &str, reference: &str, extra: &[&str]| {
        let out = dir.join(out);
        let o = veach(
            &[
                &["bench", &assets("cornell-box.gltf"), "-o", out.to_str().unwrap(), "--reference", reference][..],
                &size,
                &["--max-spp", "32", "--seeds", "3", "--strategies", "mis-balance,light"],
                extra,
            ]
            .concat(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
        let rows: Vec<Vec<String>> = csv.lines().skip(1).map(|l| l.split(',').map(str::to_owned).collect()).collect();
        let median_relmse = |budget: &str| -> f64 {
            let mut v: Vec<f64> = rows
                .iter()
                .filter(|r| r[1] == "mis-balance" && r[2] == budget)
                .map(|r| r[6].parse().unwrap())
                .collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let brightest = rows.iter().map(|r| r[10].parse::<f64>().unwrap()).fold(0.0, f64::max);
        let said = String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o);
        let of_mis = said.lines().filter(|l| l.contains("mis-balance")).collect::<Vec<_>>().join("\n");
        (median_relmse("1spp"), median_relmse("32spp"), brightest, of_mis)
    };
    // The Cornell box's light has radiance 17 (red): pixels that see it are far above any lit wall.
    let (_, _, brightest, _) = bench("default", &shown, &[]);
    assert!(brightest > 5.0, "no image showed the light: brightest pixel {brightest}");
    let (first, last, brightest_hidden, said) = bench("both-hidden", &hidden, &["--hide-emitters"]);
    assert!(brightest_hidden < 5.0, "an image showed the light: brightest pixel {brightest_hidden}");
    // 32 times the samples: a 32th of the variance (Sobol points do better), with room for the
    // reference's own error and three seeds' spread.
    assert!(last < first / 8.0, "relMSE {first:.3e} at 1 spp, {last:.3e} at 32 spp");
    assert!(!said.contains("warning"), "{said}");
    let (first, last, _, said) = bench("mismatched", &shown, &["--hide-emitters"]);
    assert!(last > first / 8.0, "relMSE {first:.3e} at 1 spp, {last:.3e} at 32 spp");
    assert!(said.contains("levels off") && !said.contains("infinite variance"), "{said}");

    let png = dir.join("reference.png");
    let o = veach(&[&["render", &assets("cornell-box.gltf"), "-o", png.to_str().unwrap()][..], &size].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = veach(&[&["bench", &assets("cornell-box.gltf"), "--reference", png.to_str().unwrap()][..], &size].concat());
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("reference.png") && stderr(&o).contains("linear"),
        "{}",
        stderr(&o)
    );
}

/// Without --strategy a render takes the defaults measured on the scene zoo (MIS 1 + 1, the power
/// heuristic, lights by the light tree, 32 spp); naming a strategy gives the classic comparison's settings
/// (MIS 32 + 32, every light, the balance heuristic, 1 spp); a flag given replaces its part.
#[test]
fn defaults_are_the_zoos_and_named_strategies_the_classic_ones() {
    let dir = out_dir();
    let settings_of = |name: &str, extra: &[&str]| -> serde_json::Value {
        let (out, stats) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.json")));
        let o = veach(
            &[
                &[
                    "render",
                    &assets("cornell-box.gltf"),
                    "-o",
                    out.to_str().unwrap(),
                    "--stats",
                    stats.to_str().unwrap(),
                ][..],
                &["--width", "8", "--height", "8"],
                extra,
            ]
            .concat(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        serde_json::json!({ "settings": s["settings"], "spp": s["samples_per_pixel"]["requested"] })
    };
    let expect =
        |v: &serde_json::Value, light: u64, brdf: u64, heuristic: &str, selection: &str, sampling: &str, spp: u64| {
            let s = &v["settings"];
            assert_eq!(
                (
                    &s["strategy"],
                    &s["light_samples"],
                    &s["brdf_samples"],
                    &s["heuristic"],
                    &s["light_selection"],
                    &s["light_sampling"],
                    &v["spp"]
                ),
                (
                    &serde_json::json!("mis"),
                    &serde_json::json!(light),
                    &serde_json::json!(brdf),
                    &serde_json::json!(heuristic),
                    &serde_json::json!(selection),
                    &serde_json::json!(sampling),
                    &serde_json::json!(spp)
                ),
                "{v}"
            );
        };
    expect(&settings_of("defaults", &[]), 1, 1, "power", "tree", "auto", 32);
    expect(&settings_of("named-mis", &["--strategy", "mis"]), 32, 32, "balance", "each", "area", 1);
    let bsdf = settings_of("defaults-bsdf", &["--light-selection", "bsdf", "--spp", "2"]);
    expect(&bsdf, 1, 1, "power", "bsdf", "auto", 2);
    let cone = settings_of("named-cone", &["--strategy", "mis", "--light-sampling", "cone"]);
    expect(&cone, 32, 32, "balance", "each", "cone", 1);
}

/// A render split into ranges of camera samples and merged is the render of all of them: the
/// same samples, summed in another order (f32 sums per part on the GPU, f64 in the merge), so
/// the difference is float rounding, relMSE orders of magnitude below 1e-10 (one sample's noise
/// at 64 spp is relMSE ~1e-2). A merge that dropped or doubled a part, or parts that took the
/// wrong samples, would be off by the noise itself.
#[test]
fn a_merge_of_sample_ranges_is_the_whole_render() {
    let dir = out_dir().join("merge");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = assets("veach-mis.gltf");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_owned();
    // A render of samples first..first+spp into `name`, of `scene_file` with `extra` options.
    let render_of = |scene_file: &str, name: &str, first: &str, spp: &str, extra: &[&str]| {
        let out = path(name);
        let mut args = vec![
            "render",
            scene_file,
            "-o",
            &out,
            "--width",
            "96",
            "--height",
            "64",
            "--first-sample",
            first,
            "--spp",
            spp,
            "-q",
        ];
        args.extend(extra);
        let o = veach(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let render = |name: &str, first: &str, spp: &str| render_of(&scene, name, first, spp, &[]);
    render("whole.exr", "0", "64");
    render("a.exr", "0", "16");
    render("b.exr", "16", "24");
    render("c.exr", "40", "24");
    let o = veach(&[
        "merge",
        &path("c.exr"),
        &path("a.exr"),
        &path("b.exr"),
        "-o",
        &path("merged.exr"),
        "--expect-spp",
        "64",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, whole) = veach::image_io::read_image(Path::new(&path("whole.exr"))).unwrap();
    let (_, _, merged) = veach::image_io::read_image(Path::new(&path("merged.exr"))).unwrap();
    let (_, _, first) = veach::image_io::read_image(Path::new(&path("a.exr"))).unwrap();
    let relmse = veach_bench::bench::error_metrics(&merged, &whole).relmse;
    assert!(relmse < 1e-10, "merged against whole: relMSE {relmse:e}");
    // The check has teeth: a part alone is the noise of its own samples away.
    let part_relmse = veach_bench::bench::error_metrics(&first, &whole).relmse;
    assert!(part_relmse > 1e-6, "samples 0..16 against 0..64: relMSE {part_relmse:e}");
    let header = veach::image_io::read_metadata(Path::new(&path("merged.exr"))).unwrap();
    let value = |k: &str| header.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    assert_eq!(value("veach:first_sample").as_deref(), Some("0"));
    assert_eq!(value("veach:spp").as_deref(), Some("64.000"));
    assert_eq!(value("veach:merged_parts").as_deref(), Some("3"));

    // A missing part, an overlap, another seed or another scene: refused, naming what is wrong,
    // and the output is left as it was.
    let before = std::fs::read(path("merged.exr")).unwrap();
    render_of(&scene, "seed1.exr", "16", "24", &["--seed", "1"]);
    render_of(&assets("cornell-box.gltf"), "other.exr", "16", "24", &[]);
    for (parts, expect, says) in [
        (vec!["a.exr", "c.exr"], None, "samples 16..40 are missing"),
        (vec!["a.exr", "b.exr"], Some("64"), "samples 40..64 are missing"),
        (vec!["b.exr", "c.exr"], None, "samples 0..16 are missing"),
        (vec!["a.exr", "b.exr", "b.exr", "c.exr"], None, "overlap"),
        (vec!["a.exr", "seed1.exr", "c.exr"], None, "veach:seed is \"0\" against \"1\""),
        (vec!["a.exr", "other.exr", "c.exr"], None, "veach:scene_hash"),
    ] {
        let mut args: Vec<String> = vec!["merge".into()];
        args.extend(parts.iter().map(|p| path(p)));
        args.extend(["-o".into(), path("merged.exr")]);
        if let Some(n) = expect {
            args.extend(["--expect-spp".into(), n.into()]);
        }
        let o = veach(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(!o.status.success(), "{parts:?} merged");
        assert!(stderr(&o).contains(says), "{parts:?}: {}", stderr(&o));
    }
    assert_eq!(std::fs::read(path("merged.exr")).unwrap(), before, "a refused merge changed the output");
}

/// A bench split into tasks (`--task I/N`, one per job of an array) merges into one results.csv
/// and report.md with every scene; a missing task is named with its scenes.
#[test]
fn a_split_bench_merges_into_one_report() {
    let dir = out_dir().join("bench-split");
    let _ = std::fs::remove_dir_all(&dir);
    let scenes = [assets("cornell-box.gltf"), assets("textured.gltf")];
    let task_dir = |i: u32| dir.join(format!("task{i}")).to_str().unwrap().to_owned();
    for i in 0..2 {
        let task = format!("{i}/2");
        let o = veach(&[
            "bench",
            &scenes[0],
            &scenes[1],
            "--task",
            &task,
            "-o",
            &task_dir(i),
            "--width",
            "16",
            "--height",
            "16",
            "--max-spp",
            "1",
            "--seeds",
            "1",
            "--strategies",
            "light",
            "--reference-spp",
            "16",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let merged = dir.join("merged").to_str().unwrap().to_owned();
    let o = veach(&["bench", "--merge", &task_dir(1), "-o", &merged]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("missing: task 0 of 2") && stderr(&o).contains("cornell-box.gltf"), "{}", stderr(&o));
    let o = veach(&["bench", "--merge", &task_dir(1), &task_dir(0), "-o", &merged]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.join("merged/results.csv")).unwrap();
    assert_eq!(csv.lines().filter(|l| l.starts_with("scene,")).count(), 1, "{csv}");
    for scene in ["cornell-box", "textured"] {
        assert!(csv.lines().any(|l| l.starts_with(&format!("{scene},light,"))), "{scene} rows missing:\n{csv}");
    }
    let report = std::fs::read_to_string(dir.join("merged/report.md")).unwrap();
    let sections: Vec<&str> = report.lines().filter(|l| l.starts_with("## ")).collect();
    assert_eq!(sections, ["## cornell-box", "## textured"], "{report}");
    assert!(dir.join("merged/textured-relmse.svg").exists());
}

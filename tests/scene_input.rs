//! Scene loading: what a glTF file turns into, and bad files giving errors that name the file
//! and the problem, never a panic. No GPU needed.

use glam::Vec3;
use serde_json::json;
use std::path::{Path, PathBuf};
use veach::assets::gltf_writer::{GltfBuilder, MaterialDesc, MeshData, Punctual};
use veach::scene::LightKind;

fn dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("veach-tests").join("scene-input");
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_json(name: &str, v: &serde_json::Value) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, serde_json::to_vec_pretty(v).unwrap()).unwrap();
    p
}

/// A valid one-triangle file as JSON, for tests to break in one place.
fn triangle_json() -> serde_json::Value {
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("grey", Vec3::splat(0.5)));
    let tri =
        MeshData { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, uvs: None, indices: vec![0, 1, 2] };
    g.add_mesh("tri", &tri, m, glam::Mat4::IDENTITY);
    g.to_json()
}

fn load_err(path: &Path) -> String {
    match veach::load_gltf(path) {
        Ok(_) => panic!("{} loaded, expected an error", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_valid_file_loads_with_transforms_materials_and_lights() {
    let mut g = GltfBuilder::new();
    let light =
        g.material(&MaterialDesc { double_sided: true, ..MaterialDesc::emitter("lamp", Vec3::new(2.0, 4.0, 8.0)) });
    let tri =
        MeshData { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, uvs: None, indices: vec![0, 1, 2] };
    g.add_mesh(
        "lamp",
        &tri,
        light,
        glam::Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0)) * glam::Mat4::from_scale(Vec3::splat(2.0)),
    );
    g.punctual_light("spot", Punctual::Spot { inner: 0.1, outer: 0.4 }, Vec3::splat(5.0), Vec3::Y, Vec3::ZERO);
    g.camera("cam", Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 30.0);
    let p = dir().join("valid.gltf");
    g.write(&p).unwrap();
    let scene = veach::load_gltf(&p).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    let t = &scene.triangles[0];
    assert_eq!(t.p, [Vec3::new(0., 0., 3.), Vec3::new(2., 0., 3.), Vec3::new(0., 2., 3.)]);
    let m = &scene.materials[t.material as usize];
    assert!((m.emission - Vec3::new(2.0, 4.0, 8.0)).length() < 1e-5, "emission × strength: {:?}", m.emission);
    assert!(m.double_sided);
    assert_eq!(scene.lights.len(), 2);
    assert!(
        matches!(scene.lights[0].kind, LightKind::Area { ref triangles, double_sided: true, .. } if triangles == &[0])
    );
    let LightKind::Spot { position, direction, intensity, inner_cone, outer_cone } = scene.lights[1].kind else {
        panic!("expected a spot light")
    };
    assert!((position - Vec3::Y).length() < 1e-6 && (direction + Vec3::Y).length() < 1e-5);
    assert_eq!((intensity, inner_cone, outer_cone), (Vec3::splat(5.0), 0.1, 0.4));
    let cam = scene.camera(Some("cam")).unwrap();
    assert!((cam.forward + Vec3::Z).length() < 1e-5 && (cam.yfov.to_degrees() - 30.0).abs() < 1e-4);
    assert!(scene.camera(Some("nope")).unwrap_err().contains("'cam'"));
}

#[test]
fn mirroring_transforms_keep_the_front_face() {
    let mut v = triangle_json();
    v["nodes"][0]["matrix"] = json!([-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    let scene = veach::load_gltf(&write_json("mirrored.gltf", &v)).unwrap();
    // The triangle faced +Z; mirrored in x it still faces +Z.
    assert!((scene.triangles[0].geometric_normal() - Vec3::Z).length() < 1e-6);
}

#[test]
fn uv_spheres_face_outward() {
    let m = MeshData::sphere(Vec3::new(1.0, 2.0, 3.0), 0.5, 12, 6);
    for t in m.indices.chunks(3) {
        let p = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let c = (p[0] + p[1] + p[2]) / 3.0 - Vec3::new(1.0, 2.0, 3.0);
        assert!(n.dot(c) > 0.0, "inward-facing triangle {t:?}");
    }
}

#[test]
fn non_triangle_modes_are_an_error_naming_the_mesh() {
    let mut v = triangle_json();
    v["meshes"][0]["primitives"][0]["mode"] = json!(1); // LINES
    let e = load_err(&write_json("lines.gltf", &v));
    assert!(e.contains("lines.gltf") && e.contains("mesh 'tri'") && e.contains("Lines"), "{e}");
}

#[test]
fn triangle_strips_and_fans_are_triangulated() {
    for (mode, name) in [(5, "strip"), (6, "fan")] {
        let mut v = triangle_json();
        v["meshes"][0]["primitives"][0]["mode"] = json!(mode);
        let scene = veach::load_gltf(&write_json(&format!("{name}.gltf"), &v)).unwrap();
        assert_eq!(scene.triangles.len(), 1, "{name}");
        assert!((scene.triangles[0].geometric_normal() - Vec3::Z).length() < 1e-6, "{name} winding");
    }
}

#[test]
fn missing_positions_are_an_error_naming_the_mesh() {
    let mut v = triangle_json();
    v["meshes"][0]["primitives"][0]["attributes"] = json!({});
    let e = load_err(&write_json("no-positions.gltf", &v));
    assert!(e.contains("mesh 'tri'") && e.contains("POSITION"), "{e}");
}

#[test]
fn out_of_range_indices_are_an_error_naming_the_mesh() {
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("grey", Vec3::splat(0.5)));
    let tri =
        MeshData { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, uvs: None, indices: vec![0, 1, 7] };
    g.add_mesh("broken", &tri, m, glam::Mat4::IDENTITY);
    let p = dir().join("bad-index.gltf");
    g.write(&p).unwrap();
    let e = load_err(&p);
    assert!(e.contains("mesh 'broken'") && e.contains("index 7") && e.contains("3 vertices"), "{e}");
}

#[test]
fn accessors_past_the_end_of_their_buffer_are_an_error() {
    let mut v = triangle_json();
    v["accessors"][0]["count"] = json!(1000);
    let e = load_err(&write_json("long-accessor.gltf", &v));
    assert!(e.contains("long-accessor.gltf") && e.contains("POSITION"), "{e}");
}

#[test]
fn unreadable_files_are_errors_naming_the_file() {
    let e = load_err(Path::new("/nonexistent/scene.gltf"));
    assert!(e.contains("/nonexistent/scene.gltf") && e.contains("cannot read"), "{e}");
    let p = dir().join("garbage.glb");
    std::fs::write(&p, b"glTF\x02\x00\x00\x00garbage").unwrap();
    assert!(load_err(&p).contains("garbage.glb"));
    let p = dir().join("missing-buffer.gltf");
    let mut v = triangle_json();
    v["buffers"][0]["uri"] = json!("does-not-exist.bin");
    std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
    let e = load_err(&p);
    assert!(e.contains("missing-buffer.gltf") && e.contains("buffer"), "{e}");
}

/// Every file of the Khronos glTF-Validator corpus (many invalid on purpose) must load or fail
/// with an error: no panic, no hang.
#[test]
fn the_gltf_validator_corpus_never_panics() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/testdata/gltf-validator");
    if !root.exists() {
        eprintln!("skipped: {} is absent", root.display());
        return;
    }
    let mut files = Vec::new();
    let mut stack = vec![root];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                files.push(p);
            }
        }
    }
    assert!(files.len() > 100, "corpus looks incomplete: {} files", files.len());
    let (mut ok, mut err) = (0, 0);
    for f in &files {
        let result = std::panic::catch_unwind(|| veach::load_gltf(f));
        match result {
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) => {
                assert!(
                    e.to_string().contains(f.file_name().unwrap().to_str().unwrap()),
                    "error does not name the file: {e}"
                );
                err += 1
            }
            Err(_) => panic!("panic while loading {}", f.display()),
        }
    }
    eprintln!("glTF-Validator corpus: {} files, {ok} loaded, {err} rejected with an error", files.len());
}

/// Emission so bright that a sample's square overflows f32 renders dark (those samples are
/// dropped): the loader says so, naming the material, and stays quiet at ordinary levels.
#[test]
fn emission_beyond_f32_sums_is_a_warning_naming_the_material() {
    let mut v = triangle_json();
    v["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    v["materials"][0]["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": 1e20 } });
    v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    let scene = veach::load_gltf(&write_json("too-bright.gltf", &v)).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("material 'grey'") && w.contains("1e20")), "{:?}", scene.warnings);
    v["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] = json!(1e9);
    let scene = veach::load_gltf(&write_json("bright.gltf", &v)).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn a_field_of_view_outside_the_specification_is_a_warning_naming_the_camera() {
    let mut v = triangle_json();
    v["cameras"] = json!([{ "name": "wide", "type": "perspective", "perspective": { "yfov": 4.0, "znear": 0.01 } }]);
    v["nodes"].as_array_mut().unwrap().push(json!({ "camera": 0 }));
    let n = v["nodes"].as_array().unwrap().len() - 1;
    v["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(n));
    let scene = veach::load_gltf(&write_json("wide-camera.gltf", &v)).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("camera 'wide'") && w.contains("yfov 4")), "{:?}", scene.warnings);
    assert!(scene.cameras[0].yfov < std::f32::consts::PI);
}

/// Factors outside their specified ranges are clamped, and the clamping is named at load.
#[test]
fn material_factors_outside_their_ranges_are_warnings_naming_the_material() {
    let mut v = triangle_json();
    v["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = json!(1.5);
    v["materials"][0]["emissiveFactor"] = json!([-1.0, 0.0, 0.0]);
    v["materials"][0]["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": -2.0 } });
    v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    let scene = veach::load_gltf(&write_json("out-of-range.gltf", &v)).unwrap();
    let w = scene.warnings.join("\n");
    assert!(w.contains("material 'grey': roughnessFactor [1.5] is outside its range ([0, 1]); clamped"), "{w}");
    assert!(w.contains("material 'grey': emissiveFactor [-1.0, 0.0, 0.0]"), "{w}");
    assert!(w.contains("emissiveStrength [-2.0] is outside its range (at least 0)"), "{w}");
    assert!(!w.contains("metallicFactor") && !w.contains("baseColorFactor"), "{w}");
    assert_eq!(scene.materials[0].roughness, 1.0);
}

/// Material features veach leaves out are named at load, not dropped silently.
#[test]
fn transparency_and_unsupported_material_extensions_are_warnings_naming_the_material() {
    let mut v = triangle_json();
    v["materials"][0]["alphaMode"] = json!("BLEND");
    v["materials"][0]["extensions"] = json!({ "KHR_materials_transmission": { "transmissionFactor": 1.0 } });
    v["extensionsUsed"] = json!(["KHR_materials_transmission"]);
    let scene = veach::load_gltf(&write_json("glass.gltf", &v)).unwrap();
    let w = scene.warnings.join("\n");
    assert!(w.contains("material 'grey': alphaMode Blend"), "{w}");
    assert!(w.contains("material 'grey': KHR_materials_transmission not supported"), "{w}");
    let scene = veach::load_gltf(&write_json("opaque.gltf", &triangle_json())).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

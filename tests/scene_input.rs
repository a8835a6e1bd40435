//! Scene loading: what a glTF file turns into, and bad files giving errors that name the file
//! and the problem, never a panic. No GPU needed.

use glam::Vec3;
use serde_json::json;
use std::path::{Path, PathBuf};
use veach::scene::LightKind;
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData, Punctual};

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

/// `triangle_json`'s buffer written to `bin` beside the file (and the JSON pointing at it), with
/// `extra` bytes after its declared length.
fn with_external_buffer(v: &mut serde_json::Value, bin: &str, extra: usize) {
    use base64::Engine;
    let uri = v["buffers"][0]["uri"].as_str().unwrap().to_owned();
    let payload = uri.split_once(";base64,").unwrap().1;
    let mut bytes = base64::engine::general_purpose::STANDARD.decode(payload).unwrap();
    bytes.extend(std::iter::repeat_n(7u8, extra));
    std::fs::write(dir().join(bin), bytes).unwrap();
    v["buffers"][0]["uri"] = json!(bin);
}

/// A buffer is read up to its byteLength and no further: a URI naming an endless device loads
/// (with a warning that it holds more) instead of filling memory, and a missing file is named.
#[test]
fn buffers_are_read_to_their_declared_length() {
    let mut v = triangle_json();
    v["buffers"][0]["uri"] = json!("/dev/zero");
    let p = write_json("dev-zero.gltf", &v);
    let start = std::time::Instant::now();
    let scene = veach::load_gltf(&p).unwrap();
    assert!(start.elapsed() < std::time::Duration::from_secs(5));
    assert!(scene.warnings.iter().any(|w| w.contains("buffer 0") && w.contains("more than")), "{:?}", scene.warnings);

    let mut v = triangle_json();
    with_external_buffer(&mut v, "longer.bin", 16);
    let scene = veach::load_gltf(&write_json("longer-buffer.gltf", &v)).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert!(
        scene.warnings.iter().any(|w| w.contains("longer.bin") && w.contains("byteLength")),
        "{:?}",
        scene.warnings
    );

    let mut v = triangle_json();
    with_external_buffer(&mut v, "exact.bin", 0);
    let scene = veach::load_gltf(&write_json("exact-buffer.gltf", &v)).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    let mut v = triangle_json();
    v["buffers"][0]["uri"] = json!("no-such-file.bin");
    let e = load_err(&write_json("missing-bin.gltf", &v));
    assert!(e.contains("missing-bin.gltf") && e.contains("no-such-file.bin") && e.contains("buffer 0"), "{e}");
}

/// 41 nodes, each listing the next as its child twice, place 2^40 instances: refused at once.
#[test]
fn hierarchies_that_multiply_instances_are_refused() {
    let mut v = triangle_json();
    let mesh_node = v["nodes"][0].clone();
    let mut nodes = vec![mesh_node];
    for i in 1..=41 {
        nodes.push(json!({ "children": [i - 1, i - 1] }));
    }
    v["nodes"] = json!(nodes);
    v["scenes"] = json!([{ "nodes": [41] }]);
    v["scene"] = json!(0);
    let start = std::time::Instant::now();
    let e = load_err(&write_json("doubling-nodes.gltf", &v));
    assert!(start.elapsed() < std::time::Duration::from_secs(10));
    assert!(e.contains("doubling-nodes.gltf") && e.contains("node instances"), "{e}");
}

fn crc32(bytes: &[u8]) -> u32 {
    // CRC-32 (ISO 3309), as PNG chunks carry it (PNG specification §5.5).
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// A PNG's signature and IHDR for a `size` × `size` RGBA8 image, without pixel data: enough for a
/// reader of its dimensions.
fn png_header(size: u32) -> Vec<u8> {
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(size.to_be_bytes());
    ihdr.extend(size.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    // The first image data chunk (where readers stop reading the header), cut short, and the end.
    for chunk in [b"IDAT\x78\x9c".as_slice(), b"IEND"] {
        png.extend((chunk.len() as u32 - 4).to_be_bytes());
        png.extend(chunk);
        png.extend(crc32(chunk).to_be_bytes());
    }
    png
}

/// A textured triangle whose base colour texture is the image at `uri`.
fn textured_triangle_json(uri: &str) -> serde_json::Value {
    let mut v = triangle_json();
    v["images"] = json!([{ "uri": uri }]);
    v["textures"] = json!([{ "source": 0 }]);
    v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": 0 });
    v
}

/// Texture images: a missing file is named, and one too large says its size and the limit
/// before anything is decoded.
#[test]
fn texture_errors_name_the_image_and_the_limit() {
    let e = load_err(&write_json("missing-texture.gltf", &textured_triangle_json("no-such-image.png")));
    assert!(e.contains("missing-texture.gltf") && e.contains("no-such-image.png") && e.contains("texture 0"), "{e}");
    std::fs::write(dir().join("huge.png"), png_header(16384)).unwrap();
    let e = load_err(&write_json("huge-texture.gltf", &textured_triangle_json("huge.png")));
    assert!(e.contains("huge-texture.gltf") && e.contains("16384x16384") && e.contains("256 MiB"), "{e}");
}

/// Files that break the specification in ways a reader can still follow load with a warning
/// that says what is wrong: a byte-order mark, a GLB length that is not the file's, another
/// asset version, an index count that is not a multiple of 3, a negative light intensity.
#[test]
fn recoverable_flaws_are_warnings() {
    let warnings_of = |name: &str, bytes: &[u8]| -> Vec<String> {
        let p = dir().join(name);
        std::fs::write(&p, bytes).unwrap();
        veach::load_gltf(&p).unwrap_or_else(|e| panic!("{e}")).warnings
    };
    let has = |w: &[String], text: &str| assert!(w.iter().any(|w| w.contains(text)), "no '{text}' in {w:?}");

    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend(serde_json::to_vec(&triangle_json()).unwrap());
    has(&warnings_of("bom.gltf", &bom), "byte-order mark");

    // A GLB of the JSON alone whose header understates its length by 8 bytes; a file 8 bytes
    // shorter than its header says is an error that says so.
    let mut json_bytes = serde_json::to_vec(&triangle_json()).unwrap();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend((12 + 8 + json_bytes.len() as u32).to_le_bytes());
    glb.extend((json_bytes.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json_bytes);
    let mut understated = glb.clone();
    understated[8..12].copy_from_slice(&(glb.len() as u32 - 8).to_le_bytes());
    has(&warnings_of("understated-length.glb", &understated), "GLB header gives a length");
    let p = dir().join("cut-short.glb");
    std::fs::write(&p, &glb[..glb.len() - 8]).unwrap();
    let e = load_err(&p);
    assert!(e.contains("cut-short.glb") && e.contains("GLB header gives a length"), "{e}");

    let mut v = triangle_json();
    v["asset"]["version"] = json!("1.0");
    has(&warnings_of("version-1.gltf", &serde_json::to_vec(&v).unwrap()), "asset.version");

    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("grey", Vec3::splat(0.5)));
    let tri =
        MeshData { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: None, uvs: None, indices: vec![0, 1, 2, 0] };
    g.add_mesh("four indices", &tri, m, glam::Mat4::IDENTITY);
    has(&warnings_of("four-indices.gltf", &serde_json::to_vec(&g.to_json()).unwrap()), "not a multiple of 3");

    let mut g = GltfBuilder::new();
    g.punctual_light("dim", Punctual::Point, Vec3::splat(1.0), Vec3::Y, Vec3::ZERO);
    let mut v = g.to_json();
    v["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(-5.0);
    has(&warnings_of("negative-light.gltf", &serde_json::to_vec(&v).unwrap()), "negative");
}

/// Intensities beyond f32 (which would render black or poison the light choice) never reach the
/// renderer silently: a punctual light's is a warning and the light is left out; a material's
/// emission is an error naming it.
#[test]
fn light_beyond_f32_is_refused_or_left_out() {
    let mut g = GltfBuilder::new();
    g.punctual_light("sun in a box", Punctual::Point, Vec3::splat(1.0), Vec3::Y, Vec3::ZERO);
    let mut v = g.to_json();
    v["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(1e39);
    let scene = veach::load_gltf(&write_json("overflowing-light.gltf", &v)).unwrap();
    assert!(scene.lights.is_empty());
    assert!(
        scene.warnings.iter().any(|w| w.contains("sun in a box") && w.contains("overflows")),
        "{:?}",
        scene.warnings
    );

    let mut v = triangle_json();
    v["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    v["materials"][0]["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": 1e39 } });
    v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    let e = load_err(&write_json("overflowing-emission.gltf", &v));
    assert!(e.contains("overflowing-emission.gltf") && e.contains("grey") && e.contains("overflows"), "{e}");
}

//! A fuzz harness for the glTF loader, run as a test for a bounded time: valid files (the shipped
//! scenes, small generated ones, as .gltf and .glb) mutated by a seeded generator, in their JSON
//! (values swapped for extreme numbers, wrong types, other references), their binary buffers
//! (floats to NaN and infinities, indices past the end) and their bytes (flips, cuts). Every
//! mutant must load or fail with an error naming the file, in bounded time, and a scene that
//! loads must hold what the renderer relies on (finite positions, indices in range). A panic
//! inside the gltf crate's reader is caught by the loader and named as an error; one in veach's
//! own code fails the test.
//!
//! VEACH_FUZZ_SECONDS sets the budget (default 20 s); VEACH_FUZZ_SEED the generator's seed.
//! A failure names the mutant's index and keeps its file, so that it can be loaded again.

use base64::Engine;
use glam::{Mat4, Vec3};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use veach::scene::LightKind;
use veach_scenes::SplitMix64 as Rng;
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData, Punctual};

fn dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("veach-tests").join("fuzz-gltf");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The seeds: the shipped scenes and a scene with every kind of light, a camera and a texture.
fn seed_documents() -> Vec<Value> {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
    let mut docs: Vec<Value> = ["cornell-box.gltf", "textured.gltf"]
        .iter()
        .map(|f| serde_json::from_slice(&std::fs::read(assets.join(f)).unwrap()).unwrap())
        .collect();
    let mut g = GltfBuilder::new();
    let lamp = g.material(&MaterialDesc::emitter("lamp", Vec3::splat(5.0)));
    let metal = g.material(&MaterialDesc::metal("metal", Vec3::new(0.9, 0.6, 0.3), 0.3));
    g.add_mesh("ball", &MeshData::sphere(Vec3::ZERO, 1.0, 6, 4), metal, Mat4::IDENTITY);
    let quad = MeshData::quad(
        Vec3::new(-1., 2., -1.),
        Vec3::new(1., 2., -1.),
        Vec3::new(1., 2., 1.),
        Vec3::new(-1., 2., 1.),
        -Vec3::Y,
    );
    g.add_mesh("lamp", &quad, lamp, Mat4::from_rotation_y(0.3));
    g.punctual_light("point", Punctual::Point, Vec3::splat(3.0), Vec3::new(0., 3., 0.), Vec3::ZERO);
    g.punctual_light("spot", Punctual::Spot { inner: 0.2, outer: 0.5 }, Vec3::splat(3.0), Vec3::Y, Vec3::ZERO);
    g.punctual_light("sun", Punctual::Directional, Vec3::splat(1.0), Vec3::ONE, Vec3::ZERO);
    g.camera("camera", Vec3::new(0., 1., 4.), Vec3::ZERO, 50.0);
    docs.push(g.to_json());
    docs
}

/// The document as a GLB: its first buffer (a data URI) moved into the binary chunk.
fn to_glb(doc: &Value) -> Vec<u8> {
    let mut doc = doc.clone();
    let mut bin = Vec::new();
    if let Some((_, payload)) = doc["buffers"][0]["uri"].as_str().and_then(|uri| uri.split_once(";base64,")) {
        bin = base64::engine::general_purpose::STANDARD.decode(payload).unwrap_or_default();
        doc["buffers"][0].as_object_mut().unwrap().remove("uri");
    }
    let mut json_bytes = serde_json::to_vec(&doc).unwrap();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend((total as u32).to_le_bytes());
    glb.extend((json_bytes.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json_bytes);
    if !bin.is_empty() {
        glb.extend((bin.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(&bin);
    }
    glb
}

/// Every path to a value in the document (object keys and array indices).
fn paths(v: &Value, at: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                at.push(json!(k));
                paths(x, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(json!(i));
                paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn at_path<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k {
        Value::String(s) => &mut v[s.as_str()],
        Value::Number(n) => &mut v[n.as_u64().unwrap() as usize],
        _ => unreachable!(),
    })
}

/// A value a careless or hostile writer might put anywhere.
fn hostile_value(rng: &mut Rng, doc: &Value, all: &[Vec<Value>]) -> Value {
    match rng.below(13) {
        0 => json!(-1),
        1 => json!(0),
        2 => json!(1u64 << 31),
        3 => json!(u64::MAX),
        4 => json!(1e39),
        5 => json!(-1e39),
        6 => json!(1e-45),
        7 => json!("data:application/octet-stream;base64,AAAA"),
        // A file that never ends.
        11 => json!("/dev/zero"),
        8 => json!(null),
        9 => json!([]),
        10 => json!({}),
        // A value from elsewhere in the document: a wrong but well-formed reference.
        _ => {
            let mut copy = doc.clone();
            at_path(&mut copy, &all[rng.below(all.len())]).clone()
        }
    }
}

/// One mutant of `doc`, as the bytes of a .gltf or .glb file.
fn mutant(rng: &mut Rng, doc: &Value) -> (Vec<u8>, &'static str) {
    let mut doc = doc.clone();
    let mutations = 1 + rng.below(3);
    for _ in 0..mutations {
        match rng.below(3) {
            // A value in the JSON.
            0 => {
                let mut all = Vec::new();
                paths(&doc, &mut Vec::new(), &mut all);
                let path = all[1 + rng.below(all.len() - 1)].clone();
                let value = hostile_value(rng, &doc, &all);
                *at_path(&mut doc, &path) = value;
            }
            // Bytes of the binary buffer: a float to NaN or infinity, an index past the end.
            1 => {
                let Some(uri) = doc["buffers"][0]["uri"].as_str() else { continue };
                let Some((head, payload)) = uri.split_once(";base64,") else { continue };
                let mut bin = base64::engine::general_purpose::STANDARD.decode(payload).unwrap_or_default();
                if bin.len() < 4 {
                    continue;
                }
                let at = rng.below(bin.len() / 4) * 4;
                let word: u32 = match rng.below(4) {
                    0 => f32::NAN.to_bits(),
                    1 => f32::INFINITY.to_bits(),
                    2 => u32::MAX,
                    _ => rng.next_u64() as u32,
                };
                bin[at..at + 4].copy_from_slice(&word.to_le_bytes());
                let encoded = base64::engine::general_purpose::STANDARD.encode(&bin);
                doc["buffers"][0]["uri"] = json!(format!("{head};base64,{encoded}"));
            }
            // A buffer's declared length.
            _ => {
                if doc["buffers"][0].is_object() {
                    doc["buffers"][0]["byteLength"] = json!(rng.below(1 << 20));
                }
            }
        }
    }
    let glb = rng.below(3) == 0;
    let mut bytes = if glb { to_glb(&doc) } else { serde_json::to_vec(&doc).unwrap() };
    // Sometimes the bytes themselves: a flip, or a cut.
    match rng.below(6) {
        0 if !bytes.is_empty() => {
            let at = rng.below(bytes.len());
            bytes[at] ^= 1 << rng.below(8);
        }
        1 => bytes.truncate(rng.below(bytes.len())),
        _ => {}
    }
    (bytes, if glb { "glb" } else { "gltf" })
}

/// What the renderer relies on in a loaded scene.
fn check_scene(scene: &veach::Scene) -> Result<(), String> {
    for (i, t) in scene.triangles.iter().enumerate() {
        if !t.p.iter().all(|p| p.is_finite()) {
            return Err(format!("triangle {i} has a non-finite vertex"));
        }
        if t.material as usize >= scene.materials.len() {
            return Err(format!("triangle {i} has material {} of {}", t.material, scene.materials.len()));
        }
    }
    for l in &scene.lights {
        let ok = match &l.kind {
            LightKind::Area { triangles, radiance, .. } => {
                triangles.iter().all(|&t| (t as usize) < scene.triangles.len()) && radiance.is_finite()
            }
            LightKind::Point { position, intensity } => position.is_finite() && intensity.is_finite(),
            LightKind::Spot { position, direction, intensity, .. } => {
                position.is_finite() && direction.is_finite() && intensity.is_finite()
            }
            LightKind::Directional { direction, irradiance } => direction.is_finite() && irradiance.is_finite(),
        };
        if !ok {
            return Err(format!("light '{}' is out of range or not finite: {:?}", l.name, l.kind));
        }
    }
    for m in &scene.materials {
        if !m.emission.is_finite() {
            return Err(format!("material '{}' has non-finite emission", m.name));
        }
    }
    for t in &scene.textures {
        if t.texels.len() != t.width as usize * t.height as usize {
            return Err(format!("texture '{}' has {} texels for {}x{}", t.name, t.texels.len(), t.width, t.height));
        }
    }
    Ok(())
}

#[test]
fn mutated_gltf_files_load_or_fail_cleanly() {
    let seconds = std::env::var("VEACH_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(20.0);
    let seed = std::env::var("VEACH_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x6c74_6673u64);
    let docs = seed_documents();
    let mut rng = Rng(seed);
    let start = Instant::now();
    let (mut loaded, mut refused, mut reader_panics) = (0, 0, 0);
    let mut n = 0u64;
    while start.elapsed() < Duration::from_secs_f64(seconds) {
        let doc = &docs[rng.below(docs.len())];
        let (bytes, ext) = mutant(&mut rng, doc);
        let path = dir().join(format!("mutant-{n}.{ext}"));
        std::fs::write(&path, &bytes).unwrap();
        let began = Instant::now();
        let result = std::panic::catch_unwind(|| veach::load_gltf(&path));
        let took = began.elapsed();
        let what = format!("mutant {n} (seed {seed:#x}, {})", path.display());
        assert!(took < Duration::from_secs(10), "{what}: took {took:?}");
        match result {
            Err(_) => panic!("{what}: the loader panicked"),
            Ok(Ok(scene)) => {
                if let Err(e) = check_scene(&scene) {
                    panic!("{what}: loaded a scene the renderer cannot take: {e}");
                }
                loaded += 1;
            }
            Ok(Err(e)) => {
                let e = e.to_string();
                assert!(
                    e.contains(path.file_name().unwrap().to_str().unwrap()),
                    "{what}: error does not name the file: {e}"
                );
                if let Some(at) = e.split("failed on its contents (at ").nth(1) {
                    assert!(!at.contains("crates/veach"), "{what}: panicked in veach's own code: {e}");
                    reader_panics += 1;
                }
                refused += 1;
            }
        }
        let _ = std::fs::remove_file(&path);
        n += 1;
    }
    eprintln!(
        "{n} mutants in {seconds} s: {loaded} loaded, {refused} refused ({reader_panics} caught inside the gltf crate)"
    );
    assert!(n >= 50, "only {n} mutants in the budget");
    assert!(loaded > 0 && refused > 0, "the mutants are not varied enough: {loaded} loaded, {refused} refused");
}

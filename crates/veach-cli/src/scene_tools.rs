//! `veach info`, `veach generate` and `veach export-mitsuba`: a scene looked at, written, exported.

use crate::console::errln;
use crate::console::outln;
use anyhow::{Context, Result};
use std::path::Path;
use veach::RenderSettings;

pub fn info(path: &Path) -> Result<()> {
    if veach::image_io::ImageFormat::from_path(path).is_ok() {
        return image_info(path);
    }
    let scene = veach::load_gltf(path)?;
    let b = scene.bounds();
    outln!("{}", path.display());
    outln!("  triangles: {} ({} emissive)", scene.triangles.len(), scene.emissive_triangle_count());
    outln!("  bounds: {:?} .. {:?}", b.min.to_array(), b.max.to_array());
    outln!("  materials: {}", scene.materials.len());
    for m in &scene.materials {
        outln!(
            "    {}: base {:?} metallic {} roughness {} emission {:?}{}",
            m.name,
            m.base_color.to_array(),
            m.metallic,
            m.roughness,
            m.emission.to_array(),
            if m.double_sided { " double-sided" } else { "" }
        );
    }
    outln!("  lights: {}", scene.lights.len());
    let triangles = |l: &veach::scene::Light| match &l.kind {
        veach::scene::LightKind::Area { triangles, .. } => triangles.len(),
        _ => 0,
    };
    // The parts of a curved mesh (lights named "MESH part K": light_shape::light_parts) on one line.
    let mesh_of = |l: &veach::scene::Light| l.name.rsplit_once(" part ").map(|(mesh, _)| mesh.to_owned());
    let same_mesh =
        |a: &veach::scene::Light, b: &veach::scene::Light| mesh_of(a).is_some_and(|m| mesh_of(b) == Some(m));
    for group in scene.lights.chunk_by(same_mesh) {
        let l = &group[0];
        if group.len() > 1 {
            let tris: usize = group.iter().map(triangles).sum();
            outln!(
                "    {} ({} area lights, one per part, {tris} triangles)",
                mesh_of(l).unwrap_or_default(),
                group.len()
            );
        } else {
            let kind = match &l.kind {
                veach::scene::LightKind::Area { .. } => format!("area, {} triangles", triangles(l)),
                veach::scene::LightKind::Point { .. } => "point".into(),
                veach::scene::LightKind::Spot { .. } => "spot".into(),
                veach::scene::LightKind::Directional { .. } => "directional".into(),
            };
            outln!("    {} ({kind})", l.name);
        }
    }
    if !scene.textures.is_empty() {
        outln!("  textures: {}", scene.textures.len());
        for t in &scene.textures {
            let wrap = format!("{:?} x {:?}", t.wrap_s, t.wrap_t);
            let filter = if t.nearest { "nearest" } else { "bilinear" };
            outln!("    {}: {}x{}, {wrap}, {filter}", t.name, t.width, t.height);
        }
    }
    let features = veach::features::SceneFeatures::detect(&scene);
    outln!("  features: {}", features.describe());
    // Whether MIS renders of it may take --control-variate (the check `veach render` makes).
    let controlled = RenderSettings { control_variate: true, ..RenderSettings::recommended() };
    let emitters = scene.emissive_triangle_count() as u32;
    match veach::control_variate::check(&features, emitters, &controlled) {
        Ok(()) => outln!("  control variate: takes --control-variate"),
        Err(e) => outln!("  control variate: no ({e})"),
    }
    outln!("  cameras: {}", scene.cameras.len());
    for c in &scene.cameras {
        outln!("    '{}' at {:?}, yfov {:.1}°", c.name, c.position.to_array(), c.yfov.to_degrees());
    }
    for w in &scene.warnings {
        outln!("  warning: {w}");
    }
    Ok(())
}

/// An image's size and the `veach:*` settings in its header (`veach render` and the viewer write
/// them into EXR and PNG files): what it takes to render it again.
fn image_info(path: &Path) -> Result<()> {
    let (width, height, _) = veach::image_io::read_image(path)?;
    let metadata = veach::image_io::read_metadata(path)?;
    outln!("{}", path.display());
    outln!("  image: {width}x{height}");
    let settings: Vec<_> = metadata.iter().filter_map(|(n, v)| Some((n.strip_prefix("veach:")?, v))).collect();
    if settings.is_empty() {
        outln!("  no veach settings recorded (only EXR and PNG files written by veach carry them)");
    }
    for (name, value) in settings {
        outln!("  {name}: {value}");
    }
    Ok(())
}

pub fn export_mitsuba(path: &Path, output: &Path, camera: Option<&str>, round_lights_as_spheres: bool) -> Result<()> {
    let scene = veach::load_gltf(path)?;
    let camera = scene.camera(camera).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))?;
    veach_bench::mitsuba::export(&scene, &camera, output, round_lights_as_spheres)
        .with_context(|| format!("{}", path.display()))?;
    errln!("wrote {}", output.join("scene.xml").display());
    Ok(())
}

pub fn generate(name: &str, output: &Path, seed: u64) -> Result<()> {
    if name == "zoo" {
        return generate_zoo(output, seed);
    }
    let builder = veach_scenes::generate_scene(name).with_context(|| format!("unknown scene '{name}'"))?;
    builder.write(output).with_context(|| format!("cannot write {}", output.display()))?;
    errln!("wrote {}", output.display());
    Ok(())
}

/// The scene zoo of `seed` into folder `output`: NAME.gltf each, and zoo.csv (name, family, what).
fn generate_zoo(output: &Path, seed: u64) -> Result<()> {
    std::fs::create_dir_all(output).with_context(|| format!("cannot create {}", output.display()))?;
    let mut index = String::from("name,family,what\n");
    let scenes = veach_scenes::zoo::zoo(seed);
    for s in &scenes {
        let path = output.join(format!("{}.gltf", s.name));
        s.builder.write(&path).with_context(|| format!("cannot write {}", path.display()))?;
        index.push_str(&format!("{},{},\"{}\"\n", s.name, s.family, s.what));
    }
    let csv = output.join("zoo.csv");
    veach::image_io::write_atomically(&csv, |f| {
        use std::io::Write;
        f.write_all(index.as_bytes()).map_err(|e| e.to_string())
    })?;
    errln!("wrote {} scenes (seed {seed}) and {}", scenes.len(), csv.display());
    Ok(())
}

//! glTF 2.0 (.gltf and .glb) → `Scene`: every triangle primitive of every node of the default
//! scene with node transforms applied, metallic-roughness materials, emissive triangles as
//! area lights, KHR_lights_punctual lights and perspective cameras.

use super::{Camera, Light, LightKind, Material, Scene, Texture, TextureRef, Triangle, Wrap};
use crate::error::{Error, Result};
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::mesh::Mode;
use std::collections::HashMap;
use std::path::Path;

pub fn load_gltf(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::scene(path, format!("cannot read file: {e}")))?;
    // The gltf crate validates the JSON, and `check_accessor` the byte ranges we read; should a
    // malformed file still reach a panic inside the crate (its validator indexes unchecked in
    // places), report it as a bad file, without the panic message.
    match quiet_catch_unwind(|| load_gltf_bytes(path, &bytes)) {
        Some(result) => result,
        None => {
            // Where it failed, for a bug report (the fuzz test also tells the reader's code from ours).
            let at = CAUGHT_AT.with(|c| c.take());
            Err(Error::scene(path, format!("malformed glTF: the glTF reader failed on its contents (at {at})")))
        }
    }
}

thread_local! {
    static QUIET_PANICS: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// The source location of the last panic `quiet_catch_unwind` kept quiet on this thread.
    static CAUGHT_AT: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
}

/// catch_unwind that keeps the panic message off stderr, for this thread only.
fn quiet_catch_unwind<T>(f: impl FnOnce() -> T + std::panic::UnwindSafe) -> Option<T> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET_PANICS.with(|q| q.get()) {
                let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
                CAUGHT_AT.with(|c| *c.borrow_mut() = at);
            } else {
                previous(info);
            }
        }));
    });
    QUIET_PANICS.with(|q| q.set(true));
    let result = std::panic::catch_unwind(f);
    QUIET_PANICS.with(|q| q.set(false));
    result.ok()
}

/// "meshes[3]..." in a validation message → " (mesh 'name')", read from the raw JSON.
fn name_the_mesh(bytes: &[u8], message: &str) -> String {
    let Some(start) = message.find("meshes[") else {
        return String::new();
    };
    let digits: String = message[start + 7..].chars().take_while(char::is_ascii_digit).collect();
    let Ok(index) = digits.parse::<usize>() else {
        return String::new();
    };
    let json: Option<serde_json::Value> = if bytes.starts_with(b"glTF") {
        gltf::binary::Glb::from_slice(bytes).ok().and_then(|g| serde_json::from_slice(&g.json).ok())
    } else {
        serde_json::from_slice(bytes).ok()
    };
    match json.as_ref().and_then(|j| j["meshes"][index]["name"].as_str()) {
        Some(name) => format!(" (mesh '{name}')"),
        None => String::new(),
    }
}

/// The UTF-8 byte-order mark, which glTF 2.0 §3.1 forbids at the start of its JSON.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

fn load_gltf_bytes(path: &Path, bytes: &[u8]) -> Result<Scene> {
    let err = |m: String| Error::scene(path, m);
    let mut warnings = Vec::new();
    let bytes = match bytes.strip_prefix(UTF8_BOM) {
        Some(rest) => {
            warnings
                .push("the file starts with a UTF-8 byte-order mark, which glTF does not allow; read anyway".into());
            rest
        }
        None => bytes,
    };
    let length_mismatch = glb_length_mismatch(bytes);
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| {
        let message = e.to_string();
        let length = length_mismatch.as_ref().map(|w| format!(" ({w})")).unwrap_or_default();
        err(format!("not a valid glTF file: {message}{}{length}", name_the_mesh(bytes, &message)))
    })?;
    warnings.extend(length_mismatch.map(|w| format!("{w}; read anyway")));
    let version = &gltf.document.as_json().asset.version;
    if !version.starts_with("2.") {
        warnings.push(format!("asset.version is \"{version}\"; veach reads glTF 2.0, so parts may be misread"));
    }
    let base = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let (buffers, buffer_warnings) =
        super::gltf_resources::read_buffers(&gltf.document, base, gltf.blob.as_deref()).map_err(err)?;
    warnings.extend(buffer_warnings);
    let doc = &gltf.document;

    let mut scene = Scene { warnings, ..Scene::default() };
    // Material i of the file is materials[i]; the default material is appended at the end.
    let mut textures = TextureTable { path, base, buffers: &buffers, index: HashMap::new(), textures: Vec::new() };
    for m in doc.materials() {
        let material = convert_material(&m, &mut textures)?;
        if !material.emission.is_finite() {
            return Err(err(format!(
                "material '{}': emissiveFactor times emissiveStrength overflows f32 ({:?} x {})",
                material.name,
                m.emissive_factor(),
                m.emissive_strength().unwrap_or(1.0)
            )));
        }
        scene.warnings.extend(ignored_material_features(&m, &material.name));
        scene.warnings.extend(factors_outside_their_range(&m, &material.name));
        if let Some(w) = beyond_f32_sums(&format!("material '{}': emission", material.name), material.emission) {
            scene.warnings.push(w);
        }
        scene.materials.push(material);
    }
    scene.textures = textures.textures;
    let default_material = scene.materials.len() as u32;
    scene.materials.push(Material::default());

    let gltf_scene =
        doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| err("the file has no scene".into()))?;
    let mut loader = Loader { path, buffers: &buffers, scene: &mut scene, default_material, instances: 0 };
    for node in gltf_scene.nodes() {
        loader.visit(&node, Mat4::IDENTITY, 0)?;
    }
    Ok(scene)
}

/// A GLB's header states the file's whole length (glTF 2.0 §4.4.2); a file of another length was
/// cut short or has bytes appended.
fn glb_length_mismatch(bytes: &[u8]) -> Option<String> {
    if !bytes.starts_with(b"glTF") || bytes.len() < 12 {
        return None;
    }
    let declared = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize;
    (declared != bytes.len())
        .then(|| format!("the GLB header gives a length of {declared} bytes but the file has {}", bytes.len()))
}

/// The textures materials use, decoded once each (a glTF texture is an image + a sampler).
struct TextureTable<'a> {
    path: &'a Path,
    base: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    index: HashMap<usize, u32>,
    textures: Vec<Texture>,
}

impl TextureTable<'_> {
    fn texture(&mut self, t: &gltf::texture::Texture) -> Result<u32> {
        if let Some(&i) = self.index.get(&t.index()) {
            return Ok(i);
        }
        let image = t.source();
        let name = t.name().or(image.name()).map(str::to_owned).unwrap_or_else(|| format!("texture {}", t.index()));
        let data = super::gltf_resources::read_image(&image, self.base, self.buffers)
            .map_err(|e| Error::scene(self.path, format!("{name}: {e}")))?;
        let texels = rgba8(&data).ok_or_else(|| Error::scene(self.path, format!("{name}: the image is empty")))?;
        let sampler = t.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let texture = Texture {
            name,
            width: data.width,
            height: data.height,
            texels,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
        };
        let i = self.textures.len() as u32;
        self.textures.push(texture);
        self.index.insert(t.index(), i);
        Ok(i)
    }

    /// A textureInfo with its KHR_texture_transform (`transform` is the extension's JSON,
    /// read by hand where the gltf crate has no accessor, as for normalTexture).
    fn reference(
        &mut self,
        t: &gltf::texture::Texture,
        tex_coord: u32,
        transform: Option<&serde_json::Value>,
    ) -> Result<TextureRef> {
        let r = TextureRef::new(self.texture(t)?, tex_coord);
        let Some(x) = transform else { return Ok(r) };
        let pair = |key: &str, default: f32| -> Vec2 {
            x.get(key)
                .and_then(|v| v.as_array())
                .map(|a| {
                    let at = |i: usize| a.get(i).and_then(|v| v.as_f64()).map_or(default, |v| v as f32);
                    Vec2::new(at(0), at(1))
                })
                .unwrap_or(Vec2::splat(default))
        };
        let rotation = x.get("rotation").and_then(|v| v.as_f64()).unwrap_or(0.0) as f32;
        let mut r = r.with_transform(pair("offset", 0.0), rotation, pair("scale", 1.0));
        if let Some(set) = x.get("texCoord").and_then(|v| v.as_u64()) {
            r.tex_coord = set as u32;
        }
        Ok(r)
    }

    fn info(&mut self, info: Option<gltf::texture::Info>) -> Result<Option<TextureRef>> {
        let Some(info) = info else { return Ok(None) };
        let transform = info.extension_value("KHR_texture_transform").cloned();
        self.reference(&info.texture(), info.tex_coord(), transform.as_ref()).map(Some)
    }
}

/// Texels as RGBA8, channels missing from the image filled as a GPU would (0, 0, 1).
fn rgba8(d: &gltf::image::Data) -> Option<Vec<[u8; 4]>> {
    use gltf::image::Format;
    let n = d.width as usize * d.height as usize;
    if n == 0 {
        return None;
    }
    let (channels, bytes_per_channel) = match d.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let stride = channels * bytes_per_channel;
    if d.pixels.len() < n * stride {
        return None;
    }
    let channel = |px: &[u8], c: usize| -> u8 {
        let b = &px[c * bytes_per_channel..(c + 1) * bytes_per_channel];
        match bytes_per_channel {
            1 => b[0],
            2 => (u16::from_le_bytes([b[0], b[1]]) >> 8) as u8,
            _ => (f32::from_le_bytes([b[0], b[1], b[2], b[3]]).clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
        }
    };
    Some(
        d.pixels
            .chunks_exact(stride)
            .take(n)
            .map(|px| {
                let mut t = [0, 0, 0, 255];
                for (c, v) in t.iter_mut().enumerate().take(channels) {
                    *v = channel(px, c);
                }
                t
            })
            .collect(),
    )
}

fn convert_material(m: &gltf::Material, textures: &mut TextureTable) -> Result<Material> {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let (specular, specular_color) = match m.specular() {
        Some(s) => (s.specular_factor(), Vec3::from(s.specular_color_factor())),
        None => (1.0, Vec3::ONE),
    };
    let strength = m.emissive_strength().unwrap_or(1.0);
    Ok(Material {
        name: m.name().map(str::to_owned).unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0))),
        base_color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
        metallic: pbr.metallic_factor().clamp(0.0, 1.0),
        roughness: pbr.roughness_factor().clamp(0.0, 1.0),
        specular: specular.clamp(0.0, 1.0),
        specular_color: specular_color.max(Vec3::ZERO),
        emission: (Vec3::from(m.emissive_factor()) * strength).max(Vec3::ZERO),
        double_sided: m.double_sided(),
        base_color_texture: textures.info(pbr.base_color_texture())?,
        metallic_roughness_texture: textures.info(pbr.metallic_roughness_texture())?,
        emissive_texture: textures.info(m.emissive_texture())?,
        normal_texture: match m.normal_texture() {
            Some(n) => {
                let transform = n.extension_value("KHR_texture_transform").cloned();
                Some(textures.reference(&n.texture(), n.tex_coord(), transform.as_ref())?)
            }
            None => None,
        },
        normal_scale: m.normal_texture().map_or(1.0, |n| n.scale()),
    })
}

struct Loader<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    scene: &'a mut Scene,
    default_material: u32,
    /// Nodes visited so far: a node reached along several paths is an instance on each.
    instances: usize,
}

/// What a material asks for that veach's BRDF leaves out: transparency (alphaMode MASK or BLEND)
/// and material extensions other than emissive strength and specular (the gltf crate parses
/// those two; any other lands in `extensions()`), so that a scene that renders differently from
/// a full glTF viewer says why.
fn ignored_material_features(m: &gltf::Material, name: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => {}
        mode => warnings.push(format!("material '{name}': alphaMode {mode:?} is not supported; rendered opaque")),
    }
    if let Some(others) = m.extensions().filter(|e| !e.is_empty()) {
        let names: Vec<&str> = others.keys().map(String::as_str).collect();
        warnings.push(format!("material '{name}': {} not supported; ignored", names.join(", ")));
    }
    warnings
}

/// Material factors outside the ranges the specifications give them, which `convert_material`
/// clamps into range: glTF 2.0 §5.19 and §5.22 (base colour, metallic, roughness and emissive
/// factors in [0, 1]); KHR_materials_specular (specular factor in [0, 1], colour factor at least
/// 0); KHR_materials_emissive_strength (at least 0).
fn factors_outside_their_range(m: &gltf::Material, name: &str) -> Vec<String> {
    let pbr = m.pbr_metallic_roughness();
    let unit = (0.0, 1.0);
    let at_least_zero = (0.0, f32::INFINITY);
    let mut factors = vec![
        ("baseColorFactor", pbr.base_color_factor()[..3].to_vec(), unit),
        ("metallicFactor", vec![pbr.metallic_factor()], unit),
        ("roughnessFactor", vec![pbr.roughness_factor()], unit),
        ("emissiveFactor", m.emissive_factor().to_vec(), unit),
    ];
    if let Some(strength) = m.emissive_strength() {
        factors.push(("emissiveStrength", vec![strength], at_least_zero));
    }
    if let Some(specular) = m.specular() {
        factors.push(("specularFactor", vec![specular.specular_factor()], unit));
        factors.push(("specularColorFactor", specular.specular_color_factor().to_vec(), at_least_zero));
    }
    factors
        .into_iter()
        .filter(|(_, values, (low, high))| values.iter().any(|v| !(low..=high).contains(&v)))
        .map(|(factor, values, (low, high))| {
            let range = if high.is_finite() { format!("[{low}, {high}]") } else { format!("at least {low}") };
            format!("material '{name}': {factor} {values:?} is outside its range ({range}); clamped")
        })
        .collect()
}

/// Emission (and punctual lights' intensity) above this warns at load. The kernels accumulate each
/// pixel's samples and their squares in f32, and drop a sample whose square overflows (above about
/// 1.8e19, counted as non-finite), so an emitter near that level renders black where it shows; the
/// margin is for the estimator's factors (BRDF peaks, 1/r² near a light), which can exceed 1000.
pub const MAX_SAFE_EMISSION: f32 = 1e16;

fn beyond_f32_sums(what: &str, value: Vec3) -> Option<String> {
    let max = value.max_element();
    (max > MAX_SAFE_EMISSION).then(|| {
        format!(
            "{what} {max:e} is above {MAX_SAFE_EMISSION:e}: samples whose squares overflow f32 are dropped \
             (counted as non-finite), so expect dark pixels; scale the scene's emission down"
        )
    })
}

/// Node hierarchies deeper than this are treated as cycles (the validator rejects cycles, but
/// a file may skip validation-relevant data).
const MAX_NODE_DEPTH: usize = 256;

/// The most node instances a scene may have: a hierarchy where nodes share children multiplies
/// them (41 nodes, each the next one's parent twice over, make 2^40), so it is bounded.
pub const MAX_NODE_INSTANCES: usize = 1 << 20;

/// The most triangles a scene may have once its instances are placed: about 4 GiB of host memory
/// at 124 bytes a triangle, past the GPU's binding limits in any case.
pub const MAX_TRIANGLES: usize = 1 << 25;

impl Loader<'_> {
    fn err(&self, message: String) -> Error {
        Error::scene(self.path, message)
    }

    fn visit(&mut self, node: &gltf::Node, parent: Mat4, depth: usize) -> Result<()> {
        if depth > MAX_NODE_DEPTH {
            return Err(self.err(format!("node hierarchy deeper than {MAX_NODE_DEPTH} (a cycle?)")));
        }
        self.instances += 1;
        if self.instances > MAX_NODE_INSTANCES {
            return Err(self.err(format!(
                "the node hierarchy places more than {MAX_NODE_INSTANCES} node instances (nodes listed as children \
                 of several parents multiply); node {} was one too many",
                node.index()
            )));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let node_name = node.name().map(str::to_owned).unwrap_or_else(|| format!("node {}", node.index()));
        if let Some(mesh) = node.mesh() {
            self.add_mesh(&mesh, world, &node_name)?;
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world, &node_name);
        }
        if let Some(camera) = node.camera() {
            self.add_camera(&camera, world, &node_name);
        }
        for child in node.children() {
            self.visit(&child, world, depth + 1)?;
        }
        Ok(())
    }

    fn add_mesh(&mut self, mesh: &gltf::Mesh, world: Mat4, node_name: &str) -> Result<()> {
        let mesh_name = mesh.name().map(str::to_owned).unwrap_or_else(|| format!("mesh {}", mesh.index()));
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        // A mirroring transform turns counter-clockwise into clockwise: swap to keep the front.
        let mirrored = Mat3::from_mat4(world).determinant() < 0.0;
        for prim in mesh.primitives() {
            let what = format!("mesh '{mesh_name}' (node '{node_name}') primitive {}", prim.index());
            let positions_accessor = prim
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| self.err(format!("{what} has no POSITION attribute")))?;
            check_accessor(&positions_accessor, self.buffers).map_err(|m| self.err(format!("{what}: POSITION {m}")))?;
            let reader = prim.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| self.err(format!("{what}: POSITION cannot be read")))?
                .map(Vec3::from)
                .collect();
            let normals: Option<Vec<Vec3>> = match prim.get(&gltf::Semantic::Normals) {
                Some(acc) => {
                    check_accessor(&acc, self.buffers).map_err(|m| self.err(format!("{what}: NORMAL {m}")))?;
                    let n: Vec<Vec3> = reader.read_normals().map(|it| it.map(Vec3::from).collect()).unwrap_or_default();
                    (n.len() == positions.len()).then_some(n)
                }
                None => None,
            };
            let mut uv_sets: [Option<Vec<Vec2>>; 2] = [None, None];
            for (set, uvs) in uv_sets.iter_mut().enumerate() {
                if let Some(acc) = prim.get(&gltf::Semantic::TexCoords(set as u32)) {
                    check_accessor(&acc, self.buffers).map_err(|m| self.err(format!("{what}: TEXCOORD_{set} {m}")))?;
                    let read: Vec<Vec2> = reader
                        .read_tex_coords(set as u32)
                        .map(|it| it.into_f32().map(Vec2::from).collect())
                        .unwrap_or_default();
                    *uvs = (read.len() == positions.len()).then_some(read);
                }
            }
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => {
                    check_accessor(&acc, self.buffers).map_err(|m| self.err(format!("{what}: indices {m}")))?;
                    reader
                        .read_indices()
                        .ok_or_else(|| self.err(format!("{what}: indices cannot be read")))?
                        .into_u32()
                        .collect()
                }
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(self.err(format!(
                    "{what}: index {bad} is out of range (the primitive has {} vertices)",
                    positions.len()
                )));
            }
            let triangles = triangle_list(prim.mode(), &indices).map_err(|m| self.err(format!("{what}: {m}")))?;
            if prim.mode() == Mode::Triangles && !indices.len().is_multiple_of(3) {
                self.scene.warnings.push(format!(
                    "{what}: {} indices are not a multiple of 3; the last {} are ignored",
                    indices.len(),
                    indices.len() % 3
                ));
            }
            if self.scene.triangles.len() + triangles.len() > MAX_TRIANGLES {
                return Err(self.err(format!(
                    "{what}: the scene would have more than {MAX_TRIANGLES} triangles (instances counted)"
                )));
            }

            let material = prim.material().index().map(|i| i as u32).unwrap_or(self.default_material);
            let first_triangle = self.scene.triangles.len() as u32;
            for [a, b, c] in triangles {
                let (b, c) = if mirrored { (c, b) } else { (b, c) };
                let p = [a, b, c].map(|i| world.transform_point3(positions[i as usize]));
                let geometric = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                let n = match &normals {
                    Some(ns) => [a, b, c].map(|i| {
                        let n = (normal_matrix * ns[i as usize]).normalize_or_zero();
                        if n == Vec3::ZERO { geometric } else { n }
                    }),
                    None => [geometric; 3],
                };
                if p.iter().any(|v| !v.is_finite()) {
                    return Err(self.err(format!("{what}: a vertex position is not finite")));
                }
                let uv = uv_sets.each_ref().map(|set| match set {
                    Some(uvs) => [a, b, c].map(|i| uvs[i as usize]),
                    None => [Vec2::ZERO; 3],
                });
                self.scene.triangles.push(Triangle { p, n, uv, material });
            }
            let m = &self.scene.materials[material as usize];
            if m.is_emissive() {
                // Zero-area triangles cannot be sampled or hit: leave them out of the light.
                let tris: Vec<u32> = (first_triangle..self.scene.triangles.len() as u32)
                    .filter(|&t| self.scene.triangles[t as usize].area() > 0.0)
                    .collect();
                if tris.is_empty() {
                    continue;
                }
                // A curved mesh becomes a light per part (light_shape::light_parts says why).
                let parts = super::light_shape::light_parts(&super::light_shape::triangle_corners(self.scene, &tris));
                let name = format!("{mesh_name} (node '{node_name}') primitive {}", prim.index());
                for (k, part) in parts.iter().enumerate() {
                    self.scene.lights.push(Light {
                        name: if parts.len() > 1 { format!("{name} part {k}") } else { name.clone() },
                        kind: LightKind::Area {
                            triangles: tris[part.clone()].to_vec(),
                            radiance: m.emission,
                            double_sided: m.double_sided,
                        },
                    });
                }
            }
        }
        Ok(())
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light, world: Mat4, node_name: &str) {
        use gltf::khr_lights_punctual::Kind;
        let color = Vec3::from(light.color()).max(Vec3::ZERO) * light.intensity().max(0.0);
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
        let name = light.name().map(str::to_owned).unwrap_or_else(|| format!("light of node '{node_name}'"));
        // KHR_lights_punctual: intensity and color are at least zero.
        let at_least_zero = |v: f32| v >= 0.0;
        if !at_least_zero(light.intensity()) || !light.color().into_iter().all(at_least_zero) {
            self.scene.warnings.push(format!(
                "{name}: intensity {} with color {:?} is negative; the light emits nothing",
                light.intensity(),
                light.color()
            ));
        }
        if !color.is_finite() || !position.is_finite() {
            self.scene.warnings.push(format!(
                "{name}: its intensity or position overflows f32 (intensity {}); the light is left out",
                light.intensity()
            ));
            return;
        }
        if light.range().is_some() {
            self.scene
                .warnings
                .push(format!("{name}: `range` is ignored; lights fall off with the inverse square law"));
        }
        if let Some(w) = beyond_f32_sums(&format!("{name}: intensity"), color) {
            self.scene.warnings.push(w);
        }
        let kind = match light.kind() {
            Kind::Point => LightKind::Point { position, intensity: color },
            Kind::Directional => LightKind::Directional { direction, irradiance: color },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => LightKind::Spot {
                position,
                direction,
                intensity: color,
                inner_cone: inner_cone_angle.max(0.0),
                outer_cone: outer_cone_angle.max(inner_cone_angle),
            },
        };
        self.scene.lights.push(Light { name, kind });
    }

    fn add_camera(&mut self, camera: &gltf::Camera, world: Mat4, node_name: &str) {
        let name = camera.name().map(str::to_owned).unwrap_or_else(|| node_name.to_owned());
        match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let forward = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
                let up_raw = world.transform_vector3(Vec3::Y);
                let right = forward.cross(up_raw).normalize_or(Vec3::X);
                // glTF 2.0 §5.14 (camera.perspective): yfov is above 0 and should be below π.
                let yfov = p.yfov().clamp(1e-4, 3.1);
                if yfov != p.yfov() {
                    self.scene.warnings.push(format!(
                        "camera '{name}': yfov {} rad is outside (0, π); rendering with {yfov} rad",
                        p.yfov()
                    ));
                }
                self.scene.cameras.push(Camera {
                    name,
                    position: world.transform_point3(Vec3::ZERO),
                    forward,
                    up: right.cross(forward),
                    yfov,
                });
            }
            gltf::camera::Projection::Orthographic(_) => {
                self.scene.warnings.push(format!("camera '{name}' is orthographic, which is not supported; skipped"));
            }
        }
    }
}

/// Triangles of a primitive as vertex-index triples, from its mode and index list.
fn triangle_list(mode: Mode, idx: &[u32]) -> std::result::Result<Vec<[u32; 3]>, String> {
    Ok(match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        // glTF §3.7.2.1: strip triangle i is (i, i+1, i+2) for even i, (i+1, i, i+2) for odd i.
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| if i % 2 == 0 { [idx[i], idx[i + 1], idx[i + 2]] } else { [idx[i + 1], idx[i], idx[i + 2]] })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1)).map(|i| [idx[i], idx[i + 1], idx[0]]).collect(),
        other => {
            return Err(format!("primitive mode {other:?} is not supported (only triangles are rendered)"));
        }
    })
}

/// Checks that an accessor's bytes lie inside its buffer view and buffer, so that reading it
/// cannot go out of bounds.
fn check_accessor(acc: &gltf::Accessor, buffers: &[gltf::buffer::Data]) -> std::result::Result<(), String> {
    let Some(view) = acc.view() else {
        return if acc.sparse().is_some() { Ok(()) } else { Err("has no buffer view".into()) };
    };
    let buffer_len = buffers.get(view.buffer().index()).map(|d| d.0.len()).ok_or("refers to a missing buffer")?;
    if view.offset() + view.length() > buffer_len {
        return Err(format!(
            "buffer view {} (bytes {}..{}) lies outside its buffer of {} bytes",
            view.index(),
            view.offset(),
            view.offset() + view.length(),
            buffer_len
        ));
    }
    if acc.count() == 0 {
        return Ok(());
    }
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    let end = acc.offset() + stride * (acc.count() - 1) + elem;
    if end > view.length() {
        return Err(format!("accessor {} needs {end} bytes but its buffer view has {}", acc.index(), view.length()));
    }
    Ok(())
}

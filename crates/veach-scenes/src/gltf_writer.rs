//! A small glTF 2.0 writer for scenes built in code: the shipped assets and the test scenes.
//! Geometry goes into one base64-embedded buffer, so every scene is a single `.gltf` file.

use base64::Engine;
use glam::{Mat4, Quat, Vec2, Vec3};
use serde_json::{Value, json};
use std::path::Path;

/// Material parameters as glTF spells them.
#[derive(Clone, Debug)]
pub struct MaterialDesc {
    pub name: String,
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    /// KHR_materials_specular specularFactor (0 gives a pure Lambertian dielectric).
    pub specular: f32,
    pub emission: Vec3,
    pub emissive_strength: f32,
    pub double_sided: bool,
    pub textures: MaterialTextures,
}

/// A material's textures (indices returned by `GltfBuilder::texture`).
#[derive(Clone, Debug, Default)]
pub struct MaterialTextures {
    pub base_color: Option<TextureUse>,
    pub metallic_roughness: Option<TextureUse>,
    pub emissive: Option<TextureUse>,
    /// With normalTexture.scale.
    pub normal: Option<(TextureUse, f32)>,
}

/// A textureInfo: texture, TEXCOORD set and an optional KHR_texture_transform.
#[derive(Clone, Copy, Debug)]
pub struct TextureUse {
    pub texture: usize,
    pub tex_coord: u32,
    /// (offset, rotation in radians, scale)
    pub transform: Option<(Vec2, f32, Vec2)>,
}

impl TextureUse {
    pub fn new(texture: usize) -> TextureUse {
        TextureUse { texture, tex_coord: 0, transform: None }
    }
}

/// An image with its sampler, embedded as PNG.
#[derive(Clone, Debug)]
pub struct TextureDesc {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// RGBA8, rows top first.
    pub rgba: Vec<u8>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub nearest: bool,
}

impl MaterialDesc {
    /// A pure Lambertian surface: dielectric with the specular layer switched off.
    pub fn lambert(name: &str, albedo: Vec3) -> Self {
        MaterialDesc {
            name: name.into(),
            base_color: albedo,
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            emission: Vec3::ZERO,
            emissive_strength: 1.0,
            double_sided: false,
            textures: MaterialTextures::default(),
        }
    }

    pub fn metal(name: &str, color: Vec3, roughness: f32) -> Self {
        MaterialDesc { metallic: 1.0, roughness, specular: 1.0, ..Self::lambert(name, color) }
    }

    /// An emitter of radiance `radiance` (stored as a unit-max emissiveFactor × strength).
    pub fn emitter(name: &str, radiance: Vec3) -> Self {
        let strength = radiance.max_element().max(1e-30);
        MaterialDesc {
            base_color: Vec3::ZERO,
            emission: radiance / strength,
            emissive_strength: strength,
            ..Self::lambert(name, Vec3::ZERO)
        }
    }
}

#[derive(Default)]
pub struct GltfBuilder {
    buffer: Vec<u8>,
    buffer_views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    cameras: Vec<Value>,
    lights: Vec<Value>,
    images: Vec<Value>,
    samplers: Vec<Value>,
    textures: Vec<Value>,
    uses_texture_transform: bool,
    /// A transform of the whole scene (a root node above every node).
    root: Option<Mat4>,
}

/// glTF sampler wrap modes (glTF 2.0 §5.26, sampler.wrapS / wrapT), as the codes the file stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat = 10497,
    ClampToEdge = 33071,
    MirroredRepeat = 33648,
}

fn wrap_code(w: Wrap) -> u32 {
    w as u32
}

impl GltfBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// An embedded PNG texture with its own sampler; returns the texture index.
    pub fn texture(&mut self, t: &TextureDesc) -> usize {
        let mut png = std::io::Cursor::new(Vec::new());
        image::write_buffer_with_format(
            &mut png,
            &t.rgba,
            t.width,
            t.height,
            image::ExtendedColorType::Rgba8,
            image::ImageFormat::Png,
        )
        .expect("PNG encoding of an in-memory image");
        let uri = format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png.get_ref()));
        self.images.push(json!({ "name": t.name, "uri": uri }));
        let mut sampler = json!({ "wrapS": wrap_code(t.wrap_s), "wrapT": wrap_code(t.wrap_t), "minFilter": 9729 });
        sampler["magFilter"] = json!(if t.nearest { 9728 } else { 9729 });
        self.samplers.push(sampler);
        self.textures.push(json!({
            "name": t.name, "source": self.images.len() - 1, "sampler": self.samplers.len() - 1
        }));
        self.textures.len() - 1
    }

    fn texture_info(&mut self, u: &TextureUse) -> Value {
        let mut v = json!({ "index": u.texture, "texCoord": u.tex_coord });
        if let Some((offset, rotation, scale)) = u.transform {
            self.uses_texture_transform = true;
            v["extensions"] = json!({ "KHR_texture_transform": {
                "offset": offset.to_array(), "rotation": rotation, "scale": scale.to_array()
            }});
        }
        v
    }

    pub fn material(&mut self, m: &MaterialDesc) -> usize {
        let mut v = json!({
            "name": m.name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [m.base_color.x, m.base_color.y, m.base_color.z, 1.0],
                "metallicFactor": m.metallic,
                "roughnessFactor": m.roughness,
            },
            "doubleSided": m.double_sided,
        });
        let mut ext = serde_json::Map::new();
        if m.specular != 1.0 {
            ext.insert("KHR_materials_specular".into(), json!({ "specularFactor": m.specular }));
        }
        if m.emission != Vec3::ZERO {
            v["emissiveFactor"] = json!([m.emission.x, m.emission.y, m.emission.z]);
            if m.emissive_strength != 1.0 {
                ext.insert(
                    "KHR_materials_emissive_strength".into(),
                    json!({ "emissiveStrength": m.emissive_strength }),
                );
            }
        }
        if !ext.is_empty() {
            v["extensions"] = Value::Object(ext);
        }
        let t = &m.textures;
        if let Some(u) = &t.base_color {
            v["pbrMetallicRoughness"]["baseColorTexture"] = self.texture_info(u);
        }
        if let Some(u) = &t.metallic_roughness {
            v["pbrMetallicRoughness"]["metallicRoughnessTexture"] = self.texture_info(u);
        }
        if let Some(u) = &t.emissive {
            v["emissiveTexture"] = self.texture_info(u);
        }
        if let Some((u, scale)) = &t.normal {
            v["normalTexture"] = self.texture_info(u);
            v["normalTexture"]["scale"] = json!(scale);
        }
        self.materials.push(v);
        self.materials.len() - 1
    }

    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.buffer.len().is_multiple_of(4) {
            self.buffer.push(0);
        }
        let offset = self.buffer.len();
        self.buffer.extend_from_slice(bytes);
        self.buffer_views.push(json!({
            "buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target
        }));
        self.buffer_views.len() - 1
    }

    fn vec3_accessor(&mut self, data: &[Vec3], with_bounds: bool) -> usize {
        let flat: Vec<f32> = data.iter().flat_map(|v| v.to_array()).collect();
        let view = self.push_view(bytemuck::cast_slice(&flat), 34962);
        let mut acc = json!({ "bufferView": view, "componentType": 5126, "count": data.len(), "type": "VEC3" });
        if with_bounds {
            let min = data.iter().fold(Vec3::splat(f32::INFINITY), |a, &b| a.min(b));
            let max = data.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, &b| a.max(b));
            acc["min"] = json!(min.to_array());
            acc["max"] = json!(max.to_array());
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A mesh with one triangle primitive; returns the mesh index.
    pub fn mesh(&mut self, name: &str, mesh: &MeshData, material: usize) -> usize {
        let pos = self.vec3_accessor(&mesh.positions, true);
        let mut attributes = json!({ "POSITION": pos });
        if let Some(n) = &mesh.normals {
            attributes["NORMAL"] = json!(self.vec3_accessor(n, false));
        }
        if let Some(uv) = &mesh.uvs {
            let flat: Vec<f32> = uv.iter().flat_map(|v| v.to_array()).collect();
            let view = self.push_view(bytemuck::cast_slice(&flat), 34962);
            self.accessors
                .push(json!({ "bufferView": view, "componentType": 5126, "count": uv.len(), "type": "VEC2" }));
            attributes["TEXCOORD_0"] = json!(self.accessors.len() - 1);
        }
        let view = self.push_view(bytemuck::cast_slice(&mesh.indices), 34963);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": mesh.indices.len(), "type": "SCALAR"
        }));
        let indices = self.accessors.len() - 1;
        self.meshes.push(json!({
            "name": name,
            "primitives": [{ "attributes": attributes, "indices": indices, "material": material }]
        }));
        self.meshes.len() - 1
    }

    /// A mesh placed by a node with `transform`.
    pub fn add_mesh(&mut self, name: &str, mesh: &MeshData, material: usize, transform: Mat4) {
        let m = self.mesh(name, mesh, material);
        self.instance(name, m, transform);
    }

    /// Mesh `mesh` (from `mesh`) placed once more, by a node of its own: glTF instancing.
    pub fn instance(&mut self, name: &str, mesh: usize, transform: Mat4) {
        self.nodes.push(json!({ "name": name, "mesh": mesh, "matrix": transform.to_cols_array() }));
    }

    pub fn camera(&mut self, name: &str, position: Vec3, target: Vec3, yfov_degrees: f32) {
        self.cameras.push(json!({
            "name": name, "type": "perspective",
            "perspective": { "yfov": yfov_degrees.to_radians(), "znear": 0.01 }
        }));
        let rotation = look_rotation(position, target);
        self.nodes.push(json!({
            "name": name,
            "camera": self.cameras.len() - 1,
            "translation": position.to_array(),
            "rotation": rotation.to_array(),
        }));
    }

    /// A KHR_lights_punctual light of colour × intensity `power` (W/sr for point and spot
    /// lights, W/m² for directional ones). Spot and directional lights shine from `position`
    /// towards `target`.
    pub fn punctual_light(&mut self, name: &str, kind: Punctual, power: Vec3, position: Vec3, target: Vec3) {
        let intensity = power.max_element().max(1e-30);
        let mut light = json!({ "name": name, "color": (power / intensity).to_array(), "intensity": intensity });
        light["type"] = json!(match kind {
            Punctual::Point => "point",
            Punctual::Spot { .. } => "spot",
            Punctual::Directional => "directional",
        });
        if let Punctual::Spot { inner, outer } = kind {
            light["spot"] = json!({ "innerConeAngle": inner, "outerConeAngle": outer });
        }
        self.lights.push(light);
        let rotation = look_rotation(position, target);
        self.nodes.push(json!({
            "name": name,
            "translation": position.to_array(),
            "rotation": rotation.to_array(),
            "extensions": { "KHR_lights_punctual": { "light": self.lights.len() - 1 } }
        }));
    }

    /// The same scene under one more transform: meshes, cameras and lights alike.
    pub fn transformed(mut self, m: Mat4) -> GltfBuilder {
        self.root = Some(self.root.map_or(m, |r| m * r));
        self
    }

    pub fn to_json(&self) -> Value {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.buffer)
        );
        let mut used = vec!["KHR_materials_emissive_strength", "KHR_materials_specular"];
        let mut root = json!({
            "asset": { "version": "2.0", "generator": "veach scene generator" },
            "scene": 0,
            "scenes": [{ "nodes": (0..self.nodes.len()).collect::<Vec<_>>() }],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.buffer_views,
            "buffers": [{ "byteLength": self.buffer.len(), "uri": uri }],
        });
        if let Some(m) = self.root {
            let mut nodes = self.nodes.clone();
            nodes.push(json!({ "name": "root", "children": (0..self.nodes.len()).collect::<Vec<_>>(), "matrix": m.to_cols_array() }));
            root["scenes"] = json!([{ "nodes": [self.nodes.len()] }]);
            root["nodes"] = json!(nodes);
        }
        if !self.cameras.is_empty() {
            root["cameras"] = json!(self.cameras);
        }
        if !self.lights.is_empty() {
            root["extensions"] = json!({ "KHR_lights_punctual": { "lights": self.lights } });
            used.push("KHR_lights_punctual");
        }
        if !self.textures.is_empty() {
            root["images"] = json!(self.images);
            root["samplers"] = json!(self.samplers);
            root["textures"] = json!(self.textures);
        }
        if self.uses_texture_transform {
            used.push("KHR_texture_transform");
        }
        root["extensionsUsed"] = json!(used);
        root
    }

    /// The glTF file's text.
    pub fn to_text(&self) -> String {
        serde_json::to_string_pretty(&self.to_json()).expect("JSON of plain values")
    }

    /// Writes the glTF file beside `path` and moves it into place, so that a failed write leaves
    /// no half-written scene.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".part");
        std::fs::write(&tmp, self.to_text()).and_then(|_| std::fs::rename(&tmp, path)).inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
    }
}

/// Rotation taking the node's -Z (glTF's view and light direction) to `target - position`,
/// keeping +Y as close to world up as possible.
fn look_rotation(position: Vec3, target: Vec3) -> Quat {
    let forward = (target - position).normalize();
    let up_hint = if forward.y.abs() > 0.999 { Vec3::Z } else { Vec3::Y };
    let right = forward.cross(up_hint).normalize();
    let up = right.cross(forward);
    Quat::from_mat3(&glam::Mat3::from_cols(right, up, -forward))
}

/// Kinds of KHR_lights_punctual lights; spot cone half-angles in radians.
#[derive(Clone, Copy, Debug)]
pub enum Punctual {
    Point,
    Spot { inner: f32, outer: f32 },
    Directional,
}

/// Triangle mesh data in the form glTF stores it.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    /// TEXCOORD_0
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<u32>,
}

impl MeshData {
    /// A planar quad a-b-c-d whose front face looks along `facing`.
    pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, facing: Vec3) -> MeshData {
        let front = (b - a).cross(c - a).dot(facing) >= 0.0;
        let indices = if front { vec![0, 1, 2, 0, 2, 3] } else { vec![0, 2, 1, 0, 3, 2] };
        // uv (0, 0) at a, (1, 0) at b, (1, 1) at c.
        let uvs = vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
        MeshData { positions: vec![a, b, c, d], normals: None, uvs: Some(uvs), indices }
    }

    /// The same triangles with the other face in front.
    pub fn flipped(mut self) -> MeshData {
        for t in self.indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        self
    }

    pub fn append(&mut self, other: &MeshData) {
        let base = self.positions.len() as u32;
        let uvs = match (self.uvs.take(), &other.uvs) {
            (Some(mut a), Some(b)) if a.len() == base as usize => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if base == 0 => Some(b.clone()),
            _ => None,
        };
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(other.indices.iter().map(|i| i + base));
        self.normals = None;
        self.uvs = uvs;
    }

    /// A closed prism over a convex footprint (4 corners at y = 0) of height `h`, faces outward.
    pub fn prism(corners: [Vec3; 4], h: f32) -> MeshData {
        let center = corners.iter().copied().sum::<Vec3>() / 4.0 + Vec3::Y * h * 0.5;
        let up = Vec3::Y * h;
        let mut m = MeshData::default();
        let out = |p: Vec3| p - center;
        let top = [corners[0] + up, corners[1] + up, corners[2] + up, corners[3] + up];
        m.append(&MeshData::quad(top[0], top[1], top[2], top[3], Vec3::Y));
        m.append(&MeshData::quad(corners[0], corners[1], corners[2], corners[3], -Vec3::Y));
        for i in 0..4 {
            let j = (i + 1) % 4;
            let mid = 0.5 * (corners[i] + corners[j]) + up * 0.5;
            m.append(&MeshData::quad(corners[i], corners[j], top[j], top[i], out(mid)));
        }
        m
    }

    /// A UV sphere with smooth normals, counter-clockwise seen from outside.
    pub fn sphere(center: Vec3, radius: f32, slices: u32, stacks: u32) -> MeshData {
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        for i in 0..=stacks {
            let theta = std::f32::consts::PI * i as f32 / stacks as f32;
            for j in 0..=slices {
                let phi = 2.0 * std::f32::consts::PI * j as f32 / slices as f32;
                let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
                positions.push(center + radius * n);
                normals.push(n);
                uvs.push(Vec2::new(j as f32 / slices as f32, i as f32 / stacks as f32));
            }
        }
        let row = slices + 1;
        let mut indices = Vec::new();
        for i in 0..stacks {
            for j in 0..slices {
                let a = i * row + j;
                let b = a + row;
                // Skip the degenerate triangles at the poles.
                if i != 0 {
                    indices.extend([a, a + 1, b]);
                }
                if i + 1 != stacks {
                    indices.extend([a + 1, b + 1, b]);
                }
            }
        }
        MeshData { positions, normals: Some(normals), uvs: Some(uvs), indices }
    }
}

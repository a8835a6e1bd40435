//! Textures: the WGSL lookups (wrap modes, nearest and bilinear filtering, sRGB decoding,
//! KHR_texture_transform, texture-coordinate sets) against `Texture::sample` on the host, and a
//! checkerboard floor under a directional light whose pixels must equal albedo · E / π exactly.

mod common;

use common::*;
use glam::{Mat4, Vec2, Vec3, Vec4};
use veach::gpu::layout::{FrameParams, TestParams};
use veach::gpu::test_kernel::{TestKernel, routine};
use veach::scene::{Encoding, Scene, srgb_to_linear};
use veach::{RenderSettings, Strategy};
use veach_scenes::gltf_writer::Wrap;
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MaterialTextures, MeshData, Punctual, TextureUse};
use veach_scenes::{texture_from, turned_texture_lambert};

fn noise_texture(
    name: &str,
    size: (u32, u32),
    wrap: (Wrap, Wrap),
    nearest: bool,
    seed: u64,
) -> veach_scenes::gltf_writer::TextureDesc {
    let texels: Vec<[u8; 4]> = {
        let mut u = uniforms(seed);
        (0..size.0 * size.1).map(|_| std::array::from_fn(|_| (u() * 256.0) as u8)).collect()
    };
    texture_from(name, size, wrap, nearest, |x, y| texels[(y * size.0 + x) as usize])
}

/// One triangle whose material uses three textures with different samplers, so that the
/// loader uploads them all: base colour (repeat × repeat, bilinear, transformed, TEXCOORD_1),
/// metallic-roughness (clamp × mirrored, bilinear), emissive (mirrored × repeat, nearest).
fn texture_scene() -> Scene {
    let mut g = GltfBuilder::new();
    let a = g.texture(&noise_texture("a", (5, 3), (Wrap::Repeat, Wrap::Repeat), false, 1));
    let b = g.texture(&noise_texture("b", (4, 4), (Wrap::ClampToEdge, Wrap::MirroredRepeat), false, 2));
    let c = g.texture(&noise_texture("c", (3, 5), (Wrap::MirroredRepeat, Wrap::Repeat), true, 3));
    let m = g.material(&MaterialDesc {
        metallic: 0.8,
        roughness: 0.9,
        specular: 1.0,
        emission: Vec3::new(1.0, 0.5, 0.25),
        textures: MaterialTextures {
            base_color: Some(TextureUse {
                texture: a,
                tex_coord: 1,
                transform: Some((Vec2::new(0.3, -0.2), 0.7, Vec2::new(2.0, -1.5))),
            }),
            metallic_roughness: Some(TextureUse::new(b)),
            emissive: Some(TextureUse {
                transform: Some((Vec2::new(-0.5, 0.25), -1.1, Vec2::splat(0.75))),
                ..TextureUse::new(c)
            }),
            normal: None,
        },
        ..MaterialDesc::lambert("textured", Vec3::new(0.9, 0.6, 0.3))
    });
    let tri = MeshData::quad(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::Z);
    g.add_mesh("quad", &tri, m, Mat4::IDENTITY);
    load(&g, "texture-lookups")
}

fn kernel() -> TestKernel<'static> {
    TestKernel::new(renderer()).unwrap_or_else(|e| panic!("{e}"))
}

/// Texture lookups differ from the host's only by float rounding (same arithmetic, pow and
/// mix done by the GPU's maths library): 1e-4 on values in [0, 1] leaves room for that and
/// catches any off-by-half-texel, wrap or decoding error (those move values by ≥ 1/255).
const LOOKUP_TOLERANCE: f32 = 1e-4;

#[test]
fn texture_lookups_match_the_host() {
    let scene = texture_scene();
    assert_eq!(scene.textures.len(), 3);
    let gpu_scene = upload(&scene);
    let k = kernel();
    let mut u = uniforms(7);
    for (index, texture) in scene.textures.iter().enumerate() {
        for encoding in [Encoding::Linear, Encoding::Srgb] {
            // Random points over several periods, plus texel centres and edges.
            let mut uvs: Vec<Vec2> = (0..4000).map(|_| Vec2::new(u() * 6.0 - 2.5, u() * 6.0 - 2.5)).collect();
            for i in -2..=2 * texture.width as i32 {
                for j in -2..=2 * texture.height as i32 {
                    uvs.push(Vec2::new(i as f32 * 0.5 / texture.width as f32, j as f32 * 0.5 / texture.height as f32));
                }
            }
            let srgb = if encoding == Encoding::Srgb { 1.0 } else { 0.0 };
            let input: Vec<[f32; 4]> = uvs.iter().map(|uv| [uv.x, uv.y, index as f32, srgb]).collect();
            let params =
                TestParams { routine: routine::TEXTURE_LOOKUP, count: input.len() as u32, ..Default::default() };
            let out = k.run(&gpu_scene, &FrameParams::default(), &params, &input, 1).unwrap();
            let mut worst = (0.0f32, Vec2::ZERO);
            for (uv, gpu) in uvs.iter().zip(&out) {
                let host = texture.sample(*uv, encoding);
                let d = (Vec4::from(*gpu) - host).abs().max_element();
                if d > worst.0 {
                    worst = (d, *uv);
                }
            }
            assert!(
                worst.0 <= LOOKUP_TOLERANCE,
                "texture {index} ({:?} × {:?}, nearest {}) {encoding:?}: GPU and host differ by {} at uv {}",
                texture.wrap_s,
                texture.wrap_t,
                texture.nearest,
                worst.0,
                worst.1
            );
        }
    }
}

#[test]
fn textured_materials_apply_transforms_and_coordinate_sets() {
    let scene = texture_scene();
    let gpu_scene = upload(&scene);
    let material = &scene.materials[0];
    let bvh = veach::bvh::build_bvh(&scene.triangles);
    let gpu_material =
        veach::gpu::scene_buffers::build_scene_arrays(&scene, &veach::features::SceneFeatures::detect(&scene), &bvh)
            .materials[0];
    let mut u = uniforms(11);
    let uvs: Vec<[f32; 4]> = (0..3000).map(|_| std::array::from_fn(|_| u() * 4.0 - 1.5)).collect();
    let params = TestParams {
        routine: routine::TEXTURED_MATERIAL,
        count: uvs.len() as u32,
        material: gpu_material,
        ..Default::default()
    };
    let out = kernel().run(&gpu_scene, &FrameParams::default(), &params, &uvs, 2).unwrap();
    let lookup = |r: &Option<veach::scene::TextureRef>, uv: &[f32; 4], encoding| {
        let r = r.as_ref().unwrap();
        let set = if r.tex_coord == 1 { Vec2::new(uv[2], uv[3]) } else { Vec2::new(uv[0], uv[1]) };
        scene.textures[r.texture as usize].sample(r.apply(set), encoding)
    };
    assert_eq!(material.base_color_texture.unwrap().tex_coord, 1, "the base colour reads TEXCOORD_1");
    for (i, uv) in uvs.iter().enumerate() {
        let base = material.base_color * lookup(&material.base_color_texture, uv, Encoding::Srgb).truncate();
        let mr = lookup(&material.metallic_roughness_texture, uv, Encoding::Linear);
        let emission = lookup(&material.emissive_texture, uv, Encoding::Srgb).truncate();
        let expected = [
            Vec4::new(base.x, base.y, base.z, material.metallic * mr.z),
            Vec4::new(material.roughness * mr.y, emission.x, emission.y, emission.z),
        ];
        for (k, e) in expected.iter().enumerate() {
            let d = (Vec4::from(out[2 * i + k]) - *e).abs().max_element();
            assert!(d <= LOOKUP_TOLERANCE, "uv {uv:?} output {k}: GPU {:?}, host {e}", out[2 * i + k]);
        }
    }
}

/// A floor of 4×4 distinct colours (nearest, repeated, turned by KHR_texture_transform; not a
/// checkerboard, which is symmetric under swapping u and v and would hide such a bug) seen from straight
/// above under a directional light from straight above: a pixel that lies inside one checker
/// cell is exactly base colour (sRGB decoded) · E / π. Any error in texture coordinates,
/// transform, wrap, decoding or the material multiply shows as a wrong colour.
#[test]
fn textured_floor_pixels_are_albedo_times_irradiance_over_pi() {
    let mut g = GltfBuilder::new();
    let cells = texture_from("cells", (4, 4), (Wrap::Repeat, Wrap::Repeat), true, |x, y| {
        [(40 + 60 * x) as u8, (40 + 60 * y) as u8, (200 - 30 * (x + y)) as u8, 255]
    });
    let checker = g.texture(&cells);
    let floor = g.material(&turned_texture_lambert("cells", Vec3::new(1.0, 0.9, 0.8), checker));
    let quad = MeshData::quad(
        Vec3::new(-1., 0., -1.),
        Vec3::new(1., 0., -1.),
        Vec3::new(1., 0., 1.),
        Vec3::new(-1., 0., 1.),
        Vec3::Y,
    );
    g.add_mesh("floor", &quad, floor, Mat4::IDENTITY);
    let irradiance = Vec3::new(2.0, 1.5, 1.0);
    g.punctual_light("sun", Punctual::Directional, irradiance, Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO);
    g.camera("above", Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, 50.0);
    let scene = load(&g, "checker-floor");
    let camera = scene.camera(None).unwrap();
    let (w, h) = (40u32, 40u32);
    let settings = RenderSettings {
        width: w,
        height: h,
        spp: 4,
        strategy: Strategy::Light,
        light_samples: 1,
        brdf_samples: 0,
        ..Default::default()
    };
    let out = render(&upload(&scene), &settings, &camera);
    let image = out.mean();

    // The floor point seen through film position (sx, sy), as camera.wgsl computes the ray.
    let c = camera.to_gpu(w, h);
    let (o, f, r, up) = (Vec3::from(c.origin), Vec3::from(c.forward), Vec3::from(c.right), Vec3::from(c.up));
    let floor_point = |fx: f32, fy: f32| -> Option<Vec3> {
        let d = (f + (2.0 * fx - 1.0) * r + (1.0 - 2.0 * fy) * up).normalize();
        let t = -o.y / d.y;
        let p = o + t * d;
        (t > 0.0 && p.x.abs() < 1.0 && p.z.abs() < 1.0).then_some(p)
    };
    let m = &scene.materials[0];
    let reference = m.base_color_texture.unwrap();
    let texture = &scene.textures[reference.texture as usize];
    // The quad's uv is ((x + 1) / 2, (z + 1) / 2) (MeshData::quad: (0, 0) at a, (1, 1) at c).
    let cell = |p: Vec3| -> (u32, u32) {
        let uv = reference.apply(Vec2::new((p.x + 1.0) / 2.0, (p.z + 1.0) / 2.0));
        let t = uv * Vec2::new(texture.width as f32, texture.height as f32);
        (
            veach::scene::wrap_index(t.x.floor() as i64, texture.width, texture.wrap_s),
            veach::scene::wrap_index(t.y.floor() as i64, texture.height, texture.wrap_t),
        )
    };
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(dx, dy)| floor_point((x as f32 + dx) / w as f32, (y as f32 + dy) / h as f32));
            let Some(cells) = corners.iter().map(|p| p.map(cell)).collect::<Option<Vec<_>>>() else { continue };
            if cells.iter().any(|c| *c != cells[0]) {
                continue;
            }
            let (tx, ty) = cells[0];
            let texel = texture.texels[(ty * texture.width + tx) as usize];
            let albedo = m.base_color
                * Vec3::new(
                    srgb_to_linear(texel[0] as f32 / 255.0),
                    srgb_to_linear(texel[1] as f32 / 255.0),
                    srgb_to_linear(texel[2] as f32 / 255.0),
                );
            let expected = albedo * irradiance / std::f32::consts::PI;
            let got = Vec3::from(image[(y * w + x) as usize]);
            let d = (got - expected).abs().max_element();
            assert!(
                d <= 1e-4 * expected.max_element().max(1e-3),
                "pixel ({x}, {y}) in cell ({tx}, {ty}): {got} vs {expected}"
            );
            checked += 1;
        }
    }
    // Cells are about 2/3 / 3 of the floor across: most pixels lie inside one.
    assert!(checked > (w * h / 2) as usize, "only {checked} pixels checked");
}

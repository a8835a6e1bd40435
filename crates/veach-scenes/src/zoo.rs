//! The scene zoo: scenes veach was not tuned on, generated from a seed in families with
//! parameters, so that speed and quality decisions are judged on many kinds of scene (by
//! geometric mean and worst case) and a second seed gives scenes no decision has seen. `veach
//! generate zoo -o DIR --seed S` writes them all with an index (`zoo.csv`).
//!
//! Families: light count (1 to 10,000 quads, power spread over 6 decades); light size (a quad
//! from 1 mm to one that fills the sky); light shapes (tessellated spheres, an emissive mesh,
//! long thin tubes); point, spot and directional lights; meshes from 1k to 1M triangles with
//! shape (displaced spheres, instanced rocks, grass blades); materials (diffuse, glossy, mirror,
//! rough metal, textured); occluded lights (rooms behind walls, lamps in shades); and the stiff
//! cases of the stability suite (`stress`).

use crate::SplitMix64;
use crate::gltf_writer::{GltfBuilder, MaterialDesc, MaterialTextures, MeshData, Punctual, TextureUse};
use glam::{Mat4, Quat, Vec2, Vec3};
use std::f32::consts::TAU;

/// One zoo scene: its name, family, what it varies, and how to build it.
pub struct ZooScene {
    pub name: String,
    pub family: &'static str,
    pub what: String,
    pub builder: GltfBuilder,
}

/// The zoo's seeded numbers: each scene its own stream, so that adding a scene changes no other.
struct Rng(SplitMix64);

impl Rng {
    fn new(seed: u64, stream: &str) -> Rng {
        let h = stream.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3));
        Rng(SplitMix64(seed ^ h))
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.0.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    /// Log-uniform in [lo, hi).
    fn log_range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.f()).exp()
    }
    fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
}

/// The stage every zoo scene stands on: an 8 m floor, a back wall, a camera looking at the middle.
fn stage(g: &mut GltfBuilder) {
    let matte = g.material(&MaterialDesc::lambert("stage", Vec3::splat(0.6)));
    let floor = MeshData::quad(
        Vec3::new(-4., 0., -4.),
        Vec3::new(4., 0., -4.),
        Vec3::new(4., 0., 4.),
        Vec3::new(-4., 0., 4.),
        Vec3::Y,
    );
    g.add_mesh("floor", &floor, matte, Mat4::IDENTITY);
    let wall = MeshData::quad(
        Vec3::new(-4., 0., -4.),
        Vec3::new(4., 0., -4.),
        Vec3::new(4., 4., -4.),
        Vec3::new(-4., 4., -4.),
        Vec3::Z,
    );
    g.add_mesh("back wall", &wall, matte, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 2.2, 6.0), Vec3::new(0.0, 0.8, 0.0), 50.0);
}

/// A few objects to light and shadow: a matte box, a glossy metal sphere, a rough metal sphere
/// (metals and Lambertian surfaces only, so that `veach export-mitsuba` writes the same BSDFs).
fn props(g: &mut GltfBuilder) {
    let matte = g.material(&MaterialDesc::lambert("box", Vec3::new(0.7, 0.5, 0.3)));
    let glossy = g.material(&MaterialDesc::metal("glossy metal", Vec3::new(0.3, 0.5, 0.9), 0.2));
    let metal = g.material(&MaterialDesc::metal("rough metal", Vec3::new(0.9, 0.75, 0.5), 0.45));
    let corners =
        [Vec3::new(-2.2, 0., -1.0), Vec3::new(-1.2, 0., -1.3), Vec3::new(-0.9, 0., -0.3), Vec3::new(-1.9, 0., 0.0)];
    g.add_mesh("box", &MeshData::prism(corners, 1.1), matte, Mat4::IDENTITY);
    g.add_mesh("glossy sphere", &MeshData::sphere(Vec3::new(0.4, 0.7, 0.2), 0.7, 48, 24), glossy, Mat4::IDENTITY);
    g.add_mesh("metal sphere", &MeshData::sphere(Vec3::new(2.0, 0.5, -0.8), 0.5, 32, 16), metal, Mat4::IDENTITY);
}

/// A square light of side `side` centred at `c`, facing `facing`.
fn quad_light(c: Vec3, side: f32, facing: Vec3) -> MeshData {
    let n = facing.normalize();
    let t = n.any_orthonormal_vector();
    let b = n.cross(t);
    let (t, b) = (t * side / 2.0, b * side / 2.0);
    MeshData::quad(c - t - b, c + t - b, c + t + b, c - t + b, n)
}

/// `count` quad lights under the ceiling, each its own light (a mesh primitive), sides 2 cm to
/// 30 cm (log-uniform), radiances over 6 decades (24 steps of 10^¼, a material each), the total
/// power about that of a 1 m² light of radiance 100 whatever the count.
fn light_count(seed: u64, count: usize) -> GltfBuilder {
    let mut rng = Rng::new(seed, &format!("lights-{count}"));
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    const STEPS: usize = 24;
    let (lo, hi) = (0.02f32, 0.3f32);
    // E[side²] of a log-uniform side, and E[10^(6k/STEPS)] over the steps.
    let mean_area = (hi * hi - lo * lo) / (2.0 * (hi / lo).ln());
    let mean_step = (0..STEPS).map(|k| 10f32.powf(6.0 * k as f32 / STEPS as f32)).sum::<f32>() / STEPS as f32;
    let unit = 100.0 / (count as f32 * mean_area * mean_step);
    let mut materials = [None; STEPS];
    for i in 0..count {
        let c = Vec3::new(rng.range(-3.5, 3.5), rng.range(2.4, 3.6), rng.range(-3.5, 2.0));
        let side = rng.log_range(lo, hi);
        let tilt = Vec3::new(rng.range(-0.4, 0.4), -1.0, rng.range(-0.4, 0.4));
        let step = rng.below(STEPS);
        let m = *materials[step].get_or_insert_with(|| {
            let radiance = unit * 10f32.powf(6.0 * step as f32 / STEPS as f32);
            g.material(&MaterialDesc::emitter(&format!("light step {step}"), Vec3::splat(radiance)))
        });
        g.add_mesh(&format!("light {i}"), &quad_light(c, side, tilt), m, Mat4::IDENTITY);
    }
    g
}

/// One square light of side `side` 2.5 m above the floor, of power independent of its size.
fn light_size(seed: u64, side: f32) -> GltfBuilder {
    let mut rng = Rng::new(seed, &format!("light-size-{side}"));
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    let c = Vec3::new(rng.range(-1.0, 1.0), 2.5, rng.range(-1.0, 1.0));
    let m = g.material(&MaterialDesc::emitter("light", Vec3::splat(20.0 / (side * side))));
    g.add_mesh("light", &quad_light(c, side, -Vec3::Y), m, Mat4::IDENTITY);
    g
}

/// Four tessellated sphere lights of radii 3 cm to 40 cm and equal power over the props.
fn sphere_lights(seed: u64) -> GltfBuilder {
    let mut rng = Rng::new(seed, "sphere-lights");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    for (i, r) in [0.03f32, 0.1, 0.2, 0.4].into_iter().enumerate() {
        let c = Vec3::new(-2.4 + 1.6 * i as f32 + rng.range(-0.3, 0.3), rng.range(2.0, 3.0), rng.range(-2.0, 0.0));
        let m = g.material(&MaterialDesc::emitter(&format!("sphere light {i}"), Vec3::splat(2.0 / (r * r))));
        g.add_mesh(&format!("sphere light {i}"), &MeshData::sphere(c, r, 24, 12), m, Mat4::IDENTITY);
    }
    g
}

/// A torus, displaced, that emits: a light of 3,000 small triangles facing every way.
fn emissive_mesh(seed: u64) -> GltfBuilder {
    let mut rng = Rng::new(seed, "emissive-mesh");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    let m = g.material(&MaterialDesc::emitter("glowing torus", Vec3::new(8.0, 5.0, 2.0)));
    let torus = torus(Vec3::new(0.0, 2.6, -1.0), 0.8, 0.12, 60, 25, &mut rng);
    g.add_mesh("glowing torus", &torus, m, Mat4::IDENTITY);
    g
}

/// Long thin emissive triangles: tube lights 2 m long and 1 cm wide, hung at angles.
fn tube_lights(seed: u64) -> GltfBuilder {
    let mut rng = Rng::new(seed, "tube-lights");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    let m = g.material(&MaterialDesc { double_sided: true, ..MaterialDesc::emitter("tube", Vec3::splat(150.0)) });
    let mut tubes = MeshData::default();
    for _ in 0..6 {
        let a = Vec3::new(rng.range(-3.0, 1.0), rng.range(2.3, 3.2), rng.range(-3.0, 1.0));
        let b = a + Vec3::new(rng.range(1.0, 2.0), rng.range(-0.3, 0.3), rng.range(-1.0, 1.0));
        let w = Vec3::new(0.0, 0.0, 0.01);
        tubes.append(&MeshData::quad(a, b, b + w, a + w, -Vec3::Y));
    }
    g.add_mesh("tubes", &tubes, m, Mat4::IDENTITY);
    g
}

/// Point, spot and directional lights together.
fn punctual(_seed: u64) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    g.punctual_light("point", Punctual::Point, Vec3::new(6.0, 5.0, 4.0), Vec3::new(-1.5, 2.5, 1.0), Vec3::ZERO);
    g.punctual_light(
        "spot",
        Punctual::Spot { inner: 0.2, outer: 0.45 },
        Vec3::new(30.0, 30.0, 40.0),
        Vec3::new(2.0, 3.5, 1.5),
        Vec3::new(0.4, 0.0, 0.0),
    );
    g.punctual_light("sun", Punctual::Directional, Vec3::new(1.5, 1.4, 1.2), Vec3::new(3.0, 5.0, 2.0), Vec3::ZERO);
    g
}

/// 100 point lights of intensities spread over 4 decades.
fn many_points(seed: u64) -> GltfBuilder {
    let mut rng = Rng::new(seed, "many-points");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    for i in 0..100 {
        let p = Vec3::new(rng.range(-3.5, 3.5), rng.range(1.5, 3.5), rng.range(-3.5, 2.0));
        let power = rng.log_range(0.01, 100.0) * 0.2;
        g.punctual_light(&format!("point {i}"), Punctual::Point, Vec3::splat(power), p, Vec3::ZERO);
    }
    g
}

/// A ring of radius `big` and tube radius `small`, its surface displaced by a seeded ripple.
fn torus(c: Vec3, big: f32, small: f32, around: u32, across: u32, rng: &mut Rng) -> MeshData {
    let (k1, k2, phase) = (rng.range(3.0, 7.0), rng.range(2.0, 5.0), rng.range(0.0, TAU));
    let mut positions = Vec::new();
    for i in 0..around {
        let u = TAU * i as f32 / around as f32;
        for j in 0..across {
            let v = TAU * j as f32 / across as f32;
            let r = small * (1.0 + 0.25 * (k1 * u + phase).sin() * (k2 * v).cos());
            let ring = Vec3::new(u.cos(), 0.0, u.sin());
            positions.push(c + ring * (big + r * v.cos()) + Vec3::Y * r * v.sin());
        }
    }
    let mut indices = Vec::new();
    for i in 0..around {
        for j in 0..across {
            let (i1, j1) = ((i + 1) % around, (j + 1) % across);
            let (a, b, cc, d) = (i * across + j, i1 * across + j, i1 * across + j1, i * across + j1);
            indices.extend([a, cc, b, a, d, cc]);
        }
    }
    MeshData { positions, normals: None, uvs: None, indices }
}

/// A sphere of about `triangles` triangles, displaced by a sum of seeded ripples: a lumpy blob
/// with smooth normals, the shape of a scanned or sculpted object.
fn blob(c: Vec3, radius: f32, triangles: usize, rng: &mut Rng) -> MeshData {
    let stacks = ((triangles as f32 / 4.0).sqrt().round() as u32).max(3);
    let mut m = MeshData::sphere(Vec3::ZERO, 1.0, 2 * stacks, stacks);
    let waves: Vec<(Vec3, f32, f32)> = (0..6)
        .map(|_| {
            let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)).normalize_or(Vec3::Y);
            (d, rng.range(2.0, 9.0), rng.range(0.0, TAU))
        })
        .collect();
    for p in m.positions.iter_mut() {
        let n = *p;
        let h: f32 = waves.iter().map(|(d, k, ph)| (k * n.dot(*d) + ph).sin()).sum::<f32>() * 0.04;
        *p = c + n * radius * (1.0 + h);
    }
    m.normals = None;
    m.uvs = None;
    m
}

/// The props' stage with a blob of `triangles` triangles in the middle, lit by two quad lights.
fn mesh_blob(seed: u64, triangles: usize) -> GltfBuilder {
    let mut rng = Rng::new(seed, &format!("mesh-blob-{triangles}"));
    let mut g = GltfBuilder::new();
    stage(&mut g);
    let clay = g.material(&MaterialDesc::lambert("clay", Vec3::new(0.75, 0.6, 0.5)));
    g.add_mesh("blob", &blob(Vec3::new(0.0, 1.1, -0.5), 1.1, triangles, &mut rng), clay, Mat4::IDENTITY);
    two_lights(&mut g);
    g
}

/// A large soft quad light and a small bright one.
fn two_lights(g: &mut GltfBuilder) {
    let soft = g.material(&MaterialDesc::emitter("soft light", Vec3::splat(6.0)));
    g.add_mesh("soft light", &quad_light(Vec3::new(-1.5, 3.5, 1.0), 1.5, -Vec3::Y), soft, Mat4::IDENTITY);
    let small = g.material(&MaterialDesc::emitter("small light", Vec3::splat(800.0)));
    g.add_mesh(
        "small light",
        &quad_light(Vec3::new(2.5, 2.8, -1.5), 0.1, Vec3::new(-1.0, -1.0, 0.5)),
        small,
        Mat4::IDENTITY,
    );
}

/// `count` instances of one rock of 320 triangles, scattered, turned and scaled: glTF instancing.
fn instanced_rocks(seed: u64, count: usize) -> GltfBuilder {
    let mut rng = Rng::new(seed, "instanced-rocks");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    let stone = g.material(&MaterialDesc::lambert("stone", Vec3::new(0.5, 0.48, 0.45)));
    let rock = g.mesh("rock", &blob(Vec3::ZERO, 1.0, 320, &mut rng), stone);
    for i in 0..count {
        let s = rng.log_range(0.04, 0.25);
        let t = Vec3::new(rng.range(-3.8, 3.8), s * 0.5, rng.range(-3.8, 3.0));
        let r = Quat::from_euler(glam::EulerRot::YXZ, rng.range(0.0, TAU), rng.range(-0.5, 0.5), rng.range(-0.5, 0.5));
        let squash = Vec3::new(s * rng.range(0.8, 1.3), s * rng.range(0.5, 0.9), s * rng.range(0.8, 1.3));
        g.instance(&format!("rock {i}"), rock, Mat4::from_scale_rotation_translation(squash, r, t));
    }
    two_lights(&mut g);
    g
}

/// `blades` blades of grass: long thin triangles (5 cm wide at the root, 30-60 cm tall).
fn grass(seed: u64, blades: usize) -> GltfBuilder {
    let mut rng = Rng::new(seed, "grass");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    let green =
        g.material(&MaterialDesc { double_sided: true, ..MaterialDesc::lambert("grass", Vec3::new(0.25, 0.5, 0.15)) });
    let mut m = MeshData::default();
    for _ in 0..blades {
        let root = Vec3::new(rng.range(-3.8, 3.8), 0.0, rng.range(-3.8, 3.0));
        let a = rng.range(0.0, TAU);
        let side = Vec3::new(a.cos(), 0.0, a.sin()) * 0.025;
        let tip = root + Vec3::new(rng.range(-0.15, 0.15), rng.range(0.3, 0.6), rng.range(-0.15, 0.15));
        let base = m.positions.len() as u32;
        m.positions.extend([root - side, root + side, tip]);
        m.indices.extend([base, base + 1, base + 2]);
    }
    g.add_mesh("grass", &m, green, Mat4::IDENTITY);
    two_lights(&mut g);
    g
}

/// Three spheres and a box of one material under a soft and a small light.
fn material(seed: u64, kind: &str) -> GltfBuilder {
    let mut rng = Rng::new(seed, &format!("material-{kind}"));
    let mut g = GltfBuilder::new();
    stage(&mut g);
    let colour = Vec3::new(rng.range(0.3, 0.9), rng.range(0.3, 0.9), rng.range(0.3, 0.9));
    let desc = match kind {
        "diffuse" => MaterialDesc::lambert("diffuse", colour),
        "glossy" => MaterialDesc { roughness: 0.15, specular: 1.0, ..MaterialDesc::lambert("glossy", colour) },
        "mirror" => MaterialDesc::metal("mirror", Vec3::splat(0.95), 0.0),
        "rough-metal" => MaterialDesc::metal("rough metal", colour, 0.6),
        _ => {
            let checker = g.texture(&crate::checker_texture());
            MaterialDesc {
                roughness: 0.4,
                specular: 0.5,
                textures: MaterialTextures {
                    base_color: Some(TextureUse {
                        transform: Some((Vec2::ZERO, 0.0, Vec2::splat(4.0))),
                        ..TextureUse::new(checker)
                    }),
                    ..Default::default()
                },
                ..MaterialDesc::lambert("textured", Vec3::ONE)
            }
        }
    };
    let m = g.material(&desc);
    for (i, (x, r)) in [(-2.0f32, 0.6f32), (0.0, 0.8), (2.0, 0.5)].into_iter().enumerate() {
        g.add_mesh(&format!("sphere {i}"), &MeshData::sphere(Vec3::new(x, r, -0.5), r, 48, 24), m, Mat4::IDENTITY);
    }
    let corners =
        [Vec3::new(-0.6, 0., 1.0), Vec3::new(0.4, 0., 0.8), Vec3::new(0.6, 0., 1.8), Vec3::new(-0.4, 0., 2.0)];
    g.add_mesh("box", &MeshData::prism(corners, 0.5), m, Mat4::IDENTITY);
    two_lights(&mut g);
    g
}

/// A box of `size` (x, y, z) with its lower corner at `lo`: a wall or a lintel.
fn slab(lo: Vec3, size: Vec3) -> MeshData {
    let corners = [
        Vec3::new(lo.x, 0.0, lo.z),
        Vec3::new(lo.x + size.x, 0.0, lo.z),
        Vec3::new(lo.x + size.x, 0.0, lo.z + size.z),
        Vec3::new(lo.x, 0.0, lo.z + size.z),
    ];
    let mut m = MeshData::prism(corners, size.y);
    for p in &mut m.positions {
        p.y += lo.y;
    }
    m
}

/// `side` × `side` rooms of 4 m, walls 2.6 m high, a doorway 1 m wide somewhere in each inner
/// wall, one or two ceiling lights in every room (radiance over two decades), the camera in a
/// corner room: most lights are behind walls, close by, and a light choice that ignores
/// visibility sends most of its samples to them.
fn rooms(seed: u64, side: usize) -> GltfBuilder {
    let mut rng = Rng::new(seed, &format!("rooms-{}", side * side));
    let mut g = GltfBuilder::new();
    const ROOM: f32 = 4.0;
    const HEIGHT: f32 = 2.6;
    const WALL: f32 = 0.1;
    const DOOR: f32 = 1.0;
    const DOOR_HEIGHT: f32 = 2.1;
    let e = ROOM * side as f32;
    let floor = g.material(&MaterialDesc::lambert("floor", Vec3::new(0.55, 0.45, 0.35)));
    let plaster = g.material(&MaterialDesc::lambert("plaster", Vec3::splat(0.75)));
    g.add_mesh(
        "floor",
        &MeshData::quad(Vec3::ZERO, Vec3::new(e, 0., 0.), Vec3::new(e, 0., e), Vec3::new(0., 0., e), Vec3::Y),
        floor,
        Mat4::IDENTITY,
    );
    g.add_mesh(
        "ceiling",
        &MeshData::quad(
            Vec3::new(0., HEIGHT, 0.),
            Vec3::new(e, HEIGHT, 0.),
            Vec3::new(e, HEIGHT, e),
            Vec3::new(0., HEIGHT, e),
            -Vec3::Y,
        ),
        plaster,
        Mat4::IDENTITY,
    );
    let mut walls = MeshData::default();
    // Outer walls, closed.
    walls.append(&slab(Vec3::new(-WALL, 0., -WALL), Vec3::new(e + 2. * WALL, HEIGHT, WALL)));
    walls.append(&slab(Vec3::new(-WALL, 0., e), Vec3::new(e + 2. * WALL, HEIGHT, WALL)));
    walls.append(&slab(Vec3::new(-WALL, 0., 0.), Vec3::new(WALL, HEIGHT, e)));
    walls.append(&slab(Vec3::new(e, 0., 0.), Vec3::new(WALL, HEIGHT, e)));
    // Inner walls: along z at x = i ROOM and along x at z = i ROOM, a doorway in each room's length.
    for i in 1..side {
        for j in 0..side {
            let at = rng.range(0.4, ROOM - DOOR - 0.4);
            let (a, b) = (j as f32 * ROOM, i as f32 * ROOM - WALL / 2.0);
            walls.append(&slab(Vec3::new(b, 0., a), Vec3::new(WALL, HEIGHT, at)));
            walls.append(&slab(Vec3::new(b, 0., a + at + DOOR), Vec3::new(WALL, HEIGHT, ROOM - at - DOOR)));
            walls.append(&slab(Vec3::new(b, DOOR_HEIGHT, a + at), Vec3::new(WALL, HEIGHT - DOOR_HEIGHT, DOOR)));
            let at = rng.range(0.4, ROOM - DOOR - 0.4);
            walls.append(&slab(Vec3::new(a, 0., b), Vec3::new(at, HEIGHT, WALL)));
            walls.append(&slab(Vec3::new(a + at + DOOR, 0., b), Vec3::new(ROOM - at - DOOR, HEIGHT, WALL)));
            walls.append(&slab(Vec3::new(a + at, DOOR_HEIGHT, b), Vec3::new(DOOR, HEIGHT - DOOR_HEIGHT, WALL)));
        }
    }
    g.add_mesh("walls", &walls, plaster, Mat4::IDENTITY);
    let mut k = 0;
    for rx in 0..side {
        for rz in 0..side {
            for _ in 0..1 + rng.below(2) {
                let c = Vec3::new(
                    (rx as f32 + rng.range(0.2, 0.8)) * ROOM,
                    HEIGHT - 0.02,
                    (rz as f32 + rng.range(0.2, 0.8)) * ROOM,
                );
                let size = rng.log_range(0.2, 0.6);
                let radiance = rng.log_range(2.0, 200.0) * 0.04 / (size * size);
                let m = g.material(&MaterialDesc::emitter(&format!("ceiling light {k}"), Vec3::splat(radiance)));
                g.add_mesh(&format!("ceiling light {k}"), &quad_light(c, size, -Vec3::Y), m, Mat4::IDENTITY);
                k += 1;
            }
        }
    }
    let a = rng.range(0.3, 0.6);
    g.camera("camera", Vec3::new(0.4, 1.6, 0.4), Vec3::new(ROOM * (1.0 + a), 1.0, ROOM * (2.0 - a)), 60.0);
    g
}

/// 16 lamps over the stage, each a small bright light in a shade open below: seen from a point
/// beside or above a lamp, its light is hidden, though its bounds face the point.
fn lamp_shades(seed: u64) -> GltfBuilder {
    let mut rng = Rng::new(seed, "lamp-shades");
    let mut g = GltfBuilder::new();
    stage(&mut g);
    props(&mut g);
    let shade = g.material(&MaterialDesc { double_sided: true, ..MaterialDesc::lambert("shade", Vec3::splat(0.8)) });
    let mut shades = MeshData::default();
    for i in 0..16 {
        let c = Vec3::new(rng.range(-3.5, 3.5), rng.range(1.2, 3.0), rng.range(-3.5, 2.0));
        let (r, depth) = (rng.range(0.12, 0.25), rng.range(0.15, 0.35));
        let corners =
            [c + Vec3::new(-r, 0., -r), c + Vec3::new(r, 0., -r), c + Vec3::new(r, 0., r), c + Vec3::new(-r, 0., r)];
        let top = Vec3::Y * depth;
        shades.append(&MeshData::quad(
            corners[0] + top,
            corners[1] + top,
            corners[2] + top,
            corners[3] + top,
            -Vec3::Y,
        ));
        for s in 0..4 {
            let (a, b) = (corners[s], corners[(s + 1) % 4]);
            shades.append(&MeshData::quad(a, b, b + top, a + top, c - 0.5 * (a + b)));
        }
        let size = r * 0.6;
        let radiance = rng.log_range(1.0, 100.0) * 0.2 / (size * size);
        let m = g.material(&MaterialDesc::emitter(&format!("lamp {i}"), Vec3::splat(radiance)));
        g.add_mesh(&format!("lamp {i}"), &quad_light(c + top * 0.9, size, -Vec3::Y), m, Mat4::IDENTITY);
    }
    g.add_mesh("shades", &shades, shade, Mat4::IDENTITY);
    g
}

/// Every zoo scene for `seed`. The stiff cases (`stress-*`) do not depend on it.
pub fn zoo(seed: u64) -> Vec<ZooScene> {
    let mut out = Vec::new();
    let mut push = |name: String, family: &'static str, what: String, builder: GltfBuilder| {
        out.push(ZooScene { name, family, what, builder })
    };
    for count in [1, 10, 100, 1000, 10_000] {
        push(
            format!("lights-{count}"),
            "light count",
            format!("{count} quad lights, 6 decades of power"),
            light_count(seed, count),
        );
    }
    for side in [0.001f32, 0.01, 0.1, 1.0, 8.0] {
        push(
            format!("light-size-{side}"),
            "light size",
            format!("one quad light of side {side} m"),
            light_size(seed, side),
        );
    }
    push(
        "sphere-lights".into(),
        "light shape",
        "4 tessellated sphere lights, radii 3-40 cm".into(),
        sphere_lights(seed),
    );
    push(
        "emissive-mesh".into(),
        "light shape",
        "a displaced emissive torus, 3,000 triangles".into(),
        emissive_mesh(seed),
    );
    push("tube-lights".into(), "light shape", "6 tube lights 1 cm wide, 2 triangles each".into(), tube_lights(seed));
    push("punctual".into(), "delta lights", "point, spot and directional".into(), punctual(seed));
    push("many-points".into(), "delta lights", "100 point lights over 4 decades".into(), many_points(seed));
    for triangles in [1_000, 10_000, 100_000, 1_000_000] {
        let name = match triangles {
            1_000_000 => "1m".to_string(),
            t => format!("{}k", t / 1000),
        };
        push(
            format!("mesh-blob-{name}"),
            "meshes",
            format!("a displaced blob of about {triangles} triangles"),
            mesh_blob(seed, triangles),
        );
    }
    push(
        "instanced-rocks".into(),
        "meshes",
        "1,500 instances of a 320-triangle rock".into(),
        instanced_rocks(seed, 1500),
    );
    push("grass".into(), "meshes", "100,000 blades: long thin triangles".into(), grass(seed, 100_000));
    for kind in ["diffuse", "glossy", "mirror", "rough-metal", "textured"] {
        push(format!("material-{kind}"), "materials", format!("spheres and a box, all {kind}"), material(seed, kind));
    }
    for side in [2, 4] {
        push(
            format!("rooms-{}", side * side),
            "occluded lights",
            format!("{} rooms of 4 m with doorways, 1-2 ceiling lights each", side * side),
            rooms(seed, side),
        );
    }
    push("lamp-shades".into(), "occluded lights", "16 small lights in shades open below".into(), lamp_shades(seed));
    for name in crate::stress::STRESS_SCENES {
        let builder = crate::stress::stress_scene(name).expect("a stress scene");
        push(format!("stress-{name}"), "stiff", "the stability suite's scene".into(), builder);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_zoo_has_thirty_scenes_in_families_and_depends_on_its_seed() {
        let a = zoo(1);
        assert!(a.len() >= 30, "{} scenes", a.len());
        let families: std::collections::BTreeSet<_> = a.iter().map(|s| s.family).collect();
        assert_eq!(families.len(), 8, "{families:?}");
        let names: std::collections::BTreeSet<_> = a.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names.len(), a.len(), "names repeat");
        let json =
            |z: &[ZooScene], name: &str| z.iter().find(|s| s.name == name).unwrap().builder.to_json().to_string();
        let b = zoo(2);
        for name in ["lights-100", "rooms-16", "lamp-shades"] {
            assert_ne!(json(&a, name), json(&b, name), "the seed changes {name}");
        }
        assert_eq!(json(&a, "lights-100"), json(&zoo(1), "lights-100"), "the same seed, the same scene");
    }
}

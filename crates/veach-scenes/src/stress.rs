//! Stiff and extreme scenes for the stability suite (`tests/stress.rs`, `veach generate
//! stress-NAME`, then `veach bench` for each strategy's error and convergence slope): each
//! pushes an estimator towards a singularity of its pdf or the renderer towards the limits of
//! f32 arithmetic.

use crate::cornell_box;
use crate::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};
use glam::{Mat4, Vec3};

/// Names accepted by `stress_scene` (and by `veach generate` as `stress-NAME`).
pub const STRESS_SCENES: &[&str] = &[
    "tiny-bright-light",
    "touching-light",
    "grazing-light",
    "near-mirrors",
    "many-lights",
    "far-cornell-box",
    "degenerate",
    "float-limits",
    "camera-inside",
];

pub fn stress_scene(name: &str) -> Option<GltfBuilder> {
    Some(match name {
        "tiny-bright-light" => tiny_bright_light(),
        "touching-light" => touching_light(),
        "grazing-light" => grazing_light(),
        "near-mirrors" => near_mirrors(),
        "many-lights" => many_lights(),
        "far-cornell-box" => far_cornell_box(),
        "degenerate" => degenerate(),
        "float-limits" => float_limits(),
        "camera-inside" => camera_inside(),
        _ => return None,
    })
}

fn floor(g: &mut GltfBuilder, half: f32, material: usize) {
    let q = MeshData::quad(
        Vec3::new(-half, 0., -half),
        Vec3::new(half, 0., -half),
        Vec3::new(half, 0., half),
        Vec3::new(-half, 0., half),
        Vec3::Y,
    );
    g.add_mesh("floor", &q, material, Mat4::IDENTITY);
}

/// A horizontal square light of side `side` centred at `c`, facing down.
fn ceiling_light(c: Vec3, side: f32) -> MeshData {
    let h = side / 2.0;
    MeshData::quad(
        c + Vec3::new(-h, 0., -h),
        c + Vec3::new(h, 0., -h),
        c + Vec3::new(h, 0., h),
        c + Vec3::new(-h, 0., h),
        -Vec3::Y,
    )
}

/// A light of side 1e-3 and radiance 1e6, 5 cm above a floor that is diffuse on the left and
/// glossy metal (roughness 0.2) on the right.
fn tiny_bright_light() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let metal = g.material(&MaterialDesc::metal("glossy metal", Vec3::splat(0.8), 0.2));
    let light = g.material(&MaterialDesc::emitter("tiny light", Vec3::splat(1.0e6)));
    let half = |x0: f32, x1: f32| {
        MeshData::quad(
            Vec3::new(x0, 0., -0.3),
            Vec3::new(x1, 0., -0.3),
            Vec3::new(x1, 0., 0.3),
            Vec3::new(x0, 0., 0.3),
            Vec3::Y,
        )
    };
    g.add_mesh("diffuse floor", &half(-0.3, 0.0), diffuse, Mat4::IDENTITY);
    g.add_mesh("metal floor", &half(0.0, 0.3), metal, Mat4::IDENTITY);
    g.add_mesh("light", &ceiling_light(Vec3::new(0.0, 0.05, 0.0), 1.0e-3), light, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 0.35, 0.45), Vec3::new(0.0, 0.0, 0.0), 50.0);
    g
}

/// A wall of light standing on the floor: r² → 0 along the contact edge.
fn touching_light() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let light = g.material(&MaterialDesc::emitter("wall light", Vec3::splat(4.0)));
    floor(&mut g, 1.0, diffuse);
    let wall = MeshData::quad(
        Vec3::new(-0.5, 0., 0.),
        Vec3::new(0.5, 0., 0.),
        Vec3::new(0.5, 0.5, 0.),
        Vec3::new(-0.5, 0.5, 0.),
        Vec3::Z,
    );
    g.add_mesh("light", &wall, light, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 0.8, 1.4), Vec3::new(0.0, 0.0, 0.2), 50.0);
    g
}

/// A light tilted 1° from the floor's plane, seen from the floor at grazing angles (cos θ_l → 0).
fn grazing_light() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let light = g.material(&MaterialDesc::emitter("grazing light", Vec3::splat(20.0)));
    floor(&mut g, 1.0, diffuse);
    let tilt = 1f32.to_radians();
    let (y0, y1) = (0.02, 0.02 + 1.0 * tilt.sin());
    let q = MeshData::quad(
        Vec3::new(-0.5, y0, -1.0),
        Vec3::new(0.5, y0, -1.0),
        Vec3::new(0.5, y1, 0.0),
        Vec3::new(-0.5, y1, 0.0),
        -Vec3::Y,
    );
    g.add_mesh("light", &q, light, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 0.6, 1.6), Vec3::new(0.0, 0.0, 0.0), 50.0);
    g
}

/// Metal strips of roughness 0 (a perfect mirror), 0.001, 0.01 and 1 under a wall of light.
fn near_mirrors() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let light = g.material(&MaterialDesc::emitter("light wall", Vec3::new(3.0, 3.0, 2.5)));
    for (i, r) in [0.0f32, 0.001, 0.01, 1.0].into_iter().enumerate() {
        let m = g.material(&MaterialDesc::metal(&format!("metal {r}"), Vec3::splat(0.9), r));
        let x0 = -1.0 + 0.5 * i as f32;
        let q = MeshData::quad(
            Vec3::new(x0, 0., -1.),
            Vec3::new(x0 + 0.5, 0., -1.),
            Vec3::new(x0 + 0.5, 0., 1.),
            Vec3::new(x0, 0., 1.),
            Vec3::Y,
        );
        g.add_mesh(&format!("strip {i}"), &q, m, Mat4::IDENTITY);
    }
    let wall = MeshData::quad(
        Vec3::new(-1.5, 0., -1.2),
        Vec3::new(1.5, 0., -1.2),
        Vec3::new(1.5, 1.5, -1.2),
        Vec3::new(-1.5, 1.5, -1.2),
        Vec3::Z,
    );
    g.add_mesh("light", &wall, light, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 0.6, 2.0), Vec3::new(0.0, 0.0, -0.3), 50.0);
    g
}

/// 300 small lights over a floor, powers log-uniform over six orders of magnitude.
fn many_lights() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    floor(&mut g, 2.0, diffuse);
    let mut state = 12345u32;
    let mut next = move || {
        state = state.wrapping_mul(1664525).wrapping_add(1013904223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    for i in 0..300 {
        let radiance = 10f32.powf(next() * 6.0 - 3.0);
        let colour = Vec3::new(0.5 + 0.5 * next(), 0.5 + 0.5 * next(), 0.5 + 0.5 * next());
        let m = g.material(&MaterialDesc::emitter(&format!("light {i}"), colour * radiance));
        let c = Vec3::new(next() * 3.6 - 1.8, 0.3 + next() * 0.6, next() * 3.6 - 1.8);
        g.add_mesh(&format!("light {i}"), &ceiling_light(c, 0.05), m, Mat4::IDENTITY);
    }
    g.camera("camera", Vec3::new(0.0, 2.5, 3.5), Vec3::ZERO, 50.0);
    g
}

/// Where `far_cornell_box` puts the box, and how much larger it is.
pub const FAR_OFFSET: Vec3 = Vec3::new(1.0e5, 1.0e5, 1.0e5);
pub const FAR_SCALE: f32 = 10.0;

/// The Cornell box moved to 1e5 and scaled by 10 (camera too): radiance does not change with
/// scale, so its image must equal the box at the origin.
pub fn far_cornell_box() -> GltfBuilder {
    cornell_box().transformed(Mat4::from_translation(FAR_OFFSET) * Mat4::from_scale(Vec3::splat(FAR_SCALE)))
}

/// Zero-area and sliver triangles (also as emitters), a back-facing emitter, and a light inside
/// a closed box, next to one ordinary light.
fn degenerate() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let light = g.material(&MaterialDesc::emitter("light", Vec3::splat(5.0)));
    let hot = g.material(&MaterialDesc::emitter("degenerate emitter", Vec3::splat(50.0)));
    floor(&mut g, 1.0, diffuse);
    g.add_mesh("light", &ceiling_light(Vec3::new(0.0, 1.0, 0.0), 0.4), light, Mat4::IDENTITY);
    let tri = |a: Vec3, b: Vec3, c: Vec3| MeshData {
        positions: vec![a, b, c],
        normals: None,
        uvs: None,
        indices: vec![0, 1, 2],
    };
    // Zero area: two coincident vertices, and three collinear ones.
    g.add_mesh(
        "zero-area emitter",
        &tri(Vec3::new(0.2, 0.3, 0.), Vec3::new(0.2, 0.3, 0.), Vec3::new(0.4, 0.3, 0.)),
        hot,
        Mat4::IDENTITY,
    );
    g.add_mesh(
        "collinear emitter",
        &tri(Vec3::new(-0.4, 0.3, 0.), Vec3::new(-0.3, 0.3, 0.), Vec3::new(-0.2, 0.3, 0.)),
        hot,
        Mat4::IDENTITY,
    );
    g.add_mesh(
        "zero-area surface",
        &tri(Vec3::new(0., 0.1, 0.3), Vec3::new(0., 0.1, 0.3), Vec3::new(0.1, 0.1, 0.3)),
        diffuse,
        Mat4::IDENTITY,
    );
    // A sliver: 1 long, 1e-6 wide.
    g.add_mesh(
        "sliver emitter",
        &tri(Vec3::new(-0.5, 0.5, -0.5), Vec3::new(0.5, 0.5, -0.5), Vec3::new(0.0, 0.5, -0.500001)),
        hot,
        Mat4::IDENTITY,
    );
    // Facing up, away from the floor: only its back is seen from below.
    g.add_mesh("back-facing emitter", &ceiling_light(Vec3::new(0.6, 0.6, 0.4), 0.2).flipped(), hot, Mat4::IDENTITY);
    // A light sealed in a closed box: none of it may leak out.
    let box_corners =
        [Vec3::new(-0.8, 0., 0.4), Vec3::new(-0.4, 0., 0.4), Vec3::new(-0.4, 0., 0.8), Vec3::new(-0.8, 0., 0.8)];
    g.add_mesh("closed box", &MeshData::prism(box_corners, 0.4), diffuse, Mat4::IDENTITY);
    g.add_mesh("sealed light", &ceiling_light(Vec3::new(-0.6, 0.2, 0.6), 0.1), hot, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 1.2, 2.0), Vec3::new(0.0, 0.2, 0.0), 55.0);
    g
}

/// Radiance near the largest f32 (1e38) next to a tiny one (1e-30).
fn float_limits() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let huge = g.material(&MaterialDesc::emitter("huge", Vec3::splat(1.0e38)));
    let tiny = g.material(&MaterialDesc::emitter("tiny", Vec3::splat(1.0e-30)));
    floor(&mut g, 1.0, diffuse);
    g.add_mesh("huge light", &ceiling_light(Vec3::new(-0.4, 0.5, 0.0), 0.3), huge, Mat4::IDENTITY);
    g.add_mesh("tiny light", &ceiling_light(Vec3::new(0.4, 0.5, 0.0), 0.3), tiny, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 1.0, 1.8), Vec3::ZERO, 50.0);
    g
}

/// The camera inside a closed box, the light outside it.
fn camera_inside() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let diffuse = g.material(&MaterialDesc::lambert("diffuse", Vec3::splat(0.6)));
    let light = g.material(&MaterialDesc::emitter("light", Vec3::splat(5.0)));
    floor(&mut g, 2.0, diffuse);
    let corners =
        [Vec3::new(-0.5, 0., -0.5), Vec3::new(0.5, 0., -0.5), Vec3::new(0.5, 0., 0.5), Vec3::new(-0.5, 0., 0.5)];
    g.add_mesh("box", &MeshData::prism(corners, 1.0), diffuse, Mat4::IDENTITY);
    g.add_mesh("light", &ceiling_light(Vec3::new(0.0, 2.0, 0.0), 0.5), light, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 0.5, 0.2), Vec3::new(0.0, 0.3, -0.5), 60.0);
    g
}

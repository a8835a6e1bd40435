//! Scenes for the scaling measurements of `veach scale`, generated at any size and never
//! committed: the Cornell box around a tessellated sphere of about N triangles (traversal cost
//! against triangle count), and a floor under a fixed grid of small triangles of which K emit,
//! with a total power that does not depend on K (render time against light count).

use crate::cornell_box;
use crate::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};
use glam::{Mat4, Vec3};

/// Triangles of the Cornell box without the sphere.
const CORNELL_TRIANGLES: usize = 36;

/// The Cornell box with a white sphere floating left of the tall box, tessellated so that the
/// scene has about `triangles` triangles (at least the box's 36 plus 24 for the sphere).
pub fn triangle_scene(triangles: usize) -> GltfBuilder {
    let mut g = cornell_box();
    // A UV sphere of s stacks and 2s slices has 2s · (2s − 2) = 4s(s − 1) triangles.
    let wanted = triangles.saturating_sub(CORNELL_TRIANGLES).max(24) as f64;
    let stacks = ((1.0 + (1.0 + wanted).sqrt()) / 2.0).round().max(3.0) as u32;
    let white = g.material(&MaterialDesc::lambert("sphere", Vec3::splat(0.73)));
    let sphere = MeshData::sphere(Vec3::new(1.8, 3.6, 2.0), 0.8, 2 * stacks, stacks);
    g.add_mesh("sphere", &sphere, white, Mat4::IDENTITY);
    g
}

/// A 4 m × 4 m diffuse floor under a square grid of `grid` small triangles 1 m above it, of which
/// `lights` (spread evenly over the grid) emit, each its own light; the others are grey and
/// shadow the floor like the emitters do. The geometry is the same for every light count, so the
/// render time measures what the lights cost, not the triangles; the emitters' radiance is scaled
/// by 1 / `lights`, so the total power is the same too. `grid` is raised to `lights` if smaller.
pub fn light_scene(lights: usize, grid: usize) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let floor = g.material(&MaterialDesc::lambert("floor", Vec3::splat(0.6)));
    g.add_mesh(
        "floor",
        &MeshData::quad(
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(2.0, 0.0, -2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::Y,
        ),
        floor,
        Mat4::IDENTITY,
    );
    let lights = lights.max(1);
    let grid = grid.max(lights);
    let per_side = (grid as f64).sqrt().ceil() as usize;
    let spacing = 3.0 / per_side as f32;
    let side = (0.5 * spacing).min(0.05);
    let emitter = g.material(&MaterialDesc::emitter("light", Vec3::splat(2000.0 / lights as f32)));
    let grey = g.material(&MaterialDesc::lambert("tile", Vec3::splat(0.5)));
    let mut tiles = MeshData::default();
    for i in 0..grid {
        let (row, col) = (i / per_side, i % per_side);
        let c = Vec3::new(-1.5 + (col as f32 + 0.5) * spacing, 1.0, -1.5 + (row as f32 + 0.5) * spacing);
        // (x̂ side) × (ẑ side) points down: counter-clockwise seen from the floor, so the
        // triangle's front face looks down at it.
        let tri = MeshData {
            positions: vec![c, c + Vec3::new(side, 0.0, 0.0), c + Vec3::new(0.0, 0.0, side)],
            normals: None,
            uvs: None,
            indices: vec![0, 1, 2],
        };
        // Triangle i emits where i · lights / grid steps to the next integer.
        if (i * lights) / grid != ((i + 1) * lights) / grid {
            g.add_mesh(&format!("light {i}"), &tri, emitter, Mat4::IDENTITY);
        } else {
            tiles.append(&tri);
        }
    }
    if !tiles.indices.is_empty() {
        g.add_mesh("tiles", &tiles, grey, Mat4::IDENTITY);
    }
    g.camera("camera", Vec3::new(0.0, 2.2, 3.2), Vec3::new(0.0, 0.0, 0.0), 50.0);
    g
}

//! A uniform grid over the area lights' triangles, for BVH kernels whose direction samples find
//! emitters in two steps (`EMITTER_LIST`, `trace_emitters` in shaders/traverse_bvh.wgsl): the
//! nearest emitting triangle along the ray from this grid alone, then a shadow ray to it
//! (`direction_sample_to_emitters` in direction_samples.wgsl), as baked kernels do with their emitters'
//! list. A BRDF sample adds only the emission it finds, and a closest hit over the whole BVH walks
//! the tree's depth to learn that a ray passes between small lights: about 6.3 four-wide steps
//! over `veach scale`'s 10,000 lights, where the grid looks in one cell (docs/performance.md,
//! "The emitters' grid").
//!
//! The ray walks the cells it crosses in order (Amanatides & Woo, "A Fast Voxel Traversal
//! Algorithm for Ray Tracing", Eurographics 1987) and stops once its nearest hit lies within the
//! cell it is in. Each triangle is listed in every cell its box, grown by `margin`, overlaps, so a
//! hit that rounding puts a little past a cell's boundary is still in the cell the walk is in.
//! A grid pays where a ray crosses few cells: `EmitterGrid::expected_cells`.

use crate::gpu::layout::{IndexedTriangle, NO_LIGHT, Vertex};
use glam::{DVec3, Vec3};

/// Words before the cells' starts: lo.xyz, res.x, hi.xyz, res.y, scale.xyz, res.z (f32 as bits;
/// scale: cells per unit length). The cells' starts follow (one more than there are cells), then
/// the triangles' indices. Read by `trace_emitters` (traverse_bvh.wgsl).
pub const HEADER_WORDS: usize = 12;
/// Cells per emitting triangle the grid aims at.
const CELLS_PER_TRIANGLE: f64 = 2.0;
/// The most cells along one axis, and in all.
const MAX_AXIS_CELLS: f64 = 1024.0;
const MAX_CELLS: f64 = (1 << 20) as f64;
/// Kernels take the grid where a ray that crosses its box is expected to visit at most this many
/// cells (`expected_cells`): lights spread over a plane (one cell), or few lights.
pub const MAX_EXPECTED_CELLS: f64 = 4.0;

pub struct EmitterGrid {
    /// Cells along each axis.
    pub res: [u32; 3],
    /// The buffer's words (`HEADER_WORDS`).
    pub words: Vec<u32>,
    /// Cells a ray that crosses the box visits on average (`expected_cells`).
    pub expected_cells: f64,
}

impl EmitterGrid {
    /// The grid over the triangles whose `triangle_lights` entry is a light, or None without any
    /// (or with a box that is not finite).
    pub fn build(vertices: &[Vertex], triangles: &[IndexedTriangle], triangle_lights: &[u32]) -> Option<EmitterGrid> {
        let corners = |t: &IndexedTriangle| [t.v0, t.v1, t.v2].map(|v| Vec3::from_array(vertices[v as usize].p));
        let emitters: Vec<(u32, [Vec3; 3])> = triangles
            .iter()
            .zip(triangle_lights)
            .enumerate()
            .filter(|(_, (_, l))| **l != NO_LIGHT)
            .map(|(i, (t, _))| (i as u32, corners(t)))
            .collect();
        if emitters.is_empty() {
            return None;
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (_, c) in &emitters {
            for p in c {
                (lo, hi) = (lo.min(*p), hi.max(*p));
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        // Grown by the binning margin, so that the box holds every grown triangle box: a margin
        // far above f32 rounding of the positions and of the walk's distances (below).
        let extent = (hi - lo).as_dvec3();
        // At least a tiny length, so that the box has a size and its cells a finite scale.
        let margin = (2e-4 * extent.max_element() + 4e-6 * lo.abs().max(hi.abs()).max_element() as f64).max(1e-30);
        let (lo, hi) = (lo.as_dvec3() - margin, hi.as_dvec3() + margin);
        let res = resolution(hi - lo, emitters.len());
        let size = hi - lo;
        let scale = DVec3::from_array(res.map(f64::from)) / size;
        // The kernel reads them as f32: lights near f32's limits get no grid.
        if ![lo, hi, scale].iter().all(|v| v.as_vec3().is_finite()) {
            return None;
        }
        let cell_of = |p: DVec3| {
            let c = ((p - lo) * scale).floor();
            [0, 1, 2].map(|k| (c[k].max(0.0) as u32).min(res[k] - 1))
        };
        let cells = (res[0] * res[1] * res[2]) as usize;
        let index = |x: u32, y: u32, z: u32| ((z * res[1] + y) * res[0] + x) as usize;
        let ranges: Vec<(u32, [[u32; 3]; 2])> = emitters
            .iter()
            .map(|(i, c)| {
                let (a, b) = (c[0].min(c[1]).min(c[2]).as_dvec3(), c[0].max(c[1]).max(c[2]).as_dvec3());
                (*i, [cell_of(a - margin), cell_of(b + margin)])
            })
            .collect();
        let mut counts = vec![0u32; cells + 1];
        let each_cell = |[a, b]: [[u32; 3]; 2], f: &mut dyn FnMut(usize)| {
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        f(index(x, y, z));
                    }
                }
            }
        };
        for &(_, r) in &ranges {
            each_cell(r, &mut |c| counts[c + 1] += 1);
        }
        for c in 0..cells {
            counts[c + 1] += counts[c];
        }
        let mut entries = vec![0u32; counts[cells] as usize];
        let mut fill = counts.clone();
        for &(i, r) in &ranges {
            each_cell(r, &mut |c| {
                entries[fill[c] as usize] = i;
                fill[c] += 1;
            });
        }
        let f = |v: f64| (v as f32).to_bits();
        let mut words = vec![
            f(lo.x),
            f(lo.y),
            f(lo.z),
            res[0],
            f(hi.x),
            f(hi.y),
            f(hi.z),
            res[1],
            f(scale.x),
            f(scale.y),
            f(scale.z),
            res[2],
        ];
        debug_assert_eq!(words.len(), HEADER_WORDS);
        words.extend_from_slice(&counts);
        words.extend_from_slice(&entries);
        Some(EmitterGrid { res, words, expected_cells: expected_cells(size, res) })
    }

    /// Whether kernels take the grid (`MAX_EXPECTED_CELLS`).
    pub fn pays(&self) -> bool {
        self.expected_cells <= MAX_EXPECTED_CELLS
    }
}

/// Cells along each axis for `n` triangles in a box of `size`: about `CELLS_PER_TRIANGLE` · n
/// cubic cells, one along an axis shorter than a cell (lights in a plane get a plane of cells).
fn resolution(size: DVec3, n: usize) -> [u32; 3] {
    let target = (CELLS_PER_TRIANGLE * n as f64).min(MAX_CELLS);
    let mut flat = [false; 3];
    // Cells per unit length over the axes not flat; an axis shorter than a cell turns flat.
    let mut per_unit = 0.0;
    for _ in 0..3 {
        let axes: Vec<f64> = (0..3).filter(|&k| !flat[k]).map(|k| size[k]).collect();
        if axes.is_empty() || axes.iter().any(|&e| e <= 0.0) {
            (0..3).filter(|&k| size[k] <= 0.0).for_each(|k| flat[k] = true);
            continue;
        }
        per_unit = (target / axes.iter().product::<f64>()).powf(1.0 / axes.len() as f64);
        let shorter: Vec<usize> = (0..3).filter(|&k| !flat[k] && size[k] * per_unit < 1.0).collect();
        if shorter.is_empty() {
            break;
        }
        shorter.into_iter().for_each(|k| flat[k] = true);
    }
    [0, 1, 2].map(|k| if flat[k] { 1 } else { (size[k] * per_unit).round().clamp(1.0, MAX_AXIS_CELLS) as u32 })
}

/// Cells a line that crosses the box visits on average, for lines of uniformly random direction
/// and position: 1 plus the cell boundaries it crosses. A line crosses axis k's inner boundaries
/// (res_k - 1 of them, every size_k / res_k) about |Δ_k| res_k / size_k times, where Δ is its
/// chord; the mean chord of a convex body is 4V / S (Cauchy's formula; Santaló, "Integral
/// Geometry and Geometric Probability", 1976, §I.4), and its mean |component| along an axis
/// half of that.
fn expected_cells(size: DVec3, res: [u32; 3]) -> f64 {
    let volume = size.x * size.y * size.z;
    let surface = 2.0 * (size.x * size.y + size.y * size.z + size.z * size.x);
    if surface <= 0.0 {
        return 1.0;
    }
    let half_chord = 2.0 * volume / surface;
    1.0 + (0..3).filter(|&k| res[k] > 1).map(|k| half_chord * (res[k] - 1) as f64 / size[k]).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(p: [f32; 3]) -> Vertex {
        Vertex { p, normal: 0 }
    }

    #[test]
    fn lights_in_a_plane_get_a_plane_of_cells() {
        // A 100 × 100 grid of small triangles at y = 1, every other one a light.
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        let mut lights = Vec::new();
        for i in 0..10_000u32 {
            let (x, z) = ((i % 100) as f32 * 0.03, (i / 100) as f32 * 0.03);
            let v = vertices.len() as u32;
            vertices.extend([vertex([x, 1.0, z]), vertex([x + 0.015, 1.0, z]), vertex([x, 1.0, z + 0.015])]);
            triangles.push(IndexedTriangle { v0: v, v1: v + 1, v2: v + 2, material: 0 });
            lights.push(if i % 2 == 0 { i } else { NO_LIGHT });
        }
        let grid = EmitterGrid::build(&vertices, &triangles, &lights).unwrap();
        assert_eq!(grid.res[1], 1, "{:?}", grid.res);
        let cells = grid.res.iter().product::<u32>() as f64;
        assert!((cells / 10_000.0 - 1.0).abs() < 0.1, "{:?}", grid.res);
        // A thin slab (the binning margin thick): a grazing ray crosses a few cells.
        assert!(grid.expected_cells < 1.1, "{}", grid.expected_cells);
        assert!(grid.pays());
        // Every light is listed, no other triangle; each in at most four cells.
        let starts = &grid.words[HEADER_WORDS..HEADER_WORDS + cells as usize + 1];
        let entries = &grid.words[HEADER_WORDS + cells as usize + 1..];
        assert_eq!(entries.len(), starts[cells as usize] as usize);
        let mut listed: Vec<u32> = entries.to_vec();
        listed.sort();
        listed.dedup();
        assert_eq!(listed, (0..10_000).step_by(2).collect::<Vec<u32>>());
        assert!(entries.len() <= 4 * 5000);
    }

    #[test]
    fn lights_filling_a_volume_do_not_pay() {
        // Points spread through a unit cube: about 21 cells along each axis, about 21 visited.
        let n = 4096u32;
        let vertices: Vec<Vertex> = (0..n)
            .flat_map(|i| {
                let p = [(i % 16) as f32 / 16.0, ((i / 16) % 16) as f32 / 16.0, (i / 256) as f32 / 16.0];
                [vertex(p), vertex([p[0] + 0.01, p[1], p[2]]), vertex([p[0], p[1] + 0.01, p[2]])]
            })
            .collect();
        let triangles: Vec<IndexedTriangle> =
            (0..n).map(|i| IndexedTriangle { v0: 3 * i, v1: 3 * i + 1, v2: 3 * i + 2, material: 0 }).collect();
        let grid = EmitterGrid::build(&vertices, &triangles, &vec![0; n as usize]).unwrap();
        assert!(grid.res.iter().all(|&r| (18..=22).contains(&r)), "{:?}", grid.res);
        assert!(grid.expected_cells > 15.0 && !grid.pays(), "{}", grid.expected_cells);
        assert!(EmitterGrid::build(&vertices, &triangles, &vec![NO_LIGHT; n as usize]).is_none());
    }

    #[test]
    fn a_light_of_no_size_or_near_f32s_limits() {
        // Every corner at the origin: a box of the smallest margin, one cell of finite scale.
        let vertices = vec![vertex([0.0; 3]); 3];
        let triangles = [IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 }];
        let grid = EmitterGrid::build(&vertices, &triangles, &[0]).unwrap();
        assert_eq!(grid.res, [1, 1, 1]);
        assert!(grid.words[..HEADER_WORDS].iter().all(|&w| f32::from_bits(w).is_finite()));
        // A light reaching f32::MAX: its grown box is not an f32 box.
        let far = [vertex([f32::MAX, 0.0, 0.0]), vertex([0.0, 1.0, 0.0]), vertex([0.0, 0.0, 1.0])];
        assert!(EmitterGrid::build(&far, &triangles, &[0]).is_none());
    }

    #[test]
    fn the_kernel_reads_the_header_this_writes() {
        let wgsl = include_str!("../../../../shaders/traverse_bvh.wgsl");
        assert!(wgsl.contains(&format!("const EMITTER_GRID_HEADER: u32 = {HEADER_WORDS}u;")));
    }

    #[test]
    fn the_mean_chord_is_cauchys() {
        // A cube of side 2 in 4 cells a side: mean chord 4V/S = 4/3, so 1 + 3 · (2/3) · 3 / 2 = 4.
        assert!((expected_cells(DVec3::splat(2.0), [4, 4, 4]) - 4.0).abs() < 1e-12);
        assert_eq!(expected_cells(DVec3::new(3.0, 0.0, 3.0), [100, 1, 100]), 1.0);
    }
}

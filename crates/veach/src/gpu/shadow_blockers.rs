//! The triangles that no shadow ray can meet before its end. A shadow ray runs from a point of the
//! scene (a point of some triangle, offset off it) to a point of an area light or a point or spot
//! light's position, short of it by a margin (light_samples.wgsl). A segment meets a plane at most
//! once unless it lies in it, where the watertight test reports no hit (det = 0). So a triangle
//! cannot block one when
//! - every corner of the scene and every point or spot light lies on one closed side of its plane
//!   (a wall of a room, the floor, a backdrop curving up behind the scene: the segment's ends lie
//!   on that side), or
//! - every point a shadow ray aims at lies in its plane (the one planar light, or a triangle
//!   beside it in that plane: the segment meets the plane only at its end, past the margin).
//!
//! With a directional light every triangle may block: its shadow rays run to infinity, across any
//! plane. Baked kernels leave the others out of the shadow rays' list
//! (`BakedTriangles::mark_blockers`). BVH kernels do not: tagging the subtrees that such
//! triangles alone fill was neutral on lavapipe (docs/performance.md).

use glam::Vec3;
use std::collections::HashSet;

/// Past this many triangle × corner tests the scene is not examined and every triangle may block
/// (the test is quadratic; a baked scene's 64 triangles take at most 12,288).
pub const MAX_SHADOW_BLOCKER_TESTS: usize = 50_000_000;

/// For each triangle (its corners, and whether it emits): true where a shadow ray may meet it.
/// `delta_lights` holds the point and spot lights' positions, or is None where a directional
/// light exists. "On a side" and "in a plane" allow 1e-6 of the scene's largest coordinate, for
/// the rounding of corners meant to lie in one plane: geometry that pokes through a wall by less
/// than that is taken as in front of it.
pub fn shadow_blockers(triangles: &[[Vec3; 3]], emits: &[bool], delta_lights: Option<&[Vec3]>) -> Vec<bool> {
    let all = vec![true; triangles.len()];
    let Some(delta_lights) = delta_lights else {
        return all;
    };
    let f64s = |p: Vec3| [p.x as f64, p.y as f64, p.z as f64];
    let mut seen = HashSet::new();
    let scene_points: Vec<[f64; 3]> = triangles
        .iter()
        .flatten()
        .chain(delta_lights)
        .filter(|p| seen.insert(p.to_array().map(f32::to_bits)))
        .map(|&p| f64s(p))
        .collect();
    if triangles.len().saturating_mul(scene_points.len()) > MAX_SHADOW_BLOCKER_TESTS {
        return all;
    }
    let light_points: Vec<[f64; 3]> = triangles
        .iter()
        .zip(emits)
        .filter(|(_, e)| **e)
        .flat_map(|(t, _)| t.iter().copied())
        .chain(delta_lights.iter().copied())
        .map(f64s)
        .collect();
    let largest = scene_points.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let tolerance = 1e-6 * largest;
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    triangles
        .iter()
        .map(|corners| {
            let [p0, p1, p2] = corners.map(f64s);
            let (e1, e2) = (sub(p1, p0), sub(p2, p0));
            let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if !(len > 0.0 && len.is_finite()) {
                return true;
            }
            let distance = |p: &[f64; 3]| {
                let d = sub(*p, p0);
                (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / len
            };
            let (mut below, mut above) = (false, false);
            for p in &scene_points {
                let d = distance(p);
                below |= d < -tolerance;
                above |= d > tolerance;
                if below && above {
                    break;
                }
            }
            let one_side = !(below && above);
            let aimed_at_in_plane =
                !light_points.is_empty() && light_points.iter().all(|p| distance(p).abs() <= tolerance);
            !(one_side || aimed_at_in_plane)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A floor quad (y = 0) and a wall quad (x = 1) of a room, a quad light just under the ceiling
    /// (y = 1.9, the wall's top at 2), and a tilted tile in the room between floor and light.
    fn room() -> (Vec<[Vec3; 3]>, Vec<bool>) {
        let quad = |c: [[f32; 3]; 4]| {
            let [a, b, c, d] = c.map(Vec3::from_array);
            [[a, b, c], [a, c, d]]
        };
        let triangles = [
            quad([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.0, 1.0]]),
            quad([[1.0, 0.0, 0.0], [1.0, 2.0, 0.0], [1.0, 2.0, 1.0], [1.0, 0.0, 1.0]]),
            quad([[0.4, 1.9, 0.4], [0.6, 1.9, 0.4], [0.6, 1.9, 0.6], [0.4, 1.9, 0.6]]),
            quad([[0.3, 1.0, 0.3], [0.7, 1.0, 0.3], [0.7, 1.2, 0.7], [0.3, 1.2, 0.7]]),
        ]
        .concat();
        let emits = (0..8).map(|i| i / 2 == 2).collect();
        (triangles, emits)
    }

    #[test]
    fn walls_and_the_planar_light_block_no_shadow_ray_and_a_tile_in_the_room_does() {
        let (triangles, emits) = room();
        let f = false;
        assert_eq!(shadow_blockers(&triangles, &emits, Some(&[])), [f, f, f, f, f, f, true, true]);
        // A point light outside the wall (x > 1): its shadow rays cross the wall's plane, and the
        // light quad is no longer the only thing they aim at.
        let outside = [Vec3::new(1.5, 1.0, 0.5)];
        assert_eq!(shadow_blockers(&triangles, &emits, Some(&outside)), [f, f, true, true, true, true, true, true]);
        // A directional light's shadow rays run to infinity, across any plane.
        assert!(shadow_blockers(&triangles, &emits, None).iter().all(|&b| b));
    }

    #[test]
    fn a_degenerate_triangle_or_too_large_a_scene_keeps_every_triangle() {
        let (mut triangles, mut emits) = room();
        triangles.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
        emits.push(false);
        assert!(shadow_blockers(&triangles, &emits, Some(&[]))[8], "a line has no plane to judge by");
        let n = 8000;
        let many: Vec<[Vec3; 3]> = (0..n).map(|i| [Vec3::splat(i as f32), Vec3::X, Vec3::Y]).collect();
        assert!(n * 3 * n > MAX_SHADOW_BLOCKER_TESTS);
        assert!(shadow_blockers(&many, &vec![false; n], Some(&[])).iter().all(|&b| b));
    }
}

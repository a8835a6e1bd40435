//! The shape of an area light, decided once from its triangles for the light records, the scene's
//! features and the Mitsuba exporter: convex (its shadow rays skip the BVH subtrees it alone fills,
//! `gpu::light_subtrees`), round (sampled by its bounding sphere's cone), a parallelogram (area
//! samples map the unit square onto it) and a rectangle (sampled by its solid angle as a whole);
//! and, when the scene is loaded, which emissive meshes are split into lights of their own parts
//! (`light_parts`).

use super::Scene;
use glam::Vec3;
use std::collections::HashSet;

/// What the kernels need to know of an area light's shape: convex (`is_convex`:
/// its shadow rays skip its subtrees), round (convex and `is_round` with the
/// bounding sphere its GPU record gets: `LightSampling::Cone` samples it by that sphere's cone)
/// and a parallelogram (`parallelogram_corner`: area samples map the unit square
/// onto it linearly). The one place they are decided, for the light records and `SceneFeatures`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AreaLightShape {
    pub convex: bool,
    pub round: bool,
    /// The corner of the light's first triangle opposite the edge it shares with the second.
    pub parallelogram: Option<u32>,
    /// A parallelogram whose edges at that corner are perpendicular (`is_rectangle`): sampled
    /// uniformly in its solid angle (Ureña et al. 2013) where light samples go by solid angle.
    pub rectangle: bool,
}

pub fn area_light_shape(scene: &Scene, triangles: &[u32]) -> AreaLightShape {
    area_light_shape_of(&triangle_corners(scene, triangles))
}

/// The same, from the light's triangles' corners.
pub fn area_light_shape_of(corners: &[[Vec3; 3]]) -> AreaLightShape {
    let (_, radius) = bounding_sphere(corners.iter().flatten().copied());
    let convex = is_convex(corners);
    let parallelogram = parallelogram_corner(corners);
    AreaLightShape {
        convex,
        round: convex && is_round(corners, radius),
        parallelogram,
        rectangle: parallelogram.is_some_and(|k| is_rectangle(&corners[0], k)),
    }
}

/// The sphere a round area light approximates, for `mitsuba::export`'s analytic spheres: the
/// bounding sphere's centre and the radius of equal surface area, sqrt(A / 4π) (so that the sphere
/// emits the power the triangles do); None where the light is not round.
pub fn round_light_sphere(scene: &Scene, triangles: &[u32]) -> Option<(Vec3, f32)> {
    if !area_light_shape(scene, triangles).round {
        return None;
    }
    let (centre, _) = bounding_sphere(triangle_corners(scene, triangles).into_iter().flatten());
    let area: f64 = triangles.iter().map(|&t| scene.triangles[t as usize].area() as f64).sum();
    Some((centre, (area / (4.0 * std::f64::consts::PI)).sqrt() as f32))
}

/// Mesh lights of more triangles stay one light: a part costs a light record and two light tree
/// nodes (144 bytes) where a triangle of a whole light costs a 16-byte alias bucket, so 2^16
/// parts are 9 MiB.
pub const MAX_SPLIT_TRIANGLES: usize = 1 << 16;

/// The parts an emissive mesh is split into, each a light of its own, as ranges of its triangles.
/// A flat light (`is_flat`) and a round one (cone sampling takes it whole) stay one light: their
/// triangles all face one way, so choosing among them by area loses nothing. A curved one (a
/// torus, a tube, a bent strip) is split, each triangle a light, or each two consecutive triangles
/// that make a parallelogram (parallelogram and rectangle sampling take those): the light tree
/// then chooses among its parts by power, distance and orientation at each shading point (Conty
/// Estevez & Kulla 2018), where a whole light's triangles were chosen by area alone, half of them
/// facing away. pbrt-v4 makes every triangle of an emissive mesh a light for the same reason.
pub fn light_parts(corners: &[[Vec3; 3]]) -> Vec<std::ops::Range<usize>> {
    let whole = std::iter::once(0..corners.len()).collect();
    if corners.len() > MAX_SPLIT_TRIANGLES || is_flat(corners) || area_light_shape_of(corners).round {
        return whole;
    }
    let mut parts = Vec::new();
    let mut i = 0;
    while i < corners.len() {
        let n = if i + 1 < corners.len() && parallelogram_corner(&corners[i..i + 2]).is_some() { 2 } else { 1 };
        parts.push(i..i + n);
        i += n;
    }
    parts
}

/// Do all `triangles` lie in the first one's plane, within 1e-5 of the light's size, and face the
/// way it does? A triangle without a plane (zero area) is not flat.
pub fn is_flat(triangles: &[[Vec3; 3]]) -> bool {
    let Some(&[p0, p1, p2]) = triangles.first() else { return false };
    let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    let (lo, hi) = point_bounds(triangles.iter().flatten().copied());
    let tolerance = 1e-5 * (hi - lo).length();
    n != Vec3::ZERO
        && tolerance.is_finite()
        && triangles.iter().all(|&[a, b, c]| {
            (b - a).cross(c - a).dot(n) > 0.0 && [a, b, c].iter().all(|&p| n.dot(p - p0).abs() <= tolerance)
        })
}

/// The smallest box holding `points` (min, max).
pub(crate) fn point_bounds(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

/// A sphere around `points`: the centre of their bounding box, the farthest point's distance
/// (not the smallest sphere, but within a factor sqrt(3) of it), grown by a relative 1e-5 so that
/// rounding never leaves a point outside.
pub(crate) fn bounding_sphere(points: impl Iterator<Item = Vec3> + Clone) -> (Vec3, f32) {
    let (lo, hi) = point_bounds(points.clone());
    let centre = 0.5 * (lo + hi);
    let radius = points.map(|p| p.distance(centre)).fold(0.0f32, f32::max);
    (centre, radius * (1.0 + 1e-5) + 1e-5 * centre.abs().max_element())
}

pub(crate) fn triangle_corners(scene: &Scene, triangles: &[u32]) -> Vec<[Vec3; 3]> {
    triangles.iter().map(|&t| scene.triangles[t as usize].p).collect()
}

/// Lights of more triangles are not tested (the test is quadratic in them) and never skipped.
pub const MAX_CONVEX_TEST_TRIANGLES: usize = 4096;

/// Does every vertex of `triangles` lie behind or on every triangle's plane (its front given by
/// the winding, as the emitted side is), within a rounding tolerance of 1e-5 of the light's size?
/// Planar lights pass; a light whose triangles face each other does not.
pub fn is_convex(triangles: &[[Vec3; 3]]) -> bool {
    if triangles.is_empty() || triangles.len() > MAX_CONVEX_TEST_TRIANGLES {
        return false;
    }
    let mut seen = HashSet::new();
    let vertices: Vec<Vec3> =
        triangles.iter().flatten().copied().filter(|p| seen.insert(p.to_array().map(f32::to_bits))).collect();
    let (lo, hi) = vertices.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let tolerance = 1e-5 * (hi - lo).length();
    if !tolerance.is_finite() {
        return false;
    }
    triangles.iter().all(|[p0, p1, p2]| {
        let n = (*p1 - *p0).cross(*p2 - *p0);
        let len = n.length();
        // A degenerate triangle has no plane; it is never hit either.
        if len.is_nan() || len <= 0.0 {
            return true;
        }
        let n = n / len;
        vertices.iter().all(|&v| n.dot(v - *p0) <= tolerance)
    })
}

/// Is a light, convex (`is_convex`, which the caller tests), round enough to be sampled by the cone its bounding sphere (of `radius`)
/// subtends (`LightSampling::Cone`)? A convex body's projected area averaged over all directions
/// is a quarter of its surface area (Cauchy's surface area formula), so a direction uniform in the
/// cone meets the light with probability about A / (4π r²) for a distant receiver. Area sampling
/// of a convex light wastes about half its samples on the side facing away; the cone is taken where
/// it wastes no more: A / (4π r²) >= 1/2 (a tessellated sphere about 0.99, a cube 0.64, a square
/// 0.16).
pub fn is_round(triangles: &[[Vec3; 3]], radius: f32) -> bool {
    let area: f64 = triangles.iter().map(|[p0, p1, p2]| 0.5 * (*p1 - *p0).cross(*p2 - *p0).length() as f64).sum();
    let sphere = 4.0 * std::f64::consts::PI * (radius as f64).powi(2);
    sphere > 0.0 && area >= 0.5 * sphere
}

/// Do a light's two triangles make one parallelogram, each sharing an edge with the other and
/// facing the same way? Then `Some(k)`: corner k of the first triangle is the one opposite the
/// shared edge, and the light is the parallelogram spanned from it by its two edges there, which
/// light samples map the unit square onto linearly (lights.wgsl, `light_parallelogram`). Corners
/// within 1e-5 of the light's size of where the parallelogram puts them count as there.
pub fn parallelogram_corner(triangles: &[[Vec3; 3]]) -> Option<u32> {
    let [first, second] = triangles else { return None };
    let normal = |t: &[Vec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
    let (n0, n1) = (normal(first), normal(second));
    let size = first.iter().chain(second).map(|p| p.distance(first[0])).fold(0.0f32, f32::max);
    let tolerance = 1e-5 * size;
    if !(n0.length() > 0.0 && n1.length() > 0.0 && n0.dot(n1) > 0.0 && tolerance.is_finite()) {
        return None;
    }
    let near = |a: Vec3, b: Vec3| a.distance(b) <= tolerance;
    (0..3u32).find(|&k| {
        let k = k as usize;
        let (origin, s0, s1) = (first[k], first[(k + 1) % 3], first[(k + 2) % 3]);
        let fourth = s0 + s1 - origin;
        // The second triangle's corners are the shared edge's ends and the fourth corner, once each.
        [s0, s1, fourth].iter().all(|&c| second.iter().filter(|&&q| near(q, c)).count() == 1)
    })
}

/// Lights and emitter triangles that subtend less than this (sr) keep area sampling where light
/// samples go by solid angle (shaders/lights.wgsl, MIN_SPHERICAL_SAMPLE_AREA: the same number).
pub const MIN_SPHERICAL_SAMPLE_SOLID_ANGLE: f32 = 1e-2;

/// Can some rectangle light of the scene subtend MIN_SPHERICAL_SAMPLE_SOLID_ANGLE from a point of
/// a triangle not its own, so that solid-angle sampling ever takes it? A planar light of area A
/// within radius r of its centre subtends at most A / d² from a point d beyond that sphere, so
/// only triangles within r + √(A / Ω_min) of the centre can see it that wide, and of a one-sided
/// light only those with a corner in front of it (not the ceiling it hangs from). Where none can,
/// kernels leave the spherical rectangles out: on drivers that run both sides of a branch
/// (Mesa 22.3's lavapipe) their code costs time even where no sample takes it.
pub fn rectangle_lights_seen_wide(scene: &Scene, bvh: &crate::bvh::Bvh) -> bool {
    scene.lights.iter().any(|light| {
        let crate::scene::LightKind::Area { triangles, double_sided, .. } = &light.kind else { return false };
        // Only the two tests a rectangle needs (area_light_shape's convexity test is quadratic).
        let corners = triangle_corners(scene, triangles);
        if !parallelogram_corner(&corners).is_some_and(|k| is_rectangle(&corners[0], k)) {
            return false;
        }
        let (centre, radius) = bounding_sphere(corners.iter().flatten().copied());
        let area: f32 = triangles.iter().map(|&t| scene.triangles[t as usize].area()).sum();
        let reach = radius + (area / MIN_SPHERICAL_SAMPLE_SOLID_ANGLE).sqrt();
        let [p0, p1, p2] = corners[0];
        let normal = (p1 - p0).cross(p2 - p0);
        let in_front = |t: &super::Triangle| *double_sided || t.p.iter().any(|&p| normal.dot(p - p0) > 0.0);
        bvh.any_triangle_near(&scene.triangles, centre, reach, |i, t| !triangles.contains(&i) && in_front(t))
    })
}

/// The most |cos| between a rectangle light's edges. The spherical rectangle sampler takes the
/// edges as perpendicular and maps its points back onto the parallelogram, so a skew of cos ε
/// moves the density by about ε: 1e-4 is far below what any estimate resolves, and far above the
/// rounding of a rectangle written in f32 (about 1e-7).
pub const MAX_RECTANGLE_SKEW: f32 = 1e-4;

/// Are the edges of parallelogram light's first triangle at its corner k (`parallelogram_corner`)
/// perpendicular, within MAX_RECTANGLE_SKEW?
pub fn is_rectangle(first: &[Vec3; 3], k: u32) -> bool {
    let k = k as usize;
    let (u, v) = (first[(k + 1) % 3] - first[k], first[(k + 2) % 3] - first[k]);
    let lengths = u.length() * v.length();
    lengths > 0.0 && u.dot(v).abs() <= MAX_RECTANGLE_SKEW * lengths
}

#[cfg(test)]
mod tests {
    use super::*;
    use veach_scenes::gltf_writer::MeshData;

    fn triangles(mesh: &MeshData) -> Vec<[Vec3; 3]> {
        mesh.indices.chunks(3).map(|i| [0, 1, 2].map(|k| mesh.positions[i[k] as usize])).collect()
    }

    #[test]
    fn two_triangles_sharing_an_edge_make_a_parallelogram_light_when_their_fourth_corner_fits() {
        let (a, b, c) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(2.5, 1.0, 1.0));
        let d = a + c - b;
        // Each rotation of the first triangle's corners names its corner opposite the diagonal a-c.
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, c, d]]), Some(1));
        assert_eq!(parallelogram_corner(&[[b, c, a], [a, c, d]]), Some(0));
        assert_eq!(parallelogram_corner(&[[c, a, b], [d, a, c]]), Some(2));
        // The shipped-style fan of a square, and the other diagonal.
        let quad = triangles(&MeshData::quad(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::Z));
        assert_eq!(parallelogram_corner(&quad), Some(1));
        assert_eq!(parallelogram_corner(&[[a, b, d], [b, c, d]]), Some(0));
        // Not one: a kite (the fourth corner moved in the plane), a fold (moved off it), opposite
        // windings, a triangle short, one too many, and a degenerate pair.
        let kite = d + Vec3::new(0.2, -0.1, 0.0);
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, c, kite]]), None);
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, c, d + Vec3::Z * 0.1]]), None);
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, d, c]]), None);
        assert_eq!(parallelogram_corner(&[[a, b, c]]), None);
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, c, d], [a, c, d]]), None);
        assert_eq!(parallelogram_corner(&[[a, a, c], [a, c, c]]), None);
        // Rounding within the tolerance still fits.
        assert_eq!(parallelogram_corner(&[[a, b, c], [a, c, d + Vec3::X * 1e-6]]), Some(1));
    }

    #[test]
    fn a_parallelogram_with_perpendicular_edges_is_a_rectangle() {
        let (a, b, c) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(2.0, 1.0, 1.0));
        // Corner 1 (b) is the right angle of [a, b, c]; corners 0 and 2 are not.
        assert!(is_rectangle(&[a, b, c], 1));
        assert!(!is_rectangle(&[a, b, c], 0));
        assert!(!is_rectangle(&[a, b, c], 2));
        // Skewed by 1e-3 in cos: a parallelogram, not a rectangle; by 1e-6: a rectangle in f32.
        assert!(!is_rectangle(&[a, b, Vec3::new(2.002, 1.0, 1.0)], 1));
        assert!(is_rectangle(&[a, b, Vec3::new(2.000002, 1.0, 1.0)], 1));
        assert!(!is_rectangle(&[a, a, c], 0), "degenerate");
        let quad = triangles(&MeshData::quad(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::Z));
        let k = parallelogram_corner(&quad).unwrap();
        assert!(is_rectangle(&quad[0], k));
    }

    #[test]
    fn spheres_and_planar_lights_are_convex_facing_lights_are_not() {
        let sphere = triangles(&MeshData::sphere(Vec3::new(1.0, 2.0, 3.0), 0.5, 24, 12));
        assert!(is_convex(&sphere));
        // The same sphere emitting inwards: every vertex lies in front of every plane.
        let inward: Vec<[Vec3; 3]> = sphere.iter().map(|&[a, b, c]| [a, c, b]).collect();
        assert!(!is_convex(&inward));
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        assert!(is_convex(&[[a, b, c], [a, c, d]]));
        // Two panels meeting at a ridge, emitting towards each other: the one can shadow the other.
        let (l0, l1, r0, r1) =
            (Vec3::new(-1.0, 0.0, 0.0), Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0));
        let top = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0));
        let facing = [[l0, top.0, top.1], [l0, top.1, l1], [r0, top.1, top.0], [r0, r1, top.1]];
        let n = (facing[0][1] - facing[0][0]).cross(facing[0][2] - facing[0][0]);
        assert!(n.x > 0.0, "the left panel faces the right one");
        assert!(!is_convex(&facing));
    }

    #[test]
    fn spheres_and_cubes_are_round_squares_and_inward_spheres_are_not() {
        let round = |tris: &[[Vec3; 3]]| {
            let points: Vec<Vec3> = tris.iter().flatten().copied().collect();
            let lo = points.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
            let hi = points.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
            let centre = 0.5 * (lo + hi);
            is_convex(tris) && is_round(tris, points.iter().map(|p| p.distance(centre)).fold(0.0, f32::max))
        };
        let sphere = triangles(&MeshData::sphere(Vec3::new(1.0, 2.0, 3.0), 0.5, 24, 12));
        assert!(round(&sphere));
        let inward: Vec<[Vec3; 3]> = sphere.iter().map(|&[a, b, c]| [a, c, b]).collect();
        assert!(!round(&inward), "not convex");
        let square = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        assert!(!round(&[[square[0], square[1], square[2]], [square[0], square[2], square[3]]]), "A / 4πr² = 0.16");
        // A unit cube: 6 / (4π · 3/4) = 0.64.
        let footprint = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
        let cube = triangles(&MeshData::prism(footprint, 1.0));
        assert!(is_convex(&cube), "the prism is closed and outward");
        assert!(round(&cube));
    }

    #[test]
    fn curved_lights_split_into_triangles_and_parallelograms_flat_and_round_ones_stay_whole() {
        let whole = |t: &[[Vec3; 3]]| std::iter::once(0..t.len()).collect::<Vec<_>>();
        // Flat: a square, and a fan of 16 triangles round a disc (no parallelograms in it).
        let square = triangles(&MeshData::quad(Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::Z));
        assert_eq!(light_parts(&square), whole(&square));
        let fan: Vec<[Vec3; 3]> = (0..16)
            .map(|i| {
                let at = |k: u32| {
                    let a = std::f32::consts::TAU * k as f32 / 16.0;
                    Vec3::new(a.cos(), 2.0, a.sin())
                };
                [Vec3::new(0.0, 2.0, 0.0), at(i + 1), at(i)]
            })
            .collect();
        assert!(is_flat(&fan));
        assert_eq!(light_parts(&fan), whole(&fan));
        // Round: a tessellated sphere stays one light for cone sampling.
        let sphere = triangles(&MeshData::sphere(Vec3::new(1.0, 2.0, 3.0), 0.5, 24, 12));
        assert!(!is_flat(&sphere));
        assert_eq!(light_parts(&sphere), whole(&sphere));
        // Curved: a roof of two rectangles (pairs of triangles) and a pyramid's four faces.
        let ridge = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 2.0));
        let mut roof = MeshData::quad(
            Vec3::new(-1.0, 0.0, 0.0),
            ridge.0,
            ridge.1,
            Vec3::new(-1.0, 0.0, 2.0),
            Vec3::new(-1.0, 1.0, 0.0),
        );
        roof.append(&MeshData::quad(
            ridge.0,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 2.0),
            ridge.1,
            Vec3::new(1.0, 1.0, 0.0),
        ));
        let roof = triangles(&roof);
        assert!(!is_flat(&roof));
        assert_eq!(light_parts(&roof), vec![0..2, 2..4]);
        let apex = Vec3::new(0.0, 0.2, 0.0);
        let base = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
        ];
        let pyramid: Vec<[Vec3; 3]> = (0..4).map(|i| [base[i], apex, base[(i + 1) % 4]]).collect();
        assert_eq!(light_parts(&pyramid), vec![0..1, 1..2, 2..3, 3..4]);
        // Two triangles in one plane facing opposite ways are not flat: each is a light.
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        assert!(!is_flat(&[[a, b, c], [a, c, b + c]]));
        assert!(is_flat(&[[a, b, c], [b, b + c, c]]));
    }
}

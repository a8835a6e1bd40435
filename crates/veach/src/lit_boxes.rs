//! Lit boxes: a light sealed inside a closed surface (a lamp in a closed fixture, a light in a
//! closed room) lights nothing outside that surface, so nothing outside the surface's bounding
//! box. veach's surfaces are opaque, and its traversal watertight (Woop et al. 2013), so no ray
//! leaves a closed surface: the box is exact, not an estimate, and the light tree gives such a
//! light no samples outside it (`light_tree::LIGHT_OUTSIDE_LIT_BOX`).
//!
//! A surface is closed when every edge of its triangles is shared by exactly two of them (by the
//! corners' positions), the light lies inside it (an odd number of crossings along a ray), and no
//! light triangle crosses it. A few probe rays from each light find the candidates: a light one
//! of whose rays meets nothing is not sealed, and the surfaces its rays meet are the ones to try.

use crate::bvh::Bvh;
use crate::scene::{LightKind, Scene, Triangle};
use glam::Vec3;
use std::collections::{HashMap, HashSet};
use std::f32::consts::PI;
use std::rc::Rc;

/// Probe rays per light, in every direction, whichever way the light faces: a closed surface
/// around it meets them all, so one that meets nothing (upwards, in an open scene) shows the light
/// is not sealed before any surface is searched.
const PROBE_RAYS: usize = 16;
/// The most triangles a closed surface may have and still be searched, the most distinct surfaces
/// tried per light, and the most (light triangle, surface triangle) pairs tested for crossing:
/// enough for fixtures and rooms, while each mesh is searched once and a light beside a large
/// mesh costs little.
const MAX_ENCLOSURE_TRIANGLES: usize = 1 << 16;
const MAX_CANDIDATES: usize = 4;
const MAX_CROSSING_PAIRS: usize = 1 << 22;

/// A box around the points a light lights (corners `min` and `max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LitBox {
    pub min: Vec3,
    pub max: Vec3,
}

impl LitBox {
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn union(&self, other: &LitBox) -> LitBox {
        LitBox { min: self.min.min(other.min), max: self.max.max(other.max) }
    }
}

/// Each light's lit box, or `None` where it is not sealed in a closed surface, where it is
/// directional, or where its box holds the whole scene anyway (it would tell the tree nothing).
pub fn lit_boxes(scene: &Scene, bvh: &Bvh) -> Vec<Option<LitBox>> {
    let bounds = scene.bounds();
    let diagonal = (bounds.max - bounds.min).length().max(f32::MIN_POSITIVE);
    // Grown past the rounding of the kernels' hit points, so that the inside of a surface stays
    // inside its box: a ten-thousandth of the scene, and at least 8-16 f32 steps at its largest
    // coordinate (a scene far from the origin).
    let magnitude = bounds.min.abs().max(bounds.max.abs()).max_element();
    let margin = Vec3::splat((1.0e-4 * diagonal).max(1.0e-6 * magnitude));
    // The edges' owners, built only if some light's probe rays all meet a surface, and each
    // searched triangle's closed surface (the same for all of a surface's triangles).
    let mut edges: Option<EdgeMap> = None;
    let mut enclosures: HashMap<u32, Option<Rc<Enclosure>>> = HashMap::new();
    scene
        .lights
        .iter()
        .map(|light| {
            let emitter = Emitter::of(scene, &light.kind)?;
            let probe = probe(scene, bvh, &emitter, diagonal)?;
            let edges = edges.get_or_insert_with(|| EdgeMap::new(&scene.triangles));
            let mut tried = Vec::new();
            for t in probe.triangles {
                if tried.len() == MAX_CANDIDATES {
                    break;
                }
                if !enclosures.contains_key(&t) {
                    match Enclosure::around(t, &scene.triangles, edges) {
                        Ok(enclosure) => {
                            let enclosure = Rc::new(enclosure);
                            enclosures.extend(enclosure.triangles.iter().map(|&i| (i, Some(enclosure.clone()))));
                        }
                        Err(searched) => enclosures.extend(searched.into_iter().map(|i| (i, None))),
                    }
                }
                let Some(enclosure) = enclosures[&t].clone() else { continue };
                if tried.contains(&enclosure.triangles[0]) {
                    continue;
                }
                tried.push(enclosure.triangles[0]);
                let b = LitBox { min: enclosure.min - margin, max: enclosure.max + margin };
                // Every probe ray of a sealed light ends inside the surface.
                let probes_inside = b.contains(probe.hits.min) && b.contains(probe.hits.max);
                if probes_inside && enclosure.seals(&emitter, &scene.triangles) {
                    let holds_scene = b.contains(bounds.min) && b.contains(bounds.max);
                    return (!holds_scene).then_some(b);
                }
            }
            None
        })
        .collect()
}

/// What `PROBE_RAYS` rays from a light meet first: the triangles, most often met first, and a box
/// around the points. `None` where one meets nothing.
struct Probe {
    triangles: Vec<u32>,
    hits: LitBox,
}

fn probe(scene: &Scene, bvh: &Bvh, emitter: &Emitter, diagonal: f32) -> Option<Probe> {
    let mut counts: HashMap<u32, usize> = HashMap::new();
    let mut hits = LitBox { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };
    for k in 0..PROBE_RAYS {
        let (origin, dir) = emitter.ray(k);
        let t_min = 1.0e-5 * diagonal;
        let nearest =
            bvh.closest_hit(&scene.triangles, origin, dir, |tri| intersect(tri, origin, dir).filter(|&d| d > t_min));
        let (t, triangle) = nearest?;
        *counts.entry(triangle).or_default() += 1;
        hits.min = hits.min.min(origin + t * dir);
        hits.max = hits.max.max(origin + t * dir);
    }
    let mut triangles: Vec<(u32, usize)> = counts.into_iter().collect();
    triangles.sort_by_key(|&(t, n)| (std::cmp::Reverse(n), t));
    Some(Probe { triangles: triangles.into_iter().map(|(t, _)| t).collect(), hits })
}

/// A corner's position, exactly.
type Corner = [u32; 3];

fn corner(p: Vec3) -> Corner {
    // + 0 makes -0 the same corner as 0.
    (p + Vec3::ZERO).to_array().map(f32::to_bits)
}

/// Each edge's owners, keyed by its corners in order: how many triangles have it, and the first
/// two of them.
struct EdgeMap(HashMap<(Corner, Corner), (u32, [u32; 2])>);

impl EdgeMap {
    fn new(triangles: &[Triangle]) -> EdgeMap {
        let mut map: HashMap<(Corner, Corner), (u32, [u32; 2])> = HashMap::new();
        for (i, t) in triangles.iter().enumerate() {
            for e in 0..3 {
                let (count, owners) = map.entry(edge_key(t, e)).or_insert((0, [u32::MAX; 2]));
                if let Some(slot) = owners.get_mut(*count as usize) {
                    *slot = i as u32;
                }
                *count += 1;
            }
        }
        EdgeMap(map)
    }
}

fn edge_key(t: &Triangle, e: usize) -> (Corner, Corner) {
    let (a, b) = (corner(t.p[e]), corner(t.p[(e + 1) % 3]));
    if a <= b { (a, b) } else { (b, a) }
}

/// A closed surface: its triangles (the first is the smallest index, naming it) and its box.
struct Enclosure {
    triangles: Vec<u32>,
    min: Vec3,
    max: Vec3,
}

impl Enclosure {
    /// The triangles joined to `start` across edges, if every edge among them has exactly two
    /// owners and there are at most `MAX_ENCLOSURE_TRIANGLES`; else the triangles searched before
    /// the search stopped, of a surface that is not closed (or too large), which no other search
    /// need repeat.
    fn around(start: u32, triangles: &[Triangle], edges: &EdgeMap) -> Result<Enclosure, Vec<u32>> {
        let mut seen = HashSet::from([start]);
        let mut stack = vec![start];
        while let Some(i) = stack.pop() {
            let t = &triangles[i as usize];
            for e in 0..3 {
                let key = edge_key(t, e);
                let (count, owners) = edges.0[&key];
                if key.0 == key.1 || count != 2 {
                    return Err(seen.into_iter().collect());
                }
                for o in owners {
                    if seen.insert(o) {
                        if seen.len() > MAX_ENCLOSURE_TRIANGLES {
                            return Err(seen.into_iter().collect());
                        }
                        stack.push(o);
                    }
                }
            }
        }
        let mut list: Vec<u32> = seen.into_iter().collect();
        list.sort_unstable();
        let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in &list {
            for p in triangles[i as usize].p {
                min = min.min(p);
                max = max.max(p);
            }
        }
        Ok(Enclosure { triangles: list, min, max })
    }

    /// Whether the emitter lies inside, clear of the surface: each of its corners (or its point)
    /// inside, and no edge of its triangles crossing a triangle of the surface, nor an edge of the
    /// surface crossing one of its triangles.
    fn seals(&self, emitter: &Emitter, triangles: &[Triangle]) -> bool {
        let surface: Vec<&Triangle> = self.triangles.iter().map(|&i| &triangles[i as usize]).collect();
        match emitter {
            Emitter::Point(p) => inside(*p, &surface) == Some(true),
            Emitter::Area { triangles: lights, .. } => {
                if lights.len() * surface.len() > MAX_CROSSING_PAIRS {
                    return false;
                }
                let crosses = |a: &Triangle, b: &Triangle| {
                    (0..3).any(|e| {
                        let (p, q) = (a.p[e], a.p[(e + 1) % 3]);
                        intersect(b, p, q - p).is_some_and(|t| (0.0..=1.0).contains(&t))
                    })
                };
                lights.iter().all(|l| l.p.iter().all(|&p| inside(p, &surface) == Some(true)))
                    && !lights.iter().any(|l| surface.iter().any(|s| crosses(l, s) || crosses(s, l)))
            }
        }
    }
}

/// Whether `p` is inside a closed surface: the parity of the crossings of a ray from it, along one
/// of a few fixed directions that meets no triangle near an edge (`None` if all do).
fn inside(p: Vec3, surface: &[&Triangle]) -> Option<bool> {
    const DIRECTIONS: [[f32; 3]; 3] = [[0.5377, 0.7013, 0.4589], [-0.3815, 0.2917, 0.8774], [0.8126, -0.5212, 0.2609]];
    'direction: for d in DIRECTIONS {
        let dir = Vec3::from(d).normalize();
        let mut crossings = 0;
        for t in surface {
            match crossing(t, p, dir) {
                Crossing::Miss => {}
                Crossing::Hit => crossings += 1,
                Crossing::Unsure => continue 'direction,
            }
        }
        return Some(crossings % 2 == 1);
    }
    None
}

enum Crossing {
    Miss,
    Hit,
    /// Too near an edge or a corner, or the ray in the triangle's plane, to count.
    Unsure,
}

/// Möller–Trumbore, counting a crossing at t > 0 only where it is clear of the triangle's edges
/// and of the ray's origin (a corner of a light that lies on the surface is neither in nor out).
fn crossing(tri: &Triangle, origin: Vec3, dir: Vec3) -> Crossing {
    const NEAR: f32 = 1.0e-4;
    let [p0, p1, p2] = tri.p;
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    let scale = e1.length() * e2.length();
    if det.abs() <= 1.0e-6 * scale {
        return Crossing::Unsure;
    }
    let inv_det = 1.0 / det;
    let tv = origin - p0;
    let u = tv.dot(pv) * inv_det;
    let qv = tv.cross(e1);
    let v = dir.dot(qv) * inv_det;
    let t = e2.dot(qv) * inv_det;
    let w = 1.0 - u - v;
    let near_origin = NEAR * 0.1 * (e1.length() + e2.length());
    if u < -NEAR || v < -NEAR || w < -NEAR || t < -near_origin {
        return Crossing::Miss;
    }
    if u < NEAR || v < NEAR || w < NEAR || t <= near_origin {
        return Crossing::Unsure;
    }
    Crossing::Hit
}

/// Where a light's rays start and which way they go.
enum Emitter<'a> {
    /// Triangles, with their areas.
    Area { triangles: Vec<&'a Triangle>, areas: Vec<f32>, total: f32 },
    /// A point light or a spot light.
    Point(Vec3),
}

impl<'a> Emitter<'a> {
    fn of(scene: &'a Scene, kind: &LightKind) -> Option<Emitter<'a>> {
        match kind {
            LightKind::Area { triangles, .. } => {
                let triangles: Vec<&Triangle> = triangles.iter().map(|&t| &scene.triangles[t as usize]).collect();
                let areas: Vec<f32> = triangles.iter().map(|t| t.area()).collect();
                let total: f32 = areas.iter().sum();
                (total > 0.0 && total.is_finite()).then_some(Emitter::Area { triangles, areas, total })
            }
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } => Some(Emitter::Point(*position)),
            LightKind::Directional { .. } => None,
        }
    }

    /// Ray k: point k of the 5-D R sequence (Roberts, "The unreasonable effectiveness of
    /// quasirandom sequences", 2018) picks a triangle by area, a point uniform on it, and a
    /// direction uniform over the sphere.
    fn ray(&self, k: usize) -> (Vec3, Vec3) {
        let [u_pick, u_1, u_2, u_z, u_phi] = r5(k);
        let dir = direction(1.0 - 2.0 * u_z, u_phi);
        match self {
            Emitter::Point(p) => (*p, dir),
            Emitter::Area { triangles, areas, total } => {
                let mut pick = u_pick * total;
                let mut i = 0;
                while i + 1 < triangles.len() && pick >= areas[i] {
                    pick -= areas[i];
                    i += 1;
                }
                let [p0, p1, p2] = triangles[i].p;
                let (b1, b2) = if u_1 + u_2 > 1.0 { (1.0 - u_1, 1.0 - u_2) } else { (u_1, u_2) };
                (p0 + b1 * (p1 - p0) + b2 * (p2 - p0), dir)
            }
        }
    }
}

/// The positive root of x^6 = x + 1, whose powers 1/g^j step the 5-D R sequence.
const R5_G: f64 = 1.134_724_138_401_519_4;

/// Point k of the 5-D R sequence: the fractional parts of (k + 1/2) / g^j, j = 1..5.
fn r5(k: usize) -> [f32; 5] {
    let k = k as f64 + 0.5;
    std::array::from_fn(|j| (k / R5_G.powi(j as i32 + 1)).fract() as f32)
}

/// The direction of height `z` and azimuth 2π u_phi.
fn direction(z: f32, u_phi: f32) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u_phi;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Möller–Trumbore ("Fast, Minimum Storage Ray/Triangle Intersection", 1997): the distance along
/// the ray to the triangle (its plane's, where it meets it).
fn intersect(tri: &Triangle, origin: Vec3, dir: Vec3) -> Option<f32> {
    let [p0, p1, p2] = tri.p;
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1.0e-20 {
        return None;
    }
    let inv_det = 1.0 / det;
    let tv = origin - p0;
    // Grown by a hair, so that no ray slips between two triangles that share an edge: a leak
    // would only cost the light its box.
    const EDGE: f32 = 1.0e-5;
    let u = tv.dot(pv) * inv_det;
    if !(-EDGE..=1.0 + EDGE).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = dir.dot(qv) * inv_det;
    if v < -EDGE || u + v > 1.0 + EDGE {
        return None;
    }
    Some(e2.dot(qv) * inv_det)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build_bvh;
    use crate::scene::Light;

    fn triangle(p: [Vec3; 3]) -> Triangle {
        Triangle { p, n: [Vec3::Y; 3], uv: [[glam::Vec2::ZERO; 3]; 2], material: 0 }
    }

    /// The two triangles of quad a b c d (counter-clockwise seen from the side it faces).
    fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> [Triangle; 2] {
        [triangle([a, b, c]), triangle([a, c, d])]
    }

    /// The six faces of the box [lo, hi], facing out; `open_top` leaves the top face out.
    fn box_faces(lo: Vec3, hi: Vec3, open_top: bool) -> Vec<Triangle> {
        let c = |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
        let mut faces = vec![
            quad(c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)),
            quad(c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)),
            quad(c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)),
            quad(c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)),
            quad(c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)),
        ];
        if !open_top {
            faces.push(quad(c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)));
        }
        faces.into_iter().flatten().collect()
    }

    /// A floor of side 20 around the origin, and the box [0, 1]³ on it; `light` is a quad of
    /// side `size` centred at `centre`, facing `facing` (+y or -y).
    fn scene_with(open_top: bool, centre: Vec3, size: f32, facing: f32) -> Scene {
        let mut triangles: Vec<Triangle> = quad(
            Vec3::new(-10.0, -0.5, -10.0),
            Vec3::new(-10.0, -0.5, 10.0),
            Vec3::new(10.0, -0.5, 10.0),
            Vec3::new(10.0, -0.5, -10.0),
        )
        .to_vec();
        triangles.extend(box_faces(Vec3::ZERO, Vec3::ONE, open_top));
        let h = size / 2.0;
        let (a, b, c, d) = (
            centre + Vec3::new(-h, 0.0, -h),
            centre + Vec3::new(h, 0.0, -h),
            centre + Vec3::new(h, 0.0, h),
            centre + Vec3::new(-h, 0.0, h),
        );
        // Counter-clockwise seen from above faces +y.
        let light = if facing > 0.0 { quad(a, d, c, b) } else { quad(a, b, c, d) };
        let first = triangles.len() as u32;
        triangles.extend(light);
        let lights = vec![Light {
            name: "light".into(),
            kind: LightKind::Area { triangles: vec![first, first + 1], radiance: Vec3::ONE, double_sided: false },
        }];
        Scene { triangles, lights, ..Default::default() }
    }

    fn boxes(scene: &Scene) -> Vec<Option<LitBox>> {
        lit_boxes(scene, &build_bvh(&scene.triangles))
    }

    #[test]
    fn a_light_sealed_in_a_closed_box_lights_only_the_box() {
        for facing in [1.0, -1.0] {
            let scene = scene_with(false, Vec3::splat(0.5), 0.2, facing);
            let b = boxes(&scene)[0].expect("sealed");
            assert!(b.contains(Vec3::ZERO) && b.contains(Vec3::ONE), "{b:?}");
            assert!(!b.contains(Vec3::new(1.01, 0.5, 0.5)) && !b.contains(Vec3::new(0.5, -0.5, 0.5)), "{b:?}");
        }
    }

    #[test]
    fn a_light_that_can_get_out_has_no_box() {
        // An open top lets the light out (facing up), and even facing down its light escapes
        // nowhere, but the box is not a closed surface.
        assert_eq!(boxes(&scene_with(true, Vec3::splat(0.5), 0.2, 1.0))[0], None);
        assert_eq!(boxes(&scene_with(true, Vec3::splat(0.5), 0.2, -1.0))[0], None);
        // Poking through a wall: its corners outside, or its edges across the wall.
        assert_eq!(boxes(&scene_with(false, Vec3::new(0.95, 0.5, 0.5), 0.2, -1.0))[0], None);
        // On the box's top, facing out, or outside it.
        assert_eq!(boxes(&scene_with(false, Vec3::new(0.5, 1.0, 0.5), 0.2, 1.0))[0], None);
        assert_eq!(boxes(&scene_with(false, Vec3::new(3.0, 0.5, 0.5), 0.2, 1.0))[0], None);
    }

    #[test]
    fn a_box_that_holds_the_whole_scene_is_left_out() {
        // The closed box is all the scene: the light's box would leave nothing out.
        let mut scene = scene_with(false, Vec3::splat(0.5), 0.2, 1.0);
        scene.triangles.drain(0..2);
        if let LightKind::Area { triangles, .. } = &mut scene.lights[0].kind {
            triangles.iter_mut().for_each(|t| *t -= 2);
        }
        assert_eq!(boxes(&scene)[0], None);
    }

    #[test]
    fn far_from_the_origin_the_box_still_holds_the_inside_of_its_surface() {
        // The box scene moved to 1e5, where an f32 step is 1/128: the kernels' hit points on the
        // inside of the walls may round a few steps out.
        let mut scene = scene_with(false, Vec3::splat(0.5), 0.2, -1.0);
        let offset = Vec3::new(1.0e5, 0.0, 0.0);
        for t in &mut scene.triangles {
            t.p = t.p.map(|p| p + offset);
        }
        let b = boxes(&scene)[0].expect("sealed");
        let step = 1.0e5f32.next_up() - 1.0e5;
        for wall in [offset, offset + Vec3::ONE] {
            let out = Vec3::splat(8.0 * step) * (wall - offset - Vec3::splat(0.5)).signum();
            assert!(b.contains(wall + out), "{b:?} leaves out {}", wall + out);
        }
    }

    #[test]
    fn r5_steps_by_the_root_of_x6_equal_x_plus_1() {
        assert!((R5_G.powi(6) - R5_G - 1.0).abs() < 1e-12);
    }
}

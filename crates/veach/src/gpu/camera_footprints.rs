//! Per-pixel lists of the triangles a camera ray through the pixel can meet first, for baked
//! kernels whose camera is at the camera list's eye (`KernelPlan::footprint_slots`,
//! `trace_camera_slots` in shaders/traverse_baked.wgsl). Every camera ray of a pixel passes
//! through its footprint, so a triangle whose projection misses the footprint, or that lies behind
//! a surface covering the whole footprint, is never the closest hit of any of them: the rays test
//! only the few triangles left (at most `FOOTPRINT_SLOTS_MAX`), by the same edge planes through
//! the eye and in the same order as the whole camera list, so they pick the same triangle.
//!
//! Both tests are conservative, in f64, with margins far above the f32 tests' rounding:
//! - a triangle misses the footprint (grown by `FOOTPRINT_MARGIN` pixels) where its four corner
//!   directions all lie outside one of its edge planes: the footprint is convex, so every ray
//!   through it does (the separating-plane test of conservative rasterisation);
//! - a triangle Q lies behind an occluder O (a triangle, or two sharing an edge whose union's
//!   projection is convex) that covers the whole footprint where the eye and the points where the
//!   footprint's corner rays meet the planes of O's triangles all lie strictly on one side of Q's
//!   plane: every ray through the footprint meets O at a point in the convex hull of those points,
//!   so the segment to it cannot cross Q's plane, and Q is met later if at all. An occluder seen
//!   nearly edge-on (within about 0.06° of its plane) hides nothing: the f32 distances along it
//!   round too coarsely.
//!
//! Blocks of `BLOCK` × `BLOCK` pixels are taken first: a block's list is a valid list for each of
//! its pixels (their footprints lie in its own), kept where it is short, else narrowed per pixel.

use glam::DVec3;

/// The most triangles a pixel's list holds; past it the render keeps the whole camera list.
pub const FOOTPRINT_SLOTS_MAX: usize = 8;
/// An empty slot (lists are packed four triangles, one byte each, to a word).
pub const NO_SLOT: u32 = 255;
/// How far outside its pixel, in pixels, a footprint's corners are taken: the f32 direction of a
/// ray at the pixel's edge rounds by about 1e-7 of the film, far less.
const FOOTPRINT_MARGIN: f64 = 1e-2;
/// Relative margins of the plane tests (each against the magnitudes of its terms): far above f32
/// rounding (6e-8), so that no ray the f32 test could accept is left out.
const SIDE_MARGIN: f64 = 1e-5;
const DEPTH_MARGIN: f64 = 1e-4;

/// The pixels' lists, row by row: `words_per_pixel` words per pixel, each four one-byte slots
/// (`NO_SLOT` where empty).
pub struct CameraFootprints {
    /// Triangles in the longest list.
    pub slots: usize,
    /// u32 words per pixel: slots.div_ceil(4).
    pub words_per_pixel: usize,
    pub words: Vec<u32>,
    pub build_time: std::time::Duration,
}

/// The pinhole camera as camera.wgsl spans it: the ray through film point (x, y) in pixels has
/// direction forward + (2x/width - 1) right + (1 - 2y/height) up (normalised there; the signs of
/// the tests here do not depend on the length).
#[derive(Clone, Copy, Debug)]
pub struct FilmFrame {
    pub eye: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub width: u32,
    pub height: u32,
}

impl FilmFrame {
    /// The frame of `camera` as the kernels get it (`Camera::to_gpu` for the image's size).
    pub fn new(camera: &crate::gpu::layout::Camera, width: u32, height: u32) -> FilmFrame {
        let d = |v: [f32; 3]| DVec3::from_array(v.map(f64::from));
        let (eye, forward, right, up) = (d(camera.origin), d(camera.forward), d(camera.right), d(camera.up));
        FilmFrame { eye, forward, right, up, width, height }
    }

    fn direction(&self, x: f64, y: f64) -> DVec3 {
        let sx = 2.0 * x / self.width as f64 - 1.0;
        let sy = 1.0 - 2.0 * y / self.height as f64;
        self.forward + sx * self.right + sy * self.up
    }
}

/// Triangle p0 p1 p2's edge planes through `eye` and its volume: with a = p0 - eye, b = p1 - eye,
/// c = p2 - eye, the normals b × c, c × a, a × b (a ray's dot products with them are the weights
/// of p0, p1, p2) and a · (b × c), negated together where the volume is negative, so that inside
/// means all three dot products >= 0 and t > 0. None where the volume is zero or not finite (the
/// eye in the triangle's plane, or a degenerate triangle). Shared with the camera list's
/// constants (`gpu::baked_triangles`).
pub(crate) fn eye_planes(eye: DVec3, corners: [DVec3; 3]) -> Option<([DVec3; 3], f64)> {
    let [a, b, c] = corners.map(|p| p - eye);
    let (n0, n1, n2) = (b.cross(c), c.cross(a), a.cross(b));
    let volume = a.dot(n0);
    if volume == 0.0 || !volume.is_finite() {
        return None;
    }
    let sign = volume.signum();
    Some(([n0 * sign, n1 * sign, n2 * sign], volume * sign))
}

/// A triangle seen from the eye: its edge planes through the eye (inward), the sum of their
/// normals (a ray d meets the triangle's plane at t = volume / (sum · d)), and its plane.
#[derive(Clone, Copy)]
struct EyeTriangle {
    edges: [DVec3; 3],
    sum: DVec3,
    volume: f64,
    normal: DVec3,
    offset: f64,
}

impl EyeTriangle {
    fn new(eye: DVec3, corners: [DVec3; 3]) -> Option<EyeTriangle> {
        let (edges, volume) = eye_planes(eye, corners)?;
        let normal = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        let sum = edges[0] + edges[1] + edges[2];
        Some(EyeTriangle { edges, sum, volume, normal, offset: normal.dot(corners[0]) })
    }

    /// Signed distance-like value of point p from the triangle's plane, and its margin.
    fn side(&self, p: DVec3) -> (f64, f64) {
        let s = self.normal.dot(p) - self.offset;
        (s, DEPTH_MARGIN * self.normal.length() * (p.length() + self.offset.abs() / self.normal.length()))
    }
}

/// A plane through the eye as a function of the film point: n · direction(x, y) = a x + b y + c,
/// affine in the pixel coordinates, with the margin its tests keep (relative to |n| and the
/// longest direction on the film).
#[derive(Clone, Copy)]
struct FilmPlane {
    a: f64,
    b: f64,
    c: f64,
    margin: f64,
}

impl FilmPlane {
    fn new(n: DVec3, film: &FilmFrame) -> FilmPlane {
        let (w, h) = (film.width as f64, film.height as f64);
        let (r, u) = (n.dot(film.right), n.dot(film.up));
        let longest = film.forward.length() + film.right.length() + film.up.length();
        FilmPlane {
            a: 2.0 * r / w,
            b: -2.0 * u / h,
            c: n.dot(film.forward) - r + u,
            margin: SIDE_MARGIN * n.length() * longest,
        }
    }

    /// Whether the whole footprint [x0, x1] × [y0, y1] lies strictly outside the plane.
    fn all_outside(&self, [x0, y0, x1, y1]: [f64; 4]) -> bool {
        let top = self.c + (self.a * x0).max(self.a * x1) + (self.b * y0).max(self.b * y1);
        top < -self.margin
    }

    /// The pixel columns x of a row whose footprints may not lie all outside the plane: a
    /// superset (one column wider each side than the real bound, which the exact test then
    /// settles), as (first, last) in f64.
    fn columns(&self, y0: f64, y1: f64, m: f64) -> (f64, f64) {
        // top(x) = a x + max(a (1 + m), -a m) + c + max(b y0, b y1) >= -margin.
        let rest = self.c + (self.a * (1.0 + m)).max(-self.a * m) + (self.b * y0).max(self.b * y1) + self.margin;
        if self.a > 0.0 {
            ((-rest / self.a).floor() - 1.0, f64::INFINITY)
        } else if self.a < 0.0 {
            (f64::NEG_INFINITY, (-rest / self.a).ceil() + 1.0)
        } else if rest >= 0.0 {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        }
    }

    /// Whether the whole footprint lies strictly inside the plane.
    fn all_inside(&self, [x0, y0, x1, y1]: [f64; 4]) -> bool {
        let bottom = self.c + (self.a * x0).min(self.a * x1) + (self.b * y0).min(self.b * y1);
        bottom > self.margin
    }
}

/// A surface that may cover a whole footprint: one triangle, or two sharing an edge whose union
/// projects to a convex quadrilateral (`outer`: its edge planes through the eye, inward).
struct Occluder {
    members: Vec<usize>,
    outer: Vec<FilmPlane>,
}

/// The lists for `corners` (the baked triangles, in list order) seen by `film`, or None where a
/// pixel needs more than `FOOTPRINT_SLOTS_MAX` or there are more triangles than a byte can name.
pub fn camera_footprints(
    corners: &[[DVec3; 3]],
    film: &FilmFrame,
    rows: std::ops::Range<u32>,
) -> Option<CameraFootprints> {
    let start = std::time::Instant::now();
    if corners.len() >= NO_SLOT as usize {
        return None;
    }
    let seen: Vec<Option<EyeTriangle>> = corners.iter().map(|&c| EyeTriangle::new(film.eye, c)).collect();
    let edges: Vec<Option<[FilmPlane; 3]>> =
        seen.iter().map(|t| t.map(|t| t.edges.map(|n| FilmPlane::new(n, film)))).collect();
    let occluders = occluders(corners, &seen, film);
    let (w, h) = (film.width as usize, rows.len());
    let first_row = rows.start as usize;
    let mut counts = vec![0u8; w * h];
    let mut lists = vec![NO_SLOT as u8; w * h * FOOTPRINT_SLOTS_MAX];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, h.max(1));
    // Whole blocks per thread.
    let rows_per = (h.div_ceil(threads).div_ceil(BLOCK) * BLOCK).max(BLOCK);
    let too_many = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|scope| {
        let chunks = counts.chunks_mut(rows_per * w).zip(lists.chunks_mut(rows_per * w * FOOTPRINT_SLOTS_MAX));
        for (chunk, (counts, lists)) in chunks.enumerate() {
            let (seen, edges, occluders, too_many) = (&seen, &edges, &occluders, &too_many);
            scope.spawn(move || {
                let chunk_rows = counts.len() / w;
                let mut overlaps: Vec<Vec<u8>> = vec![Vec::new(); w.div_ceil(BLOCK)];
                for band in (0..chunk_rows).step_by(BLOCK) {
                    let rows = band..(band + BLOCK).min(chunk_rows);
                    let y = first_row + chunk * rows_per;
                    let (y0, y1) = ((y + rows.start) as f64, (y + rows.end) as f64);
                    block_overlaps(edges, y0, y1, w, &mut overlaps);
                    let mut write = |x: usize, r: usize, list: &[u8]| {
                        let p = r * w + x;
                        counts[p] = list.len() as u8;
                        lists[p * FOOTPRINT_SLOTS_MAX..][..list.len()].copy_from_slice(list);
                    };
                    for (bx, block) in overlaps.iter().enumerate() {
                        let columns = bx * BLOCK..(bx * BLOCK + BLOCK).min(w);
                        let rect = [columns.start as f64, y0, columns.end as f64, y1];
                        let mut list = [0u8; FOOTPRINT_SLOTS_MAX];
                        // A block's list holds every pixel's in it: where it is short, it is
                        // each pixel's (every ray tests as many slots as the longest list has,
                        // so shorter lists would gain nothing); else each pixel's own, from it.
                        let block_list = visible(seen, occluders, film, rect, block, &mut list);
                        if let Some(n) = block_list.filter(|&n| n <= BLOCK_LIST_KEPT) {
                            for r in rows.clone() {
                                columns.clone().for_each(|x| write(x, r, &list[..n]));
                            }
                            continue;
                        }
                        let block = match block_list {
                            Some(n) => list[..n].to_vec(),
                            None => block.clone(),
                        };
                        for r in rows.clone() {
                            for x in columns.clone() {
                                let rect = [x as f64, (y + r) as f64, x as f64 + 1.0, (y + r) as f64 + 1.0];
                                let footprint = grown(rect);
                                let mine: Vec<u8> = block
                                    .iter()
                                    .copied()
                                    .filter(|&i| {
                                        edges[i as usize].is_some_and(|e| !e.iter().any(|p| p.all_outside(footprint)))
                                    })
                                    .collect();
                                match visible(seen, occluders, film, rect, &mine, &mut list) {
                                    Some(n) => write(x, r, &list[..n]),
                                    None => too_many.store(true, std::sync::atomic::Ordering::Relaxed),
                                }
                            }
                        }
                    }
                }
            });
        }
    });
    if too_many.into_inner() {
        return None;
    }
    let slots = counts.iter().copied().max().unwrap_or(0).max(1) as usize;
    let words_per_pixel = slots.div_ceil(4);
    let words = lists
        .chunks(FOOTPRINT_SLOTS_MAX)
        .flat_map(|l| l[..4 * words_per_pixel].chunks(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        .collect();
    Some(CameraFootprints { slots, words_per_pixel, words, build_time: start.elapsed() })
}

/// Pixels are taken in square blocks of this side first (`camera_footprints`), and a block's
/// list of at most `BLOCK_LIST_KEPT` triangles is each of its pixels'.
const BLOCK: usize = 4;
const BLOCK_LIST_KEPT: usize = 3;

/// A footprint [x0, y0, x1, y1] in pixels, grown by `FOOTPRINT_MARGIN`.
fn grown([x0, y0, x1, y1]: [f64; 4]) -> [f64; 4] {
    let m = FOOTPRINT_MARGIN;
    [x0 - m, y0 - m, x1 + m, y1 + m]
}

/// For each block of rows [y0, y1) and `BLOCK` columns, the triangles whose projection its
/// footprint may overlap, ascending: each triangle's pixel columns by its edge planes' spans over
/// those rows, then the exact test per block.
fn block_overlaps(edges: &[Option<[FilmPlane; 3]>], y0: f64, y1: f64, w: usize, overlaps: &mut [Vec<u8>]) {
    let m = FOOTPRINT_MARGIN;
    overlaps.iter_mut().for_each(Vec::clear);
    for (i, e) in edges.iter().enumerate() {
        let Some(e) = e else { continue };
        let (mut first, mut last) = (0.0f64, (w - 1) as f64);
        for p in e {
            let (a, b) = p.columns(y0 - m, y1 + m, m);
            (first, last) = (first.max(a), last.min(b));
        }
        if first > last {
            continue;
        }
        let blocks = first as usize / BLOCK..=last as usize / BLOCK;
        for (bx, list) in overlaps.iter_mut().enumerate().take(*blocks.end() + 1).skip(*blocks.start()) {
            let footprint = grown([(bx * BLOCK) as f64, y0, ((bx + 1) * BLOCK).min(w) as f64, y1]);
            if !e.iter().any(|p| p.all_outside(footprint)) {
                list.push(i as u8);
            }
        }
    }
}

/// Writes into `list` the triangles of `overlaps` (ascending; those whose projection footprint
/// `rect` may overlap) that a camera ray through the footprint may meet first, and returns their
/// count, or None where they do not fit.
fn visible(
    seen: &[Option<EyeTriangle>],
    occluders: &[Occluder],
    film: &FilmFrame,
    rect: [f64; 4],
    overlaps: &[u8],
    list: &mut [u8],
) -> Option<usize> {
    let footprint = grown(rect);
    let n = overlaps.len();
    if n <= 1 {
        list[..n].copy_from_slice(overlaps);
        return Some(n);
    }
    let [x0, y0, x1, y1] = footprint;
    let dirs = [film.direction(x0, y0), film.direction(x1, y0), film.direction(x1, y1), film.direction(x0, y1)];
    // The points where the corner rays meet each covering occluder's triangles' planes.
    // At most 2 triangles an occluder, 4 points each; occluders by their first member.
    let mut covers: Vec<(&Occluder, [DVec3; 8])> = Vec::new();
    let by_first = |t: u8| {
        let start = occluders.partition_point(|o| o.members[0] < t as usize);
        occluders[start..].iter().take_while(move |o| o.members[0] == t as usize)
    };
    for o in overlaps.iter().flat_map(|&t| by_first(t)) {
        if !o.members.iter().all(|&i| overlaps.contains(&(i as u8))) || !o.outer.iter().all(|p| p.all_inside(footprint))
        {
            continue;
        }
        let mut points = [DVec3::ZERO; 8];
        let mut grazing = false;
        for (k, t) in o.members.iter().map(|&i| seen[i].expect("overlapping triangles are seen")).enumerate() {
            for (j, d) in dirs.iter().enumerate() {
                let cos = t.sum.dot(*d);
                grazing |= cos <= 1e-3 * t.sum.length() * d.length();
                points[4 * k + j] = film.eye + (t.volume / cos) * *d;
            }
        }
        if !grazing {
            covers.push((o, points));
        }
    }
    let mut kept = 0;
    for &q in overlaps {
        let tq = seen[q as usize].expect("overlapping triangles are seen");
        let (s_eye, margin_eye) = tq.side(film.eye);
        let hidden = s_eye.abs() > margin_eye
            && covers.iter().any(|(o, points)| {
                !o.members.contains(&(q as usize))
                    && points[..4 * o.members.len()].iter().all(|&p| {
                        let (s, margin) = tq.side(p);
                        s_eye.signum() * s > margin
                    })
            });
        if !hidden {
            *list.get_mut(kept)? = q;
            kept += 1;
        }
    }
    Some(kept)
}

/// Each triangle the eye sees, and each pair sharing an edge (the same corner positions) whose
/// union's projection is convex: the corners opposite the shared edge lie on either side of the
/// plane through the eye and that edge, and the shared edge's ends on either side of the plane
/// through the eye and those corners.
fn occluders(corners: &[[DVec3; 3]], seen: &[Option<EyeTriangle>], film: &FilmFrame) -> Vec<Occluder> {
    let eye = film.eye;
    let plane = |n: DVec3| FilmPlane::new(n, film);
    let mut out: Vec<Occluder> = (0..corners.len())
        .filter_map(|i| seen[i].map(|t| Occluder { members: vec![i], outer: t.edges.map(plane).to_vec() }))
        .collect();
    for i in 0..corners.len() {
        for j in i + 1..corners.len() {
            if seen[i].is_none() || seen[j].is_none() {
                continue;
            }
            let shared: Vec<(usize, usize)> = (0..3)
                .flat_map(|a| (0..3).map(move |b| (a, b)))
                .filter(|&(a, b)| corners[i][a] == corners[j][b])
                .collect();
            if shared.len() != 2 {
                continue;
            }
            let (p, q) = (corners[i][shared[0].0], corners[i][shared[1].0]);
            let c = corners[i][3 - shared[0].0 - shared[1].0];
            let d = corners[j][3 - shared[0].1 - shared[1].1];
            let plane_pq = (p - eye).cross(q - eye);
            let plane_cd = (c - eye).cross(d - eye);
            let opposite = |n: DVec3, a: DVec3, b: DVec3| n.dot(a - eye) * n.dot(b - eye) < 0.0;
            if !(opposite(plane_pq, c, d) && opposite(plane_cd, p, q)) {
                continue;
            }
            // The quadrilateral p c q d's edges, each plane oriented towards the other corners.
            let ring = [p, c, q, d];
            let outer: Vec<FilmPlane> = (0..4)
                .map(|k| {
                    let n = (ring[k] - eye).cross(ring[(k + 1) % 4] - eye);
                    plane(if n.dot(ring[(k + 2) % 4] - eye) < 0.0 { -n } else { n })
                })
                .collect();
            out.push(Occluder { members: vec![i, j], outer });
        }
    }
    // By first member, so that a pixel looks up those of the triangles it overlaps.
    out.sort_by_key(|o| o.members[0]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays through jittered points of every pixel: the brute-force closest triangle (f64, over
    /// all triangles) is always in the pixel's list.
    fn check_lists(
        corners: &[[DVec3; 3]],
        film: &FilmFrame,
        rows: std::ops::Range<u32>,
        rays_per_pixel: usize,
    ) -> usize {
        let f = camera_footprints(corners, film, rows.clone()).expect("lists fit");
        let mut state = 0x9e3779b97f4a7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let seen: Vec<Option<EyeTriangle>> = corners.iter().map(|&c| EyeTriangle::new(film.eye, c)).collect();
        for y in rows.start as usize..rows.end as usize {
            for x in 0..film.width as usize {
                let p = (y - rows.start as usize) * film.width as usize + x;
                let list: Vec<u32> = (0..f.slots)
                    .map(|j| (f.words[p * f.words_per_pixel + j / 4] >> (8 * (j % 4))) & 0xff)
                    .filter(|&t| t != NO_SLOT)
                    .collect();
                for _ in 0..rays_per_pixel {
                    let d = film.direction(x as f64 + next(), y as f64 + next());
                    let mut best = (f64::INFINITY, None);
                    for (i, t) in seen.iter().enumerate() {
                        let Some(t) = t else { continue };
                        let e = t.edges.map(|n| n.dot(d));
                        if e.iter().all(|&v| v >= 0.0) {
                            let s = t.volume / t.sum.dot(d);
                            if s < best.0 {
                                best = (s, Some(i as u32));
                            }
                        }
                    }
                    if let (_, Some(i)) = best {
                        assert!(list.contains(&i), "pixel ({x}, {y}): closest triangle {i} not in {list:?}");
                    }
                }
            }
        }
        f.slots
    }

    /// The Cornell box from its camera at 64 × 48 (each pixel 4 × 4 pixels of a 256 × 192
    /// render), 32 rays a pixel: every closest hit is listed, and most lists are short.
    #[test]
    fn the_cornell_boxs_lists_hold_every_closest_hit() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/cornell-box.gltf");
        let scene = crate::load_gltf(&path).expect("the shipped Cornell box");
        let film = FilmFrame::new(&scene.cameras[0].to_gpu(64, 48), 64, 48);
        let corners: Vec<[DVec3; 3]> = scene.triangles.iter().map(|t| t.p.map(|p| p.as_dvec3())).collect();
        let slots = check_lists(&corners, &film, 0..48, 32);
        let f = camera_footprints(&corners, &film, 0..48).expect("lists fit");
        let short = f.words.chunks(f.words_per_pixel).filter(|w| w[0] >> 24 == NO_SLOT).count();
        assert!(
            slots <= FOOTPRINT_SLOTS_MAX && short * 10 >= 64 * 48 * 8,
            "{slots} slots, {short} pixels with at most 3"
        );
        // A band of rows (blocks then start at its first row).
        check_lists(&corners, &film, 10..23, 32);
    }

    #[test]
    fn a_box_in_front_of_a_wall() {
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let quad = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| [[a, b, c], [a, c, d]];
        let mut corners = Vec::new();
        corners.extend(quad(v(-2.0, -2.0, -5.0), v(2.0, -2.0, -5.0), v(2.0, 2.0, -5.0), v(-2.0, 2.0, -5.0)));
        // A cube's faces.
        let (lo, hi) = (v(-0.5, -0.5, -3.0), v(0.5, 0.5, -2.0));
        let c = |i: u32| {
            v(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        for [a, b, cc, d] in [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]] {
            corners.extend(quad(c(a), c(b), c(cc), c(d)));
        }
        let film = FilmFrame {
            eye: v(0.3, 0.2, 0.0),
            forward: v(0.0, 0.0, -1.0),
            right: v(0.6, 0.0, 0.0),
            up: v(0.0, 0.6, 0.0),
            width: 48,
            height: 40,
        };
        let slots = check_lists(&corners, &film, 0..film.height, 64);
        assert!(slots <= FOOTPRINT_SLOTS_MAX, "{slots}");
    }
}

//! Small scenes' triangles compiled into the kernel (`shaders/traverse_baked.wgsl`): on CPU
//! adapters a scene of at most `BAKED_TRIANGLES_MAX` triangles needs no BVH: each ray tests every
//! triangle, whose corners are constants in the WGSL. Triangles of a compact part of the scene (a
//! box in a room) are tested only where the ray meets their bounding box (`BakedGroup`).

use crate::bvh::BvhNode;
use crate::gpu::layout::{IndexedTriangle, Vertex};
use crate::gpu::shadow_blockers::shadow_blockers;
use glam::Vec3;

/// The most triangles compiled into a kernel. On Mesa 22.3's lavapipe the Cornell box's 36
/// triangles took 0.68x the BVH's render time, and its triangles listed two, three and four times
/// over (72-144 tests a ray) 0.76x, 0.91x and 0.92x, while the kernel's compile time grew from
/// 0.07 s (BVH) to 0.15 s (36) and 0.42 s (144): past 64 the gain would shrink and the compile grow
/// (docs/performance.md, "Small scenes compiled into the kernel").
pub const BAKED_TRIANGLES_MAX: usize = 64;

/// A BVH subtree becomes a group tested behind its box when its box's surface area is at most
/// this fraction of the scene's and it holds at least `GROUP_MIN_TRIANGLES`: the Cornell box's
/// two blocks (12 triangles, 0.12 and 0.20 of the room's area) are groups, its walls and light
/// (2 triangles) are not. A box test costs about a triangle test; fewer triangles would not pay.
const GROUP_MAX_AREA_FRACTION: f32 = 0.25;
const GROUP_MIN_TRIANGLES: usize = 4;

/// Which of the triangles a baked line is written out for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BakedList {
    All,
    /// Those that can block a shadow ray (`mark_blockers`).
    Blockers,
    /// The emitting ones (`mark_blockers`), where direction samples search them (`emitter_list`;
    /// none otherwise).
    Emitters,
    /// Those a camera ray from the eye of `set_camera_eye` can meet, with their edge planes through
    /// it (none without an eye).
    Camera,
}

/// Triangles tested one after the other, or with `boxed` only where the ray meets their bounding
/// box: a branch around the group that Mesa 25's lavapipe takes when none of its 8 lanes meets the
/// box (Mesa 22.3 runs the group under a mask whatever the box says: neutral there).
/// docs/performance.md, "Baked triangles behind boxes".
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct BakedGroup {
    /// Indices in the BVH's triangle order, ascending.
    triangles: Vec<usize>,
    boxed: bool,
}

/// The corners of a scene's triangles as f32 bit patterns, in the BVH's triangle order (so that
/// a hit's triangle index means what it means with the BVH). Part of `KernelPlan`: each such scene
/// has a kernel of its own.
#[derive(Clone, PartialEq, Eq, Hash)]
pub struct BakedTriangles {
    corners: Vec<[[u32; 3]; 3]>,
    /// Whether each triangle can block a shadow ray (`mark_blockers`).
    blockers: Vec<bool>,
    /// Whether each triangle emits (`mark_blockers`).
    emitters: Vec<bool>,
    /// Direction samples find what they meet among the emitters alone, then test the segment to it
    /// with a shadow ray (`trace_emitters` in traverse_baked.wgsl, `EMITTER_LIST`).
    emitter_list: bool,
    /// The triangles in order, in runs tested alone or behind their box.
    groups: Vec<BakedGroup>,
    /// The eye camera rays start from where they test `camera_planes` (`set_camera_eye`).
    camera_eye: Option<[u32; 3]>,
    /// Per triangle, for camera rays from `camera_eye`: the three edge planes through the eye and
    /// the volume (`camera_planes`), or None for one no camera ray can meet.
    camera_planes: Vec<Option<[[u32; 3]; 4]>>,
}

/// The counts only: `--stats` prints the kernel key.
impl std::fmt::Debug for BakedTriangles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let boxed: usize = self.groups.iter().filter(|g| g.boxed).map(|g| g.triangles.len()).sum();
        let (n, groups, blockers) = (self.corners.len(), self.boxed_groups(), self.blocker_count());
        write!(f, "{n} triangles ({boxed} in {groups} boxed groups), {blockers} shadow-ray blockers")?;
        if self.emitter_list {
            let emitters = self.emitters.iter().filter(|&&e| e).count();
            write!(f, ", direction samples by the list of {emitters} emitters")?;
        }
        if self.camera_eye.is_some() {
            let planes = self.camera_planes.iter().filter(|p| p.is_some()).count();
            write!(f, ", camera rays by the edge planes of {planes} triangles")?;
        }
        Ok(())
    }
}

impl BakedTriangles {
    /// The triangles to compile into the kernel, or None where there are too many (or a corner is
    /// not finite, which scene loading refuses anyway). `nodes` is their BVH (root first), whose
    /// compact subtrees become groups behind boxes, or empty for none (Mesa 22.3, which would run
    /// them under a mask anyway: `features::runs_branches_masked`).
    pub fn new(vertices: &[Vertex], triangles: &[IndexedTriangle], nodes: &[BvhNode]) -> Option<BakedTriangles> {
        if triangles.len() > BAKED_TRIANGLES_MAX {
            return None;
        }
        let corner = |v: u32| vertices.get(v as usize).map(|v| v.p);
        let mut corners = Vec::with_capacity(triangles.len());
        for t in triangles {
            let mut c = [[0u32; 3]; 3];
            for (bits, v) in c.iter_mut().zip([t.v0, t.v1, t.v2]) {
                let p = corner(v)?;
                if !p.iter().all(|x| x.is_finite()) {
                    return None;
                }
                *bits = p.map(f32::to_bits);
            }
            corners.push(c);
        }
        let blockers = vec![true; corners.len()];
        let emitters = vec![false; corners.len()];
        let mut groups = Vec::new();
        if !nodes.is_empty() {
            collect_groups(nodes, 0, surface_area(&nodes[0]), &mut groups);
        }
        groups.sort_by_key(|g| g.triangles[0]);
        // A BVH that does not cover each triangle once (none for an empty scene): one group.
        let mut listed: Vec<usize> = groups.iter().flat_map(|g| g.triangles.iter().copied()).collect();
        listed.sort_unstable();
        if !listed.iter().copied().eq(0..corners.len()) {
            groups = vec![BakedGroup { triangles: (0..corners.len()).collect(), boxed: false }];
        }
        let camera_planes = vec![None; corners.len()];
        Some(BakedTriangles {
            corners,
            blockers,
            emitters,
            emitter_list: false,
            groups,
            camera_eye: None,
            camera_planes,
        })
    }

    /// Leaves out of the shadow rays' tests the triangles that no shadow ray can meet before its
    /// end (`gpu::shadow_blockers`). `triangle_lights` is each triangle's area light or
    /// NO_LIGHT; `delta_lights` the point and spot lights' positions, or None where a
    /// directional light exists (then every triangle stays).
    pub fn mark_blockers(&mut self, triangle_lights: &[u32], delta_lights: Option<&[Vec3]>) {
        let corners: Vec<[Vec3; 3]> =
            self.corners.iter().map(|c| c.map(|bits| Vec3::from_array(bits.map(f32::from_bits)))).collect();
        let emits: Vec<bool> = triangle_lights.iter().map(|&l| l != crate::gpu::layout::NO_LIGHT).collect();
        self.blockers = shadow_blockers(&corners, &emits, delta_lights);
        self.emitters = emits;
    }

    /// Whether direction samples search the emitters' list and trace a shadow ray to what they
    /// find, instead of a closest hit over every triangle: the same answer wherever no blocker lies
    /// within the shadow rays' margin of the light (the shipped scenes and the stress scenes render
    /// the BVH's image bit for bit, tests/specialise.rs). It pays where the driver branches around
    /// code no lane runs (Mesa 25's lavapipe: Cornell box 0.89-0.94x), and not on Mesa 22.3, which
    /// runs the emitter test and its shadow ray under a mask in every batch, where the closest hit
    /// they replace was a loop pass that only batches with a BRDF sample to trace took (1.13x);
    /// docs/performance.md, "Direction samples through the emitters' list".
    pub fn set_emitter_list(&mut self, on: bool) {
        self.emitter_list = on;
    }

    pub fn emitter_list(&self) -> bool {
        self.emitter_list
    }

    /// Camera rays from `eye` (None: none) test the triangles by their edge planes through it
    /// (`trace_camera` in traverse_baked.wgsl): per triangle three dot products and a division
    /// where the watertight test shears its corners per ray. Kernels use it where the render's
    /// camera is at `eye` (`KernelPlan::camera_list`): the wavefront's first kernel, and the
    /// megakernel where the driver branches around code no lane runs (Mesa 22.3 would run the
    /// closest-hit list beside it).
    pub fn set_camera_eye(&mut self, eye: Option<Vec3>) {
        self.camera_eye = eye.map(|e| e.to_array().map(f32::to_bits));
        self.camera_planes = self
            .corners
            .iter()
            .map(|c| eye.and_then(|e| camera_planes(e, c.map(|bits| bits.map(f32::from_bits)))))
            .collect();
    }

    /// The eye of `set_camera_eye`, as f32 bits.
    pub fn camera_eye(&self) -> Option<[u32; 3]> {
        self.camera_eye
    }

    /// Whether camera rays from `position` may use the camera list: it is the eye, bit for bit.
    pub fn has_camera_eye(&self, position: Vec3) -> bool {
        self.camera_eye == Some(position.to_array().map(f32::to_bits))
    }

    /// The camera footprint lists (`gpu::camera_footprints`) of image rows `rows` seen by `film`
    /// from the camera list's eye, behind the table of every triangle's camera planes, as the
    /// kernel's buffer reads them (`shaders::footprint_declarations`); None without an eye or
    /// where a pixel's list would not fit.
    pub fn camera_footprints(
        &self,
        film: &crate::gpu::camera_footprints::FilmFrame,
        rows: std::ops::Range<u32>,
    ) -> Option<(crate::gpu::camera_footprints::CameraFootprints, Vec<u32>)> {
        self.camera_eye?;
        let corners: Vec<[glam::DVec3; 3]> = self
            .corners
            .iter()
            .map(|c| c.map(|bits| glam::DVec3::from_array(bits.map(|b| f64::from(f32::from_bits(b))))))
            .collect();
        let lists = crate::gpu::camera_footprints::camera_footprints(&corners, film, rows)?;
        let mut words = Vec::with_capacity(12 * (self.len() + 1) + lists.words.len());
        for planes in &self.camera_planes {
            match planes {
                Some([n0, n1, n2, volume]) => {
                    words.extend(n0.iter().chain([&volume[0]]));
                    words.extend(n1.iter().chain([&0]));
                    words.extend(n2.iter().chain([&0]));
                }
                None => words.extend([0; 12]),
            }
        }
        words.extend([0; 12]);
        words.extend(&lists.words);
        Some((lists, words))
    }

    /// Triangles that shadow rays test.
    pub fn blocker_count(&self) -> usize {
        self.blockers.iter().filter(|&&b| b).count()
    }

    /// Groups of triangles tested behind a box.
    pub fn boxed_groups(&self) -> usize {
        self.groups.iter().filter(|g| g.boxed).count()
    }

    pub fn len(&self) -> usize {
        self.corners.len()
    }

    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// `template` (a statement naming p0, p1, p2 and triangle) once per triangle of list `which`,
    /// with the corners as WGSL literals and the triangle's index, one statement a line. A boxed
    /// group's lines go inside `if BOX_TEST { ... }`, `box_test` naming its box's corners lo and hi
    /// (the box of the triangles listed, so of the blockers alone with `BakedList::Blockers`).
    pub fn expand(&self, template: &str, box_test: &str, indent: &str, which: BakedList) -> String {
        let mut out = String::new();
        for group in &self.groups {
            let kept: Vec<usize> = group
                .triangles
                .iter()
                .copied()
                .filter(|&i| match which {
                    BakedList::All => true,
                    BakedList::Blockers => self.blockers[i],
                    BakedList::Emitters => self.emitter_list && self.emitters[i],
                    BakedList::Camera => self.camera_planes[i].is_some(),
                })
                .collect();
            let (open, inner) = if group.boxed && kept.len() >= GROUP_MIN_TRIANGLES {
                let (lo, hi) = self.bounds(&kept);
                let test = replace_word(&replace_word(box_test, "lo", &wgsl_vec3(lo)), "hi", &wgsl_vec3(hi));
                (Some(format!("if {test} {{")), format!("{indent}    "))
            } else {
                (None, indent.to_string())
            };
            let mut lines: Vec<String> =
                kept.iter().map(|&i| format!("{inner}{}", self.statement(template, i))).collect();
            if let Some(open) = open {
                lines.insert(0, format!("{indent}{open}"));
                lines.push(format!("{indent}}}"));
            }
            for line in lines {
                out.push_str(&line);
                out.push('\n');
            }
        }
        // The marker's own indent is the caller's.
        out.trim_start().trim_end().to_string()
    }

    /// `template` for triangle i: its corners as literals and its index.
    fn statement(&self, template: &str, i: usize) -> String {
        let mut line = template.to_string();
        for (name, bits) in ["p0", "p1", "p2"].iter().zip(&self.corners[i]) {
            line = replace_word(&line, name, &wgsl_vec3(*bits));
        }
        if let Some([n0, n1, n2, volume]) = self.camera_planes[i] {
            for (name, bits) in [("n0", n0), ("n1", n1), ("n2", n2)] {
                line = replace_word(&line, name, &wgsl_vec3(bits));
            }
            line = replace_word(&line, "volume", &wgsl_f32(volume[0]));
        }
        replace_word(&line, "triangle", &format!("{i}u"))
    }

    /// The bounding box of triangles `which`, as f32 bits (min and max of corners are corners'
    /// coordinates, so exact).
    fn bounds(&self, which: &[usize]) -> ([u32; 3], [u32; 3]) {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for corner in which.iter().flat_map(|&i| self.corners[i]) {
            for k in 0..3 {
                let x = f32::from_bits(corner[k]);
                lo[k] = lo[k].min(x);
                hi[k] = hi[k].max(x);
            }
        }
        (lo.map(f32::to_bits), hi.map(f32::to_bits))
    }
}

/// For camera rays from `eye`, triangle p0 p1 p2's edge planes through the eye and its volume
/// (`camera_footprints::eye_planes`), computed in f64 from the f32 corners and scaled together by a
/// power of two, which changes no ratio, to keep them in f32's range. [n0, n1, n2, [volume, 0, 0]]
/// as f32 bits; None where there are none (the watertight test finds no camera ray crossing such a
/// triangle either). A shared edge's two planes are exact negatives of each other times a power of
/// two: the products are the same, their difference is reversed, and negation and power-of-two
/// scales round exactly.
fn camera_planes(eye: Vec3, corners: [[f32; 3]; 3]) -> Option<[[u32; 3]; 4]> {
    let corners = corners.map(|p| glam::DVec3::from_array(p.map(f64::from)));
    let ([n0, n1, n2], volume) = crate::gpu::camera_footprints::eye_planes(eye.as_dvec3(), corners)?;
    let largest = [n0.abs().max_element(), n1.abs().max_element(), n2.abs().max_element(), volume]
        .into_iter()
        .fold(0.0, f64::max);
    let scale = 2f64.powi(-(largest.log2().floor() as i32));
    let bits = |v: glam::DVec3| (v * scale).to_array().map(|x| (x as f32).to_bits());
    let volume = (volume * scale) as f32;
    (volume > 0.0 && volume.is_finite()).then(|| [bits(n0), bits(n1), bits(n2), [volume.to_bits(), 0, 0]])
}

fn surface_area(node: &BvhNode) -> f32 {
    let [dx, dy, dz] = [0, 1, 2].map(|k| node.max[k] - node.min[k]);
    dx * dy + dy * dz + dz * dx
}

/// Walks the BVH from `node`, returning its subtree's triangles: a compact subtree
/// (`GROUP_MAX_AREA_FRACTION`, `GROUP_MIN_TRIANGLES`) is one boxed group, a leaf that is not is a
/// group of its own, and a larger inner node leaves its children's groups as they are.
fn collect_groups(nodes: &[BvhNode], node: usize, root_area: f32, groups: &mut Vec<BakedGroup>) -> Vec<usize> {
    let Some(&n) = nodes.get(node) else { return Vec::new() };
    let compact =
        |count: usize| surface_area(&n) <= GROUP_MAX_AREA_FRACTION * root_area && count >= GROUP_MIN_TRIANGLES;
    let mut triangles: Vec<usize> = if n.count > 0 {
        (n.first as usize..(n.first + n.count) as usize).collect()
    } else {
        let mut below = Vec::new();
        let mut triangles = collect_groups(nodes, n.first as usize, root_area, &mut below);
        triangles.extend(collect_groups(nodes, n.first as usize + 1, root_area, &mut below));
        if !compact(triangles.len()) {
            groups.extend(below);
            return triangles;
        }
        triangles
    };
    triangles.sort_unstable();
    if !triangles.is_empty() {
        groups.push(BakedGroup { triangles: triangles.clone(), boxed: compact(triangles.len()) });
    }
    triangles
}

/// A point as a WGSL vec3f of exact literals.
fn wgsl_vec3(bits: [u32; 3]) -> String {
    let [x, y, z] = bits.map(wgsl_f32);
    format!("vec3f({x}, {y}, {z})")
}

/// An f32 as a WGSL literal that parses back to the same bits: Rust prints the shortest decimal
/// that round-trips, and naga reads an `f`-suffixed literal as an f32 directly.
fn wgsl_f32(bits: u32) -> String {
    let x = f32::from_bits(bits);
    let text = format!("{x:?}f");
    debug_assert_eq!(text.trim_end_matches('f').parse::<f32>().map(f32::to_bits), Ok(bits));
    text
}

/// `text` with each whole-word `word` replaced.
fn replace_word(text: &str, word: &str, with: &str) -> String {
    let is_ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut out = String::new();
    let mut rest = text;
    while let Some(at) = rest.find(word) {
        let before_ok = !rest[..at].chars().next_back().is_some_and(is_ident);
        let after_ok = !rest[at + word.len()..].chars().next().is_some_and(is_ident);
        out.push_str(&rest[..at]);
        out.push_str(if before_ok && after_ok { with } else { word });
        rest = &rest[at + word.len()..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(p: [f32; 3]) -> Vertex {
        Vertex { p, normal: 0 }
    }

    #[test]
    fn literals_parse_back_to_the_same_bits() {
        for x in
            [0.0f32, -0.0, 1.0, -0.5, 0.1, 1.0e-30, 3.4e38, -1.17e-38, 1.0e-45, 123456.79, f32::MAX, f32::MIN_POSITIVE]
        {
            let text = wgsl_f32(x.to_bits());
            assert!(text.ends_with('f'), "{text}");
            assert_eq!(text.trim_end_matches('f').parse::<f32>().unwrap().to_bits(), x.to_bits(), "{text}");
        }
    }

    #[test]
    fn expands_one_line_per_triangle_with_its_corners_and_index() {
        let vertices = [vertex([0.0, 0.0, 0.0]), vertex([1.0, 0.0, 0.0]), vertex([0.0, 2.5, -1.0])];
        let triangles = [
            IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 },
            IndexedTriangle { v0: 2, v1: 1, v2: 0, material: 0 },
        ];
        let baked = BakedTriangles::new(&vertices, &triangles, &[]).unwrap();
        let text = baked.expand("f(p0, p1, p2, triangle, p00);", "box(lo, hi)", "  ", BakedList::All);
        assert_eq!(
            text,
            "f(vec3f(0.0f, 0.0f, 0.0f), vec3f(1.0f, 0.0f, 0.0f), vec3f(0.0f, 2.5f, -1.0f), 0u, p00);\n  \
             f(vec3f(0.0f, 2.5f, -1.0f), vec3f(1.0f, 0.0f, 0.0f), vec3f(0.0f, 0.0f, 0.0f), 1u, p00);"
        );
    }

    #[test]
    fn shadow_rays_test_only_the_blockers_each_under_its_bvh_order_index() {
        let vertices = [vertex([0.0, 0.0, 0.0]), vertex([1.0, 0.0, 0.0]), vertex([0.0, 1.0, 0.0])];
        let t = IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 };
        let mut baked = BakedTriangles::new(&vertices, &[t; 4], &[]).unwrap();
        assert_eq!(baked.blocker_count(), 4, "every triangle blocks until marked");
        baked.blockers = vec![false, true, false, true];
        assert_eq!(baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::Blockers), "f(1u);\nf(3u);");
        assert_eq!(baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::All).lines().count(), 4);
        // A lone triangle with nothing on either side of its plane: no shadow ray can cross it.
        baked.mark_blockers(&[crate::gpu::layout::NO_LIGHT; 4], Some(&[]));
        assert_eq!(baked.blocker_count(), 0);
        baked.mark_blockers(&[crate::gpu::layout::NO_LIGHT; 4], None);
        assert_eq!(baked.blocker_count(), 4, "a directional light's shadow rays cross any plane");
    }

    #[test]
    fn the_emitters_list_holds_the_emitting_triangles_once_switched_on() {
        let vertices = [vertex([0.0, 0.0, 0.0]), vertex([1.0, 0.0, 0.0]), vertex([0.0, 1.0, 0.0])];
        let t = IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 };
        let mut baked = BakedTriangles::new(&vertices, &[t; 4], &[]).unwrap();
        let no = crate::gpu::layout::NO_LIGHT;
        baked.mark_blockers(&[no, 0, no, 1], None);
        assert_eq!(baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::Emitters), "", "off by default");
        baked.set_emitter_list(true);
        assert_eq!(baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::Emitters), "f(1u);\nf(3u);");
        assert!(format!("{baked:?}").ends_with("direction samples by the list of 2 emitters"), "{baked:?}");
    }

    #[test]
    fn compact_subtrees_are_tested_behind_the_box_of_the_triangles_listed() {
        // Triangle i lies at x = i; the BVH: root -> (leaf 0..1 big, inner -> (leaf of 4..8,
        // leaf of 1..4)), the inner node small. Its triangles are listed in order, out of the
        // leaves' order.
        let vertices: Vec<Vertex> = (0..8)
            .flat_map(|i| [[i as f32, 0.0, 0.0], [i as f32, 1.0, 0.0], [i as f32, 0.0, 1.0]])
            .map(vertex)
            .collect();
        let triangles: Vec<IndexedTriangle> =
            (0..8).map(|i| IndexedTriangle { v0: 3 * i, v1: 3 * i + 1, v2: 3 * i + 2, material: 0 }).collect();
        let node = |min: [f32; 3], max: [f32; 3], first, count| BvhNode { min, first, max, count };
        let nodes = [
            node([-100.0; 3], [100.0; 3], 1, 0),
            node([-100.0; 3], [100.0; 3], 0, 1),
            node([1.0, 0.0, 0.0], [7.0, 1.0, 1.0], 3, 0),
            node([4.0, 0.0, 0.0], [7.0, 1.0, 1.0], 4, 4),
            node([1.0, 0.0, 0.0], [3.0, 1.0, 1.0], 1, 3),
        ];
        let mut baked = BakedTriangles::new(&vertices, &triangles, &nodes).unwrap();
        assert_eq!(baked.boxed_groups(), 1);
        let text = baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::All);
        let expected = "f(0u);\nif box(vec3f(1.0f, 0.0f, 0.0f), vec3f(7.0f, 1.0f, 1.0f)) {\n    f(1u);\n    f(2u);\n    \
                        f(3u);\n    f(4u);\n    f(5u);\n    f(6u);\n    f(7u);\n}";
        assert_eq!(text, expected);
        // Shadow rays: the box of the blockers alone; fewer than GROUP_MIN_TRIANGLES go unboxed.
        baked.blockers = vec![true, false, true, true, false, true, false, false];
        assert_eq!(
            baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::Blockers),
            "f(0u);\nf(2u);\nf(3u);\nf(5u);"
        );
        baked.blockers[6] = true;
        assert_eq!(
            baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::Blockers),
            "f(0u);\nif box(vec3f(2.0f, 0.0f, 0.0f), vec3f(6.0f, 1.0f, 1.0f)) {\n    f(2u);\n    f(3u);\n    f(5u);\n    f(6u);\n}"
        );
        // Without a BVH, or with one that does not list each triangle once: no groups.
        assert_eq!(BakedTriangles::new(&vertices, &triangles, &[]).unwrap().boxed_groups(), 0);
        let short = [nodes[0], nodes[1], nodes[2], nodes[3], node([1.0, 0.0, 0.0], [3.0, 1.0, 1.0], 1, 2)];
        let baked = BakedTriangles::new(&vertices, &triangles, &short).unwrap();
        assert_eq!(baked.boxed_groups(), 0);
        assert_eq!(baked.expand("f(triangle);", "box(lo, hi)", "", BakedList::All).lines().count(), 8);
    }

    fn planes_of(eye: Vec3, corners: [[f32; 3]; 3]) -> Option<([Vec3; 3], f32)> {
        camera_planes(eye, corners).map(|[n0, n1, n2, v]| {
            ([n0, n1, n2].map(|n| Vec3::from_array(n.map(f32::from_bits))), f32::from_bits(v[0]))
        })
    }

    #[test]
    fn camera_planes_find_the_distance_and_face_the_same_way_for_either_winding() {
        let eye = Vec3::new(0.5, -1.0, 3.0);
        let corners = [[0.0, 0.0, -2.0], [4.0, 0.0, -2.0], [0.0, 3.0, -2.0]];
        let centroid = Vec3::new(4.0 / 3.0, 1.0, -2.0);
        let dir = (centroid - eye).normalize();
        for corners in [corners, [corners[0], corners[2], corners[1]]] {
            let (n, volume) = planes_of(eye, corners).unwrap();
            let [u, v, w] = n.map(|n| dir.dot(n));
            assert!(u > 0.0 && v > 0.0 && w > 0.0 && volume > 0.0, "inside means all >= 0: {u} {v} {w}");
            let t = volume / (u + v + w);
            assert!((t - (centroid - eye).length()).abs() < 1e-5, "t = {t}");
            // The weights are the barycentrics of p0, p1, p2 (here each 1/3).
            for b in [u, v, w] {
                assert!((b / (u + v + w) - 1.0 / 3.0).abs() < 1e-5);
            }
            // A ray past an edge: one weight negative.
            let outside = (Vec3::new(-1.0, 1.0, -2.0) - eye).normalize();
            assert!(n.iter().any(|&n| outside.dot(n) < 0.0));
        }
    }

    #[test]
    fn a_shared_edges_two_camera_planes_are_exact_negatives_up_to_a_power_of_two() {
        // A quad split along p1-p2, the halves far apart in size so that their scales differ.
        let eye = Vec3::new(0.3, 0.2, 5.0);
        let (p1, p2) = ([10.0, 0.0, 0.0], [0.0, 10.0, 0.5]);
        let small = planes_of(eye, [[0.0, 0.0, 0.0], p1, p2]).unwrap().0;
        let large = planes_of(eye, [[1000.0, 1000.0, 0.0], p2, p1]).unwrap().0;
        // The edge p1-p2 is opposite corner 0 in both: plane n0.
        let ratio = -large[0] / small[0];
        assert!(ratio.x > 0.0 && ratio.x.log2().fract() == 0.0, "{ratio}");
        assert_eq!(ratio, Vec3::splat(ratio.x), "{small:?} {large:?}");
    }

    #[test]
    fn triangles_no_camera_ray_can_meet_have_no_camera_planes() {
        let eye = Vec3::new(0.0, 0.0, 1.0);
        assert!(planes_of(eye, [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]).is_none(), "eye in its plane");
        assert!(planes_of(eye, [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]).is_none(), "degenerate");
        // Far from the origin the planes stay finite.
        let far = planes_of(Vec3::splat(3.0e37), [[-3.0e38, 0.0, 0.0], [0.0, -3.0e38, 0.0], [0.0, 0.0, -3.0e38]]);
        let (n, volume) = far.unwrap();
        assert!(volume.is_finite() && volume > 0.0 && n.iter().all(|n| n.is_finite()));
    }

    #[test]
    fn the_camera_list_holds_the_triangles_with_planes_once_an_eye_is_set() {
        let vertices = [vertex([0.0, 0.0, 0.0]), vertex([1.0, 0.0, 0.0]), vertex([0.0, 1.0, 0.0])];
        let t = IndexedTriangle { v0: 0, v1: 1, v2: 2, material: 0 };
        let mut baked = BakedTriangles::new(&vertices, &[t; 2], &[]).unwrap();
        let template = "f(n0, volume, triangle);";
        assert_eq!(baked.expand(template, "box(lo, hi)", "", BakedList::Camera), "", "no eye, no list");
        baked.set_camera_eye(Some(Vec3::new(0.0, 0.0, 2.0)));
        let text = baked.expand(template, "box(lo, hi)", "", BakedList::Camera);
        assert_eq!(text.lines().count(), 2);
        assert!(text.starts_with("f(vec3f(") && text.ends_with(", 1u);"), "{text}");
        assert!(format!("{baked:?}").ends_with("camera rays by the edge planes of 2 triangles"), "{baked:?}");
        baked.set_camera_eye(Some(Vec3::new(0.5, 0.5, 0.0)));
        assert_eq!(baked.expand(template, "box(lo, hi)", "", BakedList::Camera), "", "the eye in their plane");
        assert!(baked.camera_eye().is_some());
    }

    #[test]
    fn too_many_or_non_finite_triangles_are_not_baked() {
        let vertices = [vertex([0.0; 3]), vertex([1.0, 0.0, 0.0]), vertex([0.0, f32::NAN, 0.0])];
        let t = IndexedTriangle { v0: 0, v1: 1, v2: 1, material: 0 };
        assert!(BakedTriangles::new(&vertices, &vec![t; BAKED_TRIANGLES_MAX], &[]).is_some());
        assert!(BakedTriangles::new(&vertices, &vec![t; BAKED_TRIANGLES_MAX + 1], &[]).is_none());
        assert!(BakedTriangles::new(&vertices, &[IndexedTriangle { v2: 2, ..t }], &[]).is_none());
    }
}

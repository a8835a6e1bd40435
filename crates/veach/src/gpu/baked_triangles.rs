//! Small scenes' triangles compiled into the kernel (`shaders/traverse_baked.wgsl`): on CPU
//! adapters a scene of at most `BAKED_TRIANGLES_MAX` triangles needs no BVH: each ray tests every
//! triangle, whose corners are constants in the WGSL.

use crate::gpu::layout::{IndexedTriangle, Vertex};
use crate::gpu::shadow_blockers::shadow_blockers;
use glam::Vec3;

/// The most triangles compiled into a kernel. On Mesa 22.3's lavapipe the Cornell box's 36
/// triangles took 0.68x the BVH's render time, and its triangles listed two, three and four times
/// over (72-144 tests a ray) 0.76x, 0.91x and 0.92x, while the kernel's compile time grew from
/// 0.07 s (BVH) to 0.15 s (36) and 0.42 s (144): past 64 the gain would shrink and the compile grow
/// (docs/performance.md, "Small scenes compiled into the kernel").
pub const BAKED_TRIANGLES_MAX: usize = 64;

/// The corners of a scene's triangles as f32 bit patterns, in the BVH's triangle order (so that
/// a hit's triangle index means what it means with the BVH). Part of `KernelKey`: each such scene
/// has a kernel of its own.
#[derive(Clone, PartialEq, Eq, Hash)]
pub struct BakedTriangles {
    corners: Vec<[[u32; 3]; 3]>,
    /// Whether each triangle can block a shadow ray (`mark_blockers`).
    blockers: Vec<bool>,
}

/// The counts only: `--stats` prints the kernel key.
impl std::fmt::Debug for BakedTriangles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} triangles, {} shadow-ray blockers", self.corners.len(), self.blocker_count())
    }
}

impl BakedTriangles {
    /// The triangles to compile into the kernel, or None where there are too many (or a corner is
    /// not finite, which scene loading refuses anyway).
    pub fn new(vertices: &[Vertex], triangles: &[IndexedTriangle]) -> Option<BakedTriangles> {
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
        Some(BakedTriangles { corners, blockers })
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
    }

    /// Triangles that shadow rays test.
    pub fn blocker_count(&self) -> usize {
        self.blockers.iter().filter(|&&b| b).count()
    }

    pub fn len(&self) -> usize {
        self.corners.len()
    }

    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// `template` (a statement naming p0, p1, p2 and triangle) once per triangle (once per
    /// shadow-ray blocker with `blockers_only`), with the corners as WGSL literals and the
    /// triangle's index, one statement a line.
    pub fn expand(&self, template: &str, indent: &str, blockers_only: bool) -> String {
        let mut out = String::new();
        let kept = self.corners.iter().zip(&self.blockers).enumerate().filter(|(_, (_, b))| **b || !blockers_only);
        for (i, (corners, _)) in kept {
            let mut line = template.to_string();
            for (name, bits) in ["p0", "p1", "p2"].iter().zip(corners) {
                let [x, y, z] = bits.map(wgsl_f32);
                line = replace_word(&line, name, &format!("vec3f({x}, {y}, {z})"));
            }
            line = replace_word(&line, "triangle", &format!("{i}u"));
            if !out.is_empty() {
                out.push_str(indent);
            }
            out.push_str(&line);
            out.push('\n');
        }
        out.trim_end().to_string()
    }
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
        let baked = BakedTriangles::new(&vertices, &triangles).unwrap();
        let text = baked.expand("f(p0, p1, p2, triangle, p00);", "  ", false);
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
        let mut baked = BakedTriangles::new(&vertices, &[t; 4]).unwrap();
        assert_eq!(baked.blocker_count(), 4, "every triangle blocks until marked");
        baked.blockers = vec![false, true, false, true];
        assert_eq!(baked.expand("f(triangle);", "", true), "f(1u);\nf(3u);");
        assert_eq!(baked.expand("f(triangle);", "", false).lines().count(), 4);
        // A lone triangle with nothing on either side of its plane: no shadow ray can cross it.
        baked.mark_blockers(&[crate::gpu::layout::NO_LIGHT; 4], Some(&[]));
        assert_eq!(baked.blocker_count(), 0);
        baked.mark_blockers(&[crate::gpu::layout::NO_LIGHT; 4], None);
        assert_eq!(baked.blocker_count(), 4, "a directional light's shadow rays cross any plane");
    }

    #[test]
    fn too_many_or_non_finite_triangles_are_not_baked() {
        let vertices = [vertex([0.0; 3]), vertex([1.0, 0.0, 0.0]), vertex([0.0, f32::NAN, 0.0])];
        let t = IndexedTriangle { v0: 0, v1: 1, v2: 1, material: 0 };
        assert!(BakedTriangles::new(&vertices, &vec![t; BAKED_TRIANGLES_MAX]).is_some());
        assert!(BakedTriangles::new(&vertices, &vec![t; BAKED_TRIANGLES_MAX + 1]).is_none());
        assert!(BakedTriangles::new(&vertices, &[IndexedTriangle { v2: 2, ..t }]).is_none());
    }
}

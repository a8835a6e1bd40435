//! Shadow rays towards a convex light skip the BVH subtrees that only its triangles fill (tagged
//! in the GPU nodes, `BvhNode::lights_01`, `lights_23`). A shadow ray from x to a
//! point y on a light whose triangle at y faces x cannot meet that light anywhere else when the
//! light's triangles bound a convex body (each lies in a plane with all of the light behind it):
//! the segment lies in front of y's plane, the light behind it. Traversal then need not descend
//! into the boxes around y, which it otherwise must, since they reach the shadow ray's end: on the
//! Veach scene (four spheres of 960 triangles each) the shadow rays took half the render time.

use crate::bvh::Bvh;
use glam::Vec3;
use std::collections::HashSet;

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

/// A light tag for each host node of `bvh`: 1 + the light whose triangles alone fill the node's
/// subtree where that light is `convex`, else 0. `triangle_light[t]` is the light of scene
/// triangle t, or `NO_LIGHT`. A light that shares leaves with other triangles is tagged in the
/// subtrees that it fills alone (on the Veach scene the two large spheres in 9-12 pieces each).
pub fn node_lights(bvh: &Bvh, triangle_light: &[u32], convex: &[bool]) -> Vec<u32> {
    // Per node: the one light all of its triangles belong to, or MIXED (several, or any unlit).
    const MIXED: u32 = u32::MAX;
    if bvh.order.is_empty() {
        // An empty scene: one leaf over a placeholder triangle.
        return vec![0; bvh.nodes.len()];
    }
    let lights = convex.len();
    let light_of = |position: u32| {
        let l = triangle_light[bvh.order[position as usize] as usize];
        if (l as usize) < lights { l } else { MIXED }
    };
    let nodes = &bvh.nodes;
    // Parents before children (depth first from the root), then swept in reverse, so that both
    // children of a node are done before it, whatever order the builder left the nodes in.
    let mut parents_first = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        parents_first.push(i);
        if nodes[i].count == 0 {
            stack.extend([nodes[i].first as usize, nodes[i].first as usize + 1]);
        }
    }
    let mut owner = vec![MIXED; nodes.len()];
    for &i in parents_first.iter().rev() {
        let n = &nodes[i];
        owner[i] = if n.count > 0 {
            let first = light_of(n.first);
            if (n.first..n.first + n.count).all(|p| light_of(p) == first) { first } else { MIXED }
        } else {
            let (a, b) = (owner[n.first as usize], owner[n.first as usize + 1]);
            if a == b { a } else { MIXED }
        };
    }
    owner.iter().map(|&o| if o != MIXED && convex[o as usize] { o + 1 } else { 0 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assets::gltf_writer::MeshData;
    use crate::bvh::build_bvh;
    use crate::gpu::layout::NO_LIGHT;
    use crate::scene::Triangle;

    fn triangles(mesh: &MeshData) -> Vec<[Vec3; 3]> {
        mesh.indices.chunks(3).map(|i| [0, 1, 2].map(|k| mesh.positions[i[k] as usize])).collect()
    }

    fn scene_triangle(p: [Vec3; 3]) -> Triangle {
        Triangle { p, n: [Vec3::Z; 3], uv: Default::default(), material: 0 }
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
    fn nodes_are_tagged_with_the_convex_light_that_alone_fills_them() {
        let mut tris = Vec::new();
        let mut light = Vec::new();
        for (l, x) in [(0u32, -5.0f32), (1, 5.0)] {
            for t in triangles(&MeshData::sphere(Vec3::new(x, 1.0, 0.0), 0.5, 16, 8)) {
                tris.push(scene_triangle(t));
                light.push(l);
            }
        }
        let floor = MeshData::quad(
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::Y,
        );
        for t in triangles(&floor) {
            tris.push(scene_triangle(t));
            light.push(NO_LIGHT);
        }
        let bvh = build_bvh(&tris);
        // The scene triangles under each node.
        let held = |root: usize| {
            let mut stack = vec![root];
            let mut held = Vec::new();
            while let Some(i) = stack.pop() {
                let n = bvh.nodes[i];
                if n.count > 0 {
                    held.extend((n.first..n.first + n.count).map(|p| bvh.order[p as usize]));
                } else {
                    stack.extend([n.first as usize, n.first as usize + 1]);
                }
            }
            held
        };
        let tags = node_lights(&bvh, &light, &[true, false]);
        let mut tagged = 0;
        for (i, &tag) in tags.iter().enumerate() {
            let lights_under: HashSet<u32> = held(i).iter().map(|&t| light[t as usize]).collect();
            if tag > 0 {
                assert_eq!(lights_under, HashSet::from([tag - 1]), "node {i}");
                assert_eq!(tag, 1, "light 1 is not convex here");
                tagged += 1;
            } else {
                assert!(lights_under != HashSet::from([0]), "node {i} holds only light 0 but is untagged");
            }
        }
        assert!(tagged > 0);
    }

    #[test]
    fn the_veach_scenes_spheres_are_convex_round_and_their_subtrees_tagged() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/veach-mis.gltf");
        let scene = crate::load_gltf(&path).unwrap();
        let bvh = build_bvh(&scene.triangles);
        let features = crate::features::SceneFeatures::detect(&scene);
        assert!(features.round_lights);
        let arrays = crate::gpu::scene_buffers::build_scene_arrays(&scene, &features, &bvh);
        assert_eq!(arrays.lights.len(), 4);
        for (l, light) in arrays.lights.iter().enumerate() {
            assert_eq!(light.convex, 1, "light {l}");
            assert_eq!(light.round, 1, "light {l} is a sphere: sampled by its cone");
            let tags =
                arrays.bvh_nodes.iter().flat_map(|n| [n.lights_01, n.lights_23]).flat_map(|w| [w & 0xffff, w >> 16]);
            assert!(tags.filter(|&t| t == l as u32 + 1).count() > 0, "no subtree tagged with light {l}");
        }
    }
}

//! The same scene for Mitsuba 3: XML plus one binary PLY per material, for the peer comparison
//! (`bench/peer_mitsuba.py`, issue "beat Mitsuba 3 at equal time"). Every triangle, vertex
//! normal, radiance and the camera are written as veach renders them. Materials map as:
//!
//! - Lambertian (metallic 0, specular 0) ↔ `diffuse` with the same reflectance: identical.
//! - metal (metallic 1) ↔ `roughconductor`, GGX with alpha = roughness² and
//!   `specular_reflectance` = base colour on a perfect conductor (`material="none"`). Two
//!   differences are by definition, not by bug: glTF's Fresnel is Schlick with f0 = base colour
//!   (rising to 1 at grazing angles) where this conductor's is constant, and glTF's Smith term is
//!   height-correlated where Mitsuba's is separable. `peer_mitsuba.py` measures what that does to
//!   the image.
//! - emissive triangles ↔ an `area` emitter on their mesh (one-sided, front = counter-clockwise
//!   winding, as in glTF); point, spot and directional lights ↔ `point`, `spot`, `directional`.
//! - with `round_lights_as_spheres`, each round light (a tessellated sphere: `LightSampling::Cone`
//!   samples it by its bounding cone) ↔ an analytic `sphere` of the same surface area around the
//!   same centre, which Mitsuba samples by its cone too (its `Sphere::sample_direction`): the
//!   same technique on both sides, on geometry that differs by the tessellation.
//!
//! Anything else (a dielectric specular layer, a mix of metal and dielectric, textures,
//! double-sided emitters) is refused with a message, so that the two renderers never render
//! different scenes without saying so.

use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;
use veach::error::{Error, Result};
use veach::scene::{Camera, LightKind, Scene};

/// Writes `dir/scene.xml` and `dir/mesh-K.ply`; the XML takes `spp`, `width`, `height`,
/// `emitter_samples`, `bsdf_samples` and `sampler` (a Mitsuba sampler plugin: `independent`,
/// `multijitter`, ...) as parameters ($name, Mitsuba's `mi.load_file(..., name=value)`).
pub fn export(scene: &Scene, camera: &Camera, dir: &Path, round_lights_as_spheres: bool) -> Result<()> {
    let io = |e: std::io::Error| Error::Options(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(io)?;
    let mut xml = String::new();
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    for (name, value) in [
        ("spp", "64"),
        ("width", "256"),
        ("height", "256"),
        ("emitter_samples", "1"),
        ("bsdf_samples", "1"),
        ("sampler", "independent"),
    ] {
        let _ = writeln!(xml, "    <default name=\"{name}\" value=\"{value}\"/>");
    }
    let _ = writeln!(
        xml,
        "    <integrator type=\"direct\">\n        <integer name=\"emitter_samples\" value=\"$emitter_samples\"/>\n        \
         <integer name=\"bsdf_samples\" value=\"$bsdf_samples\"/>\n        <boolean name=\"hide_emitters\" value=\"true\"/>\n    </integrator>"
    );
    let target = camera.position + camera.forward;
    let _ = writeln!(
        xml,
        "    <sensor type=\"perspective\">\n        <float name=\"fov\" value=\"{}\"/>\n        <string name=\"fov_axis\" value=\"y\"/>\n        \
         <transform name=\"to_world\">\n            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n        </transform>\n        \
         <sampler type=\"$sampler\">\n            <integer name=\"sample_count\" value=\"$spp\"/>\n        </sampler>\n        \
         <film type=\"hdrfilm\">\n            <integer name=\"width\" value=\"$width\"/>\n            <integer name=\"height\" value=\"$height\"/>\n            \
         <string name=\"pixel_format\" value=\"rgb\"/>\n            <rfilter type=\"box\"/>\n        </film>\n    </sensor>",
        camera.yfov.to_degrees(),
        triple(camera.position),
        triple(target),
        triple(camera.up)
    );
    // Round lights written as spheres, and their triangles left out of the meshes.
    let mut in_sphere = vec![false; scene.triangles.len()];
    for light in &scene.lights {
        let LightKind::Area { triangles, radiance, double_sided } = &light.kind else { continue };
        let Some((centre, radius)) =
            round_lights_as_spheres.then(|| veach::scene::light_shape::round_light_sphere(scene, triangles)).flatten()
        else {
            continue;
        };
        if *double_sided {
            return Err(Error::Options(format!(
                "light '{}' is double-sided; Mitsuba's area lights are one-sided",
                light.name
            )));
        }
        let material = &scene.materials[scene.triangles[triangles[0] as usize].material as usize];
        let _ = writeln!(
            xml,
            "    <!-- {} as a sphere -->\n    <shape type=\"sphere\">\n        <point name=\"center\" value=\"{}\"/>\n        \
             <float name=\"radius\" value=\"{radius:e}\"/>\n        {}\n        <emitter type=\"area\">\n            \
             <rgb name=\"radiance\" value=\"{}\"/>\n        </emitter>\n    </shape>",
            light.name.replace("--", "- -"),
            triple(centre),
            bsdf_xml(material)?,
            triple(*radiance)
        );
        for &t in triangles {
            in_sphere[t as usize] = true;
        }
    }
    for (m, material) in scene.materials.iter().enumerate() {
        let tris: Vec<_> = scene
            .triangles
            .iter()
            .zip(&in_sphere)
            .filter(|(t, s)| t.material as usize == m && !**s)
            .map(|(t, _)| t)
            .collect();
        if tris.is_empty() {
            continue;
        }
        let bsdf = bsdf_xml(material)?;
        let emitter = if material.is_emissive() {
            if material.double_sided {
                return Err(Error::Options(format!(
                    "material '{}' is a double-sided emitter; Mitsuba's area lights are one-sided",
                    material.name
                )));
            }
            format!(
                "\n        <emitter type=\"area\">\n            <rgb name=\"radiance\" value=\"{}\"/>\n        </emitter>",
                triple(material.emission)
            )
        } else {
            String::new()
        };
        let file = format!("mesh-{m}.ply");
        write_ply(&dir.join(&file), &tris).map_err(io)?;
        let _ = writeln!(
            xml,
            "    <!-- {} -->\n    <shape type=\"ply\">\n        <string name=\"filename\" value=\"{file}\"/>\n        \
             <boolean name=\"face_normals\" value=\"false\"/>\n        {bsdf}{emitter}\n    </shape>",
            material.name.replace("--", "- -")
        );
    }
    for light in &scene.lights {
        let text = match &light.kind {
            LightKind::Area { .. } => continue,
            LightKind::Point { position, intensity } => format!(
                "<emitter type=\"point\">\n        <point name=\"position\" value=\"{}\"/>\n        <rgb name=\"intensity\" value=\"{}\"/>\n    </emitter>",
                triple(*position),
                triple(*intensity)
            ),
            LightKind::Directional { direction, irradiance } => format!(
                "<emitter type=\"directional\">\n        <vector name=\"direction\" value=\"{}\"/>\n        <rgb name=\"irradiance\" value=\"{}\"/>\n    </emitter>",
                triple(*direction),
                triple(*irradiance)
            ),
            LightKind::Spot { .. } => {
                return Err(Error::Options(format!(
                    "spot light '{}': Mitsuba's spot falloff differs from KHR_lights_punctual's; not exported",
                    light.name
                )));
            }
        };
        let _ = writeln!(xml, "    {text}");
    }
    let _ = writeln!(xml, "</scene>");
    std::fs::write(dir.join("scene.xml"), xml).map_err(io)
}

/// The material's Mitsuba BSDF (see the module's table), or why it has none.
fn bsdf_xml(material: &veach::scene::Material) -> Result<String> {
    if material.texture_refs().next().is_some() {
        return Err(Error::Options(format!("material '{}' has textures, which the export leaves out", material.name)));
    }
    if material.metallic == 0.0 && material.specular == 0.0 {
        return Ok(format!(
            "<bsdf type=\"diffuse\">\n            <rgb name=\"reflectance\" value=\"{}\"/>\n        </bsdf>",
            triple(material.base_color)
        ));
    }
    if material.metallic == 1.0 {
        let alpha = (material.roughness * material.roughness).max(1e-4);
        return Ok(format!(
            "<bsdf type=\"roughconductor\">\n            <string name=\"distribution\" value=\"ggx\"/>\n            \
             <float name=\"alpha\" value=\"{alpha}\"/>\n            <string name=\"material\" value=\"none\"/>\n            \
             <rgb name=\"specular_reflectance\" value=\"{}\"/>\n        </bsdf>",
            triple(material.base_color)
        ));
    }
    Err(Error::Options(format!(
        "material '{}' (metallic {}, specular {}) has no Mitsuba equivalent in this export: only \
         Lambertian (metallic 0, specular 0) and metal (metallic 1) map one to one",
        material.name, material.metallic, material.specular
    )))
}

fn triple(v: Vec3) -> String {
    format!("{:e}, {:e}, {:e}", v.x, v.y, v.z)
}

/// Binary little-endian PLY: three vertices (position, shading normal) per triangle.
fn write_ply(path: &Path, tris: &[&veach::scene::Triangle]) -> std::io::Result<()> {
    let mut out = Vec::new();
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        tris.len() * 3,
        tris.len()
    );
    out.extend_from_slice(header.as_bytes());
    for t in tris {
        for k in 0..3 {
            for v in [t.p[k], t.n[k]] {
                for c in v.to_array() {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
    }
    for i in 0..tris.len() {
        out.push(3);
        for k in 0..3 {
            out.extend_from_slice(&((3 * i + k) as i32).to_le_bytes());
        }
    }
    std::fs::write(path, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn export_veach_scene(spheres: bool) -> (String, usize) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/veach-mis.gltf");
        let scene = veach::load_gltf(&path).unwrap();
        let dir = std::env::temp_dir().join(format!("veach-mitsuba-export-{}-{spheres}", std::process::id()));
        export(&scene, &scene.camera(None).unwrap(), &dir, spheres).unwrap();
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        let meshes = std::fs::read_dir(&dir)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().path().extension().unwrap() == "ply")
            .count();
        std::fs::remove_dir_all(&dir).unwrap();
        (xml, meshes)
    }

    #[test]
    fn round_lights_become_spheres_of_the_same_area_only_when_asked() {
        let (meshes_only, mesh_files) = export_veach_scene(false);
        assert_eq!(meshes_only.matches("type=\"sphere\"").count(), 0);
        let (with_spheres, sphere_mesh_files) = export_veach_scene(true);
        assert_eq!(with_spheres.matches("type=\"sphere\"").count(), 4, "the Veach scene's four lights");
        // Every emitter left the meshes: one emitter per sphere, none on a PLY shape.
        assert_eq!(with_spheres.matches("type=\"area\"").count(), 4);
        assert_eq!(mesh_files - sphere_mesh_files, 4, "the four lights' meshes are not written");
        // A UV sphere's area is a little under its bounding sphere's; the radius follows it.
        let scene =
            veach::load_gltf(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/veach-mis.gltf")).unwrap();
        for light in &scene.lights {
            let LightKind::Area { triangles, .. } = &light.kind else { panic!("area lights only") };
            let (_, r) = veach::scene::light_shape::round_light_sphere(&scene, triangles).unwrap();
            let corners = triangles.iter().flat_map(|&t| scene.triangles[t as usize].p);
            let (lo, hi) = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
            let bound = 0.5 * (hi - lo).max_element();
            assert!(r < bound && r > 0.98 * bound, "{}: radius {r} against the mesh's {bound}", light.name);
            assert!(with_spheres.contains(&format!("value=\"{r:e}\"")));
        }
    }
}

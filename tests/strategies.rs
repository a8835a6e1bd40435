//! Every strategy converges to the same image: on the shipped scenes, per-region means of each
//! strategy agree with a high-sample MIS reference within confidence intervals computed from
//! both renders' own per-pixel variance.

mod common;

use common::*;
use veach::{Heuristic, LightSampling, LightSelection, RenderSettings, Sampler, Strategy};

struct Config {
    name: &'static str,
    strategy: Strategy,
    spp: u32,
    light: u32,
    brdf: u32,
    selection: LightSelection,
    heuristic: Heuristic,
    sampling: LightSampling,
    control_variate: bool,
}

impl Config {
    /// The same, with emitter triangles sampled by solid angle.
    const fn solid_angle(self) -> Config {
        Config { sampling: LightSampling::SolidAngle, ..self }
    }

    /// The same, with round lights sampled by their bounding cones.
    const fn cone(self) -> Config {
        Config { sampling: LightSampling::Cone, ..self }
    }

    /// The same, with each light sampled by its shape (the default of `veach render`).
    const fn auto(self) -> Config {
        Config { sampling: LightSampling::Auto, ..self }
    }

    /// The same, with the unshadowed diffuse light as a control variate.
    const fn cv(self) -> Config {
        Config { control_variate: true, ..self }
    }
}

const fn config(
    name: &'static str,
    strategy: Strategy,
    spp: u32,
    light: u32,
    brdf: u32,
    selection: LightSelection,
    heuristic: Heuristic,
) -> Config {
    Config {
        name,
        strategy,
        spp,
        light,
        brdf,
        selection,
        heuristic,
        sampling: LightSampling::Area,
        control_variate: false,
    }
}

/// |m_a − m_b| / sqrt(σ²_a + σ²_b) of two region means in channel `ch`; regions black in both
/// (σ = 0) must agree exactly (0, else infinity).
fn z_score(a: &RegionEstimate, b: &RegionEstimate, ch: usize) -> f64 {
    let sigma = (a.var[ch] + b.var[ch]).sqrt();
    let diff = (a.mean[ch] - b.mean[ch]).abs();
    if sigma > 0.0 {
        diff / sigma
    } else if diff == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Two renders of one image compared region by region (`block`×`block`), each channel's z score
/// against `z`: a line in `failures` per region off, and where any is, the two images and their
/// difference written under `test`. `what` names the comparison, `names` the two renders.
fn compare_renders(
    test: &str,
    what: &str,
    names: [&str; 2],
    (a, b): (&veach::RenderOutput, &veach::RenderOutput),
    (width, block, z): (u32, u32, f64),
    failures: &mut Vec<String>,
) {
    let mut worst: f64 = 0.0;
    for ry in 0..width / block {
        for rx in 0..width / block {
            let (x, y) = (rx * block, ry * block);
            let (ra, rb) = (region(a, x, y, x + block, y + block), region(b, x, y, x + block, y + block));
            for ch in 0..3 {
                let score = z_score(&ra, &rb, ch);
                worst = worst.max(score);
                if score > z {
                    failures.push(format!(
                        "{what}: region ({rx},{ry}) channel {ch}: {:.5} {} vs {:.5} {}, |Δ|/σ = {score:.2} > {z:.2}",
                        ra.mean[ch], names[0], rb.mean[ch], names[1]
                    ));
                }
            }
        }
    }
    eprintln!("{test}, {what}: worst |Δ|/σ = {worst:.2} (bound {z:.2})");
    if worst > z {
        let (ma, mb) = (a.mean(), b.mean());
        let diff = ma.iter().zip(&mb).map(|(p, q)| [0, 1, 2].map(|c| (p[c] - q[c]).abs())).collect();
        let dir = write_failure_images(
            test,
            &[(names[0], width, width, ma), (names[1], width, width, mb), ("difference", width, width, diff)],
        );
        failures.push(format!("images in {}", dir.display()));
    }
}

/// Pairs of renders (`what`, the render, the one it must agree with) of one `width`² image that
/// share an expectation: no non-finite sample in the first, and `compare_renders` on each within
/// the Bonferroni z of all their regions and channels at family-wise significance 1e-3.
fn assert_renders_agree(
    test: &str,
    names: [&str; 2],
    (width, block): (u32, u32),
    pairs: &[(String, &veach::RenderOutput, &veach::RenderOutput)],
) {
    let regions = (width / block) * (width / block);
    let z = bonferroni_z(1e-3, pairs.len() * regions as usize * 3);
    let mut failures = Vec::new();
    for (what, a, b) in pairs {
        assert_eq!(a.nonfinite_samples, 0, "{test}, {what}");
        compare_renders(test, what, names, (a, b), (width, block, z), &mut failures);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Compares each config with the reference over `block`×`block` regions, per colour channel.
/// The statistic |m_s − m_ref| / sqrt(σ²_s + σ²_ref) is bounded by the Bonferroni z for all
/// comparisons of the test at family-wise significance 1e-3.
fn check_scene(scene_name: &str, width: u32, height: u32, block: u32, reference: Config, configs: &[Config]) {
    let scene = if scene_name.ends_with(".gltf") {
        veach::load_gltf(std::path::Path::new(scene_name)).unwrap()
    } else {
        shipped_scene(scene_name)
    };
    let scene_name = std::path::Path::new(scene_name).file_stem().unwrap().to_str().unwrap();
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let settings = |c: &Config, seed: u32| RenderSettings {
        width,
        height,
        spp: c.spp,
        strategy: c.strategy,
        light_samples: c.light,
        brdf_samples: c.brdf,
        light_selection: c.selection,
        heuristic: c.heuristic,
        light_sampling: c.sampling,
        control_variate: c.control_variate,
        seed,
        // σ from each pixel's sample variance / n: true of independent samples only.
        sampler: Sampler::Independent,
        ..Default::default()
    };
    let reference_out = render(&gpu_scene, &settings(&reference, 1), &camera);
    let regions_x = width / block;
    let regions_y = height / block;
    let comparisons = configs.len() * (regions_x * regions_y) as usize * 3;
    let z = bonferroni_z(1e-3, comparisons);
    let mut failures = Vec::new();
    for (k, c) in configs.iter().enumerate() {
        let out = render(&gpu_scene, &settings(c, 100 + k as u32), &camera);
        assert_eq!(out.nonfinite_samples, 0, "{}: non-finite samples", c.name);
        let mut worst: f64 = 0.0;
        let mut failed = false;
        for ry in 0..regions_y {
            for rx in 0..regions_x {
                let (x0, y0) = (rx * block, ry * block);
                let a = region(&out, x0, y0, x0 + block, y0 + block);
                let r = region(&reference_out, x0, y0, x0 + block, y0 + block);
                for ch in 0..3 {
                    let score = z_score(&a, &r, ch);
                    worst = worst.max(score);
                    if score > z {
                        failed = true;
                        failures.push(format!(
                            "{scene_name} {}: region ({rx},{ry}) channel {ch}: {:.5} vs reference {:.5}, |Δ|/σ = {score:.2} > {z:.2}",
                            c.name, a.mean[ch], r.mean[ch]
                        ));
                    }
                }
            }
        }
        eprintln!("{scene_name} {}: worst |Δ|/σ = {worst:.2} (bound {z:.2})", c.name);
        if failed {
            let diff: Vec<[f32; 3]> = out
                .mean()
                .iter()
                .zip(reference_out.mean())
                .map(|(a, b)| std::array::from_fn(|i| (a[i] - b[i]).abs()))
                .collect();
            let dir = write_failure_images(
                &format!("strategies-{scene_name}"),
                &[
                    (&format!("{}-rendered", c.name), width, height, out.mean()),
                    ("reference", width, height, reference_out.mean()),
                    (&format!("{}-abs-difference", c.name), width, height, diff),
                ],
            );
            eprintln!("images written to {}", dir.display());
        }
    }
    assert!(failures.is_empty(), "{} comparison(s) off:\n{}", failures.len(), failures.join("\n"));
}

use Heuristic::{Balance, Power as PowerHeuristic};
use glam::{Mat4, Vec3};
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData};

/// A 4×4 floor, `left` material for x < 0 and `right` for x > 0, lit by the emitter `light`
/// (radiance (6, 6, 5)), seen from above and in front; written as glTF, returns its path.
fn floor_scene(name: &str, left: MaterialDesc, right: MaterialDesc, light: MeshData) -> String {
    floor_scene_lit_by(name, left, right, &[(light, Vec3::new(6.0, 6.0, 5.0))])
}

/// The same floor under several lights, each (mesh, radiance) a light of its own.
fn floor_scene_lit_by(name: &str, left: MaterialDesc, right: MaterialDesc, lights: &[(MeshData, Vec3)]) -> String {
    let mut g = GltfBuilder::new();
    let left = g.material(&left);
    let right = g.material(&right);
    let quad = |x0: f32, x1: f32| {
        MeshData::quad(
            Vec3::new(x0, 0., -2.),
            Vec3::new(x1, 0., -2.),
            Vec3::new(x1, 0., 2.),
            Vec3::new(x0, 0., 2.),
            Vec3::Y,
        )
    };
    g.add_mesh("left floor", &quad(-2.0, 0.0), left, Mat4::IDENTITY);
    g.add_mesh("right floor", &quad(0.0, 2.0), right, Mat4::IDENTITY);
    for (k, (mesh, radiance)) in lights.iter().enumerate() {
        let emitter = g.material(&MaterialDesc::emitter(&format!("light {k}"), *radiance));
        g.add_mesh(&format!("light {k}"), mesh, emitter, Mat4::IDENTITY);
    }
    g.camera("camera", Vec3::new(0.0, 1.0, 2.6), Vec3::new(0.0, 0.0, -0.6), 50.0);
    let path = output_dir("scenes").join(format!("{name}.gltf"));
    g.write(&path).unwrap();
    path.to_str().unwrap().to_owned()
}
use LightSelection::{Each, Power, Uniform};

/// check_scene on a floor_scene: 24×24 in 6×6 regions against MIS 8 + 8 at 256 spp.
fn check_floor_scene(path: &str, configs: &[Config]) {
    check_scene(path, 24, 24, 6, config("reference", Strategy::Mis, 256, 8, 8, Each, Balance), configs);
}

/// A stress scene (`veach_scenes::stress`) written as glTF; returns its path.
fn stress_scene_file(name: &str) -> String {
    let path = output_dir("scenes").join(format!("stress-{name}.gltf"));
    veach_scenes::stress::stress_scene(name).unwrap().write(&path).unwrap();
    path.to_str().unwrap().to_owned()
}

#[test]
fn all_strategies_agree_on_the_cornell_box() {
    check_scene(
        "cornell-box",
        32,
        32,
        8,
        config("reference", Strategy::Mis, 256, 8, 8, Each, Balance),
        &[
            config("uniform", Strategy::Uniform, 32, 0, 512, Each, Balance),
            config("brdf", Strategy::Brdf, 32, 0, 64, Each, Balance),
            config("light", Strategy::Light, 64, 8, 0, Each, Balance),
            config("light-uniform", Strategy::Light, 64, 8, 0, Uniform, Balance),
            config("mis-balance", Strategy::Mis, 64, 4, 4, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
            config("mis-lobes", Strategy::MisLobes, 64, 4, 4, Each, Balance),
        ],
    );
}

/// Glossy materials under an area light, where every single strategy is well-conditioned:
/// a metal half (roughness 0.35) and a glossy dielectric half (roughness 0.25, specular on).
#[test]
fn all_strategies_agree_on_glossy_surfaces() {
    let light = MeshData::quad(
        Vec3::new(-0.6, 1.5, -1.6),
        Vec3::new(0.6, 1.5, -1.6),
        Vec3::new(0.6, 1.2, -0.8),
        Vec3::new(-0.6, 1.2, -0.8),
        Vec3::new(0.0, -1.0, 0.3),
    );
    let path = floor_scene(
        "glossy",
        MaterialDesc::metal("gold", Vec3::new(0.9, 0.7, 0.3), 0.35),
        MaterialDesc {
            roughness: 0.25,
            specular: 1.0,
            ..MaterialDesc::lambert("red plastic", Vec3::new(0.5, 0.08, 0.05))
        },
        light,
    );
    check_floor_scene(
        &path,
        &[
            config("uniform", Strategy::Uniform, 32, 0, 512, Each, Balance),
            config("brdf", Strategy::Brdf, 64, 0, 32, Each, Balance),
            config("light", Strategy::Light, 64, 16, 0, Each, Balance),
            config("mis-balance", Strategy::Mis, 64, 4, 4, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
            config("mis-lobes", Strategy::MisLobes, 64, 4, 4, Power, Balance),
        ],
    );
}

/// The Veach scene is built so that each single strategy fails somewhere: uniform and BRDF
/// sampling on the rough plates under the small lights, light sampling on the sharp plates
/// under the large lights. There their variance is so large (hits with probability below
/// 1e-4 per sample) that no affordable sample count puts the region means in the regime where
/// a confidence interval from the sample variance holds. Single strategies are therefore
/// checked on the Cornell box, the glossy scene and the analytic scenes; here every MIS
/// variant (heuristics, light selections, sample splits) must match the reference.
#[test]
fn mis_variants_agree_on_the_veach_mis_scene() {
    check_scene(
        "veach-mis",
        36,
        24,
        6,
        config("reference", Strategy::Mis, 128, 4, 8, Each, Balance),
        &[
            config("mis-balance", Strategy::Mis, 64, 2, 4, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Each, PowerHeuristic),
            config("mis-power-selection", Strategy::Mis, 64, 8, 8, Power, PowerHeuristic),
            config("mis-bsdf-selection", Strategy::Mis, 64, 4, 4, LightSelection::Bsdf, PowerHeuristic),
            config("mis-uniform-selection", Strategy::Mis, 64, 8, 4, Uniform, Balance),
            config("mis-brdf-heavy", Strategy::Mis, 64, 1, 16, Each, PowerHeuristic),
            config("mis-lobes", Strategy::MisLobes, 64, 4, 4, Power, Balance),
            config("mis-lobes-each", Strategy::MisLobes, 64, 4, 4, Each, Balance),
        ],
    );
}

/// mis-lobes decides per point, before sampling, whether the glossy lobe gets samples of its own:
/// only where some light, seen from the point, covers more solid angle per selection probability
/// than the lobe does around the light's direction. Under a light smaller than the lobe (20 cm at
/// 1.3 m over roughness 0.3, where lobe samples would still hit it around the highlight) every
/// sample becomes a light sample and the BRDF-sample image is exactly zero; under a 1.2 m light
/// the lobe's samples find it around the highlight.
/// (That either choice is unbiased, the agreement tests above check on the glossy and Veach
/// scenes.)
#[test]
fn mis_lobes_samples_the_glossy_lobe_only_where_a_light_is_wider_than_it() {
    let contributions = |name: &str, half: f32| -> (f64, f64) {
        let light = MeshData::quad(
            Vec3::new(-half, 1.3, -0.6 - half),
            Vec3::new(half, 1.3, -0.6 - half),
            Vec3::new(half, 1.3, -0.6 + half),
            Vec3::new(-half, 1.3, -0.6 + half),
            Vec3::NEG_Y,
        );
        let metal = |n| MaterialDesc::metal(n, Vec3::new(0.9, 0.9, 0.9), 0.3);
        let path = floor_scene(name, metal("left metal"), metal("right metal"), light);
        let scene = veach::load_gltf(std::path::Path::new(&path)).unwrap();
        let settings = RenderSettings {
            width: 32,
            height: 32,
            spp: 16,
            strategy: Strategy::MisLobes,
            light_samples: 1,
            brdf_samples: 1,
            write_aovs: true,
            hide_emitters: true,
            ..Default::default()
        };
        let out = render(&upload(&scene), &settings, &scene.camera(None).unwrap());
        let images = out.contribution_images().unwrap();
        let total = |img: &[[f32; 3]]| img.iter().map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64).sum::<f64>();
        (total(&images.light), total(&images.brdf))
    };
    let (light, brdf) = contributions("lobe-allocation-small-light", 0.1);
    assert!(light > 0.0, "small light: no light-sample contribution");
    assert_eq!(brdf, 0.0, "small light: the glossy lobe got samples of its own");
    let (light, brdf) = contributions("lobe-allocation-large-light", 0.6);
    assert!(light > 0.0, "large light: no light-sample contribution");
    assert!(brdf > 0.05 * (light + brdf), "large light: lobe samples found little ({brdf} of {})", light + brdf);
}

/// A dielectric mirror (roughness 0: a delta specular lobe over a diffuse base) and a metal
/// mirror under an area light. Only BRDF sampling reaches the delta lobe, so BRDF sampling and
/// every MIS variant must agree; light and uniform sampling see the diffuse part alone.
#[test]
fn brdf_and_mis_agree_on_perfect_mirrors() {
    // A wall of light behind the floor: the mirrors reflect it.
    let light = MeshData::quad(
        Vec3::new(-3.0, 0.0, -3.0),
        Vec3::new(3.0, 0.0, -3.0),
        Vec3::new(3.0, 2.5, -3.0),
        Vec3::new(-3.0, 2.5, -3.0),
        Vec3::Z,
    );
    let path = floor_scene(
        "mirrors",
        MaterialDesc::metal("mirror", Vec3::new(0.9, 0.8, 0.6), 0.0),
        MaterialDesc { roughness: 0.0, specular: 1.0, ..MaterialDesc::lambert("lacquer", Vec3::new(0.4, 0.1, 0.1)) },
        light,
    );
    check_scene(
        &path,
        24,
        24,
        6,
        config("reference", Strategy::Mis, 256, 4, 4, Each, Balance),
        &[
            config("brdf", Strategy::Brdf, 64, 0, 16, Each, Balance),
            config("mis-balance", Strategy::Mis, 64, 2, 2, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
            config("mis-lobes", Strategy::MisLobes, 64, 2, 2, Each, Balance),
        ],
    );
}

/// Textures of every kind (shipped `textured` scene): base colour, metallic-roughness, normal
/// map and an emissive texture on the light. Light samples read the emissive texture at the
/// sampled point and BRDF samples at the point they hit; if the two disagreed, light and BRDF
/// sampling would converge to different images.
#[test]
fn all_strategies_agree_on_the_textured_scene() {
    check_scene(
        "textured",
        32,
        24,
        8,
        config("reference", Strategy::Mis, 256, 8, 8, Each, Balance),
        &[
            config("uniform", Strategy::Uniform, 32, 0, 256, Each, Balance),
            config("brdf", Strategy::Brdf, 64, 0, 32, Each, Balance),
            config("light", Strategy::Light, 64, 8, 0, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
        ],
    );
}

/// Light samples in round lights' bounding cones (traced as direction samples, to their closest
/// hits) converge to the area-sampled MIS reference. Cone samples that miss the tessellated
/// sphere, or find another surface first, must count nothing, and a BRDF sample that finds a
/// sphere must be weighed with the cone's density: each mistake shifts the image by more than
/// these bounds. Light sampling alone is checked on a floor (diffuse and rough metal) under two
/// spheres, one of them low enough that floor points see it in a wide cone, and under a cube
/// standing on the floor (round too, A / 4πr² = 0.64: the floor around its base lies inside its
/// bounding sphere, where every direction is sampled, and area sampling's r² → 0 at the contact
/// edge) beside a tiny bright sphere (radius 0.01, radiance 3,000); on the Veach scene,
/// where light sampling alone has no usable confidence interval on the sharp plates (above; with
/// cones too: at 64 spp one region's mean came out 0.04-0.24 around a true 0.20), every MIS variant.
#[test]
fn cone_light_sampling_agrees_with_area_sampling() {
    let radiance = Vec3::new(6.0, 6.0, 5.0);
    let white = || MaterialDesc::lambert("white", Vec3::splat(0.7));
    let gold = || MaterialDesc::metal("rough gold", Vec3::new(0.9, 0.7, 0.3), 0.45);
    let spheres = [
        (MeshData::sphere(Vec3::new(-0.6, 0.45, -0.7), 0.3, 24, 12), radiance),
        (MeshData::sphere(Vec3::new(0.9, 1.3, -1.2), 0.15, 16, 8), radiance),
    ];
    let cube = MeshData::prism(
        [Vec3::new(-0.5, 0.0, -1.0), Vec3::new(0.1, 0.0, -1.0), Vec3::new(0.1, 0.0, -0.4), Vec3::new(-0.5, 0.0, -0.4)],
        0.6,
    );
    let cube_and_tiny =
        [(cube, radiance), (MeshData::sphere(Vec3::new(0.8, 0.4, -0.6), 0.01, 12, 6), Vec3::splat(3000.0))];
    let configs = [
        config("light", Strategy::Light, 64, 8, 0, Each, Balance),
        config("light-cone", Strategy::Light, 64, 8, 0, Each, Balance).cone(),
        config("light-cone-power-selection", Strategy::Light, 64, 8, 0, Power, Balance).cone(),
        config("mis-cone", Strategy::Mis, 64, 4, 4, LightSelection::Bsdf, PowerHeuristic).cone(),
        config("mis-lobes-cone", Strategy::MisLobes, 64, 4, 4, Power, Balance).cone(),
    ];
    for (name, lights) in [("spheres", &spheres), ("cube-and-tiny-sphere", &cube_and_tiny)] {
        let path = floor_scene_lit_by(name, white(), gold(), lights);
        let scene = veach::load_gltf(std::path::Path::new(&path)).unwrap();
        assert!(veach::features::SceneFeatures::detect(&scene).all_lights_round, "{name}: every light is round");
        check_floor_scene(&path, &configs);
    }
    check_scene(
        "veach-mis",
        36,
        24,
        6,
        config("reference", Strategy::Mis, 128, 4, 8, Each, Balance),
        &[
            config("mis-cone", Strategy::Mis, 64, 2, 2, Each, Balance).cone(),
            config("mis-cone-power", Strategy::Mis, 64, 4, 4, LightSelection::Bsdf, PowerHeuristic).cone(),
            config("mis-cone-brdf-heavy", Strategy::Mis, 64, 1, 8, Power, PowerHeuristic).cone(),
            config("mis-lobes-cone", Strategy::MisLobes, 64, 4, 4, Power, Balance).cone(),
        ],
    );
}

/// A curved emissive mesh is loaded as lights of its own parts (`light_shape::light_parts`): a
/// tube of rectangles (each a parallelogram light) closed by fans of single triangles. Split, it
/// renders the expectation it has as one light: each region's mean under `veach render`'s defaults
/// (lights chosen by the tree, which picks among the parts), and under lights chosen by power and
/// uniformly, agrees with the whole light's within |Δ|/σ below the Bonferroni z of all
/// comparisons at family-wise significance 1e-3 (σ² = the two means' variances: independent
/// samples, each pixel's sample variance / n).
#[test]
fn a_curved_light_split_into_parts_renders_what_it_does_whole() {
    // Above and behind the camera, out of its view, lighting the floor in front of it.
    let (segments, radius, y, z) = (12u32, 0.12f32, 1.6f32, 2.9f32);
    let (x0, x1) = (-0.8f32, 0.6f32);
    let ring = |k: u32, x: f32| {
        let a = std::f32::consts::TAU * k as f32 / segments as f32;
        Vec3::new(x, y + radius * a.cos(), z + radius * a.sin())
    };
    let mut tube = MeshData::default();
    for k in 0..segments {
        let (a, b) = (ring(k, x0), ring(k + 1, x0));
        let outward = 0.5 * (a + b) - Vec3::new(x0, y, z);
        tube.append(&MeshData::quad(a, ring(k, x1), ring(k + 1, x1), b, outward));
    }
    for (x, facing) in [(x0, -1.0f32), (x1, 1.0)] {
        let centre = Vec3::new(x, y, z);
        for k in 0..segments {
            let (a, b) = (ring(k, x), ring(k + 1, x));
            let t = if (b - a).cross(centre - a).x * facing > 0.0 { [a, b, centre] } else { [a, centre, b] };
            tube.append(&MeshData { positions: t.to_vec(), normals: None, uvs: None, indices: vec![0, 1, 2] });
        }
    }
    let path = floor_scene_lit_by(
        "curved-light",
        MaterialDesc::lambert("white", Vec3::splat(0.7)),
        MaterialDesc::metal("rough gold", Vec3::new(0.9, 0.7, 0.3), 0.3),
        &[(tube, Vec3::new(6.0, 6.0, 5.0))],
    );
    let split = veach::load_gltf(std::path::Path::new(&path)).unwrap();
    assert_eq!(split.lights.len(), 12 + 2 * 12, "{:?}", split.lights.iter().map(|l| &l.name).collect::<Vec<_>>());
    let mut whole = split.clone();
    let all: Vec<u32> = split
        .lights
        .iter()
        .flat_map(|l| match &l.kind {
            veach::scene::LightKind::Area { triangles, .. } => triangles.clone(),
            _ => unreachable!("area lights only"),
        })
        .collect();
    assert_eq!(all.len(), 4 * segments as usize, "every triangle in one part");
    whole.lights.truncate(1);
    let veach::scene::LightKind::Area { triangles, .. } = &mut whole.lights[0].kind else { unreachable!() };
    *triangles = all;
    let camera = split.camera(None).unwrap();
    let (width, block) = (24u32, 6u32);
    let settings = |selection: LightSelection, seed: u32| RenderSettings {
        width,
        height: width,
        spp: 256,
        light_selection: selection,
        seed,
        sampler: Sampler::Independent,
        ..RenderSettings::recommended()
    };
    let selections = [LightSelection::Tree, Power, Uniform];
    let whole_out = render(&upload(&whole), &settings(LightSelection::Tree, 1), &camera);
    let split_gpu = upload(&split);
    let outs: Vec<_> = (selections.iter().enumerate())
        .map(|(k, &selection)| render(&split_gpu, &settings(selection, 10 + k as u32), &camera))
        .collect();
    let pairs: Vec<_> = selections.iter().zip(&outs).map(|(s, out)| (format!("{s:?}"), out, &whole_out)).collect();
    assert_renders_agree("curved-light", ["split", "whole"], (width, block), &pairs);
}

/// A light sealed in a closed box gets no light samples outside the box (its lit box,
/// `veach::lit_boxes`), and that leaves the image unbiased: the stress scene `degenerate`, whose
/// camera sees the box from outside, renders the expectation it has without the sealed light at
/// all, with MIS at `veach render`'s defaults and with light samples alone (lights by the tree),
/// region by region within the Bonferroni z of all comparisons at family-wise significance 1e-3
/// (σ² = the two means' variances, as above).
#[test]
fn a_sealed_light_left_out_of_light_samples_outside_its_box_stays_unbiased() {
    let sealed = veach::load_gltf(std::path::Path::new(&stress_scene_file("degenerate"))).unwrap();
    let without = {
        let mut s = sealed.clone();
        s.lights.retain(|l| !l.name.starts_with("sealed light"));
        assert_eq!(s.lights.len() + 1, sealed.lights.len());
        s
    };
    let camera = sealed.camera(None).unwrap();
    let (width, block) = (24u32, 6u32);
    let settings = |strategy: Strategy, seed: u32| RenderSettings {
        width,
        height: width,
        spp: 256,
        strategy,
        light_samples: 1,
        brdf_samples: if strategy == Strategy::Light { 0 } else { 1 },
        seed,
        sampler: Sampler::Independent,
        ..RenderSettings::recommended()
    };
    let sealed_gpu = upload(&sealed);
    assert!(sealed_gpu.light_tree_lit_boxes(), "the sealed light has no lit box");
    let without_gpu = upload(&without);
    let strategies = [Strategy::Mis, Strategy::Light];
    let outs: Vec<_> = (strategies.iter().enumerate())
        .map(|(k, &strategy)| {
            let out = render(&sealed_gpu, &settings(strategy, 20 + k as u32), &camera);
            (out, render(&without_gpu, &settings(strategy, 30 + k as u32), &camera))
        })
        .collect();
    let pairs: Vec<_> =
        strategies.iter().zip(&outs).map(|(s, (out, reference))| (format!("{s:?}"), out, reference)).collect();
    assert_renders_agree("sealed-light", ["sealed", "without"], (width, block), &pairs);
}

/// Solid-angle sampling (these scenes' lights are rectangles: Ureña et al. 2013's spherical
/// rectangles) converges to the area-sampled MIS reference: on the Cornell box, and on the stress
/// scenes where it matters, a light touching the floor (r² → 0 at the contact edge) and one seen
/// at grazing angles (cos θ_l → 0); so do uniform, BRDF and area-sampled MIS there, and
/// `veach render`'s defaults (MIS 1 + 1, lights by the tree, the power heuristic, auto).
#[test]
fn solid_angle_light_sampling_agrees_with_area_sampling() {
    // Light sampling by area is left out on these two: its variance is infinite there (the
    // bench's slopes are -0.75 and -0.84), which is the point of solid-angle sampling.
    let configs = [
        config("uniform", Strategy::Uniform, 32, 0, 256, Each, Balance),
        config("brdf", Strategy::Brdf, 64, 0, 32, Each, Balance),
        config("mis-balance", Strategy::Mis, 64, 4, 4, Each, Balance),
        config("light-solid-angle", Strategy::Light, 64, 8, 0, Each, Balance).solid_angle(),
        config("mis-solid-angle", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic).solid_angle(),
        config("mis-lobes-solid-angle", Strategy::MisLobes, 64, 4, 4, Each, Balance).solid_angle(),
        config("defaults", Strategy::Mis, 64, 1, 1, LightSelection::Tree, PowerHeuristic).auto(),
    ];
    let reference = config("reference", Strategy::Mis, 256, 8, 8, Each, Balance);
    check_scene("cornell-box", 32, 32, 8, reference, &configs);
    let reference = config("reference", Strategy::Mis, 256, 8, 8, Each, Balance);
    check_scene(&stress_scene_file("touching-light"), 24, 24, 6, reference, &configs);
    let reference = config("reference", Strategy::Mis, 256, 8, 8, Each, Balance);
    check_scene(&stress_scene_file("grazing-light"), 24, 24, 6, reference, &configs);
}

/// The other stiff stress scenes, with every strategy whose variance is finite there: a tiny,
/// very bright light (uniform and BRDF sampling find it with probability ~1e-6 per sample and
/// are left out), 300 lights over six orders of power (lights chosen by power; the reference
/// too, as `veach bench` does past 32 lights), and mirrors of roughness 0 to 1 (light sampling
/// cannot reach a mirror lobe and is left out: it converges to the image without it).
#[test]
fn finite_variance_strategies_agree_on_the_stiff_stress_scenes() {
    let cases = [
        (
            "tiny-bright-light",
            config("reference", Strategy::Mis, 256, 8, 8, Each, Balance),
            [
                config("light", Strategy::Light, 64, 8, 0, Each, Balance),
                config("mis-power", Strategy::Mis, 64, 4, 4, Each, PowerHeuristic),
                config("mis-lobes", Strategy::MisLobes, 64, 4, 4, Each, Balance),
            ],
        ),
        (
            "many-lights",
            config("reference", Strategy::Mis, 256, 16, 4, Power, Balance),
            [
                config("light-by-power", Strategy::Light, 64, 8, 0, Power, Balance),
                config("mis-by-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
                config("mis-lobes-by-power", Strategy::MisLobes, 64, 4, 4, Power, Balance),
            ],
        ),
        (
            "near-mirrors",
            config("reference", Strategy::Mis, 256, 4, 4, Each, Balance),
            [
                config("brdf", Strategy::Brdf, 64, 0, 8, Each, Balance),
                config("mis-balance", Strategy::Mis, 64, 2, 2, Each, Balance),
                config("mis-lobes", Strategy::MisLobes, 64, 2, 2, Each, PowerHeuristic),
            ],
        ),
    ];
    for (scene, reference, configs) in cases {
        check_scene(&stress_scene_file(scene), 24, 24, 6, reference, &configs);
    }
}

/// Lights chosen per shading point (`--light-selection bsdf`) where one light's guess is zero
/// at every floor point while part of it lights the floor: a wall light half sunk into the floor,
/// whose bounding-sphere centre lies in the floor's plane (cos = 0 there), beside a small light
/// above. Only the power share of the choice keeps the wall light selectable; light sampling
/// alone (no BRDF samples, whose MIS weight would make up for a light never chosen) must match
/// the reference.
#[test]
fn per_point_light_choice_keeps_lights_whose_centre_is_below_the_horizon() {
    let mut g = GltfBuilder::new();
    let floor = g.material(&MaterialDesc::lambert("floor", Vec3::splat(0.6)));
    let wall = g.material(&MaterialDesc::emitter("wall light", Vec3::new(3.0, 3.0, 3.0)));
    let top = g.material(&MaterialDesc::emitter("top light", Vec3::new(20.0, 20.0, 20.0)));
    let q = MeshData::quad(
        Vec3::new(-2., 0., -2.),
        Vec3::new(2., 0., -2.),
        Vec3::new(2., 0., 2.),
        Vec3::new(-2., 0., 2.),
        Vec3::Y,
    );
    g.add_mesh("floor", &q, floor, Mat4::IDENTITY);
    let half_sunk = MeshData::quad(
        Vec3::new(-0.8, -0.6, -1.0),
        Vec3::new(0.8, -0.6, -1.0),
        Vec3::new(0.8, 0.6, -1.0),
        Vec3::new(-0.8, 0.6, -1.0),
        Vec3::Z,
    );
    g.add_mesh("wall light", &half_sunk, wall, Mat4::IDENTITY);
    let above = MeshData::quad(
        Vec3::new(-0.2, 1.5, 0.2),
        Vec3::new(0.2, 1.5, 0.2),
        Vec3::new(0.2, 1.5, 0.6),
        Vec3::new(-0.2, 1.5, 0.6),
        Vec3::NEG_Y,
    );
    g.add_mesh("top light", &above, top, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 1.2, 2.4), Vec3::new(0.0, 0.0, -0.2), 50.0);
    let path = output_dir("scenes").join("half-sunk-light.gltf");
    g.write(&path).unwrap();
    let bsdf = LightSelection::Bsdf;
    check_scene(
        path.to_str().unwrap(),
        24,
        24,
        6,
        config("reference", Strategy::Mis, 256, 8, 8, Each, Balance),
        &[
            config("light-bsdf", Strategy::Light, 64, 8, 0, bsdf, Balance),
            config("mis-bsdf", Strategy::Mis, 64, 4, 4, bsdf, PowerHeuristic),
        ],
    );
}

/// Past 16 lights a direction sample's ray is traced only as far as it can find an emitter: to
/// where it leaves the sphere and the box around all emitters (`emitter_reach`, lights.wgsl),
/// and not at all where it misses them. Under `veach scale`'s grid of 64 small lights 1 m over a
/// floor (a box of zero height around them, grown by rounding's margin), BRDF sampling and MIS
/// must still find every light: they agree with light sampling, which traces no such ray.
#[test]
fn direction_samples_find_every_light_of_a_flat_grid_of_many() {
    let path = output_dir("scenes").join("light-grid-64.gltf");
    veach_scenes::scale_scenes::light_scene(64, 64).write(&path).unwrap();
    check_scene(
        path.to_str().unwrap(),
        24,
        24,
        6,
        config("reference", Strategy::Light, 256, 8, 0, Power, Balance),
        &[
            config("brdf", Strategy::Brdf, 64, 0, 64, Each, Balance),
            config("mis-power", Strategy::Mis, 64, 4, 4, Power, PowerHeuristic),
        ],
    );
}

/// The unshadowed diffuse light as a control variate (shaders/control_variate.wgsl) converges to
/// the plain MIS reference wherever something changes it: shadows and the boxes' faces of the
/// Cornell box; a light that passes through the floor's plane (the clip at the horizon), seen by a
/// blocker's top and by a floor whose shading normals lean 17° off its geometric normal towards
/// the light (g below the geometric normal's plane, where f L_e V cos is zero), with an umbra, where
/// the estimate is A minus the samples' g; the stress scenes' light touching the floor and light
/// at grazing angles; glossy and metal floors, where g is only part of f (metal: none). Each with
/// every strategy it takes and light selection by power, BSDF and each. Planted: without the
/// horizon clip 126 comparisons fail, without g below the geometric normal's plane 120.
#[test]
fn the_control_variate_agrees_with_plain_mis() {
    let cv_configs = [
        config("uniform-cv", Strategy::Uniform, 32, 0, 128, Each, Balance).cv(),
        config("brdf-cv", Strategy::Brdf, 64, 0, 16, Each, Balance).cv(),
        config("light-cv", Strategy::Light, 64, 4, 0, Power, Balance).cv(),
        config("mis-power-cv", Strategy::Mis, 64, 2, 2, Power, PowerHeuristic).cv(),
        config("mis-bsdf-cv", Strategy::Mis, 64, 1, 1, LightSelection::Bsdf, PowerHeuristic).cv(),
        config("mis-each-cv", Strategy::Mis, 64, 2, 2, Each, Balance).cv(),
        config("mis-solid-angle-cv", Strategy::Mis, 64, 2, 2, Each, Balance).solid_angle().cv(),
    ];
    check_scene("cornell-box", 32, 32, 8, config("reference", Strategy::Mis, 256, 8, 8, Each, Balance), &cv_configs);
    for name in ["touching-light", "grazing-light"] {
        check_floor_scene(&stress_scene_file(name), &cv_configs);
    }
    let white = MaterialDesc::lambert("white", Vec3::splat(0.7));
    let glossy = MaterialDesc { specular: 1.0, roughness: 0.4, ..MaterialDesc::lambert("glossy", Vec3::splat(0.6)) };
    let gold = MaterialDesc::metal("rough gold", Vec3::new(0.9, 0.7, 0.3), 0.45);
    let panel = MeshData::quad(
        Vec3::new(-1.0, 1.2, -1.2),
        Vec3::new(1.0, 1.2, -1.2),
        Vec3::new(1.0, 1.2, -0.2),
        Vec3::new(-1.0, 1.2, -0.2),
        -Vec3::Y,
    );
    check_floor_scene(&floor_scene("cv-glossy", glossy, gold, panel), &cv_configs);

    // Through the floor's plane, facing the camera's side; a blocker over the floor in front of it.
    let mut g = GltfBuilder::new();
    let floor = g.material(&white);
    let lean = Vec3::new(0.1, 1.0, -0.3).normalize();
    let mut ground = MeshData::quad(
        Vec3::new(-2., 0., -2.),
        Vec3::new(2., 0., -2.),
        Vec3::new(2., 0., 2.),
        Vec3::new(-2., 0., 2.),
        Vec3::Y,
    );
    ground.normals = Some(vec![lean; 4]);
    g.add_mesh("floor", &ground, floor, Mat4::IDENTITY);
    let blocker = MeshData::quad(
        Vec3::new(-0.3, 0.25, -0.9),
        Vec3::new(0.3, 0.25, -0.9),
        Vec3::new(0.3, 0.25, -0.5),
        Vec3::new(-0.3, 0.25, -0.5),
        Vec3::Y,
    );
    let blocker_material = g.material(&MaterialDesc::lambert("blocker", Vec3::splat(0.5)));
    g.add_mesh("blocker", &blocker, blocker_material, Mat4::IDENTITY);
    let through = MeshData::quad(
        Vec3::new(-1.0, -0.4, -1.6),
        Vec3::new(1.0, -0.4, -1.6),
        Vec3::new(1.0, 0.8, -1.1),
        Vec3::new(-1.0, 0.8, -1.1),
        Vec3::Z,
    );
    let emitter = g.material(&MaterialDesc::emitter("light", Vec3::new(6.0, 6.0, 5.0)));
    g.add_mesh("light", &through, emitter, Mat4::IDENTITY);
    g.camera("camera", Vec3::new(0.0, 1.0, 2.6), Vec3::new(0.0, 0.0, -0.6), 50.0);
    let path = output_dir("scenes").join("cv-through-the-floor.gltf");
    g.write(&path).unwrap();
    check_floor_scene(path.to_str().unwrap(), &cv_configs);
}

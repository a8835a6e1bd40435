//! Kernels specialised to a scene's features and strategy (shaders/features.wgsl) render the
//! same image as the generic kernel, and compiled kernels are cached.

mod common;

use common::*;
use glam::{Mat4, Vec3};
use std::time::Duration;
use veach::gpu::baked_triangles::BAKED_TRIANGLES_MAX;
use veach::kernel_plan::KernelPlan;
use veach::{Execution, LightSampling, LightSelection, RenderSettings, Strategy};
use veach_scenes::gltf_writer::{GltfBuilder, MaterialDesc, MeshData, Punctual};

fn point_lit_plane() -> veach::Scene {
    let mut g = GltfBuilder::new();
    let m = g.material(&MaterialDesc::lambert("plane", Vec3::splat(0.5)));
    let q = MeshData::quad(
        Vec3::new(-5., 0., -5.),
        Vec3::new(5., 0., -5.),
        Vec3::new(5., 0., 5.),
        Vec3::new(-5., 0., 5.),
        Vec3::Y,
    );
    g.add_mesh("plane", &q, m, Mat4::IDENTITY);
    g.punctual_light("point", Punctual::Point, Vec3::splat(2.0), Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO);
    g.punctual_light("sun", Punctual::Directional, Vec3::splat(0.5), Vec3::new(1.0, 1.0, 0.0), Vec3::ZERO);
    g.camera("camera", Vec3::new(0.0, 2.0, 3.0), Vec3::ZERO, 60.0);
    load(&g, "specialise-point")
}

/// The shipped scenes and a plane under point and directional lights: every feature the kernels
/// specialise on.
fn scenes() -> [(&'static str, veach::Scene); 4] {
    [
        ("cornell-box", shipped_scene("cornell-box")),
        ("veach-mis", shipped_scene("veach-mis")),
        ("textured", shipped_scene("textured")),
        ("point-lit plane", point_lit_plane()),
    ]
}

/// The specialised kernels only drop code behind constant-false conditions (features the scene
/// lacks, other strategies, contribution images not asked for) and draw the same random numbers,
/// so their images are identical, bit for bit, to the generic kernel's. Both read the scene's
/// arrays where its upload put them (storage textures on a CPU adapter; against storage buffers:
/// `scene_arrays_render_alike_from_textures_and_from_storage`), and on a CPU adapter the scenes of
/// at most `BAKED_TRIANGLES_MAX` triangles (all but the Veach scene) have their triangles compiled
/// into the specialised kernel (shaders/traverse_baked.wgsl), the generic kernel a BVH.
#[test]
fn specialised_kernels_render_the_generic_kernels_image() {
    let cpu = renderer().gpu.adapter_info.device_type == wgpu::DeviceType::Cpu;
    // Kernels that take their camera samples in straight-line code (KernelPlan::straight_line_sample),
    // compared here with the generic kernel's loop: some must be, where the driver gets them.
    let mut straight_line = 0;
    for (name, scene) in scenes() {
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        for strategy in Strategy::ALL {
            // With one light and one BRDF sample the specialised kernel takes them without loops
            // (features.wgsl, AT_MOST_ONE_*), the generic kernel with.
            for (write_aovs, light_selection, light_sampling, samples) in [
                (false, LightSelection::Power, LightSampling::Area, 2),
                (true, LightSelection::Power, LightSampling::Area, 2),
                (false, LightSelection::Bsdf, LightSampling::Area, 2),
                (true, LightSelection::Bsdf, LightSampling::Cone, 2),
                (false, LightSelection::Bsdf, LightSampling::Auto, 1),
                (true, LightSelection::Power, LightSampling::Cone, 1),
            ] {
                let settings = RenderSettings {
                    width: 24,
                    height: 16,
                    spp: 2,
                    strategy,
                    light_samples: samples,
                    brdf_samples: samples,
                    light_selection,
                    light_sampling,
                    write_aovs,
                    seed: 9,
                    ..Default::default()
                };
                let special = render(&gpu_scene, &settings, &camera);
                let generic = render(&gpu_scene, &RenderSettings { specialise: false, ..settings.clone() }, &camera);
                assert_ne!(special.kernel, KernelPlan::generic());
                straight_line += special.kernel.driver.straight_line_sample as usize;
                // The workgroup is the driver's (GpuContext::render_workgroup), and the array
                // memory the scene's: neither is a specialisation.
                let workgroup = renderer().gpu.render_workgroup(false);
                let arrays = special.kernel.driver.arrays;
                let driver =
                    veach::kernel_plan::DriverTuning { workgroup, arrays, ..veach::kernel_plan::DriverTuning::none() };
                assert_eq!(generic.kernel, KernelPlan { driver, ..KernelPlan::generic() });
                if strategy == Strategy::Mis {
                    let k = &special.kernel;
                    assert_eq!(
                        k.samples.at_most_one_light_request && k.samples.at_most_one_direction_sample,
                        samples == 1,
                        "{name}"
                    );
                }
                assert_eq!(arrays.texels, cpu, "{name}: scene memory {arrays:?}");
                let baked = special.kernel.driver.baked.as_ref().map(|b| b.len());
                let small = scene.triangles.len() <= BAKED_TRIANGLES_MAX;
                assert_eq!(baked, (cpu && small).then_some(scene.triangles.len()), "{name}: baked triangles");
                assert!(generic.kernel.driver.baked.is_none());
                let what = format!("{name} {strategy:?} {light_selection:?} {light_sampling:?} aovs {write_aovs}");
                if special.kernel.driver.deferred_direction_rays {
                    // The same samples, their direction rays traced after the run's camera
                    // samples (take_samples_deferred): the sums add them in another order.
                    let counts = &generic.sum;
                    assert_same_samples_reordered(
                        "specialised",
                        &what,
                        &special.sum,
                        &generic.sum,
                        counts,
                        settings.width,
                    );
                } else {
                    assert_same_image("specialised", &what, &special.sum, &generic.sum, settings.width);
                }
                if write_aovs {
                    let (a, b) = (special.contributions.unwrap(), generic.contributions.unwrap());
                    assert_same_contributions("specialised", &what, &a, &b, settings.width);
                }
            }
        }
    }
    let masked = veach::kernel_plan::AutoExecution::for_adapter(&renderer().gpu.adapter_info)
        == veach::kernel_plan::AutoExecution::WavefrontWhereMasked;
    assert_eq!(straight_line > 0, masked, "{straight_line} straight-line kernels compared");
}

/// `veach scale`'s grid of 64 lights over a glossy gold floor just above its matte one, written as
/// `file`.
fn glossy_light_grid(file: &str) -> veach::Scene {
    let mut glossy = veach_scenes::scale_scenes::light_scene(64, 64);
    let gold = glossy.material(&MaterialDesc::metal("gold", Vec3::new(0.9, 0.7, 0.3), 0.3));
    let floor = MeshData::quad(
        Vec3::new(-2.0, 0.01, -2.0),
        Vec3::new(2.0, 0.01, -2.0),
        Vec3::new(2.0, 0.01, 2.0),
        Vec3::new(-2.0, 0.01, 2.0),
        Vec3::Y,
    );
    glossy.add_mesh("gold floor", &floor, gold, Mat4::IDENTITY);
    load(&glossy, file)
}

/// BVH kernels whose BRDF samples find emitters in the emitters' grid and trace a shadow ray to
/// what they find (gpu/emitter_grid.rs, `trace_emitters` in traverse_bvh.wgsl) render the generic
/// kernel's image, whose direction samples take a closest hit over the BVH: the same answer
/// wherever no blocker lies within the shadow rays' margin of a light, which none of these scenes
/// has. The grid is forced on (`StorageWithEmitterGrid`), also where it does not pay: `veach
/// scale`'s grid of 64 lights (a plane of cells) and the same grid over a glossy floor, the Veach
/// scene (3,840 emitting triangles in four spheres: a grid of cells in all three axes, which the
/// rays cross several at a time), `veach scale`'s Cornell box around a sphere, and the stress
/// scenes (coordinates near f32's limits, a box 10^5 away, lights touching and grazing surfaces,
/// degenerate triangles); MIS 1 + 1, BRDF sampling and uniform sampling, in the megakernel and the
/// wavefront.
#[test]
fn kernels_with_the_emitters_grid_render_the_generic_kernels_image() {
    let mut scenes = vec![
        ("grid", load(&veach_scenes::scale_scenes::light_scene(64, 64), "emitter-grid-grid")),
        ("veach-mis", shipped_scene("veach-mis")),
        ("cornell sphere", load(&veach_scenes::scale_scenes::triangle_scene(400), "emitter-grid-sphere")),
    ];
    scenes.push(("glossy grid", glossy_light_grid("emitter-grid-glossy")));
    for &name in veach_scenes::stress::STRESS_SCENES {
        scenes.push((name, load(&veach_scenes::stress::stress_scene(name).unwrap(), &format!("emitter-grid-{name}"))));
    }
    let mut compared = 0;
    for (name, scene) in scenes {
        let camera = scene.camera(None).unwrap();
        let gpu_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::StorageWithEmitterGrid).unwrap();
        if gpu_scene.emitter_triangles() == 0 {
            continue;
        }
        for (strategy, light_samples, brdf_samples, execution) in [
            (Strategy::Mis, 1, 1, Execution::Megakernel),
            (Strategy::Mis, 1, 1, Execution::Wavefront),
            (Strategy::Brdf, 0, 1, Execution::Megakernel),
            (Strategy::Uniform, 0, 1, Execution::Wavefront),
        ] {
            let settings = RenderSettings {
                width: 40,
                height: 30,
                spp: 6,
                strategy,
                light_samples,
                brdf_samples,
                execution,
                seed: 5,
                ..Default::default()
            };
            let gridded = render(&gpu_scene, &settings, &camera);
            let generic = render(&gpu_scene, &RenderSettings { specialise: false, ..settings.clone() }, &camera);
            let what = format!("{name} {strategy:?} {light_samples} + {brdf_samples} {execution:?}");
            assert!(
                gridded.kernel.driver.emitter_grid && !generic.kernel.driver.emitter_grid,
                "{what}: {:?}",
                gridded.kernel
            );
            assert_same_image("emitter-grid", &what, &gridded.sum, &generic.sum, settings.width);
            assert_same_rays(&what, gridded.rays, generic.rays);
            compared += 1;
        }
    }
    assert!(compared >= 4 * 10, "only {compared} renders compared");
}

/// Baked megakernels whose camera rays test their pixel's footprint list (gpu/camera_footprints.rs)
/// and whose direction rays wait for the end of the invocation's run (deferred_rays.wgsl,
/// take_samples_deferred) take the same samples as the generic kernel's loop, with the same values:
/// the same counts and rays, and sums equal up to reordered sums' rounding. The Cornell box (the
/// textured scene's 8 triangles are too few for the lists to pay), MIS 1 + 1, BRDF samples alone (every sample's ray deferred) and light samples
/// alone (lists, nothing deferred), in one dispatch and in bands of rows (one sample a run), at a
/// size whose rows do not fill a workgroup (and whose pixels are small enough for the lists: at
/// 37 × 21 a Cornell-box pixel sees more than `FOOTPRINT_SLOTS_MAX` triangles). Where the driver
/// gets these kernels (Mesa 22.3's lavapipe) the test checks that they ran.
#[test]
fn camera_footprint_kernels_render_the_loops_image() {
    let masked = veach::kernel_plan::AutoExecution::for_adapter(&renderer().gpu.adapter_info)
        == veach::kernel_plan::AutoExecution::WavefrontWhereMasked;
    for name in ["cornell-box"] {
        let scene = shipped_scene(name);
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        for (strategy, light_samples, brdf_samples, dispatch_target) in [
            (Strategy::Mis, 1, 1, Duration::from_secs(10)),
            (Strategy::Mis, 1, 1, Duration::from_nanos(1)),
            (Strategy::Brdf, 0, 1, Duration::from_secs(10)),
            (Strategy::Light, 1, 0, Duration::from_nanos(1)),
        ] {
            let settings = RenderSettings {
                width: 99,
                height: 70,
                spp: 8,
                strategy,
                light_samples,
                brdf_samples,
                dispatch_target,
                seed: 5,
                ..Default::default()
            };
            let special = render(&gpu_scene, &settings, &camera);
            let generic = render(&gpu_scene, &RenderSettings { specialise: false, ..settings.clone() }, &camera);
            let what = format!("{name} {strategy:?} {light_samples} + {brdf_samples} {dispatch_target:?}");
            assert_eq!(special.kernel.driver.footprint_slots > 0, masked, "{what}: {:?}", special.kernel);
            assert_eq!(special.kernel.driver.deferred_direction_rays, masked && brdf_samples > 0, "{what}");
            let counts = &generic.sum;
            let w = settings.width;
            assert_same_samples_reordered("footprints", &what, &special.sum, &generic.sum, counts, w);
            let squares = format!("{what}: squares");
            assert_same_samples_reordered("footprints", &squares, &special.sum_sq, &generic.sum_sq, counts, w);
            assert_same_rays(&what, special.rays, generic.rays);
            assert_eq!(special.nonfinite_samples, generic.nonfinite_samples, "{what}");
        }
        // With the control variate a sample may be negative, so a sum's rounding is bounded by
        // the sum of the samples' magnitudes, at most sqrt(n Σ x²) (Cauchy-Schwarz): each channel
        // may differ by 2n · 2^-24 of that. The sums of squares are checked as above.
        let settings = RenderSettings {
            width: 99,
            height: 70,
            spp: 8,
            strategy: Strategy::Mis,
            light_samples: 1,
            brdf_samples: 1,
            control_variate: true,
            seed: 6,
            ..Default::default()
        };
        let special = render(&gpu_scene, &settings, &camera);
        let generic = render(&gpu_scene, &RenderSettings { specialise: false, ..settings.clone() }, &camera);
        assert_eq!(
            special.kernel.driver.deferred_direction_rays, masked,
            "{name} control variate: {:?}",
            special.kernel
        );
        let counts = &generic.sum;
        let w = settings.width;
        let what = format!("{name} control variate: squares");
        assert_same_samples_reordered("footprints", &what, &special.sum_sq, &generic.sum_sq, counts, w);
        if kernels_round_alike() {
            for (i, ((a, b), sq)) in special.sum.iter().zip(&generic.sum).zip(&generic.sum_sq).enumerate() {
                let n = b[3];
                for c in 0..3 {
                    let bound = n * f32::EPSILON * (n * sq[c]).sqrt() + f32::MIN_POSITIVE;
                    assert!(
                        a[3] == n && (a[c] - b[c]).abs() <= bound,
                        "{name} control variate: pixel {i}: {a:?} against {b:?}"
                    );
                }
            }
        }
    }
}

/// The wavefront kernels (shaders/wavefront.wgsl) take the same samples from the same random
/// streams as the megakernel, only in other kernels, so their images, contribution images, ray
/// and non-finite counts are identical; also when a dispatch is a band of rows (a short dispatch
/// target) and when it runs several rounds (several camera samples).
#[test]
fn wavefront_kernels_render_the_megakernels_image() {
    for (name, scene) in scenes() {
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        for strategy in Strategy::ALL {
            // The second case also chooses lights per point: the direction kernel rebuilds the
            // point's table from the deferred hit. The third samples round lights by their cones,
            // light samples that the direction kernel takes.
            // The last two take one light and one BRDF sample, without loops (AT_MOST_ONE_*).
            for (write_aovs, dispatch_target, light_selection, light_sampling, samples) in [
                (false, Duration::from_secs(1), LightSelection::Power, LightSampling::Area, 2),
                (true, Duration::from_nanos(1), LightSelection::Bsdf, LightSampling::Area, 2),
                (true, Duration::from_nanos(1), LightSelection::Power, LightSampling::Cone, 2),
                (false, Duration::from_secs(1), LightSelection::Bsdf, LightSampling::Area, 1),
                (true, Duration::from_nanos(1), LightSelection::Power, LightSampling::Cone, 1),
            ] {
                let settings = RenderSettings {
                    width: 24,
                    height: 16,
                    spp: 3,
                    strategy,
                    light_samples: samples,
                    brdf_samples: samples,
                    light_selection,
                    light_sampling,
                    write_aovs,
                    dispatch_target,
                    seed: 5,
                    execution: Execution::Megakernel,
                    ..Default::default()
                };
                let mega = render(&gpu_scene, &settings, &camera);
                let wave = render(
                    &gpu_scene,
                    &RenderSettings { execution: Execution::Wavefront, ..settings.clone() },
                    &camera,
                );
                assert!(!mega.kernel.wavefront && wave.kernel.wavefront);
                let what = format!("{name} {strategy:?} {light_selection:?} {light_sampling:?} aovs {write_aovs}");
                assert_same_image("wavefront", &what, &wave.sum, &mega.sum, mega.width);
                assert_same_image("wavefront", &format!("{what}: squares"), &wave.sum_sq, &mega.sum_sq, mega.width);
                assert_same_rays(&what, wave.rays, mega.rays);
                assert_eq!(wave.nonfinite_samples, mega.nonfinite_samples, "{what}");
                assert!(mega.rays > 0, "{what}: no rays");
                if write_aovs {
                    let (a, b) = (wave.contributions.unwrap(), mega.contributions.unwrap());
                    assert_same_contributions("wavefront", &what, &a, &b, mega.width);
                }
                // The generic kernel (strategy read at run time) split the same way.
                if !write_aovs {
                    let generic = RenderSettings { specialise: false, execution: Execution::Wavefront, ..settings };
                    let generic = render(&gpu_scene, &generic, &camera);
                    assert!(generic.kernel.wavefront && generic.kernel.strategy.is_none());
                    assert_same_image(
                        "wavefront",
                        &format!("{what}: generic wavefront"),
                        &generic.sum,
                        &mega.sum,
                        mega.width,
                    );
                }
            }
        }
    }
}

/// The stress scenes small enough to be compiled into the kernel (coordinates near f32's limits,
/// a box 10^5 away, degenerate triangles, a camera inside a box, lights touching and grazing
/// surfaces) render the image their BVH renders, bit for bit: each ray meets the same triangles
/// in the same watertight test, only in another order (ties would pick another triangle at the
/// same distance; none of these scenes has one). MIS 1 + 1, so that camera, shadow and BRDF rays
/// all go through both traversals. The boxed variant also has its direction samples search the
/// emitters' list and trace a shadow ray to what they find (`BakedTriangles::emitter_list`, what
/// Mesa 25 gets), in the megakernel and in the wavefront's direction kernel, and its camera rays
/// test the triangles by their edge planes through the eye (`BakedTriangles::set_camera_eye`; the
/// two tests could pick different triangles for a ray within rounding of an edge, which none of
/// these renders has): the same image.
#[test]
fn triangles_compiled_into_the_kernel_render_the_bvhs_image() {
    let cpu = renderer().gpu.adapter_info.device_type == wgpu::DeviceType::Cpu;
    let (mut baked_scenes, mut boxed_scenes, mut listed_scenes, mut camera_scenes) = (0, 0, 0, 0);
    let stress = veach_scenes::stress::STRESS_SCENES
        .iter()
        .map(|&name| (name, load(&veach_scenes::stress::stress_scene(name).unwrap(), &format!("baked-{name}"))));
    for (name, scene) in stress.chain([("cornell-box", shipped_scene("cornell-box"))]) {
        if scene.triangles.len() > BAKED_TRIANGLES_MAX {
            continue;
        }
        let camera = scene.camera(None).unwrap();
        let settings = RenderSettings {
            width: 48,
            height: 32,
            spp: 4,
            strategy: Strategy::Mis,
            light_samples: 1,
            brdf_samples: 1,
            seed: 3,
            ..Default::default()
        };
        let bvh_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::Storage).unwrap();
        let bvh = render(&bvh_scene, &settings, &camera);
        assert!(bvh.kernel.driver.baked.is_none(), "{name}");
        // As the driver picks (Mesa 22.3: no boxes), then with compact groups behind boxes.
        let boxed_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::AutoWithBoxes).unwrap();
        let boxed_wavefront = RenderSettings { execution: Execution::Wavefront, ..settings.clone() };
        for (kind, gpu_scene, settings) in [
            ("baked", &upload(&scene), &settings),
            ("baked-boxed", &boxed_scene, &settings),
            ("baked-boxed-wavefront", &boxed_scene, &boxed_wavefront),
        ] {
            let baked = render(gpu_scene, settings, &camera);
            assert_eq!(baked.kernel.driver.baked.is_some(), cpu, "{name}");
            baked_scenes += baked.kernel.driver.baked.is_some() as u32;
            boxed_scenes += baked.kernel.driver.baked.as_ref().is_some_and(|b| b.boxed_groups() > 0) as u32;
            listed_scenes += baked.kernel.driver.baked.as_ref().is_some_and(|b| b.emitter_list()) as u32;
            camera_scenes += baked.kernel.driver.baked.as_ref().is_some_and(|b| b.camera_eye().is_some()) as u32;
            if baked.sum != bvh.sum {
                let dir = output_dir("baked-triangles");
                for (out, kind) in [(&baked, kind), (&bvh, "bvh")] {
                    let path = dir.join(format!("{name}-{kind}.exr"));
                    veach::image_io::write_image(&path, out.width, out.height, &out.mean(), 0.0).unwrap();
                }
                panic!("{name}: the {kind} triangles' image differs from the BVH's (both in {})", dir.display());
            }
        }
    }
    if cpu {
        assert!(baked_scenes >= 15, "only {} scenes were baked", baked_scenes / 3);
        assert!(boxed_scenes >= 2, "only {boxed_scenes} scenes had groups behind boxes");
        assert!(listed_scenes >= 10, "only {} scenes searched the emitters' list", listed_scenes / 2);
        assert!(camera_scenes >= 10, "only {} scenes traced camera rays by edge planes", camera_scenes / 2);
    }
}

/// Camera rays through a baked kernel's camera list (`trace_camera`: each triangle by its edge
/// planes through the eye, `BakedTriangles::set_camera_eye`) find what the watertight closest-hit
/// list finds from the same eye, on the Cornell box and every stress scene that bakes: rays
/// through a 64 × 64 grid of jittered points of the view miss in both or find the same triangle
/// with the same t and barycentrics bit for bit (a ray within rounding of an edge could pick its neighbour, at the
/// same t: allowed, none seen); and rays aimed along every edge two coplanar triangles share (at a
/// quarter, half and three quarters of it, where the two triangles' tests meet) find that surface
/// in both lists, at the same t within 1e-5: the planes of a shared edge are exact negatives of
/// each other, so no ray slips between its two triangles.
#[test]
fn camera_rays_by_edge_planes_find_the_closest_hit_lists_hits() {
    use veach::gpu::layout::{FrameParams, TestParams};
    use veach::gpu::test_kernel::{TestKernel, routine};
    if renderer().gpu.adapter_info.device_type != wgpu::DeviceType::Cpu {
        return; // triangles are baked on CPU adapters only
    }
    let stress = veach_scenes::stress::STRESS_SCENES
        .iter()
        .map(|&name| (name, load(&veach_scenes::stress::stress_scene(name).unwrap(), &format!("camera-{name}"))));
    let mut tested = 0;
    for (name, scene) in stress.chain([("cornell-box", shipped_scene("cornell-box"))]) {
        if scene.triangles.len() > BAKED_TRIANGLES_MAX {
            continue;
        }
        let gpu_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::AutoWithBoxes).unwrap();
        let kernel = TestKernel::for_baked_scene(renderer(), &gpu_scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        let camera = scene.camera(None).unwrap();
        let gpu_camera = camera.to_gpu(64, 64);
        let [forward, right, up] = [gpu_camera.forward, gpu_camera.right, gpu_camera.up].map(Vec3::from_array);
        let frame = FrameParams { camera: gpu_camera, ..Default::default() };
        // A fixed jitter per grid cell (a 32-bit LCG: any points in the cells would do).
        let mut state = 0x2545_f491u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / 16_777_216.0
        };
        let mut grid = Vec::new();
        for j in 0..64 {
            for i in 0..64 {
                let sx = 2.0 * (i as f32 + next()) / 64.0 - 1.0;
                let sy = 1.0 - 2.0 * (j as f32 + next()) / 64.0;
                grid.push((forward + sx * right + sy * up).normalize());
            }
        }
        let mut along_edges = Vec::new();
        for (k, a) in scene.triangles.iter().enumerate() {
            for b in &scene.triangles[k + 1..] {
                let shared: Vec<Vec3> = a.p.iter().copied().filter(|p| b.p.contains(p)).collect();
                let normal = |t: &veach::scene::Triangle| (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
                let (na, nb) = (normal(a), normal(b));
                if shared.len() == 2 && na.cross(nb).length() <= 1e-6 * na.length() * nb.length() {
                    for f in [0.25, 0.5, 0.75] {
                        let d = (shared[0].lerp(shared[1], f) - camera.position).normalize();
                        if d.dot(camera.forward) > 0.0 {
                            along_edges.push(d);
                        }
                    }
                }
            }
        }
        let input: Vec<[f32; 4]> = grid.iter().chain(&along_edges).map(|d| [d.x, d.y, d.z, 0.0]).collect();
        let params = TestParams { routine: routine::TRACE_CAMERA, count: input.len() as u32, ..Default::default() };
        let out = kernel.run(&gpu_scene, &frame, &params, &input, 2).unwrap();
        let mut wrong = Vec::new();
        for (k, pair) in out.chunks(2).enumerate() {
            let (camera_hit, closest) = (pair[0], pair[1]);
            let same_t = (camera_hit[0] - closest[0]).abs() <= 1e-5 * closest[0].abs();
            let ok = if k < grid.len() {
                let both_miss = camera_hit[0] < 0.0 && closest[0] < 0.0;
                both_miss || camera_hit == closest || (camera_hit[1] != closest[1] && closest[0] > 0.0 && same_t)
            } else {
                closest[0] > 0.0 && camera_hit[0] > 0.0 && same_t
            };
            if !ok {
                let kind = if k < grid.len() { "grid" } else { "shared edge" };
                wrong.push(format!("{kind} ray {:?}: camera list {camera_hit:?}, closest {closest:?}", input[k]));
            }
        }
        assert!(wrong.is_empty(), "{name}: {} of {} rays:\n{}", wrong.len(), input.len(), wrong.join("\n"));
        tested += 1;
    }
    assert!(tested >= 5, "only {tested} scenes were baked");
}

#[test]
fn kernels_are_cached_per_feature_set_and_strategy() {
    let scene = shipped_scene("cornell-box");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let settings = |strategy| RenderSettings { width: 8, height: 8, spp: 1, strategy, seed: 1, ..Default::default() };
    // Compile both kernels, then switch back and forth: nothing is compiled again.
    render(&gpu_scene, &settings(Strategy::Light), &camera);
    render(&gpu_scene, &settings(Strategy::Mis), &camera);
    for strategy in [Strategy::Light, Strategy::Mis, Strategy::Light] {
        let out = render(&gpu_scene, &settings(strategy), &camera);
        assert_eq!(out.kernel_creation, Duration::ZERO, "{strategy:?} was compiled again");
    }
    assert_eq!(
        gpu_scene.features.describe(),
        "area lights, parallelogram lights, rectangle lights, one light, all diffuse"
    );
}

/// Shadow rays of a kernel with baked triangles leave out the triangles that no shadow ray can
/// meet, judged from where the scene's geometry and lights lie (BakedTriangles::mark_blockers):
/// a wall with every triangle of the scene on one side of it still blocks a point light or a
/// directional light on the other. The floor behind it stays dark, as it does with the BVH.
#[test]
fn a_wall_at_the_edge_of_the_scene_shadows_a_delta_light_beyond_it() {
    for (name, kind, position) in [
        ("point", Punctual::Point, Vec3::new(-1.0, 1.0, 0.0)),
        ("directional", Punctual::Directional, Vec3::new(-1.0, 2.0, 0.0)),
    ] {
        let mut g = GltfBuilder::new();
        let grey = g.material(&MaterialDesc::lambert("grey", Vec3::splat(0.5)));
        let floor = MeshData::quad(
            Vec3::new(0., 0., -2.),
            Vec3::new(2., 0., -2.),
            Vec3::new(2., 0., 2.),
            Vec3::new(0., 0., 2.),
            Vec3::Y,
        );
        let wall = MeshData::quad(
            Vec3::new(0., 0., -2.),
            Vec3::new(0., 3., -2.),
            Vec3::new(0., 3., 2.),
            Vec3::new(0., 0., 2.),
            Vec3::X,
        );
        g.add_mesh("floor", &floor, grey, Mat4::IDENTITY);
        g.add_mesh("wall", &wall, grey, Mat4::IDENTITY);
        // Aimed at the floor beyond the wall: a directional light travels along position -> target.
        g.punctual_light("light", kind, Vec3::splat(5.0), position, Vec3::new(1.0, 0.0, 0.0));
        g.camera("camera", Vec3::new(1.0, 4.0, 0.5), Vec3::new(1.0, 0.0, 0.0), 60.0);
        let scene = load(&g, &format!("wall-{name}"));
        let camera = scene.camera(None).unwrap();
        let settings = RenderSettings {
            width: 16,
            height: 16,
            spp: 2,
            strategy: Strategy::Light,
            light_samples: 1,
            hide_emitters: true,
            ..Default::default()
        };
        let baked = render(&upload(&scene), &settings, &camera);
        let bvh_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::Storage).unwrap();
        let bvh = render(&bvh_scene, &settings, &camera);
        let lit = |out: &veach::RenderOutput| out.mean().iter().filter(|p| p.iter().any(|&v| v > 0.0)).count();
        assert_eq!(lit(&bvh), 0, "{name}: the wall does not shadow the floor even with the BVH");
        assert_eq!(lit(&baked), 0, "{name}: the floor behind the wall is lit with baked triangles");
    }
}

/// Scene arrays are read from `rgba32uint` storage textures on CPU adapters
/// (`SceneArrayMemory::texels`; Mesa 22.3 loads storage lane by lane): the same image, bit for
/// bit, as from storage buffers, since each reader returns the same words. 5,000 triangle lights
/// among 12,000 triangles over a floor, so that every array has rows of texels to get wrong: the
/// BVH, vertices, triangles, lights, emitter triangles, light picks, the light tree and the
/// triangles' lights; MIS 1 + 1 with lights chosen by the tree.
#[test]
fn scene_arrays_render_alike_from_textures_and_from_storage() {
    let cpu = renderer().gpu.adapter_info.device_type == wgpu::DeviceType::Cpu;
    let scene = load(&veach_scenes::scale_scenes::light_scene(5000, 12000), "texel-arrays");
    let camera = scene.camera(None).unwrap();
    let settings = RenderSettings {
        width: 32,
        height: 24,
        spp: 2,
        strategy: Strategy::Mis,
        light_samples: 1,
        brdf_samples: 1,
        light_selection: LightSelection::Tree,
        seed: 3,
        ..Default::default()
    };
    let storage =
        render(&renderer().upload_scene_with(&scene, veach::render::BvhMemory::Storage).unwrap(), &settings, &camera);
    let auto = render(&upload(&scene), &settings, &camera);
    assert!(!storage.kernel.driver.arrays.texels);
    assert_eq!(auto.kernel.driver.arrays.texels, cpu, "a CPU adapter reads the arrays from textures");
    assert!(storage.sum.iter().any(|p| p[0] > 0.0), "the scene renders black");
    assert_same_image("texel-arrays", "textures against storage", &auto.sum, &storage.sum, settings.width);
}

/// With the control variate (shaders/control_variate.wgsl) every kernel still renders the same
/// image, bit for bit: the generic kernel, the specialised megakernel and wavefront, over the BVH,
/// the baked triangles and the emitters' list (baked, boxed), for every strategy that takes it. Its
/// terms depend on the shading point and the lights only, and are added in the same order.
#[test]
fn every_kernel_renders_the_same_image_with_the_control_variate() {
    let stress = ["touching-light", "grazing-light"]
        .map(|name| (name, load(&veach_scenes::stress::stress_scene(name).unwrap(), &format!("cv-{name}"))));
    for (name, scene) in stress.into_iter().chain([("cornell-box", shipped_scene("cornell-box"))]) {
        let camera = scene.camera(None).unwrap();
        let bvh_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::Storage).unwrap();
        let boxed_scene = renderer().upload_scene_with(&scene, veach::render::BvhMemory::AutoWithBoxes).unwrap();
        let auto_scene = upload(&scene);
        // Two samples of each kind through the loops, one without them (AT_MOST_ONE_*).
        for (strategy, samples) in [Strategy::Uniform, Strategy::Brdf, Strategy::Light, Strategy::Mis]
            .into_iter()
            .flat_map(|s| [(s, 2), (s, 1)])
        {
            let settings = RenderSettings {
                width: 24,
                height: 16,
                spp: 3,
                strategy,
                light_samples: samples,
                brdf_samples: samples,
                light_selection: LightSelection::Bsdf,
                control_variate: true,
                seed: 4,
                execution: Execution::Megakernel,
                ..Default::default()
            };
            let wavefront = RenderSettings { execution: Execution::Wavefront, ..settings.clone() };
            let generic = RenderSettings { specialise: false, ..settings.clone() };
            let first = render(&bvh_scene, &settings, &camera);
            assert!(first.kernel.techniques.control_variate && !generic.specialise);
            for (kind, gpu_scene, s) in [
                ("generic", &bvh_scene, &generic),
                ("bvh-wavefront", &bvh_scene, &wavefront),
                ("baked", &auto_scene, &settings),
                ("baked-wavefront", &auto_scene, &wavefront),
                ("baked-boxed", &boxed_scene, &settings),
                ("baked-boxed-wavefront", &boxed_scene, &wavefront),
            ] {
                let out = render(gpu_scene, s, &camera);
                assert_same_image(
                    "control-variate",
                    &format!("{name} {strategy:?} {kind}"),
                    &out.sum,
                    &first.sum,
                    out.width,
                );
            }
        }
    }
}

/// The render kernels' workgroup (`GpuContext::render_workgroup`, which `VEACH_WORKGROUP` sets)
/// only groups pixels into threads: any size renders the same image, bit for bit, with either
/// execution. 5×3 and 16×4 leave partial workgroups at the image's right edge and below each band
/// of rows (a 1 ns dispatch target renders the image a few rows at a time).
#[test]
fn any_workgroup_size_renders_the_same_image() {
    for (name, scene) in [("cornell-box", shipped_scene("cornell-box")), ("veach-mis", shipped_scene("veach-mis"))] {
        let camera = scene.camera(None).unwrap();
        let gpu_scene = upload(&scene);
        for execution in [Execution::Megakernel, Execution::Wavefront] {
            for dispatch_target in [Duration::from_secs(1), Duration::from_nanos(1)] {
                let settings = RenderSettings {
                    width: 37,
                    height: 23,
                    spp: 2,
                    strategy: Strategy::Mis,
                    light_samples: 1,
                    brdf_samples: 1,
                    light_selection: LightSelection::Power,
                    dispatch_target,
                    seed: 9,
                    execution,
                    ..Default::default()
                };
                let default = render(&gpu_scene, &settings, &camera);
                for workgroup in [(5, 3), (16, 4)] {
                    let gpu = veach::GpuContext { workgroup_override: Some(workgroup), ..renderer().gpu.clone() };
                    let other = veach::Renderer::new(gpu).unwrap();
                    let out = other.render(&gpu_scene, &settings, &camera, &mut |_| true).unwrap();
                    let what = format!("{name} {execution:?} {workgroup:?} target {dispatch_target:?}");
                    assert_same_image("workgroup", &what, &out.sum, &default.sum, settings.width);
                    assert_same_rays(&what, out.rays, default.rays);
                    assert!(default.rays > 0, "{what}: no rays");
                }
            }
        }
    }
}

/// The rule `assert_same_image` applies where a GPU's kernels round differently, on made-up
/// images: differences of f32 rounding pass, a sample's worth in 1% of the pixels passes, more
/// does not, nor does a single non-finite value.
#[test]
fn image_agreement_allows_rounding_and_one_percent_of_pixels() {
    let base: Vec<[f32; 4]> = (0..384).map(|i| [0.1 + i as f32 * 1e-3, 0.5, 2.0, 3.0]).collect();
    let with = |changes: &[(usize, [f32; 4])]| {
        let mut img = base.clone();
        for &(i, p) in changes {
            img[i] = p;
        }
        ImageAgreement::of(&base, &img)
    };
    let same = with(&[]);
    assert!(same.differ == 0 && same.within_rounding());
    // A few ulps in every channel of many pixels.
    let rounded: Vec<(usize, [f32; 4])> = (0..200).map(|i| (i, base[i].map(|v| v * (1.0 + 3e-7)))).collect();
    let r = with(&rounded);
    assert!(r.differ > 100 && r.far == 0 && r.within_rounding(), "{r:?}");
    // A sample's worth (or one sample more) in 3 of 384 pixels: allowed; in 4: not.
    let moved = |n: usize| (0..n).map(|i| (10 * i, [0.9, 0.5, 2.0, 4.0])).collect::<Vec<_>>();
    assert!(with(&moved(3)).within_rounding());
    assert!(!with(&moved(4)).within_rounding());
    assert!(!with(&[(0, [f32::NAN, 0.5, 2.0, 3.0])]).within_rounding());
    assert!(!with(&[(5, [0.1, 0.5, 2.0, f32::INFINITY])]).within_rounding());
}

/// A room of 48 triangles (floor, back wall, three boxes, one of them glossy metal) under four
/// small one-sided quad lights whose radiances span four decades (1, 20, 300, 5000): small enough
/// to be compiled into the kernel, with several lights for every light selection to choose among.
fn four_light_room() -> veach::Scene {
    let mut g = GltfBuilder::new();
    let matte = g.material(&MaterialDesc::lambert("matte", Vec3::splat(0.6)));
    let metal = g.material(&MaterialDesc::metal("metal", Vec3::new(0.9, 0.7, 0.4), 0.2));
    let floor = MeshData::quad(
        Vec3::new(-3., 0., -3.),
        Vec3::new(3., 0., -3.),
        Vec3::new(3., 0., 3.),
        Vec3::new(-3., 0., 3.),
        Vec3::Y,
    );
    g.add_mesh("floor", &floor, matte, Mat4::IDENTITY);
    let wall = MeshData::quad(
        Vec3::new(-3., 0., -3.),
        Vec3::new(3., 0., -3.),
        Vec3::new(3., 3., -3.),
        Vec3::new(-3., 3., -3.),
        Vec3::Z,
    );
    g.add_mesh("wall", &wall, matte, Mat4::IDENTITY);
    let square = |x: f32, z: f32, r: f32| {
        [
            Vec3::new(x - r, 0., z - r),
            Vec3::new(x + r, 0., z - r),
            Vec3::new(x + r, 0., z + r),
            Vec3::new(x - r, 0., z + r),
        ]
    };
    g.add_mesh("box a", &MeshData::prism(square(-1.2, -0.5, 0.4), 0.9), matte, Mat4::IDENTITY);
    g.add_mesh("box b", &MeshData::prism(square(0.9, -1.0, 0.5), 1.4), metal, Mat4::IDENTITY);
    g.add_mesh("box c", &MeshData::prism(square(0.2, 0.8, 0.3), 0.5), matte, Mat4::IDENTITY);
    for (i, (radiance, x, z, y)) in
        [(1.0, -2.0, -1.5, 2.2), (20.0, 1.8, 0.5, 2.0), (300.0, -0.3, 1.2, 2.5), (5000.0, 0.5, -2.0, 1.8)]
            .into_iter()
            .enumerate()
    {
        let e = g.material(&MaterialDesc::emitter(&format!("light {i}"), Vec3::splat(radiance)));
        let r = 0.15;
        let q = MeshData::quad(
            Vec3::new(x - r, y, z - r),
            Vec3::new(x + r, y, z - r),
            Vec3::new(x + r, y, z + r),
            Vec3::new(x - r, y, z + r),
            -Vec3::Y,
        );
        g.add_mesh(&format!("light {i}"), &q, e, Mat4::IDENTITY);
    }
    g.camera("camera", Vec3::new(0.0, 2.2, 5.0), Vec3::new(0.0, 0.7, 0.0), 55.0);
    load(&g, "specialise-four-lights")
}

/// Specialised = generic on a scene of several lights, for every light selection and on every
/// execution path the driver offers: the megakernel's loop, its straight-line sample, camera
/// footprint lists with deferred direction rays (several camera samples per run), the wavefront.
/// A path that holds a direction ray across camera samples must not weigh it by a later sample's
/// light-selection table (`--light-selection bsdf` chooses per shading point): that bias showed
/// here as a different image.
#[test]
fn several_lights_render_the_generic_image_with_every_selection_and_path() {
    let scene = four_light_room();
    assert_eq!(scene.triangles.len(), 48);
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let mut deferred_selections = Vec::new();
    // Footprint lists need pixels small enough that each sees at most 8 triangles: 128 x 96 here.
    for (execution, width, height) in
        [(Execution::Auto, 128, 96), (Execution::Megakernel, 40, 30), (Execution::Wavefront, 40, 30)]
    {
        for light_selection in LightSelection::ALL {
            for (strategy, n, m) in [(Strategy::Mis, 1, 1), (Strategy::Mis, 2, 3), (Strategy::Light, 1, 0)] {
                let settings = RenderSettings {
                    width,
                    height,
                    spp: 8,
                    strategy,
                    light_samples: n,
                    brdf_samples: m,
                    light_selection,
                    execution,
                    seed: 11,
                    ..Default::default()
                };
                let special = render(&gpu_scene, &settings, &camera);
                let generic = render(&gpu_scene, &RenderSettings { specialise: false, ..settings.clone() }, &camera);
                let what = format!("{execution:?} {strategy:?} {n} + {m} {light_selection:?}");
                if special.kernel.driver.deferred_direction_rays {
                    deferred_selections.push(light_selection);
                }
                let w = settings.width;
                assert_same_samples_reordered("several-lights", &what, &special.sum, &generic.sum, &generic.sum, w);
                let squares = format!("{what}: squares");
                assert_same_samples_reordered(
                    "several-lights",
                    &squares,
                    &special.sum_sq,
                    &generic.sum_sq,
                    &generic.sum,
                    w,
                );
                assert_same_rays(&what, special.rays, generic.rays);
            }
        }
    }
    // Where the driver takes deferred direction rays (Mesa 22.3), they were compared above.
    let masked = veach::kernel_plan::AutoExecution::for_adapter(&renderer().gpu.adapter_info)
        == veach::kernel_plan::AutoExecution::WavefrontWhereMasked;
    assert_eq!(!deferred_selections.is_empty(), masked, "deferred kernels with {deferred_selections:?}");
}

/// The wavefront's queue keeps a camera sample's light and direction sample counts at their full
/// width (each up to 2^20, settings.rs): with 65,537 BRDF samples it weighs them as the
/// megakernel does, where counts packed in 16 bits would have read 1. Mesa 22's lavapipe cannot
/// run so many samples in one invocation (its loop limit, 65,535 iterations); there both must
/// refuse with that reason instead of writing an image.
#[test]
fn the_wavefront_weighs_more_than_65535_samples_as_the_megakernel() {
    let scene = shipped_scene("cornell-box");
    let camera = scene.camera(None).unwrap();
    let gpu_scene = upload(&scene);
    let settings = RenderSettings {
        width: 3,
        height: 2,
        spp: 1,
        strategy: Strategy::Mis,
        light_samples: 2,
        brdf_samples: 65_537,
        seed: 3,
        execution: Execution::Megakernel,
        ..Default::default()
    };
    let wave_settings = RenderSettings { execution: Execution::Wavefront, ..settings.clone() };
    let results = [&settings, &wave_settings].map(|s| renderer().render(&gpu_scene, s, &camera, &mut |_| true));
    match results {
        [Ok(mega), Ok(wave)] => {
            assert!(wave.kernel.wavefront && !mega.kernel.wavefront);
            assert_same_image("wide-counts", "65,537 BRDF samples", &wave.sum, &mega.sum, settings.width);
            assert_same_rays("65,537 BRDF samples", wave.rays, mega.rays);
        }
        [mega, wave] => {
            let masked = veach::kernel_plan::AutoExecution::for_adapter(&renderer().gpu.adapter_info)
                == veach::kernel_plan::AutoExecution::WavefrontWhereMasked;
            for (name, r) in [("megakernel", mega), ("wavefront", wave)] {
                let e = r.err().map(|e| e.to_string()).unwrap_or_default();
                assert!(masked && e.contains("more loop iterations than this driver allows"), "{name}: {e}");
            }
        }
    }
}

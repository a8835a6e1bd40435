//! The kernel plan: everything a render's kernel is, decided in one place. `KernelPlan::for_render`
//! is a function of the scene (its features and what its upload chose), the render's settings, its
//! camera and rows, and the adapter; nothing changes the plan after it. The plan is the kernel
//! cache's key, sets the WGSL `override` constants (`shaders/features.wgsl`) and says how the
//! plan-dependent bindings are declared (`gpu::bindings::DeclaredBindings`).
//!
//! Its axes: the strategy, the scene's light kinds and lobes, the light techniques, the texture
//! lookups, the contribution images, the sample counts' shape, the scheduler (megakernel or
//! wavefront), the traversal's stack, and one group of driver tuning (`DriverTuning`), which only
//! changes speed, never the image beyond the order of a sum.

use crate::features::{SceneArrayMemory, SceneFeatures};
use crate::gpu::baked_triangles::BakedTriangles;
use crate::gpu::camera_footprints::{CameraFootprints, FilmFrame};
use crate::scene::Camera;
use crate::settings::{Execution, LightSampling, LightSelection, RenderSettings, Strategy};
use std::sync::Arc;

/// The plan of one kernel. `KernelPlan::generic()` is the kernel for everything.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct KernelPlan {
    /// A fixed strategy, or None to read it at run time.
    pub strategy: Option<Strategy>,
    /// A fixed light selection, or None to read it at run time. Fixed, the other selections'
    /// code is left out, which Mesa 22.3 would run under a mask (multi-light zoo scenes
    /// 0.95-0.98x the render time; docs/performance.md, "The light selection in the kernel").
    pub light_selection: Option<LightSelection>,
    pub lights: LightKinds,
    pub lobes: Lobes,
    pub techniques: LightTechniques,
    pub textures: TextureLookups,
    /// Contribution images (light-sample and BRDF-sample sums).
    pub aovs: bool,
    pub samples: SampleShape,
    /// The wavefront kernels (shaders/wavefront.wgsl) instead of `render` (megakernel.wgsl).
    pub wavefront: bool,
    /// Entries of the BVH traversal's stack: `gpu::bvh_nodes::BVH_STACK_SIZE`, more for deeper
    /// trees (`GpuScene::bvh_stack`). Every kernel takes its scene's.
    pub bvh_stack: u32,
    pub driver: DriverTuning,
}

/// The kinds of light the kernel has code for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LightKinds {
    pub area: bool,
    pub delta: bool,
    /// The scene has exactly one light (`SceneFeatures::single_light`): read at a constant index.
    pub single: bool,
    /// The light tree's nodes may have lit boxes (`LightTree::lit`): the walk reads them.
    pub lit_boxes: bool,
}

/// The BSDF lobes the kernel has code for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Lobes {
    pub glossy: bool,
    pub mirrors: bool,
}

/// How light samples may be taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LightTechniques {
    /// Emitter triangles by their solid angle (`LightSampling::SolidAngle`).
    pub solid_angle: bool,
    /// Rectangle lights by their solid angle (`LightSampling::spherical_rectangles`).
    pub rectangles: bool,
    /// As directions in round lights' bounding cones (`LightSampling::Cone`).
    pub cone: bool,
    /// As points with shadow rays: false where `cone` takes every light.
    pub shadow_rays: bool,
    /// Mapping the unit square onto a parallelogram light.
    pub parallelograms: bool,
    /// Picking a light's triangle by area: false where `parallelograms` takes every area light.
    pub triangle_picks: bool,
    /// The unshadowed diffuse light as a control variate (`RenderSettings::control_variate`).
    pub control_variate: bool,
}

/// The texture module (shaders/textures.wgsl and its bindings), and its lookups by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureLookups {
    pub module: bool,
    /// Base colour, metallic-roughness, emissive, normal.
    pub kinds: [bool; 4],
}

/// The most samples of each kind a camera sample takes (`at_most_one_sample`): where one at most,
/// the kernel takes them without a loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleShape {
    pub at_most_one_light_request: bool,
    pub at_most_one_direction_sample: bool,
}

/// What a kernel does for the driver's sake: each changes the render time, none the samples
/// (deferred rays sum them in another order). Chosen by the adapter's profile
/// (`AdapterProfile`) and what the scene's upload chose for it; none in the generic kernel but
/// the workgroup and where the arrays are.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct DriverTuning {
    /// Where the scene arrays are read from (`GpuScene` decides: storage textures on CPU
    /// adapters).
    pub arrays: SceneArrayMemory,
    /// Each entry point copies the frame's parameters into a private variable (CPU adapters:
    /// lavapipe loads a storage word lane by lane at every read).
    pub frame_copy: bool,
    /// A small scene's triangles, compiled into the kernel in place of the BVH (`GpuScene`
    /// decides, on CPU adapters).
    pub baked: Option<Arc<BakedTriangles>>,
    /// Camera rays test `baked`'s edge planes through the eye (`BakedTriangles::set_camera_eye`):
    /// the render's camera is at that eye.
    pub camera_list: bool,
    /// Camera rays test their pixel's footprint list of this many triangles (at most
    /// `gpu::camera_footprints::FOOTPRINT_SLOTS_MAX`; 0: none), read once per invocation, for the
    /// megakernel where the driver runs every branch under a mask (Mesa 22.3's lavapipe).
    pub footprint_slots: u32,
    /// With `footprint_slots`: direction rays wait in their invocation and are traced after its
    /// camera samples (deferred_rays.wgsl, take_samples_deferred).
    pub deferred_direction_rays: bool,
    /// A BVH kernel's BRDF samples find emitters in the emitters' grid, then trace a shadow ray to
    /// what they find (`gpu::emitter_grid`; `EMITTER_LIST`), instead of a closest hit over the BVH.
    pub emitter_grid: bool,
    /// The megakernel takes each camera sample in straight-line code, its direction sample's ray
    /// at a call site of its own (`straight_line_sample`).
    pub straight_line_sample: bool,
    /// Threads per workgroup of `render` and `render_light_pass`, as (columns, rows)
    /// (`GpuContext::render_workgroup`).
    pub workgroup: (u32, u32),
}

impl DriverTuning {
    /// No tuning: the generic kernel's, with the default workgroup.
    pub fn none() -> DriverTuning {
        DriverTuning {
            arrays: SceneArrayMemory::default(),
            frame_copy: false,
            baked: None,
            camera_list: false,
            footprint_slots: 0,
            deferred_direction_rays: false,
            emitter_grid: false,
            straight_line_sample: false,
            workgroup: crate::gpu::layout::WORKGROUP_SIZE,
        }
    }
}

/// What a plan needs to know of the scene as its upload left it (`GpuScene::uploaded`).
#[derive(Clone, Copy)]
pub struct UploadedScene<'a> {
    pub features: &'a SceneFeatures,
    /// The traversal stack its BVH needs.
    pub bvh_stack: u32,
    /// Where its arrays are.
    pub arrays: SceneArrayMemory,
    /// Its triangles, where they are compiled into the kernel.
    pub baked: Option<&'a Arc<BakedTriangles>>,
    /// It has an emitters' grid.
    pub emitter_grid: bool,
    /// Its light tree's nodes have lit boxes.
    pub lit_boxes: bool,
}

/// What a plan needs to know of the adapter (`GpuContext::profile`).
#[derive(Clone, Copy, Debug)]
pub struct AdapterProfile {
    pub auto: AutoExecution,
    /// A CPU adapter (lavapipe).
    pub cpu: bool,
    pub storage_buffers_per_stage: u32,
    /// The largest storage buffer binding, in bytes.
    pub max_binding: u64,
    /// `render`'s workgroup, and `render_light_pass`'s.
    pub workgroups: [(u32, u32); 2],
}

/// A plan, and the camera footprint lists it reads (`DriverTuning::footprint_slots`): built with
/// the plan, since their length is compiled in, and counted in the render's time.
pub struct PlannedKernel {
    pub plan: KernelPlan,
    pub footprints: Option<(CameraFootprints, Vec<u32>)>,
}

/// Fewer samples per pixel do not pay for the lists' building (1.2 ms for the Cornell box at
/// 256×256 on 2 cores) and each run's pass of held rays: the Cornell box at 2 spp took 1.35x the
/// time with them, at 4 spp 1.03x, at 8 spp and up 0.79-0.87x (docs/performance.md).
const FOOTPRINT_MIN_SPP: u32 = 8;

/// Scenes of fewer baked triangles keep their closest-hit list for camera rays: it costs less
/// than the lists' slots and the deferred rays' pass save (the textured scene's 8 triangles: 1.06x
/// the time with them, the Cornell box's 36: 0.80x; docs/performance.md).
const FOOTPRINT_MIN_TRIANGLES: usize = 16;

impl KernelPlan {
    pub fn generic() -> KernelPlan {
        KernelPlan {
            strategy: None,
            light_selection: None,
            lights: LightKinds { area: true, delta: true, single: false, lit_boxes: true },
            lobes: Lobes { glossy: true, mirrors: true },
            techniques: LightTechniques {
                solid_angle: true,
                rectangles: true,
                cone: true,
                shadow_rays: true,
                parallelograms: true,
                triangle_picks: true,
                control_variate: true,
            },
            textures: TextureLookups { module: true, kinds: [true; 4] },
            aovs: true,
            samples: SampleShape { at_most_one_light_request: false, at_most_one_direction_sample: false },
            wavefront: false,
            bvh_stack: crate::gpu::bvh_nodes::BVH_STACK_SIZE,
            driver: DriverTuning::none(),
        }
    }

    /// The kernel that renders `rows` of the image `settings` describes: specialised to the scene,
    /// the settings and the adapter, or (with `specialise` off) the generic one, split into the
    /// wavefront only when asked by name. `runs_of_samples`: an invocation takes several camera
    /// samples of its pixel (no time limit), which footprint lists need.
    pub fn for_render(
        scene: UploadedScene,
        settings: &RenderSettings,
        camera: &Camera,
        rows: std::ops::Range<u32>,
        runs_of_samples: bool,
        adapter: &AdapterProfile,
    ) -> PlannedKernel {
        let mut plan = if settings.specialise {
            KernelPlan::specialised(scene.features, settings, adapter.auto)
        } else {
            KernelPlan { wavefront: settings.execution == Execution::Wavefront, ..KernelPlan::generic() }
        };
        // Every kernel, generic or not, takes the stack its scene's BVH needs and reads the
        // scene's arrays where its upload put them (`Renderer::upload_scene`: once, as storage
        // textures on CPU adapters).
        plan.bvh_stack = scene.bvh_stack;
        plan.driver.arrays = scene.arrays;
        if settings.specialise {
            plan.lights.lit_boxes = scene.lit_boxes && plan.light_selection == Some(LightSelection::Tree);
        }
        plan.driver.workgroup = adapter.workgroups[plan.wavefront as usize];
        let mut footprints = None;
        if settings.specialise {
            plan.driver_tuning(scene, camera, adapter);
            footprints = plan.footprints(scene, settings, camera, rows, runs_of_samples, adapter);
        }
        PlannedKernel { plan, footprints }
    }

    /// The kernel specialised to a scene's features and a render's settings, with the driver
    /// tuning that follows from them alone.
    pub fn specialised(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> KernelPlan {
        let parallelograms = features.parallelogram_lights && settings.light_sampling != LightSampling::SolidAngle;
        let (at_most_one_light_request, at_most_one_direction_sample) = at_most_one_sample(features, settings);
        let wavefront = uses_wavefront(features, settings, auto);
        let strategy = effective_strategy(features, settings).0;
        KernelPlan {
            strategy: Some(strategy),
            // A strategy without light samples never chooses a light: uniform, which has no code.
            light_selection: Some(if strategy.samples_lights() {
                settings.light_selection
            } else {
                LightSelection::Uniform
            }),
            lights: LightKinds {
                area: features.area_lights,
                delta: features.delta_lights(),
                single: features.single_light,
                // Known once the scene is uploaded (`for_render`).
                lit_boxes: true,
            },
            lobes: Lobes { glossy: features.any_glossy, mirrors: features.any_mirror },
            techniques: LightTechniques {
                solid_angle: features.area_lights && settings.light_sampling == LightSampling::SolidAngle,
                rectangles: features.rectangle_lights && settings.light_sampling.spherical_rectangles(),
                cone: cone_sampling(features, settings),
                shadow_rays: !(features.all_lights_round && settings.light_sampling.cones()),
                parallelograms,
                triangle_picks: !(parallelograms && features.all_area_lights_parallelograms),
                control_variate: settings.control_variate,
            },
            textures: TextureLookups {
                module: features.textures(),
                kinds: [
                    features.base_color_texture,
                    features.metallic_roughness_texture,
                    features.emissive_texture,
                    features.normal_texture,
                ],
            },
            aovs: settings.write_aovs,
            samples: SampleShape { at_most_one_light_request, at_most_one_direction_sample },
            wavefront,
            bvh_stack: crate::gpu::bvh_nodes::BVH_STACK_SIZE,
            driver: DriverTuning {
                straight_line_sample: !wavefront && straight_line_sample(features, settings, auto),
                ..DriverTuning::none()
            },
        }
    }

    /// The tuning that follows from what the scene's upload chose (array memory, baked
    /// triangles, the emitters' grid) and where the camera is.
    fn driver_tuning(&mut self, scene: UploadedScene, camera: &Camera, adapter: &AdapterProfile) {
        let d = &mut self.driver;
        d.frame_copy = adapter.cpu;
        d.baked = scene.baked.cloned();
        // A BVH kernel's direction samples search the emitters' grid where the scene has one
        // (`Renderer::upload_scene`: where the driver branches and the grid pays), and the device
        // binds that many storage buffers.
        d.emitter_grid = d.baked.is_none()
            && scene.emitter_grid
            && adapter.storage_buffers_per_stage >= crate::gpu::bindings::STORAGE_BUFFERS_WITH_EMITTER_GRID;
        // Camera rays by the edge planes through the eye where this camera is at it: in the
        // wavefront's first kernel, which then has no closest-hit list at all, and in the
        // megakernel where the driver branches around the list its camera pass leaves out (Mesa
        // 22.3 would run both; docs/performance.md, "Camera rays by edge planes").
        let at_eye = scene.baked.is_some_and(|b| b.has_camera_eye(camera.position));
        d.camera_list = at_eye && (self.wavefront || adapter.auto != AutoExecution::WavefrontWhereMasked);
    }

    /// In the megakernel where the driver runs every branch under a mask (Mesa 22.3), camera rays
    /// test only their pixel's footprint list, and direction rays wait for the end of the
    /// invocation's run, so that its camera samples run no closest-hit list at all
    /// (docs/performance.md, "Camera rays by footprint lists"; on Mesa 25, which branches, the
    /// camera list's loop stays faster: 1.05x the time with them). On the zoo at 256x256 they
    /// apply to 3 of its 35 scenes, which take 1.12-1.28x the time without them
    /// (docs/performance.md, "Driver-specific paths on the zoo").
    fn footprints(
        &mut self,
        scene: UploadedScene,
        settings: &RenderSettings,
        camera: &Camera,
        rows: std::ops::Range<u32>,
        runs_of_samples: bool,
        adapter: &AdapterProfile,
    ) -> Option<(CameraFootprints, Vec<u32>)> {
        let baked = scene.baked?;
        let masked = adapter.auto == AutoExecution::WavefrontWhereMasked;
        let apply = runs_of_samples
            && baked.has_camera_eye(camera.position)
            && !self.wavefront
            && masked
            && baked.len() >= FOOTPRINT_MIN_TRIANGLES
            && settings.spp >= FOOTPRINT_MIN_SPP
            && self.strategy.is_some_and(|s| s != Strategy::MisLobes)
            && self.samples.at_most_one_direction_sample
            && !self.techniques.cone
            && !settings.write_aovs;
        if !apply {
            return None;
        }
        let cam = camera.to_gpu(settings.width, settings.height);
        let film = FilmFrame::new(&cam, settings.width, settings.height);
        let (lists, words) =
            baked.camera_footprints(&film, rows).filter(|(_, w)| (w.len() as u64 * 4) <= adapter.max_binding)?;
        self.driver.footprint_slots = lists.slots as u32;
        // A held ray is weighed after later camera samples have shaded other points, so not where
        // lights are chosen by the BSDF per shading point (its MIS weight needs the selection
        // table of its own point; the light tree's needs only the point and normal, which the held
        // ray keeps).
        self.driver.deferred_direction_rays = self.strategy.is_some_and(|s| s != Strategy::Light)
            && (self.lights.single || self.light_selection != Some(LightSelection::Bsdf));
        self.driver.camera_list = false;
        Some((lists, words))
    }

    /// How the plan-dependent bindings are declared (`gpu::bindings::wgsl_declarations`).
    pub fn declared_bindings(&self) -> crate::gpu::bindings::DeclaredBindings {
        crate::gpu::bindings::DeclaredBindings {
            arrays: self.driver.arrays,
            frame_copy: self.driver.frame_copy,
            emitter_grid: self.driver.emitter_grid,
            bvh_stack: self.bvh_stack,
        }
    }

    /// The values of the WGSL `override` constants (`shaders/features.wgsl`).
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        // FROM_FRAME (features.wgsl): the kernel reads the choice from the frame at run time.
        const FROM_FRAME: f64 = 255.0;
        let (t, d) = (&self.techniques, &self.driver);
        let mut constants = vec![
            ("STRATEGY", self.strategy.map_or(FROM_FRAME, |s| s.gpu_code() as f64)),
            ("LIGHT_SELECTION", self.light_selection.map_or(FROM_FRAME, |s| s.gpu_code() as f64)),
            ("HAS_AREA_LIGHTS", flag(self.lights.area)),
            ("HAS_DELTA_LIGHTS", flag(self.lights.delta)),
            ("HAS_GLOSSY", flag(self.lobes.glossy)),
            ("HAS_MIRRORS", flag(self.lobes.mirrors)),
            ("HAS_AOVS", flag(self.aovs)),
            ("SOLID_ANGLE_SAMPLING", flag(t.solid_angle)),
            ("RECTANGLE_SAMPLING", flag(t.rectangles)),
            ("CONE_SAMPLING", flag(t.cone)),
            ("SHADOW_RAY_LIGHTS", flag(t.shadow_rays)),
            ("PARALLELOGRAM_LIGHTS", flag(t.parallelograms)),
            ("TRIANGLE_PICKS", flag(t.triangle_picks)),
            ("SINGLE_LIGHT", flag(self.lights.single)),
            ("LIT_BOXES", flag(self.lights.lit_boxes)),
            ("EMITTER_LIST", flag(d.emitter_grid || d.baked.as_ref().is_some_and(|b| b.emitter_list()))),
            ("CAMERA_LIST", flag(d.camera_list)),
            ("CONTROL_VARIATE", flag(t.control_variate)),
            ("AT_MOST_ONE_LIGHT_REQUEST", flag(self.samples.at_most_one_light_request)),
            ("AT_MOST_ONE_DIRECTION_SAMPLE", flag(self.samples.at_most_one_direction_sample)),
            ("STRAIGHT_LINE_SAMPLE", flag(d.straight_line_sample)),
            ("DEFERRED_DIRECTION_RAYS", flag(d.deferred_direction_rays)),
            ("RENDER_WORKGROUP_WIDTH", d.workgroup.0 as f64),
            ("RENDER_WORKGROUP_HEIGHT", d.workgroup.1 as f64),
        ];
        // These exist only in textures.wgsl.
        if self.textures.module {
            let [base, mr, emissive, normal] = self.textures.kinds;
            constants.push(("HAS_BASE_COLOR_TEXTURE", flag(base)));
            constants.push(("HAS_METALLIC_ROUGHNESS_TEXTURE", flag(mr)));
            constants.push(("HAS_EMISSIVE_TEXTURE", flag(emissive)));
            constants.push(("HAS_NORMAL_TEXTURE", flag(normal)));
        }
        constants
    }
}

/// Whether a camera sample takes at most one light-sample request, and at most one direction
/// sample, by the render's counts: the kernel's plans (sample_plan.wgsl, `sample_plan`) take at
/// most n light samples, or n + m at a mis-lobes point without a lobe to sample, each n of every
/// light with `LightSelection::Each` (one light here), and at most m direction samples.
pub fn at_most_one_sample(features: &SceneFeatures, settings: &RenderSettings) -> (bool, bool) {
    let (strategy, n, m) = effective_strategy(features, settings);
    let (n, m) = match strategy {
        Strategy::Uniform | Strategy::Brdf => (0, m),
        Strategy::Light => (n, 0),
        Strategy::Mis => (n, m),
        Strategy::MisLobes => (n + m, m),
    };
    let lights = if settings.light_selection == LightSelection::Each && !features.single_light { u32::MAX } else { 1 };
    (n.saturating_mul(lights) <= 1, m <= 1)
}

/// The strategy and (light, BRDF) sample counts a render runs: `settings`' own, except that
/// mis-lobes on a scene without glossy lobes is light sampling with n + m light samples (the
/// same estimator, sample for sample), which runs the light kernel (6-8% faster on lavapipe
/// than the lobe code with its glossy branches compiled out).
pub fn effective_strategy(features: &SceneFeatures, settings: &RenderSettings) -> (Strategy, u32, u32) {
    if settings.strategy == Strategy::MisLobes && !features.any_glossy {
        return (Strategy::Light, settings.light_samples + settings.brdf_samples, 0);
    }
    (settings.strategy, settings.light_samples, settings.brdf_samples)
}

/// What `Execution::Auto` picks on an adapter, from its driver (docs/performance.md, "Megakernel
/// against wavefront"; 256×256, 32 spp, the three shipped scenes, medians of 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AutoExecution {
    /// lavapipe from Mesa 22 and older, whose code generator runs both sides of every branch
    /// under a SIMD mask. Where a kernel takes its camera samples in straight-line code
    /// (`straight_line_sample`: light, uniform and brdf with at most one direction sample, and
    /// MIS on textured scenes) the megakernel, which then runs nothing twice (0.70-0.92x the
    /// wavefront's time). Elsewhere the wavefront for light sampling in cones, whose first kernel
    /// leaves out the direction-sample code that the megakernel's loop runs masked at every point
    /// (0.78-0.96x when measured), and on textured scenes for every strategy, where the loop also
    /// runs the camera hit's texture lookups masked on every direction sample's pass (0.75-0.88x;
    /// mis-lobes 0.96-0.99x). On untextured scenes the queue costs more than it saves: uniform,
    /// brdf and mis 1.02-1.46x, mis-lobes 1.04-1.18x (the megakernel 0.85-0.96x its time).
    WavefrontWhereMasked,
    /// NVIDIA's driver (an H200, driver 580; docs/performance.md, "On a GPU"): the wavefront for
    /// MIS (0.52-0.92x the time on the three shipped scenes, each execution with its best
    /// workgroup: the megakernel traces the BRDF samples on part of a warp while the rest wait,
    /// 1.9 G rays/s against the wavefront's 3.1 G/s under `veach scale`'s 10,000 lights; "On the
    /// H200 again"), the megakernel for the other strategies, where the wavefront's rounds cost
    /// more (1.04-1.95x).
    WavefrontForMis,
    /// lavapipe from Mesa 23 on, which branches around code that no lane of a SIMD group runs: the
    /// megakernel, as `Megakernel` (measured on Mesa 25, where the wavefront took 1.01-1.38x the
    /// time in 11 of 12 cases, 0.96x in one).
    MegakernelOnLavapipe,
    /// Every other driver: the megakernel.
    Megakernel,
}

impl AutoExecution {
    pub fn for_adapter(info: &wgpu::AdapterInfo) -> AutoExecution {
        AutoExecution::for_driver(&info.driver, &info.driver_info)
    }

    /// From wgpu's `AdapterInfo::driver` and `driver_info`.
    pub fn for_driver(driver: &str, driver_info: &str) -> AutoExecution {
        if runs_branches_masked(driver, driver_info) {
            AutoExecution::WavefrontWhereMasked
        } else if driver == NVIDIA_DRIVER {
            AutoExecution::WavefrontForMis
        } else if driver == LAVAPIPE_DRIVER && mesa_major(driver_info).is_some() {
            AutoExecution::MegakernelOnLavapipe
        } else {
            AutoExecution::Megakernel
        }
    }
}

/// wgpu's `AdapterInfo::driver` for Mesa's lavapipe.
pub const LAVAPIPE_DRIVER: &str = "llvmpipe";

/// wgpu's `AdapterInfo::driver` for NVIDIA's own driver, which `AutoExecution` and
/// `GpuContext::render_workgroup` choose for (measured on an H200).
pub const NVIDIA_DRIVER: &str = "NVIDIA";

/// Whether the driver runs both sides of every branch under a SIMD mask, whether or not any lane
/// takes it: lavapipe from Mesa 22 and older (wgpu's `AdapterInfo::driver` and `driver_info`).
/// Mesa 25's branches around code that no lane of the 8 runs.
pub fn runs_branches_masked(driver: &str, driver_info: &str) -> bool {
    driver == LAVAPIPE_DRIVER && mesa_major(driver_info).is_some_and(|major| major <= 22)
}

/// 22 from "Mesa 22.3.6 (LLVM 15.0.6)".
fn mesa_major(driver_info: &str) -> Option<u32> {
    let version = driver_info.split("Mesa ").nth(1)?;
    version.split('.').next()?.parse().ok()
}

/// Whether light samples may be directions in round lights' bounding cones (`LightTechniques::cone`).
fn cone_sampling(features: &SceneFeatures, settings: &RenderSettings) -> bool {
    features.round_lights && settings.light_sampling.cones()
}

/// Whether the megakernel takes its camera samples in straight-line code (direct.wgsl,
/// `estimate_radiance_straight`): the camera ray, its hit's shading and at most one direction
/// sample, whose ray is traced at a second closest-hit call site, instead of on a second pass of
/// one loop. Measured on Mesa 22's lavapipe alone (docs/performance.md, "Camera samples in
/// straight-line code"; 256×256, 32 spp, megakernel against megakernel), which runs a loop's whole
/// body on every pass, the camera hit's shading and texture lookups included:
/// - light sampling, 2 samples: 0.81-0.85x the time on the shipped scenes, 0.85-0.95x on
///   `veach scale`'s light grid; uniform and brdf, 1 sample: 0.76-0.83x, textured 0.55-0.57x;
///   MIS 1 + 1 on the textured scene 0.73x;
/// - MIS 1 + 1 on untextured scenes 1.10-1.15x (1.13-1.23x on the one-light grid, 0.89-0.96x on
///   the 10,000-light grid): its kernel would then inline three traversals (camera, direction,
///   shadow), and the second closest hit's step and surface, run under a mask where no lane has a
///   ray, cost more than the second pass saves; mis-lobes 0.97-1.01x. Both keep the loop.
///
/// Other drivers keep the loop (not measured).
pub fn straight_line_sample(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> bool {
    if auto != AutoExecution::WavefrontWhereMasked {
        return false;
    }
    let (_, at_most_one_direction) = at_most_one_sample(features, settings);
    if !at_most_one_direction || cone_sampling(features, settings) {
        return false;
    }
    match effective_strategy(features, settings).0 {
        Strategy::Light | Strategy::Uniform | Strategy::Brdf => true,
        Strategy::Mis => features.textures(),
        Strategy::MisLobes => false,
    }
}

/// Whether a render's kernel is the wavefront (`KernelPlan::wavefront`): the generic kernel's only
/// where asked by name.
pub fn runs_wavefront(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> bool {
    if settings.specialise {
        uses_wavefront(features, settings, auto)
    } else {
        settings.execution == Execution::Wavefront
    }
}

/// Whether a render runs the wavefront kernels: as asked, or as `auto` picks for the adapter.
pub fn uses_wavefront(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> bool {
    match settings.execution {
        Execution::Megakernel => false,
        Execution::Wavefront => true,
        Execution::Auto if matches!(auto, AutoExecution::Megakernel | AutoExecution::MegakernelOnLavapipe) => false,
        Execution::Auto if auto == AutoExecution::WavefrontForMis => {
            effective_strategy(features, settings).0 == Strategy::Mis
        }
        // The straight-line megakernel took 0.75-0.93x the wavefront's time where it applies.
        Execution::Auto if straight_line_sample(features, settings, auto) => false,
        // Light sampling gets here only with cone samples (more than one direction sample).
        // mis-lobes on untextured scenes: the megakernel's loop took 0.85-0.96x the wavefront's time.
        Execution::Auto => match effective_strategy(features, settings).0 {
            Strategy::Light => true,
            Strategy::Uniform | Strategy::Brdf | Strategy::Mis | Strategy::MisLobes => features.textures(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::{AutoExecution, KernelPlan, SceneFeatures, at_most_one_sample, straight_line_sample, uses_wavefront};
    use crate::settings::{LightSelection, RenderSettings, Strategy};

    /// The flags must bound every plan the kernel makes: a flag set where a point could take two
    /// samples would drop the second.
    #[test]
    fn at_most_one_sample_only_where_no_plan_takes_two() {
        let glossy = SceneFeatures { any_glossy: true, ..SceneFeatures::default() };
        let one_light = SceneFeatures { single_light: true, ..glossy };
        let at = |features: &SceneFeatures, strategy, n, m, light_selection| {
            let settings =
                RenderSettings { strategy, light_samples: n, brdf_samples: m, light_selection, ..Default::default() };
            at_most_one_sample(features, &settings)
        };
        let power = LightSelection::Power;
        assert_eq!(at(&glossy, Strategy::Mis, 1, 1, power), (true, true));
        assert_eq!(at(&glossy, Strategy::Mis, 2, 1, power), (false, true));
        assert_eq!(at(&glossy, Strategy::Mis, 1, 2, power), (true, false));
        assert_eq!(at(&glossy, Strategy::Light, 1, 0, LightSelection::Bsdf), (true, true));
        assert_eq!(at(&glossy, Strategy::Brdf, 0, 1, power), (true, true));
        assert_eq!(at(&glossy, Strategy::Uniform, 0, 3, power), (true, false));
        // n of every light: one light only where the scene has one.
        assert_eq!(at(&glossy, Strategy::Mis, 1, 1, LightSelection::Each), (false, true));
        assert_eq!(at(&one_light, Strategy::Mis, 1, 1, LightSelection::Each), (true, true));
        // A mis-lobes point without a lobe to sample takes n + m light samples.
        assert_eq!(at(&glossy, Strategy::MisLobes, 1, 1, power), (false, true));
        assert_eq!(at(&glossy, Strategy::MisLobes, 1, 0, power), (true, true));
        let diffuse = SceneFeatures { any_glossy: false, ..SceneFeatures::default() };
        assert_eq!(at(&diffuse, Strategy::MisLobes, 1, 1, power), (false, true));
    }

    /// A render's settings with lights chosen by power.
    fn power_settings(strategy: Strategy, light_samples: u32, brdf_samples: u32) -> RenderSettings {
        RenderSettings {
            strategy,
            light_samples,
            brdf_samples,
            light_selection: LightSelection::Power,
            ..Default::default()
        }
    }

    /// Straight-line samples only where they were measured to pay: on Mesa 22's lavapipe, for
    /// light, uniform and brdf kernels with at most one direction sample, and MIS on textured
    /// scenes; `auto` then runs the megakernel there, and a wavefront asked for by name keeps its
    /// own kernels.
    #[test]
    fn straight_line_samples_only_where_measured_to_pay() {
        use crate::settings::{Execution, LightSampling};
        let masked = AutoExecution::WavefrontWhereMasked;
        let plain = SceneFeatures { area_lights: true, any_glossy: true, ..SceneFeatures::default() };
        let textured = SceneFeatures { base_color_texture: true, ..plain };
        let round = SceneFeatures { round_lights: true, ..plain };
        let s = power_settings;
        assert!(straight_line_sample(&plain, &s(Strategy::Light, 2, 0), masked));
        assert!(straight_line_sample(&plain, &s(Strategy::Uniform, 0, 1), masked));
        assert!(straight_line_sample(&plain, &s(Strategy::Brdf, 0, 1), masked));
        assert!(!straight_line_sample(&plain, &s(Strategy::Brdf, 0, 2), masked));
        assert!(!straight_line_sample(&plain, &s(Strategy::Mis, 1, 1), masked));
        assert!(straight_line_sample(&textured, &s(Strategy::Mis, 1, 1), masked));
        assert!(!straight_line_sample(&plain, &s(Strategy::MisLobes, 1, 1), masked));
        let cone = RenderSettings { light_sampling: LightSampling::Cone, ..s(Strategy::Light, 2, 0) };
        assert!(!straight_line_sample(&round, &cone, masked));
        for other in [AutoExecution::Megakernel, AutoExecution::MegakernelOnLavapipe, AutoExecution::WavefrontForMis] {
            assert!(!straight_line_sample(&textured, &s(Strategy::Light, 2, 0), other));
        }
        assert!(!uses_wavefront(&plain, &s(Strategy::Light, 2, 0), masked));
        assert!(!uses_wavefront(&textured, &s(Strategy::Mis, 1, 1), masked));
        assert!(!uses_wavefront(&plain, &s(Strategy::MisLobes, 1, 1), masked));
        assert!(uses_wavefront(&textured, &s(Strategy::MisLobes, 1, 1), masked));
        assert!(uses_wavefront(&round, &cone, masked));
        let key = KernelPlan::specialised(&plain, &s(Strategy::Light, 2, 0), masked);
        assert!(key.driver.straight_line_sample && !key.wavefront);
        let wavefront = RenderSettings { execution: Execution::Wavefront, ..s(Strategy::Light, 2, 0) };
        let key = KernelPlan::specialised(&plain, &wavefront, masked);
        assert!(!key.driver.straight_line_sample && key.wavefront);
        assert!(!KernelPlan::generic().driver.straight_line_sample);
    }

    #[test]
    fn auto_execution_follows_the_driver() {
        // The strings wgpu reports for lavapipe on Debian 12 and from bookworm-backports.
        assert_eq!(
            AutoExecution::for_driver("llvmpipe", "Mesa 22.3.6 (LLVM 15.0.6)"),
            AutoExecution::WavefrontWhereMasked
        );
        assert_eq!(
            AutoExecution::for_driver("llvmpipe", "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"),
            AutoExecution::MegakernelOnLavapipe
        );
        assert_eq!(AutoExecution::for_driver("NVIDIA", "580.159.04"), AutoExecution::WavefrontForMis);
        assert_eq!(AutoExecution::for_driver("llvmpipe", ""), AutoExecution::Megakernel);
    }

    /// The plan is a function of its inputs alone: the adapter's profile decides the driver
    /// tuning, the upload's choices pass through, `specialise` off gives the generic kernel, and
    /// the scene's stack goes to every kernel.
    #[test]
    fn the_plan_follows_the_scene_the_settings_and_the_adapter() {
        use super::{AdapterProfile, DriverTuning, UploadedScene};
        use crate::features::SceneArrayMemory;
        use crate::scene::Camera;
        use glam::Vec3;
        let features = SceneFeatures { area_lights: true, many_lights: true, ..SceneFeatures::default() };
        let arrays = SceneArrayMemory { uniform_materials: 64, texels: true };
        let scene = UploadedScene {
            features: &features,
            bvh_stack: 160,
            arrays,
            baked: None,
            emitter_grid: true,
            lit_boxes: false,
        };
        let camera = Camera::look_at("c", Vec3::Z, Vec3::ZERO, Vec3::Y, 0.8);
        let profile = |auto, cpu| AdapterProfile {
            auto,
            cpu,
            storage_buffers_per_stage: 32,
            max_binding: 1 << 27,
            workgroups: [(8, 8), (32, 8)],
        };
        let mis = RenderSettings { strategy: Strategy::Mis, light_samples: 1, brdf_samples: 1, ..Default::default() };
        let plan = |settings: &RenderSettings, adapter: &AdapterProfile| {
            KernelPlan::for_render(scene, settings, &camera, 0..settings.height, true, adapter).plan
        };
        // Mesa 25's lavapipe: the upload's array memory and grid, a copy of the frame.
        let lavapipe = plan(&mis, &profile(AutoExecution::MegakernelOnLavapipe, true));
        assert!(lavapipe.driver.frame_copy && lavapipe.driver.emitter_grid);
        assert_eq!(lavapipe.driver.arrays, arrays);
        assert!(!lavapipe.wavefront);
        assert_eq!(lavapipe.bvh_stack, 160);
        // NVIDIA: the wavefront for MIS, with its workgroup; the same semantic axes.
        let nvidia = plan(&mis, &profile(AutoExecution::WavefrontForMis, false));
        assert!(nvidia.wavefront && !nvidia.driver.frame_copy);
        assert_eq!(nvidia.driver.workgroup, (32, 8));
        assert_eq!(
            (nvidia.strategy, nvidia.lights, nvidia.techniques),
            (lavapipe.strategy, lavapipe.lights, lavapipe.techniques)
        );
        // The generic kernel: no tuning but the workgroup, the scene's stack and array memory.
        let generic = plan(
            &RenderSettings { specialise: false, ..mis.clone() },
            &profile(AutoExecution::MegakernelOnLavapipe, true),
        );
        let driver = DriverTuning { workgroup: (8, 8), arrays, ..DriverTuning::none() };
        assert_eq!(generic, KernelPlan { bvh_stack: 160, driver, ..KernelPlan::generic() });
        // The same inputs, the same plan.
        assert_eq!(plan(&mis, &profile(AutoExecution::MegakernelOnLavapipe, true)), lavapipe);
    }
}

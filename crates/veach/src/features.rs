//! Scene features, detected on load, and the kernel key they give: the set of WGSL override
//! constants (`shaders/features.wgsl`) that specialise the kernel to one scene and strategy.

use crate::scene::{LightKind, Scene};
use crate::settings::{Execution, RenderSettings, Strategy};
use serde::Serialize;

/// Lights that lights.wgsl's `emitter_reach` bounds one by one, each by its sphere; past this many
/// it takes one sphere and one box around all of them (lights.wgsl's `MAX_REACH_LIGHTS`).
pub const MAX_REACH_LIGHTS: usize = 16;

/// What a scene contains that the kernel may need code for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct SceneFeatures {
    pub area_lights: bool,
    pub point_lights: bool,
    pub spot_lights: bool,
    pub directional_lights: bool,
    /// Exactly one light.
    pub single_light: bool,
    /// Every material that triangles use is Lambertian (metallic 0, specular 0).
    pub all_diffuse: bool,
    /// Some used material has metallic > 0.
    pub any_metal: bool,
    /// Some used material has a GGX lobe (metallic > 0 or specular > 0).
    pub any_glossy: bool,
    /// Some used material is a perfect mirror (roughness 0).
    pub any_mirror: bool,
    pub double_sided_emitters: bool,
    /// Some area light is round (`scene::light_shape::area_light_shape`), which
    /// `LightSampling::Cone` samples by its bounding cone.
    pub round_lights: bool,
    /// Every light is a round area light (and there is one).
    pub all_lights_round: bool,
    /// Some area light is one parallelogram of two triangles, which area samples map the unit
    /// square onto linearly.
    pub parallelogram_lights: bool,
    /// Every area light is a parallelogram (true where there are none).
    pub all_area_lights_parallelograms: bool,
    /// More lights than `emitter_reach` (lights.wgsl) bounds one by one (`MAX_REACH_LIGHTS`): a
    /// direction sample's ray is then traced wherever it crosses one sphere and box around all
    /// of them, which lets through many more rays than the lights' own spheres.
    pub many_lights: bool,
    /// Textures in use, by kind.
    pub base_color_texture: bool,
    pub metallic_roughness_texture: bool,
    pub emissive_texture: bool,
    pub normal_texture: bool,
}

impl SceneFeatures {
    pub fn detect(scene: &Scene) -> SceneFeatures {
        let mut used = vec![false; scene.materials.len()];
        for t in &scene.triangles {
            used[t.material as usize] = true;
        }
        let materials = || scene.materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);
        let glossy = |m: &&crate::scene::Material| m.metallic > 0.0 || m.specular > 0.0;
        let has = |f: fn(&LightKind) -> bool| scene.lights.iter().any(|l| f(&l.kind));
        let shapes: Vec<Option<crate::scene::light_shape::AreaLightShape>> = scene
            .lights
            .iter()
            .map(|l| match &l.kind {
                LightKind::Area { triangles, .. } => {
                    Some(crate::scene::light_shape::area_light_shape(scene, triangles))
                }
                _ => None,
            })
            .collect();
        let round: Vec<bool> = shapes.iter().map(|s| s.is_some_and(|s| s.round)).collect();
        SceneFeatures {
            area_lights: has(|k| matches!(k, LightKind::Area { .. })),
            point_lights: has(|k| matches!(k, LightKind::Point { .. })),
            spot_lights: has(|k| matches!(k, LightKind::Spot { .. })),
            directional_lights: has(|k| matches!(k, LightKind::Directional { .. })),
            single_light: scene.lights.len() == 1,
            all_diffuse: !materials().any(|m| glossy(&m)),
            any_metal: materials().any(|m| m.metallic > 0.0),
            any_glossy: materials().any(|m| glossy(&m)),
            any_mirror: materials().any(|m| glossy(&m) && m.roughness <= 0.0),
            double_sided_emitters: has(|k| matches!(k, LightKind::Area { double_sided: true, .. })),
            round_lights: round.iter().any(|&r| r),
            all_lights_round: !round.is_empty() && round.iter().all(|&r| r),
            parallelogram_lights: shapes.iter().any(|s| s.is_some_and(|s| s.parallelogram.is_some())),
            all_area_lights_parallelograms: shapes.iter().flatten().all(|s| s.parallelogram.is_some()),
            many_lights: scene.lights.len() > MAX_REACH_LIGHTS,
            base_color_texture: materials().any(|m| m.base_color_texture.is_some()),
            metallic_roughness_texture: materials().any(|m| m.metallic_roughness_texture.is_some()),
            // An emissive texture matters only where the emissive factor is not zero.
            emissive_texture: materials().any(|m| m.emissive_texture.is_some() && m.is_emissive()),
            normal_texture: materials().any(|m| m.normal_texture.is_some()),
        }
    }

    pub fn textures(&self) -> bool {
        self.base_color_texture || self.metallic_roughness_texture || self.emissive_texture || self.normal_texture
    }

    pub fn delta_lights(&self) -> bool {
        self.point_lights || self.spot_lights || self.directional_lights
    }

    /// "area lights, point lights, glossy, 1 light"
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        let mut add = |on: bool, name: &str| {
            if on {
                parts.push(name.to_owned())
            }
        };
        add(self.area_lights, "area lights");
        add(self.round_lights, "round lights");
        add(self.parallelogram_lights, "parallelogram lights");
        add(self.point_lights, "point lights");
        add(self.spot_lights, "spot lights");
        add(self.directional_lights, "directional lights");
        add(self.single_light, "one light");
        add(self.all_diffuse, "all diffuse");
        add(self.any_glossy, "glossy");
        add(self.any_metal, "metal");
        add(self.any_mirror, "mirrors");
        add(self.double_sided_emitters, "double-sided emitters");
        add(self.base_color_texture, "base colour textures");
        add(self.metallic_roughness_texture, "metallic-roughness textures");
        add(self.emissive_texture, "emissive textures");
        add(self.normal_texture, "normal textures");
        if parts.is_empty() { "nothing to light".into() } else { parts.join(", ") }
    }
}

/// The scene arrays a kernel reads from uniform buffers instead of storage buffers, each as a
/// uniform array of this many elements (0: storage), in binding order. On CPU adapters, where a scene's array fits
/// in 64 KiB (`GpuScene`, `BvhMemory`): lavapipe gathers a uniform array's elements where it
/// loads a storage buffer's lane by lane (docs/performance.md, "Small BVHs in a uniform buffer",
/// "Small scenes' triangles in uniform buffers").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct UniformArrays {
    pub bvh_nodes: u32,
    pub vertices: u32,
    pub triangles: u32,
    pub materials: u32,
    pub lights: u32,
    pub emitter_tris: u32,
    pub light_picks: u32,
    /// Binding 23's `triangle_lights` as a uniform array of this many vec4u, four triangles'
    /// lights each (0: storage).
    pub triangle_lights: u32,
}

impl UniformArrays {
    /// The lengths in binding order (bindings 1 to 7, `gpu::bindings`).
    pub fn lengths(&self) -> [u32; 7] {
        [
            self.bvh_nodes,
            self.vertices,
            self.triangles,
            self.materials,
            self.lights,
            self.emitter_tris,
            self.light_picks,
        ]
    }
}

/// The override constants of one kernel. `KernelKey::generic()` is the kernel for everything.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct KernelKey {
    /// A fixed strategy, or None to read it at run time.
    pub strategy: Option<Strategy>,
    pub area_lights: bool,
    pub delta_lights: bool,
    pub glossy: bool,
    pub mirrors: bool,
    pub aovs: bool,
    /// Light samples may be taken by solid angle (`LightSampling::SolidAngle`).
    pub solid_angle: bool,
    /// Light samples may be directions in round lights' bounding cones (`LightSampling::Cone`).
    pub cone: bool,
    /// Light samples may be points with shadow rays: false where `cone` takes every light.
    pub shadow_rays: bool,
    /// Area samples may map the unit square onto a parallelogram light.
    pub parallelograms: bool,
    /// Area samples may pick a light's triangle by area: false where `parallelograms` takes every
    /// area light.
    pub triangle_picks: bool,
    /// Lights may be chosen per shading point (`LightSelection::per_point`).
    pub point_selection: bool,
    /// The scene has exactly one light (`SceneFeatures::single_light`).
    pub single_light: bool,
    /// The texture module (shaders/textures.wgsl and its bindings) is in the kernel...
    pub textures: bool,
    /// ...with lookups of these kinds: base colour, metallic-roughness, emissive, normal.
    pub texture_kinds: [bool; 4],
    /// The wavefront kernels (shaders/wavefront.wgsl) instead of `render`.
    pub wavefront: bool,
    /// Scene arrays read from uniform buffers (`GpuScene` decides, for small scenes on CPU
    /// adapters); none in the generic kernel.
    pub uniform: UniformArrays,
    /// Each entry point copies the frame's parameters from their storage buffer into a private
    /// variable (`Accumulation` decides, on CPU adapters: lavapipe loads a storage word lane by
    /// lane at every read); none in the generic kernel.
    pub frame_copy: bool,
    /// A small scene's triangles, compiled into the kernel in place of the BVH (`GpuScene`
    /// decides, on CPU adapters); none in the generic kernel.
    pub baked: Option<std::sync::Arc<crate::gpu::baked_triangles::BakedTriangles>>,
    /// Camera rays test `baked`'s edge planes through the eye (`BakedTriangles::set_camera_eye`):
    /// the render's camera is at that eye (`Accumulation` decides).
    pub camera_list: bool,
    /// Camera rays test their pixel's footprint list of this many triangles (at most
    /// `gpu::camera_footprints::FOOTPRINT_SLOTS_MAX`; 0: none), read once per invocation
    /// (`Accumulation` decides, with `camera_list`'s eye, for the megakernel where the driver runs
    /// every branch under a mask, Mesa 22.3's lavapipe).
    pub footprint_slots: u32,
    /// With `footprint_slots`: direction rays wait in their invocation and are traced after its
    /// camera samples (waiting_rays.wgsl, take_samples_deferred).
    pub deferred_direction_rays: bool,
    /// A BVH kernel's BRDF samples find emitters in the emitters' grid, then trace a shadow ray to
    /// what they find (`gpu::emitter_grid`; `EMITTER_LIST`), instead of a closest hit over the
    /// BVH (`Accumulation` decides: where the scene has a grid that pays and the driver branches
    /// around code no lane runs).
    pub emitter_grid: bool,
    /// The unshadowed diffuse light may be a control variate (`RenderSettings::control_variate`).
    pub control_variate: bool,
    /// A camera sample takes at most one light-sample request, or at most one direction sample
    /// (`at_most_one_sample`): the kernel takes them without a loop.
    pub at_most_one_light_request: bool,
    pub at_most_one_direction_sample: bool,
    /// The megakernel takes each camera sample in straight-line code, its direction sample's ray
    /// at a call site of its own (`straight_line_sample`).
    pub straight_line_sample: bool,
    /// The megakernel lets a camera sample's direction ray wait for a later sample's pass, so that
    /// the lanes of a SIMD group trace theirs together (`waiting_direction_rays`).
    pub waiting_direction_rays: bool,
    /// Entries of the BVH traversal's stack: `gpu::bvh_nodes::BVH_STACK_SIZE`, more for deeper
    /// trees (`GpuScene::bvh_stack`). Not a specialisation: every kernel takes its scene's.
    pub bvh_stack: u32,
    /// Threads per workgroup of `render` and `render_light_pass`, as (columns, rows)
    /// (`GpuContext::render_workgroup`, which depends on `wavefront`). Not a specialisation
    /// either.
    pub workgroup: (u32, u32),
}

impl KernelKey {
    pub fn generic() -> KernelKey {
        KernelKey {
            strategy: None,
            area_lights: true,
            delta_lights: true,
            glossy: true,
            mirrors: true,
            aovs: true,
            solid_angle: true,
            cone: true,
            shadow_rays: true,
            parallelograms: true,
            triangle_picks: true,
            point_selection: true,
            single_light: false,
            textures: true,
            texture_kinds: [true; 4],
            wavefront: false,
            uniform: UniformArrays::default(),
            frame_copy: false,
            baked: None,
            camera_list: false,
            footprint_slots: 0,
            deferred_direction_rays: false,
            emitter_grid: false,
            control_variate: true,
            at_most_one_light_request: false,
            at_most_one_direction_sample: false,
            straight_line_sample: false,
            waiting_direction_rays: false,
            bvh_stack: crate::gpu::bvh_nodes::BVH_STACK_SIZE,
            workgroup: crate::gpu::layout::WORKGROUP_SIZE,
        }
    }

    /// The kernel a render runs: specialised to the scene and the settings, or (with
    /// `specialise` off) the generic one, split into the wavefront only when asked by name.
    pub fn for_render(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> KernelKey {
        if settings.specialise {
            KernelKey::specialised(features, settings, auto)
        } else {
            KernelKey { wavefront: settings.execution == Execution::Wavefront, ..KernelKey::generic() }
        }
    }

    /// The kernel specialised to a scene's features and a render's settings.
    pub fn specialised(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> KernelKey {
        let parallelograms =
            features.parallelogram_lights && settings.light_sampling != crate::settings::LightSampling::SolidAngle;
        let (at_most_one_light_request, at_most_one_direction_sample) = at_most_one_sample(features, settings);
        let wavefront = uses_wavefront(features, settings, auto);
        KernelKey {
            strategy: Some(effective_strategy(features, settings).0),
            area_lights: features.area_lights,
            delta_lights: features.delta_lights(),
            glossy: features.any_glossy,
            mirrors: features.any_mirror,
            aovs: settings.write_aovs,
            solid_angle: features.area_lights && settings.light_sampling == crate::settings::LightSampling::SolidAngle,
            cone: cone_sampling(features, settings),
            shadow_rays: !(features.all_lights_round
                && settings.light_sampling == crate::settings::LightSampling::Cone),
            parallelograms,
            triangle_picks: !(parallelograms && features.all_area_lights_parallelograms),
            point_selection: !features.single_light
                && settings.light_selection.per_point()
                && effective_strategy(features, settings).0.samples_lights(),
            single_light: features.single_light,
            textures: features.textures(),
            texture_kinds: [
                features.base_color_texture,
                features.metallic_roughness_texture,
                features.emissive_texture,
                features.normal_texture,
            ],
            wavefront,
            uniform: UniformArrays::default(),
            frame_copy: false,
            baked: None,
            camera_list: false,
            footprint_slots: 0,
            deferred_direction_rays: false,
            emitter_grid: false,
            control_variate: settings.control_variate,
            at_most_one_light_request,
            at_most_one_direction_sample,
            straight_line_sample: !wavefront && straight_line_sample(features, settings, auto),
            waiting_direction_rays: !wavefront && waiting_direction_rays(features, settings, auto),
            bvh_stack: crate::gpu::bvh_nodes::BVH_STACK_SIZE,
            workgroup: crate::gpu::layout::WORKGROUP_SIZE,
        }
    }

    /// The values of the WGSL `override` constants (`shaders/features.wgsl`).
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let strategy = match self.strategy {
            None => 255.0,
            Some(Strategy::Uniform) => crate::gpu::layout::STRATEGY_UNIFORM as f64,
            Some(Strategy::Brdf) => crate::gpu::layout::STRATEGY_BRDF as f64,
            Some(Strategy::Light) => crate::gpu::layout::STRATEGY_LIGHT as f64,
            Some(Strategy::Mis) => crate::gpu::layout::STRATEGY_MIS as f64,
            Some(Strategy::MisLobes) => crate::gpu::layout::STRATEGY_MIS_LOBES as f64,
        };
        let mut constants = vec![
            ("STRATEGY", strategy),
            ("HAS_AREA_LIGHTS", flag(self.area_lights)),
            ("HAS_DELTA_LIGHTS", flag(self.delta_lights)),
            ("HAS_GLOSSY", flag(self.glossy)),
            ("HAS_MIRRORS", flag(self.mirrors)),
            ("HAS_AOVS", flag(self.aovs)),
            ("SOLID_ANGLE_SAMPLING", flag(self.solid_angle)),
            ("CONE_SAMPLING", flag(self.cone)),
            ("SHADOW_RAY_LIGHTS", flag(self.shadow_rays)),
            ("PARALLELOGRAM_LIGHTS", flag(self.parallelograms)),
            ("TRIANGLE_PICKS", flag(self.triangle_picks)),
            ("POINT_LIGHT_SELECTION", flag(self.point_selection)),
            ("SINGLE_LIGHT", flag(self.single_light)),
            ("EMITTER_LIST", flag(self.emitter_grid || self.baked.as_ref().is_some_and(|b| b.emitter_list()))),
            ("CAMERA_LIST", flag(self.camera_list)),
            ("CONTROL_VARIATE", flag(self.control_variate)),
            ("AT_MOST_ONE_LIGHT_REQUEST", flag(self.at_most_one_light_request)),
            ("AT_MOST_ONE_DIRECTION_SAMPLE", flag(self.at_most_one_direction_sample)),
            ("STRAIGHT_LINE_SAMPLE", flag(self.straight_line_sample)),
            ("WAITING_DIRECTION_RAYS", flag(self.waiting_direction_rays)),
            ("DEFERRED_DIRECTION_RAYS", flag(self.deferred_direction_rays)),
            ("RENDER_WORKGROUP_WIDTH", self.workgroup.0 as f64),
            ("RENDER_WORKGROUP_HEIGHT", self.workgroup.1 as f64),
        ];
        // These exist only in textures.wgsl.
        if self.textures {
            let [base, mr, emissive, normal] = self.texture_kinds;
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
    let lights = if settings.light_selection == crate::settings::LightSelection::Each && !features.single_light {
        u32::MAX
    } else {
        1
    };
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
    /// time in 11 of 12 cases, 0.96x in one), with direction rays that wait where those pay
    /// (`waiting_direction_rays`).
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

    /// Whether the megakernel may let direction rays wait on this driver: lavapipe, of any Mesa
    /// release, where it was measured (`waiting_direction_rays`; its SIMD groups are 8 lanes).
    pub fn waits_direction_rays(self) -> bool {
        matches!(self, AutoExecution::WavefrontWhereMasked | AutoExecution::MegakernelOnLavapipe)
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

/// Whether light samples may be directions in round lights' bounding cones (`KernelKey::cone`).
fn cone_sampling(features: &SceneFeatures, settings: &RenderSettings) -> bool {
    features.round_lights && settings.light_sampling == crate::settings::LightSampling::Cone
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

/// Whether the megakernel lets a camera sample's direction ray wait in its invocation for a later
/// sample's pass (waiting_rays.wgsl, `estimate_radiance_waiting`), where lanes that have a ray
/// trace it together instead of each sample's ray on a pass that a SIMD group runs if any lane
/// needs it. It applies to MIS with one BRDF sample and lights chosen independently of the point
/// (no cone samples, control variate or contribution images), and was measured on lavapipe alone
/// (docs/performance.md, "Direction rays that wait for the lanes beside them"; 256×256, 32 spp,
/// against the loop). On Mesa 25 `veach scale`'s grid at 1,000 and 10,000 lights took
/// 0.90-0.96x the time. On Mesa 22.3:
/// - `veach scale`'s grid, where 30% of camera samples have a direction ray: 10,000 lights
///   0.89-0.92x, 1,000 lights 0.93-0.94x; 100 lights in one column, where few have one, 0.98-1.00x;
/// - taken everywhere, the one-light grid 0.99-1.06x and the Veach scene (5.5% of its camera
///   samples have one) 1.02x, so it is taken only past `MAX_REACH_LIGHTS` lights, where
///   `emitter_reach` lets most direction rays through; the textured scene keeps the straight-line
///   sample (the waiting kernel 1.19x its time).
///
/// Taken everywhere on Mesa 25, the Cornell box took 1.13x, the textured scene 1.05x and the
/// one-light grid 1.05x the time, the Veach scene 0.96x. In a render of one sample per pass (the
/// viewer's) no ray waits: 10,000 lights at 1024×1024 and 1 spp took 0.96x the loop's time on
/// Mesa 22.3. Other drivers keep the loop (not measured).
pub fn waiting_direction_rays(features: &SceneFeatures, settings: &RenderSettings, auto: AutoExecution) -> bool {
    if !auto.waits_direction_rays() {
        return false;
    }
    let (strategy, _, m) = effective_strategy(features, settings);
    strategy == Strategy::Mis
        && m == 1
        && features.many_lights
        && !features.textures()
        && !cone_sampling(features, settings)
        && !settings.control_variate
        && !settings.write_aovs
        && settings.light_selection != crate::settings::LightSelection::Bsdf
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
    use super::{
        AutoExecution, KernelKey, MAX_REACH_LIGHTS, SceneFeatures, at_most_one_sample, straight_line_sample,
        uses_wavefront, waiting_direction_rays,
    };
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
        let key = KernelKey::specialised(&plain, &s(Strategy::Light, 2, 0), masked);
        assert!(key.straight_line_sample && !key.wavefront);
        let wavefront = RenderSettings { execution: Execution::Wavefront, ..s(Strategy::Light, 2, 0) };
        let key = KernelKey::specialised(&plain, &wavefront, masked);
        assert!(!key.straight_line_sample && key.wavefront);
        assert!(!KernelKey::generic().straight_line_sample);
    }

    /// Direction rays wait only where that was measured to pay: on Mesa 22's lavapipe, for MIS
    /// with one BRDF sample on untextured scenes with more lights than `emitter_reach` bounds one
    /// by one, and never where the kernel's code for it would be wrong (cone samples, the control
    /// variate, contribution images and lights chosen per point keep the loop).
    #[test]
    fn direction_rays_wait_only_where_measured_to_pay() {
        use crate::settings::{Execution, LightSampling};
        let masked = AutoExecution::WavefrontWhereMasked;
        let many = SceneFeatures { area_lights: true, any_glossy: true, many_lights: true, ..SceneFeatures::default() };
        let few = SceneFeatures { many_lights: false, ..many };
        let s = power_settings;
        let mis = s(Strategy::Mis, 1, 1);
        assert!(waiting_direction_rays(&many, &mis, masked));
        assert!(waiting_direction_rays(&many, &s(Strategy::Mis, 8, 1), masked));
        assert!(waiting_direction_rays(
            &many,
            &RenderSettings { light_selection: LightSelection::Each, ..mis.clone() },
            masked
        ));
        assert!(!waiting_direction_rays(&few, &mis, masked));
        assert!(!waiting_direction_rays(&many, &s(Strategy::Mis, 1, 2), masked));
        assert!(!waiting_direction_rays(&many, &s(Strategy::Mis, 1, 0), masked));
        for strategy in [Strategy::Light, Strategy::Brdf, Strategy::Uniform, Strategy::MisLobes] {
            assert!(!waiting_direction_rays(&many, &s(strategy, 1, 1), masked), "{strategy:?}");
        }
        let textured = SceneFeatures { base_color_texture: true, ..many };
        assert!(!waiting_direction_rays(&textured, &mis, masked));
        let round = SceneFeatures { round_lights: true, ..many };
        let cone = RenderSettings { light_sampling: LightSampling::Cone, ..mis.clone() };
        assert!(!waiting_direction_rays(&round, &cone, masked));
        for unsupported in [
            RenderSettings { control_variate: true, ..mis.clone() },
            RenderSettings { write_aovs: true, ..mis.clone() },
            RenderSettings { light_selection: LightSelection::Bsdf, ..mis.clone() },
        ] {
            assert!(!waiting_direction_rays(&many, &unsupported, masked), "{unsupported:?}");
        }
        assert!(waiting_direction_rays(&many, &mis, AutoExecution::MegakernelOnLavapipe));
        for other in [AutoExecution::Megakernel, AutoExecution::WavefrontForMis] {
            assert!(!waiting_direction_rays(&many, &mis, other));
        }
        // The megakernel's alone: a wavefront asked for by name keeps its own kernels.
        assert!(KernelKey::specialised(&many, &mis, masked).waiting_direction_rays);
        let wavefront = RenderSettings { execution: Execution::Wavefront, ..mis.clone() };
        assert!(!KernelKey::specialised(&many, &wavefront, masked).waiting_direction_rays);
        assert!(!KernelKey::generic().waiting_direction_rays);
    }

    /// `SceneFeatures::many_lights` is what lights.wgsl's emitter_reach tests.
    #[test]
    fn many_lights_is_where_emitter_reach_stops_bounding_each() {
        let lights = crate::shaders::SHADER_FILES.iter().find(|(name, _)| *name == "lights.wgsl").unwrap().1;
        assert!(lights.contains(&format!("const MAX_REACH_LIGHTS: u32 = {MAX_REACH_LIGHTS}u;")));
        assert!(lights.contains("if light_count() > MAX_REACH_LIGHTS {"));
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
}

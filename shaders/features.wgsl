// features.wgsl: what a kernel is specialised for. Each is a pipeline-overridable constant, set
// from the scene's features and the render settings (crates/veach/src/features.rs); the
// defaults make the generic kernel, which renders any scene and reads the strategy and the light
// selection at run time.
// A branch on a false constant is dead code that the driver's compiler removes.

// 0..4: the strategy is fixed (STRATEGY_*); 255: read frame.strategy.
override STRATEGY: u32 = 255u;
// The scene has emissive triangles (area lights, emission seen directly).
override HAS_AREA_LIGHTS: bool = true;
// The scene has point, spot or directional lights.
override HAS_DELTA_LIGHTS: bool = true;
// Some material has a GGX lobe (metallic > 0 or specular > 0); else every one is Lambertian.
override HAS_GLOSSY: bool = true;
// Some material is a perfect mirror (roughness 0, a delta lobe).
override HAS_MIRRORS: bool = true;
// The contribution images may be written.
override HAS_AOVS: bool = true;
// 0..4: the light selection is fixed (SELECT_*); 255: read frame.light_selection.
override LIGHT_SELECTION: u32 = 255u;
// The scene has exactly one light: every light index is 0, read as a constant (lights.wgsl's
// light_at), where lavapipe gathers a record at a run-time index lane by lane.
override SINGLE_LIGHT: bool = false;
// The light tree's nodes may have lit boxes (frame.light_tree_lit_boxes; light_tree.wgsl,
// lit_factor): false where the scene's have none, or lights are not chosen by the tree.
override LIT_BOXES: bool = true;
// Light samples may pick directions in emitter triangles' solid angle (frame.light_sampling ==
// LIGHT_SAMPLING_SOLID_ANGLE); false: by area only.
override SOLID_ANGLE_SAMPLING: bool = true;
// Light samples may pick directions in rectangle lights' solid angle (frame.light_sampling ==
// LIGHT_SAMPLING_SOLID_ANGLE or LIGHT_SAMPLING_AUTO; lights.wgsl, rectangle_sampled).
override RECTANGLE_SAMPLING: bool = true;
// Light samples may pick directions in round lights' bounding cones (frame.light_sampling ==
// LIGHT_SAMPLING_CONE or LIGHT_SAMPLING_AUTO): they are then traced as direction samples
// (light_samples.wgsl).
override CONE_SAMPLING: bool = true;
// Some light sample may be a point on a light with a shadow ray; false where CONE_SAMPLING takes
// every light (each is round), so the kernel has no shadow-ray traversal at all.
override SHADOW_RAY_LIGHTS: bool = true;
// Some area light is a parallelogram (Light.parallelogram), and light samples are not taken by
// solid angle: its area samples map the unit square onto it linearly.
override PARALLELOGRAM_LIGHTS: bool = true;
// Some area light sample picks a triangle by area (lights.wgsl, select_emitter_triangle); false
// where PARALLELOGRAM_LIGHTS takes every area light.
override TRIANGLE_PICKS: bool = true;
// Where the driver branches around untaken code, baked kernels (traverse_baked.wgsl, the emitters'
// list) and BVH kernels whose scene has an emitters' grid that pays (traverse_bvh.wgsl,
// DriverTuning::emitter_grid): a direction sample finds what it meets among the emitters alone
// (trace_emitters), then a shadow ray tests the segment to it (direction_samples.wgsl,
// direction_sample_to_emitters).
override EMITTER_LIST: bool = false;
// Baked kernels for a render from the eye the camera list was built for (DriverTuning::camera_list):
// camera rays test the triangles by their edge planes through that eye (traverse_baked.wgsl,
// trace_camera). False for BVH kernels.
override CAMERA_LIST: bool = false;
// The unshadowed diffuse light may be a control variate (frame.control_variate;
// control_variate.wgsl).
override CONTROL_VARIATE: bool = true;

// A camera sample takes at most one light-sample request, or at most one direction sample, where
// the kernel is specialised to the render's counts (KernelPlan::at_most_one_light_request,
// at_most_one_direction_sample): those samples are then taken without a loop. On Mesa 22.3's
// lavapipe a loop nested in the sample loop cost the Cornell box about a quarter of its render
// time, and that driver keeps a loop bounded by a constant as a loop (docs/performance.md,
// "Sample loops left out").
override AT_MOST_ONE_LIGHT_REQUEST: bool = false;
override AT_MOST_ONE_DIRECTION_SAMPLE: bool = false;
// With AT_MOST_ONE_DIRECTION_SAMPLE (and no cone sampling): a camera sample in straight-line code,
// its direction sample's ray traced at a call site of its own (direct.wgsl,
// estimate_radiance_straight), not on a second pass of one loop (DriverTuning::straight_line_sample).
override STRAIGHT_LINE_SAMPLE: bool = false;
// With FOOTPRINT_SLOTS (traverse_baked.wgsl) and at most one direction sample: direction rays
// wait in their invocation and are traced together after its camera samples
// (deferred_rays.wgsl, take_samples_deferred; DriverTuning::deferred_direction_rays).
override DEFERRED_DIRECTION_RAYS: bool = false;
// Threads per workgroup of the kernels that take a pixel each, in columns and rows
// (DriverTuning::workgroup). Not a specialisation: a size the driver runs fastest.
override RENDER_WORKGROUP_WIDTH: u32 = 8u;
override RENDER_WORKGROUP_HEIGHT: u32 = 8u;

// An override constant of 255 leaves the choice to the frame's parameters (the generic kernel).
const FROM_FRAME: u32 = 255u;

fn fixed_or_frame(fixed: u32, from_frame: u32) -> u32 {
    if fixed != FROM_FRAME {
        return fixed;
    }
    return from_frame;
}

fn active_strategy() -> u32 {
    return fixed_or_frame(STRATEGY, frame.strategy);
}

fn active_light_selection() -> u32 {
    return fixed_or_frame(LIGHT_SELECTION, frame.light_selection);
}

// deferred_rays.wgsl: camera samples whose direction rays are held in their invocation and traced
// after its run of camera samples (DEFERRED_DIRECTION_RAYS, features.wgsl: baked megakernels with
// camera footprint lists on Mesa 22.3), so that the camera samples run no closest-hit list.

// A camera sample whose direction ray is held: its value without that ray, and the ray with what
// weighs its hit (the shading point for the light pdf of the MIS weight, the sample's density and
// throughput; the plan is the strategy's, the same for every sample).
struct HeldRay {
    // Emitted radiance plus the light samples' estimate.
    partial: vec3f,
    // The shading point and normal (the light tree's choice depends on them: its MIS weight is
    // taken there).
    p: vec3f,
    n: vec3f,
    origin: vec3f,
    t_max: f32,
    wi: vec3f,
    pdf: f32,
    throughput: vec3f,
    mis: bool,
    held: bool,
}

// One camera sample's value added to a pixel's sums, as `render` adds it (no contribution images).
fn add_to_sums(l: vec3f, sum: ptr<function, vec4f>, sum_sq: ptr<function, vec4f>, count: ptr<function, PixelCounters>) {
    // A non-finite sample is counted and dropped (as a zero), never accumulated.
    if is_finite3(l) && is_finite3(l * l) {
        *sum += vec4f(l, 1.0);
        *sum_sq += vec4f(l * l, 0.0);
    } else {
        (*sum).w += 1.0;
        (*count).nonfinite += 1u;
    }
}

// A camera sample in straight-line code up to its direction sample's ray, which it returns (held
// where it needs one; `partial` is then the rest of the sample) instead of tracing it:
// estimate_radiance_straight traces it right away, take_samples_deferred after the run.
struct Deferring {
    e: Estimate,
    ray: HeldRay,
}

fn estimate_radiance_deferring(ray: Ray, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> Deferring {
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var held = HeldRay(vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0), 0.0, vec3f(0.0), 0.0, vec3f(0.0), false, false);
    *rays += 1u;
    let hit = trace_camera_ray(ray);
    if !hit.found {
        return Deferring(e, held);
    }
    let c = shading_context(surface_at(hit, ray.dir), ray.dir);
    if frame.hide_emitters == 0u {
        e.emitted = emitted_radiance(c.s);
    }
    let plan = sample_plan(c);
    let light_dim = reserve_light_requests(plan, stream);
    if plan.m > 0u {
        // plan.m is 1 (AT_MOST_ONE_DIRECTION_SAMPLE).
        let next = next_direction_sample(c, plan, 0u, light_dim, stream, rays, &e);
        held = HeldRay(vec3f(0.0), c.s.p, c.frame.n, next.origin, next.t_max, next.d.wi, next.d.pdf, next.d.throughput, next.d.mis, next.d.valid);
    }
    var light_stream = SampleStream((*stream).index, (*stream).seed, light_dim);
    e.light = estimate_light(c, plan, &light_stream, rays);
    held.partial = e.emitted + e.light + e.brdf;
    return Deferring(e, held);
}

// What a held direction ray adds (the direction sample's MIS-weighted emission where it meets a
// light), traced at this call's closest-hit call site. Strategies whose plan is the same at every
// point only (not mis-lobes), as estimate_radiance_deferring's callers are.
fn held_ray_value(w: HeldRay, rays: ptr<function, u32>) -> vec3f {
    *rays += 1u;
    let hit = trace_closest(w.origin, w.wi, w.t_max);
    if !hit.found {
        return vec3f(0.0);
    }
    let d = DirectionSample(w.wi, w.pdf, w.throughput, w.mis, true, NO_LIGHT);
    // The light tree's probabilities at the ray's own point, which later samples moved on.
    tree_point = w.p;
    tree_normal = w.n;
    return direction_sample_value(w.p, d, strategy_plan(), hit.tri, surface_at(hit, w.wi));
}

// Direction rays an invocation holds before it traces them (take_samples_deferred).
const DEFERRED_SLOTS: u32 = 4u;

// `render`'s samples of pixel `px` from sample `start`, for kernels with camera footprint lists
// (FOOTPRINT_SLOTS) where a camera sample takes at most one direction sample: the camera samples
// run without any closest-hit list (their camera rays test the pixel's slots), and each direction
// sample that needs a ray waits in one of DEFERRED_SLOTS slots; once the run ends or a slot-full
// lane stops it, a loop traces the held rays, one a pass, at the kernel's one closest-hit call
// site. Mesa 22.3 runs every branch under a mask and a loop's first pass whatever the mask: there
// the closest-hit list then runs once a run (plus a pass per ray beyond the first that some lane
// holds) instead of once per camera sample. The same samples with the same values; the sums add
// them in another order. Where Mesa 22's loop limit cuts a run short (loop_budget_held), the
// samples since the slots were last empty are dropped and taken again later; with
// frame.finish_samples every ray is traced right after its sample.
fn take_samples_deferred(px: BandPixel, start: u32, sum: ptr<function, vec4f>, sum_sq: ptr<function, vec4f>, count: ptr<function, PixelCounters>) {
    var capacity = DEFERRED_SLOTS;
    if frame.finish_samples != 0u {
        capacity = 1u;
    }
    var q0: HeldRay;
    var q1: HeldRay;
    var q2: HeldRay;
    var q3: HeldRay;
    var k = start;
    loop {
        let kept_sum = *sum;
        let kept_sum_sq = *sum_sq;
        let kept_count = *count;
        let kept_from = k;
        var held = 0u;
        // Camera samples until the run's end or full slots; tested at the end (render says why).
        loop {
            var stream = pixel_sample_stream(px.index, k);
            let ray = camera_ray(vec2u(px.x, px.y), sample_2d(&stream));
            var rays = 0u;
            let o = estimate_radiance_deferring(ray, &stream, &rays);
            (*count).rays += rays;
            if o.ray.held {
                if held == 0u {
                    q0 = o.ray;
                } else if held == 1u {
                    q1 = o.ray;
                } else if held == 2u {
                    q2 = o.ray;
                } else {
                    q3 = o.ray;
                }
                held += 1u;
            } else {
                add_to_sums(o.e.emitted + o.e.light + o.e.brdf, sum, sum_sq, count);
            }
            k++;
            if k >= frame.sample_start + frame.sample_count || held >= capacity {
                break;
            }
        }
        // The held rays, the first slot's each pass; Mesa 22.3 runs the first pass in any case.
        loop {
            if held > 0u {
                var rays = 0u;
                add_to_sums(q0.partial + held_ray_value(q0, &rays), sum, sum_sq, count);
                (*count).rays += rays;
                q0 = q1;
                q1 = q2;
                q2 = q3;
                held -= 1u;
            }
            if held == 0u {
                break;
            }
        }
        if !loop_budget_held() {
            *sum = kept_sum;
            *sum_sq = kept_sum_sq;
            (*count).rays = kept_count.rays;
            (*count).nonfinite = kept_count.nonfinite;
            (*count).truncated += k - kept_from;
            break;
        }
        if k >= frame.sample_start + frame.sample_count {
            break;
        }
    }
}

// wavefront.wgsl: the same estimate as `render` (megakernel.wgsl), split into kernels so that
// each one runs only the code its threads need. On lavapipe a branch costs its code in every
// thread of the SIMD group, taken or not (docs/performance.md), so a megakernel pays for the
// direction-sample code at every diffuse point; here it runs only on a compacted queue.
//
//   render_light_pass       camera ray, emission, the plan and its light samples; a sample
//                           without direction samples is added to its pixel, one with some is
//                           appended to `deferred`.
//   prepare_direction_pass  one thread: the indirect dispatch arguments for the queue's length;
//                           empties the queue for the next round.
//   render_direction_pass   per deferred sample: its m direction samples (and the light
//                           samples that are directions in a round light's cone), then the
//                           whole sample is added to its pixel.
// A dispatch runs these three once per camera sample (a round), so that a pixel has at most one
// deferred sample at a time and the last kernel adds to its sums without atomics.
// The sample stream continues where the light samples left it, so the image is the one
// `render` makes, sample for sample (tests/specialise.rs).

@compute @workgroup_size(RENDER_WORKGROUP_WIDTH, RENDER_WORKGROUP_HEIGHT, 1)
fn render_light_pass(@builtin(global_invocation_id) gid: vec3u) {
    load_frame();
    let px = band_pixel(gid);
    if !px.inside {
        return;
    }
    let pixel = px.index;
    // The pixel's next sample (its own count, as in `render`), unless it has this dispatch's.
    let sample = u32(accum[pixel].w);
    if sample >= frame.sample_start + frame.sample_count {
        return;
    }
    var stream = pixel_sample_stream(pixel, sample);
    let ray = camera_ray(vec2u(px.x, px.y), sample_2d(&stream));
    var rays = 1u;
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    // With the camera list this kernel has no closest-hit traversal at all.
    let hit = trace_camera_ray(ray);
    if hit.found {
        let c = shading_context(surface_at(hit, ray.dir), ray.dir);
        if frame.hide_emitters == 0u {
            e.emitted = emitted_radiance(c.s);
        }
        let plan = sample_plan(c);
        e.light = estimate_light(c, plan, &stream, &rays);
        if !loop_budget_held() {
            counters[pixel].truncated += 1u;
            return;
        }
        // Deferred only where some direction sample needs a ray; the others' part (the control
        // variate's terms) is added here.
        let screen = screen_direction_samples(c, plan, stream);
        e.brdf = screen.brdf;
        if cone_passes(plan) > 0u || screen.needs_rays {
            let slot = atomicAdd(&deferred_header.count, 1u);
            deferred[slot] = DeferredSample(e.emitted, pixel, e.light, stream.dim, hit.tri, hit.b1, hit.b2, plan.n, rays, sample, plan.light_weighting, plan.m);
            return;
        }
    }
    if !loop_budget_held() {
        counters[pixel].truncated += 1u;
        return;
    }
    add_sample(pixel, e, rays);
}

// Whether any of the m direction samples (taken from `stream` as estimate_direction_samples takes
// them) needs a ray: it adds something where it finds a light, and crosses some light's reach
// (direction_reach). Where none does, what estimate_direction_samples would add without tracing
// one, the control variate's terms over m, in the same order: the same sum bit for bit. In the
// Cornell box at MIS 1 + 1 about 3% of camera samples have a BRDF sample to trace (an estimate
// from `--stats`' ray counts, docs/performance.md).
struct DirectionScreen {
    needs_rays: bool,
    brdf: vec3f,
}

fn screen_direction_samples(c: ShadingContext, plan: SamplePlan, stream: SampleStream) -> DirectionScreen {
    var s = stream;
    var screen = DirectionScreen(false, vec3f(0.0));
    // With at most one direction sample, no loop (features.wgsl, AT_MOST_ONE_DIRECTION_SAMPLE).
    if AT_MOST_ONE_DIRECTION_SAMPLE {
        if plan.m > 0u {
            screen = screen_direction_sample(c, plan, &s, screen);
        }
    } else {
        // Tested at its end (megakernel.wgsl's `render` says why).
        if plan.m > 0u {
            var k = 0u;
            loop {
                screen = screen_direction_sample(c, plan, &s, screen);
                k++;
                if k >= plan.m {
                    break;
                }
            }
        }
    }
    if plan.m > 0u {
        screen.brdf /= f32(plan.m);
    }
    return screen;
}

// The stream's next direction sample added to the screen.
fn screen_direction_sample(c: ShadingContext, plan: SamplePlan, stream: ptr<function, SampleStream>, screen: DirectionScreen) -> DirectionScreen {
    var r = screen;
    let d = sample_direction(c, stream);
    if uses_control_variate() {
        r.brdf += control_variate_direction_term(c, d, plan);
    }
    r.needs_rays = r.needs_rays || (d.valid && direction_reach(d, offset_ray_origin(c.s.p, c.s.ng, d.wi)) > 0.0);
    return r;
}

// Threads per workgroup of render_direction_pass (crates/veach/src/gpu/layout.rs has the same).
const DEFERRED_WORKGROUP: u32 = 64u;

@compute @workgroup_size(1, 1, 1)
fn prepare_direction_pass() {
    load_frame();
    let count = atomicExchange(&deferred_header.count, 0u);
    deferred_header.pending = count;
    deferred_dispatch[0] = (count + DEFERRED_WORKGROUP - 1u) / DEFERRED_WORKGROUP;
    deferred_dispatch[1] = 1u;
    deferred_dispatch[2] = 1u;
}

// What the direction passes of a deferred camera sample add: the m direction samples (brdf,
// over m) and the cone light samples (light, over n).
struct DirectionEstimates {
    brdf: vec3f,
    light: vec3f,
}

// The direction samples of a deferred camera sample: the samples estimate_radiance's loop takes
// after the camera hit, in the same order from the same random stream; the light samples' requests
// start at `light_dim`.
fn estimate_direction_samples(c: ShadingContext, plan: SamplePlan, light_dim: u32, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> DirectionEstimates {
    var sum = DirectionEstimates(vec3f(0.0), vec3f(0.0));
    // Tested at its end (megakernel.wgsl's `render` says why).
    let end = plan.m + cone_passes(plan);
    if end > 0u {
        var k = 0u;
        loop {
            add_direction_sample(c, plan, k, light_dim, stream, rays, &sum);
            k++;
            if k >= end {
                break;
            }
        }
    }
    if plan.m > 0u {
        sum.brdf /= f32(plan.m);
    }
    if plan.n > 0u {
        sum.light /= f32(plan.n);
    }
    return sum;
}

// Direction sample k of estimate_direction_samples, traced and added to `sum`.
fn add_direction_sample(c: ShadingContext, plan: SamplePlan, k: u32, light_dim: u32, stream: ptr<function, SampleStream>, rays: ptr<function, u32>, sum: ptr<function, DirectionEstimates>) {
    var d: DirectionSample;
    if k < plan.m {
        d = sample_direction(c, stream);
    } else {
        d = cone_light_sample(c, plan, k - plan.m, light_dim, *stream);
    }
    if uses_control_variate() && k < plan.m {
        (*sum).brdf += control_variate_direction_term(c, d, plan);
    }
    if !d.valid {
        return;
    }
    let origin = offset_ray_origin(c.s.p, c.s.ng, d.wi);
    let t_max = direction_reach(d, origin);
    if t_max <= 0.0 {
        return;
    }
    if EMITTER_LIST && d.light == NO_LIGHT {
        (*sum).brdf += direction_sample_to_emitters(c, d, plan, origin, t_max, rays);
        return;
    }
    *rays += 1u;
    let hit = trace_closest(origin, d.wi, t_max);
    if hit.found {
        let e = surface_at(hit, d.wi);
        if CONE_SAMPLING && d.light != NO_LIGHT {
            (*sum).light += cone_sample_value(d, e);
        } else {
            (*sum).brdf += direction_sample_value(c.s.p, d, plan, hit.tri, e);
        }
    }
}

@compute @workgroup_size(64, 1, 1)
fn render_direction_pass(@builtin(global_invocation_id) gid: vec3u) {
    load_frame();
    let i = gid.x;
    if i >= deferred_header.pending {
        return;
    }
    let q = deferred[i];
    // The camera ray again, from the start of the sample's stream.
    let x = q.pixel % frame.width;
    let y = q.pixel / frame.width;
    var stream = pixel_sample_stream(q.pixel, q.sample);
    let ray = camera_ray(vec2u(x, y), sample_2d(&stream));
    let hit = Hit(0.0, q.b1, q.b2, q.tri, true);
    let c = shading_context(surface_at(hit, ray.dir), ray.dir);
    let plan = SamplePlan(q.light_samples, q.light_weighting, q.direction_samples);
    // The stream where the light samples left it, after their requests.
    stream.dim = q.stream_dim;
    var rays = q.rays;
    let found = estimate_direction_samples(c, plan, q.stream_dim - light_sample_requests(plan), &stream, &rays);
    if !loop_budget_held() {
        counters[q.pixel].truncated += 1u;
        return;
    }
    add_sample(q.pixel, Estimate(q.emitted, q.light + found.light, found.brdf), rays);
}

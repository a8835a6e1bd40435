// waiting_rays.wgsl: camera samples whose direction rays wait, in the thread or for the
// invocation's end, so that the lanes of a SIMD group trace theirs together
// (WAITING_DIRECTION_RAYS, features.wgsl).
//
// Where a render traces a BRDF ray for some camera samples and not for others, the loop of
// estimate_radiance (direct.wgsl) traces them on a pass of their own, which a SIMD group runs if any of its lanes has such a ray:
// under `veach scale`'s 10,000 lights 30% of camera samples have one, and 94% of lavapipe's 8-lane
// groups (1 - 0.7^8) run that pass. Here a sample's direction ray may instead wait in its
// invocation, beside its value so far, and be traced on a later sample's pass. A lane traces its
// waiting ray when some lane of its group must trace (a second ray would wait, or its run of
// samples ends: any_lane, lanes.wgsl), so that lanes trace together: about 0.54 passes per sample
// instead of 0.94 there (scripts/waiting-rays-model.py). The samples are the same, and their values too, bit for bit;
// only the order in which a pixel adds them up changes, and with it the sums' rounding
// (docs/performance.md, "Direction rays that wait for the lanes beside them").

// A camera sample whose direction ray waits: its value without that ray, and the ray with what
// weighs its hit (the shading point for the light pdf of the MIS weight, the sample's density and
// throughput; the plan is the strategy's, the same for every sample).
struct WaitingSample {
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

// What one camera sample's passes complete: the sample itself, unless its direction ray waits,
// and the sample that waited before it, where its ray was traced on these passes.
struct WaitingOutcome {
    current: vec3f,
    current_complete: bool,
    earlier: vec3f,
    earlier_complete: bool,
}

const CAMERA_PASS: u32 = 0u;
const EARLIER_PASS: u32 = 1u;
const CURRENT_PASS: u32 = 2u;

// estimate_radiance for a kernel whose camera samples take at most one direction sample (MIS, at
// most one BRDF sample, no cone samples), with the direction ray of the sample `waiting` holds,
// if any, traced here or left to wait on. `finish`: no ray may be left waiting after this sample
// (the last of the invocation's run, or every one: take_samples_waiting).
fn estimate_radiance_waiting(ray: Ray, stream: ptr<function, SampleStream>, rays: ptr<function, u32>, waiting: ptr<function, WaitingSample>, finish: bool) -> WaitingOutcome {
    var out = WaitingOutcome(vec3f(0.0), true, vec3f(0.0), false);
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var c: ShadingContext;
    let plan = strategy_plan();
    var origin = ray.origin;
    var d = DirectionSample(ray.dir, 1.0, vec3f(1.0), false, true, NO_LIGHT);
    var t_max = RAY_INF;
    // The shading point of the sample whose direction ray this pass traces.
    var at = vec3f(0.0);
    var this_pass = CAMERA_PASS;
    var light_dim = 0u;
    var seen = false;
    var next = NextDirection(d, origin, 0.0);
    next.d.valid = false;
    var trace_earlier = false;
    var trace_current = false;
    let held = (*waiting).held;
    // One closest-hit call site for all three passes (estimate_radiance says why).
    loop {
        *rays += 1u;
        let hit = trace_closest(origin, d.wi, t_max);
        if hit.found {
            let s = surface_at(hit, d.wi);
            if this_pass == CAMERA_PASS {
                c = shading_context(s, ray.dir);
                if frame.hide_emitters == 0u {
                    e.emitted = emitted_radiance(s);
                }
                light_dim = reserve_light_requests(plan, stream);
                if plan.m > 0u {
                    next = next_direction_sample(c, plan, 0u, light_dim, stream, rays, &e);
                }
            } else {
                let value = direction_sample_value(at, d, plan, hit.tri, s);
                if this_pass == EARLIER_PASS {
                    out.earlier = value;
                } else {
                    e.brdf = value;
                }
            }
        }
        if this_pass == CAMERA_PASS {
            seen = hit.found;
            // Every lane runs this pass, so all of them vote. A lane must trace where its new ray
            // would be a second one waiting, or where it finishes; then every lane with a ray
            // traces it, a waiting one first.
            let fresh = next.d.valid;
            let trace_now = any_lane((held && fresh) || (finish && (held || fresh)));
            trace_earlier = trace_now && held;
            trace_current = fresh && ((trace_now && !held) || finish);
        }
        if this_pass == CAMERA_PASS && trace_earlier {
            this_pass = EARLIER_PASS;
            let w = *waiting;
            d = DirectionSample(w.wi, w.pdf, w.throughput, w.mis, true, NO_LIGHT);
            origin = w.origin;
            t_max = w.t_max;
            at = w.p;
            tree_point = w.p;
            tree_normal = w.n;
        } else if this_pass != CURRENT_PASS && trace_current {
            this_pass = CURRENT_PASS;
            d = next.d;
            origin = next.origin;
            t_max = next.t_max;
            at = c.s.p;
            tree_point = c.s.p;
            tree_normal = c.frame.n;
        } else {
            break;
        }
    }
    if trace_earlier {
        // As estimate_radiance sums a sample: emitted + light, then its direction sample.
        out.earlier = (*waiting).partial + out.earlier;
        out.earlier_complete = true;
        (*waiting).held = false;
    }
    if !seen {
        return out;
    }
    // The light samples choose from this sample's point (the earlier sample's pass moved it).
    tree_point = c.s.p;
    tree_normal = c.frame.n;
    var light_stream = SampleStream((*stream).index, (*stream).seed, light_dim);
    e.light = estimate_light(c, plan, &light_stream, rays);
    let partial = e.emitted + e.light;
    if next.d.valid && !trace_current {
        *waiting = WaitingSample(partial, c.s.p, c.frame.n, next.origin, next.t_max, next.d.wi, next.d.pdf, next.d.throughput, next.d.mis, true);
        out.current_complete = false;
    }
    out.current = partial + e.brdf;
    return out;
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

// `render`'s samples of pixel `px` from sample `start`, with direction rays that wait
// (estimate_radiance_waiting). Where a sample is cut short by Mesa 22's loop limit
// (loop_budget_held) while an earlier one waits, the samples after that one are already in the
// sums: they fall back to the sums kept when it began to wait, and a later dispatch takes all of
// them again. A run may then keep no sample at all, so the samples left out are taken again with
// frame.finish_samples set (Accumulation::take_left_out_samples), where no ray waits and a run
// keeps every sample before the one cut short, as render's own loop does.
fn take_samples_waiting(px: BandPixel, start: u32, sum: ptr<function, vec4f>, sum_sq: ptr<function, vec4f>, count: ptr<function, PixelCounters>) {
    var waiting: WaitingSample;
    waiting.held = false;
    var kept_sum = *sum;
    var kept_sum_sq = *sum_sq;
    var kept_count = *count;
    var kept_from = start;
    var k = start;
    // Tested at its end, as render's loop (which says why).
    loop {
        var stream = pixel_sample_stream(px.index, k);
        let ray = camera_ray(vec2u(px.x, px.y), sample_2d(&stream));
        var rays = 0u;
        let held = waiting.held;
        let finish = frame.finish_samples != 0u || k + 1u >= frame.sample_start + frame.sample_count;
        let o = estimate_radiance_waiting(ray, &stream, &rays, &waiting, finish);
        if !loop_budget_held() {
            if held {
                *sum = kept_sum;
                *sum_sq = kept_sum_sq;
                (*count).rays = kept_count.rays;
                (*count).nonfinite = kept_count.nonfinite;
                (*count).truncated += k - kept_from + 1u;
            } else {
                (*count).truncated += 1u;
            }
            break;
        }
        (*count).rays += rays;
        if o.earlier_complete {
            add_to_sums(o.earlier, sum, sum_sq, count);
        }
        if o.current_complete {
            add_to_sums(o.current, sum, sum_sq, count);
        } else {
            kept_sum = *sum;
            kept_sum_sq = *sum_sq;
            kept_count = *count;
            kept_from = k;
        }
        k++;
        if k >= frame.sample_start + frame.sample_count {
            break;
        }
    }
}

// A camera sample in straight-line code up to its direction sample's ray, which it returns (held
// where it needs one; `partial` is then the rest of the sample) instead of tracing it:
// estimate_radiance_straight traces it right away, take_samples_deferred after the run.
struct Deferring {
    e: Estimate,
    ray: WaitingSample,
}

fn estimate_radiance_deferring(ray: Ray, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> Deferring {
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var held = WaitingSample(vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0), 0.0, vec3f(0.0), 0.0, vec3f(0.0), false, false);
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
        held = WaitingSample(vec3f(0.0), c.s.p, c.frame.n, next.origin, next.t_max, next.d.wi, next.d.pdf, next.d.throughput, next.d.mis, next.d.valid);
    }
    var light_stream = SampleStream((*stream).index, (*stream).seed, light_dim);
    e.light = estimate_light(c, plan, &light_stream, rays);
    held.partial = e.emitted + e.light + e.brdf;
    return Deferring(e, held);
}

// What a held direction ray adds (the direction sample's MIS-weighted emission where it meets a
// light), traced at this call's closest-hit call site. Strategies whose plan is the same at every
// point only (not mis-lobes), as estimate_radiance_deferring's callers are.
fn held_ray_value(w: WaitingSample, rays: ptr<function, u32>) -> vec3f {
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
    var q0: WaitingSample;
    var q1: WaitingSample;
    var q2: WaitingSample;
    var q3: WaitingSample;
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

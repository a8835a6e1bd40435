// direct.wgsl: the direct-lighting estimator of one camera sample.
//
// For each camera sample: L = L_e + estimate of  ∫ f(wo, wi) L_d(wi) |cos θ_i| dω_i  at the first
// hit, by the strategy in frame.strategy:
//   uniform: (1/N) Σ f L cos / (1/2π)                         (hemisphere directions)
//   brdf:    (1/m) Σ f L cos / p_brdf                          (glTF BRDF sampling)
//   light:   (1/n) Σ f L_e cos / (P(light) p_ω)                (area sampling, r²/(|cos θ_l| A);
//            or a round light's bounding cone, 1/Ω: those samples are traced as direction samples)
//   mis:     (1/n) Σ w_l f L_e cos / p_l + (1/m) Σ w_b f L_e cos / p_b   (Veach & Guibas 1995, eq. 8)
//   mis-lobes: f = f_diffuse + f_glossy; the diffuse lobe by light sampling alone (n + m light
//            samples where there is no glossy lobe), the glossy lobe by MIS of n light samples
//            and m samples of that lobe (Veach & Guibas 1995, eq. 8, counts fixed per point; the
//            m become light samples where no light is wider than the lobe)
// Delta lights are reached only through light sampling and always get MIS weight 1.

// The parts of one camera sample's estimate: emission seen directly, light-sample and
// direction-sample (BRDF or uniform) contributions, MIS-weighted where the strategy is MIS.
struct Estimate {
    emitted: vec3f,
    light: vec3f,
    brdf: vec3f,
}

// Direction sample `taken` of a camera sample (the m BRDF samples, then the light samples that are
// directions in a round light's cone), valid where it needs a ray: one that adds something where
// it finds a light, and crosses some light's bounding sphere (traced only as far as that). What it
// adds without the loop's pass goes to e.brdf: the control variate's term, or with the emitters'
// list the whole sample.
struct NextDirection {
    d: DirectionSample,
    origin: vec3f,
    t_max: f32,
}

fn next_direction_sample(c: ShadingContext, plan: SamplePlan, taken: u32, light_dim: u32, stream: ptr<function, SampleStream>, rays: ptr<function, u32>, e: ptr<function, Estimate>) -> NextDirection {
    var d: DirectionSample;
    if taken < plan.m {
        d = sample_direction(c, stream);
        if uses_control_variate() {
            (*e).brdf += control_variate_direction_term(c, d, plan);
        }
    } else {
        d = cone_light_sample(c, plan, taken - plan.m, light_dim, *stream);
    }
    var origin = vec3f(0.0);
    var t_max = 0.0;
    if d.valid {
        origin = offset_ray_origin(c.s.p, c.s.ng, d.wi);
        t_max = direction_reach(d, origin);
        d.valid = t_max > 0.0;
        // With the emitters' list a BRDF sample needs no pass of the loop.
        if EMITTER_LIST && d.valid && d.light == NO_LIGHT {
            (*e).brdf += direction_sample_to_emitters(c, d, plan, origin, t_max, rays);
            d.valid = false;
        }
    }
    return NextDirection(d, origin, t_max);
}

// estimate_radiance in straight-line code, for a kernel whose camera samples take at most one
// direction sample and no cone passes (STRAIGHT_LINE_SAMPLE, features.wgsl): the camera ray, the
// shading at its hit, the direction sample and the light samples (estimate_radiance_deferring),
// then the direction sample's ray at a second closest-hit call site. The same samples, so the
// same image. On Mesa
// 22.3, which runs a loop's whole body on every pass, the loop's second pass runs the camera hit's
// shading and the next sample's code again under a mask; here they run once, at the cost of a
// second traversal that runs a step even where no lane has a ray (docs/performance.md, "Camera
// samples in straight-line code").
fn estimate_radiance_straight(ray: Ray, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> Estimate {
    let o = estimate_radiance_deferring(ray, stream, rays);
    var e = o.e;
    if o.ray.held {
        e.brdf += held_ray_value(o.ray, rays);
    }
    return e;
}

// The camera ray, then the strategy's direction samples and light samples at the surface it hits.
// Each pass of the loop traces one closest-hit ray, the camera's first and then each direction
// sample's, so the kernel inlines the closest-hit traversal (and surface_at) once: on lavapipe a
// second call site, even one never reached, made the mis-lobes kernel 6-10% slower
// (docs/performance.md). Where that pays, a kernel takes estimate_radiance_straight instead.
fn estimate_radiance(ray: Ray, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> Estimate {
    // Camera rays by footprint lists take the straight-line form too: they have no closest-hit
    // call site of their own (trace_camera_ray).
    if (STRAIGHT_LINE_SAMPLE || FOOTPRINT_SLOTS > 0u) && AT_MOST_ONE_DIRECTION_SAMPLE && !CONE_SAMPLING {
        return estimate_radiance_straight(ray, stream, rays);
    }
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var c: ShadingContext;
    var plan = SamplePlan(0u, LIGHT_ALONE, 0u);
    var origin = ray.origin;
    var d = DirectionSample(ray.dir, 1.0, vec3f(1.0), false, true, NO_LIGHT);
    var t_max = RAY_INF;
    var at_camera = true;
    var taken = 0u;
    var light_dim = 0u;
    var cone_sum = vec3f(0.0);
    loop {
        *rays += 1u;
        var hit: Hit;
        if CAMERA_LIST && at_camera {
            hit = trace_camera(d.wi);
        } else {
            hit = trace_closest(origin, d.wi, t_max);
        }
        if hit.found {
            let s = surface_at(hit, d.wi);
            if at_camera {
                c = shading_context(s, ray.dir);
                if frame.hide_emitters == 0u {
                    e.emitted = emitted_radiance(s);
                }
                plan = sample_plan(c);
                // The light samples are taken after the loop, with the sampler requests they
                // would take here (the same image): the direction samples' passes then do not
                // carry their code, which Mesa 22.3 runs under a mask where no lane takes it
                // (10,000 lights, MIS 1 + 1: 0.93x; docs/performance.md).
                light_dim = reserve_light_requests(plan, stream);
            } else if CONE_SAMPLING && d.light != NO_LIGHT {
                cone_sum += cone_sample_value(d, s);
            } else {
                e.brdf += direction_sample_value(c.s.p, d, plan, hit.tri, s);
            }
        } else if at_camera {
            return e;
        }
        at_camera = false;
        // The next direction sample that needs a ray (next_direction_sample). With at most one
        // direction sample (and no cone passes) that is one step, not a loop (features.wgsl,
        // AT_MOST_ONE_DIRECTION_SAMPLE).
        d.valid = false;
        var next = NextDirection(d, origin, t_max);
        if AT_MOST_ONE_DIRECTION_SAMPLE && !CONE_SAMPLING {
            if taken < plan.m {
                next = next_direction_sample(c, plan, taken, light_dim, stream, rays, &e);
                taken += 1u;
            }
        } else {
            // Tested at its end (`render` says why).
            let end = plan.m + cone_passes(plan);
            if taken < end {
                loop {
                    next = next_direction_sample(c, plan, taken, light_dim, stream, rays, &e);
                    taken += 1u;
                    if next.d.valid || taken >= end {
                        break;
                    }
                }
            }
        }
        d = next.d;
        origin = next.origin;
        t_max = next.t_max;
        if !d.valid {
            break;
        }
    }
    if plan.m > 0u {
        e.brdf /= f32(plan.m);
    }
    var light_stream = SampleStream((*stream).index, (*stream).seed, light_dim);
    e.light = estimate_light(c, plan, &light_stream, rays);
    if CONE_SAMPLING && plan.n > 0u {
        e.light += cone_sum / f32(plan.n);
    }
    return e;
}

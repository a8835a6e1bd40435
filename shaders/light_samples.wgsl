// light_samples.wgsl: light samples at a shading point: a point or direction on a light, a shadow
// ray, a weight.

// A light sample seen from the surface, before any weighting: g = f L_e |cos θ_i| (zero when
// occluded or facing away), and the density with which the light strategy (selection included)
// produces its direction.
struct LightSampleEval {
    g: vec3f,
    p_light: f32,
    is_delta: bool,
    // The glossy lobe's part of g, and the sampled direction in the shading frame.
    g_glossy: vec3f,
    wi: vec3f,
    // With the control variate (control_variate.wgsl): g's counterpart k L_e |cos θ_i|, taken
    // before the shadow ray; zero without it.
    g_cv: vec3f,
}

// One sample of light `index`, chosen with probability p_select, with its shadow ray traced;
// u is the 2D sample (what the light choice left of it) for the point on the light.
fn trace_light_sample(c: ShadingContext, index: u32, p_select: f32, u: vec2f, rays: ptr<function, u32>) -> LightSampleEval {
    var r = LightSampleEval(vec3f(0.0), 0.0, false, vec3f(0.0), vec3f(0.0), vec3f(0.0));
    let ls = sample_light(index, c.s.p, u);
    if ls.pdf <= 0.0 || !(p_select > 0.0) {
        return r;
    }
    let wi = frame_to_local(c.frame, ls.wi);
    r.is_delta = HAS_DELTA_LIGHTS && ls.is_delta;
    // A delta light's "pdf" is the probability of choosing it; no direction density.
    r.p_light = select(p_select * ls.pdf, p_select, r.is_delta);
    r.wi = wi;
    // The control variate's g is not clipped to the geometric normal's hemisphere: it counts
    // below it too, where f L_e V cos is zero.
    if wi.z > 0.0 {
        r.g_cv = control_variate_light_integrand(c, ls.value, wi, r.is_delta);
    }
    if dot(ls.wi, c.s.ng) <= 0.0 {
        return r;
    }
    let lobes = bsdf_eval_lobes(c.bsdf, c.wo, wi);
    let f = lobes.diffuse + lobes.glossy;
    if wi.z <= 0.0 || all(f == vec3f(0.0)) || all(ls.value == vec3f(0.0)) {
        return r;
    }
    // Both ends of the shadow ray are offset off their surfaces (far from the origin a fraction
    // of the distance is less than the rounding of the light's position: tests/stress.rs, the
    // Cornell box moved to 1e5), and the ray is aimed from the one to the other, as pbrt-v4's
    // SpawnRayTo does. Along the sampled direction from the offset origin, the ray ran parallel
    // to the true one, displaced by the origin's offset, and crossed a light seen at a slant
    // before its end: a light tilted 1° over the floor lit the floor 10× too dark.
    let origin = offset_ray_origin(c.s.p, c.s.ng, ls.wi);
    var shadow_dir = ls.wi;
    var t_max = RAY_INF;
    if ls.dist < RAY_INF {
        let to_end = ls.shadow_end - origin;
        let len = length(to_end);
        if len <= 0.0 {
            return r;
        }
        shadow_dir = to_end / len;
        t_max = len * (1.0 - 1.0e-4);
    }
    *rays += 1u;
    if trace_occluded(origin, shadow_dir, t_max, ls.skip) {
        return r;
    }
    r.g = f * ls.value * wi.z;
    r.g_glossy = lobes.glossy * ls.value * wi.z;
    return r;
}

// A light sample's contribution g / p_light, MIS-weighted as the plan says. A delta light has
// no density to weigh against: weight 1.
// With the control variate the value is that of g − g_cv (g_cv is zero without it, and for
// mis-lobes, which does not take it).
fn light_sample_value(c: ShadingContext, s: LightSampleEval, plan: SamplePlan) -> vec3f {
    if all(s.g == vec3f(0.0)) && all(s.g_cv == vec3f(0.0)) {
        return vec3f(0.0);
    }
    let g = s.g - s.g_cv;
    if s.is_delta || plan.light_weighting == LIGHT_ALONE || plan.m == 0u {
        return g / s.p_light;
    }
    if plan.light_weighting == LIGHT_MIS {
        let w = mis_weight(f32(plan.n), s.p_light, f32(plan.m), bsdf_pdf(c.bsdf, c.wo, s.wi));
        return w * g / s.p_light;
    }
    // LIGHT_LOBE_MIS: the density of sampling the glossy lobe alone (sample_direction); m > 0
    // there only for a GGX lobe or a mirror, and a mirror's g_glossy is zero.
    let p_glossy = select(ggx_vndf_pdf(c.wo, s.wi, c.bsdf.alpha), 0.0, c.bsdf.delta);
    let w = mis_weight(f32(plan.n), s.p_light, f32(plan.m), p_glossy);
    return (s.g - s.g_glossy + w * s.g_glossy) / s.p_light;
}

// How many light samples, and so sampler requests, estimate_light_samples takes.
fn light_sample_requests(plan: SamplePlan) -> u32 {
    if light_count() == 0u || plan.n == 0u {
        return 0u;
    }
    return select(plan.n, plan.n * light_count(), active_light_selection() == SELECT_EACH);
}

// The stream's dimension where a camera sample's light-sample requests begin, with the stream
// moved past them: the light samples are taken after the direction samples (estimate_light), with
// the numbers they would have taken first.
fn reserve_light_requests(plan: SamplePlan, stream: ptr<function, SampleStream>) -> u32 {
    let light_dim = (*stream).dim;
    (*stream).dim += light_sample_requests(plan);
    return light_dim;
}

// Light sample k of a plan: the light (the k / n-th with SELECT_EACH, else one chosen by the
// frame's selection), the probability of choosing it, and the 2D sample left for the light itself.
// One request of the stream.
struct LightChoice {
    index: u32,
    p_select: f32,
    u: vec2f,
}

fn choose_light(plan: SamplePlan, k: u32, stream: ptr<function, SampleStream>) -> LightChoice {
    var ch = LightChoice(k / plan.n, 1.0, sample_2d(stream));
    if active_light_selection() != SELECT_EACH {
        let chosen = select_light_with_pmf(ch.u.x);
        ch.index = chosen.pick.index;
        ch.u.x = chosen.pick.u;
        ch.p_select = chosen.pmf;
    }
    return ch;
}

// Is a light sample with this choice traced as a direction sample (a round light's cone)?
fn traced_as_direction(ch: LightChoice) -> bool {
    return CONE_SAMPLING && cone_sampled(light_at(ch.index));
}

// The plan's light samples: n of each light (SELECT_EACH), or n of one light chosen per sample;
// the sum of those taken here, over n (samples of a round light's cone are direction samples,
// estimate_radiance). One call site of the shadow-ray traversal, so that it is inlined once.
fn estimate_light_samples(c: ShadingContext, plan: SamplePlan, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> vec3f {
    let total = light_sample_requests(plan);
    if total == 0u {
        return vec3f(0.0);
    }
    if !SHADOW_RAY_LIGHTS {
        // All of them are cone samples; the stream moves past their requests all the same.
        (*stream).dim += total;
        return vec3f(0.0);
    }
    var sum = vec3f(0.0);
    if AT_MOST_ONE_LIGHT_REQUEST {
        sum = light_request_value(c, plan, 0u, stream, rays);
    } else {
        // Tested at its end (`render` says why); total is at least 1 here.
        var k = 0u;
        loop {
            sum += light_request_value(c, plan, k, stream, rays);
            k++;
            if k >= total {
                break;
            }
        }
    }
    return sum / f32(plan.n);
}

// The light part of a camera sample's estimate: its light samples, and with the control variate
// the unshadowed light's integral (control_variate.wgsl).
fn estimate_light(c: ShadingContext, plan: SamplePlan, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> vec3f {
    var light = estimate_light_samples(c, plan, stream, rays);
    if uses_control_variate() {
        light += unshadowed_light_integral(c);
    }
    return light;
}

// Light sample k of the plan, traced with a shadow ray (zero where it is a direction sample).
fn light_request_value(c: ShadingContext, plan: SamplePlan, k: u32, stream: ptr<function, SampleStream>, rays: ptr<function, u32>) -> vec3f {
    let ch = choose_light(plan, k, stream);
    if traced_as_direction(ch) {
        return vec3f(0.0);
    }
    return light_sample_value(c, trace_light_sample(c, ch.index, ch.p_select, ch.u, rays), plan);
}

// Light sample k of the plan where it is a direction in a round light's bounding cone (invalid
// otherwise: a shadow-ray sample, or one that adds nothing). Its throughput is the light sample's
// MIS-weighted f |cos θ_i| / p_light (light_sample_value with L_e = 1); what its closest hit finds
// counts where that is the chosen light (cone_sample_value). `light_dim` is the stream's first
// light-sample request.
fn cone_light_sample(c: ShadingContext, plan: SamplePlan, k: u32, light_dim: u32, stream: SampleStream) -> DirectionSample {
    var d = DirectionSample(c.s.ns, 0.0, vec3f(0.0), false, false, NO_LIGHT);
    var light_stream = SampleStream(stream.index, stream.seed, light_dim + k);
    let ch = choose_light(plan, k, &light_stream);
    if !traced_as_direction(ch) || !(ch.p_select > 0.0) {
        return d;
    }
    let cone = bounding_cone(light_at(ch.index), c.s.p);
    d.wi = sample_cone(cone, ch.u);
    d.pdf = ch.p_select * cone_pdf(cone);
    d.light = ch.index;
    let wi = frame_to_local(c.frame, d.wi);
    if wi.z <= 0.0 || dot(d.wi, c.s.ng) <= 0.0 {
        return d;
    }
    let lobes = bsdf_eval_lobes(c.bsdf, c.wo, wi);
    let s = LightSampleEval((lobes.diffuse + lobes.glossy) * wi.z, d.pdf, false, lobes.glossy * wi.z, wi, vec3f(0.0));
    d.throughput = light_sample_value(c, s, plan);
    d.valid = any(d.throughput != vec3f(0.0));
    return d;
}

// What a cone sample of light d.light found at surface `e`: that light's emitted radiance times
// the sample's throughput; nothing where the ray met anything else first (occluded).
fn cone_sample_value(d: DirectionSample, e: SurfaceHit) -> vec3f {
    if e.light != d.light {
        return vec3f(0.0);
    }
    return d.throughput * emitted_radiance(e);
}

// How far a direction sample's ray need go: to where it leaves the bounding sphere of the light a
// cone sample aims at, or as far as any light (emitter_reach).
fn direction_reach(d: DirectionSample, origin: vec3f) -> f32 {
    if CONE_SAMPLING && d.light != NO_LIGHT {
        let light = light_at(d.light);
        return sphere_exit(origin, d.wi, light.position, light.bound_radius) * (1.0 + 1.0e-4);
    }
    return emitter_reach(origin, d.wi);
}

// How many of a plan's light samples may be cone samples, and so passes of the direction loop.
fn cone_passes(plan: SamplePlan) -> u32 {
    if !samples_cones() {
        return 0u;
    }
    return light_sample_requests(plan);
}

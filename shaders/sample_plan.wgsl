// sample_plan.wgsl: how many light and direction samples a strategy takes at a shading point,
// and how they are weighted; mis-lobes decides its counts per point here.

// How a light sample is weighted (SamplePlan.light_weighting).
const LIGHT_ALONE: u32 = 0u;
// Against sampling the whole BSDF (mis).
const LIGHT_MIS: u32 = 1u;
// The diffuse lobe's part alone, the glossy lobe's part against sampling that lobe (mis-lobes).
const LIGHT_LOBE_MIS: u32 = 2u;

// What the strategy takes at one shading point: n light samples (per light with SELECT_EACH),
// weighted as light_weighting says, and m direction samples. The counts are fixed from the point
// alone before any sampling, which keeps MIS unbiased when they vary (Veach & Guibas 1995, eq. 8).
struct SamplePlan {
    n: u32,
    light_weighting: u32,
    m: u32,
}

// mis-lobes: which samples a point gets.

// mis-lobes looks at the lights one by one up to this many; past it every glossy lobe keeps its
// own samples (the choice below costs a loop over the lights per shading point).
const MAX_ALLOCATION_LIGHTS: u32 = 16u;

// Would samples of the glossy lobe find some area light with a higher density than light
// sampling does? Per area light, the lobe's density in the light's direction nearest to the lobe
// (the mirror direction, or the edge of the light's bounding cone nearest to it) is compared with
// the light strategy's density on that light, about P(light) / Ω with Ω the bounding cone's solid
// angle, each times its sample count (the balance heuristic's n p). Where no light passes, the lobe
// samples would get little weight (a sharp lobe next to a small light, Veach's small lights over
// every plate) and mis-lobes spends them as light samples. The answer depends on the point alone,
// fixed before sampling, so the estimator stays unbiased whatever it says (Veach & Guibas 1995,
// eq. 8); only its variance depends on choosing well.
fn glossy_lobe_outsamples_lights(c: ShadingContext) -> bool {
    if !HAS_AREA_LIGHTS || c.bsdf.delta || light_count() > MAX_ALLOCATION_LIGHTS {
        return true;
    }
    let axis = frame_to_world(c.frame, vec3f(-c.wo.x, -c.wo.y, c.wo.z));
    let n_light = f32(frame.light_samples);
    let m_lobe = f32(frame.brdf_samples);
    // The lobe's highest density, at the mirror direction (D peaks at h = n, 1 / (π α²)), times
    // the count: a light fails the test below wherever m p_peak Ω_max <= n P(light), with
    // Ω_max = 2π r² / dist² >= Ω, which needs no square root (most lights, on rough lobes).
    let m_peak = m_lobe * smith_g1(c.wo.z, c.bsdf.alpha) / (4.0 * c.wo.z * PI * c.bsdf.alpha * c.bsdf.alpha);
    // Tested at its end (`render` says why); HAS_AREA_LIGHTS, so there is a light.
    var li = 0u;
    loop {
        if glossy_lobe_outsamples_light(c, li, axis, n_light, m_peak, m_lobe) {
            return true;
        }
        li++;
        if li >= light_count() {
            break;
        }
    }
    return false;
}

// The test above for light li: false for lights other than area lights.
fn glossy_lobe_outsamples_light(c: ShadingContext, li: u32, axis: vec3f, n_light: f32, m_peak: f32, m_lobe: f32) -> bool {
    let light = light_at(li);
    if light.kind != LIGHT_AREA {
        return false;
    }
    let d = light.position - c.s.p;
    let dist_sq = dot(d, d);
    let r_sq = light.bound_radius * light.bound_radius;
    if dist_sq <= r_sq {
        return true;
    }
    // Below the horizon, or too small for the lobe even at its peak.
    if dot(d, c.s.ns) <= -light.bound_radius || m_peak * 2.0 * PI * r_sq <= n_light * light_selection_pdf(li) * dist_sq {
        return false;
    }
    let dist = sqrt(dist_sq);
    let to_centre = d / dist;
    let sin_t = light.bound_radius / dist;
    let cos_t = sqrt(max(0.0, 1.0 - sin_t * sin_t));
    // Solid angle of the cone, 2π(1 − cos θ) written without the cancellation.
    let omega = 2.0 * PI * sin_t * sin_t / (1.0 + cos_t);
    var nearest = axis;
    let cos_phi = dot(axis, to_centre);
    if cos_phi < cos_t {
        let perp = axis - cos_phi * to_centre;
        let len = length(perp);
        nearest = select(to_centre, cos_t * to_centre + (sin_t / len) * perp, len > 0.0);
    }
    let wi = frame_to_local(c.frame, nearest);
    let p_lobe = select(0.0, ggx_vndf_pdf(c.wo, wi, c.bsdf.alpha), wi.z > 0.0);
    let p_light = light_selection_pdf(li) / max(omega, 1.0e-30);
    return m_lobe * p_lobe > n_light * p_light;
}

// MIS per lobe (mis-lobes): the diffuse lobe is estimated by light sampling alone, the glossy
// lobe by MIS between light sampling and sampling that lobe itself. Veach's multi-sample model
// (Veach & Guibas 1995, eq. 8; thesis §9.2) lets the counts differ from point to point as long as
// they are fixed before sampling: at a point without a glossy lobe the m BRDF samples become
// light samples (a diffuse lobe's BRDF samples rarely find a small light, and the balance
// heuristic would give them little weight); at a point with one, n light samples serve both lobes
// and m samples go to the glossy lobe, weighted against light sampling with the counts, unless
// glossy_lobe_outsamples_lights finds no light they would sample better: then they become light
// samples too. A mirror lobe's one direction needs one sample.
fn lobe_mis_plan(c: ShadingContext) -> SamplePlan {
    // The host refuses light_samples = 0 for this strategy (the diffuse lobe needs them).
    if light_count() == 0u {
        return SamplePlan(0u, LIGHT_LOBE_MIS, 0u);
    }
    let lobe_sampled = has_glossy_lobe(c.bsdf) && glossy_lobe_outsamples_lights(c);
    if !lobe_sampled {
        return SamplePlan(frame.light_samples + frame.brdf_samples, LIGHT_LOBE_MIS, 0u);
    }
    let m = select(frame.brdf_samples, min(frame.brdf_samples, 1u), c.bsdf.delta);
    return SamplePlan(frame.light_samples, LIGHT_LOBE_MIS, m);
}

fn sample_plan(c: ShadingContext) -> SamplePlan {
    if active_strategy() == STRATEGY_MIS_LOBES {
        return lobe_mis_plan(c);
    }
    return strategy_plan();
}

// The plan of every strategy but mis-lobes: the same at every point.
fn strategy_plan() -> SamplePlan {
    switch active_strategy() {
        case STRATEGY_UNIFORM, STRATEGY_BRDF: {
            return SamplePlan(0u, LIGHT_ALONE, frame.brdf_samples);
        }
        case STRATEGY_LIGHT: {
            return SamplePlan(frame.light_samples, LIGHT_ALONE, 0u);
        }
        default: {
            return SamplePlan(frame.light_samples, LIGHT_MIS, frame.brdf_samples);
        }
    }
}

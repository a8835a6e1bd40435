// direction_samples.wgsl: direction samples (uniform, BRDF, glossy lobe) at a shading point: a
// direction, a closest-hit ray, what it finds.

// A direction sampled at the shading point, waiting for its closest hit.
struct DirectionSample {
    // World direction and its density.
    wi: vec3f,
    pdf: f32,
    // f |cos θ_i| / pdf for the sampled lobes, or a mirror's reflectance over its choice
    // probability: the radiance the ray finds times this is the sample's estimate.
    throughput: vec3f,
    // Weigh what it finds against light sampling (false for uniform, BRDF alone and mirrors).
    mis: bool,
    // False where the direction adds nothing (below the surface, f = 0): no ray is traced.
    valid: bool,
    // NO_LIGHT for a BRDF or uniform sample; for a light sample in a round light's cone
    // (cone_light_sample), the light it counts.
    light: u32,
}

// A sample with a density: f of all lobes, or of the glossy lobe alone.
fn density_sample(c: ShadingContext, wi: vec3f, pdf: f32, glossy_only: bool, mis: bool) -> DirectionSample {
    var d = DirectionSample(frame_to_world(c.frame, wi), pdf, vec3f(0.0), mis, false, NO_LIGHT);
    if pdf <= 0.0 || wi.z <= 0.0 || dot(d.wi, c.s.ng) <= 0.0 {
        return d;
    }
    let lobes = bsdf_eval_lobes(c.bsdf, c.wo, wi);
    let f = select(lobes.diffuse + lobes.glossy, lobes.glossy, glossy_only);
    d.throughput = f * wi.z / pdf;
    d.valid = any(f != vec3f(0.0));
    return d;
}

// A mirror direction: no other technique produces it (MIS weight 1), and its estimate is the
// reflectance over the probability of choosing the mirror lobe times the radiance found.
fn mirror_sample(c: ShadingContext, wi: vec3f, reflectance_over_pdf: vec3f) -> DirectionSample {
    var d = DirectionSample(frame_to_world(c.frame, wi), 1.0, reflectance_over_pdf, false, false, NO_LIGHT);
    d.valid = dot(d.wi, c.s.ng) > 0.0;
    return d;
}

// The strategy's next direction sample:
//   uniform: the hemisphere around the shading normal, pdf 1/2π;
//   brdf, mis: the glTF BRDF (a lobe chosen, then GGX visible normals or cosine; or the mirror);
//   mis-lobes: the glossy lobe alone (GGX visible normals, or the mirror direction).
fn sample_direction(c: ShadingContext, stream: ptr<function, SampleStream>) -> DirectionSample {
    let strategy = active_strategy();
    if strategy == STRATEGY_UNIFORM {
        let wi = sample_uniform_hemisphere(sample_2d(stream));
        return density_sample(c, wi, uniform_hemisphere_pdf(), false, false);
    }
    if strategy == STRATEGY_MIS_LOBES {
        let u = sample_2d(stream);
        if HAS_MIRRORS && c.bsdf.delta {
            return mirror_sample(c, vec3f(-c.wo.x, -c.wo.y, c.wo.z), mirror_reflectance(c.bsdf, c.wo.z));
        }
        let wi = reflect(-c.wo, sample_ggx_vndf(c.wo, c.bsdf.alpha, u));
        return density_sample(c, wi, ggx_vndf_pdf(c.wo, wi, c.bsdf.alpha), true, true);
    }
    let bs = bsdf_sample(c.bsdf, c.wo, sample_2d(stream));
    if HAS_MIRRORS && bs.delta {
        var d = mirror_sample(c, bs.wi, bs.delta_reflectance / bs.pdf);
        d.valid = d.valid && bs.pdf > 0.0;
        return d;
    }
    return density_sample(c, bs.wi, bs.pdf, false, strategy == STRATEGY_MIS);
}

// What a direction sample taken at shading point `p` found at surface `e` (triangle `tri`): the
// emitted radiance times its throughput, MIS-weighted against the light strategy's density for the
// same direction (zero unless `e` is on a light; that density converts the light's area pdf to
// solid angle).
fn direction_sample_value(p: vec3f, d: DirectionSample, plan: SamplePlan, tri: u32, e: SurfaceHit) -> vec3f {
    let le = emitted_radiance(e);
    if all(le == vec3f(0.0)) {
        return vec3f(0.0);
    }
    var w = 1.0;
    if d.mis && HAS_AREA_LIGHTS && e.light != NO_LIGHT && light_count() > 0u && plan.n > 0u {
        let p_light = area_light_pdf(e.light, p, triangle_positions(triangle_at(tri)), e.p);
        if p_light > 0.0 {
            w = mis_weight(f32(plan.m), d.pdf, f32(plan.n), p_light);
        }
    }
    return w * d.throughput * le;
}

// A direction sample's value where it can only add emitted radiance (everything but a cone
// sample), with EMITTER_LIST: the nearest emitter along it (trace_emitters), then a shadow ray to
// that point, short of it by the light samples' margin. What the closest hit over every triangle
// gives wherever no blocker lies within that margin: a segment from a surface to a light is what
// the baked shadow rays' blockers were chosen for (BakedTriangles::mark_blockers). The list holds
// a scene's few emitters and the shadow ray only its blockers, where the closest hit tests every
// triangle; in a BVH kernel the emitters' grid looks in the cells the ray crosses, where the
// closest hit walks the tree's depth to find that a ray passes between small lights.
fn direction_sample_to_emitters(c: ShadingContext, d: DirectionSample, plan: SamplePlan, origin: vec3f, t_max: f32, rays: ptr<function, u32>) -> vec3f {
    *rays += 1u;
    let hit = trace_emitters(origin, d.wi, t_max);
    if !hit.found {
        return vec3f(0.0);
    }
    let value = direction_sample_value(c.s.p, d, plan, hit.tri, surface_at(hit, d.wi));
    if all(value == vec3f(0.0)) || trace_occluded(origin, d.wi, hit.t * (1.0 - 1.0e-4), 0u) {
        return vec3f(0.0);
    }
    return value;
}

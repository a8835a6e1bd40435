// integrator.wgsl: the direct-lighting estimators and the compute entry point.
//
// For each camera sample: L = L_e + estimate of  ∫ f(wo, wi) L_d(wi) |cos θ_i| dω_i  at the first
// hit, by the strategy in frame.strategy:
//   uniform: (1/N) Σ f L cos / (1/2π)                         (hemisphere directions)
//   brdf:    (1/m) Σ f L cos / p_brdf                          (glTF BRDF sampling)
//   light:   (1/n) Σ f L_e cos / (P(light) p_ω)                (area sampling, r²/(|cos θ_l| A))
//   mis:     (1/n) Σ w_l f L_e cos / p_l + (1/m) Σ w_b f L_e cos / p_b   (Veach & Guibas 1995, eq. 8)
//   mis-lobes: f = f_diffuse + f_glossy; the diffuse lobe by light sampling alone (n + m light
//            samples where there is no glossy lobe), the glossy lobe by MIS of n light samples
//            and m samples of that lobe (Veach & Guibas 1995, eq. 8, counts fixed per point)
// Delta lights are reached only through light sampling and always get MIS weight 1.

struct SurfaceHit {
    p: vec3f,
    // Geometric and shading normals, both on the side the viewer is on.
    ng: vec3f,
    ns: vec3f,
    front_face: bool,
    material: u32,
    light: u32,
    // Texture coordinates (TEXCOORD_0.xy, TEXCOORD_1.xy); zero without textures.
    uvs: vec4f,
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3f) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

fn triangle_normal(v: TriangleVerts) -> vec3f {
    let c = cross(v.p1 - v.p0, v.p2 - v.p0);
    let len_sq = dot(c, c);
    return select(vec3f(0.0, 0.0, 1.0), c * inverseSqrt(len_sq), len_sq > 0.0);
}

fn surface_at(hit: Hit, ray_dir: vec3f) -> SurfaceHit {
    let v = tri_verts[hit.tri];
    let sh = tri_shading[hit.tri];
    let b0 = 1.0 - hit.b1 - hit.b2;
    let p = b0 * v.p0 + hit.b1 * v.p1 + hit.b2 * v.p2;
    var ng = triangle_normal(v);
    // Front face: counter-clockwise winding seen from the ray's origin (glTF's convention).
    let front = dot(ng, ray_dir) < 0.0;
    if !front {
        ng = -ng;
    }
    let n_interp = b0 * sh.n0 + hit.b1 * sh.n1 + hit.b2 * sh.n2;
    let len_sq = dot(n_interp, n_interp);
    var ns = select(ng, n_interp * inverseSqrt(len_sq), len_sq > 0.0);
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    let uvs = surface_uvs(hit.tri, hit.b1, hit.b2);
    ns = mapped_normal(materials[sh.material], uvs, hit.tri, ns);
    // A shading normal that faces away from the viewer would make the BRDF vanish: fall back.
    if dot(ns, -ray_dir) <= 0.0 {
        ns = ng;
    }
    return SurfaceHit(p, ng, ns, front, sh.material, sh.light, uvs);
}

// Radiance a hit surface emits back along the ray: one-sided unless the material is doubleSided.
fn emitted_radiance(s: SurfaceHit) -> vec3f {
    if !HAS_AREA_LIGHTS {
        return vec3f(0.0);
    }
    let m = materials[s.material];
    if s.front_face || m.double_sided != 0u {
        return m.emission * emission_texture(m, s.uvs);
    }
    return vec3f(0.0);
}

struct ShadingContext {
    s: SurfaceHit,
    frame: Frame,
    wo: vec3f,
    bsdf: BsdfParams,
}

// A light sample seen from the surface, before any weighting: g = f L_e |cos θ_i| (zero when
// occluded or facing away), and the densities with which the light strategy (selection
// included) and BRDF sampling produce its direction.
struct LightSampleEval {
    g: vec3f,
    p_light: f32,
    p_brdf: f32,
    is_delta: bool,
    // The glossy lobe's part of g, and the density of sampling that lobe alone (glossy_lobe_sample).
    g_glossy: vec3f,
    p_glossy: f32,
}

// One sample of light `index`, chosen with probability p_select, with its shadow ray traced.
fn trace_light_sample(c: ShadingContext, index: u32, p_select: f32, rng: ptr<function, u32>, rays: ptr<function, u32>) -> LightSampleEval {
    var r = LightSampleEval(vec3f(0.0), 0.0, 0.0, false, vec3f(0.0), 0.0);
    let u = vec3f(rng_next(rng), rng_next2(rng));
    let ls = sample_light(index, c.s.p, u);
    if ls.pdf <= 0.0 || dot(ls.wi, c.s.ng) <= 0.0 {
        return r;
    }
    let wi = frame_to_local(c.frame, ls.wi);
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
    if trace_occluded(origin, shadow_dir, t_max) {
        return r;
    }
    r.g = f * ls.value * wi.z;
    r.is_delta = HAS_DELTA_LIGHTS && ls.is_delta;
    // A delta light's "pdf" is the probability of choosing it; no direction density.
    r.p_light = select(p_select * ls.pdf, p_select, r.is_delta);
    r.p_brdf = select(bsdf_pdf(c.bsdf, c.wo, wi), 0.0, r.is_delta);
    r.g_glossy = lobes.glossy * ls.value * wi.z;
    if HAS_GLOSSY && !c.bsdf.delta && !r.is_delta {
        r.p_glossy = ggx_vndf_pdf(c.wo, wi, c.bsdf.alpha);
    }
    return r;
}

// One light sample, weighted: g / p_light, times the MIS weight against BRDF sampling.
fn light_sample_contribution(c: ShadingContext, index: u32, p_select: f32, use_mis: bool, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    let s = trace_light_sample(c, index, p_select, rng, rays);
    if all(s.g == vec3f(0.0)) {
        return vec3f(0.0);
    }
    // A delta light has no density to weigh against: MIS weight 1.
    var w = 1.0;
    if use_mis && !s.is_delta {
        w = mis_weight(f32(frame.light_samples), s.p_light, f32(frame.brdf_samples), s.p_brdf);
    }
    return w * s.g / s.p_light;
}

// Light sampling: n samples of each light (SELECT_EACH) or n samples of one chosen light.
fn estimate_light_sampling(c: ShadingContext, use_mis: bool, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    if frame.light_count == 0u || frame.light_samples == 0u {
        return vec3f(0.0);
    }
    var sum = vec3f(0.0);
    if frame.light_selection == SELECT_EACH {
        for (var li = 0u; li < frame.light_count; li++) {
            for (var k = 0u; k < frame.light_samples; k++) {
                sum += light_sample_contribution(c, li, 1.0, use_mis, rng, rays);
            }
        }
    } else {
        for (var k = 0u; k < frame.light_samples; k++) {
            let li = select_light(rng_next(rng));
            sum += light_sample_contribution(c, li, light_selection_pdf(li), use_mis, rng, rays);
        }
    }
    return sum / f32(frame.light_samples);
}

// A direction sampled at the surface, before any weighting: g = f L_e |cos θ_i| with L_e
// emitted by the first hit, and the density with which the light strategy would have
// produced the same direction (zero unless the hit is on a light).
struct DirectionEval {
    g: vec3f,
    p_light: f32,
    // The glossy lobe's part of g.
    g_glossy: vec3f,
}

fn trace_direction(c: ShadingContext, wi_world: vec3f, rays: ptr<function, u32>) -> DirectionEval {
    var r = DirectionEval(vec3f(0.0), 0.0, vec3f(0.0));
    if dot(wi_world, c.s.ng) <= 0.0 {
        return r;
    }
    let wi = frame_to_local(c.frame, wi_world);
    let lobes = bsdf_eval_lobes(c.bsdf, c.wo, wi);
    let f = lobes.diffuse + lobes.glossy;
    if all(f == vec3f(0.0)) {
        return r;
    }
    let origin = offset_ray_origin(c.s.p, c.s.ng, wi_world);
    *rays += 1u;
    let hit = trace_closest(origin, wi_world, RAY_INF);
    if !hit.found {
        return r;
    }
    let e = surface_at(hit, wi_world);
    let le = emitted_radiance(e);
    if all(le == vec3f(0.0)) {
        return r;
    }
    r.g = f * le * wi.z;
    r.g_glossy = lobes.glossy * le * wi.z;
    if HAS_AREA_LIGHTS && e.light != NO_LIGHT && frame.light_count > 0u {
        r.p_light = area_light_pdf(e.light, c.s.p, tri_verts[hit.tri], e.p);
    }
    return r;
}

// Radiance arriving along a direction sampled with density `pdf`, over that density; with
// MIS, weighted against the light strategy's pdf for the same direction.
fn direction_sample_contribution(c: ShadingContext, wi_world: vec3f, pdf: f32, n_samples: f32, use_mis: bool, rays: ptr<function, u32>) -> vec3f {
    if pdf <= 0.0 {
        return vec3f(0.0);
    }
    let d = trace_direction(c, wi_world, rays);
    var w = 1.0;
    if use_mis && d.p_light > 0.0 && frame.light_samples > 0u {
        w = mis_weight(n_samples, pdf, f32(frame.light_samples), d.p_light);
    }
    return w * d.g / pdf;
}

// A sample of a delta (mirror) lobe: no other strategy can produce its direction, so its MIS
// weight is 1; its value is the lobe's reflectance over the probability of choosing the lobe.
fn delta_sample_contribution(c: ShadingContext, bs: BsdfSample, rays: ptr<function, u32>) -> vec3f {
    let wi_world = frame_to_world(c.frame, bs.wi);
    if bs.pdf <= 0.0 || dot(wi_world, c.s.ng) <= 0.0 {
        return vec3f(0.0);
    }
    *rays += 1u;
    let hit = trace_closest(offset_ray_origin(c.s.p, c.s.ng, wi_world), wi_world, RAY_INF);
    if !hit.found {
        return vec3f(0.0);
    }
    return bs.delta_reflectance / bs.pdf * emitted_radiance(surface_at(hit, wi_world));
}

fn estimate_brdf_sampling(c: ShadingContext, use_mis: bool, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    if frame.brdf_samples == 0u {
        return vec3f(0.0);
    }
    let n = f32(frame.brdf_samples);
    var sum = vec3f(0.0);
    for (var k = 0u; k < frame.brdf_samples; k++) {
        let u = vec3f(rng_next(rng), rng_next2(rng));
        let bs = bsdf_sample(c.bsdf, c.wo, u);
        if HAS_MIRRORS && bs.delta {
            sum += delta_sample_contribution(c, bs, rays);
        } else {
            sum += direction_sample_contribution(c, frame_to_world(c.frame, bs.wi), bs.pdf, n, use_mis, rays);
        }
    }
    return sum / n;
}

// Uniform hemisphere sampling around the shading normal; brdf_samples directions.
fn estimate_uniform_sampling(c: ShadingContext, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    if frame.brdf_samples == 0u {
        return vec3f(0.0);
    }
    let n = f32(frame.brdf_samples);
    var sum = vec3f(0.0);
    for (var k = 0u; k < frame.brdf_samples; k++) {
        let wi = sample_uniform_hemisphere(rng_next2(rng));
        sum += direction_sample_contribution(c, frame_to_world(c.frame, wi), uniform_hemisphere_pdf(), n, false, rays);
    }
    return sum / n;
}

const DEFENSIVE_SHARE: f32 = 0.1;

// The parts of one camera sample's estimate: emission seen directly, light-sample and
// direction-sample (BRDF or uniform) contributions, MIS-weighted where the strategy is MIS.
struct Estimate {
    emitted: vec3f,
    light: vec3f,
    brdf: vec3f,
}

// MIS per lobe (mis-lobes): the diffuse lobe is estimated by light sampling alone, the glossy
// lobe by MIS between light sampling and sampling that lobe itself. Veach's multi-sample model
// (Veach & Guibas 1995, eq. 8; thesis §9.2) lets the counts differ from point to point as long as
// they are fixed before sampling: at a point without a glossy lobe the m BRDF samples become
// light samples (a diffuse lobe's BRDF samples rarely find a small light, and the balance
// heuristic would give them little weight); at a point with one, n light samples serve both lobes
// and m samples go to the glossy lobe, weighted against light sampling with the counts.
fn estimate_lobe_mis(c: ShadingContext, rng: ptr<function, u32>, rays: ptr<function, u32>) -> Estimate {
    let glossy = has_glossy_lobe(c.bsdf);
    let n = select(frame.light_samples + frame.brdf_samples, frame.light_samples, glossy);
    // A mirror lobe's one direction needs one sample.
    let m = select(0u, select(frame.brdf_samples, min(frame.brdf_samples, 1u), c.bsdf.delta), glossy);
    // The host refuses light_samples = 0 for this strategy (the diffuse lobe needs them).
    if n == 0u || frame.light_count == 0u {
        return Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    }
    var light = vec3f(0.0);
    if frame.light_selection == SELECT_EACH {
        for (var li = 0u; li < frame.light_count; li++) {
            for (var k = 0u; k < n; k++) {
                light += lobe_light_sample(c, li, 1.0, n, m, rng, rays);
            }
        }
    } else {
        for (var k = 0u; k < n; k++) {
            let li = select_light(rng_next(rng));
            light += lobe_light_sample(c, li, light_selection_pdf(li), n, m, rng, rays);
        }
    }
    var brdf = vec3f(0.0);
    for (var k = 0u; k < m; k++) {
        brdf += glossy_lobe_sample(c, n, m, rng, rays);
    }
    return Estimate(vec3f(0.0), light / f32(n), select(vec3f(0.0), brdf / f32(m), m > 0u));
}

// A light sample of mis-lobes: the diffuse lobe's part with weight 1 (no other technique
// samples it), the glossy lobe's weighted against glossy-lobe sampling; a delta light weight 1.
fn lobe_light_sample(c: ShadingContext, index: u32, p_select: f32, n: u32, m: u32, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    let s = trace_light_sample(c, index, p_select, rng, rays);
    if all(s.g == vec3f(0.0)) {
        return vec3f(0.0);
    }
    if s.is_delta || m == 0u {
        return s.g / s.p_light;
    }
    let w = mis_weight(f32(n), s.p_light, f32(m), s.p_glossy);
    return (s.g - s.g_glossy + w * s.g_glossy) / s.p_light;
}

// A sample of the glossy lobe alone (GGX visible normals, or the mirror direction), weighted
// against light sampling. The mirror's direction no light sample reaches: weight 1, and its
// value is the lobe's reflectance times the radiance found.
fn glossy_lobe_sample(c: ShadingContext, n: u32, m: u32, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    let u = rng_next2(rng);
    if HAS_MIRRORS && c.bsdf.delta {
        let wi_world = frame_to_world(c.frame, vec3f(-c.wo.x, -c.wo.y, c.wo.z));
        if dot(wi_world, c.s.ng) <= 0.0 {
            return vec3f(0.0);
        }
        *rays += 1u;
        let hit = trace_closest(offset_ray_origin(c.s.p, c.s.ng, wi_world), wi_world, RAY_INF);
        if !hit.found {
            return vec3f(0.0);
        }
        return mirror_reflectance(c.bsdf, c.wo.z) * emitted_radiance(surface_at(hit, wi_world));
    }
    let wi = reflect(-c.wo, sample_ggx_vndf(c.wo, c.bsdf.alpha, u));
    let pdf = ggx_vndf_pdf(c.wo, wi, c.bsdf.alpha);
    if wi.z <= 0.0 || pdf <= 0.0 {
        return vec3f(0.0);
    }
    let d = trace_direction(c, frame_to_world(c.frame, wi), rays);
    let w = select(1.0, mis_weight(f32(m), pdf, f32(n), d.p_light), d.p_light > 0.0);
    return w * d.g_glossy / pdf;
}

fn estimate_radiance(ray: Ray, rng: ptr<function, u32>, rays: ptr<function, u32>) -> Estimate {
    var e = Estimate(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    *rays += 1u;
    let hit = trace_closest(ray.origin, ray.dir, RAY_INF);
    if !hit.found {
        return e;
    }
    let s = surface_at(hit, ray.dir);
    let f = frame_from_normal(s.ns);
    let c = ShadingContext(s, f, frame_to_local(f, -ray.dir), bsdf_params(textured_material(materials[s.material], s.uvs)));
    if frame.hide_emitters == 0u {
        e.emitted = emitted_radiance(s);
    }
    switch active_strategy() {
        case STRATEGY_UNIFORM: {
            e.brdf = estimate_uniform_sampling(c, rng, rays);
        }
        case STRATEGY_BRDF: {
            e.brdf = estimate_brdf_sampling(c, false, rng, rays);
        }
        case STRATEGY_LIGHT: {
            e.light = estimate_light_sampling(c, false, rng, rays);
        }
        case STRATEGY_MIS_LOBES: {
            let parts = estimate_lobe_mis(c, rng, rays);
            e.light = parts.light;
            e.brdf = parts.brdf;
        }
        default: {
            e.light = estimate_light_sampling(c, true, rng, rays);
            e.brdf = estimate_brdf_sampling(c, true, rng, rays);
        }
    }
    return e;
}

@compute @workgroup_size(8, 8, 1)
fn render(@builtin(global_invocation_id) gid: vec3u) {
    let x = gid.x;
    let y = frame.row_start + gid.y;
    if x >= frame.width || gid.y >= frame.row_count || y >= frame.height {
        return;
    }
    let pixel = y * frame.width + x;
    var sum = accum[pixel];
    var sum_sq = accum_sq[pixel];
    var count = counters[pixel];
    var sum_light = vec4f(0.0);
    var sum_brdf = vec4f(0.0);
    let write_aovs = HAS_AOVS && frame.write_aovs != 0u;
    if write_aovs {
        sum_light = aov_light[pixel];
        sum_brdf = aov_brdf[pixel];
    }
    for (var k = 0u; k < frame.sample_count; k++) {
        var rng = rng_seed(pixel, frame.sample_start + k, frame.seed);
        let ray = camera_ray(vec2u(x, y), rng_next2(&rng));
        var rays = 0u;
        let e = estimate_radiance(ray, &rng, &rays);
        let l = e.emitted + e.light + e.brdf;
        count.rays += rays;
        // A non-finite sample is counted and dropped (as a zero), never accumulated.
        if is_finite3(l) && is_finite3(l * l) {
            sum += vec4f(l, 1.0);
            sum_sq += vec4f(l * l, 0.0);
            sum_light += vec4f(e.light, 0.0);
            // w: luminance of the emission part, so that the two sampled parts can be told apart.
            sum_brdf += vec4f(e.emitted + e.brdf, luminance(e.emitted));
        } else {
            sum.w += 1.0;
            count.nonfinite += 1u;
        }
    }
    accum[pixel] = sum;
    accum_sq[pixel] = sum_sq;
    counters[pixel] = count;
    if write_aovs {
        aov_light[pixel] = sum_light;
        aov_brdf[pixel] = sum_brdf;
    }
}

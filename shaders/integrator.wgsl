// integrator.wgsl: the direct-lighting estimators and the compute entry point.
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

fn triangle_normal(v: TrianglePositions) -> vec3f {
    let c = cross(v.p1 - v.p0, v.p2 - v.p0);
    let len_sq = dot(c, c);
    return select(vec3f(0.0, 0.0, 1.0), c * inverseSqrt(len_sq), len_sq > 0.0);
}

fn surface_at(hit: Hit, ray_dir: vec3f) -> SurfaceHit {
    let t = triangles[hit.tri];
    let v = triangle_positions(t);
    let b0 = 1.0 - hit.b1 - hit.b2;
    let p = b0 * v.p0 + hit.b1 * v.p1 + hit.b2 * v.p2;
    var ng = triangle_normal(v);
    // Front face: counter-clockwise winding seen from the ray's origin (glTF's convention).
    let front = dot(ng, ray_dir) < 0.0;
    if !front {
        ng = -ng;
    }
    let n0 = decode_normal(vertices[t.v0].normal);
    let n1 = decode_normal(vertices[t.v1].normal);
    let n2 = decode_normal(vertices[t.v2].normal);
    let n_interp = b0 * n0 + hit.b1 * n1 + hit.b2 * n2;
    let len_sq = dot(n_interp, n_interp);
    var ns = select(ng, n_interp * inverseSqrt(len_sq), len_sq > 0.0);
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    let uvs = surface_uvs(hit.tri, hit.b1, hit.b2);
    ns = mapped_normal(materials[t.material], uvs, hit.tri, ns);
    // A shading normal that faces away from the viewer would make the BRDF vanish: fall back.
    if dot(ns, -ray_dir) <= 0.0 {
        ns = ng;
    }
    return SurfaceHit(p, ng, ns, front, t.material, triangle_light(hit.tri), uvs);
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

// A camera ray's closest hit: by the camera list's edge planes where the kernel has one
// (CAMERA_LIST), else by the closest-hit traversal.
fn trace_camera_ray(ray: Ray) -> Hit {
    if FOOTPRINT_SLOTS > 0u {
        return trace_camera_slots(ray.dir);
    }
    if CAMERA_LIST {
        return trace_camera(ray.dir);
    }
    return trace_closest(ray.origin, ray.dir, RAY_INF);
}

struct ShadingContext {
    s: SurfaceHit,
    frame: Frame,
    wo: vec3f,
    bsdf: BsdfParams,
}

// The shading frame, the direction to the viewer in it and the BSDF at a surface the camera
// sees; with SELECT_BSDF also the point's light-choice table (prepare_point_selection).
fn shading_context(s: SurfaceHit, ray_dir: vec3f) -> ShadingContext {
    let f = frame_from_normal(s.ns);
    let c = ShadingContext(s, f, frame_to_local(f, -ray_dir), bsdf_params(textured_material(materials[s.material], s.uvs)));
    prepare_point_selection(s.p, f, c.wo, c.bsdf);
    return c;
}

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

// ---------------------------------------------------------------------------------------------
// Light samples: a point or direction on a light, a shadow ray, a weight.

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
    return select(plan.n, plan.n * light_count(), frame.light_selection == SELECT_EACH);
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
    if frame.light_selection != SELECT_EACH {
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
    if !CONE_SAMPLING || frame.light_sampling != LIGHT_SAMPLING_CONE {
        return 0u;
    }
    return light_sample_requests(plan);
}

// ---------------------------------------------------------------------------------------------
// Direction samples (uniform, BRDF, glossy lobe): a direction, a closest-hit ray, what it finds.

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
        let p_light = area_light_pdf(e.light, p, triangle_positions(triangles[tri]), e.p);
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

// ---------------------------------------------------------------------------------------------
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

// ---------------------------------------------------------------------------------------------
// One camera sample.

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

// ---------------------------------------------------------------------------------------------
// Direction rays that wait (WAITING_DIRECTION_RAYS, features.wgsl).
//
// Where a render traces a BRDF ray for some camera samples and not for others, the loop above
// traces them on a pass of their own, which a SIMD group runs if any of its lanes has such a ray:
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

// The pixel a thread of a dispatch over a band of rows takes, and whether it lies in the image and
// the band.
struct BandPixel {
    x: u32,
    y: u32,
    index: u32,
    inside: bool,
}

// A camera sample's numbers, keyed by its pixel's index in the whole image (`pixel` indexes the
// buffers, which start at image row frame.tile_row), so that a tiled image is the untiled one.
fn pixel_sample_stream(pixel: u32, sample: u32) -> SampleStream {
    return sample_stream(pixel + frame.tile_row * frame.width, frame.first_sample + sample, frame.seed);
}

fn band_pixel(gid: vec3u) -> BandPixel {
    let y = frame.row_start + gid.y;
    let inside = gid.x < frame.width && gid.y < frame.row_count && y < frame.height;
    return BandPixel(gid.x, y, y * frame.width + gid.x, inside);
}

// Mesa 22's llvmpipe (gallivm's loop limiter, LP_MAX_TGSI_LOOP_ITERATIONS in
// lp_bld_ir_common.c) gives each invocation one budget of 65,535 loop iterations, shared by all
// of its loops; once it is spent, every loop stops after its current iteration: traversals end
// early, rays miss, and the sample is silently dark. Mesa 23 and later have no such limit. This
// loop must run twice (its trip count is read at run time, so it is not unrolled); after a
// camera sample it tells whether the budget held through it. A sample it did not is left out
// and taken again by the next dispatch (`render` starts from the pixel's own count).
fn loop_budget_held() -> bool {
    let trips = max(frame.loop_check, 2u);
    var i = 0u;
    loop {
        i += 1u;
        if i >= trips {
            break;
        }
    }
    return i >= 2u;
}

@compute @workgroup_size(RENDER_WORKGROUP_WIDTH, RENDER_WORKGROUP_HEIGHT, 1)
fn render(@builtin(global_invocation_id) gid: vec3u) {
    load_frame();
    let px = band_pixel(gid);
    if !px.inside {
        return;
    }
    let pixel = px.index;
    var sum = vec4f(0.0);
    var sum_sq = vec4f(0.0);
    var count = PixelCounters(0u, 0u, 0u);
    var sum_light = vec4f(0.0);
    var sum_brdf = vec4f(0.0);
    let write_aovs = HAS_AOVS && frame.write_aovs != 0u;
    // In its rows' first pass the sums are still zero: not read. Mesa 22.3 reads a storage word lane
    // by lane, and these 11 words, read and written, cost an invocation about half a camera sample
    // there (docs/performance.md, "The frame's parameters copied once per invocation").
    if frame.fresh_sums == 0u {
        sum = accum[pixel];
        sum_sq = accum_sq[pixel];
        count = counters[pixel];
        if write_aovs {
            sum_light = aov_light[pixel];
            sum_brdf = aov_brdf[pixel];
        }
    }
    // From the pixel's own count of samples (sum.w), which trails the dispatch's first sample
    // where a sample was left out before (loop_budget_held). The loop's end test is the last
    // statement of its body: written in a `continuing` block (or at the top, as a `for` or `while`
    // has it), Mesa 22.3's lavapipe, which runs code whose lanes are all masked off, ran the whole
    // body once more after the last trip, a camera sample's worth per pixel (one-sample renders of
    // the Cornell box took 0.6x the time without it; docs/performance.md, "Loops tested at the end
    // of their body"). The other hot loops (traversal, lights) are written the same way. The tests
    // read the end from `frame` each time: held in a variable, it made the Cornell box 1.10x
    // slower on Mesa 22.3 (not understood; measured twice, before this form).
    var k = u32(sum.w);
    load_camera_slots(pixel);
    if DEFERRED_DIRECTION_RAYS && k < frame.sample_start + frame.sample_count {
        take_samples_deferred(px, k, &sum, &sum_sq, &count);
    } else if WAITING_DIRECTION_RAYS && k < frame.sample_start + frame.sample_count {
        take_samples_waiting(px, k, &sum, &sum_sq, &count);
    } else if k < frame.sample_start + frame.sample_count {
        loop {
            var stream = pixel_sample_stream(pixel, k);
            let ray = camera_ray(vec2u(px.x, px.y), sample_2d(&stream));
            var rays = 0u;
            let e = estimate_radiance(ray, &stream, &rays);
            if !loop_budget_held() {
                count.truncated += 1u;
                break;
            }
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
            k++;
            if k >= frame.sample_start + frame.sample_count {
                break;
            }
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

// One camera sample's estimate added to its pixel's sums (the wavefront kernels; `render` keeps
// its sums in registers over its samples, in the same order).
fn add_sample(pixel: u32, e: Estimate, rays: u32) {
    let l = e.emitted + e.light + e.brdf;
    counters[pixel].rays += rays;
    // A non-finite sample is counted and dropped (as a zero), never accumulated.
    if is_finite3(l) && is_finite3(l * l) {
        accum[pixel] += vec4f(l, 1.0);
        accum_sq[pixel] += vec4f(l * l, 0.0);
        if HAS_AOVS && frame.write_aovs != 0u {
            aov_light[pixel] += vec4f(e.light, 0.0);
            aov_brdf[pixel] += vec4f(e.emitted + e.brdf, luminance(e.emitted));
        }
    } else {
        accum[pixel].w += 1.0;
        counters[pixel].nonfinite += 1u;
    }
}

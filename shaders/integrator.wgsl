// integrator.wgsl: the direct-lighting estimators and the compute entry point.
//
// For each camera sample: L = L_e + estimate of  ∫ f(wo, wi) L_d(wi) |cos θ_i| dω_i  at the first
// hit, by the strategy in frame.strategy:
//   uniform: (1/N) Σ f L cos / (1/2π)                         (hemisphere directions)
//   brdf:    (1/m) Σ f L cos / p_brdf                          (glTF BRDF sampling)
//   light:   (1/n) Σ f L_e cos / (P(light) p_ω)                (area sampling, r²/(|cos θ_l| A))
//   mis:     (1/n) Σ w_l f L_e cos / p_l + (1/m) Σ w_b f L_e cos / p_b   (Veach & Guibas 1995, eq. 8)
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

// One sample of light `index` chosen with probability p_select.
fn light_sample_contribution(c: ShadingContext, index: u32, p_select: f32, use_mis: bool, rng: ptr<function, u32>, rays: ptr<function, u32>) -> vec3f {
    let u = vec3f(rng_next(rng), rng_next2(rng));
    let ls = sample_light(index, c.s.p, u);
    if ls.pdf <= 0.0 || dot(ls.wi, c.s.ng) <= 0.0 {
        return vec3f(0.0);
    }
    let wi = frame_to_local(c.frame, ls.wi);
    let f = bsdf_eval(c.bsdf, c.wo, wi);
    if wi.z <= 0.0 || all(f == vec3f(0.0)) || all(ls.value == vec3f(0.0)) {
        return vec3f(0.0);
    }
    let origin = offset_ray_origin(c.s.p, c.s.ng, ls.wi);
    // Both ends of the shadow ray are offset off their surfaces: far from the origin a
    // fraction of the distance is less than the rounding of the light's position, and the
    // light would occlude itself (found by tests/stress.rs on the Cornell box moved to 1e5).
    let to_end = max(dot(ls.shadow_end - origin, ls.wi), 0.0);
    let t_max = select(to_end * (1.0 - 1.0e-4), RAY_INF, ls.dist >= RAY_INF);
    *rays += 1u;
    if trace_occluded(origin, ls.wi, t_max) {
        return vec3f(0.0);
    }
    if HAS_DELTA_LIGHTS && ls.is_delta {
        // A delta light has no density to weigh against: MIS weight 1.
        return f * ls.value * wi.z / p_select;
    }
    let p_light = p_select * ls.pdf;
    var w = 1.0;
    if use_mis {
        w = mis_weight(f32(frame.light_samples), p_light, f32(frame.brdf_samples), bsdf_pdf(c.bsdf, c.wo, wi));
    }
    return w * f * ls.value * wi.z / p_light;
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

// Radiance arriving along a direction sampled at the surface: L_e of the first hit.
// With MIS, weighted against the light strategy's pdf for the same direction.
fn direction_sample_contribution(c: ShadingContext, wi_world: vec3f, pdf: f32, n_samples: f32, use_mis: bool, rays: ptr<function, u32>) -> vec3f {
    if pdf <= 0.0 || dot(wi_world, c.s.ng) <= 0.0 {
        return vec3f(0.0);
    }
    let wi = frame_to_local(c.frame, wi_world);
    let f = bsdf_eval(c.bsdf, c.wo, wi);
    if all(f == vec3f(0.0)) {
        return vec3f(0.0);
    }
    let origin = offset_ray_origin(c.s.p, c.s.ng, wi_world);
    *rays += 1u;
    let hit = trace_closest(origin, wi_world, RAY_INF);
    if !hit.found {
        return vec3f(0.0);
    }
    let e = surface_at(hit, wi_world);
    let le = emitted_radiance(e);
    if all(le == vec3f(0.0)) {
        return vec3f(0.0);
    }
    var w = 1.0;
    if HAS_AREA_LIGHTS && use_mis && e.light != NO_LIGHT && frame.light_samples > 0u {
        let v = tri_verts[hit.tri];
        let p_light = area_light_pdf(e.light, c.s.p, e.p, triangle_normal(v));
        w = mis_weight(n_samples, pdf, f32(frame.light_samples), p_light);
    }
    return w * f * le * wi.z / pdf;
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

// The parts of one camera sample's estimate: emission seen directly, light-sample and
// direction-sample (BRDF or uniform) contributions, MIS-weighted where the strategy is MIS.
struct Estimate {
    emitted: vec3f,
    light: vec3f,
    brdf: vec3f,
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

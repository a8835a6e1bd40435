// lights.wgsl: light selection, and per light kind: sample (a point or direction with its pdf)
// and pdf (of a direction that a BRDF or uniform sample found).

// A sampled light contribution. For area lights `value` is the emitted radiance L_e and `pdf`
// the solid-angle pdf; for delta lights `value` is the incident radiance already integrated over
// the delta (I / r^2, E) and `pdf` is the discrete selection probability only.
struct LightSample {
    wi: vec3f,
    dist: f32,
    value: vec3f,
    pdf: f32,
    is_delta: bool,
    // Where the shadow ray ends: the sampled point pushed off the light's surface towards the
    // receiver (area lights), the light's position (point, spot); unused for directional.
    shadow_end: vec3f,
}

fn light_is_delta(kind: u32) -> bool {
    return kind != LIGHT_AREA;
}

// Probability that light `index` is chosen by the frame's light-selection method.
fn light_selection_pdf(index: u32) -> f32 {
    switch frame.light_selection {
        case SELECT_UNIFORM: {
            return 1.0 / f32(frame.light_count);
        }
        case SELECT_POWER: {
            let lo = select(0.0, light_power_cdf[index - 1u], index > 0u);
            return light_power_cdf[index] - lo;
        }
        default: {
            // SELECT_EACH: every light gets its own samples.
            return 1.0;
        }
    }
}

// First index i with cdf[i] > u (binary search over the normalised power CDF).
fn select_light_by_power(u: f32) -> u32 {
    var lo = 0u;
    var hi = frame.light_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if light_power_cdf[mid] > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

fn select_light(u: f32) -> u32 {
    if frame.light_selection == SELECT_POWER {
        return select_light_by_power(u);
    }
    return min(u32(u * f32(frame.light_count)), frame.light_count - 1u);
}

// Emitter triangle of `light` covering area fraction u (binary search over the light's area CDF).
fn select_emitter_triangle(light: Light, u: f32) -> u32 {
    var lo = light.first_tri;
    var hi = light.first_tri + light.tri_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if emitter_tris[mid].cdf > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// Does the light emit towards a receiver lying along -wi from a point with normal n_l?
fn emits_towards(double_sided: bool, n_l: vec3f, wi: vec3f) -> bool {
    return double_sided || dot(n_l, wi) < 0.0;
}

// Area pdf 1/A converted to solid angle at the receiver: p_w = r^2 / (|cos theta_l| A).
// dw = |cos theta_l| dA / r^2: pbrt-v4 §4.2.3 ("Integrals over Area"), Veach 1997 thesis §8.1.
fn area_to_solid_angle_pdf(dist_sq: f32, cos_light: f32, area: f32) -> f32 {
    let denom = abs(cos_light) * area;
    return select(0.0, dist_sq / denom, denom > 0.0);
}

// Area light: a point uniform on the light's surface (triangle by area, then uniform in it).
fn sample_area_light(light: Light, x: vec3f, u: vec3f) -> LightSample {
    let ti = select_emitter_triangle(light, u.x);
    let tri = emitter_tris[ti];
    let b = sample_uniform_triangle(u.yz);
    let y = tri.p0 + b.x * tri.e1 + b.y * tri.e2;
    let n_l = normalize(cross(tri.e1, tri.e2));
    let d = y - x;
    let dist_sq = dot(d, d);
    let dist = sqrt(dist_sq);
    let wi = d / dist;
    var s = LightSample(wi, dist, vec3f(0.0), 0.0, false, offset_ray_origin(y, n_l, -wi));
    if dist_sq <= 0.0 || !emits_towards(light.double_sided != 0u, n_l, wi) {
        return s;
    }
    s.value = light.intensity * emitter_emission_texture(ti, b.x, b.y);
    s.pdf = area_to_solid_angle_pdf(dist_sq, dot(n_l, wi), light.area);
    return s;
}

// Spot cone falloff as KHR_lights_punctual recommends ("Inner and Outer Cone Angles"):
// smooth attenuation squared between the outer and inner cone.
fn spot_falloff(light: Light, wi: vec3f) -> f32 {
    let cd = dot(light.direction, -wi);
    let scale = 1.0 / max(0.001, light.cos_inner - light.cos_outer);
    let offset = -light.cos_outer * scale;
    let a = clamp(cd * scale + offset, 0.0, 1.0);
    return a * a;
}

fn sample_delta_light(light: Light, x: vec3f) -> LightSample {
    if light.kind == LIGHT_DIRECTIONAL {
        return LightSample(-light.direction, RAY_INF, light.intensity, 1.0, true, vec3f(0.0));
    }
    let d = light.position - x;
    let dist_sq = dot(d, d);
    let dist = sqrt(dist_sq);
    let wi = d / dist;
    var value = light.intensity / dist_sq;
    if light.kind == LIGHT_SPOT {
        value *= spot_falloff(light, wi);
    }
    return LightSample(wi, dist, value, 1.0, true, light.position);
}

// Sample light `index` from x; the returned pdf excludes the selection probability.
fn sample_light(index: u32, x: vec3f, u: vec3f) -> LightSample {
    let light = lights[index];
    if HAS_AREA_LIGHTS && light.kind == LIGHT_AREA {
        return sample_area_light(light, x, u);
    }
    if HAS_DELTA_LIGHTS {
        return sample_delta_light(light, x);
    }
    return LightSample(vec3f(0.0, 0.0, 1.0), 0.0, vec3f(0.0), 0.0, false, x);
}

// Solid-angle pdf with which the light strategy (selection included) would have produced the
// direction from x to point y on emitter triangle `tri` of light `index`.
fn area_light_pdf(index: u32, x: vec3f, y: vec3f, n_l: vec3f) -> f32 {
    let light = lights[index];
    let d = y - x;
    let dist_sq = dot(d, d);
    let cos_l = dot(n_l, normalize(d));
    return light_selection_pdf(index) * area_to_solid_angle_pdf(dist_sq, cos_l, light.area);
}

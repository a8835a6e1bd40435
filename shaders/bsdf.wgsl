// bsdf.wgsl: the glTF 2.0 metallic-roughness BRDF (glTF 2.0 specification, Appendix B) with
// KHR_materials_specular, and its importance sampling. Directions are in the local shading
// frame (z = shading normal); wo points to the viewer, wi to the light. Reflection only.
//
//   material   = mix(dielectric_brdf, metal_brdf, metallic)
//   metal_brdf = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(alpha))
//   dielectric_brdf = fresnel_mix(ior = 1.5, base = diffuse_brdf(baseColor),
//                                 layer = specular_brdf(alpha))
//   specular_brdf = V * D, alpha = roughness^2

// Smallest GGX alpha of a rough lobe: roughness 0.01. Roughness exactly 0 is a perfect mirror,
// the limit α → 0 of the specular lobe: a delta BRDF that only BRDF sampling can reach.
const MIN_ALPHA: f32 = 1.0e-4;

struct BsdfParams {
    base_color: vec3f,
    metallic: f32,
    alpha: f32,
    specular: f32,
    specular_color: vec3f,
    // The specular lobe is a delta (roughness 0).
    delta: bool,
}

fn bsdf_params(m: Material) -> BsdfParams {
    let delta = HAS_MIRRORS && m.roughness <= 0.0;
    let alpha = select(max(m.roughness * m.roughness, MIN_ALPHA), 0.0, delta);
    return BsdfParams(m.base_color, m.metallic, alpha, m.specular, m.specular_color, delta);
}

fn max3(v: vec3f) -> f32 {
    return max(v.x, max(v.y, v.z));
}

fn luminance(c: vec3f) -> f32 {
    return dot(c, vec3f(0.2126, 0.7152, 0.0722));
}

fn pow5(x: f32) -> f32 {
    let x2 = x * x;
    return x2 * x2 * x;
}

// GGX / Trowbridge-Reitz normal distribution of the unit half vector h (local frame).
// Appendix B.3.2, "Microfacet Distribution": D = α² / (π ((N·H)²(α² − 1) + 1)²). For unit h,
// (N·H)²(α² − 1) + 1 = |h_xy|² + h_z² α²; this form keeps its precision for tiny α, where
// 1 − (N·H)² cancels catastrophically in f32.
fn ggx_d(h: vec3f, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = dot(h.xy, h.xy) + h.z * h.z * a2;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility V = G / (4 |N.L| |N.V|). Appendix B.3.2, "Masking-Shadowing".
fn smith_v_height_correlated(n_dot_l: f32, n_dot_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    let s = gv + gl;
    return select(0.0, 0.5 / s, s > 0.0);
}

// Smith G1 for GGX, the masking term of the visible-normal distribution (Heitz 2018, eq. 2).
fn smith_g1(n_dot_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    return 2.0 * n_dot_v / (n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v));
}

// Dielectric Fresnel of KHR_materials_specular ("Implementation"): f0 = min(0.04 * specularColor, 1),
// the layer weighted by `specular`.
fn dielectric_fresnel(p: BsdfParams, v_dot_h: f32) -> vec3f {
    let f0 = min(vec3f(0.04) * p.specular_color, vec3f(1.0));
    return f0 + (vec3f(1.0) - f0) * pow5(1.0 - abs(v_dot_h));
}

// conductor_fresnel: Schlick with f0 = baseColor. Appendix B.3.3.
fn conductor_fresnel(p: BsdfParams, v_dot_h: f32) -> vec3f {
    return p.base_color + (vec3f(1.0) - p.base_color) * pow5(1.0 - abs(v_dot_h));
}

// f(wo, wi) split into its diffuse lobe and its glossy (GGX) lobe, without the cosine.
struct BsdfLobes {
    diffuse: vec3f,
    glossy: vec3f,
}

// f(wo, wi), without the cosine.
fn bsdf_eval(p: BsdfParams, wo: vec3f, wi: vec3f) -> vec3f {
    let l = bsdf_eval_lobes(p, wo, wi);
    return l.diffuse + l.glossy;
}

fn bsdf_eval_lobes(p: BsdfParams, wo: vec3f, wi: vec3f) -> BsdfLobes {
    let n_dot_l = wi.z;
    let n_dot_v = wo.z;
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return BsdfLobes(vec3f(0.0), vec3f(0.0));
    }
    let h = normalize(wo + wi);
    let v_dot_h = dot(wo, h);
    // A delta lobe has no density off its one direction: only the diffuse part is left.
    // Without glossy materials every specular weight is 0 and the lobe is not evaluated.
    var specular_brdf = 0.0;
    if HAS_GLOSSY && !p.delta {
        specular_brdf = ggx_d(h, p.alpha) * smith_v_height_correlated(n_dot_l, n_dot_v, p.alpha);
    }
    let diffuse_brdf = p.base_color * INV_PI;
    // fresnel_mix (Appendix B.3.4, weighted as in KHR_materials_specular).
    // material = mix(dielectric, metal, metallic), the diffuse lobe only in the dielectric.
    let fr = dielectric_fresnel(p, v_dot_h);
    let diffuse = (1.0 - p.metallic) * (1.0 - p.specular * max3(fr)) * diffuse_brdf;
    let glossy = ((1.0 - p.metallic) * p.specular * fr + p.metallic * conductor_fresnel(p, v_dot_h)) * specular_brdf;
    return BsdfLobes(diffuse, glossy);
}

// The BSDF has a glossy or mirror lobe (metallic > 0 or a specular layer).
fn has_glossy_lobe(p: BsdfParams) -> bool {
    return HAS_GLOSSY && (p.metallic > 0.0 || p.specular > 0.0);
}

// Probability of sampling the specular lobe, from the Fresnel-weighted albedo of each lobe at
// the viewing angle. It depends on wo only, so the mixture pdf below is exact.
fn bsdf_specular_probability(p: BsdfParams, wo: vec3f) -> f32 {
    let fr_d = p.specular * max3(dielectric_fresnel(p, wo.z));
    let spec = (1.0 - p.metallic) * fr_d + p.metallic * luminance(conductor_fresnel(p, wo.z));
    let diff = (1.0 - p.metallic) * (1.0 - fr_d) * luminance(p.base_color);
    let total = spec + diff;
    return select(0.5, spec / total, total > 0.0);
}

// Visible-normal pdf of the reflected direction: D_v(h) / (4 wo.h) = G1(wo) D(h) / (4 wo.z).
// Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018, eqs. 3 and 17.
fn ggx_vndf_pdf(wo: vec3f, wi: vec3f, alpha: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = normalize(wo + wi);
    return smith_g1(wo.z, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);
}

// Heitz 2018, Listing 1 (isotropic alpha): a microfacet normal from the visible normals.
fn sample_ggx_vndf(wo: vec3f, alpha: f32, u: vec2f) -> vec3f {
    let vh = normalize(vec3f(alpha * wo.x, alpha * wo.y, wo.z));
    let len_sq = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3f(1.0, 0.0, 0.0);
    if len_sq > 0.0 {
        t1 = vec3f(-vh.y, vh.x, 0.0) * inverseSqrt(len_sq);
    }
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3f(alpha * nh.x, alpha * nh.y, max(1.0e-6, nh.z)));
}

// pdf of bsdf_sample in solid angle: the exact mixture of both lobes.
fn bsdf_pdf(p: BsdfParams, wo: vec3f, wi: vec3f) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let p_spec = bsdf_specular_probability(p, wo);
    let diffuse = (1.0 - p_spec) * cosine_hemisphere_pdf(wi.z);
    if !HAS_GLOSSY || p.delta {
        return diffuse;
    }
    return p_spec * ggx_vndf_pdf(wo, wi, p.alpha) + diffuse;
}

// A sampled direction. For the delta lobe (`delta`), `pdf` is the discrete probability of
// choosing it and `delta_reflectance` the lobe's reflectance ∫ f cos over it.
struct BsdfSample {
    wi: vec3f,
    pdf: f32,
    delta: bool,
    delta_reflectance: vec3f,
}

// Reflectance of the mirror lobe at normal·wo = c: the Fresnel-weighted layer of fresnel_mix
// and the conductor Fresnel, mixed by metallic (the α → 0 limit of the specular terms).
fn mirror_reflectance(p: BsdfParams, c: f32) -> vec3f {
    return mix(p.specular * dielectric_fresnel(p, c), conductor_fresnel(p, c), p.metallic);
}

// Chooses a lobe with u.x, then samples it with u.x remapped and u.y (one 2D sample, so that the
// sampler's stratification carries into each lobe). pdf = 0 marks a failed sample.
fn bsdf_sample(p: BsdfParams, wo: vec3f, u: vec2f) -> BsdfSample {
    if wo.z <= 0.0 {
        return BsdfSample(vec3f(0.0, 0.0, 1.0), 0.0, false, vec3f(0.0));
    }
    let p_spec = bsdf_specular_probability(p, wo);
    if p.delta && u.x < p_spec {
        return BsdfSample(vec3f(-wo.x, -wo.y, wo.z), p_spec, true, mirror_reflectance(p, wo.z));
    }
    var wi: vec3f;
    if HAS_GLOSSY && u.x < p_spec {
        let h = sample_ggx_vndf(wo, p.alpha, vec2f(remap_below(u.x, p_spec), u.y));
        wi = reflect(-wo, h);
    } else {
        wi = sample_cosine_hemisphere(vec2f(remap_above(u.x, p_spec), u.y));
    }
    if wi.z <= 0.0 {
        return BsdfSample(wi, 0.0, false, vec3f(0.0));
    }
    return BsdfSample(wi, bsdf_pdf(p, wo, wi), false, vec3f(0.0));
}

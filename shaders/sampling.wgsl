// sampling.wgsl: warps from the unit square to directions and points, with their pdfs.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const INV_TWO_PI: f32 = 0.159154943091895;

// Orthonormal frame around a unit normal. Duff et al., "Building an Orthonormal Basis,
// Revisited", JCGT 6(1), 2017.
struct Frame {
    t: vec3f,
    b: vec3f,
    n: vec3f,
}

fn frame_from_normal(n: vec3f) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3f(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3f(b, sign + n.y * n.y * a, -n.y);
    return Frame(t, bt, n);
}

fn frame_to_local(f: Frame, v: vec3f) -> vec3f {
    return vec3f(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

fn frame_to_world(f: Frame, v: vec3f) -> vec3f {
    return v.x * f.t + v.y * f.b + v.z * f.n;
}

// Uniform hemisphere (z up): pdf = 1 / (2 pi). pbrt-v4 §A.5.2.
fn sample_uniform_hemisphere(u: vec2f) -> vec3f {
    let z = u.x;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), z);
}

fn uniform_hemisphere_pdf() -> f32 {
    return INV_TWO_PI;
}

// Concentric disk mapping: Shirley & Chiu, "A Low Distortion Map Between Disk and Square", 1997.
fn sample_concentric_disk(u: vec2f) -> vec2f {
    let o = 2.0 * u - vec2f(1.0);
    if o.x == 0.0 && o.y == 0.0 {
        return vec2f(0.0);
    }
    var r: f32;
    var theta: f32;
    if abs(o.x) > abs(o.y) {
        r = o.x;
        theta = (PI / 4.0) * (o.y / o.x);
    } else {
        r = o.y;
        theta = PI / 2.0 - (PI / 4.0) * (o.x / o.y);
    }
    return r * vec2f(cos(theta), sin(theta));
}

// Cosine-weighted hemisphere (Malley's method): pdf = cos(theta) / pi. pbrt-v4 §A.5.3.
fn sample_cosine_hemisphere(u: vec2f) -> vec3f {
    let d = sample_concentric_disk(u);
    let z = sqrt(max(0.0, 1.0 - dot(d, d)));
    return vec3f(d, z);
}

fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

// Uniform point on a triangle as barycentrics (b1, b2): pdf = 1 / area.
// Turk, "Generating Random Points in Triangles", Graphics Gems 1990.
fn sample_uniform_triangle(u: vec2f) -> vec2f {
    let su = sqrt(u.x);
    return vec2f(u.y * su, 1.0 - su);
}

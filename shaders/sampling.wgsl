// sampling.wgsl: warps from the unit square to directions and points, with their pdfs.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const INV_TWO_PI: f32 = 0.159154943091895;
// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 0.99999994;

// Sample reuse: a uniform u that chose the outcome of probability p (u < p) is uniform again as
// u / p, and one that chose the rest as (u - p) / (1 - p) (pbrt-v4 §A.1, SampleDiscrete).
fn remap_below(u: f32, p: f32) -> f32 {
    return min(u / p, ONE_MINUS_EPSILON);
}

fn remap_above(u: f32, p: f32) -> f32 {
    return clamp((u - p) / (1.0 - p), 0.0, ONE_MINUS_EPSILON);
}

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

// Solid angle of triangle (p0, p1, p2) seen from x. Van Oosterom & Strackee, "The Solid Angle
// of a Plane Triangle", IEEE Trans. Biomed. Eng. 30(2), 1983: for unit a, b, c towards the
// vertices, tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a). Accurate for small triangles,
// where the angle-sum formula Ω = α + β + γ − π cancels.
fn spherical_triangle_solid_angle(x: vec3f, p0: vec3f, p1: vec3f, p2: vec3f) -> f32 {
    let a = normalize(p0 - x);
    let b = normalize(p1 - x);
    let c = normalize(p2 - x);
    let omega = abs(2.0 * atan2(dot(a, cross(b, c)), 1.0 + dot(a, b) + dot(b, c) + dot(c, a)));
    return select(0.0, omega, omega == omega);
}

// Component of v orthogonal to unit w, normalised; zero where v is parallel to w.
fn orthonormal_to(v: vec3f, w: vec3f) -> vec3f {
    let o = v - dot(v, w) * w;
    let len_sq = dot(o, o);
    return select(vec3f(0.0), o * inverseSqrt(len_sq), len_sq > 0.0);
}

// sin and cos of 0 ≤ x ≤ 2π to f32 precision, also near 0: WGSL bounds sin and cos only by an
// absolute error of 2^-11, which is the whole of a small spherical triangle's area. x is halved
// below 1/4, where a Taylor series is exact to f32, and doubled back with sin 2y = 2 sin y cos y,
// cos 2y = 1 − 2 sin² y.
fn sin_cos_accurate(x: f32) -> vec2f {
    var y = x;
    var halvings = 0u;
    while y >= 0.25 && halvings < 8u {
        y *= 0.5;
        halvings++;
    }
    let y2 = y * y;
    var sc = vec2f(y * (1.0 - y2 / 6.0 * (1.0 - y2 / 20.0 * (1.0 - y2 / 42.0))), 1.0 - y2 / 2.0 * (1.0 - y2 / 12.0 * (1.0 - y2 / 30.0)));
    for (var k = 0u; k < halvings; k++) {
        sc = vec2f(2.0 * sc.x * sc.y, 1.0 - 2.0 * sc.x * sc.x);
    }
    return sc;
}

// A direction uniform in the solid angle of triangle (p0, p1, p2) seen from x: pdf = 1 / Ω.
// Arvo, "Stratified Sampling of Spherical Triangles", SIGGRAPH 1995, in the form of pbrt-v4
// §6.5.4 (SampleSphericalTriangle): u.x picks the sub-triangle of area A' = u.x · A, which
// fixes the point C' on the arc from A to C; u.y picks the direction's height along the arc
// from B to C'. pbrt's angles and their sines and cosines come from trigonometric functions;
// here cos α and sin α come from dot and cross products, A from spherical_triangle_solid_angle,
// and sin, cos of π + A' from sin_cos_accurate, so that triangles of 1e-3 sr sample as exactly
// as large ones. Returns the zero vector for a degenerate triangle.
fn sample_spherical_triangle(x: vec3f, p0: vec3f, p1: vec3f, p2: vec3f, u: vec2f) -> vec3f {
    let a = normalize(p0 - x);
    let b = normalize(p1 - x);
    let c = normalize(p2 - x);
    var n_ab = cross(a, b);
    var n_ca = cross(c, a);
    if dot(n_ab, n_ab) == 0.0 || dot(n_ca, n_ca) == 0.0 {
        return vec3f(0.0);
    }
    n_ab = normalize(n_ab);
    n_ca = normalize(n_ca);
    // The spherical triangle's angle α at vertex a, between the planes of arcs ab and ac.
    let cos_alpha = clamp(dot(n_ab, -n_ca), -1.0, 1.0);
    let sin_alpha = length(cross(n_ab, -n_ca));
    let area = spherical_triangle_solid_angle(x, p0, p1, p2);
    if area <= 0.0 || sin_alpha <= 0.0 {
        return vec3f(0.0);
    }
    // sin and cos of A' + π = u.x · A + π.
    let sc = sin_cos_accurate(u.x * area);
    let sin_ap = -sc.x;
    let cos_ap = -sc.y;
    let sin_phi = sin_ap * cos_alpha - cos_ap * sin_alpha;
    let cos_phi = cos_ap * cos_alpha + sin_ap * sin_alpha;
    let k1 = cos_phi + cos_alpha;
    let k2 = sin_phi - sin_alpha * dot(a, b);
    let denom = (k2 * sin_phi + k1 * cos_phi) * sin_alpha;
    var cos_bp = select(1.0, (k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / denom, denom != 0.0);
    cos_bp = clamp(cos_bp, -1.0, 1.0);
    let sin_bp = sqrt(max(0.0, 1.0 - cos_bp * cos_bp));
    let cp = cos_bp * a + sin_bp * orthonormal_to(c, a);
    let cos_theta = 1.0 - u.y * (1.0 - dot(cp, b));
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    return normalize(cos_theta * b + sin_theta * orthonormal_to(cp, b));
}

// A rectangle seen from x, set up for sample_spherical_rectangle: Ureña, Fajardo and King, "An
// Area-Preserving Parametrization for Spherical Rectangles", EGSR 2013, §3. In the frame of unit
// edges ex, ey and ez = ex × ey turned away from x, the rectangle spans [x0, x1] × [y0, y1] at
// height z0 ≤ 0 below x. b0, b1 are the z components of the normals of the planes through x and
// the edges y = y0 and y = y1; the inner angles γ2 + γ3 at the corners (x1, y1) and (x0, y1) are
// kept as their cosine and sine, so that no arc cosine is taken.
struct SphericalRectangle {
    x0: f32,
    y0: f32,
    z0: f32,
    x1: f32,
    y1: f32,
    b0: f32,
    b1: f32,
    cos_g23: f32,
    sin_g23: f32,
    solid_angle: f32,
}

// The rectangle from corner o along perpendicular edges e_u, e_v, seen from x. Its solid angle is
// that of its two triangles by van Oosterom and Strackee, tan(Ω_i / 2) = N_i / D_i, summed as one
// arc tangent (tan of a sum): accurate for small rectangles, where the angle sum
// γ0 + γ1 + γ2 + γ3 − 2π of Ureña's eq. 2 cancels; 0 where x lies in its plane.
fn spherical_rectangle(x: vec3f, o: vec3f, e_u: vec3f, e_v: vec3f) -> SphericalRectangle {
    let len_u = length(e_u);
    let len_v = length(e_v);
    let d = o - x;
    let ex = e_u / len_u;
    let ey = e_v / len_v;
    let z = dot(d, cross(ex, ey));
    let x0 = dot(d, ex);
    let y0 = dot(d, ey);
    let x1 = x0 + len_u;
    let y1 = y0 + len_v;
    let z0 = -abs(z);
    // The planes' normals (Ureña eq. 3, unnormalised n0 = (0, z0, −y0), n1 = (−z0, 0, x1),
    // n2 = (0, −z0, y1), n3 = (z0, 0, −x0)); cos γi = −ni · ni+1, sin γi = |ni × ni+1|.
    let n0 = vec3f(0.0, z0, -y0) * inverseSqrt(z0 * z0 + y0 * y0);
    let n2 = vec3f(0.0, -z0, y1) * inverseSqrt(z0 * z0 + y1 * y1);
    let n3 = vec3f(z0, 0.0, -x0) * inverseSqrt(z0 * z0 + x0 * x0);
    let c2 = -dot(n2, n3);
    let c3 = -dot(n3, n0);
    let s2 = length(cross(n2, n3));
    let s3 = length(cross(n3, n0));
    // Unit directions to the corners, and the two triangles (v00, v10, v11), (v00, v11, v01).
    let a = normalize(vec3f(x0, y0, z0));
    let b = normalize(vec3f(x1, y0, z0));
    let c = normalize(vec3f(x1, y1, z0));
    let e = normalize(vec3f(x0, y1, z0));
    let n_1 = abs(dot(a, cross(b, c)));
    let d_1 = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
    let n_2 = abs(dot(a, cross(c, e)));
    let d_2 = 1.0 + dot(a, c) + dot(c, e) + dot(e, a);
    var omega = 2.0 * atan2(n_1 * d_2 + n_2 * d_1, d_1 * d_2 - n_1 * n_2);
    if !(z0 < 0.0 && omega == omega) {
        omega = 0.0;
    }
    return SphericalRectangle(x0, y0, z0, x1, y1, n0.z, n2.z, c2 * c3 - s2 * s3, s2 * c3 + c2 * s3, omega);
}

// A point uniform in the solid angle of rectangle r (pdf 1 / Ω), as its coordinates (s, t) in
// [0, 1]² along the edges: Ureña et al. 2013, Algorithm 1. u.x fixes the sub-rectangle of solid
// angle u.x Ω, whose edge x = xu follows from cos of the angle there (cu); u.y the height yv
// along that edge, uniform in h = y / √(xu² + z0² + y²). The (s, t) are kept EDGE_MARGIN inside
// the square, so that a ray aimed at the point does not miss the light by its rounding.
fn sample_spherical_rectangle(r: SphericalRectangle, u: vec2f) -> vec2f {
    // sin and cos of au = u.x Ω − (γ2 + γ3) (Ureña's u Ω + k, k = 2π − γ2 − γ3), by the angle
    // difference formulas from those of u.x Ω.
    let sc = sin_cos_accurate(u.x * r.solid_angle);
    let sin_au = sc.x * r.cos_g23 - sc.y * r.sin_g23;
    let cos_au = sc.y * r.cos_g23 + sc.x * r.sin_g23;
    // cu = sign(fu) / √(fu² + b0²) with fu = (cos au b0 − b1) / sin au, written without dividing
    // by sin au, which is 0 at the ends of the range.
    let f = cos_au * r.b0 - r.b1;
    let denom = sqrt(f * f + r.b0 * r.b0 * sin_au * sin_au);
    var cu = select(0.0, select(-1.0, 1.0, f >= 0.0) * sin_au / denom, denom > 0.0);
    cu = clamp(cu, -ONE_MINUS_EPSILON, ONE_MINUS_EPSILON);
    let xu = clamp(-(cu * r.z0) * inverseSqrt(1.0 - cu * cu), r.x0, r.x1);
    let dd = sqrt(xu * xu + r.z0 * r.z0);
    let h0 = r.y0 * inverseSqrt(dd * dd + r.y0 * r.y0);
    let h1 = r.y1 * inverseSqrt(dd * dd + r.y1 * r.y1);
    let hv = h0 + u.y * (h1 - h0);
    let hv2 = hv * hv;
    let yv = clamp(select(r.y1, hv * dd * inverseSqrt(1.0 - hv2), hv2 < 1.0 - 1.0e-6), r.y0, r.y1);
    let st = vec2f((xu - r.x0) / (r.x1 - r.x0), (yv - r.y0) / (r.y1 - r.y0));
    return clamp(st, vec2f(EDGE_MARGIN), vec2f(1.0 - EDGE_MARGIN));
}

// lights.wgsl: per light kind, sample (a point or direction with its pdf) and pdf (of a direction
// that a BRDF or uniform sample found); light_selection.wgsl chooses the light.

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
    // 1 + the light whose subtrees the shadow ray may skip (BvhNode.left_light): where the light
    // is convex and the sampled point's triangle faces the receiver; 0 for none.
    skip: u32,
}

fn light_is_delta(kind: u32) -> bool {
    return kind != LIGHT_AREA;
}

// A triangle of `light` with probability proportional to its area, by the light's alias table (as
// select_light_by_power); the index is into `triangles`.
fn select_emitter_triangle(light: Light, u: f32) -> DiscretePick {
    let b = alias_bucket(u, light.tri_count);
    let bucket = emitter_tri_at(light.first_tri + b.index);
    return alias_pick(b, bucket.alias_prob, bucket.triangle, bucket.alias_triangle);
}

// Triangle i of `light` (an index into `triangles`).
fn light_triangle(light: Light, i: u32) -> u32 {
    return emitter_tri_at(light.first_tri + i).triangle;
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

// With LIGHT_SAMPLING_SOLID_ANGLE, an emitter triangle whose solid angle from the receiver lies in
// this range is sampled by solid angle; outside it by area. Above, the triangle wraps around the
// receiver (pbrt-v4's MaxSphericalSampleArea). Below: pbrt-v4 goes down to 3e-4 sr, but in f32
// the thin triangles of a light seen at grazing angles sample measurably off-uniform there (at
// 7e-4 sr the mean direction moved by 5% of the triangle's width; found with a chi-square test
// in tests/sampling.rs and a float32 replay), and a triangle that small is nearly uniform in
// solid angle under area sampling anyway.
// The same number as light_shape.rs, MIN_SPHERICAL_SAMPLE_SOLID_ANGLE.
const MIN_SPHERICAL_SAMPLE_AREA: f32 = 1.0e-2;
const MAX_SPHERICAL_SAMPLE_AREA: f32 = 6.22;

// Solid angle of the emitter triangle from x where it is sampled by solid angle, else 0.
fn spherical_sampling_solid_angle(x: vec3f, p0: vec3f, p1: vec3f, p2: vec3f) -> f32 {
    if !SOLID_ANGLE_SAMPLING || frame.light_sampling != LIGHT_SAMPLING_SOLID_ANGLE {
        return 0.0;
    }
    let omega = spherical_triangle_solid_angle(x, p0, p1, p2);
    return select(0.0, omega, omega >= MIN_SPHERICAL_SAMPLE_AREA && omega <= MAX_SPHERICAL_SAMPLE_AREA);
}

// With PARALLELOGRAM_LIGHTS, a light of two triangles that make one parallelogram
// (Light.parallelogram) is sampled by area through the linear map of the unit square onto it,
// y = o + u.x a + u.y b. The density is the same, 1 / A, as a triangle chosen by area and a point
// on it by Turk's square-root map, but the sampler's strata stay parallelograms of equal area,
// where the triangle choice cuts the square in two and the square-root map stretches each half
// towards a corner: the Sobol points stratify the light better (docs/performance.md,
// "Parallelogram lights").
fn parallelogram_sampled(light: Light) -> bool {
    if !PARALLELOGRAM_LIGHTS {
        return false;
    }
    return !TRIANGLE_PICKS || (light.parallelogram != 0u && frame.light_sampling != LIGHT_SAMPLING_SOLID_ANGLE);
}

// The point u of the unit square on the parallelogram spanned from corner k = parallelogram - 1 of
// the light's first triangle by its edges to the two other corners; u.x + u.y <= 1 is that triangle.
fn parallelogram_point(light: Light, u: vec2f) -> vec3f {
    return parallelogram_point_on(light, triangle_corners(light_triangle(light, 0u)), u);
}

// The same, given the corners t of the light's first triangle.
fn parallelogram_point_on(light: Light, t: TrianglePositions, u: vec2f) -> vec3f {
    let q = parallelogram_edges(light, t);
    return q.o + u.x * q.e_u + u.y * q.e_v;
}

// A parallelogram light's corner k = (parallelogram & 3) - 1 of its first triangle t, and its edges
// from there to corners k + 1 and k + 2 (mod 3).
struct ParallelogramEdges {
    o: vec3f,
    e_u: vec3f,
    e_v: vec3f,
}

fn parallelogram_edges(light: Light, t: TrianglePositions) -> ParallelogramEdges {
    let k = (light.parallelogram & 3u) - 1u;
    let o = select(select(t.p2, t.p1, k == 1u), t.p0, k == 0u);
    let s0 = select(select(t.p0, t.p2, k == 1u), t.p1, k == 0u);
    let s1 = select(select(t.p1, t.p0, k == 1u), t.p2, k == 0u);
    return ParallelogramEdges(o, s0 - o, s1 - o);
}

// With RECTANGLE_SAMPLING and LIGHT_SAMPLING_SOLID_ANGLE or _AUTO, a rectangle light
// (Light.parallelogram has RECTANGLE_LIGHT) is sampled uniformly in its solid angle as a whole
// (Ureña et al. 2013; sampling.wgsl, sample_spherical_rectangle), pdf 1 / Ω: bounded where area
// sampling's r² / |cos θ_l| grows (grazing angles, receivers touching the light), and the Sobol
// points' strata stay equal in solid angle over the whole light. Like triangles, rectangles
// subtending less than MIN_SPHERICAL_SAMPLE_AREA keep area sampling, which is nearly uniform in
// solid angle there. Returns the rectangle seen from x, its solid angle 0 where area sampling
// takes it.
fn rectangle_sampled(light: Light, x: vec3f) -> SphericalRectangle {
    var r = SphericalRectangle(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let mode = frame.light_sampling;
    if !RECTANGLE_SAMPLING || (light.parallelogram & RECTANGLE_LIGHT) == 0u
        || !(mode == LIGHT_SAMPLING_SOLID_ANGLE || mode == LIGHT_SAMPLING_AUTO) {
        return r;
    }
    // A planar light of area A within radius R of its centre subtends at most A / (d − R)² from a
    // point at distance d: below the threshold, the setup is skipped (the same test, on the same
    // inputs, in sampling and in the pdf).
    let beyond = length(light.position - x) - light.bound_radius;
    if beyond > 0.0 && light.area < MIN_SPHERICAL_SAMPLE_AREA * beyond * beyond {
        return r;
    }
    let q = parallelogram_edges(light, triangle_corners(light_triangle(light, 0u)));
    r = spherical_rectangle(x, q.o, q.e_u, q.e_v);
    if !(r.solid_angle >= MIN_SPHERICAL_SAMPLE_AREA) {
        r.solid_angle = 0.0;
    }
    return r;
}

// Barycentrics (b1, b2) of point y in the plane of triangle v, whose edges from v.p0 are e1 and e2
// (normal n = e1 × e2).
fn triangle_barycentrics(v: TrianglePositions, e1: vec3f, e2: vec3f, n: vec3f, y: vec3f) -> vec2f {
    let d = y - v.p0;
    let b = vec2f(dot(cross(d, e2), n), dot(cross(e1, d), n)) / dot(n, n);
    return clamp(b, vec2f(0.0), vec2f(1.0));
}

// Barycentrics (b1, b2) moved at least EDGE_MARGIN inside the triangle. Rounding in Arvo's
// construction leaves a few directions just outside the spherical triangle; pbrt-v4 §6.5.4
// (SampleSphericalTriangle) clamps their barycentrics onto it, and the margin keeps a ray aimed at
// the point from missing the triangle by its own rounding. Without it, lavapipe had 2 of 2^20
// solid-angle samples whose ray missed the light, an NVIDIA H200 up to 196 whose pdf the pdf
// function did not give back (tests/sampling.rs). Points already inside by the margin do not move.
const EDGE_MARGIN: f32 = 1.0e-5;

fn barycentrics_inside(b: vec2f) -> vec2f {
    let c = max(b, vec2f(EDGE_MARGIN));
    let sum = c.x + c.y;
    return select(c, c * ((1.0 - EDGE_MARGIN) / sum), sum > 1.0 - EDGE_MARGIN);
}

// Area light: an emitter triangle chosen by area, then a point uniform on it (pdf 1/A in area,
// converted to solid angle), or, with LIGHT_SAMPLING_SOLID_ANGLE, a direction uniform in the
// triangle's solid angle (pdf P(triangle) / Ω, Arvo 1995), which stays bounded where r² → 0
// at a contact edge and where cos θ_l → 0 at grazing angles. A rectangle light seen wide enough,
// with LIGHT_SAMPLING_SOLID_ANGLE or _AUTO, is sampled as one spherical rectangle instead
// (rectangle_sampled).
fn sample_area_light(index: u32, light: Light, x: vec3f, u_light: vec2f) -> LightSample {
    let rectangle = rectangle_sampled(light, x);
    // A rectangle sampled by solid angle gives a point (s, t) of the unit square, which maps onto
    // it as an area sample's u does.
    var u_square = u_light;
    if rectangle.solid_angle > 0.0 {
        u_square = sample_spherical_rectangle(rectangle, u_light);
    }
    let parallelogram = rectangle.solid_angle > 0.0 || parallelogram_sampled(light);
    let pick = select_emitter_triangle(light, u_light.x);
    var tri = pick.index;
    if parallelogram {
        // The parallelogram's second triangle is where u.x + u.y > 1 (parallelogram_point).
        tri = light_triangle(light, select(0u, 1u, u_square.x + u_square.y > 1.0));
    }
    let u = vec2f(pick.u, u_light.y);
    let v = triangle_corners(tri);
    let e1 = v.p1 - v.p0;
    let e2 = v.p2 - v.p0;
    let n = cross(e1, e2);
    let n_l = normalize(n);
    var b = sample_uniform_triangle(u);
    var y = v.p0 + b.x * e1 + b.y * e2;
    if parallelogram {
        y = parallelogram_point(light, u_square);
        b = triangle_barycentrics(v, e1, e2, n, y);
    }
    let omega = select(spherical_sampling_solid_angle(x, v.p0, v.p1, v.p2), 0.0, rectangle.solid_angle > 0.0);
    var failed = false;
    if omega > 0.0 {
        let w = sample_spherical_triangle(x, v.p0, v.p1, v.p2, u);
        // The point where the direction meets the triangle's plane, and its barycentrics.
        let t = dot(v.p0 - x, n) / dot(w, n);
        failed = all(w == vec3f(0.0)) || !(t > 0.0);
        b = barycentrics_inside(triangle_barycentrics(v, e1, e2, n, x + t * w));
        y = v.p0 + b.x * e1 + b.y * e2;
    }
    let d = y - x;
    let dist_sq = dot(d, d);
    let dist = sqrt(dist_sq);
    let wi = d / dist;
    var s = LightSample(wi, dist, vec3f(0.0), 0.0, false, offset_ray_origin(y, n_l, -wi), 0u);
    if failed || dist_sq <= 0.0 || !emits_towards(light.double_sided != 0u, n_l, wi) {
        return s;
    }
    // In front of the sampled triangle's plane, the receiver sees a convex light nowhere else.
    s.skip = select(0u, index + 1u, light.convex != 0u && dot(n_l, wi) < 0.0);
    s.value = light.intensity * emitter_emission_texture(tri, b.x, b.y);
    if rectangle.solid_angle > 0.0 {
        s.pdf = 1.0 / rectangle.solid_angle;
    } else if omega > 0.0 {
        s.pdf = (0.5 * length(n) / light.area) / omega;
    } else {
        s.pdf = area_to_solid_angle_pdf(dist_sq, dot(n_l, wi), light.area);
    }
    return s;
}

// With LIGHT_SAMPLING_CONE or _AUTO, a round light (Light.round: convex, filling at least half of its
// bounding sphere's surface) is sampled by the cone its bounding sphere subtends: a direction
// uniform in the cone (pdf 1 / Ω), traced to its closest hit, which counts where it is the chosen
// light (pbrt-v4 §6.2.4, Sphere::Sample; Shirley et al. 1996); from inside the sphere, by a
// direction uniform over all of them (pdf 1 / 4π). Area sampling sends about half of a sphere's
// samples to its far side and weighs the rest by r² / (|cos θ_l| A), unbounded at the
// silhouette; the cone's density is constant over the light. Other lights keep area sampling;
// without SHADOW_RAY_LIGHTS the kernel has none.
fn cone_sampled(light: Light) -> bool {
    if !samples_cones() {
        return false;
    }
    return !SHADOW_RAY_LIGHTS || (light.kind == LIGHT_AREA && light.round != 0u);
}

// Does the render sample round lights by their cones (LIGHT_SAMPLING_CONE or _AUTO)?
fn samples_cones() -> bool {
    return CONE_SAMPLING && (frame.light_sampling == LIGHT_SAMPLING_CONE || frame.light_sampling == LIGHT_SAMPLING_AUTO);
}

// The cone from x around the bounding sphere of `light`: its axis and 1 − cos θ_max, written as
// sin²θ_max / (1 + cos θ_max), which does not cancel for small, distant spheres.
struct BoundingCone {
    axis: vec3f,
    one_minus_cos_max: f32,
}

fn bounding_cone(light: Light, x: vec3f) -> BoundingCone {
    let d = light.position - x;
    let dist_sq = dot(d, d);
    let r_sq = light.bound_radius * light.bound_radius;
    if !(dist_sq > r_sq) {
        // Inside the sphere: the whole sphere of directions, 1 − cos θ_max = 2.
        return BoundingCone(vec3f(0.0, 0.0, 1.0), 2.0);
    }
    let sin2_max = r_sq / dist_sq;
    let cos_max = sqrt(1.0 - sin2_max);
    return BoundingCone(d * inverseSqrt(dist_sq), sin2_max / (1.0 + cos_max));
}

// Directions uniform in the cone: pdf 1 / (2π (1 − cos θ_max)) (the cone's solid angle).
fn cone_pdf(cone: BoundingCone) -> f32 {
    return 1.0 / (2.0 * PI * cone.one_minus_cos_max);
}

// A direction uniform in the cone: 1 − cos θ = u.x (1 − cos θ_max), sin²θ = (1 − cos θ)(1 + cos θ)
// written without the cancellation, φ = 2π u.y about the axis.
fn sample_cone(cone: BoundingCone, u: vec2f) -> vec3f {
    let one_minus_cos = u.x * cone.one_minus_cos_max;
    let cos_theta = 1.0 - one_minus_cos;
    let sin_theta = sqrt(max(one_minus_cos * (2.0 - one_minus_cos), 0.0));
    let phi = 2.0 * PI * u.y;
    let f = frame_from_normal(cone.axis);
    return normalize(frame_to_world(f, vec3f(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta)));
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
        return LightSample(-light.direction, RAY_INF, light.intensity, 1.0, true, vec3f(0.0), 0u);
    }
    let d = light.position - x;
    let dist_sq = dot(d, d);
    let dist = sqrt(dist_sq);
    let wi = d / dist;
    var value = light.intensity / dist_sq;
    if light.kind == LIGHT_SPOT {
        value *= spot_falloff(light, wi);
    }
    return LightSample(wi, dist, value, 1.0, true, light.position, 0u);
}

// Sample light `index` from x; the returned pdf excludes the selection probability.
fn sample_light(index: u32, x: vec3f, u: vec2f) -> LightSample {
    let light = light_at(index);
    if HAS_AREA_LIGHTS && light.kind == LIGHT_AREA {
        return sample_area_light(index, light, x, u);
    }
    if HAS_DELTA_LIGHTS {
        return sample_delta_light(light, x);
    }
    return LightSample(vec3f(0.0, 0.0, 1.0), 0.0, vec3f(0.0), 0.0, false, x, 0u);
}

// Solid-angle pdf with which the light strategy (selection included) would have produced the
// direction from x to point y on emitter triangle v of light `index`.
fn area_light_pdf(index: u32, x: vec3f, v: TrianglePositions, y: vec3f) -> f32 {
    return light_selection_pdf(index) * area_light_direction_pdf(index, x, v, y);
}

// The same density once light `index` is chosen (sample_area_light's pdf).
fn area_light_direction_pdf(index: u32, x: vec3f, v: TrianglePositions, y: vec3f) -> f32 {
    let light = light_at(index);
    if cone_sampled(light) {
        // Every point of the light lies in its bounding sphere, so in the cone.
        return cone_pdf(bounding_cone(light, x));
    }
    let rectangle = rectangle_sampled(light, x);
    if rectangle.solid_angle > 0.0 {
        return 1.0 / rectangle.solid_angle;
    }
    let n = cross(v.p1 - v.p0, v.p2 - v.p0);
    let omega = spherical_sampling_solid_angle(x, v.p0, v.p1, v.p2);
    if omega > 0.0 {
        return (0.5 * length(n) / light.area) / omega;
    }
    let d = y - x;
    let cos_l = dot(normalize(n), normalize(d));
    return area_to_solid_angle_pdf(dot(d, d), cos_l, light.area);
}

// emitter_reach looks at the lights one by one up to this many; past it, at one sphere and one box
// around all.
const MAX_REACH_LIGHTS: u32 = 16u;

// Where a ray along unit `dir` leaves the sphere, or 0 if it misses it or the sphere lies behind.
fn sphere_exit(origin: vec3f, dir: vec3f, centre: vec3f, radius: f32) -> f32 {
    let to_centre = centre - origin;
    let b = dot(to_centre, dir);
    // Squared distance from the centre to the ray's line from the perpendicular itself, not as
    // |to_centre|^2 - b^2, which cancels for distant spheres (Haines et al., "Precision
    // Improvements for Ray/Sphere Intersection", Ray Tracing Gems, ch. 7, 2019).
    let perp = to_centre - b * dir;
    let h_sq = radius * radius - dot(perp, perp);
    return select(0.0, max(b + sqrt(max(h_sq, 0.0)), 0.0), h_sq >= 0.0 && radius > 0.0);
}

// Where a ray leaves the box, or 0 if it misses it or the box lies behind: the slab test, its exit
// grown by 1 + 2 gamma(3) as in intersect_aabb (Ize 2013), so rounding cannot clip a ray short.
fn box_exit(origin: vec3f, dir: vec3f, bmin: vec3f, bmax: vec3f) -> f32 {
    let inv_dir = safe_inverse(dir);
    let t0 = (bmin - origin) * inv_dir;
    let t1 = (bmax - origin) * inv_dir;
    let tnear = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z));
    let tfar = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z)) * 1.0000004;
    return select(0.0, tfar, tnear <= tfar && tfar > 0.0);
}

// How far along origin + t dir (dir of unit length) a direction sample can find emitted radiance:
// the farthest exit from the bounding spheres of the area lights the ray crosses, 0 when it
// crosses none. Emission comes from area lights only and every triangle of a light lies in its
// sphere, so a closest-hit ray clipped there finds the same emitter as an unclipped one, or
// nothing where the unclipped one would have found a surface that emits nothing: the estimate is
// unchanged, and a ray that crosses no light's sphere is not traced at all.
fn emitter_reach(origin: vec3f, dir: vec3f) -> f32 {
    if !HAS_AREA_LIGHTS {
        return 0.0;
    }
    if light_count() > MAX_REACH_LIGHTS {
        // Every emitter lies in both: a ray finds one before it leaves either. The box is the
        // tighter for lights in a plane (a ceiling of panels): under `veach scale`'s grid of
        // 10,000 lights it traces 0.86x the sphere's rays, and renders 100 lights in 0.81x the time.
        let sphere = sphere_exit(origin, dir, frame.emitter_centre, frame.emitter_radius);
        let box = box_exit(origin, dir, frame.emitter_min, frame.emitter_max);
        return min(sphere, box) * (1.0 + 1.0e-4);
    }
    var reach = 0.0;
    // Tested at its end (megakernel.wgsl's `render` says why).
    if light_count() > 0u {
        var li = 0u;
        loop {
            let light = light_at(li);
            if light.kind == LIGHT_AREA {
                reach = max(reach, sphere_exit(origin, dir, light.position, light.bound_radius));
            }
            li++;
            if li >= light_count() {
                break;
            }
        }
    }
    // A little past the exit, for the rounding of the exit distance itself.
    return reach * (1.0 + 1.0e-4);
}

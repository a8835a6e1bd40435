// control_variate.wgsl: the unshadowed diffuse light as a control variate (`--control-variate`).
//
// At a shading point the estimate of  ∫ f L_e V |cos θ| dω  (V: nothing blocks the light) becomes
//   F = A + MC[ f L_e V cos θ − g ],   g(ω) = k L_e(ω) cos θ,   A = ∫ g dω  in closed form,
// with k the diffuse lobe's f (its albedo over π) and the same light samples, direction samples
// and MIS weights as without it: the control variate in its unbiased, additive form (Hammersley &
// Handscomb, "Monte Carlo Methods", 1964; for direct light: Heitz, Hill & McGuire, "Combining
// Analytic Direct Illumination and Stochastic Shadows", I3D 2018, whose ratio form is biased). E[MC of f L_e V cos − g] = ∫ f L_e V cos − A, so F is unbiased whatever k is;
// where a Lambertian surface sees a light unblocked every sample's f L_e V cos − g is zero, so the
// estimate there has no variance, and only penumbrae and umbrae keep theirs.
//
// g is evaluated per emitter polygon (emitter_polygon: a parallelogram light as one, else each
// triangle), other emitters and blockers ignored: a light sample's g is at its own point, and a
// direction sample's is the sum over the polygons its ray crosses (control_variate_direction_term).
// A sums, per polygon of constant radiance, Lambert's formula for its projected solid angle
// clipped to the hemisphere above the shading normal (polygon_projected_solid_angle). Where a shading normal leans off the geometric one, g
// stays non-zero below the geometric normal's plane, where f L_e V cos is zero: the samples that
// land there carry −g (trace_light_sample, and direction samples whether valid or not).
// The host allows it only where that holds: area lights without emission textures, a bounded
// number of emitter triangles (crates/veach/src/control_variate.rs), no mirrors, no cone samples.

fn uses_control_variate() -> bool {
    return CONTROL_VARIATE && frame.control_variate != 0u && active_strategy() != STRATEGY_MIS_LOBES;
}

// k: the diffuse lobe's f (bsdf_eval_lobes) with the Fresnel weight at normal incidence, f0. The
// lobe is k exactly where there is no specular layer (the Cornell box), below it elsewhere.
fn control_variate_albedo(c: ShadingContext) -> vec3f {
    if c.wo.z <= 0.0 {
        return vec3f(0.0);
    }
    let f0 = min(vec3f(0.04) * c.bsdf.specular_color, vec3f(1.0));
    return (1.0 - c.bsdf.metallic) * (1.0 - c.bsdf.specular * max3(f0)) * c.bsdf.base_color * INV_PI;
}

// One term of Lambert's formula, the arc from corner a to corner b (relative to the shading
// point): Θ (n · (a × b) / |a × b|) with Θ the angle between them, atan2(|a × b|, a · b), which
// needs no unit vectors and keeps its precision for small and for near-π angles where acos of
// the dot product does not. Zero for a corner repeated or a zero vector.
fn lambert_arc(a: vec3f, b: vec3f, n: vec3f) -> f32 {
    let c = cross(a, b);
    let s = length(c);
    return select(0.0, atan2(s, dot(a, b)) / s * dot(c, n), s > 0.0);
}

// An edge of a convex polygon clipped to the hemisphere above n (Sutherland & Hodgman, "Reentrant
// Polygon Clipping", CACM 17(1), 1974, one plane, without branches): its arc's term, and where it
// leaves the hemisphere (exit) or enters it (entry), zero where it does neither. A convex polygon
// cut by the plane leaves once and enters once, and the clipped polygon closes with the arc along
// the horizon from the exit to the entry.
struct ClippedEdge {
    term: f32,
    exit: vec3f,
    entry: vec3f,
}

fn clipped_edge(a: vec3f, b: vec3f, n: vec3f) -> ClippedEdge {
    let da = dot(a, n);
    let db = dot(b, n);
    let above_a = da >= 0.0;
    let above_b = db >= 0.0;
    // Where the edge meets the plane; used only where its ends lie on either side.
    let p = a + (da / (da - db)) * (b - a);
    let term = lambert_arc(select(p, a, above_a), select(p, b, above_b), n);
    return ClippedEdge(
        select(0.0, term, above_a || above_b),
        select(vec3f(0.0), p, above_a && !above_b),
        select(vec3f(0.0), p, !above_a && above_b),
    );
}

// ∫ cos θ dω (θ from n) over the directions of the convex polygon a b c d (relative to the
// shading point; a triangle repeats a corner) above the horizon: Lambert's formula, ½ |Σ arcs|,
// π times the point-to-polygon form factor of Baum, Rushmeier & Winget ("Improving Radiosity
// Solutions Through the Use of Analytically Determined Form-Factors", SIGGRAPH 1989), on the
// polygon clipped to the horizon first as Heitz et al. do ("Real-Time Polygonal-Light Shading with
// Linearly Transformed Cosines", SIGGRAPH 2016). A repeated corner adds a zero-length arc.
fn clipped_projected_solid_angle(a: vec3f, b: vec3f, c: vec3f, d: vec3f, n: vec3f) -> f32 {
    let e0 = clipped_edge(a, b, n);
    let e1 = clipped_edge(b, c, n);
    let e2 = clipped_edge(c, d, n);
    let e3 = clipped_edge(d, a, n);
    let horizon = lambert_arc(e0.exit + e1.exit + e2.exit + e3.exit, e0.entry + e1.entry + e2.entry + e3.entry, n);
    return 0.5 * abs(e0.term + e1.term + e2.term + e3.term + horizon);
}

// The emitter polygons of a light that the control variate takes one by one: its parallelogram as
// one where its samples map the unit square onto it (parallelogram_sampled: then a point's light
// pdf is the same on both triangles), else each triangle. With SINGLE_LIGHT and every light a
// parallelogram the count is the constant 1, and the loops over lights and polygons go.
fn emitter_polygons(light: Light) -> u32 {
    return select(light.tri_count, 1u, parallelogram_sampled(light));
}

// Polygon i of a light: a corner and the edges to its two neighbours, a parallelogram (o, o + e1,
// o + e1 + e2, o + e2) or a triangle (p0, p0 + e1, p0 + e2); the triangle it lies on, for its pdf.
struct EmitterPolygon {
    o: vec3f,
    e1: vec3f,
    e2: vec3f,
    parallelogram: bool,
    tri: TrianglePositions,
}

fn emitter_polygon(light: Light, i: u32) -> EmitterPolygon {
    let t = triangle_corners(light_triangle(light, i));
    if parallelogram_sampled(light) {
        // t is the first triangle's: a parallelogram is one polygon (emitter_polygons).
        let o = parallelogram_point_on(light, t, vec2f(0.0));
        return EmitterPolygon(o, parallelogram_point_on(light, t, vec2f(1.0, 0.0)) - o, parallelogram_point_on(light, t, vec2f(0.0, 1.0)) - o, true, t);
    }
    return EmitterPolygon(t.p0, t.p1 - t.p0, t.p2 - t.p0, false, t);
}

// The projected solid angle about n of polygon q seen from x, clipped to the hemisphere above n:
// zero from behind a one-sided emitter (emits_towards).
fn polygon_projected_solid_angle(q: EmitterPolygon, double_sided: bool, x: vec3f, n: vec3f) -> f32 {
    let a = q.o - x;
    if !double_sided && dot(cross(q.e1, q.e2), a) >= 0.0 {
        return 0.0;
    }
    let far = select(a + q.e2, a + q.e1 + q.e2, q.parallelogram);
    return clipped_projected_solid_angle(a, a + q.e1, far, a + q.e2, n);
}

// A = ∫ g dω at the shading point: k times, per area light, its radiance times the projected solid
// angle of its polygons.
fn unshadowed_light_integral(c: ShadingContext) -> vec3f {
    let k = control_variate_albedo(c);
    if all(k == vec3f(0.0)) {
        return vec3f(0.0);
    }
    // Loops tested at their end (megakernel.wgsl's `render` says why); an area light has a
    // polygon.
    var sum = vec3f(0.0);
    if light_count() > 0u {
        var li = 0u;
        loop {
            let light = light_at(li);
            if light.kind == LIGHT_AREA {
                var psa = 0.0;
                var i = 0u;
                loop {
                    psa += polygon_projected_solid_angle(emitter_polygon(light, i), light.double_sided != 0u, c.s.p, c.s.ns);
                    i++;
                    if i >= emitter_polygons(light) {
                        break;
                    }
                }
                sum += light.intensity * psa;
            }
            li++;
            if li >= light_count() {
                break;
            }
        }
    }
    return k * sum;
}

// A light sample's g before its shadow ray: k L_e cos θ_i (wi in the shading frame); zero for
// delta lights, which A leaves out.
fn control_variate_light_integrand(c: ShadingContext, value: vec3f, wi: vec3f, is_delta: bool) -> vec3f {
    if !uses_control_variate() || is_delta {
        return vec3f(0.0);
    }
    return control_variate_albedo(c) * value * wi.z;
}

// Distance along the ray to polygon q, or 0 where it misses (Möller & Trumbore, "Fast, Minimum
// Storage Ray/Triangle Intersection", JGT 2(1), 1997; a parallelogram takes both coordinates in
// [0, 1] instead of their sum).
fn polygon_crossing(origin: vec3f, dir: vec3f, q: EmitterPolygon) -> f32 {
    let p = cross(dir, q.e2);
    let det = dot(q.e1, p);
    let inv = 1.0 / det;
    let s = origin - q.o;
    let b1 = dot(s, p) * inv;
    let r = cross(s, q.e1);
    let b2 = dot(dir, r) * inv;
    let dist = dot(q.e2, r) * inv;
    let inside = b1 >= 0.0 && b2 >= 0.0 && select(b1 + b2 <= 1.0, b1 <= 1.0 && b2 <= 1.0, q.parallelogram);
    return select(0.0, dist, det != 0.0 && inside && dist > 0.0);
}

// A direction sample's part of the control variate, −Σ w g / p over the emitter polygons its ray
// crosses (blockers and other emitters ignored), with the MIS weight direction_sample_value gives
// a hit there; taken whether or not its ray is traced, and also where the sample adds nothing
// because the direction lies below the geometric normal's plane (g is not clipped there).
fn control_variate_direction_term(c: ShadingContext, d: DirectionSample, plan: SamplePlan) -> vec3f {
    let k = control_variate_albedo(c);
    let cos_i = dot(d.wi, c.s.ns);
    if all(k == vec3f(0.0)) || cos_i <= 0.0 || !(d.pdf > 0.0) {
        return vec3f(0.0);
    }
    // Loops tested at their end, as in unshadowed_light_integral.
    var sum = vec3f(0.0);
    if light_count() > 0u {
        var li = 0u;
        loop {
            let light = light_at(li);
            if light.kind == LIGHT_AREA {
                var i = 0u;
                loop {
                    sum += polygon_direction_weight(c, d, plan, li, light, emitter_polygon(light, i)) * light.intensity;
                    i++;
                    if i >= emitter_polygons(light) {
                        break;
                    }
                }
            }
            li++;
            if li >= light_count() {
                break;
            }
        }
    }
    return -(k * cos_i / d.pdf) * sum;
}

// The MIS weight direction_sample_value gives a hit on polygon q of light li (`light`) where the
// direction sample's ray crosses q towards its emitting side, else 0.
fn polygon_direction_weight(c: ShadingContext, d: DirectionSample, plan: SamplePlan, li: u32, light: Light, q: EmitterPolygon) -> f32 {
    let dist = polygon_crossing(c.s.p, d.wi, q);
    if dist <= 0.0 || !emits_towards(light.double_sided != 0u, cross(q.e1, q.e2), d.wi) {
        return 0.0;
    }
    var w = 1.0;
    if d.mis && plan.n > 0u {
        let p_light = area_light_pdf(li, c.s.p, q.tri, c.s.p + dist * d.wi);
        if p_light > 0.0 {
            w = mis_weight(f32(plan.m), d.pdf, f32(plan.n), p_light);
        }
    }
    return w;
}

// light_selection.wgsl: which light a light sample takes, and the probability of that choice:
// each light in turn, uniformly, by power (alias table), per shading point by the BSDF, or by the
// light tree (light_tree.wgsl).

// SELECT_BSDF chooses among at most this many lights per shading point; with more it chooses
// by power (a loop over the lights at every point would cost more than it saves).
const MAX_POINT_SELECTION_LIGHTS: u32 = 16u;

// SELECT_BSDF: the probability of choosing each light at the current shading point, set by
// prepare_point_selection when the camera ray's hit is shaded (one shading point per camera
// sample, so every light sample and MIS weight of the sample reads the same table).
var<private> point_selection: array<f32, MAX_POINT_SELECTION_LIGHTS>;

// The power share of SELECT_BSDF's mixture. On the Veach scene (MIS 1 + 1, 32 spp, 3 seeds) 1/2
// gave relMSE 1.12e-2, 1/4 8.75e-3, 1/10 9.31e-3 (docs/performance.md): 1/4, tuned on that one
// scene, bounds the loss where the guess is wrong at 4x the second moment of power alone.
const POWER_SHARE: f32 = 0.25;

fn uses_point_selection() -> bool {
    return active_light_selection() == SELECT_BSDF && light_count() > 1u &&
        light_count() <= MAX_POINT_SELECTION_LIGHTS;
}

// A guess at how much light `index` sends to x through the BSDF: its power share times
// f |cos θ_i| / d² towards its centre (an area light's bounding-sphere centre, clamped to the
// sphere's radius inside it; a directional light's direction, d = 1). It ranks lights that the
// lobe faces above lights behind or beside it; it needs to be no more than a guess, since
// prepare_point_selection mixes it with the power shares.
fn light_importance(index: u32, x: vec3f, shading: Frame, wo: vec3f, bsdf: BsdfParams) -> f32 {
    let light = light_at(index);
    var to_light = -light.direction;
    var dist_sq = 1.0;
    if light.kind != LIGHT_DIRECTIONAL {
        let d = light.position - x;
        let len_sq = dot(d, d);
        if !(len_sq > 0.0) {
            return 0.0;
        }
        to_light = d * inverseSqrt(len_sq);
        dist_sq = max(len_sq, light.bound_radius * light.bound_radius);
    }
    let wi = frame_to_local(shading, to_light);
    let f = bsdf_eval_lobes(bsdf, wo, wi);
    return light_pick_at(index).pdf * luminance(f.diffuse + f.glossy) * max(wi.z, 0.0) / dist_sq;
}

// SELECT_BSDF at shading point x: P(light i) = a P_power(i) + (1 - a) g_i / Σg (g:
// light_importance, a = POWER_SHARE), or P_power(i) where every g is zero. The power part is a
// defensive mixture (Hesterberg, "Weighted Average Importance Sampling and Defensive Mixture
// Distributions", Technometrics 37(2), 1995): every light with power keeps at least a of its
// power share, so the estimator is unbiased whatever the guess, and a bad guess costs at most 1/a
// times the second moment of choosing by power (the sample's weight 1/P is at most 1/a times its
// weight there).
fn prepare_point_selection(x: vec3f, shading: Frame, wo: vec3f, bsdf: BsdfParams) {
    // SELECT_TREE: the point and its shading normal, which the tree's walks read.
    tree_point = x;
    tree_normal = shading.n;
    if !uses_point_selection() {
        return;
    }
    // Loops tested at their end (megakernel.wgsl's `render` says why): there are two lights or more.
    var sum = 0.0;
    var i = 0u;
    loop {
        let g = light_importance(i, x, shading, wo, bsdf);
        point_selection[i] = g;
        sum += g;
        i++;
        if i >= light_count() {
            break;
        }
    }
    let guess = select(0.0, (1.0 - POWER_SHARE) / sum, sum > 0.0 && sum < RAY_INF);
    let power = select(1.0, POWER_SHARE, guess > 0.0);
    i = 0u;
    loop {
        point_selection[i] = power * light_pick_at(i).pdf + guess * point_selection[i];
        i++;
        if i >= light_count() {
            break;
        }
    }
}

// A light by the point's table: the interval of u in the table's running sum, with u remapped
// inside it (as alias_pick remaps), so that the sample's stratification carries over.
fn select_light_at_point(u: f32) -> DiscretePick {
    var start = 0.0;
    var pick = DiscretePick(0u, u);
    // Tested at its end, as in prepare_point_selection (two lights or more).
    var i = 0u;
    loop {
        let p = point_selection[i];
        // The last light with p > 0 whose interval starts at or below u: rounding in the sum
        // cannot leave u without a light.
        if p > 0.0 && u >= start {
            pick = DiscretePick(i, clamp((u - start) / p, 0.0, ONE_MINUS_EPSILON));
        }
        start += p;
        i++;
        if i >= light_count() {
            break;
        }
    }
    return pick;
}

// Probability that light `index` is chosen by the frame's light-selection method (at the
// current shading point, for SELECT_BSDF).
fn light_selection_pdf(index: u32) -> f32 {
    if SINGLE_LIGHT {
        return 1.0;
    }
    if uses_point_selection() {
        return point_selection[min(index, MAX_POINT_SELECTION_LIGHTS - 1u)];
    }
    if uses_light_tree() {
        return light_tree_pmf(index);
    }
    switch active_light_selection() {
        case SELECT_UNIFORM: {
            return 1.0 / f32(light_count());
        }
        case SELECT_POWER, SELECT_BSDF: {
            return light_pick_at(index).pdf;
        }
        default: {
            // SELECT_EACH: every light gets its own samples.
            return 1.0;
        }
    }
}

// A discrete choice made with one uniform number u, and u remapped to a uniform number again
// (sampling.wgsl's remap_below / remap_above), so that the same 2D sample chooses a light, an
// emitter triangle and the point on it: the stratification of the sampler's 2D points then
// carries over the whole light, where a separate number for the choice would deal each
// triangle a random subset of them (Mitsuba 3's sample reuse; pbrt-v4 SampleDiscrete's uRemapped).
struct DiscretePick {
    index: u32,
    u: f32,
}

// Bucket i = ⌊u N⌋ of N, and the fraction of u left over inside it (a second uniform number).
struct AliasBucket {
    index: u32,
    frac: f32,
}

fn alias_bucket(u: f32, n: u32) -> AliasBucket {
    let x = u * f32(n);
    let i = min(u32(x), n - 1u);
    return AliasBucket(i, clamp(x - f32(i), 0.0, 1.0));
}

// The alias method (Walker 1977; Vose 1991): the bucket keeps its own outcome with probability
// `keep`, else gives its alias. O(1), where a binary search over a CDF took log2(N) loads.
fn alias_pick(b: AliasBucket, keep: f32, own: u32, other: u32) -> DiscretePick {
    if b.frac < keep {
        return DiscretePick(own, remap_below(b.frac, keep));
    }
    return DiscretePick(other, remap_above(b.frac, keep));
}

// A light with probability light_pick_at(i).pdf, by the lights' alias table.
fn select_light_by_power(u: f32) -> DiscretePick {
    let b = alias_bucket(u, light_count());
    let bucket = light_pick_at(b.index);
    return alias_pick(b, bucket.alias_prob, b.index, bucket.alias_index);
}

// How many lights loops over the lights visit: with SINGLE_LIGHT the constant 1, so that the
// compiler unrolls them away (Mesa 22.3 keeps a loop of one trip otherwise, with its overhead).
fn light_count() -> u32 {
    return select(frame.light_count, 1u, SINGLE_LIGHT);
}

// Light `index`'s record; with SINGLE_LIGHT, light 0's at a constant index.
fn light_at(index: u32) -> Light {
    if SINGLE_LIGHT {
        return light_record(0u);
    }
    return light_record(index);
}

fn select_light(u: f32) -> DiscretePick {
    if SINGLE_LIGHT {
        // What each selection below gives for one light: alias_bucket(u, 1) = (0, u), kept.
        return DiscretePick(0u, remap_below(u, 1.0));
    }
    if uses_point_selection() {
        return select_light_at_point(u);
    }
    if uses_light_tree() {
        return select_light_from_tree(u).pick;
    }
    let selection = active_light_selection();
    if selection == SELECT_POWER || selection == SELECT_BSDF {
        return select_light_by_power(u);
    }
    let b = alias_bucket(u, light_count());
    return DiscretePick(b.index, remap_below(b.frac, 1.0));
}

// A light chosen by the frame's selection, and the probability of choosing it.
struct SelectedLight {
    pick: DiscretePick,
    pmf: f32,
}

// select_light and light_selection_pdf in one: the tree's walk gives the probability as it goes,
// where light_selection_pdf would walk the tree again.
fn select_light_with_pmf(u: f32) -> SelectedLight {
    if uses_light_tree() {
        return select_light_from_tree(u);
    }
    let pick = select_light(u);
    return SelectedLight(pick, light_selection_pdf(pick.index));
}

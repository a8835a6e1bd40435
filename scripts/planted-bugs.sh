#!/usr/bin/env bash
# Plants known bugs in the WGSL (and the host code), one at a time, in a scratch copy of the tree, and checks that
# the test meant to catch each one fails. Prints a table; exits non-zero if a bug goes unseen.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
export CARGO_TARGET_DIR="$root/target/planted-bugs"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$scratch/xdg}"
mkdir -p -m 700 "$XDG_RUNTIME_DIR"

# file | text to replace | replacement | test binary | test filter | what the bug is
#
# Retired: "shadow ray along the sample direction (ls.wi) from the offset origin" in
# trace_light_sample, once caught by strategies/solid_angle at the touching and grazing lights.
# Shadow rays now leave out the light they aim at (convex lights' subtrees in the BVH; a planar
# light's triangles, and the walls it touches, in baked kernels: gpu/shadow_blockers.rs), and the
# ray aimed a little off the sampled point is blocked by nothing else there: the touching-light
# scene renders the same image bit for bit with and without it (light sampling, by area and by
# solid angle, 64 spp). Catching it again needs a non-convex light at a contact edge.
bugs=(
  "shaders/lights.wgsl|let denom = abs(cos_light) * area;|let denom = area;|sampling|area_light|area pdf converted without cos θ_l"
  "shaders/lights.wgsl|let denom = abs(cos_light) * area;|let denom = area;|analytic|area_and_point|(same bug, seen by the closed form)"
  "shaders/sampling.wgsl|    let hv = h0 + u.y * (h1 - h0);|    let hv = h0 + u.y * u.y * (h1 - h0);|sampling|area_light|spherical rectangle: height along the edge not uniform in h"
  "shaders/lights.wgsl|        s.pdf = 1.0 / rectangle.solid_angle;|        s.pdf = 2.0 / rectangle.solid_angle;|sampling|area_light|spherical rectangle: pdf not 1 / Ω"
  "shaders/sampling.wgsl|return max(cos_theta, 0.0) * INV_PI;|return max(cos_theta, 0.0) * 2.0 * INV_PI;|sampling|hemisphere|cosine pdf off by a factor 2"
  "shaders/bsdf.wgsl|return smith_g1(wo.z, alpha) * ggx_d(h, alpha) / (4.0 * wo.z);|return ggx_d(h, alpha) / (4.0 * wo.z);|sampling|ggx_visible|VNDF pdf without the G1 masking term"
  "shaders/bsdf.wgsl|return p_spec * ggx_vndf_pdf(wo, wi, p.alpha) + diffuse;|return 0.5 * ggx_vndf_pdf(wo, wi, p.alpha) + diffuse;|sampling|gltf_brdf|mixture pdf ignores the lobe probability"
  "shaders/light_samples.wgsl|r.p_light = select(p_select * ls.pdf, p_select, r.is_delta);|r.p_light = select(p_select * ls.pdf, p_select / f32(frame.light_samples), r.is_delta);|analytic|delta_light|delta light skips the 1/n (Mitsuba 3 #1861)"
  "shaders/light_tree.wgsl|                pmf *= 1.0 - step.p0;\n                node = step.second;\n            }\n            trail >>= 1u;|                pmf *= step.p0;\n                node = step.second;\n            }\n            trail >>= 1u;|analytic|many_lights|light tree: a path's probability retraced with the first child's share"
  "shaders/light_tree.wgsl|    return select(cos_a * cos_b + sin_a * sin_b, 1.0, cos_a > cos_b);|    return select(cos_a * cos_b - sin_a * sin_b, 1.0, cos_a > cos_b);|sampling|light_tree|light tree: cos(a − b) written as cos(a + b)"
  "shaders/light_tree.wgsl|tree_normal) * lit_factor(i);\n    let ib = light_bounds_importance(node_bounds(b), tree_point, tree_normal) * lit_factor(i + 1u);|tree_normal) * lit_factor(i + 1u);\n    let ib = light_bounds_importance(node_bounds(b), tree_point, tree_normal) * lit_factor(i);|strategies|sealed_light|lit boxes: each child weighed by its sibling's box"
  "shaders/light_tree.wgsl|light_tree_node(frame.light_tree_nodes + frame.directional_lights + i)|light_tree_node(frame.light_tree_nodes + i)|sampling|light_tree|lit boxes read from where the directional leaves lie"
  "shaders/direction_samples.wgsl|w = mis_weight(f32(plan.m), d.pdf, f32(plan.n), p_light);|w = mis_weight(f32(plan.n), d.pdf, f32(plan.m), p_light);|strategies|veach_mis|BRDF samples weighted with the counts swapped"
  "shaders/light_samples.wgsl|return sum / f32(plan.n);|return sum / f32(total);|strategies|veach_mis|every light's samples averaged over all lights"
  "shaders/sampling.wgsl|(k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha) / denom|(k2 + (k2 * cos_phi - k1 * sin_phi)) * cos_alpha / denom|sampling|area_light|Arvo's cos β' with a misplaced parenthesis"
  "shaders/mis.wgsl|    let f = n_f * pdf_f;\n    let g = n_g * pdf_g;\n    if f <= 0.0 {\n        return 0.0;\n    }\n    return 1.0 / (1.0 + g / f);|    let f = pdf_f;\n    let g = pdf_g;\n    if f <= 0.0 {\n        return 0.0;\n    }\n    return 1.0 / (1.0 + g / f);|sampling|mis_weights|balance heuristic without the sample counts"
  "shaders/light_selection.wgsl|return alias_pick(b, bucket.alias_prob, b.index, bucket.alias_index);|return alias_pick(b, bucket.alias_prob, bucket.alias_index, b.index);|sampling|light_selection|light alias table: bucket and alias swapped"
  "shaders/lights.wgsl|return alias_pick(b, bucket.alias_prob, bucket.triangle, bucket.alias_triangle);|return DiscretePick(bucket.triangle, b.frac);|sampling|area_light|emitter triangle chosen uniformly, not by area"
  "shaders/light_selection.wgsl|return DiscretePick(other, remap_above(b.frac, keep));|return DiscretePick(other, b.frac);|sampling|area_light|sample reuse: an alias outcome's number not rescaled"
  "shaders/light_samples.wgsl|        ch.u.x = chosen.pick.u;\n||strategies|veach_mis|light choice's number reused unrescaled for the point"
  "shaders/sampling.wgsl|return min(u / p, ONE_MINUS_EPSILON);|return min(u, ONE_MINUS_EPSILON);|sampling|area_light|sample reuse: the chosen outcome's number not rescaled"
  "shaders/bsdf.wgsl|sample_cosine_hemisphere(vec2f(remap_above(u.x, p_spec), u.y))|sample_cosine_hemisphere(u)|sampling|gltf_brdf|diffuse lobe sampled with the lobe choice's number"
  "shaders/sampler.wgsl|y ^= (y >> 4u) & 0x0f0f0f0fu;|y ^= (y >> 4u) & 0x0f0f0f0eu;|sampling|sobol_points|Sobol's second dimension: a wrong direction number"
  "shaders/sampler.wgsl|return nested_uniform_scramble(index, s);|return index;|sampling|sampler_requests|requests not shuffled: a scrambled diagonal"
  "shaders/textures.wgsl|let q = p - 0.5;|let q = p;|textures|lookups|bilinear texel centres off by half a texel"
  "shaders/textures.wgsl|return vec2f(dot(r.row0, h), dot(r.row1, h));|return vec2f(dot(r.row1, h), dot(r.row0, h));|textures|floor_pixels|KHR_texture_transform rows swapped"
  "shaders/textures.wgsl|return select(v, vec4f(srgb_to_linear(v.rgb), v.a), srgb);|return v;|textures|lookups|sRGB textures not decoded"
  "shaders/lights.wgsl|max(b + sqrt(max(h_sq, 0.0)), 0.0)|max(b, 0.0)|strategies|cornell_box|direction samples clipped at the light's centre, not its far side"
  "shaders/lights.wgsl|let box = box_exit(origin, dir, frame.emitter_min, frame.emitter_max);|let box = box_exit(origin, dir, frame.emitter_min, frame.emitter_min);|strategies|flat_grid|past 16 lights, the emitters' box shrunk to its corner"
  "shaders/layout.wgsl|let t = max(-n.z, 0.0);|let t = 0.0;|sampling|encoded_normals|octahedral decoding without the lower hemisphere's fold"
  "shaders/wavefront.wgsl|    if AT_MOST_ONE_DIRECTION_SAMPLE {\n        if plan.m > 0u {|    if AT_MOST_ONE_DIRECTION_SAMPLE {\n        if plan.m > 1u {|specialise|wavefront|one direction sample taken without its loop but never screened: the wavefront drops it"
  "shaders/wavefront.wgsl|pixel_sample_stream(q.pixel, q.sample)|pixel_sample_stream(q.pixel, frame.sample_start)|specialise|wavefront|direction kernel re-traces the first round's camera ray"
  "shaders/traverse.wgsl|let int_scale = 32.0;|let int_scale = 256.0;|stress|far_from_the_origin|ray offset of 256 ULPs (2 units at 1e5)"
  "shaders/megakernel.wgsl|    return i >= 2u;|    return i >= 1u;|stress|cut_short|loop-limit canary that never fires: Mesa 22 truncates samples silently (passes on Mesa 23+)"
  "shaders/light_selection.wgsl|const POWER_SHARE: f32 = 0.25;|const POWER_SHARE: f32 = 0.0;|strategies|per_point|per-point light choice without its power share: a light whose guess is zero is never chosen"
  "shaders/light_selection.wgsl|return point_selection[min(index, MAX_POINT_SELECTION_LIGHTS - 1u)];|return light_picks[index].pdf;|analytic|area_and_point|per-point light choice weighted by the power pdf it did not sample from"
  "shaders/traverse_baked.wgsl|intersect_triangle(origin, sh, p0, p1, p2, (*hit).t);|intersect_triangle(origin, sh, p0, p1, p2, RAY_INF);|specialise|compiled_into|baked closest hit: the last triangle met, not the nearest"
  "shaders/traverse_baked.wgsl|return Hit(hit.t, r.y, r.z, hit.tri, hit.found);|return Hit(hit.t, r.y, r.y, hit.tri, hit.found);|specialise|compiled_into|baked closest hit: the winner's barycentrics recomputed wrong (b2 = b1)"
  "crates/veach/src/scene/light_shape.rs|let tolerance = 1e-5 * (hi - lo).length();|let tolerance = 1e30 * (hi - lo).length();|stress|shadows_itself|every light taken as convex: a light's own panel no longer shadows it"
  "shaders/light_selection.wgsl|    if SINGLE_LIGHT {\n        return 1.0;|    if SINGLE_LIGHT {\n        return 0.5;|specialise|specialised_kernels|one light's selection probability taken as 1/2 in its kernel"
  "shaders/traverse_bvh.wgsl|var hi_z = grid.z + vec4f((vec4u(high.z) >> shifts)|var hi_z = grid.z + vec4f((vec4u(low.z) >> shifts)|specialise|triangles_compiled|quantised BVH: the children's high z decoded from their low cells"
  "shaders/traverse_bvh.wgsl|select(select(e3.y, e2.y, k == 2u), e1.y, k == 1u)|select(select(e3.y, e2.y, k == 2u), e2.y, k == 1u)|specialise|triangles_compiled|4-wide BVH: the second-nearest child entered never visited"
  "shaders/traverse_bvh.wgsl|select(t, vec4f(RAY_INF), tags == vec4u(skipped))|select(t, vec4f(RAY_INF), tags.yxwz == vec4u(skipped))|specialise|triangles_compiled|4-wide BVH: shadow rays skip the sibling of their light's subtree"
  "shaders/traverse_bvh.wgsl|bvh_stack[(*s).bottom] = window_slot(s, k);|bvh_stack[(*s).bottom] = window_slot(s, k + 1u);|stress|triangle_soup|traversal stack: a full window spills the wrong slot to memory"
  "shaders/traverse_bvh.wgsl|node = bvh_stack[(*s).sp];|node = bvh_stack[(*s).bottom];|stress|triangle_soup|traversal stack: a pop from an empty window reads the wrong memory entry"
  "crates/veach/src/gpu/bvh_nodes.rs|children.slots[slot + 1] = first + 1;|children.slots[slot + 1] = first;|specialise|triangles_compiled|4-wide BVH: a collapsed node's second child lost"
  "crates/veach/src/gpu/bvh_nodes.rs|while q < 255 && grid_bound(origin, cell, q + 1) <= low {|while q < 255 && grid_bound(origin, cell, q) <= low {|specialise|triangles_compiled|quantised BVH: low bounds rounded one cell inwards"
  "crates/veach/src/gpu/baked_triangles.rs|kept.iter().map(|kept.iter().skip(1).map(|specialise|compiled_into|baked triangles: each group's first left out of the kernel"
  "crates/veach/src/gpu/bindings.rs|return {}[tri & 3u];|return {}[tri & 1u];|analytic|area_and_point_light|triangle lights four to a word: a wrong word of the four"
  "crates/veach/src/gpu/bindings.rs|let mask = TEXEL_ROW - 1;|let mask = TEXEL_ROW / 2 - 1;|specialise|scene_arrays|scene arrays in textures: a texel's column wrapped at half the row"
  "crates/veach/src/render.rs|baked.mark_blockers(&arrays.triangle_lights, (!directional).then_some(&delta[..]));|let _ = directional; baked.mark_blockers(&arrays.triangle_lights, Some(&delta[..]));|specialise|wall_at_the_edge|baked shadow rays: a wall left out though a directional light shines across it"
  "crates/veach/src/gpu/baked_triangles.rs|\"hi\", &wgsl_vec3(hi));|\"hi\", &wgsl_vec3(lo));|specialise|triangles_compiled|baked triangles behind boxes: the box collapsed to its lower corner"
  "crates/veach/src/render.rs|baked.mark_blockers(&arrays.triangle_lights, (!directional).then_some(&delta[..]));|let _ = (directional, &delta); baked.mark_blockers(&arrays.triangle_lights, Some(&[]));|specialise|wall_at_the_edge|baked shadow rays: a wall left out though a point light lies beyond it"
  "shaders/lights.wgsl|let one_minus_cos = u.x * cone.one_minus_cos_max;|let one_minus_cos = sqrt(u.x) * cone.one_minus_cos_max;|sampling|cone_light|cone samples not uniform in solid angle"
  "shaders/lights.wgsl|return BoundingCone(vec3f(0.0, 0.0, 1.0), 2.0);|return BoundingCone(vec3f(0.0, 0.0, -1.0), 1.0);|sampling|cone_light|inside the bounding sphere: a hemisphere, not every direction"
  "shaders/lights.wgsl|    if cone_sampled(light) {\n        // Every point|    if false \u0026\u0026 cone_sampled(light) {\n        // Every point|strategies|cone_light|BRDF samples finding a round light weighed with its area pdf"
  "shaders/lights.wgsl|    let k = light.parallelogram - 1u;|    let k = 0u;|sampling|area_light|parallelogram light spanned from its first corner, not the one opposite the shared edge"
  "shaders/lights.wgsl|light_triangle(light, select(0u, 1u, u_light.x + u_light.y > 1.0))|light_triangle(light, 0u)|strategies|textured|parallelogram light: its second half taken as the first triangle (emission texture read off it)"
  "shaders/wavefront.wgsl|SamplePlan(q.light_samples, q.light_weighting, q.direction_samples)|SamplePlan(q.light_samples, LIGHT_ALONE, q.direction_samples)|strategies|cone_light|the direction kernel's cone samples weighed as light sampling alone"
  "shaders/direction_samples.wgsl|trace_occluded(origin, d.wi, hit.t * (1.0 - 1.0e-4), 0u)|false|specialise|triangles_compiled|emitters' list: no shadow ray to the emitter a direction sample found"
  "shaders/traverse_baked.wgsl|let nearer = min(min(u, v), w) >= 0.0 \u0026\u0026 t < (*hit).t;|let nearer = min(u, v) >= 0.0 \u0026\u0026 t < (*hit).t;|specialise|camera_rays|camera list: a triangle's third edge plane left out"
  "crates/veach/src/gpu/camera_footprints.rs|Some(([n0 * sign, n1 * sign, n2 * sign], volume * sign))|Some(([n0, n1, n2], volume * sign))|specialise|camera_rays|camera list: the planes of triangles wound away from the eye not flipped"
  "shaders/wavefront.wgsl|r.needs_rays = r.needs_rays || (d.valid|r.needs_rays = (d.valid|specialise|wavefront|wavefront: a sample deferred by its last direction sample alone, the others' rays dropped"
  "shaders/wavefront.wgsl|fn render_direction_pass(@builtin(global_invocation_id) gid: vec3u) {\n    load_frame();|fn render_direction_pass(@builtin(global_invocation_id) gid: vec3u) {|specialise|wavefront|wavefront: the direction kernel reads the frame's copy unfilled"
  "shaders/direct.wgsl|let s = surface_at(hit, d.wi);|let s = surface_at(hit, ray.dir);|specialise|specialised_kernels|straight-line sample: the direction hit's facing judged along the camera ray"
  "crates/veach/src/headless.rs|Some(t) => settings.dispatch_target.min(t / 10),|Some(_) => settings.dispatch_target,|renderer|time_limit|a time limit does not cap the dispatches (the default half-second target overshoots it)"
  "crates/veach/src/accumulation.rs|target - fewest, false, true)|target - fewest, true, true)|stress|samples_cut_short|retaken samples overwrite the pixel's sums (fresh_sums where a pixel has samples; Mesa 22 only)"
  "shaders/control_variate.wgsl|    let above_a = da >= 0.0;\n    let above_b = db >= 0.0;|    let above_a = true;\n    let above_b = true;|strategies|control_variate|control variate: emitters not clipped to the horizon"
  "shaders/light_samples.wgsl|    if wi.z > 0.0 {\n        r.g_cv|    if wi.z > 0.0 \u0026\u0026 dot(ls.wi, c.s.ng) > 0.0 {\n        r.g_cv|strategies|control_variate|control variate: light samples' g left out below the geometric normal"
  "shaders/control_variate.wgsl|            w = mis_weight(f32(plan.m), d.pdf, f32(plan.n), p_light);|            w = 1.0;|analytic|control_variate|control variate: direction samples' g not MIS-weighted"
)

printf "%-52s %-10s %-16s %s\n" bug test filter result
status=0
for entry in "${bugs[@]}"; do
  IFS='|' read -r file from to test filter what <<<"$entry"
  # ONLY=text runs the entries whose description contains it.
  if [ -n "${ONLY:-}" ] && [[ "$what" != *"$ONLY"* ]]; then continue; fi
  rm -rf "$scratch/tree" && mkdir "$scratch/tree"
  git ls-files -z | xargs -0 -I{} cp --parents {} "$scratch/tree/"
  python3 - "$scratch/tree/$file" "$from" "$to" <<'PY'
import sys
path, old, new = sys.argv[1], sys.argv[2].encode().decode("unicode_escape"), sys.argv[3].encode().decode("unicode_escape")
text = open(path).read()
assert old in text, f"pattern not found in {path}: {old!r}"
open(path, "w").write(text.replace(old, new))
PY
  if (cd "$scratch/tree" && cargo test --release -q -p veach --test "$test" "$filter" >"$scratch/log" 2>&1); then
    result="PASSED - bug not caught"
    status=1
  else
    result="failed, as it should ($(grep -m1 -oE '[0-9]+ of [0-9]+ cases failed|[0-9]+ region\(s\) off|[0-9]+ comparison\(s\) off|panicked at [^:]+' "$scratch/log" || echo failed))"
  fi
  printf "%-52s %-10s %-16s %s\n" "$what" "$test" "$filter" "$result"
done
exit $status

// test_kernels.wgsl: an entry point that runs the renderer's own sampling routines on inputs the
// tests choose (tests/sampling.rs: chi-square, pdf consistency, furnace, MIS weights). It is
// joined after the render kernel's files and is never part of a render.

@group(0) @binding(20) var<uniform> test: TestParams;
@group(0) @binding(21) var<storage, read> test_in: array<vec4f>;
@group(0) @binding(22) var<storage, read_write> test_out: array<vec4f>;

// Sampling routines: out[2i] = (direction, pdf returned by the sampler),
// out[2i + 1] = (pdf function at that direction, max channel of f cos / pdf, 1 if valid, 0).
const TEST_SAMPLE_UNIFORM: u32 = 0u;
const TEST_SAMPLE_COSINE: u32 = 1u;
const TEST_SAMPLE_GGX_VNDF: u32 = 2u;
const TEST_SAMPLE_BSDF: u32 = 3u;
const TEST_SAMPLE_LIGHT: u32 = 4u;
// out[i] = (chosen light index, its selection probability, 0, 0).
const TEST_SELECT_LIGHT: u32 = 5u;
// test_in[i] = (pixel, camera sample index, request number, 0): out[i] = (sample_2d, 0, 0) of
// that stream after that many requests, with the frame's sampler and test.seed.
const TEST_SAMPLE_STREAM: u32 = 6u;
// pdf functions at direction test_in[i].xyz: out[i] = (pdf, 0, 0, 0).
const TEST_PDF_UNIFORM: u32 = 10u;
const TEST_PDF_COSINE: u32 = 11u;
const TEST_PDF_GGX_VNDF: u32 = 12u;
const TEST_PDF_BSDF: u32 = 13u;
const TEST_PDF_LIGHT: u32 = 14u;
// f(wo = test_in[2i], wi = test_in[2i + 1]): out[i] = (f, bsdf pdf).
const TEST_EVAL_BSDF: u32 = 20u;
// test_in[i] = (n_f, p_f, n_g, p_g): out[i] = (w_f, w_g, balance w_f, power w_f).
const TEST_MIS_WEIGHTS: u32 = 21u;
// test_in[i] = (low, high 16 bits of an encoded normal): out[i] = (decode_normal, 0).
const TEST_DECODE_NORMAL: u32 = 22u;
// test_in[i] = (u, v, texture index, 1 for sRGB): out[i] = texture_lookup (textures.wgsl).
const TEST_TEXTURE_LOOKUP: u32 = 30u;
// test_in[i] = (TEXCOORD_0.xy, TEXCOORD_1.xy): the test material with its textures applied,
// out[2i] = (base colour, metallic), out[2i + 1] = (roughness, emissive texture rgb).
const TEST_TEXTURED_MATERIAL: u32 = 31u;
// test_in[2i] = (origin, t_max), test_in[2i + 1] = (direction, 0): out[i] = (closest hit's t or -1,
// 1 if the segment is blocked, 0, 0), from the kernel's own traversal (trace_closest, trace_occluded).
const TEST_TRACE: u32 = 40u;
// test_in[i] = (direction, 0): camera rays from frame.camera.origin, out[2i] = trace_camera's hit
// (t or -1, triangle, b1, b2) and out[2i + 1] = trace_closest's. Baked test kernels only
// (TestKernel::for_baked_scene); a BVH kernel's trace_camera finds nothing.
const TEST_TRACE_CAMERA: u32 = 41u;

// pdf with which the light strategy picks direction wi at `point` on light test.light_index,
// found the way a BRDF sample finds it: by tracing the ray to the emitter.
fn traced_light_pdf(x: vec3f, wi: vec3f) -> f32 {
    let hit = trace_closest(x, wi, RAY_INF);
    if !hit.found || triangle_light(hit.tri) != test.light_index {
        return 0.0;
    }
    let v = triangle_positions(triangle_at(hit.tri));
    let n_l = triangle_normal(v);
    let light = light_record(test.light_index);
    if !emits_towards(light.double_sided != 0u, n_l, wi) {
        return 0.0;
    }
    let y = x + hit.t * wi;
    return area_light_pdf(test.light_index, x, v, y) / light_selection_pdf(test.light_index);
}

fn write_sample(i: u32, wi: vec3f, pdf: f32, pdf_eval: f32, weight: f32) {
    test_out[2u * i] = vec4f(wi, pdf);
    test_out[2u * i + 1u] = vec4f(pdf_eval, weight, select(0.0, 1.0, pdf > 0.0), 0.0);
}

@compute @workgroup_size(64)
fn run_test(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) groups: vec3u) {
    load_frame();
    let i = gid.x + gid.y * groups.x * 64u;
    if i >= test.count {
        return;
    }
    var rng = rng_seed(i, 0u, test.seed);
    let u = vec3f(rng_next(&rng), rng_next2(&rng));
    let p = bsdf_params(test.material);
    let wo = test.wo;
    switch test.routine {
        case TEST_SAMPLE_UNIFORM: {
            let wi = sample_uniform_hemisphere(u.xy);
            write_sample(i, wi, uniform_hemisphere_pdf(), uniform_hemisphere_pdf(), 0.0);
        }
        case TEST_SAMPLE_COSINE: {
            let wi = sample_cosine_hemisphere(u.xy);
            write_sample(i, wi, cosine_hemisphere_pdf(wi.z), cosine_hemisphere_pdf(wi.z), 0.0);
        }
        case TEST_SAMPLE_GGX_VNDF: {
            let wi = reflect(-wo, sample_ggx_vndf(wo, p.alpha, u.xy));
            let pdf = select(0.0, ggx_vndf_pdf(wo, wi, p.alpha), wi.z > 0.0);
            write_sample(i, wi, pdf, pdf, 0.0);
        }
        case TEST_SAMPLE_BSDF: {
            let s = bsdf_sample(p, wo, u.xy);
            var weight = 0.0;
            if s.delta {
                weight = max3(s.delta_reflectance / s.pdf);
            } else if s.pdf > 0.0 {
                weight = max3(bsdf_eval(p, wo, s.wi) * s.wi.z / s.pdf);
            }
            write_sample(i, s.wi, s.pdf, bsdf_pdf(p, wo, s.wi), weight);
        }
        case TEST_SAMPLE_LIGHT: {
            let light = light_record(test.light_index);
            if cone_sampled(light) {
                // A direction in the bounding cone: a sample where its ray finds the light.
                let cone = bounding_cone(light, test.point);
                let wi = sample_cone(cone, u.xy);
                let pdf_eval = traced_light_pdf(test.point, wi);
                write_sample(i, wi, select(0.0, cone_pdf(cone), pdf_eval > 0.0), pdf_eval, 0.0);
            } else {
                let ls = sample_light(test.light_index, test.point, u.xy);
                write_sample(i, ls.wi, ls.pdf, traced_light_pdf(test.point, ls.wi), 0.0);
            }
        }
        case TEST_SAMPLE_STREAM: {
            let q = test_in[i];
            var stream = sample_stream(u32(q.x), u32(q.y), test.seed);
            stream.dim = u32(q.z);
            test_out[i] = vec4f(sample_2d(&stream), 0.0, 0.0);
        }
        case TEST_SELECT_LIGHT: {
            // For SELECT_TREE: the point, and `wo` as its normal.
            tree_point = test.point;
            tree_normal = test.wo;
            let chosen = select_light_with_pmf(u.x);
            let index = chosen.pick.index;
            test_out[i] = vec4f(f32(index), light_selection_pdf(index), chosen.pmf, 0.0);
        }
        case TEST_PDF_UNIFORM: {
            test_out[i] = vec4f(select(0.0, uniform_hemisphere_pdf(), test_in[i].z > 0.0), 0.0, 0.0, 0.0);
        }
        case TEST_PDF_COSINE: {
            test_out[i] = vec4f(cosine_hemisphere_pdf(test_in[i].z), 0.0, 0.0, 0.0);
        }
        case TEST_PDF_GGX_VNDF: {
            test_out[i] = vec4f(ggx_vndf_pdf(wo, test_in[i].xyz, p.alpha), 0.0, 0.0, 0.0);
        }
        case TEST_PDF_BSDF: {
            test_out[i] = vec4f(bsdf_pdf(p, wo, test_in[i].xyz), 0.0, 0.0, 0.0);
        }
        case TEST_PDF_LIGHT: {
            test_out[i] = vec4f(traced_light_pdf(test.point, test_in[i].xyz), 0.0, 0.0, 0.0);
        }
        case TEST_EVAL_BSDF: {
            let a = test_in[2u * i].xyz;
            let b = test_in[2u * i + 1u].xyz;
            test_out[i] = vec4f(bsdf_eval(p, a, b), bsdf_pdf(p, a, b));
        }
        case TEST_MIS_WEIGHTS: {
            let q = test_in[i];
            test_out[i] = vec4f(
                mis_weight(q.x, q.y, q.z, q.w),
                mis_weight(q.z, q.w, q.x, q.y),
                balance_heuristic(q.x, q.y, q.z, q.w),
                power_heuristic(q.x, q.y, q.z, q.w),
            );
        }
        case TEST_DECODE_NORMAL: {
            let q = test_in[i];
            test_out[i] = vec4f(decode_normal(u32(q.x) | (u32(q.y) << 16u)), 0.0);
        }
        case TEST_TEXTURE_LOOKUP: {
            let q = test_in[i];
            test_out[i] = texture_lookup(u32(q.z), q.xy, q.w != 0.0);
        }
        case TEST_TEXTURED_MATERIAL: {
            let m = textured_material(test.material, test_in[i]);
            test_out[2u * i] = vec4f(m.base_color, m.metallic);
            test_out[2u * i + 1u] = vec4f(m.roughness, emission_texture(test.material, test_in[i]));
        }
        case TEST_TRACE: {
            let o = test_in[2u * i];
            let d = test_in[2u * i + 1u].xyz;
            let hit = trace_closest(o.xyz, d, o.w);
            let blocked = trace_occluded(o.xyz, d, o.w, 0u);
            test_out[i] = vec4f(select(-1.0, hit.t, hit.found), select(0.0, 1.0, blocked), 0.0, 0.0);
        }
        case TEST_TRACE_CAMERA: {
            let d = test_in[i].xyz;
            let camera = trace_camera(d);
            let closest = trace_closest(frame.camera.origin, d, RAY_INF);
            test_out[2u * i] = vec4f(select(-1.0, camera.t, camera.found), f32(camera.tri), camera.b1, camera.b2);
            test_out[2u * i + 1u] = vec4f(select(-1.0, closest.t, closest.found), f32(closest.tri), closest.b1, closest.b2);
        }
        default: {}
    }
}

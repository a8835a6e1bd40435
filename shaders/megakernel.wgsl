// megakernel.wgsl: the `render` entry point: each thread takes one pixel of a band of rows and
// its camera samples, estimated by direct.wgsl (wavefront.wgsl is the other scheduler).

// The pixel a thread of a dispatch over a band of rows takes, and whether it lies in the image and
// the band.
struct BandPixel {
    x: u32,
    y: u32,
    index: u32,
    inside: bool,
}

// A camera sample's numbers, keyed by its pixel's index in the whole image (`pixel` indexes the
// buffers, which start at image row frame.tile_row), so that a tiled image is the untiled one.
fn pixel_sample_stream(pixel: u32, sample: u32) -> SampleStream {
    return sample_stream(pixel + frame.tile_row * frame.width, frame.first_sample + sample, frame.seed);
}

fn band_pixel(gid: vec3u) -> BandPixel {
    let y = frame.row_start + gid.y;
    let inside = gid.x < frame.width && gid.y < frame.row_count && y < frame.height;
    return BandPixel(gid.x, y, y * frame.width + gid.x, inside);
}

// Mesa 22's llvmpipe (gallivm's loop limiter, LP_MAX_TGSI_LOOP_ITERATIONS in
// lp_bld_ir_common.c) gives each invocation one budget of 65,535 loop iterations, shared by all
// of its loops; once it is spent, every loop stops after its current iteration: traversals end
// early, rays miss, and the sample is silently dark. Mesa 23 and later have no such limit. This
// loop must run twice (its trip count is read at run time, so it is not unrolled); after a
// camera sample it tells whether the budget held through it. A sample it did not is left out
// and taken again by the next dispatch (`render` starts from the pixel's own count).
fn loop_budget_held() -> bool {
    let trips = max(frame.loop_check, 2u);
    var i = 0u;
    loop {
        i += 1u;
        if i >= trips {
            break;
        }
    }
    return i >= 2u;
}

@compute @workgroup_size(RENDER_WORKGROUP_WIDTH, RENDER_WORKGROUP_HEIGHT, 1)
fn render(@builtin(global_invocation_id) gid: vec3u) {
    load_frame();
    let px = band_pixel(gid);
    if !px.inside {
        return;
    }
    let pixel = px.index;
    var sum = vec4f(0.0);
    var sum_sq = vec4f(0.0);
    var count = PixelCounters(0u, 0u, 0u);
    var sum_light = vec4f(0.0);
    var sum_brdf = vec4f(0.0);
    let write_aovs = HAS_AOVS && frame.write_aovs != 0u;
    // In its rows' first pass the sums are still zero: not read. Mesa 22.3 reads a storage word lane
    // by lane, and these 11 words, read and written, cost an invocation about half a camera sample
    // there (docs/performance.md, "The frame's parameters copied once per invocation").
    if frame.fresh_sums == 0u {
        sum = accum[pixel];
        sum_sq = accum_sq[pixel];
        count = counters[pixel];
        if write_aovs {
            sum_light = aov_light[pixel];
            sum_brdf = aov_brdf[pixel];
        }
    }
    // From the pixel's own count of samples (sum.w), which trails the dispatch's first sample
    // where a sample was left out before (loop_budget_held). The loop's end test is the last
    // statement of its body: written in a `continuing` block (or at the top, as a `for` or `while`
    // has it), Mesa 22.3's lavapipe, which runs code whose lanes are all masked off, ran the whole
    // body once more after the last trip, a camera sample's worth per pixel (one-sample renders of
    // the Cornell box took 0.6x the time without it; docs/performance.md, "Loops tested at the end
    // of their body"). The other hot loops (traversal, lights) are written the same way. The tests
    // read the end from `frame` each time: held in a variable, it made the Cornell box 1.10x
    // slower on Mesa 22.3 (not understood; measured twice, before this form).
    var k = u32(sum.w);
    load_camera_slots(pixel);
    if DEFERRED_DIRECTION_RAYS && k < frame.sample_start + frame.sample_count {
        take_samples_deferred(px, k, &sum, &sum_sq, &count);
    } else if k < frame.sample_start + frame.sample_count {
        loop {
            var stream = pixel_sample_stream(pixel, k);
            let ray = camera_ray(vec2u(px.x, px.y), sample_2d(&stream));
            var rays = 0u;
            let e = estimate_radiance(ray, &stream, &rays);
            if !loop_budget_held() {
                count.truncated += 1u;
                break;
            }
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
            k++;
            if k >= frame.sample_start + frame.sample_count {
                break;
            }
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

// One camera sample's estimate added to its pixel's sums (the wavefront kernels; `render` keeps
// its sums in registers over its samples, in the same order).
fn add_sample(pixel: u32, e: Estimate, rays: u32) {
    let l = e.emitted + e.light + e.brdf;
    counters[pixel].rays += rays;
    // A non-finite sample is counted and dropped (as a zero), never accumulated.
    if is_finite3(l) && is_finite3(l * l) {
        accum[pixel] += vec4f(l, 1.0);
        accum_sq[pixel] += vec4f(l * l, 0.0);
        if HAS_AOVS && frame.write_aovs != 0u {
            aov_light[pixel] += vec4f(e.light, 0.0);
            aov_brdf[pixel] += vec4f(e.emitted + e.brdf, luminance(e.emitted));
        }
    } else {
        accum[pixel].w += 1.0;
        counters[pixel].nonfinite += 1u;
    }
}

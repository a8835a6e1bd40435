// rng.wgsl: counter-based independent random numbers: the hash that seeds sampler.wgsl's streams,
// and the independent samples the test kernels feed to chi-square tests. The renderer's estimates
// take theirs from sampler.wgsl.

// PCG hash: Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3), 2020.
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn rng_seed(pixel: u32, sample: u32, seed: u32) -> u32 {
    return pcg_hash(pixel ^ pcg_hash(sample ^ pcg_hash(seed)));
}

// A uniform float in [0, 1) with 24 random bits.
fn rng_next(state: ptr<function, u32>) -> f32 {
    *state = *state * 747796405u + 2891336453u;
    let s = *state;
    let word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return f32(((word >> 22u) ^ word) >> 8u) * (1.0 / 16777216.0);
}

fn rng_next2(state: ptr<function, u32>) -> vec2f {
    let a = rng_next(state);
    let b = rng_next(state);
    return vec2f(a, b);
}

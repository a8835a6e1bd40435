// sampler.wgsl: the numbers a camera sample's estimate consumes. Each request (the pixel offset, a
// light sample's choice of light and triangle and point, a BRDF sample's lobe and direction) is two
// dimensions of an Owen-scrambled Sobol sequence over the pixel's camera samples, padded: every
// request has its own index shuffle and scramble (Burley 2020, "Practical Hash-based Owen
// Scrambling", JCGT 9(4), §3-4). So the camera samples of a pixel stratify each request's 2D
// domain, while different requests stay independent of each other. Discrete choices reuse the
// request's x (sampling.wgsl's remap_below / remap_above) so the stratification reaches the point.
// Scrambling makes each point uniformly distributed, so the estimators stay unbiased; their variance
// is bounded by a small constant times that of independent samples (Owen 1997, scrambled nets;
// Owen 1998, padding as Latin supercube sampling) and is far less where the integrand is smooth
// (docs/performance.md measures it). Counter-based like rng.wgsl: a pixel's sample k does not
// depend on how the work was split into dispatches.

struct SampleStream {
    // The camera sample's number within its pixel (over all dispatches and frames).
    index: u32,
    // The pixel and the render's seed, hashed.
    seed: u32,
    // Requests taken so far in this camera sample.
    dim: u32,
}

fn sample_stream(pixel: u32, sample: u32, seed: u32) -> SampleStream {
    return SampleStream(sample, pcg_hash(pixel ^ pcg_hash(seed ^ 0x5bd1e995u)), 0u);
}

// A random bijection of 32-bit words in which each bit is flipped depending only on the bits below
// it: applied to bit-reversed numbers, a nested uniform (Owen) scramble in base 2. Constants from
// Burley 2020, listing 2 (Laine & Karras 2011's hash with better mixing).
fn laine_karras_permutation(x: u32, seed: u32) -> u32 {
    var v = x + seed;
    v ^= v * 0x6c50b47cu;
    v ^= v * 0xb82f1e52u;
    v ^= v * 0xc7afe638u;
    v ^= v * 0x8d22f6e6u;
    return v;
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras_permutation(reverseBits(x), seed));
}

// The Sobol sequence's second dimension. Its direction numbers are the rows of Pascal's triangle
// mod 2 (Joe & Kuo's first polynomial, x + 1): bit p of the fraction (p = 0 the half) is the xor
// of the index bits b with C(b, p) odd, that is (Lucas) with p a submask of b. Five butterfly steps
// xor each bit with its supersets, as a fast Walsh transform over GF(2) would; reversing puts bit p
// at the fraction's place p. The first dimension is the van der Corput sequence, reverseBits(index).
fn sobol_second_dimension(index: u32) -> u32 {
    var y = index;
    y ^= (y >> 1u) & 0x55555555u;
    y ^= (y >> 2u) & 0x33333333u;
    y ^= (y >> 4u) & 0x0f0f0f0fu;
    y ^= (y >> 8u) & 0x00ff00ffu;
    y ^= (y >> 16u) & 0x0000ffffu;
    return reverseBits(y);
}

fn unit_float(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

// The seed of the stream's next request.
fn next_request_seed(stream: ptr<function, SampleStream>) -> u32 {
    let s = pcg_hash((*stream).seed ^ pcg_hash((*stream).dim));
    (*stream).dim += 1u;
    return s;
}

// The index of this request's point: the pixel's samples in an order of their own (a nested
// uniform scramble of the index, Burley 2020 §4), so that requests are paired at random with each
// other, not sample k with sample k (the same index with only the values scrambled would put two
// requests' x coordinates on a scrambled diagonal). An aligned block of 2^m indices maps to another,
// and any such block of a Sobol sequence is a net, so stratification survives the shuffle.
fn shuffled_index(index: u32, s: u32) -> u32 {
    return nested_uniform_scramble(index, s);
}

// Two dimensions: Sobol's first two, a (0,2)-sequence, each Owen-scrambled with its own seed. With
// SAMPLER_INDEPENDENT, two consecutive PCG outputs (rng.wgsl) from a state hashed from the same
// counters instead.
fn sample_2d(stream: ptr<function, SampleStream>) -> vec2f {
    let s = next_request_seed(stream);
    if frame.sampler == SAMPLER_INDEPENDENT {
        var state = pcg_hash(s ^ pcg_hash((*stream).index));
        return rng_next2(&state);
    }
    let i = shuffled_index((*stream).index, s);
    let x = nested_uniform_scramble(reverseBits(i), pcg_hash(s ^ 0x68bc21ebu));
    let y = nested_uniform_scramble(sobol_second_dimension(i), pcg_hash(s ^ 0x02e5be93u));
    return vec2f(unit_float(x), unit_float(y));
}

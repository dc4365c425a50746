// Random numbers and the warps from the unit square to directions and triangle points, ported
// operation for operation from the CPU reference's sampling module so a GPU path draws the
// same numbers and turns them into the same directions.
//
// - Generator: PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically
//   Good Algorithms for Random Number Generation", the XSH RR output of rand_pcg's Lcg64Xsh32),
//   seeded per path from (seed, pixel, sample) through Vigna's splitmix64 finalizer exactly as
//   the reference seeds it. WGSL `u64` needs a device feature, so 64-bit words are emulated as
//   `vec2<u32>` (x = low half, y = high half): the sequences equal the reference's bit for bit.
// - Cosine-weighted hemisphere through Shirley and Chiu 1997, "A Low Distortion Map Between
//   Disk and Square" (the concentric map).
// - Uniform triangle barycentrics: pbrt-v3's square-root parameterization.
// - Veach 1997 (thesis, ch. 9) power heuristic with exponent 2.
// - Orthonormal frame: Duff et al. 2017, "Building an Orthonormal Basis, Revisited" (JCGT 6(1)).
#define_import_path gi::sampling

#import gi::math::{PI, world_from_tangent}

// ---------------------------------------------------------------------------------------------
// 64-bit words as two u32 halves.
// ---------------------------------------------------------------------------------------------

// `a + b` modulo 2^64.
fn u64_add(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    let carry = select(0u, 1u, lo < a.x);
    return vec2<u32>(lo, a.y + b.y + carry);
}

// The full 64-bit product of two u32s, from 16-bit halves so no partial product overflows.
fn u32_mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a_lo = a & 0xffffu;
    let a_hi = a >> 16u;
    let b_lo = b & 0xffffu;
    let b_hi = b >> 16u;
    let ll = a_lo * b_lo;
    let lh = a_lo * b_hi;
    let hl = a_hi * b_lo;
    let hh = a_hi * b_hi;
    // At most 3 * (2^16 - 1): the carries into the high word cannot overflow.
    let mid = (ll >> 16u) + (lh & 0xffffu) + (hl & 0xffffu);
    let lo = (mid << 16u) | (ll & 0xffffu);
    let hi = hh + (lh >> 16u) + (hl >> 16u) + (mid >> 16u);
    return vec2<u32>(lo, hi);
}

// `a * b` modulo 2^64: the high halves only reach the high word, where u32 wrapping is right.
fn u64_mul(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let low = u32_mul_wide(a.x, b.x);
    return vec2<u32>(low.x, low.y + a.x * b.y + a.y * b.x);
}

// `a >> n` for a constant-like `n` in 1..=63 (WGSL shifts of 32 bits or more wrap the amount).
fn u64_shr(a: vec2<u32>, n: u32) -> vec2<u32> {
    if n >= 32u {
        return vec2<u32>(a.y >> (n - 32u), 0u);
    }
    return vec2<u32>((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

// Vigna's splitmix64 finalizer: a bijective 64-bit mix, as the reference's `splitmix64`.
fn splitmix64(x: vec2<u32>) -> vec2<u32> {
    var z = u64_add(x, vec2<u32>(0x7f4a7c15u, 0x9e3779b9u));
    z = u64_mul(z ^ u64_shr(z, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = u64_mul(z ^ u64_shr(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return z ^ u64_shr(z, 31u);
}

// ---------------------------------------------------------------------------------------------
// PCG32 and the per-path sampler.
// ---------------------------------------------------------------------------------------------

// The LCG multiplier of PCG32, 6364136223846793005.
const PCG32_MULTIPLIER: vec2<u32> = vec2<u32>(0x4c957f2du, 0x5851f42du);

// A PCG32 generator (64-bit LCG state, 32-bit XSH RR output): the random numbers of one path.
struct Sampler {
    state: vec2<u32>,
    // Odd LCG increment, which selects the stream.
    increment: vec2<u32>,
}

// The generator rand_pcg's `Pcg32::new(state, stream)` makes: increment `2 stream + 1`, then
// one step after adding the increment to the state.
fn pcg32_new(state: vec2<u32>, stream: vec2<u32>) -> Sampler {
    let increment = vec2<u32>((stream.x << 1u) | 1u, (stream.y << 1u) | (stream.x >> 31u));
    var sampler = Sampler(u64_add(state, increment), increment);
    sampler.state = u64_add(u64_mul(sampler.state, PCG32_MULTIPLIER), increment);
    return sampler;
}

// The sampler of sample `sample_index` of pixel `pixel` (row-major index) for the render seed
// `seed` (x = low, y = high 32 bits; a 32-bit seed is `vec2(seed, 0u)`). PCG streams with
// nearby parameters are correlated, so state and stream both come from an avalanche of all
// three inputs, exactly as the reference does it (pixel and sample indices fit in 32 bits:
// images have at most 2^26 pixels).
fn sampler_new(seed: vec2<u32>, pixel: u32, sample_index: u32) -> Sampler {
    let seeded_pixel = splitmix64(seed) ^ vec2<u32>(pixel, 0u);
    // The reference's `sample.rotate_left(32)` of a 32-bit index: it moves to the high word.
    let h = splitmix64(splitmix64(seeded_pixel) ^ vec2<u32>(0u, sample_index));
    let stream = splitmix64(h ^ PCG32_MULTIPLIER);
    return pcg32_new(h, stream);
}

// The next 32 random bits: XSH RR of the current state, then one LCG step.
fn sampler_next_u32(sampler: ptr<function, Sampler>) -> u32 {
    let old = (*sampler).state;
    (*sampler).state = u64_add(u64_mul(old, PCG32_MULTIPLIER), (*sampler).increment);
    let rot = old.y >> 27u;
    let xorshifted = u64_shr(old, 18u) ^ old;
    let xsh = (xorshifted.x >> 27u) | (xorshifted.y << 5u);
    // Masking the left shift keeps a rotation by 0 a no-op (a shift by 32 would wrap to 0).
    return (xsh >> rot) | (xsh << ((32u - rot) & 31u));
}

// Uniform in `[0, 1)` with 24 bits, so every value is exactly representable and equal to the
// reference's.
fn sampler_next_f32(sampler: ptr<function, Sampler>) -> f32 {
    return f32(sampler_next_u32(sampler) >> 8u) * (1.0 / 16777216.0);
}

// Two uniform numbers, drawn in the order x then y.
fn sampler_next_2d(sampler: ptr<function, Sampler>) -> vec2<f32> {
    let x = sampler_next_f32(sampler);
    return vec2<f32>(x, sampler_next_f32(sampler));
}

// ---------------------------------------------------------------------------------------------
// Warps.
// ---------------------------------------------------------------------------------------------

// Shirley's concentric map from the unit square to the unit disk: strata of the square stay
// compact on the disk.
fn concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if o.x == 0.0 && o.y == 0.0 {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var theta: f32;
    if abs(o.x) > abs(o.y) {
        r = o.x;
        theta = PI / 4.0 * (o.y / o.x);
    } else {
        r = o.y;
        theta = PI / 2.0 - PI / 4.0 * (o.x / o.y);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

// Cosine-weighted direction about +Z, pdf `z / pi`.
fn cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = concentric_disk(u);
    let z = sqrt(max(1.0 - (d.x * d.x + d.y * d.y), 0.0));
    return vec3<f32>(d.x, d.y, z);
}

// Barycentric weights `(b1, b2)` of a uniformly distributed point on a triangle; the point is
// `(1 - b1 - b2) v0 + b1 v1 + b2 v2`.
fn uniform_triangle(u: vec2<f32>) -> vec2<f32> {
    let su = sqrt(u.x);
    return vec2<f32>(1.0 - su, u.y * su);
}

// Veach's power heuristic (exponent 2) for the strategy with pdf `a` against one with pdf `b`,
// written as `1 / (1 + (b/a)^2)` so huge near-mirror pdfs cannot overflow to `inf / inf`.
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        return 0.0;
    }
    let r = b / a;
    return 1.0 / (1.0 + r * r);
}

// ---------------------------------------------------------------------------------------------
// Shading frame.
// ---------------------------------------------------------------------------------------------

// An orthonormal basis whose z axis is a given unit normal.
struct Frame {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

// The reference's shading frame: `gi::math::world_from_tangent`'s columns (Duff et al.'s
// branchless basis with the reference's sign-bit rule, so local samples map to the same world
// directions on the CPU and the GPU).
fn frame_from_normal(n: vec3<f32>) -> Frame {
    let basis = world_from_tangent(n);
    return Frame(basis[0], basis[1], basis[2]);
}

// World-space `v` in the frame's coordinates.
fn frame_to_local(frame: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, frame.x), dot(v, frame.y), dot(v, frame.z));
}

// Frame coordinates `v` in world space.
fn frame_to_world(frame: Frame, v: vec3<f32>) -> vec3<f32> {
    return frame.x * v.x + frame.y * v.y + frame.z * v.z;
}

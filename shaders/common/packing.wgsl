// Compact encodings for G-buffer and cache storage: unit vectors in 32 bits with the
// octahedral mapping (Cigolle et al. 2014, "A Survey of Efficient Representations for
// Independent Unit Vectors", JCGT 3(2)), and linear HDR color in 32 bits as shared-exponent
// RGB9E5 (the format of `rgb9e5ufloat` textures); IEEE half precision written out, and
// non-negative rgb plus one value in 64 bits (`pack_color64`) for histories.
#define_import_path gi::packing

// Largest finite f16: packed values are clamped to it.
const F16_MAX: f32 = 65504.0;

// Unit vector -> point of the [-1, 1]^2 square (octahedral mapping).
fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z >= 0.0 {
        return p;
    }
    let sign_p = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * sign_p;
}

// Point of the [-1, 1]^2 square -> unit vector (inverse of `oct_encode`).
fn oct_decode(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e, 1.0 - abs(e.x) - abs(e.y));
    let fold = max(-n.z, 0.0);
    n.x += select(fold, -fold, n.x >= 0.0);
    n.y += select(fold, -fold, n.y >= 0.0);
    return normalize(n);
}

// Unit vector in 32 bits (two 16-bit snorm coordinates); angular error below 0.005 degrees
// (the shared-function test measures about 6e-5 radians at worst).
fn pack_unit_vector(n: vec3<f32>) -> u32 {
    return pack2x16snorm(oct_encode(n));
}

// Inverse of `pack_unit_vector`.
fn unpack_unit_vector(packed: u32) -> vec3<f32> {
    return oct_decode(unpack2x16snorm(packed));
}

// Non-negative linear RGB in 32 bits: three 9-bit mantissas sharing a 5-bit exponent
// (values clamp to 65408; relative precision about 1/512 of the largest channel).
fn pack_rgb9e5(rgb: vec3<f32>) -> u32 {
    return pack_rgb9e5_offset(rgb, 0.5, 0.5);
}

// `pack_rgb9e5` rounded stochastically: each mantissa is floor(x + u) for `u` uniform in
// [0, 1), so the stored value is the input on average (round to nearest is not: a history
// blended towards a value less than half a step away never moves). One step is at most
// 2^-8 of the largest channel.
fn pack_rgb9e5_dithered(rgb: vec3<f32>, u: f32) -> u32 {
    return pack_rgb9e5_offset(rgb, u, 1.0);
}

// RGB9E5 with each mantissa floor(x + offset); the exponent leaves room for the largest offset
// any call may use (`largest_offset`: 0.5 rounds to nearest, 1 any offset in [0, 1)).
fn pack_rgb9e5_offset(rgb: vec3<f32>, offset: f32, largest_offset: f32) -> u32 {
    let max_value = 65408.0;
    let c = clamp(rgb, vec3<f32>(0.0), vec3<f32>(max_value));
    let max_channel = max(max(c.r, c.g), c.b);
    var exponent = max(-16, i32(floor(log2(max(max_channel, 1e-30))))) + 1 + 15;
    var scale = exp2(f32(exponent - 15 - 9));
    // No offset may carry the largest mantissa to 512.
    if max_channel / scale + largest_offset >= 512.0 {
        exponent += 1;
        scale *= 2.0;
    }
    let m = vec3<u32>(floor(c / scale + offset));
    return m.r | (m.g << 9u) | (m.b << 18u) | (u32(exponent) << 27u);
}

// Inverse of `pack_rgb9e5`.
fn unpack_rgb9e5(packed: u32) -> vec3<f32> {
    let exponent = i32(packed >> 27u);
    let scale = exp2(f32(exponent - 15 - 9));
    let m = vec3<u32>(packed & 511u, (packed >> 9u) & 511u, (packed >> 18u) & 511u);
    return vec3<f32>(m) * scale;
}

// IEEE half precision by hand: the builtins `pack2x16float` / `unpack2x16float` need naga's
// `SHADER_FLOAT16_IN_FLOAT32`, which wgpu grants on llvmpipe only with `Features::SHADER_F16`,
// and `gi_gpu` requests neither. Same results: round to nearest even (at most 2^-11 of the
// value), subnormals kept; values are clamped to +-F16_MAX (no infinities).
fn half_bits(x: f32) -> u32 {
    let sign = (bitcast<u32>(x) >> 16u) & 0x8000u;
    let a = min(abs(x), F16_MAX);
    if a < 6.103515625e-5 {
        // Below 2^-14: subnormal, steps of 2^-24 (`round` ties to even).
        return sign | u32(round(a * 16777216.0));
    }
    // Rebias the exponent (127 -> 15) and round the 23-bit mantissa to 10 bits, ties to even;
    // a carry into the exponent is the right result.
    let rebiased = bitcast<u32>(a) - (112u << 23u);
    return sign | ((rebiased + 0xfffu + ((rebiased >> 13u) & 1u)) >> 13u);
}

fn half_value(h: u32) -> f32 {
    let sign = (h & 0x8000u) << 16u;
    let exponent = (h >> 10u) & 0x1fu;
    let mantissa = h & 0x3ffu;
    if exponent == 0u {
        return bitcast<f32>(sign | bitcast<u32>(f32(mantissa) * 5.9604644775390625e-8));
    }
    return bitcast<f32>(sign | ((exponent + 112u) << 23u) | (mantissa << 13u));
}

// Two halves in 32 bits, x in the low bits (the layout of `pack2x16float`).
fn pack_half2(v: vec2<f32>) -> u32 {
    return half_bits(v.x) | (half_bits(v.y) << 16u);
}

fn unpack_half2(packed: u32) -> vec2<f32> {
    return vec2(half_value(packed & 0xffffu), half_value(packed >> 16u));
}

// A power of two, exactly (`exp2` need not be exact).
fn power_of_two(exponent: i32) -> f32 {
    return bitcast<f32>(u32(exponent + 127) << 23u);
}

// Non-negative rgb and one more non-negative value in 64 bits: three 16-bit mantissas sharing
// a 5-bit exponent (RGB9E5's layout with 16-bit mantissas: at most 2^-17 of the largest
// channel off, channels clamped to 65535), and the value as an f16 cut to 6 mantissa bits
// (at most 2^-7 of itself off; integers exact to 128). x = r | g << 16,
// y = b | exponent << 16 | value << 21.
fn pack_color64(rgb: vec3<f32>, value: f32) -> vec2<u32> {
    let c = clamp(rgb, vec3(0.0), vec3(65535.0));
    let largest = max(max(c.r, c.g), c.b);
    // The largest channel's power of two from its bits (exact, unlike `log2`); the mantissas
    // then hold [2^15, 2^16) for it, unless it rounds up to 2^16.
    var exponent = max(i32(bitcast<u32>(largest) >> 23u) - 127, -16) + 16;
    if round(largest * power_of_two(31 - exponent)) >= 65536.0 {
        exponent += 1;
    }
    let m = vec3<u32>(round(c * power_of_two(31 - exponent)));
    let short_half = (half_bits(max(value, 0.0)) + 8u) >> 4u;
    return vec2(m.r | (m.g << 16u), m.b | (u32(exponent) << 16u) | (short_half << 21u));
}

fn unpack_color64(packed: vec2<u32>) -> vec4<f32> {
    let m = vec3(packed.x & 0xffffu, packed.x >> 16u, packed.y & 0xffffu);
    let exponent = i32((packed.y >> 16u) & 0x1fu);
    let rgb = vec3<f32>(m) * power_of_two(exponent - 31);
    return vec4(rgb, half_value((packed.y >> 21u) << 4u));
}

// A color, its luminance variance and its age in 64 bits, as a denoiser's long history keeps
// them (NRD's ReLAX keeps a history's second moment beside its color the same way): three
// 14-bit mantissas sharing a 5-bit exponent (at most 2^-14 of the largest channel off,
// channels clamped to 65504), the variance as an f16 cut to 5 mantissa bits (at most 2^-6 of
// itself off, clamped to 65504) and the age as a 7-bit integer (rounded, clamped to 0-127).
// x = r | g << 14 | (b & 15) << 28, y = b >> 4 | exponent << 10 | variance << 15 | age << 25.
fn pack_history64(rgb: vec3<f32>, variance: f32, age: f32) -> vec2<u32> {
    let c = clamp(rgb, vec3(0.0), vec3(F16_MAX));
    let largest = max(max(c.r, c.g), c.b);
    // As `pack_color64`: the mantissas hold [2^13, 2^14) for the largest channel, unless it
    // rounds up to 2^14.
    var exponent = max(i32(bitcast<u32>(largest) >> 23u) - 127, -16) + 16;
    if round(largest * power_of_two(29 - exponent)) >= 16384.0 {
        exponent += 1;
    }
    let m = vec3<u32>(round(c * power_of_two(29 - exponent)));
    let short_half = (half_bits(clamp(variance, 0.0, F16_MAX)) + 16u) >> 5u;
    let a = u32(round(clamp(age, 0.0, 127.0)));
    return vec2(
        m.r | (m.g << 14u) | ((m.b & 15u) << 28u),
        (m.b >> 4u) | (u32(exponent) << 10u) | (short_half << 15u) | (a << 25u),
    );
}

// `pack_history64`'s rgb, variance and age.
struct History64 {
    rgb: vec3<f32>,
    variance: f32,
    age: f32,
}

fn unpack_history64(packed: vec2<u32>) -> History64 {
    let m = vec3(packed.x & 0x3fffu, (packed.x >> 14u) & 0x3fffu, (packed.x >> 28u) | ((packed.y & 0x3ffu) << 4u));
    let exponent = i32((packed.y >> 10u) & 0x1fu);
    let rgb = vec3<f32>(m) * power_of_two(exponent - 29);
    return History64(rgb, half_value(((packed.y >> 15u) & 0x3ffu) << 5u), f32(packed.y >> 25u));
}

// A G-buffer surface's depth and normal in 32 bits, as a history checks reprojected taps
// against them: the depth as an f16 (low bits; at most 2^-11 of itself off, depths beyond
// 65504 clamped to it, +inf for sky kept as the f16 infinity) and the normal as two 8-bit snorm
// octahedral coordinates (high bits; under a degree off).
fn pack_depth_normal(depth: f32, n: vec3<f32>) -> u32 {
    var depth_bits = 0x7c00u;
    if depth < 3.0e38 {
        depth_bits = half_bits(depth);
    }
    return depth_bits | ((pack4x8snorm(vec4(oct_encode(n), 0.0, 0.0)) & 0xffffu) << 16u);
}

// The depth of `pack_depth_normal` (+inf for sky).
fn unpack_depth(packed: u32) -> f32 {
    let depth_bits = packed & 0xffffu;
    if depth_bits == 0x7c00u {
        return bitcast<f32>(0x7f800000u);
    }
    return half_value(depth_bits);
}

// The normal of `pack_depth_normal`.
fn unpack_normal8(packed: u32) -> vec3<f32> {
    return oct_decode(unpack4x8snorm(packed >> 16u).xy);
}

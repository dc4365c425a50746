// Compact encodings for G-buffer and cache storage: unit vectors in 32 bits with the
// octahedral mapping (Cigolle et al. 2014, "A Survey of Efficient Representations for
// Independent Unit Vectors", JCGT 3(2)), and linear HDR color in 32 bits as shared-exponent
// RGB9E5 (the format of `rgb9e5ufloat` textures).
#define_import_path gi::packing

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
    let max_value = 65408.0;
    let c = clamp(rgb, vec3<f32>(0.0), vec3<f32>(max_value));
    let max_channel = max(max(c.r, c.g), c.b);
    var exponent = max(-16, i32(floor(log2(max(max_channel, 1e-30))))) + 1 + 15;
    var scale = exp2(f32(exponent - 15 - 9));
    if u32(floor(max_channel / scale + 0.5)) == 512u {
        exponent += 1;
        scale *= 2.0;
    }
    let m = vec3<u32>(floor(c / scale + 0.5));
    return m.r | (m.g << 9u) | (m.b << 18u) | (u32(exponent) << 27u);
}

// Inverse of `pack_rgb9e5`.
fn unpack_rgb9e5(packed: u32) -> vec3<f32> {
    let exponent = i32(packed >> 27u);
    let scale = exp2(f32(exponent - 15 - 9));
    let m = vec3<u32>(packed & 511u, (packed >> 9u) & 511u, (packed >> 18u) & 511u);
    return vec3<f32>(m) * scale;
}

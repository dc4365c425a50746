//! Rust mirrors of the WGSL packing the cache stores (`gi::packing` and WGSL's
//! `pack4x8unorm` / `pack2x16snorm`), so CPU-built caches hold the same bits the GPU writes
//! (up to rounding of the packed inputs) and tests can decode what the GPU wrote.

use glam::{Vec2, Vec3, Vec4};

/// WGSL `pack4x8unorm`: `floor(0.5 + 255 * clamp(e, 0, 1))` per component, x in the low byte.
pub fn pack4x8unorm(v: Vec4) -> u32 {
    v.to_array()
        .iter()
        .enumerate()
        .map(|(i, &e)| ((0.5 + 255.0 * e.clamp(0.0, 1.0)).floor() as u32) << (8 * i))
        .fold(0, |a, b| a | b)
}

/// WGSL `unpack4x8unorm`.
pub fn unpack4x8unorm(packed: u32) -> Vec4 {
    Vec4::from_array(std::array::from_fn(|i| {
        ((packed >> (8 * i)) & 0xff) as f32 / 255.0
    }))
}

/// WGSL `pack2x16snorm`.
pub fn pack2x16snorm(v: Vec2) -> u32 {
    let q = |e: f32| ((0.5 + 32767.0 * e.clamp(-1.0, 1.0)).floor() as i32 as u32) & 0xffff;
    q(v.x) | (q(v.y) << 16)
}

/// WGSL `unpack2x16snorm`.
pub fn unpack2x16snorm(packed: u32) -> Vec2 {
    let q = |bits: u32| ((bits as u16 as i16) as f32 / 32767.0).max(-1.0);
    Vec2::new(q(packed & 0xffff), q(packed >> 16))
}

/// `gi::packing::oct_encode`.
pub fn oct_encode(n: Vec3) -> Vec2 {
    let p = Vec2::new(n.x, n.y) / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.z >= 0.0 {
        return p;
    }
    let sign = Vec2::new(
        if p.x >= 0.0 { 1.0 } else { -1.0 },
        if p.y >= 0.0 { 1.0 } else { -1.0 },
    );
    (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign
}

/// `gi::packing::oct_decode`.
pub fn oct_decode(e: Vec2) -> Vec3 {
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    let fold = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -fold } else { fold };
    n.y += if n.y >= 0.0 { -fold } else { fold };
    n.normalize()
}

/// `gi::packing::pack_unit_vector`.
pub fn pack_unit_vector(n: Vec3) -> u32 {
    pack2x16snorm(oct_encode(n))
}

/// `gi::packing::unpack_unit_vector`.
pub fn unpack_unit_vector(packed: u32) -> Vec3 {
    oct_decode(unpack2x16snorm(packed))
}

/// `gi::packing::pack_rgb9e5`.
pub fn pack_rgb9e5(rgb: Vec3) -> u32 {
    let max_value = 65408.0;
    let c = rgb.clamp(Vec3::ZERO, Vec3::splat(max_value));
    let max_channel = c.max_element();
    let mut exponent = (max_channel.max(1e-30).log2().floor() as i32).max(-16) + 1 + 15;
    let mut scale = ((exponent - 15 - 9) as f32).exp2();
    if (max_channel / scale + 0.5).floor() as u32 == 512 {
        exponent += 1;
        scale *= 2.0;
    }
    let m = (c / scale + 0.5).floor().as_uvec3();
    m.x | (m.y << 9) | (m.z << 18) | ((exponent as u32) << 27)
}

/// `gi::packing::unpack_rgb9e5`.
pub fn unpack_rgb9e5(packed: u32) -> Vec3 {
    let exponent = (packed >> 27) as i32;
    let scale = ((exponent - 15 - 9) as f32).exp2();
    Vec3::new(
        (packed & 511) as f32,
        ((packed >> 9) & 511) as f32,
        ((packed >> 18) & 511) as f32,
    ) * scale
}

/// `gi::packing::half_bits`: the f16 bits of `x` (rounded to nearest, ties to even; beyond
/// the largest f16 clamped to it, as the shader clamps).
pub fn half_bits(x: f32) -> u32 {
    u32::from(half::f16::from_f32(x.clamp(-65504.0, 65504.0)).to_bits())
}

/// `gi::packing::half_value`: the f32 value of f16 bits (the low 16 of `h`).
pub fn half_value(h: u32) -> f32 {
    half::f16::from_bits(h as u16).to_f32()
}

/// `gi::packing::pack_color64`: non-negative rgb (16-bit mantissas sharing a 5-bit exponent,
/// channels clamped to 65535) and a non-negative value (an f16 cut to 6 mantissa bits).
pub fn pack_color64(rgb: Vec3, value: f32) -> [u32; 2] {
    let c = rgb.clamp(Vec3::ZERO, Vec3::splat(65535.0));
    let largest = c.max_element();
    let power_of_two = |e: i32| f32::from_bits(((e + 127) as u32) << 23);
    let mut exponent = ((largest.to_bits() >> 23) as i32 - 127).max(-16) + 16;
    if (largest * power_of_two(31 - exponent)).round_ties_even() >= 65536.0 {
        exponent += 1;
    }
    let m = (c * power_of_two(31 - exponent))
        .to_array()
        .map(|e| e.round_ties_even() as u32);
    let short_half = (half_bits(value.max(0.0)) + 8) >> 4;
    [
        m[0] | (m[1] << 16),
        m[2] | ((exponent as u32) << 16) | (short_half << 21),
    ]
}

/// `gi::packing::unpack_color64`: rgb and the value.
pub fn unpack_color64(packed: [u32; 2]) -> Vec4 {
    let m = Vec3::new(
        (packed[0] & 0xffff) as f32,
        (packed[0] >> 16) as f32,
        (packed[1] & 0xffff) as f32,
    );
    let exponent = ((packed[1] >> 16) & 0x1f) as i32;
    let scale = f32::from_bits(((exponent - 31 + 127) as u32) << 23);
    (m * scale).extend(half_value((packed[1] >> 21) << 4))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_within_the_formats_precision() {
        for n in [Vec3::X, Vec3::NEG_Z, Vec3::new(0.3, -0.5, -0.8).normalize()] {
            assert!(unpack_unit_vector(pack_unit_vector(n)).angle_between(n) < 1e-3);
        }
        let rgb = Vec3::new(17.0, 12.0, 4.0);
        assert!((unpack_rgb9e5(pack_rgb9e5(rgb)) - rgb).abs().max_element() < 17.0 / 256.0);
        assert_eq!(pack_rgb9e5(Vec3::ZERO) & 0x7ff_ffff, 0);
        let c = Vec4::new(0.725, 0.71, 0.68, 1.0);
        assert!((unpack4x8unorm(pack4x8unorm(c)) - c).abs().max_element() <= 0.5 / 255.0);
        for (rgb, value) in [
            (Vec3::new(17.0, 12.0, 4.0), 3.0),
            (Vec3::new(1e-3, 2.5e-4, 0.0), 0.0),
            (Vec3::new(6e4, 1.0, 1e-6), 200.0),
        ] {
            let back = unpack_color64(pack_color64(rgb, value));
            let largest = rgb.max_element();
            assert!(
                (back.truncate() - rgb).abs().max_element() <= largest * 2f32.powi(-16),
                "{rgb} {back}"
            );
            assert!(
                (back.w - value).abs() <= value * 2f32.powi(-7),
                "{value} {back}"
            );
        }
        for x in [0.0f32, 1.0, 0.1, 3.0e-6, 65504.0, 1e6] {
            let h = half_value(half_bits(x));
            assert!(
                (h - x.min(65504.0)).abs() <= x * 2f32.powi(-11) + 6e-8,
                "{x} {h}"
            );
        }
    }
}

//! Display encoding: exposure, clamping and the sRGB transfer functions.
//!
//! Every 8-bit image the product writes or measures is produced by the same
//! rule, `srgb_oetf(clamp(exposure * L, 0, 1))` quantised with round-to-nearest,
//! so PNGs on disk and the `rmse_srgb8` metric always agree.
//!
//! Non-finite input is mapped deterministically before encoding: NaN becomes
//! black, `+inf` saturates to white and `-inf` clamps to black.

use glam::Vec3;

use crate::{Image, ImageError};

/// Linear values below this are encoded by the linear toe of the sRGB curve.
pub const SRGB_OETF_THRESHOLD: f32 = 0.003_130_8;

/// Encoded values at or below this are decoded by the linear toe of the sRGB
/// curve; it is `12.92 * SRGB_OETF_THRESHOLD` as specified by IEC 61966-2-1.
pub const SRGB_EOTF_THRESHOLD: f32 = 0.040_45;

/// The exact piecewise sRGB opto-electronic transfer function: linear light to
/// encoded value.
///
/// `12.92 * x` below [`SRGB_OETF_THRESHOLD`], else `1.055 * x^(1/2.4) - 0.055`.
/// Meant for `x` in `0..=1`; outside that range the pieces are simply extended
/// and NaN propagates.
pub fn srgb_oetf(linear: f32) -> f32 {
    if linear < SRGB_OETF_THRESHOLD {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_oetf`]: encoded value to linear light.
///
/// `v / 12.92` up to [`SRGB_EOTF_THRESHOLD`], else `((v + 0.055) / 1.055)^2.4`.
/// Meant for `v` in `0..=1`; outside that range the pieces are simply extended
/// and NaN propagates.
pub fn srgb_eotf(encoded: f32) -> f32 {
    if encoded <= SRGB_EOTF_THRESHOLD {
        encoded / 12.92
    } else {
        ((encoded + 0.055) / 1.055).powf(2.4)
    }
}

/// Applies exposure and clamps to the displayable range `0..=1`.
///
/// NaN (including `0 * inf`) becomes 0, so a single bad sample shows up as a
/// black pixel instead of poisoning a whole metric.
pub fn expose_clamped(linear: f32, exposure: f32) -> f32 {
    let v = exposure * linear;
    if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) }
}

/// Quantises a value in `0..=1` to 8 bits with round-to-nearest:
/// `floor(v * 255 + 0.5)`. Out-of-range input saturates.
pub fn quantize8(value: f32) -> u8 {
    // `as` saturates, and maps NaN to 0, which matches the tonemap rule.
    (value * 255.0 + 0.5).floor() as u8
}

/// Encodes one linear channel to its 8-bit sRGB display value:
/// `quantize8(srgb_oetf(clamp(exposure * linear, 0, 1)))`.
pub fn linear_to_srgb8(linear: f32, exposure: f32) -> u8 {
    quantize8(srgb_oetf(expose_clamped(linear, exposure)))
}

/// Decodes one 8-bit sRGB value back to linear light with [`srgb_eotf`].
pub fn srgb8_to_linear(code: u8) -> f32 {
    srgb_eotf(f32::from(code) / 255.0)
}

/// Tonemaps a whole image to interleaved 8-bit sRGB bytes (`R, G, B` per pixel,
/// row-major, top row first), exactly as [`crate::write_png`] stores them.
pub fn to_srgb8(image: &Image, exposure: f32) -> Vec<u8> {
    image
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(|c| linear_to_srgb8(c, exposure)))
        .collect()
}

/// Builds a linear image from interleaved 8-bit sRGB bytes, the inverse of
/// [`to_srgb8`] up to quantisation.
pub fn from_srgb8(width: u32, height: u32, bytes: &[u8]) -> Result<Image, ImageError> {
    if !bytes.len().is_multiple_of(3) {
        // A trailing partial pixel would otherwise be dropped silently.
        return Err(ImageError::PixelCount {
            width,
            height,
            len: bytes.len() / 3,
        });
    }
    let pixels = bytes
        .chunks_exact(3)
        .map(|rgb| Vec3::from_array([rgb[0], rgb[1], rgb[2]].map(srgb8_to_linear)))
        .collect();
    Image::from_pixels(width, height, pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn oetf_known_values() {
        assert_eq!(srgb_oetf(0.0), 0.0);
        assert!(close(srgb_oetf(1.0), 1.0, 1e-6));
        // Linear toe.
        assert!(close(srgb_oetf(0.001), 0.01292, 1e-7));
        // Mid grey and one half, from the closed form evaluated in f64.
        assert!(close(srgb_oetf(0.18), 0.461_356_1, 1e-6));
        assert!(close(srgb_oetf(0.5), 0.735_356_6, 1e-6));
        // Both pieces meet (almost exactly) at the threshold.
        let below = 12.92 * SRGB_OETF_THRESHOLD;
        assert!(close(srgb_oetf(SRGB_OETF_THRESHOLD), below, 1e-6));
    }

    #[test]
    fn eotf_known_values() {
        assert_eq!(srgb_eotf(0.0), 0.0);
        assert!(close(srgb_eotf(1.0), 1.0, 1e-6));
        assert!(close(srgb_eotf(0.02), 0.02 / 12.92, 1e-9));
        assert!(close(srgb_eotf(0.5), 0.214_041_1, 1e-6));
        assert!(close(srgb_eotf(188.0 / 255.0), 0.502_886_5, 1e-6));
    }

    #[test]
    fn oetf_and_eotf_are_inverse() {
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            assert!(close(srgb_eotf(srgb_oetf(x)), x, 2e-6), "x = {x}");
            assert!(close(srgb_oetf(srgb_eotf(x)), x, 2e-6), "v = {x}");
        }
    }

    #[test]
    fn every_8bit_code_round_trips() {
        for code in 0..=255u8 {
            assert_eq!(linear_to_srgb8(srgb8_to_linear(code), 1.0), code);
        }
    }

    #[test]
    fn srgb8_known_codes_and_rounding() {
        assert_eq!(linear_to_srgb8(0.0, 1.0), 0);
        assert_eq!(linear_to_srgb8(1.0, 1.0), 255);
        assert_eq!(linear_to_srgb8(0.5, 1.0), 188);
        assert_eq!(linear_to_srgb8(0.18, 1.0), 118);
        // Round to nearest, not truncation: 0.5 / 255 encodes to code 1.
        assert_eq!(quantize8(0.5 / 255.0), 1);
        assert_eq!(quantize8(0.49 / 255.0), 0);
    }

    #[test]
    fn exposure_scales_before_clamping() {
        assert_eq!(linear_to_srgb8(0.25, 2.0), 188);
        assert_eq!(linear_to_srgb8(2.0, 0.5), 255);
        assert_eq!(linear_to_srgb8(2.0, 1.0), 255);
        assert_eq!(linear_to_srgb8(-3.0, 1.0), 0);
        assert_eq!(linear_to_srgb8(1.0, 0.5), 188);
    }

    #[test]
    fn non_finite_input_is_mapped_deterministically() {
        assert_eq!(linear_to_srgb8(f32::NAN, 1.0), 0);
        assert_eq!(linear_to_srgb8(f32::INFINITY, 1.0), 255);
        assert_eq!(linear_to_srgb8(f32::NEG_INFINITY, 1.0), 0);
        // 0 * inf is NaN, hence black.
        assert_eq!(linear_to_srgb8(f32::INFINITY, 0.0), 0);
        assert_eq!(linear_to_srgb8(0.5, f32::NAN), 0);
    }

    #[test]
    fn to_srgb8_interleaves_rgb_row_major() {
        let image = Image::from_fn(2, 1, |x, _| {
            if x == 0 {
                Vec3::new(1.0, 0.0, 0.5)
            } else {
                Vec3::new(0.0, 0.18, f32::NAN)
            }
        });
        assert_eq!(to_srgb8(&image, 1.0), vec![255, 0, 188, 0, 118, 0]);
    }

    #[test]
    fn from_srgb8_inverts_to_srgb8() {
        let bytes = vec![0, 128, 255, 17, 188, 3];
        let image = from_srgb8(2, 1, &bytes).unwrap();
        assert_eq!(image.get(1, 0).y, srgb_eotf(188.0 / 255.0));
        assert_eq!(to_srgb8(&image, 1.0), bytes);
        assert!(from_srgb8(2, 1, &bytes[..5]).is_err());
        assert!(from_srgb8(3, 1, &bytes).is_err());
    }
}

//! Error heat maps: where, and how badly, an image departs from its reference.
//!
//! The per-pixel error is the RMS over R, G and B of the difference between
//! the two 8-bit sRGB encodings (the same encoding [`crate::rmse_srgb8`]
//! averages), so a heat map is the spatial breakdown of that metric.
//!
//! Errors are normalised to a fixed scale, [`HEATMAP_FULL_SCALE`] levels by
//! default, rather than to each image's maximum: heat maps of different
//! techniques on the same scene are then directly comparable, and a nearly
//! perfect image does not have its noise blown up to full brightness.
//!
//! Heat map images are display-referred: their values are already sRGB
//! encoded in `0..=1`. Write them with [`write_heatmap_png`], which stores
//! them directly, not with [`crate::write_png`], which would encode them again.

use std::path::Path;

use glam::Vec3;

use crate::io::{check_writable, write_rgb8_png};
use crate::metrics::check_comparable;
use crate::tonemap::{linear_to_srgb8, quantize8};
use crate::{Image, ImageError};

/// Per-pixel error, in 8-bit sRGB levels, shown at the top of the ramp by
/// [`error_heatmap`]. Larger errors saturate. A quarter of the 8-bit range
/// keeps typical real-time GI errors spread over the ramp while still
/// showing gross failures as saturated.
pub const HEATMAP_FULL_SCALE: f32 = 64.0;

/// The ramp's control points as sRGB bytes, evenly spaced from zero error to
/// full scale. They are samples of the "inferno" colour map: perceptually
/// ordered from near-black through purple, red and orange to pale yellow,
/// with lightness increasing monotonically, and readable by people with
/// common colour-vision deficiencies.
const RAMP: [[u8; 3]; 5] = [
    [0, 0, 4],
    [87, 16, 110],
    [188, 55, 84],
    [249, 142, 9],
    [252, 255, 164],
];

/// Colour of the ramp at `t` (0 = no error, 1 = full scale), as display
/// sRGB values in `0..=1`, linearly interpolated between control points.
/// `t` is clamped to `0..=1`; NaN maps to the zero colour.
pub fn heatmap_ramp(t: f32) -> Vec3 {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let segments = (RAMP.len() - 1) as f32;
    let position = t * segments;
    // The last control point belongs to the last segment, at fraction 1.
    let i = (position.floor() as usize).min(RAMP.len() - 2);
    let f = position - i as f32;
    let lo = Vec3::from_array(RAMP[i].map(f32::from));
    let hi = Vec3::from_array(RAMP[i + 1].map(f32::from));
    lo.lerp(hi, f) / 255.0
}

/// Per-pixel error between the 8-bit sRGB encodings of `a` and `b` (each
/// tonemapped with `exposure`): the RMS over channels of the code difference,
/// in `0..=255` levels, row-major.
pub fn pixel_errors_srgb8(a: &Image, b: &Image, exposure: f32) -> Result<Vec<f32>, ImageError> {
    check_comparable(a, b)?;
    Ok(a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(pa, pb)| {
            let sum: f32 = (0..3)
                .map(|c| {
                    let d = f32::from(linear_to_srgb8(pa[c], exposure))
                        - f32::from(linear_to_srgb8(pb[c], exposure));
                    d * d
                })
                .sum();
            (sum / 3.0).sqrt()
        })
        .collect())
}

/// Heat map of the per-pixel sRGB8 error between `a` and `b`, with
/// [`HEATMAP_FULL_SCALE`] levels at the top of the ramp.
///
/// The result is display-referred (see the module documentation).
pub fn error_heatmap(a: &Image, b: &Image, exposure: f32) -> Result<Image, ImageError> {
    error_heatmap_with_scale(a, b, exposure, HEATMAP_FULL_SCALE)
}

/// Heat map of the per-pixel sRGB8 error between `a` and `b`, with an error of
/// `full_scale` levels (or more) at the top of the ramp.
///
/// # Panics
/// When `full_scale` is not a positive finite number.
pub fn error_heatmap_with_scale(
    a: &Image,
    b: &Image,
    exposure: f32,
    full_scale: f32,
) -> Result<Image, ImageError> {
    assert!(
        full_scale.is_finite() && full_scale > 0.0,
        "heat map full scale must be positive and finite, got {full_scale}"
    );
    let errors = pixel_errors_srgb8(a, b, exposure)?;
    let pixels = errors
        .into_iter()
        .map(|e| heatmap_ramp(e / full_scale))
        .collect();
    Image::from_pixels(a.width, a.height, pixels)
}

/// Writes a display-referred image, such as a heat map, as an 8-bit RGB PNG:
/// each value is clamped to `0..=1` and quantised with round-to-nearest, with
/// no exposure and no transfer function.
pub fn write_heatmap_png(heatmap: &Image, path: impl AsRef<Path>) -> Result<(), ImageError> {
    let path = path.as_ref();
    check_writable(heatmap, path)?;
    let bytes: Vec<u8> = heatmap
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(quantize8))
        .collect();
    write_rgb8_png(&bytes, heatmap.width, heatmap.height, path)
}

/// What [`write_error_heatmap`] drew.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeatmapInfo {
    /// Error, in 8-bit sRGB levels, at the top of the ramp.
    pub full_scale: f32,
    /// Largest per-pixel error in the image; above `full_scale` means some
    /// pixels saturated.
    pub max_error: f32,
}

/// Computes the heat map of `a` against `b` at [`HEATMAP_FULL_SCALE`] and
/// writes it to `path` as a PNG, returning the scale used and the largest
/// per-pixel error.
pub fn write_error_heatmap(
    a: &Image,
    b: &Image,
    exposure: f32,
    path: impl AsRef<Path>,
) -> Result<HeatmapInfo, ImageError> {
    let errors = pixel_errors_srgb8(a, b, exposure)?;
    let max_error = errors.iter().copied().fold(0.0, f32::max);
    let pixels = errors
        .into_iter()
        .map(|e| heatmap_ramp(e / HEATMAP_FULL_SCALE))
        .collect();
    write_heatmap_png(&Image::from_pixels(a.width, a.height, pixels)?, path)?;
    Ok(HeatmapInfo {
        full_scale: HEATMAP_FULL_SCALE,
        max_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brightness(v: Vec3) -> f32 {
        v.x + v.y + v.z
    }

    #[test]
    fn ramp_hits_its_control_points() {
        assert_eq!(heatmap_ramp(0.0), Vec3::new(0.0, 0.0, 4.0) / 255.0);
        assert_eq!(heatmap_ramp(0.5), Vec3::new(188.0, 55.0, 84.0) / 255.0);
        assert_eq!(heatmap_ramp(1.0), Vec3::new(252.0, 255.0, 164.0) / 255.0);
        assert_eq!(heatmap_ramp(-1.0), heatmap_ramp(0.0));
        assert_eq!(heatmap_ramp(7.0), heatmap_ramp(1.0));
        assert_eq!(heatmap_ramp(f32::NAN), heatmap_ramp(0.0));
    }

    #[test]
    fn ramp_brightens_monotonically() {
        let mut previous = brightness(heatmap_ramp(0.0));
        for i in 1..=100 {
            let current = brightness(heatmap_ramp(i as f32 / 100.0));
            assert!(
                current > previous,
                "ramp darkens at t = {}",
                i as f32 / 100.0
            );
            previous = current;
        }
    }

    #[test]
    fn pixel_errors_are_rms_over_channels() {
        let a = Image::from_fn(2, 1, |x, _| {
            if x == 0 {
                Vec3::new(1.0, 0.0, 0.0)
            } else {
                Vec3::ONE
            }
        });
        let b = Image::new(2, 1);
        let errors = pixel_errors_srgb8(&a, &b, 1.0).unwrap();
        assert!((errors[0] - 255.0 / 3.0f32.sqrt()).abs() < 1e-4);
        assert_eq!(errors[1], 255.0);
    }

    #[test]
    fn identical_images_give_the_zero_colour_everywhere() {
        let a = Image::from_fn(4, 3, |x, y| Vec3::new(x as f32 * 0.3, y as f32, 0.7));
        let map = error_heatmap(&a, &a, 1.0).unwrap();
        assert_eq!(map.size(), (4, 3));
        assert!(map.pixels.iter().all(|p| *p == heatmap_ramp(0.0)));
    }

    #[test]
    fn larger_error_gives_a_brighter_colour() {
        let reference = Image::new(3, 1);
        // Errors of 0, 10 and 188 levels: none, small, saturated.
        let image = Image::from_fn(3, 1, |x, _| Vec3::splat([0.0, 0.003, 0.5][x as usize]));
        let map = error_heatmap(&image, &reference, 1.0).unwrap();
        let [none, small, large] = [0, 1, 2].map(|x| brightness(map.get(x, 0)));
        assert!(none < small && small < large);
        assert_eq!(map.get(2, 0), heatmap_ramp(1.0));
    }

    #[test]
    fn scale_sets_where_the_ramp_saturates() {
        let reference = Image::new(1, 1);
        // 0.5 encodes to 188 on every channel.
        let image = Image::from_fn(1, 1, |_, _| Vec3::splat(0.5));
        let full = error_heatmap_with_scale(&image, &reference, 1.0, 188.0).unwrap();
        assert_eq!(full.get(0, 0), heatmap_ramp(1.0));
        let half = error_heatmap_with_scale(&image, &reference, 1.0, 376.0).unwrap();
        assert_eq!(half.get(0, 0), heatmap_ramp(0.5));
    }

    #[test]
    #[should_panic(expected = "full scale must be positive")]
    fn zero_scale_panics() {
        let a = Image::new(1, 1);
        let _ = error_heatmap_with_scale(&a, &a, 1.0, 0.0);
    }

    #[test]
    fn heatmap_rejects_mismatched_sizes() {
        let err = error_heatmap(&Image::new(2, 2), &Image::new(2, 3), 1.0).unwrap_err();
        assert!(matches!(err, ImageError::SizeMismatch { .. }));
    }
}

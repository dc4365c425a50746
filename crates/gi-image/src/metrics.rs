//! Error metrics between a rendered image and its reference.
//!
//! All metrics require two images of the same, non-zero resolution and average
//! over every pixel and every channel. Sums are accumulated in 64 bits so the
//! result does not depend on image size through rounding.
//!
//! Non-finite values are handled as follows:
//! - [`rmse_srgb8`] tonemaps first, which maps NaN to black and infinities to
//!   the clamp bounds (see [`crate::tonemap`]), so it always returns a number.
//! - [`rmse_linear`] and [`rel_mse`] return [`ImageError::NonFinite`] naming
//!   the first offending pixel (scanning `a` then `b`), because no finite
//!   linear-space error describes an image containing NaN or infinity.

use glam::Vec3;

use crate::tonemap::linear_to_srgb8;
use crate::{Image, ImageError};

/// The `0.01` in the denominator of [`rel_mse`], which keeps near-black
/// reference pixels from dominating the relative error.
pub const REL_MSE_EPSILON: f64 = 0.01;

/// Root-mean-square error between the 8-bit sRGB encodings of `a` and `b`,
/// each tonemapped with `exposure` as [`crate::write_png`] would, over all
/// pixels and channels. The result is in `0..=255` display levels.
pub fn rmse_srgb8(a: &Image, b: &Image, exposure: f32) -> Result<f64, ImageError> {
    check_comparable(a, b)?;
    // Squared differences of 8-bit codes are integers, so an integer sum is
    // exact for any image that fits in memory.
    let sum: u64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(pa, pb)| {
            (0..3)
                .map(|c| {
                    let d = i64::from(linear_to_srgb8(pa[c], exposure))
                        - i64::from(linear_to_srgb8(pb[c], exposure));
                    (d * d) as u64
                })
                .sum::<u64>()
        })
        .sum();
    Ok((sum as f64 / sample_count(a)).sqrt())
}

/// Root-mean-square error between the linear values of `a` and `b`, over all
/// pixels and channels.
///
/// Returns [`ImageError::NonFinite`] if either image holds NaN or infinity.
pub fn rmse_linear(a: &Image, b: &Image) -> Result<f64, ImageError> {
    let sum = sum_over_channels(a, b, |x, y| (x - y) * (x - y))?;
    Ok((sum / sample_count(a)).sqrt())
}

/// Relative mean squared error of `image` against `reference`: the mean over
/// pixels and channels of `(image - reference)^2 / (reference^2 + 0.01)`.
///
/// Returns [`ImageError::NonFinite`] if either image holds NaN or infinity.
pub fn rel_mse(image: &Image, reference: &Image) -> Result<f64, ImageError> {
    let sum = sum_over_channels(image, reference, |x, r| {
        (x - r) * (x - r) / (r * r + REL_MSE_EPSILON)
    })?;
    Ok(sum / sample_count(image))
}

/// How much of the direct-only error a technique leaves:
/// `tier_rmse / direct_rmse`, both measured with [`rmse_srgb8`] against the
/// same reference. Lower is better; 1 means no better than direct lighting
/// alone, 0 means identical to the reference.
///
/// Returns `None` when the ratio is undefined or meaningless: `direct_rmse`
/// is zero (direct lighting already matches the reference), negative or not
/// finite, or `tier_rmse` is negative or not finite.
pub fn gain_vs_direct(tier_rmse: f64, direct_rmse: f64) -> Option<f64> {
    let valid = |v: f64| v.is_finite() && v >= 0.0;
    (valid(tier_rmse) && valid(direct_rmse) && direct_rmse > 0.0).then(|| tier_rmse / direct_rmse)
}

/// The standard measurements of an image against its reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// [`rmse_srgb8`] at the comparison's exposure.
    pub rmse_srgb8: f64,
    /// Mean FLIP (LDR) at the comparison's exposure ([`crate::flip_ldr`]).
    pub flip: f64,
    /// [`rmse_linear`].
    pub rmse_linear: f64,
    /// [`rel_mse`] with the reference as denominator.
    pub rel_mse: f64,
}

/// Computes [`rmse_srgb8`], mean FLIP ([`crate::flip_ldr`]), [`rmse_linear`] and
/// [`rel_mse`] of `image` against `reference` in one call. Fails as the linear
/// metrics do on non-finite input.
pub fn compare(image: &Image, reference: &Image, exposure: f32) -> Result<Comparison, ImageError> {
    Ok(Comparison {
        rmse_srgb8: rmse_srgb8(image, reference, exposure)?,
        flip: crate::flip_ldr(image, reference, exposure)?.mean,
        rmse_linear: rmse_linear(image, reference)?,
        rel_mse: rel_mse(image, reference)?,
    })
}

/// The error of a renderer split into its noise and its bias, from two renders of one view
/// with independent random seeds ([`error_split_srgb8`]), in 8-bit sRGB levels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorSplit {
    /// [`rmse_srgb8`] of the first render against the reference.
    pub rmse_a: f64,
    /// [`rmse_srgb8`] of the second render against the reference.
    pub rmse_b: f64,
    /// RMS of one render's deviation from the renderer's expected image: the square root of
    /// half the mean squared difference of the two renders.
    pub noise: f64,
    /// RMS error of the expected image against the reference: the square root of the mean
    /// squared error less the noise's share (0 where noise explains all the error).
    pub bias: f64,
}

/// Splits the error of a renderer into noise and bias: `a` and `b` are two renders of one view
/// that differ only in their random seeds. For each 8-bit code `x = mu + e` with `e` zero-mean
/// and independent between the renders, `E[(a - b)^2] / 2 = var(e)` and
/// `E[(a - r)^2] = (mu - r)^2 + var(e)`, averaged over pixels and channels as [`rmse_srgb8`]
/// averages. Noise that the two renders share (a seed-independent pattern) counts as bias.
pub fn error_split_srgb8(
    reference: &Image,
    a: &Image,
    b: &Image,
    exposure: f32,
) -> Result<ErrorSplit, ImageError> {
    check_comparable(reference, a)?;
    check_comparable(reference, b)?;
    let rmse_a = rmse_srgb8(a, reference, exposure)?;
    let rmse_b = rmse_srgb8(b, reference, exposure)?;
    let noise = rmse_srgb8(a, b, exposure)? / std::f64::consts::SQRT_2;
    let mse = (rmse_a * rmse_a + rmse_b * rmse_b) / 2.0;
    Ok(ErrorSplit {
        rmse_a,
        rmse_b,
        noise,
        bias: (mse - noise * noise).max(0.0).sqrt(),
    })
}

/// Mean luminance (Rec. 709 weights, linear) of `image` over that of `reference`, less 1: the
/// image's overall brightness error, `0.01` for 1% too bright. Linear, so unlike a mean over
/// 8-bit images it does not lose the light that clipping at white removes. `None` when the
/// reference is black.
pub fn luminance_bias(image: &Image, reference: &Image) -> Result<Option<f64>, ImageError> {
    check_comparable(image, reference)?;
    check_finite(image, "image")?;
    check_finite(reference, "reference")?;
    let luminance = |img: &Image| -> f64 {
        img.pixels
            .iter()
            .map(|p| p.as_dvec3().dot(glam::DVec3::new(0.2126, 0.7152, 0.0722)))
            .sum()
    };
    let total = luminance(reference);
    Ok((total > 0.0).then(|| luminance(image) / total - 1.0))
}

/// Checks that two images can be compared: consistent buffers, same size and
/// at least one pixel.
pub(crate) fn check_comparable(a: &Image, b: &Image) -> Result<(), ImageError> {
    a.check_same_size(b)?;
    if a.is_empty() {
        return Err(ImageError::Empty {
            path: None,
            width: a.width,
            height: a.height,
        });
    }
    Ok(())
}

/// Number of channel samples the metrics average over.
fn sample_count(image: &Image) -> f64 {
    image.pixels.len() as f64 * 3.0
}

/// Sums `f(a, b)` in `f64` over every channel of every pixel pair, after
/// checking both images are comparable and finite.
fn sum_over_channels(a: &Image, b: &Image, f: impl Fn(f64, f64) -> f64) -> Result<f64, ImageError> {
    check_comparable(a, b)?;
    check_finite(a, "a")?;
    check_finite(b, "b")?;
    Ok(a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(pa, pb)| {
            let (pa, pb) = (pa.as_dvec3(), pb.as_dvec3());
            (0..3).map(|c| f(pa[c], pb[c])).sum::<f64>()
        })
        .sum())
}

fn check_finite(image: &Image, name: &'static str) -> Result<(), ImageError> {
    match image.enumerate_pixels().find(|(_, _, p)| !p.is_finite()) {
        None => Ok(()),
        Some((x, y, p)) => Err(ImageError::NonFinite {
            image: name,
            x,
            y,
            value: first_non_finite(p),
        }),
    }
}

fn first_non_finite(p: Vec3) -> f32 {
    p.to_array()
        .into_iter()
        .find(|c| !c.is_finite())
        .unwrap_or(f32::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(w: u32, h: u32, v: Vec3) -> Image {
        Image::from_fn(w, h, |_, _| v)
    }

    /// An image whose 8-bit codes (exposure 1) are `code(x, y)` in every channel.
    fn from_codes(w: u32, h: u32, code: impl Fn(u32, u32) -> i32) -> Image {
        Image::from_fn(w, h, |x, y| {
            Vec3::splat(crate::tonemap::srgb8_to_linear(code(x, y) as u8))
        })
    }

    #[test]
    fn error_split_recovers_a_known_bias_and_noise() {
        // Codes: reference 100; the renders 100 + 6 (bias) + 3 s, with s = +-1 patterns of
        // period 4 that are orthogonal (mean of their product 0) and zero-mean, as independent
        // noise is in expectation.
        let pattern_a = |x: u32| [1, 1, -1, -1][(x % 4) as usize];
        let pattern_b = |x: u32| [1, -1, 1, -1][(x % 4) as usize];
        let reference = from_codes(8, 2, |_, _| 100);
        let a = from_codes(8, 2, |x, _| 106 + 3 * pattern_a(x));
        let b = from_codes(8, 2, |x, _| 106 + 3 * pattern_b(x));
        let split = error_split_srgb8(&reference, &a, &b, 1.0).unwrap();
        let close = |x: f64, y: f64| (x - y).abs() < 1e-9;
        assert!(close(split.rmse_a, 45f64.sqrt()), "{split:?}");
        assert!(close(split.rmse_b, 45f64.sqrt()), "{split:?}");
        assert!(close(split.noise, 3.0), "{split:?}");
        assert!(close(split.bias, 6.0), "{split:?}");
        // Identical renders: no noise, all of the error is bias.
        let same = error_split_srgb8(&reference, &a, &a, 1.0).unwrap();
        assert_eq!(same.noise, 0.0);
        assert!(close(same.bias, same.rmse_a));
        // Sizes must agree.
        assert!(error_split_srgb8(&reference, &a, &Image::new(4, 2), 1.0).is_err());
    }

    #[test]
    fn luminance_bias_is_linear_and_ignores_clipping() {
        let reference = constant(4, 2, Vec3::new(2.0, 2.0, 2.0));
        // 10% brighter in linear light, although both encode to white.
        let brighter = constant(4, 2, Vec3::new(2.2, 2.2, 2.2));
        let bias = luminance_bias(&brighter, &reference).unwrap().unwrap();
        assert!((bias - 0.1).abs() < 1e-6, "{bias}");
        assert_eq!(rmse_srgb8(&brighter, &reference, 1.0).unwrap(), 0.0);
        // Green weighs most: a green-only excess moves the mean by its weight.
        let green = constant(4, 2, Vec3::new(2.0, 2.2, 2.0));
        let bias = luminance_bias(&green, &reference).unwrap().unwrap();
        assert!((bias - 0.07152).abs() < 1e-6, "{bias}");
        assert_eq!(luminance_bias(&reference, &Image::new(4, 2)).unwrap(), None);
        let mut nan = reference.clone();
        nan.set(1, 1, Vec3::splat(f32::NAN));
        assert!(luminance_bias(&nan, &reference).is_err());
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = Image::from_fn(5, 3, |x, y| Vec3::new(x as f32, y as f32 * 0.1, 0.3));
        assert_eq!(rmse_srgb8(&a, &a, 1.0).unwrap(), 0.0);
        assert_eq!(rmse_linear(&a, &a).unwrap(), 0.0);
        assert_eq!(rel_mse(&a, &a).unwrap(), 0.0);
    }

    #[test]
    fn rmse_linear_of_constant_images() {
        let a = constant(4, 4, Vec3::splat(0.5));
        let b = constant(4, 4, Vec3::splat(0.25));
        assert_eq!(rmse_linear(&a, &b).unwrap(), 0.25);
        // One channel differing by 3 in one pixel of 4: sqrt(9 / 12).
        let mut c = Image::new(2, 2);
        c.set(1, 1, Vec3::new(0.0, 3.0, 0.0));
        let expected = (9.0f64 / 12.0).sqrt();
        assert!((rmse_linear(&c, &Image::new(2, 2)).unwrap() - expected).abs() < 1e-15);
    }

    #[test]
    fn rmse_srgb8_of_constant_images() {
        let white = constant(3, 2, Vec3::ONE);
        let black = Image::new(3, 2);
        assert_eq!(rmse_srgb8(&white, &black, 1.0).unwrap(), 255.0);
        // 0.5 encodes to 188 and 0.25 to 137: a difference of 51 everywhere.
        let a = constant(3, 2, Vec3::splat(0.5));
        let b = constant(3, 2, Vec3::splat(0.25));
        assert_eq!(rmse_srgb8(&a, &b, 1.0).unwrap(), 51.0);
        // One red pixel among black: sqrt(255^2 / 3) over one pixel.
        let red = constant(1, 1, Vec3::X);
        let expected = 255.0 / 3.0f64.sqrt();
        assert!((rmse_srgb8(&red, &Image::new(1, 1), 1.0).unwrap() - expected).abs() < 1e-12);
    }

    #[test]
    fn rmse_srgb8_applies_exposure_then_clamps() {
        let black = Image::new(2, 2);
        // 0.5 at exposure 2 reaches white; at exposure 1 it is code 188.
        let half = constant(2, 2, Vec3::splat(0.5));
        assert_eq!(rmse_srgb8(&half, &black, 2.0).unwrap(), 255.0);
        assert_eq!(rmse_srgb8(&half, &black, 1.0).unwrap(), 188.0);
        // Values above 1 clamp: 2.0 and 8.0 are both white at exposure 1,
        // but differ at exposure 1/8 (codes 137 and 255).
        let two = constant(2, 2, Vec3::splat(2.0));
        let eight = constant(2, 2, Vec3::splat(8.0));
        assert_eq!(rmse_srgb8(&two, &eight, 1.0).unwrap(), 0.0);
        assert_eq!(rmse_srgb8(&two, &eight, 0.125).unwrap(), 118.0);
        // Negative values clamp to black.
        let negative = constant(2, 2, Vec3::splat(-1.0));
        assert_eq!(rmse_srgb8(&negative, &black, 1.0).unwrap(), 0.0);
    }

    #[test]
    fn rmse_srgb8_treats_nan_as_black() {
        let nan = constant(1, 1, Vec3::splat(f32::NAN));
        let black = Image::new(1, 1);
        assert_eq!(rmse_srgb8(&nan, &black, 1.0).unwrap(), 0.0);
        let inf = constant(1, 1, Vec3::splat(f32::INFINITY));
        assert_eq!(rmse_srgb8(&inf, &black, 1.0).unwrap(), 255.0);
    }

    #[test]
    fn rel_mse_follows_its_formula() {
        // (1 - 0.5)^2 / (0.5^2 + 0.01) = 0.25 / 0.26 on every channel.
        let image = constant(2, 1, Vec3::ONE);
        let reference = constant(2, 1, Vec3::splat(0.5));
        let expected = 0.25 / 0.26;
        assert!((rel_mse(&image, &reference).unwrap() - expected).abs() < 1e-12);
        // The reference is the denominator: swapping changes the result.
        let swapped = 0.25 / 1.01;
        assert!((rel_mse(&reference, &image).unwrap() - swapped).abs() < 1e-12);
        // Black reference: (0.1)^2 / 0.01 = 1 on one channel of one pixel out of 2.
        let mut dim = Image::new(2, 1);
        dim.set(0, 0, Vec3::new(0.1, 0.0, 0.0));
        let expected = (0.1f32 as f64).powi(2) / 0.01 / 6.0;
        assert!((rel_mse(&dim, &Image::new(2, 1)).unwrap() - expected).abs() < 1e-12);
    }

    #[test]
    fn linear_metrics_reject_non_finite_input() {
        let mut a = Image::new(3, 2);
        a.set(2, 1, Vec3::new(0.0, f32::INFINITY, 0.0));
        let b = Image::new(3, 2);
        let err = rmse_linear(&a, &b).unwrap_err();
        assert!(matches!(
            err,
            ImageError::NonFinite { image: "a", x: 2, y: 1, value } if value == f32::INFINITY
        ));
        let err = rel_mse(&b, &a).unwrap_err();
        assert!(matches!(
            err,
            ImageError::NonFinite {
                image: "b",
                x: 2,
                y: 1,
                ..
            }
        ));
        let mut nan = Image::new(3, 2);
        nan.set(0, 1, Vec3::splat(f32::NAN));
        let err = rmse_linear(&nan, &b).unwrap_err();
        assert!(
            matches!(err, ImageError::NonFinite { image: "a", x: 0, y: 1, value } if value.is_nan())
        );
    }

    #[test]
    fn size_mismatch_and_empty_images_are_errors() {
        let a = Image::new(4, 2);
        let b = Image::new(2, 4);
        for err in [
            rmse_srgb8(&a, &b, 1.0).unwrap_err(),
            rmse_linear(&a, &b).unwrap_err(),
            rel_mse(&a, &b).unwrap_err(),
        ] {
            assert!(matches!(
                err,
                ImageError::SizeMismatch {
                    a: (4, 2),
                    b: (2, 4)
                }
            ));
        }
        let empty = Image::new(0, 3);
        assert!(matches!(
            rmse_srgb8(&empty, &empty, 1.0).unwrap_err(),
            ImageError::Empty { path: None, .. }
        ));
        let broken = Image {
            width: 2,
            height: 2,
            pixels: vec![Vec3::ZERO; 3],
        };
        assert!(matches!(
            rmse_linear(&broken, &Image::new(2, 2)).unwrap_err(),
            ImageError::PixelCount { len: 3, .. }
        ));
    }

    #[test]
    fn gain_vs_direct_is_a_ratio_with_undefined_cases() {
        assert_eq!(gain_vs_direct(1.0, 4.0), Some(0.25));
        assert!((gain_vs_direct(5.734, 57.34).unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(gain_vs_direct(0.0, 57.34), Some(0.0));
        assert_eq!(gain_vs_direct(3.0, 0.0), None);
        assert_eq!(gain_vs_direct(3.0, f64::NAN), None);
        assert_eq!(gain_vs_direct(f64::INFINITY, 2.0), None);
        assert_eq!(gain_vs_direct(-1.0, 2.0), None);
    }

    #[test]
    fn compare_bundles_the_metrics() {
        let image = constant(2, 2, Vec3::splat(0.5));
        let reference = constant(2, 2, Vec3::splat(0.25));
        let c = compare(&image, &reference, 1.0).unwrap();
        assert_eq!(c.rmse_srgb8, 51.0);
        assert_eq!(
            c.flip,
            crate::flip_ldr(&image, &reference, 1.0).unwrap().mean
        );
        assert!(c.flip > 0.0);
        assert_eq!(c.rmse_linear, 0.25);
        assert!((c.rel_mse - 0.0625 / 0.0725).abs() < 1e-12);
    }
}

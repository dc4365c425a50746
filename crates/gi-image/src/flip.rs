//! FLIP: a perceptual difference between a render and its reference.
//!
//! FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images", HPG)
//! estimates, per pixel, how visible the difference between two images is to a person who
//! flips between them: both images go to a perceptually uniform colour space after filtering
//! by the eye's contrast sensitivity at the given viewing distance, their colour difference is
//! combined with a difference of edges and points, and the result lies in `0..=1` (0: no
//! visible difference). The mean over pixels is the single number its authors recommend.
//!
//! This module computes the LDR variant with NVIDIA's own C++ implementation (through the
//! `nv-flip` bindings), on the 8-bit sRGB images that [`crate::write_png`] stores and
//! [`crate::rmse_srgb8`] measures: `srgb_oetf(clamp(exposure * L, 0, 1))` quantised to 8 bits
//! (see [`crate::tonemap`]). So `flip` and `rmse_srgb8` always describe the same pixels, and
//! NVIDIA's tools give the same numbers on the written PNGs. The viewing condition is
//! NVIDIA's default, [`FLIP_PIXELS_PER_DEGREE`].
//!
//! FLIP costs far more than RMSE: about half a second per megapixel on one core (0.54 s at
//! 1280x720 on the development machine).

use std::path::Path;

use crate::heatmap::write_heatmap_png;
use crate::metrics::check_comparable;
use crate::tonemap::to_srgb8;
use crate::{Image, ImageError};

/// Pixels per degree of visual angle FLIP assumes: NVIDIA's default viewing condition, a
/// 3840-pixel-wide display 0.7 m wide seen from 0.7 m, `0.7 * 3840 / 0.7 * pi / 180` in
/// `f32`, exactly as NVIDIA's tools compute it (the "67 PPD" of the paper; 67.0 itself moves
/// a mean by about 1e-5). More pixels per degree (a farther viewer) hide finer differences;
/// fewer make them more visible.
pub const FLIP_PIXELS_PER_DEGREE: f32 = 67.020_645;

/// FLIP (LDR) of a render against its reference: the per-pixel error map and its mean.
#[derive(Debug, Clone, PartialEq)]
pub struct Flip {
    /// Mean of [`Flip::errors`] over every pixel, in `0..=1`; lower is better. Accumulated in
    /// `f64`.
    pub mean: f64,
    /// Width of the error map (that of both images).
    pub width: u32,
    /// Height of the error map.
    pub height: u32,
    /// Per-pixel FLIP error in `0..=1`, row-major, top row first.
    pub errors: Vec<f32>,
}

/// FLIP (LDR) of `render` against `reference`, both encoded to 8-bit sRGB with `exposure` as
/// [`crate::write_png`] would, at [`FLIP_PIXELS_PER_DEGREE`].
///
/// Fails as [`crate::rmse_srgb8`] does: on images of different sizes, inconsistent pixel
/// buffers or no pixels. Non-finite values are mapped by the tonemap, so there is always a
/// result.
pub fn flip_ldr(render: &Image, reference: &Image, exposure: f32) -> Result<Flip, ImageError> {
    check_comparable(render, reference)?;
    let (width, height) = reference.size();
    let encode = |image: &Image| {
        nv_flip::FlipImageRgb8::with_data(width, height, &to_srgb8(image, exposure))
    };
    let map = nv_flip::flip(encode(reference), encode(render), FLIP_PIXELS_PER_DEGREE);
    let errors = map.to_vec();
    let mean = errors.iter().map(|&e| f64::from(e)).sum::<f64>() / errors.len() as f64;
    Ok(Flip {
        mean,
        width,
        height,
        errors,
    })
}

/// The error map of `flip` in FLIP's own magma colour map (black for no error through purple
/// and orange to pale yellow for 1), as NVIDIA's tools draw it: display-referred sRGB values
/// in `0..=1`, to be written with [`crate::write_heatmap_png`].
///
/// Fails with [`ImageError::PixelCount`] when `errors` does not hold `width * height` values
/// (a `Flip` built by hand), and with [`ImageError::Empty`] when it holds none.
pub fn flip_error_map(flip: &Flip) -> Result<Image, ImageError> {
    let (width, height) = (flip.width, flip.height);
    if flip.errors.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(ImageError::PixelCount {
            width,
            height,
            len: flip.errors.len(),
        });
    }
    if flip.errors.is_empty() {
        return Err(ImageError::Empty {
            path: None,
            width,
            height,
        });
    }
    let errors = nv_flip::FlipImageFloat::with_data(width, height, &flip.errors);
    let colours = errors.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let pixels = colours
        .chunks_exact(3)
        .map(|rgb| glam::Vec3::from_array([rgb[0], rgb[1], rgb[2]].map(f32::from)) / 255.0)
        .collect();
    Image::from_pixels(width, height, pixels)
}

/// Computes [`flip_ldr`] of `render` against `reference`, writes its magma error map
/// ([`flip_error_map`]) to `path` as a PNG and returns it.
pub fn write_flip_map(
    render: &Image,
    reference: &Image,
    exposure: f32,
    path: impl AsRef<Path>,
) -> Result<Flip, ImageError> {
    let flip = flip_ldr(render, reference, exposure)?;
    write_heatmap_png(&flip_error_map(&flip)?, path)?;
    Ok(flip)
}

//! Linear HDR images, their file formats, display encoding and error metrics.
//!
//! Every image in the product is an [`Image`]: linear RGB radiance in `f32`,
//! row-major, top row first. This crate defines how such images are
//!
//! - stored: lossless OpenEXR ([`write_exr`], [`read_exr`]) and 8-bit sRGB PNG
//!   ([`write_png`], [`read_png`]), or either by extension ([`save`], [`load`]);
//! - shown: `srgb_oetf(clamp(exposure * L, 0, 1))` quantised to 8 bits with
//!   round-to-nearest ([`to_srgb8`] and the [`tonemap`] module);
//! - measured against a path-traced reference: [`rmse_srgb8`] (in 0..255
//!   display levels), [`flip_ldr`] (mean FLIP, LDR: how visible the difference
//!   is to a person flipping between the two, in 0..1), [`rmse_linear`],
//!   [`rel_mse`] and [`gain_vs_direct`];
//! - inspected: [`error_heatmap`] shows where the sRGB8 error lies, and
//!   [`flip_error_map`] where the visible difference lies.
//!
//! The 8-bit encoding used by PNG output, the sRGB8 metric, FLIP and the heat
//! maps is one and the same, so a number in a benchmark table always describes
//! the pixels a person sees in the written PNG.
//!
//! FLIP is NVIDIA's (Andersson et al. 2020, "FLIP: A Difference Evaluator for
//! Alternating Images", HPG), computed by their C++ implementation in its LDR
//! mode at their default viewing condition of 67 pixels per degree
//! ([`FLIP_PIXELS_PER_DEGREE`]); see [`flip_ldr`].
//!
//! ```
//! use gi_image::{Image, gain_vs_direct, rmse_srgb8};
//! use glam::Vec3;
//!
//! let reference = Image::from_fn(4, 4, |_, _| Vec3::splat(0.5));
//! let direct_only = Image::from_fn(4, 4, |_, _| Vec3::splat(0.25));
//! let tier = Image::from_fn(4, 4, |_, _| Vec3::splat(0.45));
//!
//! let direct = rmse_srgb8(&direct_only, &reference, 1.0)?;
//! let rendered = rmse_srgb8(&tier, &reference, 1.0)?;
//! assert_eq!(direct, 51.0); // codes 137 vs 188
//! assert!(gain_vs_direct(rendered, direct).unwrap() < 0.25);
//! # Ok::<(), gi_image::ImageError>(())
//! ```

#![warn(missing_docs)]

mod error;
mod flip;
mod heatmap;
mod image;
mod io;
mod metrics;
pub mod tonemap;

pub use crate::error::ImageError;
pub use crate::flip::{FLIP_PIXELS_PER_DEGREE, Flip, flip_error_map, flip_ldr, write_flip_map};
pub use crate::heatmap::{
    HEATMAP_FULL_SCALE, HeatmapInfo, error_heatmap, error_heatmap_with_scale, heatmap_ramp,
    pixel_errors_srgb8, write_error_heatmap, write_heatmap_png,
};
pub use crate::image::Image;
pub use crate::io::{FileFormat, load, read_exr, read_png, save, write_exr, write_png};
pub use crate::metrics::{
    Comparison, ErrorSplit, REL_MSE_EPSILON, compare, error_split_srgb8, gain_vs_direct,
    luminance_bias, rel_mse, rmse_linear, rmse_srgb8,
};
pub use crate::tonemap::{srgb_eotf, srgb_oetf, to_srgb8};

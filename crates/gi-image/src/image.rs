use glam::{DVec3, Vec3};

use crate::ImageError;

/// A linear HDR RGB image with `f32` channels.
///
/// Pixels are stored row-major with the top row first, so pixel `(x, y)` lives
/// at `pixels[y * width + x]`. Values are scene-referred radiance: they are not
/// clamped and carry no transfer function.
///
/// The fields are public so renderers can fill `pixels` directly; every
/// function that consumes an image checks that `pixels.len() == width * height`
/// (see [`Image::validate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Number of columns.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
    /// Row-major pixel values, top row first.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// Creates a black image of the given size.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; pixel_count(width, height)],
        }
    }

    /// Creates an image by evaluating `f(x, y)` for every pixel, row by row.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> Vec3) -> Self {
        let mut pixels = Vec::with_capacity(pixel_count(width, height));
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            pixels,
        }
    }

    /// Wraps an existing row-major pixel buffer, checking its length.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Result<Self, ImageError> {
        let image = Self {
            width,
            height,
            pixels,
        };
        image.validate()?;
        Ok(image)
    }

    /// Checks that the pixel buffer matches the declared resolution.
    pub fn validate(&self) -> Result<(), ImageError> {
        if self.pixels.len() == pixel_count(self.width, self.height) {
            Ok(())
        } else {
            Err(ImageError::PixelCount {
                width: self.width,
                height: self.height,
                len: self.pixels.len(),
            })
        }
    }

    /// `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// True when the image has no pixels (zero width or height).
    pub fn is_empty(&self) -> bool {
        self.width == 0 || self.height == 0
    }

    /// The value of pixel `(x, y)`.
    ///
    /// # Panics
    /// When `(x, y)` lies outside the image.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[self.index(x, y)]
    }

    /// Overwrites pixel `(x, y)`.
    ///
    /// # Panics
    /// When `(x, y)` lies outside the image.
    pub fn set(&mut self, x: u32, y: u32, value: Vec3) {
        let i = self.index(x, y);
        self.pixels[i] = value;
    }

    /// Mean pixel value, accumulated in `f64` so large images do not lose
    /// precision. An image without pixels has a mean of zero.
    pub fn mean(&self) -> Vec3 {
        if self.pixels.is_empty() {
            return Vec3::ZERO;
        }
        let sum = self
            .pixels
            .iter()
            .fold(DVec3::ZERO, |acc, p| acc + p.as_dvec3());
        (sum / self.pixels.len() as f64).as_vec3()
    }

    /// True when no channel of any pixel is NaN or infinite.
    pub fn is_finite(&self) -> bool {
        self.pixels.iter().all(|p| p.is_finite())
    }

    /// Multiplies every pixel by `factor`, e.g. to turn a sum of `n`
    /// progressive passes into their average with `scale(1.0 / n as f32)`.
    pub fn scale(&mut self, factor: f32) {
        for p in &mut self.pixels {
            *p *= factor;
        }
    }

    /// Adds `weight * other` to this image, pixel by pixel.
    ///
    /// Progressive renderers call this once per pass and [`Image::scale`] at
    /// the end, or use [`Image::blend_toward`] for a running average.
    pub fn accumulate(&mut self, other: &Image, weight: f32) -> Result<(), ImageError> {
        self.check_same_size(other)?;
        for (dst, src) in self.pixels.iter_mut().zip(&other.pixels) {
            *dst += *src * weight;
        }
        Ok(())
    }

    /// Moves every pixel a fraction `t` of the way toward `other`:
    /// `self = self + (other - self) * t`.
    ///
    /// With `t = 1 / n` for the `n`-th pass (counting from 1) this keeps a
    /// running average that is displayable after every pass.
    pub fn blend_toward(&mut self, other: &Image, t: f32) -> Result<(), ImageError> {
        self.check_same_size(other)?;
        for (dst, src) in self.pixels.iter_mut().zip(&other.pixels) {
            *dst = dst.lerp(*src, t);
        }
        Ok(())
    }

    /// Returns an error unless both images have the same resolution and
    /// consistent pixel buffers.
    pub fn check_same_size(&self, other: &Image) -> Result<(), ImageError> {
        self.validate()?;
        other.validate()?;
        if self.size() == other.size() {
            Ok(())
        } else {
            Err(ImageError::SizeMismatch {
                a: self.size(),
                b: other.size(),
            })
        }
    }

    /// Iterates over `(x, y, value)` for every pixel, row by row.
    pub fn enumerate_pixels(&self) -> impl Iterator<Item = (u32, u32, Vec3)> + '_ {
        // A zero width would make the division below meaningless, but such an
        // image has no pixels, so the closure never runs.
        let width = self.width.max(1) as usize;
        self.pixels
            .iter()
            .enumerate()
            .map(move |(i, p)| ((i % width) as u32, (i / width) as u32, *p))
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{} image",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }
}

fn pixel_count(width: u32, height: u32) -> usize {
    width as usize * height as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_fn_is_row_major_top_row_first() {
        let image = Image::from_fn(3, 2, |x, y| Vec3::new(x as f32, y as f32, 0.0));
        assert_eq!(image.pixels.len(), 6);
        assert_eq!(image.pixels[1], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(image.pixels[3], Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(image.get(2, 1), Vec3::new(2.0, 1.0, 0.0));
    }

    #[test]
    fn set_then_get_and_new_is_black() {
        let mut image = Image::new(4, 3);
        assert!(image.pixels.iter().all(|p| *p == Vec3::ZERO));
        image.set(3, 2, Vec3::ONE);
        assert_eq!(image.get(3, 2), Vec3::ONE);
        assert_eq!(image.pixels[11], Vec3::ONE);
        assert_eq!(image.get(2, 2), Vec3::ZERO);
    }

    #[test]
    #[should_panic(expected = "outside 2x2 image")]
    fn get_out_of_bounds_panics() {
        Image::new(2, 2).get(2, 0);
    }

    #[test]
    fn mean_uses_all_pixels() {
        let image = Image::from_fn(2, 2, |x, y| Vec3::new((x + 2 * y) as f32, 1.0, -1.0));
        assert_eq!(image.mean(), Vec3::new(1.5, 1.0, -1.0));
        assert_eq!(Image::new(0, 5).mean(), Vec3::ZERO);
    }

    #[test]
    fn mean_accumulates_in_f64() {
        // In f32, 2^24 + 1 rounds back to 2^24, so an f32 running sum would
        // drop every one of the 1023 ones and report a mean of exactly 16384.
        let mut image = Image::from_fn(1024, 1, |_, _| Vec3::ONE);
        image.set(0, 0, Vec3::splat(16_777_216.0));
        let expected = ((16_777_216.0f64 + 1023.0) / 1024.0) as f32;
        assert_eq!(image.mean(), Vec3::splat(expected));
        assert_ne!(expected, 16384.0);
    }

    #[test]
    fn is_finite_detects_nan_and_infinity() {
        let mut image = Image::new(2, 1);
        assert!(image.is_finite());
        image.set(1, 0, Vec3::new(0.0, f32::NAN, 0.0));
        assert!(!image.is_finite());
        image.set(1, 0, Vec3::new(f32::INFINITY, 0.0, 0.0));
        assert!(!image.is_finite());
    }

    #[test]
    fn accumulate_and_scale_average_passes() {
        let mut sum = Image::new(2, 2);
        for pass in 1..=4 {
            let sample = Image::from_fn(2, 2, |_, _| Vec3::splat(pass as f32));
            sum.accumulate(&sample, 1.0).unwrap();
        }
        sum.scale(0.25);
        assert!(sum.pixels.iter().all(|p| *p == Vec3::splat(2.5)));

        let mut weighted = Image::new(1, 1);
        weighted
            .accumulate(&Image::from_fn(1, 1, |_, _| Vec3::ONE), 0.5)
            .unwrap();
        assert_eq!(weighted.get(0, 0), Vec3::splat(0.5));
    }

    #[test]
    fn blend_toward_keeps_a_running_average() {
        let mut average = Image::new(1, 1);
        for (n, value) in [2.0f32, 4.0, 9.0].into_iter().enumerate() {
            let pass = Image::from_fn(1, 1, |_, _| Vec3::splat(value));
            average.blend_toward(&pass, 1.0 / (n + 1) as f32).unwrap();
        }
        assert!((average.get(0, 0) - Vec3::splat(5.0)).abs().max_element() < 1e-6);
    }

    #[test]
    fn accumulate_rejects_other_sizes() {
        let mut a = Image::new(2, 3);
        let err = a.accumulate(&Image::new(3, 2), 1.0).unwrap_err();
        assert!(matches!(
            err,
            ImageError::SizeMismatch {
                a: (2, 3),
                b: (3, 2)
            }
        ));
    }

    #[test]
    fn from_pixels_checks_length() {
        assert!(Image::from_pixels(2, 2, vec![Vec3::ZERO; 4]).is_ok());
        let err = Image::from_pixels(2, 2, vec![Vec3::ZERO; 3]).unwrap_err();
        assert!(matches!(
            err,
            ImageError::PixelCount {
                width: 2,
                height: 2,
                len: 3
            }
        ));
    }

    #[test]
    fn enumerate_pixels_yields_coordinates() {
        let image = Image::from_fn(3, 2, |x, y| Vec3::new(x as f32, y as f32, 0.0));
        for (x, y, p) in image.enumerate_pixels() {
            assert_eq!(p, Vec3::new(x as f32, y as f32, 0.0));
        }
        assert_eq!(image.enumerate_pixels().count(), 6);
    }
}

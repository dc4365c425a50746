//! Reading and writing images: OpenEXR for linear HDR data, PNG for display.
//!
//! EXR files hold the exact `f32` values (R, G, B channels, lossless RLE
//! compression), so a reference written and read back is bit-identical. PNG
//! files hold 8-bit sRGB produced by [`crate::to_srgb8`]; reading one decodes it
//! back to linear light.

use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::Path;

use exr::prelude::{ReadChannels, ReadLayers};
use glam::Vec3;
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, ImageReader};

use crate::tonemap::{from_srgb8, srgb_eotf, to_srgb8};
use crate::{Image, ImageError};

/// The file formats [`save`] and [`load`] understand, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// 8-bit sRGB PNG (`.png`): tonemapped, lossy.
    Png,
    /// OpenEXR with `f32` RGB channels (`.exr`): linear, lossless.
    Exr,
}

impl FileFormat {
    /// The format named by the path's extension (case-insensitive), or
    /// [`ImageError::UnsupportedFormat`] for any other or missing extension.
    pub fn from_path(path: &Path) -> Result<Self, ImageError> {
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match extension.as_deref() {
            Some("png") => Ok(Self::Png),
            Some("exr") => Ok(Self::Exr),
            _ => Err(ImageError::UnsupportedFormat {
                path: path.to_path_buf(),
            }),
        }
    }
}

/// Writes `image` to `path` in the format named by its extension.
///
/// `.png` files are tonemapped with `exposure` (see [`write_png`]); `.exr`
/// files store the linear values unchanged and ignore `exposure`.
pub fn save(image: &Image, path: impl AsRef<Path>, exposure: f32) -> Result<(), ImageError> {
    let path = path.as_ref();
    match FileFormat::from_path(path)? {
        FileFormat::Png => write_png(image, path, exposure),
        FileFormat::Exr => write_exr(image, path),
    }
}

/// Reads the image at `path` in the format named by its extension.
///
/// `.png` files are decoded to linear light (see [`read_png`]); `.exr` files
/// are returned as stored.
pub fn load(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    match FileFormat::from_path(path)? {
        FileFormat::Png => read_png(path),
        FileFormat::Exr => read_exr(path),
    }
}

/// Writes the linear values of `image` to an OpenEXR file with `f32` R, G
/// and B channels. Non-finite values are stored as they are.
pub fn write_exr(image: &Image, path: impl AsRef<Path>) -> Result<(), ImageError> {
    let path = path.as_ref();
    check_writable(image, path)?;
    let width = image.width as usize;
    let pixels = &image.pixels;
    exr::prelude::write_rgb_file(path, width, image.height as usize, |x, y| {
        let p = pixels[y * width + x];
        (p.x, p.y, p.z)
    })
    .map_err(|e| exr_error(path, e, Direction::Write))
}

/// Reads the R, G and B channels of the first layer of an OpenEXR file, at
/// full resolution, converting any sample type to `f32`. Other channels
/// (alpha included) are ignored.
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    // Opening the file here, rather than inside the exr crate, keeps "file not
    // found" an I/O error that names the path.
    let file = open(path)?;
    let decoded = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |resolution, _| Image::new(to_u32(resolution.width()), to_u32(resolution.height())),
            |image: &mut Image, position, (r, g, b): (f32, f32, f32)| {
                image.set(
                    to_u32(position.x()),
                    to_u32(position.y()),
                    Vec3::new(r, g, b),
                );
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(BufReader::new(file))
        .map_err(|e| exr_error(path, e, Direction::Read))?;
    Ok(decoded.layer_data.channel_data.pixels)
}

/// Writes `image` as an 8-bit RGB PNG, each channel encoded as
/// `srgb_oetf(clamp(exposure * L, 0, 1))` rounded to nearest.
pub fn write_png(image: &Image, path: impl AsRef<Path>, exposure: f32) -> Result<(), ImageError> {
    let path = path.as_ref();
    check_writable(image, path)?;
    write_rgb8_png(&to_srgb8(image, exposure), image.width, image.height, path)
}

/// Reads a PNG and decodes its sRGB values to linear light with
/// [`crate::srgb_eotf`], so `read_png` after `write_png` returns
/// `clamp(exposure * image, 0, 1)` up to 8-bit quantisation.
///
/// Greyscale PNGs are expanded to RGB, alpha is ignored and 16-bit PNGs are
/// decoded at their full precision.
pub fn read_png(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let file = open(path)?;
    let decoded = ImageReader::with_format(BufReader::new(file), image::ImageFormat::Png)
        .decode()
        .map_err(|e| image_error(path, e, Direction::Read))?;
    let (width, height) = (decoded.width(), decoded.height());
    let color = decoded.color();
    if color.bytes_per_pixel() == color.channel_count() {
        // 8 bits per channel: decode exactly the codes `to_srgb8` produces.
        from_srgb8(width, height, decoded.to_rgb8().as_raw())
    } else {
        let pixels = decoded
            .to_rgb32f()
            .pixels()
            .map(|p| Vec3::from_array(p.0.map(srgb_eotf)))
            .collect();
        Image::from_pixels(width, height, pixels)
    }
}

/// Writes interleaved 8-bit RGB bytes (display-referred, no transfer function
/// applied) to a PNG file.
pub(crate) fn write_rgb8_png(
    bytes: &[u8],
    width: u32,
    height: u32,
    path: &Path,
) -> Result<(), ImageError> {
    let mut writer = BufWriter::new(File::create(path).map_err(|e| io_error(path, e))?);
    PngEncoder::new(&mut writer)
        .write_image(bytes, width, height, ExtendedColorType::Rgb8)
        .map_err(|e| image_error(path, e, Direction::Write))?;
    // Flushing explicitly reports a failed final write instead of losing it
    // in `BufWriter`'s drop.
    writer.flush().map_err(|e| io_error(path, e))
}

/// Rejects images that cannot be stored: inconsistent buffers and images
/// without pixels, which neither PNG nor EXR can represent.
pub(crate) fn check_writable(image: &Image, path: &Path) -> Result<(), ImageError> {
    image.validate()?;
    if image.is_empty() {
        return Err(ImageError::Empty {
            path: Some(path.to_path_buf()),
            width: image.width,
            height: image.height,
        });
    }
    Ok(())
}

fn open(path: &Path) -> Result<File, ImageError> {
    File::open(path).map_err(|e| io_error(path, e))
}

fn io_error(path: &Path, source: std::io::Error) -> ImageError {
    ImageError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Whether a codec failure happened while reading or while writing.
#[derive(Clone, Copy)]
enum Direction {
    Read,
    Write,
}

fn codec_error(path: &Path, message: String, direction: Direction) -> ImageError {
    let path = path.to_path_buf();
    match direction {
        Direction::Read => ImageError::Decode { path, message },
        Direction::Write => ImageError::Encode { path, message },
    }
}

/// Keeps I/O failures as [`ImageError::Io`] and reports everything else as a
/// decode or encode error, depending on the direction.
fn exr_error(path: &Path, error: exr::error::Error, direction: Direction) -> ImageError {
    match error {
        exr::error::Error::Io(source) => io_error(path, source),
        other => codec_error(path, other.to_string(), direction),
    }
}

/// Same as [`exr_error`], for the PNG codec.
fn image_error(path: &Path, error: image::ImageError, direction: Direction) -> ImageError {
    match error {
        image::ImageError::IoError(source) => io_error(path, source),
        other => codec_error(path, other.to_string(), direction),
    }
}

/// EXR resolutions are stored as `i32`, so they always fit.
fn to_u32(value: usize) -> u32 {
    u32::try_from(value).expect("EXR dimensions fit in u32")
}

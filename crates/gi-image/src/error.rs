use std::path::{Path, PathBuf};

/// Everything that can go wrong while reading, writing or comparing images.
///
/// File errors always carry the path they concern so a message printed by a
/// tool is enough to find the offending file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The file could not be opened, read, created or written.
    #[error("{path}: {source}")]
    Io {
        /// The file being read or written.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The file exists but its content is not a valid image of the expected
    /// kind (corrupt data, missing R/G/B channels, ...).
    #[error("{path}: cannot decode image: {message}")]
    Decode {
        /// The file being read.
        path: PathBuf,
        /// What the decoder reported.
        message: String,
    },
    /// The encoder refused the image while writing it.
    #[error("{path}: cannot encode image: {message}")]
    Encode {
        /// The file being written.
        path: PathBuf,
        /// What the encoder reported.
        message: String,
    },
    /// The path's extension names no format this crate handles.
    #[error("{path}: unsupported image format (expected a .png or .exr extension)")]
    UnsupportedFormat {
        /// The path whose extension was not recognised.
        path: PathBuf,
    },
    /// Two images that must have the same resolution do not.
    #[error("image size mismatch: {}x{} vs {}x{}", a.0, a.1, b.0, b.1)]
    SizeMismatch {
        /// Width and height of the first image.
        a: (u32, u32),
        /// Width and height of the second image.
        b: (u32, u32),
    },
    /// The image has no pixels, so it cannot be written or measured.
    #[error("{}image is empty ({width}x{height})", path_prefix(path.as_deref()))]
    Empty {
        /// The file concerned, when the empty image was to be written to one.
        path: Option<PathBuf>,
        /// Width of the empty image.
        width: u32,
        /// Height of the empty image.
        height: u32,
    },
    /// `pixels.len()` does not equal `width * height`.
    #[error("image claims {width}x{height} pixels but holds {len}")]
    PixelCount {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Actual length of the pixel buffer.
        len: usize,
    },
    /// A linear-space metric met a NaN or infinite sample, which would make
    /// the result meaningless.
    #[error("non-finite value {value} in image {image} at pixel ({x}, {y})")]
    NonFinite {
        /// Which input held the value: `"a"` or `"b"` (the reference).
        image: &'static str,
        /// Column of the first non-finite pixel.
        x: u32,
        /// Row of the first non-finite pixel.
        y: u32,
        /// The offending sample.
        value: f32,
    },
}

fn path_prefix(path: Option<&Path>) -> String {
    path.map(|p| format!("{}: ", p.display()))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_path_and_the_problem() {
        let io = ImageError::Io {
            path: PathBuf::from("renders/missing.exr"),
            source: std::io::Error::from(std::io::ErrorKind::NotFound),
        };
        assert!(io.to_string().starts_with("renders/missing.exr: "));

        let empty = ImageError::Empty {
            path: Some(PathBuf::from("out.png")),
            width: 0,
            height: 4,
        };
        assert_eq!(empty.to_string(), "out.png: image is empty (0x4)");

        let empty_no_path = ImageError::Empty {
            path: None,
            width: 3,
            height: 0,
        };
        assert_eq!(empty_no_path.to_string(), "image is empty (3x0)");

        let mismatch = ImageError::SizeMismatch {
            a: (4, 2),
            b: (2, 4),
        };
        assert_eq!(mismatch.to_string(), "image size mismatch: 4x2 vs 2x4");
    }
}

//! Decoding glTF images for material textures: PNG and JPEG through `image`, DDS through
//! [`super::dds`]. With a texel budget, every image's size is read from its header and counted
//! before any image is decoded ([`charge_all`]).
//!
//! An image is decoded once, whatever uses it; [`Decoded::texels`] then gives the 8-bit RGBA a
//! texture role needs. For PNG, JPEG and most DDS formats that is the stored values as they are;
//! two-channel normal maps and HDR images differ per role (see [`Pixels`]).

use std::borrow::Cow;
use std::io::Cursor;

use image::{ImageFormat, ImageReader, Limits};

use super::buffers::fetch_uri;
use super::{Result, Source, dds, malformed, unusable};
use crate::{TextureEncoding, linear_to_srgb};

/// Largest width and height of an image the importer decodes; larger images are refused
/// before decoding, which bounds one image's memory to 256 MiB of RGBA8.
pub(super) const MAX_IMAGE_SIZE: u32 = 8192;

/// The MIME type `MSFT_texture_dds` gives DDS images.
const DDS_MIME: &str = "image/vnd-ms.dds";

/// How a material slot reads its image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Role {
    /// sRGB-encoded color: base color, emissive, specular color.
    Color,
    /// Linear data: metallic-roughness, occlusion, specular weight.
    Data,
    /// A tangent-space normal map: linear data whose blue a two-channel image lacks.
    Normal,
}

impl Role {
    /// The encoding of a texture made for this role.
    pub(super) fn encoding(self) -> TextureEncoding {
        match self {
            Role::Color => TextureEncoding::Srgb,
            Role::Data | Role::Normal => TextureEncoding::Linear,
        }
    }
}

/// Decoded texels, still as stored.
pub(super) enum Pixels {
    /// 8-bit RGBA whose encoding the texture's role gives, as for PNG and JPEG.
    Rgba8(Vec<[u8; 4]>),
    /// Two channels (BC5) in red and green; blue 0 and alpha 1. As a normal map, blue is
    /// rebuilt as the unit vector's z: with x and y mapped from [0, 1] to [-1, 1],
    /// z = sqrt(1 - x^2 - y^2) (0 where x^2 + y^2 > 1), stored as (z + 1) / 2.
    Rg8(Vec<[u8; 4]>),
    /// BC6H blocks: linear values past 8 bits, decoded per role (clamped to [0, 1], then sRGB
    /// or linear 8-bit) rather than stored once in one of the two encodings.
    Bc6h { blocks: Vec<u8>, signed: bool },
}

/// An image decoded for textures.
pub(super) struct Decoded {
    pub(super) name: String,
    pub(super) width: u32,
    pub(super) height: u32,
    pixels: Pixels,
    /// What decoding left out or changed (HDR clamped, slices skipped), for a warning where
    /// the image is used.
    pub(super) notes: Vec<String>,
}

impl Decoded {
    /// The role whose texels `role` gets from this image: roles that give the same texels
    /// share one texture.
    pub(super) fn variant(&self, role: Role) -> Role {
        match (role, &self.pixels) {
            (Role::Normal, Pixels::Rg8(_)) => Role::Normal,
            (Role::Normal, Pixels::Rgba8(_) | Pixels::Bc6h { .. }) => Role::Data,
            (role, _) => role,
        }
    }

    /// The texels of a texture with role `role`, row-major, top row first.
    pub(super) fn texels(&self, role: Role) -> Vec<[u8; 4]> {
        match (&self.pixels, role) {
            (Pixels::Rgba8(texels), _) => texels.clone(),
            (Pixels::Rg8(texels), Role::Normal) => {
                texels.iter().map(|&t| with_normal_z(t)).collect()
            }
            (Pixels::Rg8(texels), _) => texels.clone(),
            (Pixels::Bc6h { blocks, signed }, Role::Color) => {
                dds::decode_bc6h(blocks, self.width, self.height, *signed, linear_to_srgb)
            }
            (Pixels::Bc6h { blocks, signed }, _) => {
                dds::decode_bc6h(blocks, self.width, self.height, *signed, |c| {
                    (c * 255.0).round() as u8
                })
            }
        }
    }
}

/// `texel` (x, y in red and green) with blue set to the unit normal's z.
fn with_normal_z(texel: [u8; 4]) -> [u8; 4] {
    let signed = |c: u8| f32::from(c) / 255.0 * 2.0 - 1.0;
    let (x, y) = (signed(texel[0]), signed(texel[1]));
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    [
        texel[0],
        texel[1],
        ((z + 1.0) * 0.5 * 255.0).round() as u8,
        texel[3],
    ]
}

/// The encodings the importer decodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Png,
    Jpeg,
    Dds,
}

impl Encoding {
    /// The `image` crate's format of PNG and JPEG; `None` for DDS, which [`dds`] reads.
    fn image_format(self) -> Option<ImageFormat> {
        match self {
            Encoding::Png => Some(ImageFormat::Png),
            Encoding::Jpeg => Some(ImageFormat::Jpeg),
            Encoding::Dds => None,
        }
    }
}

impl std::fmt::Display for Encoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Encoding::Png => "PNG",
            Encoding::Jpeg => "JPEG",
            Encoding::Dds => "DDS",
        })
    }
}

/// An image's bytes as the file stores them, not decoded.
struct Encoded<'a> {
    /// The name of the textures made of the image.
    name: String,
    /// `images[i] ("name")`, to start messages with.
    label: String,
    bytes: Cow<'a, [u8]>,
    mime: Option<&'a str>,
}

impl<'a> Encoded<'a> {
    /// Image `index`'s bytes: from a buffer view (of any buffer), a data URI or a file. `Err`
    /// holds why they cannot be read; a broken document (no such image) is an import error.
    fn read(source: &'a Source, index: usize) -> Result<std::result::Result<Self, String>> {
        let image = source
            .root
            .images
            .get(index)
            .ok_or_else(|| malformed(format!("images[{index}] does not exist")))?;
        let name = match (&image.name, &image.uri) {
            (Some(name), _) => name.clone(),
            (None, Some(uri)) if !uri.starts_with("data:") => uri.clone(),
            _ => format!("image {index}"),
        };
        let label = format!("images[{index}] (\"{name}\")");
        let bytes: Cow<[u8]> = match (&image.buffer_view, &image.uri) {
            (Some(view), _) => match source.buffers.view(view.value()) {
                Ok(bytes) => Cow::Borrowed(bytes),
                Err(_) => return Ok(Err(format!("{label}: its buffer view is unreadable"))),
            },
            (None, Some(uri)) => match fetch_uri(uri, source.dir) {
                Ok(bytes) => Cow::Owned(bytes),
                Err(e) => return Ok(Err(format!("{label} cannot be read: {e}"))),
            },
            (None, None) => return Ok(Err(format!("{label} has neither uri nor bufferView"))),
        };
        Ok(Ok(Self {
            name,
            label,
            bytes,
            mime: image.mime_type.as_ref().map(|m| m.0.as_str()),
        }))
    }

    /// The encoding the image is read as: its MIME type's, else the one its first bytes show.
    fn encoding(&self) -> std::result::Result<Encoding, String> {
        let label = &self.label;
        match self.mime {
            Some(DDS_MIME) => Ok(Encoding::Dds),
            Some("image/png") => Ok(Encoding::Png),
            Some("image/jpeg") => Ok(Encoding::Jpeg),
            Some(other) => Err(format!(
                "{label} has mime type {other}; only image/png, image/jpeg and {DDS_MIME} are read"
            )),
            None if dds::is_dds(&self.bytes) => Ok(Encoding::Dds),
            None => match image::guess_format(&self.bytes) {
                Ok(ImageFormat::Png) => Ok(Encoding::Png),
                Ok(ImageFormat::Jpeg) => Ok(Encoding::Jpeg),
                _ => Err(format!("{label} is neither PNG, JPEG nor DDS")),
            },
        }
    }

    /// A reader of the image as `format`.
    fn reader(&self, format: ImageFormat) -> ImageReader<Cursor<&[u8]>> {
        let mut reader = ImageReader::new(Cursor::new(&self.bytes[..]));
        reader.set_format(format);
        reader
    }

    /// Width and height from the image's header, without decoding its texels.
    fn size(&self, encoding: Encoding) -> std::result::Result<(u32, u32), String> {
        let label = &self.label;
        match encoding.image_format() {
            None => dds::size(&self.bytes).map_err(|why| format!("{label} {why}")),
            Some(format) => self
                .reader(format)
                .into_dimensions()
                .map_err(|e| format!("{label} has no readable {encoding} header ({e})")),
        }
    }
}

/// With a texel budget ([`super::ImportOptions::max_texels`]), counts every image of the file
/// from its header, before any is decoded: an image that cannot be read, is not PNG, JPEG or
/// DDS, or brings the count past the budget fails the import. Without one, does nothing.
pub(super) fn charge_all(source: &Source) -> Result<()> {
    let Some(budget) = &source.texel_budget else {
        return Ok(());
    };
    for index in 0..source.root.images.len() {
        let header = Encoded::read(source, index)?.and_then(|image| {
            let encoding = image.encoding()?;
            let (width, height) = image.size(encoding)?;
            Ok((image.label, encoding, width, height))
        });
        let (label, encoding, width, height) = header.map_err(|why| {
            unusable(format!(
                "{why}; with a texel budget, every image must be a PNG, JPEG or DDS file whose \
                 header gives its size"
            ))
        })?;
        budget.charge(width, height, || {
            format!("{label} ({width} x {height} texels, {encoding})")
        })?;
    }
    Ok(())
}

/// Decodes image `index` (PNG, JPEG or DDS, from a buffer view, a data URI or a file) to RGBA.
/// `Err` holds a description of why the image cannot be used (missing file, unsupported type,
/// undecodable, truncated or too large data), for the warning of each slot that uses it; a
/// broken document (no such image) is an import error.
pub(super) fn decode(
    source: &Source,
    index: usize,
) -> Result<std::result::Result<Decoded, String>> {
    let image = match Encoded::read(source, index)? {
        Ok(image) => image,
        Err(why) => return Ok(Err(why)),
    };
    let label = &image.label;
    let encoding = match image.encoding() {
        Ok(encoding) => encoding,
        Err(why) => return Ok(Err(why)),
    };
    let Some(format) = encoding.image_format() else {
        return Ok(match dds::decode(&image.bytes) {
            Ok(dds) => Ok(Decoded {
                name: image.name,
                width: dds.width,
                height: dds.height,
                pixels: dds.pixels,
                notes: dds.notes,
            }),
            Err(why) => Err(format!("{label} {why}")),
        });
    };

    let mut reader = image.reader(format);
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIZE);
    limits.max_image_height = Some(MAX_IMAGE_SIZE);
    reader.limits(limits);
    let decoded = match reader.decode() {
        Ok(decoded) => decoded,
        Err(image::ImageError::Limits(_)) => {
            return Ok(Err(format!(
                "{label} is larger than {MAX_IMAGE_SIZE} x {MAX_IMAGE_SIZE} texels and is not decoded"
            )));
        }
        Err(e) => return Ok(Err(format!("{label} cannot be decoded: {e}"))),
    };
    let (width, height) = (decoded.width(), decoded.height());
    if width == 0 || height == 0 {
        return Ok(Err(format!("{label} is empty")));
    }
    let texels = decoded.into_rgba8().pixels().map(|p| p.0).collect();
    Ok(Ok(Decoded {
        name: image.name,
        width,
        height,
        pixels: Pixels::Rgba8(texels),
        notes: Vec::new(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_z_completes_a_unit_vector() {
        // x = 1, y = 0: z = 0, stored as 0.5.
        assert_eq!(with_normal_z([255, 128, 0, 255])[2], 128);
        // x = y = 0 (128 is 0.0039): z = 1.
        assert_eq!(with_normal_z([128, 128, 0, 255])[2], 255);
        // Outside the unit disc: z = 0.
        assert_eq!(with_normal_z([255, 255, 0, 255])[2], 128);
    }
}

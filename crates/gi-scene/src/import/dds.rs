//! DDS images, the sources `MSFT_texture_dds` adds to textures: the first 2D surface at full
//! resolution, decoded to 8-bit RGBA.
//!
//! Formats read:
//! - block-compressed BC1 to BC7: from DX10 headers (UNORM, `_SRGB` and TYPELESS; SNORM for BC4
//!   and BC5; UF16 and SF16 for BC6H) and from legacy FourCC codes (`DXT1` to `DXT5`, `ATI1`,
//!   `ATI2`, `BC4U`, `BC4S`, `BC5S`);
//! - uncompressed R8G8B8A8, B8G8R8A8 and B8G8R8X8 (UNORM, `_SRGB` and TYPELESS) from DX10
//!   headers, and legacy headers whose RGB, luminance and alpha masks describe 8-, 16-, 24- or
//!   32-bit texels (A8R8G8B8, A8B8G8R8, X8R8G8B8, R8G8B8, R5G6B5, A4R4G4B4, L8, A8L8, A8...).
//!
//! Like a PNG's, the stored 8-bit values are kept as they are and the texture's role in the
//! material gives their encoding (base color and emissive sRGB, the other maps linear); a DXGI
//! `_SRGB` suffix is not consulted, as glTF fixes the encoding per role. Where a format does not
//! map to 8-bit RGBA directly:
//! - BC4 (one channel) decodes to grey, alpha 1; BC5 (two channels) to red and green, blue 0,
//!   alpha 1, and a normal map rebuilds its blue (see [`Pixels::Rg8`]);
//! - SNORM values v in [-1, 1] (BC4, BC5) are stored as (v + 1) / 2, the unsigned encoding of
//!   glTF normal maps;
//! - BC6H holds linear HDR values: they are clamped to [0, 1] and quantized for the role, with a
//!   note (the blocks are kept, see [`Pixels::Bc6h`]);
//! - cube maps, arrays and volume textures give their first face, layer or depth slice, with a
//!   note.
//!
//! Mip levels after the first are not read: the GPU tiers build their own mip chains. Every size
//! is checked against [`MAX_IMAGE_SIZE`] and the file's length before anything is allocated, so a
//! header that claims a huge image costs nothing.

use ddsfile::{
    Caps2, D3D10ResourceDimension, DxgiFormat, FourCC, Header, Header10, MiscFlag, PixelFormatFlags,
};

use super::images::{MAX_IMAGE_SIZE, Pixels};

/// A DDS file's first surface, decoded.
pub(super) struct DdsImage {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) pixels: Pixels,
    /// What decoding left out or changed (HDR clamped, slices skipped), for a warning.
    pub(super) notes: Vec<String>,
}

/// True when `bytes` start with the DDS magic number.
pub(super) fn is_dds(bytes: &[u8]) -> bool {
    bytes.starts_with(b"DDS ")
}

/// Width and height of DDS file `bytes`'s first surface, from its header alone. `Err` says
/// why the header cannot be read, as [`decode`]'s does.
pub(super) fn size(bytes: &[u8]) -> Result<(u32, u32), String> {
    read_header(bytes).map(|(header, _)| (header.width, header.height))
}

/// The header of DDS file `bytes` and what follows it.
fn read_header(bytes: &[u8]) -> Result<(Header, &[u8]), String> {
    if !is_dds(bytes) {
        return Err("is not a DDS file (it does not start with \"DDS \")".into());
    }
    let mut rest = &bytes[4..];
    let header = Header::read(&mut rest).map_err(|e| format!("has an unreadable header ({e})"))?;
    Ok((header, rest))
}

/// Decodes the first surface of DDS file `bytes`. `Err` says why it cannot be used (not DDS,
/// truncated, an unsupported format, too large), to follow the image's label in a warning.
pub(super) fn decode(bytes: &[u8]) -> Result<DdsImage, String> {
    let (header, mut rest) = read_header(bytes)?;
    let header10 = if header.spf.fourcc == Some(FourCC(FourCC::DX10)) {
        Some(
            Header10::read(&mut rest)
                .map_err(|e| format!("has an unreadable DX10 header ({e})"))?,
        )
    } else {
        None
    };
    let data = rest;

    let (width, height) = (header.width, header.height);
    if width == 0 || height == 0 {
        return Err(format!("is empty ({width} x {height} texels)"));
    }
    if width > MAX_IMAGE_SIZE || height > MAX_IMAGE_SIZE {
        return Err(format!(
            "is larger than {MAX_IMAGE_SIZE} x {MAX_IMAGE_SIZE} texels ({width} x {height}) and is not decoded"
        ));
    }
    let mut notes = first_slice_notes(&header, header10.as_ref())?;
    let format = match &header10 {
        Some(h10) => dxgi_format(h10.dxgi_format).ok_or_else(|| {
            format!(
                "has format {:?}, which is not read (BC1-BC7, R8G8B8A8 and B8G8R8A8/X8 are)",
                h10.dxgi_format
            )
        })?,
        None => legacy_format(&header, bytes, &mut notes)?,
    };

    // At most 8192 * 8192 * 16 bytes: no overflow in u64.
    let (w, h) = (u64::from(width), u64::from(height));
    let needed = match format.block_bytes() {
        Some(block) => w.div_ceil(4) * h.div_ceil(4) * block,
        None => w * h * format.texel_bytes(),
    };
    if (data.len() as u64) < needed {
        return Err(format!(
            "is truncated: its first {width} x {height} surface needs {needed} bytes, the file holds {}",
            data.len()
        ));
    }
    let data = &data[..needed as usize];

    let pixels = match format {
        Format::Bc1 => Pixels::Rgba8(decode_blocks(data, width, height, 8, |b| {
            let mut rgba = [0; 64];
            bcdec_rs::bc1(b, &mut rgba, 16);
            rgba_block(&rgba)
        })),
        Format::Bc2 => Pixels::Rgba8(decode_blocks(data, width, height, 16, |b| {
            let mut rgba = [0; 64];
            bcdec_rs::bc2(b, &mut rgba, 16);
            rgba_block(&rgba)
        })),
        Format::Bc3 => Pixels::Rgba8(decode_blocks(data, width, height, 16, |b| {
            let mut rgba = [0; 64];
            bcdec_rs::bc3(b, &mut rgba, 16);
            rgba_block(&rgba)
        })),
        Format::Bc7 => Pixels::Rgba8(decode_blocks(data, width, height, 16, |b| {
            let mut rgba = [0; 64];
            bcdec_rs::bc7(b, &mut rgba, 16);
            rgba_block(&rgba)
        })),
        Format::Bc4 { signed: false } => {
            Pixels::Rgba8(decode_blocks(data, width, height, 8, |b| {
                let mut red = [0; 16];
                bcdec_rs::bc4(b, &mut red, 4, false);
                std::array::from_fn(|i| [red[i], red[i], red[i], 255])
            }))
        }
        Format::Bc4 { signed: true } => Pixels::Rgba8(decode_blocks(data, width, height, 8, |b| {
            let mut red = [0.0; 16];
            bcdec_rs::bc4_float(b, &mut red, 4, true);
            std::array::from_fn(|i| {
                let v = snorm_to_unorm8(red[i]);
                [v, v, v, 255]
            })
        })),
        Format::Bc5 { signed: false } => Pixels::Rg8(decode_blocks(data, width, height, 16, |b| {
            let mut rg = [0; 32];
            bcdec_rs::bc5(b, &mut rg, 8, false);
            std::array::from_fn(|i| [rg[2 * i], rg[2 * i + 1], 0, 255])
        })),
        Format::Bc5 { signed: true } => Pixels::Rg8(decode_blocks(data, width, height, 16, |b| {
            let mut rg = [0.0; 32];
            bcdec_rs::bc5_float(b, &mut rg, 8, true);
            std::array::from_fn(|i| {
                [
                    snorm_to_unorm8(rg[2 * i]),
                    snorm_to_unorm8(rg[2 * i + 1]),
                    0,
                    255,
                ]
            })
        })),
        Format::Bc6h { signed } => {
            notes
                .push("holds HDR (BC6H) values, which are clamped to [0, 1] in 8 bits".to_string());
            Pixels::Bc6h {
                blocks: data.to_vec(),
                signed,
            }
        }
        Format::Rgba8 => Pixels::Rgba8(
            data.chunks_exact(4)
                .map(|t| [t[0], t[1], t[2], t[3]])
                .collect(),
        ),
        Format::Bgra8 => Pixels::Rgba8(
            data.chunks_exact(4)
                .map(|t| [t[2], t[1], t[0], t[3]])
                .collect(),
        ),
        Format::Bgrx8 => Pixels::Rgba8(
            data.chunks_exact(4)
                .map(|t| [t[2], t[1], t[0], 255])
                .collect(),
        ),
        Format::Masked {
            bytes,
            masks,
            luminance,
        } => Pixels::Rgba8(
            data.chunks_exact(bytes as usize)
                .map(|t| masked_texel(t, masks, luminance))
                .collect(),
        ),
    };
    Ok(DdsImage {
        width,
        height,
        pixels,
        notes,
    })
}

/// Decodes BC6H `blocks` of a `width` x `height` image, clamping the linear values to [0, 1]
/// and storing each through `quantize` (sRGB or linear 8-bit, as the texture's role asks).
pub(super) fn decode_bc6h(
    blocks: &[u8],
    width: u32,
    height: u32,
    signed: bool,
    quantize: impl Fn(f32) -> u8,
) -> Vec<[u8; 4]> {
    decode_blocks(blocks, width, height, 16, |b| {
        let mut rgb = [0.0; 48];
        bcdec_rs::bc6h_float(b, &mut rgb, 12, signed);
        std::array::from_fn(|i| {
            let c = |k: usize| quantize(rgb[3 * i + k].clamp(0.0, 1.0));
            [c(0), c(1), c(2), 255]
        })
    })
}

/// The texel format of a DDS surface.
#[derive(Clone, Copy, Debug)]
enum Format {
    Bc1,
    Bc2,
    Bc3,
    Bc4 {
        signed: bool,
    },
    Bc5 {
        signed: bool,
    },
    Bc6h {
        signed: bool,
    },
    Bc7,
    Rgba8,
    Bgra8,
    Bgrx8,
    /// A legacy texel of `bytes` bytes whose channels are picked by `masks` (red, green, blue,
    /// alpha; a zero mask is a missing channel). With `luminance` the red mask is grey.
    Masked {
        bytes: u64,
        masks: [u32; 4],
        luminance: bool,
    },
}

impl Format {
    /// Bytes per 4 x 4 block of a block-compressed format; `None` for the others.
    fn block_bytes(self) -> Option<u64> {
        match self {
            Format::Bc1 | Format::Bc4 { .. } => Some(8),
            Format::Bc2 | Format::Bc3 | Format::Bc5 { .. } | Format::Bc6h { .. } | Format::Bc7 => {
                Some(16)
            }
            _ => None,
        }
    }

    /// Bytes per texel of an uncompressed format.
    fn texel_bytes(self) -> u64 {
        match self {
            Format::Masked { bytes, .. } => bytes,
            _ => 4,
        }
    }
}

/// The format of a DX10 header, or `None` when it is not read.
fn dxgi_format(format: DxgiFormat) -> Option<Format> {
    use DxgiFormat as D;
    Some(match format {
        D::BC1_Typeless | D::BC1_UNorm | D::BC1_UNorm_sRGB => Format::Bc1,
        D::BC2_Typeless | D::BC2_UNorm | D::BC2_UNorm_sRGB => Format::Bc2,
        D::BC3_Typeless | D::BC3_UNorm | D::BC3_UNorm_sRGB => Format::Bc3,
        D::BC4_Typeless | D::BC4_UNorm => Format::Bc4 { signed: false },
        D::BC4_SNorm => Format::Bc4 { signed: true },
        D::BC5_Typeless | D::BC5_UNorm => Format::Bc5 { signed: false },
        D::BC5_SNorm => Format::Bc5 { signed: true },
        D::BC6H_Typeless | D::BC6H_UF16 => Format::Bc6h { signed: false },
        D::BC6H_SF16 => Format::Bc6h { signed: true },
        D::BC7_Typeless | D::BC7_UNorm | D::BC7_UNorm_sRGB => Format::Bc7,
        D::R8G8B8A8_Typeless | D::R8G8B8A8_UNorm | D::R8G8B8A8_UNorm_sRGB => Format::Rgba8,
        D::B8G8R8A8_Typeless | D::B8G8R8A8_UNorm | D::B8G8R8A8_UNorm_sRGB => Format::Bgra8,
        D::B8G8R8X8_Typeless | D::B8G8R8X8_UNorm | D::B8G8R8X8_UNorm_sRGB => Format::Bgrx8,
        _ => return None,
    })
}

/// The format of a legacy (pre-DX10) header: a FourCC code or channel masks. `bytes` is the
/// whole file: ddsfile keeps the masks only for RGB formats, so they are read from it.
fn legacy_format(header: &Header, bytes: &[u8], notes: &mut Vec<String>) -> Result<Format, String> {
    let pixel_format = &header.spf;
    if let Some(FourCC(code)) = pixel_format.fourcc {
        if matches!(code, FourCC::DXT2 | FourCC::DXT4) {
            notes.push("holds colors premultiplied by alpha (DXT2/DXT4), read as stored".into());
        }
        return match code {
            FourCC::DXT1 => Ok(Format::Bc1),
            FourCC::DXT2 | FourCC::DXT3 => Ok(Format::Bc2),
            FourCC::DXT4 | FourCC::DXT5 => Ok(Format::Bc3),
            FourCC::ATI1 | FourCC::BC4_UNORM => Ok(Format::Bc4 { signed: false }),
            FourCC::BC4_SNORM => Ok(Format::Bc4 { signed: true }),
            FourCC::ATI2 => Ok(Format::Bc5 { signed: false }),
            FourCC::BC5_SNORM => Ok(Format::Bc5 { signed: true }),
            other => Err(format!(
                "has FourCC format {}, which is not read",
                fourcc_text(other)
            )),
        };
    }
    let flags = pixel_format.flags;
    let rgb = flags.contains(PixelFormatFlags::RGB);
    let luminance = flags.contains(PixelFormatFlags::LUMINANCE);
    let alpha = flags.intersects(PixelFormatFlags::ALPHA | PixelFormatFlags::ALPHA_PIXELS);
    // The pixel format starts at byte 76: size, flags, FourCC, bit count, then the four masks.
    let field = |offset: usize| {
        bytes
            .get(offset..offset + 4)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let bits = field(88);
    if !(rgb || luminance || alpha) {
        return Err("has a pixel format that is neither a FourCC code nor channel masks".into());
    }
    if !matches!(bits, 8 | 16 | 24 | 32) {
        return Err(format!(
            "has {bits}-bit texels; masked texels of 8, 16, 24 or 32 bits are read"
        ));
    }
    let mask = |offset: usize, used: bool| if used { field(offset) } else { 0 };
    let masks = [
        mask(92, rgb || luminance),
        mask(96, rgb),
        mask(100, rgb),
        mask(104, alpha),
    ];
    if masks == [0; 4] {
        return Err("has channel masks that select no bits".into());
    }
    Ok(Format::Masked {
        bytes: u64::from(bits / 8),
        masks,
        luminance: luminance && !rgb,
    })
}

/// Notes for a file holding more than one 2D surface at full resolution (cube faces, array
/// layers, depth slices), whose first surface is read; `Err` for a resource that is not a
/// texture.
fn first_slice_notes(header: &Header, header10: Option<&Header10>) -> Result<Vec<String>, String> {
    let mut notes = Vec::new();
    let mut volume = header.caps2.contains(Caps2::VOLUME);
    let mut cube = header.caps2.contains(Caps2::CUBEMAP);
    if let Some(h10) = header10 {
        match h10.resource_dimension {
            D3D10ResourceDimension::Texture1D | D3D10ResourceDimension::Texture2D => {}
            D3D10ResourceDimension::Texture3D => volume = true,
            other => return Err(format!("is a {other:?} resource, not a texture")),
        }
        cube |= h10.misc_flag.contains(MiscFlag::TEXTURECUBE);
        match h10.array_size {
            0 => return Err("declares an array of 0 textures".into()),
            1 => {}
            n => notes.push(format!(
                "is an array of {n} textures; only the first is read"
            )),
        }
    }
    if cube {
        notes.push("is a cube map; only its first face (+X) is read".into());
    }
    let depth = header.depth.unwrap_or(1);
    if volume && depth > 1 {
        notes.push(format!(
            "is a volume texture of {depth} slices; only the first is read"
        ));
    }
    Ok(notes)
}

/// Decodes the 4 x 4 blocks of `block_bytes` bytes each in `data` (row-major, with enough
/// blocks for the image) into `width` x `height` texels, dropping the parts of edge blocks past
/// the image.
fn decode_blocks(
    data: &[u8],
    width: u32,
    height: u32,
    block_bytes: usize,
    decode_block: impl Fn(&[u8]) -> [[u8; 4]; 16],
) -> Vec<[u8; 4]> {
    let (width, height) = (width as usize, height as usize);
    let blocks_x = width.div_ceil(4);
    let mut texels = vec![[0; 4]; width * height];
    let blocks = data
        .chunks_exact(block_bytes)
        .take(blocks_x * height.div_ceil(4));
    for (i, block) in blocks.enumerate() {
        let (x0, y0) = (i % blocks_x * 4, i / blocks_x * 4);
        let decoded = decode_block(block);
        for y in 0..4.min(height - y0) {
            for x in 0..4.min(width - x0) {
                texels[(y0 + y) * width + x0 + x] = decoded[y * 4 + x];
            }
        }
    }
    texels
}

/// The 16 texels of a block decoded to RGBA8 rows of 16 bytes.
fn rgba_block(rgba: &[u8; 64]) -> [[u8; 4]; 16] {
    std::array::from_fn(|i| {
        [
            rgba[4 * i],
            rgba[4 * i + 1],
            rgba[4 * i + 2],
            rgba[4 * i + 3],
        ]
    })
}

/// A signed normalized value in [-1, 1] stored unsigned as (v + 1) / 2.
fn snorm_to_unorm8(v: f32) -> u8 {
    ((v.clamp(-1.0, 1.0) + 1.0) * 0.5 * 255.0).round() as u8
}

/// One legacy masked texel (little-endian) to RGBA8: each channel's bits scaled to 8 bits; a
/// missing color channel is 0 and a missing alpha 255.
fn masked_texel(bytes: &[u8], masks: [u32; 4], luminance: bool) -> [u8; 4] {
    let value = bytes
        .iter()
        .rev()
        .fold(0u32, |v, &b| (v << 8) | u32::from(b));
    let channel = |mask: u32, missing: u8| {
        if mask == 0 {
            return missing;
        }
        let shift = mask.trailing_zeros();
        let max = u64::from(mask >> shift);
        let bits = u64::from((value & mask) >> shift);
        ((bits * 255 + max / 2) / max) as u8
    };
    let red = channel(masks[0], 0);
    let alpha = channel(masks[3], 255);
    if luminance {
        [red, red, red, alpha]
    } else {
        [red, channel(masks[1], 0), channel(masks[2], 0), alpha]
    }
}

/// A FourCC code as its four characters when they are printable, else as a number.
fn fourcc_text(code: u32) -> String {
    let bytes = code.to_le_bytes();
    if bytes.iter().all(|b| b.is_ascii_graphic() || *b == b' ') {
        format!("\"{}\"", String::from_utf8_lossy(&bytes))
    } else {
        code.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DX10 DDS file of `width` x `height` texels in `format` followed by `data`.
    fn dx10(width: u32, height: u32, format: DxgiFormat, data: &[u8]) -> Vec<u8> {
        let mut bytes = b"DDS ".to_vec();
        let mut header = [0u32; 31];
        header[0] = 124;
        header[1] = 0x1 | 0x2 | 0x4 | 0x1000;
        header[2] = height;
        header[3] = width;
        header[18] = 32;
        header[19] = 0x4;
        header[20] = FourCC::DX10;
        header[26] = 0x1000;
        for word in header {
            bytes.extend_from_slice(&word.to_le_bytes());
        }
        for word in [format as u32, 3, 0, 1, 0] {
            bytes.extend_from_slice(&word.to_le_bytes());
        }
        bytes.extend_from_slice(data);
        bytes
    }

    #[test]
    fn arbitrary_blocks_of_every_format_decode_without_panicking() {
        let formats = [
            DxgiFormat::BC1_UNorm,
            DxgiFormat::BC2_UNorm,
            DxgiFormat::BC3_UNorm,
            DxgiFormat::BC4_UNorm,
            DxgiFormat::BC4_SNorm,
            DxgiFormat::BC5_UNorm,
            DxgiFormat::BC5_SNorm,
            DxgiFormat::BC6H_UF16,
            DxgiFormat::BC6H_SF16,
            DxgiFormat::BC7_UNorm,
        ];
        // A xorshift stream: every BC6H and BC7 mode and partition shows up among 4096 blocks.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let data: Vec<u8> = (0..4096 * 16)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state as u8
            })
            .collect();
        for format in formats {
            let image = decode(&dx10(256, 256, format, &data)).unwrap();
            let texels = match image.pixels {
                Pixels::Rgba8(t) | Pixels::Rg8(t) => t,
                Pixels::Bc6h { blocks, signed } => decode_bc6h(&blocks, 256, 256, signed, |c| {
                    assert!((0.0..=1.0).contains(&c), "{c}");
                    (c * 255.0) as u8
                }),
            };
            assert_eq!(texels.len(), 256 * 256, "{format:?}");
        }
    }

    #[test]
    fn masked_texels_scale_each_channel_to_8_bits() {
        // R5G6B5: full red, green 31 of 63 (31 * 255 / 63 = 125.48), no blue.
        let texel = (31u16 << 11 | 31 << 5).to_le_bytes();
        assert_eq!(
            masked_texel(&texel, [0xf800, 0x07e0, 0x001f, 0], false),
            [255, 125, 0, 255]
        );
        // A8L8: luminance 0x40, alpha 0x80.
        assert_eq!(
            masked_texel(&[0x40, 0x80], [0xff, 0, 0, 0xff00], true),
            [0x40, 0x40, 0x40, 0x80]
        );
    }
}

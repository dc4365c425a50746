//! DDS texture sources (`MSFT_texture_dds`) and `AMD_split_roughnessMetallic`: DDS files built
//! here block by block, whose decoded texels are known from the formats' definitions, imported
//! through glTF files written beside them.

mod peak_alloc;

use gi_scene::{ImportWarning, Scene, Texture, TextureEncoding, import_gltf, linear_to_srgb};
use serde_json::{Value, json};

// DXGI format codes.
const BC3_UNORM_SRGB: u32 = 78;
const BC4_UNORM: u32 = 80;
const BC5_UNORM: u32 = 83;
const BC6H_UF16: u32 = 95;
const BC7_UNORM: u32 = 98;
const R8G8B8A8_UNORM: u32 = 28;
const R16G16B16A16_FLOAT: u32 = 10;

/// The 124-byte DDS header after the magic: `width` x `height`, pixel format flags `pf_flags`,
/// FourCC `fourcc`, then bit count and masks.
fn header(width: u32, height: u32, pf_flags: u32, fourcc: u32, masks: [u32; 5]) -> Vec<u8> {
    let mut words = [0u32; 31];
    words[0] = 124;
    words[1] = 0x1 | 0x2 | 0x4 | 0x1000;
    words[2] = height;
    words[3] = width;
    words[18] = 32;
    words[19] = pf_flags;
    words[20] = fourcc;
    words[21..26].copy_from_slice(&masks);
    words[26] = 0x1000;
    let mut bytes = b"DDS ".to_vec();
    for word in words {
        bytes.extend_from_slice(&word.to_le_bytes());
    }
    bytes
}

fn fourcc(code: &[u8; 4]) -> u32 {
    u32::from_le_bytes(*code)
}

/// A DDS file with a DX10 header: DXGI format `format`, `misc_flag` (4: cube map), then `data`.
fn dds_dx10(width: u32, height: u32, format: u32, misc_flag: u32, data: &[u8]) -> Vec<u8> {
    let mut bytes = header(width, height, 0x4, fourcc(b"DX10"), [0; 5]);
    for word in [format, 3, misc_flag, 1, 0] {
        bytes.extend_from_slice(&word.to_le_bytes());
    }
    bytes.extend_from_slice(data);
    bytes
}

/// A legacy DDS file whose format is FourCC `code`.
fn dds_fourcc(width: u32, height: u32, code: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut bytes = header(width, height, 0x4, fourcc(code), [0; 5]);
    bytes.extend_from_slice(data);
    bytes
}

/// A BC1 block: 565 endpoints `c0`, `c1` and the 2-bit index of each texel, row-major.
fn bc1_block(c0: u16, c1: u16, indices: [u32; 16]) -> [u8; 8] {
    let bits = indices
        .iter()
        .enumerate()
        .fold(0u32, |bits, (i, &index)| bits | index << (2 * i));
    let mut block = [0; 8];
    block[0..2].copy_from_slice(&c0.to_le_bytes());
    block[2..4].copy_from_slice(&c1.to_le_bytes());
    block[4..8].copy_from_slice(&bits.to_le_bytes());
    block
}

/// A BC4 block (also BC3's alpha and each BC5 channel): endpoints and 3-bit indices.
fn bc4_block(e0: u8, e1: u8, indices: [u64; 16]) -> [u8; 8] {
    let bits = indices
        .iter()
        .enumerate()
        .fold(0u64, |bits, (i, &index)| bits | index << (3 * i));
    let mut block = [0; 8];
    block[0] = e0;
    block[1] = e1;
    block[2..8].copy_from_slice(&bits.to_le_bytes()[..6]);
    block
}

/// Writes bit fields least significant first, as BC6H and BC7 blocks are laid out.
#[derive(Default)]
struct Bits {
    value: u128,
    len: u32,
}

impl Bits {
    fn push(&mut self, value: u32, bits: u32) {
        assert!(u64::from(value) < 1 << bits);
        self.value |= u128::from(value) << self.len;
        self.len += bits;
    }

    fn block(self) -> [u8; 16] {
        assert_eq!(self.len, 128);
        self.value.to_le_bytes()
    }
}

/// A BC7 mode 6 block: 7-bit RGBA endpoints with one p-bit each (8-bit endpoint =
/// value << 1 | p) and 4-bit indices (the first 3-bit).
fn bc7_mode6(e0: [u32; 4], p0: u32, e1: [u32; 4], p1: u32, indices: [u32; 16]) -> [u8; 16] {
    let mut bits = Bits::default();
    bits.push(1 << 6, 7);
    for c in 0..4 {
        bits.push(e0[c], 7);
        bits.push(e1[c], 7);
    }
    bits.push(p0, 1);
    bits.push(p1, 1);
    bits.push(indices[0], 3);
    for &index in &indices[1..] {
        bits.push(index, 4);
    }
    bits.block()
}

/// A one-triangle scene whose materials, textures and images are `extra`, written with
/// `files` into a new folder and imported.
fn import_files(extra: Value, files: &[(&str, &[u8])]) -> (Scene, Vec<ImportWarning>) {
    let dir = tempfile::tempdir().unwrap();
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0];
    let uvs: [f32; 6] = [0.0, 0.0, 0.0, 1.0, 1.0, 0.0];
    let bin: Vec<u8> = positions
        .iter()
        .chain(&uvs)
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(dir.path().join("mesh.bin"), &bin).unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let materials = extra["materials"].as_array().map_or(1, Vec::len);
    let primitives: Vec<Value> = (0..materials)
        .map(|m| json!({ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "material": m }))
        .collect();
    let mut doc = json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["MSFT_texture_dds"],
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": primitives }],
        "buffers": [{ "uri": "mesh.bin", "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 36 },
            { "buffer": 0, "byteOffset": 36, "byteLength": 24 }
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2" }
        ]
    });
    for (key, value) in extra.as_object().unwrap() {
        doc[key] = value.clone();
    }
    let path = dir.path().join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    import_gltf(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A scene whose one material uses texture 0, which has only the DDS source `dds`, in `slot`.
fn import_dds_only(slot: &str, dds: &[u8]) -> (Scene, Vec<ImportWarning>) {
    import_files(
        json!({
            "materials": [material_with(slot, 0)],
            "textures": [{ "extensions": { "MSFT_texture_dds": { "source": 0 } } }],
            "images": [{ "uri": "texture.dds", "mimeType": "image/vnd-ms.dds" }]
        }),
        &[("texture.dds", dds)],
    )
}

/// A material whose `slot` (a glTF material property, `pbr.` for the metallic-roughness ones)
/// uses texture `index`.
fn material_with(slot: &str, index: usize) -> Value {
    match slot.strip_prefix("pbr.") {
        Some(pbr) => json!({ "pbrMetallicRoughness": { pbr: { "index": index } } }),
        None => json!({ slot: { "index": index } }),
    }
}

fn texel(texture: &Texture, x: u32, y: u32) -> [u8; 4] {
    texture.texels[(y * texture.width + x) as usize]
}

fn has_warning(warnings: &[ImportWarning], text: &str) -> bool {
    warnings.iter().any(|w| w.0.contains(text))
}

/// The texture material 0's base color slot references.
fn base_color(scene: &Scene) -> &Texture {
    let reference = scene.materials[0]
        .base_color_texture
        .expect("a base color texture");
    &scene.textures[reference.texture]
}

#[test]
fn bc1_decodes_endpoints_and_thirds_across_blocks() {
    // Block 0: red and blue endpoints (c0 > c1: four colors), texel i takes index i % 4.
    // Block 1: green and black, every texel index 2 (2/3 green).
    let red_blue = bc1_block(0xf800, 0x001f, std::array::from_fn(|i| i as u32 % 4));
    let green_black = bc1_block(0x07e0, 0x0000, [2; 16]);
    let dds = dds_fourcc(8, 4, b"DXT1", &[red_blue, green_black].concat());
    let (scene, warnings) = import_dds_only("pbr.baseColorTexture", &dds);
    assert!(!has_warning(&warnings, "MSFT_texture_dds"), "{warnings:?}");
    let texture = base_color(&scene);
    assert_eq!((texture.width, texture.height), (8, 4));
    assert_eq!(texture.encoding, TextureEncoding::Srgb);
    // 255 * 2 / 3 = 170 and 255 / 3 = 85 exactly.
    let palette = [
        [255, 0, 0, 255],
        [0, 0, 255, 255],
        [170, 0, 85, 255],
        [85, 0, 170, 255],
    ];
    for y in 0..4 {
        for x in 0..4 {
            assert_eq!(
                texel(texture, x, y),
                palette[((y * 4 + x) % 4) as usize],
                "({x}, {y})"
            );
            assert_eq!(
                texel(texture, x + 4, y),
                [0, 170, 0, 255],
                "({}, {y})",
                x + 4
            );
        }
    }
}

#[test]
fn bc3_decodes_interpolated_alpha() {
    // White color block; alpha endpoints 255 and 0 (eight values), texel i takes index i % 8.
    let alpha = bc4_block(255, 0, std::array::from_fn(|i| i as u64 % 8));
    let color = bc1_block(0xffff, 0xffff, [0; 16]);
    let dds = dds_dx10(4, 4, BC3_UNORM_SRGB, 0, &[&alpha[..], &color[..]].concat());
    let (scene, warnings) = import_dds_only("pbr.baseColorTexture", &dds);
    assert!(warnings.is_empty(), "{warnings:?}");
    let texture = base_color(&scene);
    for i in 0..16u32 {
        let index = i % 8;
        // Index 0 and 1 are the endpoints; index k >= 2 is ((8 - k) * 255 + (k - 1) * 0) / 7,
        // which decoders may round either way.
        let expected = match index {
            0 => 255.0,
            1 => 0.0,
            k => f64::from(8 - k) * 255.0 / 7.0,
        };
        let [r, g, b, a] = texel(texture, i % 4, i / 4);
        assert_eq!([r, g, b], [255; 3]);
        assert!(
            (f64::from(a) - expected).abs() < 1.0,
            "texel {i}: alpha {a}, expected {expected:.2}"
        );
    }
}

#[test]
fn bc5_is_red_green_and_a_normal_map_rebuilds_its_z() {
    // Red: endpoints 191 and 64, texel 0 takes index 1 (64), the others index 0 (191).
    // Green: 128 everywhere.
    let red = bc4_block(191, 64, std::array::from_fn(|i| u64::from(i == 0)));
    let green = bc4_block(128, 0, [0; 16]);
    let dds = dds_dx10(4, 4, BC5_UNORM, 0, &[red, green].concat());
    let (scene, warnings) = import_files(
        json!({
            "materials": [material_with("normalTexture", 0), material_with("pbr.metallicRoughnessTexture", 0)],
            "textures": [{ "extensions": { "MSFT_texture_dds": { "source": 0 } } }],
            "images": [{ "uri": "normal.dds" }]
        }),
        &[("normal.dds", &dds)],
    );
    assert!(!has_warning(&warnings, "normal.dds"), "{warnings:?}");
    let normal = &scene.textures[scene.materials[0].normal_texture.unwrap().texture];
    let data = &scene.textures[scene.materials[1]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!(normal.encoding, TextureEncoding::Linear);
    let z = |r: u8, g: u8| {
        let (x, y) = (
            f64::from(r) / 255.0 * 2.0 - 1.0,
            f64::from(g) / 255.0 * 2.0 - 1.0,
        );
        let z = (1.0 - x * x - y * y).max(0.0).sqrt();
        ((z + 1.0) / 2.0 * 255.0).round() as u8
    };
    // 191 and 64 map to x = 0.498 and -0.498: z = 0.867, stored as 238.
    assert_eq!(z(191, 128), 238);
    assert_eq!(texel(normal, 0, 0), [64, 128, z(64, 128), 255]);
    assert_eq!(texel(normal, 1, 0), [191, 128, 238, 255]);
    assert_eq!(texel(data, 0, 0), [64, 128, 0, 255]);
    assert_eq!(texel(data, 3, 3), [191, 128, 0, 255]);
}

#[test]
fn bc7_mode_6_decodes_endpoints_and_crops_edge_blocks() {
    // A 6 x 3 image: two blocks, of which the right one is half outside and the bottom row of
    // both is outside. Block 0: endpoints (101, 151, 201, 255) and (20, 40, 60, 128); texel 0
    // index 0, texel 1 index 15 (the second endpoint), texel 2 index 8 (weight 34 of 64).
    let mut indices = [0; 16];
    indices[1] = 15;
    indices[2] = 8;
    let block0 = bc7_mode6([50, 75, 100, 127], 1, [10, 20, 30, 64], 0, indices);
    let block1 = bc7_mode6([5, 10, 15, 20], 0, [0; 4], 0, [0; 16]);
    let dds = dds_dx10(6, 3, BC7_UNORM, 0, &[block0, block1].concat());
    let (scene, warnings) = import_dds_only("emissiveTexture", &dds);
    assert!(warnings.is_empty(), "{warnings:?}");
    let texture = &scene.textures[scene.materials[0].emissive_texture.unwrap().texture];
    assert_eq!((texture.width, texture.height), (6, 3));
    let (e0, e1) = ([101u32, 151, 201, 255], [20u32, 40, 60, 128]);
    // BC7's interpolation: ((64 - w) * e0 + w * e1 + 32) >> 6.
    let lerp = |w: u32| std::array::from_fn(|c| (((64 - w) * e0[c] + w * e1[c] + 32) >> 6) as u8);
    assert_eq!(texel(texture, 0, 0), [101, 151, 201, 255]);
    assert_eq!(texel(texture, 1, 0), [20, 40, 60, 128]);
    assert_eq!(texel(texture, 2, 0), lerp(34));
    assert_eq!(lerp(34), [58, 92, 126, 188]);
    assert_eq!(texel(texture, 3, 2), [101, 151, 201, 255]);
    assert_eq!(texel(texture, 5, 2), [10, 20, 30, 40]);
}

#[test]
fn bc6h_is_clamped_to_8_bits_per_role_with_a_warning() {
    // Mode 11 (one region, 10-bit endpoints): red 400, green 500, blue 0, every index 0.
    let mut bits = Bits::default();
    bits.push(0b00011, 5);
    for value in [400, 500, 0, 400, 500, 0] {
        bits.push(value, 10);
    }
    bits.push(0, 63);
    let dds = dds_dx10(4, 4, BC6H_UF16, 0, &bits.block());
    let (scene, warnings) = import_files(
        json!({
            "materials": [material_with("pbr.baseColorTexture", 0), material_with("pbr.metallicRoughnessTexture", 0)],
            "textures": [{ "extensions": { "MSFT_texture_dds": { "source": 0 } } }],
            "images": [{ "uri": "sky.dds" }]
        }),
        &[("sky.dds", &dds)],
    );
    assert!(has_warning(&warnings, "HDR (BC6H)"), "{warnings:?}");
    // The format's unsigned unquantization: 10-bit v -> ((v << 16) + 0x8000) >> 10, scaled by
    // 31/64 into the bits of a half float.
    let half = |v: u32| ((((v << 16) + 0x8000) >> 10) * 31) >> 6;
    let to_f32 = |h: u32| 2f32.powi((h >> 10) as i32 - 15) * (1.0 + (h & 0x3ff) as f32 / 1024.0);
    let red = to_f32(half(400));
    assert!((0.1..0.2).contains(&red), "{red}");
    assert!(to_f32(half(500)) > 1.0);
    let color = base_color(&scene);
    let data = &scene.textures[scene.materials[1]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!(texel(color, 2, 2), [linear_to_srgb(red), 255, 0, 255]);
    assert_eq!(
        texel(data, 2, 2),
        [(red * 255.0).round() as u8, 255, 0, 255]
    );
}

#[test]
fn uncompressed_dx10_and_legacy_masked_texels_are_read() {
    let rgba: Vec<u8> = (1..=16).collect();
    let dx10 = dds_dx10(2, 2, R8G8B8A8_UNORM, 0, &rgba);
    // A8R8G8B8 by masks: bytes in memory are blue, green, red, alpha.
    let mut legacy = header(
        2,
        1,
        0x40 | 0x1,
        0,
        [32, 0x00ff_0000, 0x0000_ff00, 0x0000_00ff, 0xff00_0000],
    );
    legacy.extend_from_slice(&[10, 20, 30, 40, 50, 60, 70, 80]);
    let (scene, warnings) = import_files(
        json!({
            "materials": [material_with("pbr.baseColorTexture", 0), material_with("occlusionTexture", 1)],
            "textures": [
                { "extensions": { "MSFT_texture_dds": { "source": 0 } } },
                { "extensions": { "MSFT_texture_dds": { "source": 1 } } }
            ],
            "images": [{ "uri": "rgba.dds" }, { "uri": "legacy.dds" }]
        }),
        &[("rgba.dds", &dx10), ("legacy.dds", &legacy)],
    );
    assert!(warnings.is_empty(), "{warnings:?}");
    let texture = base_color(&scene);
    assert_eq!(
        texture.texels,
        [
            [1, 2, 3, 4],
            [5, 6, 7, 8],
            [9, 10, 11, 12],
            [13, 14, 15, 16]
        ]
    );
    let occlusion = &scene.textures[scene.materials[1].occlusion_texture.unwrap().texture];
    assert_eq!(occlusion.encoding, TextureEncoding::Linear);
    assert_eq!(occlusion.texels, [[30, 20, 10, 40], [70, 60, 50, 80]]);
}

#[test]
fn the_core_source_wins_when_it_decodes_and_the_dds_source_stands_in_otherwise() {
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([7, 8, 9, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let dds = dds_dx10(1, 1, R8G8B8A8_UNORM, 0, &[200, 100, 50, 255]);
    let (scene, warnings) = import_files(
        json!({
            "materials": [material_with("pbr.baseColorTexture", 0), material_with("pbr.baseColorTexture", 1)],
            "textures": [
                { "source": 0, "extensions": { "MSFT_texture_dds": { "source": 2 } } },
                { "source": 1, "extensions": { "MSFT_texture_dds": { "source": 2 } } }
            ],
            "images": [{ "uri": "color.png" }, { "uri": "gone.png" }, { "uri": "color.dds" }]
        }),
        &[("color.png", &png), ("color.dds", &dds)],
    );
    let texture_of =
        |m: usize| &scene.textures[scene.materials[m].base_color_texture.unwrap().texture];
    assert_eq!(texture_of(0).texels, [[7, 8, 9, 255]]);
    assert_eq!(texture_of(1).texels, [[200, 100, 50, 255]]);
    assert!(
        warnings.iter().any(|w| w.0.contains("gone.png")
            && w.0.contains("cannot be read")
            && w.0
                .contains("MSFT_texture_dds source images[2] is used instead")),
        "{warnings:?}"
    );
    assert_eq!(warnings.len(), 1, "{warnings:?}");
}

#[test]
fn unusable_dds_files_are_warned_and_the_factor_applies() {
    let truncated = dds_fourcc(64, 64, b"DXT1", &[0; 16]);
    let unsupported = dds_dx10(1, 1, R16G16B16A16_FLOAT, 0, &[0; 8]);
    let not_dds = b"PNG? no".to_vec();
    let (scene, warnings) = import_files(
        json!({
            "materials": (0..4).map(|i| json!({
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.25, 0.5, 0.75, 1.0],
                    "baseColorTexture": { "index": i }
                }
            })).collect::<Vec<_>>(),
            "textures": (0..4).map(|i| json!({ "extensions": { "MSFT_texture_dds": { "source": i } } })).collect::<Vec<_>>(),
            "images": [
                { "uri": "missing.dds" },
                { "uri": "truncated.dds" },
                { "uri": "half.dds", "mimeType": "image/vnd-ms.dds" },
                { "uri": "not_dds.dds", "mimeType": "image/vnd-ms.dds" }
            ]
        }),
        &[
            ("truncated.dds", &truncated),
            ("half.dds", &unsupported),
            ("not_dds.dds", &not_dds),
        ],
    );
    for text in [
        "images[0] (\"missing.dds\") cannot be read",
        "images[1] (\"truncated.dds\") is truncated: its first 64 x 64 surface needs 2048 bytes, the file holds 16",
        "images[2] (\"half.dds\") has format R16G16B16A16_Float, which is not read",
        "images[3] (\"not_dds.dds\") is not a DDS file",
    ] {
        assert!(
            warnings
                .iter()
                .any(|w| w.0.contains(text) && w.0.contains("the material's factor applies")),
            "no warning with {text}: {warnings:?}"
        );
    }
    for material in &scene.materials {
        assert_eq!(material.base_color_texture, None);
        assert_eq!(material.base_color.y, 0.5);
    }
    assert!(scene.textures.is_empty());
}

#[test]
fn hostile_dimensions_are_refused_without_allocating_them() {
    // 65535 x 65535 is past the size limit; 8192 x 8192 RGBA8 (256 MiB) is within it but the
    // file holds 4 bytes: both are refused before the texels are allocated.
    let huge = dds_fourcc(65535, 65535, b"DXT5", &[0; 16]);
    let claims_256_mib = dds_dx10(8192, 8192, R8G8B8A8_UNORM, 0, &[1, 2, 3, 4]);
    let extra = json!({
        "materials": [material_with("pbr.baseColorTexture", 0), material_with("emissiveTexture", 1)],
        "textures": [
            { "extensions": { "MSFT_texture_dds": { "source": 0 } } },
            { "extensions": { "MSFT_texture_dds": { "source": 1 } } }
        ],
        "images": [{ "uri": "huge.dds" }, { "uri": "claims.dds" }]
    });
    peak_alloc::reset();
    let (scene, warnings) = import_files(
        extra,
        &[("huge.dds", &huge), ("claims.dds", &claims_256_mib)],
    );
    let peak = peak_alloc::peak_bytes();
    assert!(
        has_warning(&warnings, "larger than 8192 x 8192 texels (65535 x 65535)"),
        "{warnings:?}"
    );
    assert!(
        has_warning(&warnings, "needs 268435456 bytes, the file holds 4"),
        "{warnings:?}"
    );
    assert!(scene.textures.is_empty());
    assert!(peak < 1 << 20, "largest allocation {peak} bytes");
}

#[test]
fn a_cube_map_gives_its_first_face_with_a_warning() {
    let faces: Vec<u8> = (0..6u8).flat_map(|face| [face, face, face, 255]).collect();
    let dds = dds_dx10(1, 1, R8G8B8A8_UNORM, 4, &faces);
    let (scene, warnings) = import_dds_only("pbr.baseColorTexture", &dds);
    assert!(
        has_warning(&warnings, "is a cube map; only its first face (+X) is read"),
        "{warnings:?}"
    );
    assert_eq!(base_color(&scene).texels, [[0, 0, 0, 255]]);
}

#[test]
fn split_roughness_and_metallic_maps_combine_into_green_and_blue() {
    // Roughness: a 4 x 4 BC4 map, texel i 200 (index 0) or 100 (index 1) by parity.
    let roughness = dds_dx10(
        4,
        4,
        BC4_UNORM,
        0,
        &bc4_block(200, 100, std::array::from_fn(|i| i as u64 % 2)),
    );
    // Metallic: a 2 x 2 RGBA map with red 10, 20, 30, 40, stretched over the 4 x 4 result.
    let metallic = dds_dx10(
        2,
        2,
        R8G8B8A8_UNORM,
        0,
        &[10, 0, 0, 255, 20, 0, 0, 255, 30, 0, 0, 255, 40, 0, 0, 255],
    );
    let split = |maps: Value| json!({ "extensions": { "AMD_split_roughnessMetallic": maps } });
    let (scene, warnings) = import_files(
        json!({
            "extensionsUsed": ["MSFT_texture_dds", "AMD_split_roughnessMetallic"],
            "extensionsRequired": ["AMD_split_roughnessMetallic"],
            "materials": [
                split(json!({ "roughnessTexture": { "index": 0 }, "metallicTexture": { "index": 1 } })),
                split(json!({ "roughnessTexture": { "index": 0 } }))
            ],
            "textures": [
                { "extensions": { "MSFT_texture_dds": { "source": 0 } } },
                { "extensions": { "MSFT_texture_dds": { "source": 1 } } }
            ],
            "images": [{ "uri": "roughness.dds" }, { "uri": "metallic.dds" }]
        }),
        &[("roughness.dds", &roughness), ("metallic.dds", &metallic)],
    );
    assert!(warnings.is_empty(), "{warnings:?}");
    let both = &scene.textures[scene.materials[0]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!((both.width, both.height), (4, 4));
    assert_eq!(both.encoding, TextureEncoding::Linear);
    for y in 0..4 {
        for x in 0..4 {
            let rough = if (y * 4 + x) % 2 == 0 { 200 } else { 100 };
            let metal = [10, 20, 30, 40][(y / 2 * 2 + x / 2) as usize];
            assert_eq!(texel(both, x, y), [255, rough, metal, 255], "({x}, {y})");
        }
    }
    let rough_only = &scene.textures[scene.materials[1]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!(texel(rough_only, 1, 0), [255, 100, 255, 255]);
    assert_eq!(scene.materials[1].metallic, 1.0);
}

#[test]
fn a_core_metallic_roughness_texture_wins_over_split_maps() {
    let core = dds_dx10(1, 1, R8G8B8A8_UNORM, 0, &[0, 10, 20, 255]);
    let roughness = dds_dx10(1, 1, R8G8B8A8_UNORM, 0, &[99, 0, 0, 255]);
    let (scene, _) = import_files(
        json!({
            "materials": [{
                "pbrMetallicRoughness": { "metallicRoughnessTexture": { "index": 0 } },
                "extensions": { "AMD_split_roughnessMetallic": { "roughnessTexture": { "index": 1 } } }
            }],
            "textures": [
                { "extensions": { "MSFT_texture_dds": { "source": 0 } } },
                { "extensions": { "MSFT_texture_dds": { "source": 1 } } }
            ],
            "images": [{ "uri": "core.dds" }, { "uri": "roughness.dds" }]
        }),
        &[("core.dds", &core), ("roughness.dds", &roughness)],
    );
    let texture = &scene.textures[scene.materials[0]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!(texture.texels, [[0, 10, 20, 255]]);
}

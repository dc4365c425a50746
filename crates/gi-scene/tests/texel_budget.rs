//! The texel budget of an import ([`ImportOptions::max_texels`]): every image of a file counts,
//! whatever its encoding (PNG, JPEG, DDS) and wherever it lives (the GLB binary chunk, a second
//! buffer that is a data URI, a data URI image, a file beside a `.gltf`), from its header and
//! before anything is decoded. A file past the budget, or with an image whose header does not
//! read, is refused with an error naming the image, and a refused import allocates nothing
//! near the size its images claim.

mod common;
mod peak_alloc;
use common::base64;

use std::path::Path;

use gi_scene::{ImportOptions, Scene, SceneError, import_gltf_slice_with};
use serde_json::{Value, json};

/// `width` x `height` texels of one grey, encoded as `format`: large, yet a few kilobytes.
fn flat_image(width: u32, height: u32, format: image::ImageFormat) -> Vec<u8> {
    let image = image::RgbImage::from_pixel(width, height, image::Rgb([90, 120, 150]));
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), format)
        .unwrap();
    bytes
}

/// A DDS file of `width` x `height` RGBA8 texels (DX10 header), all zero.
fn dds(width: u32, height: u32) -> Vec<u8> {
    const R8G8B8A8_UNORM: u32 = 28;
    let mut words = [0u32; 31];
    words[0] = 124;
    words[1] = 0x1 | 0x2 | 0x4 | 0x1000;
    words[2] = height;
    words[3] = width;
    words[18] = 32;
    words[19] = 0x4;
    words[20] = u32::from_le_bytes(*b"DX10");
    words[26] = 0x1000;
    let mut bytes = b"DDS ".to_vec();
    for word in words.into_iter().chain([R8G8B8A8_UNORM, 3, 0, 1, 0]) {
        bytes.extend_from_slice(&word.to_le_bytes());
    }
    bytes.resize(bytes.len() + (width * height * 4) as usize, 0);
    bytes
}

/// Where a test puts an image.
enum Place<'a> {
    /// In the GLB binary chunk, after the triangle, through a buffer view.
    BinaryChunk(&'a [u8]),
    /// Through a buffer view of a second buffer that is a data URI.
    SecondBuffer(&'a [u8]),
    /// A data URI image.
    DataUri(&'a [u8]),
    /// A file beside the `.gltf` (`base` names the folder when importing).
    File(&'a str),
}

/// A GLB of one textured triangle whose material uses texture i for image i (the base color,
/// then the emissive, occlusion and normal maps), with `images` placed as asked and `extra`
/// merged into the material.
fn textured_triangle(images: &[Place], extra: Value) -> Vec<u8> {
    let positions: [f32; 9] = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0];
    let uvs: [f32; 6] = [0.0, 0.0, 0.0, 1.0, 1.0, 0.0];
    let mut bin: Vec<u8> = positions
        .iter()
        .chain(&uvs)
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut buffers = vec![json!({ "byteLength": 0 })];
    let mut views = vec![
        json!({ "buffer": 0, "byteOffset": 0, "byteLength": 36 }),
        json!({ "buffer": 0, "byteOffset": 36, "byteLength": 24 }),
    ];
    let mut json_images = Vec::new();
    for place in images {
        json_images.push(match place {
            Place::BinaryChunk(bytes) => {
                views.push(
                    json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }),
                );
                bin.extend_from_slice(bytes);
                while !bin.len().is_multiple_of(4) {
                    bin.push(0);
                }
                json!({ "bufferView": views.len() - 1, "mimeType": mime(bytes) })
            }
            Place::SecondBuffer(bytes) => {
                buffers.push(json!({
                    "byteLength": bytes.len(),
                    "uri": format!("data:application/octet-stream;base64,{}", base64(bytes))
                }));
                views.push(json!({ "buffer": buffers.len() - 1, "byteLength": bytes.len() }));
                json!({ "bufferView": views.len() - 1, "mimeType": mime(bytes) })
            }
            Place::DataUri(bytes) => {
                json!({ "uri": format!("data:{};base64,{}", mime(bytes), base64(bytes)) })
            }
            Place::File(name) => json!({ "uri": name }),
        });
    }
    buffers[0]["byteLength"] = json!(bin.len());
    let mut material = json!({ "pbrMetallicRoughness": {} });
    for (i, slot) in [
        "baseColorTexture",
        "emissiveTexture",
        "occlusionTexture",
        "normalTexture",
    ]
    .into_iter()
    .enumerate()
    .take(images.len())
    {
        let slot = if i == 0 {
            &mut material["pbrMetallicRoughness"][slot]
        } else {
            &mut material[slot]
        };
        *slot = json!({ "index": i });
    }
    for (key, value) in extra.as_object().unwrap() {
        material[key] = value.clone();
    }
    let doc = json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["AMD_split_roughnessMetallic"],
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "material": 0 }] }],
        "materials": [material],
        "buffers": buffers,
        "bufferViews": views,
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2" }
        ],
        "textures": (0..images.len()).map(|i| json!({ "source": i })).collect::<Vec<_>>(),
        "images": json_images
    });
    glb(&serde_json::to_vec(&doc).unwrap(), &bin)
}

fn mime(bytes: &[u8]) -> &'static str {
    match bytes {
        [0x89, b'P', b'N', b'G', ..] => "image/png",
        [0xff, 0xd8, ..] => "image/jpeg",
        [b'D', b'D', b'S', b' ', ..] => "image/vnd-ms.dds",
        _ => "image/png",
    }
}

/// A GLB container of `json` and binary chunk `bin`.
fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// GLB `file` with its JSON changed by `change`, the binary chunk kept.
fn edit(file: &[u8], change: impl FnOnce(&mut Value)) -> Vec<u8> {
    let json_len = u32::from_le_bytes(file[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&file[20..20 + json_len]).unwrap();
    change(&mut doc);
    glb(
        &serde_json::to_vec(&doc).unwrap(),
        &file[20 + json_len + 8..],
    )
}

fn import(bytes: &[u8], base: &Path, max_texels: Option<u64>) -> Result<Scene, SceneError> {
    import_gltf_slice_with(bytes, base, &ImportOptions { max_texels }).map(|(scene, _)| scene)
}

/// The error of an import that must be refused, after checking its kind.
fn refused(bytes: &[u8], max_texels: u64) -> String {
    match import(bytes, Path::new("budget.glb"), Some(max_texels)) {
        Err(e @ SceneError::Invalid { .. }) => e.to_string(),
        Err(other) => panic!("refused for another reason: {other}"),
        Ok(_) => panic!("imported past a budget of {max_texels} texels"),
    }
}

#[test]
fn a_large_jpeg_in_the_binary_chunk_is_counted_and_refused_before_it_is_decoded() {
    let jpeg = flat_image(2048, 2048, image::ImageFormat::Jpeg);
    assert!(jpeg.len() < 200_000, "{} bytes", jpeg.len());
    let file = textured_triangle(&[Place::BinaryChunk(&jpeg)], json!({}));

    peak_alloc::reset();
    let error = refused(&file, 1 << 20);
    let peak = peak_alloc::peak_bytes();
    assert!(
        error.contains("images[0]") && error.contains("2048 x 2048") && error.contains("JPEG"),
        "{error}"
    );
    assert!(error.contains("more than the 1048576 allowed"), "{error}");
    // Decoding would allocate 2048 * 2048 * 3 bytes at once.
    assert!(
        peak < 2048 * 2048,
        "the refused import allocated {peak} bytes"
    );

    // Within the budget, or without one, the same file imports with its texture.
    for budget in [Some(1 << 22), None] {
        let scene = import(&file, Path::new("budget.glb"), budget).unwrap();
        let texture = &scene.textures[scene.materials[0].base_color_texture.unwrap().texture];
        assert_eq!((texture.width, texture.height), (2048, 2048));
    }
}

#[test]
fn images_count_wherever_they_live_and_in_every_encoding() {
    let png = flat_image(300, 200, image::ImageFormat::Png);
    let jpeg = flat_image(100, 100, image::ImageFormat::Jpeg);
    let dds = dds(16, 8);
    let texels = 300 * 200 + 100 * 100 + 16 * 8;
    for place in 0..3 {
        let at = |bytes| match place {
            0 => Place::BinaryChunk(bytes),
            1 => Place::SecondBuffer(bytes),
            _ => Place::DataUri(bytes),
        };
        let file = textured_triangle(&[at(&png), at(&jpeg), at(&dds)], json!({}));
        let scene = import(&file, Path::new("budget.glb"), Some(texels)).unwrap();
        assert_eq!(scene.textures.len(), 3, "place {place}");
        // One texel less, and the last image counted is the one named.
        let error = refused(&file, texels - 1);
        assert!(
            error.contains("images[2]") && error.contains("16 x 8") && error.contains("DDS"),
            "place {place}: {error}"
        );
    }
    // A PNG in a second buffer alone past the budget (its view starts at offset 0 of that
    // buffer, not of the binary chunk).
    let file = textured_triangle(&[Place::SecondBuffer(&png)], json!({}));
    assert!(refused(&file, 300 * 200 - 1).contains("300 x 200 texels, PNG"));
}

#[test]
fn files_beside_a_gltf_and_images_no_material_uses_count_too() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("wall.png"),
        flat_image(64, 64, image::ImageFormat::Png),
    )
    .unwrap();
    let file = textured_triangle(&[Place::File("wall.png")], json!({}));
    let base = dir.path().join("scene.glb");
    assert!(import(&file, &base, Some(64 * 64)).is_ok());
    let error = import(&file, &base, Some(64 * 64 - 1)).unwrap_err();
    assert!(error.to_string().contains("\"wall.png\""), "{error}");

    // An image no texture uses is not decoded, yet counts against a budget.
    let unused = edit(&file, |doc| doc["materials"] = json!([{}]));
    assert!(import(&unused, &base, None).is_ok());
    assert!(import(&unused, &base, Some(64 * 64 - 1)).is_err());
}

#[test]
fn with_a_budget_an_image_whose_header_does_not_read_is_refused() {
    let png = flat_image(8, 8, image::ImageFormat::Png);
    let cases: [(&[u8], &str); 3] = [
        (&png[..20], "no readable PNG header"),
        (
            b"GIF89a\x01\x00\x01\x00\x00\x00\x00",
            "neither PNG, JPEG nor DDS",
        ),
        (b"DDS \x04\x00", "unreadable header"),
    ];
    for (bytes, why) in cases {
        // No MIME type: the importer goes by the first bytes.
        let file = edit(
            &textured_triangle(&[Place::DataUri(bytes)], json!({})),
            |doc| {
                doc["images"][0] = json!({
                    "uri": format!("data:application/octet-stream;base64,{}", base64(bytes))
                })
            },
        );
        // Without a budget the texture is dropped with a warning; with one the file is refused.
        let (scene, warnings) =
            import_gltf_slice_with(&file, Path::new("budget.glb"), &ImportOptions::default())
                .unwrap();
        assert_eq!(scene.materials[0].base_color_texture, None);
        assert!(!warnings.is_empty());
        let error = refused(&file, 1 << 20);
        assert!(
            error.contains("images[0]") && error.contains(why),
            "{error}"
        );
    }
}

#[test]
fn a_texture_combined_from_split_maps_counts() {
    // A 64 x 1 roughness map and a 1 x 64 metallic map combine into 64 x 64 texels.
    let roughness = flat_image(64, 1, image::ImageFormat::Png);
    let metallic = flat_image(1, 64, image::ImageFormat::Png);
    let file = textured_triangle(
        &[Place::DataUri(&roughness), Place::DataUri(&metallic)],
        json!({ "extensions": { "AMD_split_roughnessMetallic": {
            "roughnessTexture": { "index": 0 }, "metallicTexture": { "index": 1 } } } }),
    );
    // Only the split maps use the images.
    let file = edit(&file, |doc| {
        let material = doc["materials"][0].as_object_mut().unwrap();
        material.remove("emissiveTexture");
        material.insert("pbrMetallicRoughness".into(), json!({}));
    });
    let scene = import(&file, Path::new("split.glb"), Some(128 + 64 * 64)).unwrap();
    let combined = &scene.textures[scene.materials[0]
        .metallic_roughness_texture
        .unwrap()
        .texture];
    assert_eq!((combined.width, combined.height), (64, 64));
    let error = refused(&file, 128 + 64 * 64 - 1);
    assert!(
        error.contains("AMD_split_roughnessMetallic") && error.contains("64 x 64"),
        "{error}"
    );
}

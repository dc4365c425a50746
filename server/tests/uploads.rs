//! The texel budget of uploads (`--max-upload-texels`) over HTTP: a scene's images count
//! whatever their encoding and wherever the GLB stores them, read from their headers before
//! any is decoded. A small JPEG of many texels in the binary chunk, a PNG in a second buffer
//! that is a data URI, and an image whose header does not read are all refused with 422 and
//! a message naming the image; a scene within the budget is accepted and renders.

mod common;

use std::time::Duration;

use common::*;
use serde_json::{Value, json};

/// `width` x `height` texels of one grey, encoded as `format`: many texels in few bytes.
fn flat_image(width: u32, height: u32, format: image::ImageFormat) -> Vec<u8> {
    let image = image::RgbImage::from_pixel(width, height, image::Rgb([200, 180, 160]));
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), format)
        .unwrap();
    bytes
}

/// Where the base color image of [`textured_quad`] lives.
enum Place<'a> {
    /// In the GLB binary chunk, after the geometry.
    BinaryChunk(&'a [u8], &'a str),
    /// At the start of a second buffer, a base64 data URI (the view's offset 0 is that
    /// buffer's, not the binary chunk's).
    SecondBuffer(&'a [u8], &'a str),
}

/// A GLB of a lit, textured quad whose base color texture is `image`.
fn textured_quad(image: Place) -> Vec<u8> {
    let positions: [[f32; 3]; 4] = [
        [-1.0, 0.0, -1.0],
        [-1.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
    ];
    let uvs: [[f32; 2]; 4] = [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]];
    let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = (positions.as_flattened().iter().chain(uvs.as_flattened()))
        .flat_map(|v| v.to_le_bytes())
        .chain(indices.iter().flat_map(|i| i.to_le_bytes()))
        .collect();
    let mut buffers = vec![json!({})];
    let mut views = vec![
        json!({ "buffer": 0, "byteOffset": 0, "byteLength": 48 }),
        json!({ "buffer": 0, "byteOffset": 48, "byteLength": 32 }),
        json!({ "buffer": 0, "byteOffset": 80, "byteLength": 24 }),
    ];
    let image_json = match image {
        Place::BinaryChunk(bytes, mime) => {
            views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
            bin.extend_from_slice(bytes);
            json!({ "bufferView": 3, "mimeType": mime })
        }
        Place::SecondBuffer(bytes, mime) => {
            buffers.push(json!({
                "byteLength": bytes.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64(bytes))
            }));
            views.push(json!({ "buffer": 1, "byteLength": bytes.len() }));
            json!({ "bufferView": 3, "mimeType": mime })
        }
    };
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    buffers[0] = json!({ "byteLength": bin.len() });
    // The sun shines straight down: -Z turned a quarter turn about X.
    let half = std::f32::consts::FRAC_1_SQRT_2;
    let doc = json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [{ "type": "directional", "intensity": 3.0 }] } },
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "mesh": 0 },
            { "extensions": { "KHR_lights_punctual": { "light": 0 } },
              "rotation": [-half, 0.0, 0.0, half] }
        ],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 0 }] }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
        "textures": [{ "source": 0 }],
        "images": [image_json],
        "buffers": buffers,
        "bufferViews": views,
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0] },
            { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" },
            { "bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR" }
        ]
    });
    glb(&serde_json::to_vec(&doc).unwrap(), &bin)
}

/// A GLB container of `json` and binary chunk `bin` (padded to 4 bytes).
fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
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

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for i in 0..4 {
            out.push(if i <= chunk.len() {
                ALPHABET[(n >> (18 - 6 * i)) as usize & 63] as char
            } else {
                '='
            });
        }
    }
    out
}

/// Asserts `response` is a 422 `invalid_scene` whose message has every one of `parts`.
fn assert_refused(response: &Response, parts: &[&str]) {
    assert_eq!(response.status, 422, "{}", response.text());
    assert_eq!(response.error_code(), "invalid_scene");
    let message = response.json()["error"]["message"]
        .as_str()
        .unwrap()
        .to_string();
    for part in parts {
        assert!(message.contains(part), "no {part:?} in {message:?}");
    }
}

#[test]
fn every_image_of_an_upload_counts_against_the_texel_budget() {
    // The default budget: 2^24 texels.
    let server = TestServer::start(|c| c.no_gpu = true);
    let addr = server.addr;
    let budget = gi_server::Config::with_data_dir("unused").max_upload_texels;
    assert_eq!(budget, 1 << 24);

    // 4608 x 4096 texels (72 MiB as RGBA8) in a JPEG of a few hundred kilobytes.
    let jpeg = flat_image(4608, 4096, image::ImageFormat::Jpeg);
    assert!(jpeg.len() < 2 << 20, "{} bytes", jpeg.len());
    let upload = textured_quad(Place::BinaryChunk(&jpeg, "image/jpeg"));
    assert_refused(
        &upload_glb(addr, &upload),
        &[
            "images[0]",
            "4608 x 4096 texels, JPEG",
            "more than the 16777216",
        ],
    );

    // A PNG in a second, data-URI buffer: its view starts at that buffer's offset 0.
    let png = flat_image(4200, 4200, image::ImageFormat::Png);
    let upload = textured_quad(Place::SecondBuffer(&png, "image/png"));
    assert_refused(
        &upload_glb(addr, &upload),
        &["images[0]", "4200 x 4200 texels, PNG"],
    );

    // An image whose header does not read cannot be counted: refused, named.
    let upload = textured_quad(Place::SecondBuffer(&png[..16], "image/png"));
    assert_refused(
        &upload_glb(addr, &upload),
        &["images[0]", "no readable PNG header"],
    );

    // Nothing refused was stored.
    let scenes = get(addr, "/v1/scenes").json();
    let uploaded = |scenes: &Value| {
        scenes["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|s| s["source"] == "uploaded")
            .count()
    };
    assert_eq!(uploaded(&scenes), 0, "{scenes}");

    // Within the budget, the same scene is accepted and renders with its texture.
    for (what, upload) in [
        (
            "a JPEG in the binary chunk",
            textured_quad(Place::BinaryChunk(
                &flat_image(512, 512, image::ImageFormat::Jpeg),
                "image/jpeg",
            )),
        ),
        (
            "a PNG in a second buffer",
            textured_quad(Place::SecondBuffer(
                &flat_image(512, 256, image::ImageFormat::Png),
                "image/png",
            )),
        ),
    ] {
        let response = upload_glb(addr, &upload);
        assert_eq!(response.status, 201, "{what}: {}", response.text());
        let scene = response.json()["scene"].clone();
        assert_eq!(scene["triangles"], 2, "{what}: {scene}");
        let id = submit(
            addr,
            &json!({"scene": scene["id"], "tier": "direct", "width": 16, "height": 12, "spp": 1,
                    "compare": false}),
        );
        let job = wait_final(addr, &id, Duration::from_secs(60));
        assert_eq!(job["state"], "done", "{what}: {job}");
    }
    assert_eq!(uploaded(&get(addr, "/v1/scenes").json()), 2);
}

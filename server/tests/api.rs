//! The API over real HTTP on loopback: every tier rendered, compared and served; every bad
//! input answered with the right 4xx; uploads; paging; the OpenAPI document against the router.

mod common;

use std::time::Duration;

use common::*;
use gi_reference::cache::{REFERENCE_SEED, ReferenceCache, ReferenceRequest};
use gi_tiers::{
    TierSettings,
    select::{self, AdapterDescription, RunsOn},
};
use serde_json::{Value, json};

const JOB_TIMEOUT: Duration = Duration::from_secs(120);

/// A small job of `tier`; temporal tiers get two warm-up frames so the test stays short.
fn small_job(tier: &str, compare: bool) -> Value {
    json!({
        "scene": "cornell-box", "tier": tier, "width": 32, "height": 24, "spp": 2,
        "warmup": 2, "compare": compare, "reference_spp": if compare { Some(8) } else { None },
    })
}

fn assert_images(addr: std::net::SocketAddr, job: &Value, compared: bool) {
    let id = job["id"].as_str().unwrap();
    let image = get(addr, &format!("/v1/jobs/{id}/image.png"));
    assert_eq!(image.status, 200);
    assert_eq!(image.header("content-type"), Some("image/png"));
    assert_eq!(png_size(&image.body), (32, 24));
    let exr = get(addr, &format!("/v1/jobs/{id}/image.exr"));
    assert_eq!(exr.status, 200);
    assert_eq!(&exr.body[..4], &[0x76, 0x2f, 0x31, 0x01], "OpenEXR magic");
    for file in ["reference.png", "error.png", "flip.png"] {
        let response = get(addr, &format!("/v1/jobs/{id}/{file}"));
        if compared {
            assert_eq!(response.status, 200, "{file}");
            assert_eq!(png_size(&response.body), (32, 24), "{file}");
        } else {
            assert_eq!(response.status, 404, "{file}");
            assert_eq!(response.error_code(), "image_not_found");
        }
    }
}

#[test]
fn every_tier_renders_compares_and_serves_its_images() {
    let adapter = gi_gpu::GpuContext::new_or_skip(
        "every_tier_renders_compares_and_serves_its_images (GPU tiers)",
    )
    .map(|ctx| AdapterDescription::from_context(&ctx));
    // `auto` is the library's policy for this adapter at the job's size, with no budget.
    let settings = TierSettings {
        width: 32,
        height: 24,
        spp: 2,
        seed: 0,
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let auto = select::plan(adapter.as_ref(), &settings, None);
    let server = TestServer::start(|_| {});
    let addr = server.addr;

    let mut tiers = vec!["auto", "reference", "direct"];
    if adapter.is_some() {
        tiers.extend(["path", "mobile", "pc"]);
    }
    let jobs: Vec<(String, &str)> = tiers
        .iter()
        .map(|&tier| (submit(addr, &small_job(tier, true)), tier))
        .collect();
    let mut references_rendered = 0;
    for (id, tier) in &jobs {
        let job = wait_final(addr, id, JOB_TIMEOUT);
        assert_eq!(job["state"], "done", "{tier}: {job}");
        let result = &job["result"];
        let used = result["tier"].as_str().unwrap();
        match *tier {
            // pc on a discrete GPU, the CPU reference on a software adapter (lavapipe) or none.
            "auto" => {
                assert_eq!(used, auto.chosen().kind.name(), "{auto:?}");
                let device = result["device"].as_str().unwrap();
                match auto.chosen().runs_on {
                    RunsOn::Gpu => assert!(device.starts_with("gpu"), "{device}"),
                    RunsOn::Cpu => assert_eq!(device, "cpu"),
                }
            }
            _ => assert_eq!(used, *tier),
        }
        assert!(result["ms_per_frame"].as_f64().unwrap() > 0.0, "{result}");
        assert!(
            !result["passes"].as_object().unwrap().is_empty(),
            "{result}"
        );
        assert!(result["memory_bytes"].as_u64().unwrap() > 0, "{result}");
        let temporal = matches!(used, "mobile" | "pc" | "path");
        assert_eq!(result["warmup"], if temporal { 2 } else { 0 }, "{tier}");
        let comparison = &result["comparison"];
        assert_eq!(comparison["reference_spp"], 8);
        // Auto: the GPU path tier on a hardware adapter, else the CPU.
        let engine = comparison["reference_engine"].as_str().unwrap();
        assert!(engine == "cpu" || engine.starts_with("gpu: "), "{engine}");
        if comparison["reference_cached"] == false {
            references_rendered += 1;
        }
        let rmse = comparison["rmse_srgb8"].as_f64().unwrap();
        assert!(rmse.is_finite() && rmse >= 0.0, "{comparison}");
        assert!(comparison["rmse_linear"].as_f64().unwrap().is_finite());
        let flip = comparison["flip"].as_f64().unwrap();
        assert!((0.0..1.0).contains(&flip), "{comparison}");
        if *tier == "direct" {
            // The direct-only image measured against itself.
            assert_eq!(
                comparison["gain_vs_direct"].as_f64(),
                Some(1.0),
                "{comparison}"
            );
        } else {
            // Full transport is far closer to the reference than direct light in the box,
            // where every wall is lit indirectly.
            let gain = comparison["gain_vs_direct"].as_f64().unwrap();
            assert!(gain < 0.8, "{tier}: gain_vs_direct {gain}");
        }
        assert_eq!(job["progress"], Value::Null);
        assert_images(addr, &job, true);
    }

    // Every job compared the same view: one path traced its reference, the others waited for
    // it and read it from the cache.
    assert_eq!(references_rendered, 1);

    // The reference went into the cache `gi compare` reads, under the key it computes.
    let scene = gi_scene::load("cornell-box").unwrap();
    let request = ReferenceRequest::new(
        &scene,
        scene.default_view(0.0),
        0.0,
        (32, 24),
        8,
        REFERENCE_SEED,
    );
    let cached = ReferenceCache::new(server.cache_dir()).load(&request.key());
    assert!(
        cached.is_some(),
        "no reference in {}",
        server.cache_dir().display()
    );
    // A later comparison of the same view reuses it.
    let again = submit(addr, &small_job("reference", true));
    let job = wait_final(addr, &again, JOB_TIMEOUT);
    assert_eq!(
        job["result"]["comparison"]["reference_cached"], true,
        "{job}"
    );

    // Without comparing there is no reference or error map.
    let plain = submit(addr, &small_job("reference", false));
    let job = wait_final(addr, &plain, JOB_TIMEOUT);
    assert_eq!(job["result"]["comparison"], Value::Null);
    assert_images(addr, &job, false);
}

#[test]
fn gpu_tiers_without_a_gpu_answer_a_clear_error_and_auto_still_renders() {
    let server = TestServer::start(|c| c.no_gpu = true);
    let addr = server.addr;
    for tier in ["path", "mobile", "pc"] {
        let response = post_json(addr, "/v1/jobs", &small_job(tier, false));
        assert_eq!(response.status, 422, "{tier}");
        assert_eq!(response.error_code(), "gpu_unavailable");
        assert!(
            response.text().contains("needs a GPU"),
            "{}",
            response.text()
        );
    }
    let health = get(addr, "/healthz").json();
    assert_eq!(health["gpu"], Value::Null);
    for tier in ["auto", "direct"] {
        let id = submit(addr, &small_job(tier, false));
        let job = wait_final(addr, &id, JOB_TIMEOUT);
        assert_eq!(job["state"], "done", "{job}");
        assert_eq!(job["result"]["device"], "cpu");
        assert_eq!(
            job["result"]["tier"],
            if tier == "auto" {
                "reference"
            } else {
                "direct"
            }
        );
    }
}

#[test]
fn bad_input_gets_the_right_4xx_and_changes_nothing() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.max_width = 512;
        c.max_height = 512;
        c.max_upload_bytes = 64 << 10;
    });
    let addr = server.addr;
    let json_header = [("Content-Type", "application/json")];
    let cases: Vec<(&str, u16, &str, Response)> = vec![
        (
            "malformed JSON",
            400,
            "malformed_json",
            request(
                addr,
                "POST",
                "/v1/jobs",
                &json_header,
                b"{\"scene\": \"cornell-box\",",
            ),
        ),
        (
            "not JSON",
            415,
            "unsupported_media_type",
            request(
                addr,
                "POST",
                "/v1/jobs",
                &[("Content-Type", "text/plain")],
                b"scene=cornell-box",
            ),
        ),
        (
            "wrong type",
            422,
            "invalid_request",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "width": "wide"}),
            ),
        ),
        (
            "unknown field",
            422,
            "invalid_request",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "widht": 32}),
            ),
        ),
        (
            "missing scene",
            422,
            "invalid_request",
            post_json(addr, "/v1/jobs", &json!({"tier": "auto"})),
        ),
        (
            "unknown scene",
            422,
            "unknown_scene",
            post_json(addr, "/v1/jobs", &json!({"scene": "no-such-scene"})),
        ),
        (
            "unknown tier",
            422,
            "unknown_tier",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "tier": "ultra"}),
            ),
        ),
        (
            "huge width",
            422,
            "limit_exceeded",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "width": 100000}),
            ),
        ),
        (
            "negative height",
            422,
            "invalid_request",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "height": -4}),
            ),
        ),
        (
            "zero spp",
            422,
            "limit_exceeded",
            post_json(addr, "/v1/jobs", &json!({"scene": "cornell-box", "spp": 0})),
        ),
        (
            "huge spp",
            422,
            "limit_exceeded",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "spp": 1u64 << 31}),
            ),
        ),
        (
            "too many frames",
            422,
            "limit_exceeded",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "frames": 200, "warmup": 200}),
            ),
        ),
        (
            "huge reference",
            422,
            "limit_exceeded",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "compare": true, "reference_spp": 1 << 30}),
            ),
        ),
        (
            "reference without compare",
            422,
            "invalid_request",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "compare": false, "reference_spp": 4}),
            ),
        ),
        (
            "unknown camera",
            422,
            "invalid_camera",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "camera": "drone"}),
            ),
        ),
        (
            "degenerate camera",
            422,
            "invalid_camera",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "cornell-box", "camera": {"position": [1, 1, 1], "target": [1, 1, 1]}}),
            ),
        ),
        (
            "path traversal in the scene",
            422,
            "invalid_scene_name",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "../../../../etc/passwd"}),
            ),
        ),
        (
            "absolute path as the scene",
            422,
            "invalid_scene_name",
            post_json(addr, "/v1/jobs", &json!({"scene": "/etc/passwd"})),
        ),
        (
            "scene file of the repository",
            422,
            "invalid_scene_name",
            post_json(
                addr,
                "/v1/jobs",
                &json!({"scene": "scenes/cornell-box.gltf"}),
            ),
        ),
        (
            "path traversal in the URL",
            404,
            "job_not_found",
            get(addr, "/v1/jobs/..%2F..%2Fetc%2Fpasswd"),
        ),
        (
            "dot segments in the URL",
            404,
            "not_found",
            get(addr, "/v1/jobs/1/../../../etc/passwd"),
        ),
        (
            "unknown job",
            404,
            "job_not_found",
            get(addr, "/v1/jobs/987654"),
        ),
        (
            "unknown job's image",
            404,
            "job_not_found",
            get(addr, "/v1/jobs/987654/image.png"),
        ),
        (
            "cancel an unknown job",
            404,
            "job_not_found",
            delete(addr, "/v1/jobs/987654"),
        ),
        (
            "unknown route",
            404,
            "not_found",
            get(addr, "/v2/everything"),
        ),
        (
            "wrong method",
            405,
            "method_not_allowed",
            request(addr, "PUT", "/v1/jobs", &[], b""),
        ),
        (
            "bad page size",
            400,
            "invalid_query",
            get(addr, "/v1/jobs?limit=0"),
        ),
        (
            "bad state filter",
            400,
            "invalid_query",
            get(addr, "/v1/jobs?state=sleeping"),
        ),
        (
            "malformed upload",
            422,
            "invalid_scene",
            upload_glb(addr, b"glTF but not really a binary glTF file"),
        ),
        ("truncated upload", 422, "invalid_scene", {
            let glb = sample_glb("Box");
            upload_glb(addr, &glb[..glb.len() - 100])
        }),
        (
            "oversized upload",
            413,
            "payload_too_large",
            upload_glb(addr, &vec![0u8; 200 << 10]),
        ),
        (
            "upload of another type",
            415,
            "unsupported_media_type",
            request(
                addr,
                "POST",
                "/v1/scenes",
                &[("Content-Type", "application/json")],
                b"{}",
            ),
        ),
        (
            "upload with a texture too large to decode",
            422,
            "invalid_scene",
            upload_glb(addr, &glb_with_huge_texture()),
        ),
        (
            "upload naming an outside file",
            422,
            "invalid_scene",
            upload_glb(addr, &glb_with_external_buffer()),
        ),
    ];
    for (what, status, code, response) in &cases {
        assert_eq!(response.status, *status, "{what}: {}", response.text());
        assert_eq!(response.error_code(), *code, "{what}");
        assert_eq!(
            response.header("content-type"),
            Some("application/json"),
            "{what}"
        );
    }
    // The huge texture was refused from its header, before the importer saw it.
    let (_, _, _, huge) = cases.iter().find(|c| c.0.contains("texture")).unwrap();
    assert!(huge.text().contains("60000 x 60000"), "{}", huge.text());
    // Nothing was queued or stored by any of them, and the service still answers.
    let jobs = get(addr, "/v1/jobs").json();
    assert_eq!(jobs["total"], 0, "{jobs}");
    let scenes = get(addr, "/v1/scenes").json();
    assert!(
        scenes["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["source"] == "bundled")
    );
    assert_eq!(get(addr, "/healthz").json()["status"], "ok");

    // A job over the cost budget is refused with its estimate.
    let costly = post_json(
        addr,
        "/v1/jobs",
        &json!({"scene": "cornell-box", "tier": "reference", "width": 512, "height": 512,
                "spp": 4096, "frames": 256, "compare": false}),
    );
    assert_eq!(costly.status, 422, "{}", costly.text());
    assert_eq!(costly.error_code(), "job_too_costly");
    // 512 x 512 pixels x 4096 spp x 256 frames.
    assert!(costly.text().contains("2.749e11"), "{}", costly.text());
}

/// A GLB whose one image, in its binary chunk, is a PNG of one texel whose header claims
/// 60000 x 60000 (the service must refuse it from that alone).
fn glb_with_huge_texture() -> Vec<u8> {
    let texel = image::RgbaImage::from_pixel(1, 1, image::Rgba([1, 2, 3, 255]));
    let mut png = Vec::new();
    texel
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    // IHDR's width and height follow the signature, the chunk's length and its type; its
    // CRC-32 (over type and data) follows its 13 data bytes.
    png[16..20].copy_from_slice(&60_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&60_000u32.to_be_bytes());
    let mut crc = !0u32;
    for &byte in &png[12..29] {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    png[29..33].copy_from_slice(&(!crc).to_be_bytes());
    while !png.len().is_multiple_of(4) {
        png.push(0);
    }
    let mut json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{n}}}],"bufferViews":[{{"buffer":0,"byteLength":{n}}}],"images":[{{"bufferView":0,"mimeType":"image/png"}}]}}"#,
        n = png.len()
    )
    .into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(((20 + json.len() + 8 + png.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(json);
    glb.extend((png.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(png);
    glb
}

/// A GLB whose buffer points at a file outside the upload.
fn glb_with_external_buffer() -> Vec<u8> {
    let mut json = br#"{"asset":{"version":"2.0"},"buffers":[{"uri":"../../../../etc/hostname","byteLength":4}]}"#.to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(((20 + json.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(json);
    glb
}

#[test]
fn uploaded_scenes_are_validated_listed_and_rendered() {
    let server = TestServer::start(|c| c.no_gpu = true);
    let addr = server.addr;
    let glb = sample_glb("Box");
    let headers = [("Content-Type", "model/gltf-binary")];
    let response = request(
        addr,
        "POST",
        "/v1/scenes?name=Khronos%20Box",
        &headers,
        &glb,
    );
    assert_eq!(response.status, 201, "{}", response.text());
    let scene = response.json()["scene"].clone();
    let id = scene["id"].as_str().unwrap().to_string();
    assert!(id.starts_with("upload-"), "{id}");
    assert_eq!(scene["name"], "Khronos Box");
    assert_eq!(scene["bytes"], glb.len());
    assert_eq!(scene["triangles"], 12);
    // The same file again is the same scene.
    let again = request(addr, "POST", "/v1/scenes", &headers, &glb);
    assert_eq!(again.status, 200);
    assert_eq!(again.json()["scene"]["id"], id.as_str());

    let scenes = get(addr, "/v1/scenes").json();
    let listed: Vec<&str> = scenes["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert!(
        listed.contains(&"cornell-box") && listed.contains(&id.as_str()),
        "{listed:?}"
    );

    let job = submit(
        addr,
        &json!({"scene": id, "tier": "reference", "width": 16, "height": 12, "spp": 1, "compare": true, "reference_spp": 2}),
    );
    let job = wait_final(addr, &job, JOB_TIMEOUT);
    assert_eq!(job["state"], "done", "{job}");

    // The upload survives a restart of the service over the same data folder.
    let dir = server.stop();
    let data = dir.path().join("data");
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.data_dir = data;
    });
    let scenes = get(server.addr, "/v1/scenes").json();
    assert!(
        scenes["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["name"] == id.as_str())
    );
}

#[test]
fn cameras_jobs_pages_cancellation_and_metrics() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.reference_pool = 1;
    });
    let addr = server.addr;
    // Four cameras of the same frame (a second into the scene's camera path): the default
    // camera and the camera node it is, the path, and an explicit camera.
    let cameras = [
        json!("default"),
        json!("Camera"),
        json!("path"),
        json!({"position": [0.0, 1.0, 0.5], "target": [0.0, 1.0, -1.0], "fov_deg": 70.0}),
    ];
    let mut images = Vec::new();
    for camera in &cameras {
        let id = submit(
            addr,
            &json!({"scene": "dynamic", "tier": "direct", "width": 24, "height": 16, "spp": 1, "frames": 30, "camera": camera, "compare": false}),
        );
        let job = wait_final(addr, &id, JOB_TIMEOUT);
        assert_eq!(job["state"], "done", "{job}");
        assert_eq!(job["request"]["camera"], *camera);
        images.push(get(addr, &format!("/v1/jobs/{id}/image.png")).body);
    }
    assert_eq!(images[0], images[1]);
    assert_ne!(images[0], images[2]);
    assert_ne!(images[0], images[3]);
    assert_ne!(images[2], images[3]);

    // A long comparison: cancelled while it renders its reference.
    let long = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48, "spp": 1, "compare": true, "reference_spp": 4096}),
    );
    let running = wait_for(addr, &long, JOB_TIMEOUT, |job| {
        job["progress"]["stage"] == "reference"
    });
    assert_eq!(running["state"], "running");
    let fraction = running["progress"]["fraction"].as_f64().unwrap();
    assert!((0.5..1.0).contains(&fraction), "{running}");
    let queued = submit(addr, &small_job("reference", false));
    assert_eq!(
        get(addr, &format!("/v1/jobs/{queued}")).json()["state"],
        "queued"
    );
    let cancelled = delete(addr, &format!("/v1/jobs/{long}"));
    assert_eq!(cancelled.status, 200);
    assert_eq!(cancelled.json()["state"], "cancelled");
    // The pool is free again: the queued job runs, and the cancelled one stays cancelled.
    assert_eq!(wait_final(addr, &queued, JOB_TIMEOUT)["state"], "done");
    let job = get(addr, &format!("/v1/jobs/{long}")).json();
    assert_eq!(job["state"], "cancelled");
    assert_eq!(job["result"], Value::Null);
    assert_eq!(
        get(addr, &format!("/v1/jobs/{long}/image.png")).error_code(),
        "image_not_ready"
    );

    // Six jobs in all: pages of two, newest first, each job once.
    let page = get(addr, "/v1/jobs?limit=2").json();
    assert_eq!(page["total"], 6);
    let mut seen: Vec<u64> = Vec::new();
    let mut next = Some("/v1/jobs?limit=2".to_string());
    while let Some(url) = next {
        let page = get(addr, &url).json();
        for job in page["jobs"].as_array().unwrap() {
            seen.push(job["id"].as_str().unwrap().parse().unwrap());
        }
        next = page["next"].as_str().map(str::to_string);
    }
    assert_eq!(seen.len(), 6, "{seen:?}");
    assert!(seen.windows(2).all(|w| w[0] > w[1]), "{seen:?}");
    let only_cancelled = get(addr, "/v1/jobs?state=cancelled").json();
    assert_eq!(only_cancelled["total"], 1);
    assert_eq!(only_cancelled["jobs"][0]["id"], long.as_str());

    let metrics = get(addr, "/metrics");
    assert_eq!(metrics.status, 200);
    assert!(
        metrics
            .header("content-type")
            .unwrap()
            .starts_with("text/plain")
    );
    let text = metrics.text();
    for line in [
        "gi_queue_depth 0",
        "gi_jobs{state=\"done\"} 5",
        "gi_jobs{state=\"cancelled\"} 1",
        "gi_jobs_submitted_total 6",
        "gi_gpu_available 0",
        "gi_render_seconds_count{tier=\"direct\"} 4",
    ] {
        assert!(text.lines().any(|l| l == line), "no `{line}` in\n{text}");
    }
    assert!(text.contains("# TYPE gi_gpu_busy_seconds_total counter"));
}

#[test]
fn the_openapi_document_and_the_router_serve_the_same_routes() {
    let server = TestServer::start(|c| c.no_gpu = true);
    let addr = server.addr;
    let document = get(addr, "/openapi.json").json();
    assert_eq!(document["openapi"], "3.1.0");
    let mut documented: Vec<(String, String)> = Vec::new();
    for (path, item) in document["paths"].as_object().unwrap() {
        for method in item.as_object().unwrap().keys() {
            documented.push((path.clone(), method.to_uppercase()));
        }
    }
    let mut routed: Vec<(String, String)> = gi_server::ROUTES
        .iter()
        .flat_map(|(path, methods)| methods.iter().map(|m| (path.to_string(), m.to_string())))
        .collect();
    documented.sort();
    routed.sort();
    assert_eq!(documented, routed);

    // And the router really serves each of them (no fallback answer), and no other method.
    for (path, method) in &routed {
        let concrete = path.replace("{id}", "1");
        let response = request(
            addr,
            method,
            &concrete,
            &[("Content-Type", "application/json")],
            b"{}",
        );
        assert_ne!(response.status, 405, "{method} {path}");
        if response.status == 404 {
            assert_ne!(
                response.error_code(),
                "not_found",
                "{method} {path} is not routed"
            );
        }
        for other in ["GET", "POST", "PUT", "PATCH", "DELETE"] {
            if routed.contains(&(path.clone(), other.to_string())) {
                continue;
            }
            let response = request(addr, other, &concrete, &[], b"");
            assert_eq!(response.status, 405, "{other} {path}");
            assert_eq!(response.error_code(), "method_not_allowed");
        }
    }

    // The web page and its files are there.
    let page = get(addr, "/");
    assert!(
        page.header("content-type")
            .unwrap()
            .starts_with("text/html")
    );
    assert!(page.text().contains("/app.js"));
    assert!(get(addr, "/app.js").text().contains("/v1/jobs"));
}

//! The render service end to end, as a client uses it: the service is started in this process
//! from the `gi_server` library on a free loopback port, a scene built in code is exported
//! with gi-scene, packed into one `.glb` and uploaded, a render job compared against the
//! reference is submitted and polled until it is done, and its image, linear image, reference,
//! error map and FLIP map are downloaded. The reported errors (rmse_srgb8 and FLIP) must be the
//! ones computed here from the downloaded image and reference. `DELETE` cancels a running job
//! and deletes a finished one with its images, both checked.
//!
//! The client is a few lines of HTTP/1.1 over a TCP socket (`Connection: close`), as the
//! server's own tests use: no HTTP client crate in the workspace. The test needs no GPU: the
//! job asks for `auto`, which renders on whatever the service found (the CPU reference on a
//! software adapter or none).

mod common;

use std::{
    io::{Read, Write},
    net::{SocketAddr, TcpStream},
    path::Path,
    time::{Duration, Instant},
};

use gi_server::{Config, Server};
use serde_json::{Value, json};

const SIZE: (u32, u32) = (32, 24);
/// How long a small job may take, queue and reference included (a few seconds on 2 cores).
const JOB_DEADLINE: Duration = Duration::from_secs(120);
const POLL_INTERVAL: Duration = Duration::from_millis(20);

/// The service running in this process on a runtime of its own, with its data and reference
/// cache in a temporary folder; stopped when dropped.
struct Service {
    addr: SocketAddr,
    dir: tempfile::TempDir,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Service {
    fn start() -> Self {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let mut config = Config::with_data_dir(dir.path().join("data"));
        config.bind = "127.0.0.1:0".parse().expect("an address");
        // Not the user's reference cache: this test's references are its own.
        config.cache_dir = Some(dir.path().join("cache"));
        config.shutdown_grace_s = 10;
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .expect("a runtime");
            runtime.block_on(async move {
                let server = Server::start(config).await.expect("the service starts");
                addr_tx.send(server.local_addr()).expect("the test waits");
                let shutdown = async move {
                    let _ = stopped.await;
                };
                server.run(shutdown).await.expect("the service runs");
            });
        });
        let addr = addr_rx.recv().expect("the service started");
        Self {
            addr,
            dir,
            stop: Some(stop),
            thread: Some(thread),
        }
    }

    /// Stops the service gracefully and checks that it stopped without an error.
    fn stop(mut self) {
        let _ = self.stop.take().expect("running").send(());
        let stopped = self.thread.take().expect("running").join();
        assert!(stopped.is_ok(), "the service failed while stopping");
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// An HTTP response.
struct Response {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Response {
    fn header(&self, name: &str) -> Option<&str> {
        (self.headers.iter())
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("status {}: not JSON ({e}): {}", self.status, self.text()))
    }

    /// The body of a response that must have `status`.
    fn expect_status(self, status: u16, what: &str) -> Self {
        assert_eq!(self.status, status, "{what}: {}", self.text());
        self
    }
}

/// Sends one request (`Connection: close`) and reads the response to the end of the stream.
fn request(addr: SocketAddr, method: &str, path: &str, body: Option<(&str, &[u8])>) -> Response {
    let mut stream = TcpStream::connect(addr).expect("the service accepts");
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .expect("a timeout");
    let (content_type, body) = body.unwrap_or(("text/plain", b""));
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\
         Content-Type: {content_type}\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    stream
        .write_all(head.as_bytes())
        .expect("the request is sent");
    stream.write_all(body).expect("the body is sent");
    let mut raw = Vec::new();
    stream.read_to_end(&mut raw).expect("the response is read");
    let end = (raw.windows(4).position(|w| w == b"\r\n\r\n"))
        .unwrap_or_else(|| panic!("{method} {path}: no HTTP head in {raw:?}"));
    let head = String::from_utf8_lossy(&raw[..end]);
    let mut lines = head.split("\r\n");
    let status = (lines.next())
        .and_then(|line| line.split(' ').nth(1))
        .and_then(|code| code.parse().ok())
        .unwrap_or_else(|| panic!("{method} {path}: no status in {head}"));
    let headers = (lines.filter_map(|l| l.split_once(':')))
        .map(|(n, v)| (n.trim().to_string(), v.trim().to_string()))
        .collect();
    let mut response = Response {
        status,
        headers,
        body: raw[end + 4..].to_vec(),
    };
    if response.header("transfer-encoding") == Some("chunked") {
        response.body = dechunk(&response.body);
    }
    response
}

/// The data of a chunked body.
fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    while let Some(line_end) = data.windows(2).position(|w| w == b"\r\n") {
        let size = String::from_utf8_lossy(&data[..line_end]);
        let size = usize::from_str_radix(size.split(';').next().unwrap_or("").trim(), 16)
            .expect("a chunk size");
        if size == 0 {
            break;
        }
        let start = line_end + 2;
        body.extend_from_slice(&data[start..start + size]);
        data = &data[start + size + 2..];
    }
    body
}

fn get(addr: SocketAddr, path: &str) -> Response {
    request(addr, "GET", path, None)
}

/// Polls job `url` until it is done, failed or cancelled, within [`JOB_DEADLINE`].
fn wait_final(addr: SocketAddr, url: &str) -> Value {
    let started = Instant::now();
    loop {
        let job = get(addr, url).expect_status(200, url).json();
        if matches!(job["state"].as_str(), Some("done" | "failed" | "cancelled")) {
            return job;
        }
        assert!(
            started.elapsed() < JOB_DEADLINE,
            "{url} still {} after {JOB_DEADLINE:?}: {job}",
            job["state"]
        );
        std::thread::sleep(POLL_INTERVAL);
    }
}

/// The yard as one binary glTF, as a user uploads an asset: exported by gi-scene as `.gltf`,
/// `.bin` and a PNG per texture into `dir`, then packed with the buffer and the images in the
/// BIN chunk.
fn yard_glb(dir: &Path) -> Vec<u8> {
    let path = dir.join("yard.gltf");
    gi_scene::write_gltf(&common::yard(), &path).expect("the yard exports");
    let mut gltf: Value = serde_json::from_slice(&std::fs::read(&path).expect("the .gltf"))
        .expect("the export is JSON");
    let read = |uri: &Value| {
        let file = dir.join(uri.as_str().expect("a file name"));
        std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()))
    };
    let align = |bytes: &mut Vec<u8>, pad: u8| bytes.resize(bytes.len().next_multiple_of(4), pad);
    let mut bin = read(&gltf["buffers"][0]["uri"]);
    let images = gltf["images"]
        .as_array()
        .cloned()
        .expect("the yard is textured");
    for (i, image) in images.iter().enumerate() {
        let png = read(&image["uri"]);
        align(&mut bin, 0);
        let views = gltf["bufferViews"].as_array_mut().expect("buffer views");
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": png.len() }));
        gltf["images"][i] = json!({ "bufferView": views.len() - 1, "mimeType": "image/png" });
        bin.extend(png);
    }
    align(&mut bin, 0);
    gltf["buffers"][0] = json!({ "byteLength": bin.len() });
    let mut text = gltf.to_string().into_bytes();
    align(&mut text, b' ');
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((text.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(text);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(bin);
    glb
}

/// Downloads the PNG at `url`: its size and 8-bit RGB codes.
fn download_png(addr: SocketAddr, url: &str) -> ((u32, u32), Vec<u8>) {
    let response = get(addr, url).expect_status(200, url);
    assert_eq!(response.header("content-type"), Some("image/png"), "{url}");
    let decoded = image::load_from_memory_with_format(&response.body, image::ImageFormat::Png)
        .unwrap_or_else(|e| panic!("{url} does not decode: {e}"))
        .to_rgb8();
    (decoded.dimensions(), decoded.into_raw())
}

/// `rmse_srgb8` from 8-bit codes: the root of the mean squared difference over every channel.
fn rmse_of_codes(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let sum: u64 = (a.iter().zip(b))
        .map(|(&x, &y)| (i64::from(x) - i64::from(y)).pow(2) as u64)
        .sum();
    (sum as f64 / a.len() as f64).sqrt()
}

#[test]
fn a_client_uploads_a_scene_renders_compares_downloads_and_cancels() {
    let service = Service::start();
    let addr = service.addr;
    let health = get(addr, "/healthz").expect_status(200, "health").json();
    assert_eq!(health["status"], "ok", "{health}");

    // Upload: the scene gets an id that jobs name.
    let glb = yard_glb(service.dir.path());
    let upload = request(
        addr,
        "POST",
        "/v1/scenes?name=yard",
        Some(("model/gltf-binary", &glb)),
    );
    let scene = upload.expect_status(201, "upload").json()["scene"].clone();
    let scene_id = scene["id"].as_str().expect("an id").to_string();
    assert_eq!(scene["name"], "yard");
    assert_eq!(scene["bytes"], glb.len());
    assert_eq!(scene["triangles"], common::TRIANGLES);
    assert_eq!(scene["warnings"], json!([]), "{scene}");
    let listed = get(addr, "/v1/scenes").expect_status(200, "scenes").json();
    let entry = (listed["scenes"].as_array().expect("scenes").iter())
        .find(|s| s["name"] == scene_id.as_str())
        .unwrap_or_else(|| panic!("{scene_id} not listed: {listed}"));
    assert_eq!(entry["source"], "uploaded");

    // A job through the scene's own camera, compared against the reference as every job is
    // unless it says `"compare": false`.
    let job = json!({
        "scene": scene_id, "tier": "auto", "width": SIZE.0, "height": SIZE.1, "spp": 4,
        "warmup": 2, "seed": 5, "reference_spp": 16,
    });
    let body = job.to_string();
    let submitted = request(
        addr,
        "POST",
        "/v1/jobs",
        Some(("application/json", body.as_bytes())),
    )
    .expect_status(202, "submit");
    let url = submitted.json()["url"].as_str().expect("a url").to_string();
    assert_eq!(submitted.header("location"), Some(url.as_str()));
    let done = wait_final(addr, &url);
    assert_eq!(done["state"], "done", "{done}");
    let result = &done["result"];
    assert_eq!(
        (result["width"].as_u64(), result["height"].as_u64()),
        (Some(u64::from(SIZE.0)), Some(u64::from(SIZE.1)))
    );
    let tier = result["tier"].as_str().expect("the tier that rendered");
    assert!(tier.parse::<gi_tiers::TierKind>().is_ok(), "{result}");
    let comparison = &result["comparison"];
    assert_eq!(comparison["reference_spp"], 16, "{comparison}");
    let reported = comparison["rmse_srgb8"].as_f64().expect("rmse_srgb8");
    let reported_linear = comparison["rmse_linear"].as_f64().expect("rmse_linear");
    assert!(
        reported.is_finite() && reported_linear.is_finite(),
        "{comparison}"
    );

    // The images, by the links the job gives.
    let images = &done["images"];
    let link = |key: &str| {
        images[key]
            .as_str()
            .unwrap_or_else(|| panic!("no {key}: {done}"))
    };
    let (size, rendered) = download_png(addr, link("image_png"));
    assert_eq!(size, SIZE);
    let (size, reference) = download_png(addr, link("reference_png"));
    assert_eq!(size, SIZE);
    for map in ["error_png", "flip_png"] {
        let (size, _) = download_png(addr, link(map));
        assert_eq!(size, SIZE, "{map}");
    }
    // The reported error is the error between what was downloaded: the same 8-bit codes.
    let computed = rmse_of_codes(&rendered, &reference);
    assert!(
        (computed - reported).abs() <= 1e-9 * computed.max(1.0),
        "reported rmse_srgb8 {reported}, computed from the downloads {computed}"
    );
    // FLIP too: NVIDIA's FLIP of the downloaded 8-bit images.
    let reported_flip = comparison["flip"].as_f64().expect("flip");
    let decode = |codes: &[u8]| gi_image::tonemap::from_srgb8(SIZE.0, SIZE.1, codes).unwrap();
    let computed_flip = gi_image::flip_ldr(&decode(&rendered), &decode(&reference), 1.0)
        .unwrap()
        .mean;
    assert!(
        (computed_flip - reported_flip).abs() <= 1e-9,
        "reported flip {reported_flip}, computed from the downloads {computed_flip}"
    );
    println!(
        "{tier} on {}: rmse_srgb8 {reported:.3} (computed {computed:.3}), flip {reported_flip:.4} \
         (computed {computed_flip:.4}), rmse_linear {reported_linear:.4}",
        result["device"]
    );
    // Four samples per pixel against sixteen: noisy, yet the same picture.
    assert!(computed > 0.0 && computed < 40.0, "rmse_srgb8 {computed}");
    let mean_code = rendered.iter().map(|&c| f64::from(c)).sum::<f64>() / rendered.len() as f64;
    assert!(mean_code > 20.0, "a dark render: mean code {mean_code}");
    // The linear image is the same render: tonemapped, it gives the PNG's codes exactly.
    let exr = get(addr, link("image_exr")).expect_status(200, "image.exr");
    let exr_path = service.dir.path().join("image.exr");
    std::fs::write(&exr_path, &exr.body).expect("the download is saved");
    let linear = gi_image::read_exr(&exr_path).expect("the EXR decodes");
    assert_eq!(linear.size(), SIZE);
    assert_eq!(gi_image::to_srgb8(&linear, common::EXPOSURE), rendered);

    // A long comparison (its reference takes seconds) is cancelled while queued or running, and
    // stays so.
    let long = json!({
        "scene": scene_id, "tier": "reference", "width": 64, "height": 48, "spp": 1,
        "compare": true, "reference_spp": 4096,
    });
    let body = long.to_string();
    let submitted = request(
        addr,
        "POST",
        "/v1/jobs",
        Some(("application/json", body.as_bytes())),
    )
    .expect_status(202, "submit the long job");
    let long_url = submitted.json()["url"].as_str().expect("a url").to_string();
    let cancelled = request(addr, "DELETE", &long_url, None).expect_status(200, "cancel");
    assert_eq!(cancelled.json()["state"], "cancelled");
    let job = wait_final(addr, &long_url);
    assert_eq!(job["state"], "cancelled", "{job}");
    assert_eq!(job["result"], Value::Null);
    let image = get(addr, &format!("{long_url}/image.png")).expect_status(404, "a cancelled image");
    assert_eq!(image.json()["error"]["code"], "image_not_ready");

    let jobs = get(addr, "/v1/jobs")
        .expect_status(200, "the job list")
        .json();
    assert_eq!(jobs["total"], 2, "{jobs}");

    // A finished job is deleted with its images; the list no longer has it.
    let deleted = request(addr, "DELETE", &url, None).expect_status(200, "delete a finished job");
    assert_eq!(deleted.json()["deleted"], true);
    assert_eq!(deleted.json()["state"], "done");
    get(addr, &url).expect_status(404, "a deleted job");
    get(addr, link("image_png")).expect_status(404, "a deleted job's image");
    let jobs = get(addr, "/v1/jobs")
        .expect_status(200, "the job list")
        .json();
    assert_eq!(jobs["total"], 1, "{jobs}");
    service.stop();
}

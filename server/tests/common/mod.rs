//! What the service's tests share: a small HTTP/1.1 client over a plain TCP socket (it sends
//! any bytes, malformed ones included), a server started in-process on a free loopback port
//! or as the `gi-server` binary, and polling helpers.

#![allow(dead_code)] // each test binary uses its own part

pub mod browser;

use std::{
    ffi::OsStr,
    io::{BufRead, BufReader, Read, Write},
    net::{SocketAddr, TcpStream},
    path::PathBuf,
    process::{Child, Command, ExitStatus, Stdio},
    time::{Duration, Instant},
};

use gi_server::{Config, Server};
use serde_json::Value;

/// An HTTP response.
#[derive(Debug)]
pub struct Response {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Response {
    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body).unwrap_or_else(|e| {
            panic!(
                "status {}: body is not JSON ({e}): {}",
                self.status,
                String::from_utf8_lossy(&self.body)
            )
        })
    }

    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }

    /// The error code of a `{ "error": { "code", "message" } }` answer, after checking its
    /// shape and that the message says something.
    pub fn error_code(&self) -> String {
        let body = self.json();
        let message = body["error"]["message"].as_str().unwrap_or("");
        assert!(!message.is_empty(), "error without a message: {body}");
        body["error"]["code"]
            .as_str()
            .unwrap_or_else(|| panic!("not an error answer: {body}"))
            .to_string()
    }
}

/// Sends one request (`Connection: close`, and `Host: <addr>` unless `headers` has a Host)
/// and reads the whole response.
pub fn request(
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> Response {
    let mut stream = TcpStream::connect(addr).expect("connect");
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    let mut head = format!("{method} {path} HTTP/1.1\r\n");
    if !headers
        .iter()
        .any(|(name, _)| name.eq_ignore_ascii_case("host"))
    {
        head.push_str(&format!("Host: {addr}\r\n"));
    }
    head.push_str(&format!(
        "Connection: close\r\nContent-Length: {}\r\n",
        body.len()
    ));
    for (name, value) in headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes()).unwrap();
    // The server may answer (413) before reading a large body and close: not an error here.
    let _ = stream.write_all(body);
    read_response(&mut stream)
}

/// Reads one response: up to its Content-Length, its last chunk, or the end of the stream
/// (peers such as chromedriver keep the connection open despite `Connection: close`).
pub fn read_response(stream: &mut TcpStream) -> Response {
    let mut raw = Vec::new();
    let mut buffer = [0u8; 16 << 10];
    loop {
        if let Some(end) = raw.windows(4).position(|w| w == b"\r\n\r\n") {
            let response = parse_response(&raw);
            let body_bytes = raw.len() - (end + 4);
            let complete = match response.header("content-length") {
                Some(length) => body_bytes >= length.parse::<usize>().unwrap_or(0),
                None if response.header("transfer-encoding").is_some() => {
                    raw.ends_with(b"0\r\n\r\n")
                }
                None => false,
            };
            if complete {
                return response;
            }
        }
        match stream.read(&mut buffer) {
            Ok(0) | Err(_) => return parse_response(&raw),
            Ok(n) => raw.extend_from_slice(&buffer[..n]),
        }
    }
}

fn parse_response(raw: &[u8]) -> Response {
    let end = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("no HTTP head in {:?}", String::from_utf8_lossy(raw)));
    let head = String::from_utf8_lossy(&raw[..end]);
    let mut lines = head.split("\r\n");
    let status: u16 = lines
        .next()
        .and_then(|l| l.split(' ').nth(1))
        .and_then(|s| s.parse().ok())
        .expect("status line");
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim().to_string(), v.trim().to_string()))
        .collect();
    let mut body = raw[end + 4..].to_vec();
    let chunked = headers.iter().any(|(n, v)| {
        n.eq_ignore_ascii_case("transfer-encoding") && v.eq_ignore_ascii_case("chunked")
    });
    if chunked {
        body = dechunk(&body);
    }
    Response {
        status,
        headers,
        body,
    }
}

fn dechunk(mut data: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    loop {
        let Some(line_end) = data.windows(2).position(|w| w == b"\r\n") else {
            return body;
        };
        let size_text = String::from_utf8_lossy(&data[..line_end]);
        let size =
            usize::from_str_radix(size_text.split(';').next().unwrap().trim(), 16).unwrap_or(0);
        if size == 0 {
            return body;
        }
        let start = line_end + 2;
        body.extend_from_slice(&data[start..start + size]);
        data = &data[start + size + 2..];
    }
}

pub fn get(addr: SocketAddr, path: &str) -> Response {
    request(addr, "GET", path, &[], b"")
}

pub fn delete(addr: SocketAddr, path: &str) -> Response {
    request(addr, "DELETE", path, &[], b"")
}

pub fn post_json(addr: SocketAddr, path: &str, body: &Value) -> Response {
    request(
        addr,
        "POST",
        path,
        &[("Content-Type", "application/json")],
        body.to_string().as_bytes(),
    )
}

/// Uploads `body` to `/v1/scenes` as a binary glTF.
pub fn upload_glb(addr: SocketAddr, body: &[u8]) -> Response {
    request(
        addr,
        "POST",
        "/v1/scenes",
        &[("Content-Type", "model/gltf-binary")],
        body,
    )
}

/// Submits a job, asserting it was accepted; its id.
pub fn submit(addr: SocketAddr, job: &Value) -> String {
    let response = post_json(addr, "/v1/jobs", job);
    assert_eq!(response.status, 202, "{job}: {}", response.text());
    let body = response.json();
    let id = body["id"].as_str().expect("id").to_string();
    assert_eq!(body["url"], format!("/v1/jobs/{id}"));
    assert_eq!(
        response.header("location"),
        Some(format!("/v1/jobs/{id}").as_str())
    );
    id
}

/// Polls job `id` until it is done, failed or cancelled.
pub fn wait_final(addr: SocketAddr, id: &str, timeout: Duration) -> Value {
    wait_for(addr, id, timeout, |job| {
        matches!(job["state"].as_str(), Some("done" | "failed" | "cancelled"))
    })
}

/// Polls job `id` until `done` says so.
pub fn wait_for(
    addr: SocketAddr,
    id: &str,
    timeout: Duration,
    done: impl Fn(&Value) -> bool,
) -> Value {
    let started = Instant::now();
    loop {
        let response = get(addr, &format!("/v1/jobs/{id}"));
        assert_eq!(response.status, 200, "{}", response.text());
        let job = response.json();
        if done(&job) {
            return job;
        }
        assert!(
            started.elapsed() < timeout,
            "job {id} still {} after {timeout:?}: {job}",
            job["state"]
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A configuration for tests: a free loopback port, data and reference cache in `dir`.
pub fn test_config(dir: &std::path::Path) -> Config {
    let mut config = Config::with_data_dir(dir.join("data"));
    config.bind = "127.0.0.1:0".parse().unwrap();
    config.cache_dir = Some(dir.join("cache"));
    config.shutdown_grace_s = 10;
    config
}

/// A service running in this process on its own runtime; stopped when dropped.
pub struct TestServer {
    pub addr: SocketAddr,
    dir: Option<tempfile::TempDir>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl TestServer {
    /// Starts a service with [`test_config`] changed by `configure`.
    pub fn start(configure: impl FnOnce(&mut Config)) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let mut config = test_config(dir.path());
        configure(&mut config);
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .unwrap();
            runtime.block_on(async move {
                let server = Server::start(config).await.expect("server starts");
                addr_tx.send(server.local_addr()).unwrap();
                server
                    .run(async move {
                        let _ = stopped.await;
                    })
                    .await
                    .expect("server runs");
            });
        });
        let addr = addr_rx.recv().expect("server started");
        Self {
            addr,
            dir: Some(dir),
            stop: Some(stop),
            thread: Some(thread),
        }
    }

    /// The folder holding the data and cache folders.
    pub fn path(&self) -> &std::path::Path {
        self.dir.as_ref().expect("running").path()
    }

    pub fn cache_dir(&self) -> PathBuf {
        self.path().join("cache")
    }

    /// Stops the service gracefully and hands over its folder (kept until dropped).
    pub fn stop(mut self) -> tempfile::TempDir {
        self.shut_down();
        self.dir.take().expect("running")
    }

    fn shut_down(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for TestServer {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// Width and height from a PNG's IHDR chunk, after checking the signature.
pub fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 24, "too short for a PNG");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |o: usize| u32::from_be_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    (be(16), be(20))
}

/// A small .glb from the Khronos samples the scene crate tests with.
pub fn sample_glb(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../crates/gi-scene/tests/data/gltf-samples")
        .join(name)
        .join("glTF-Binary")
        .join(format!("{name}.glb"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The `gi-server` binary, killed if the test ends without stopping it.
pub struct ServerProcess(pub Child);

impl Drop for ServerProcess {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl std::ops::Deref for ServerProcess {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for ServerProcess {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

/// The `gi-server` binary on a free port in its embedded mode (no database), its data and
/// reference cache in `dir`, with `extra` flags; the process and its address.
pub fn spawn_embedded<S: AsRef<OsStr>>(
    dir: &std::path::Path,
    extra: impl IntoIterator<Item = S>,
) -> (ServerProcess, std::net::SocketAddr) {
    let mut args: Vec<std::ffi::OsString> = vec!["--bind".into(), "127.0.0.1:0".into()];
    args.extend(extra.into_iter().map(|arg| arg.as_ref().to_os_string()));
    args.extend([
        "--data-dir".into(),
        dir.join("data").into(),
        "--cache-dir".into(),
        dir.join("cache").into(),
    ]);
    spawn_server(args)
}

/// Starts the `gi-server` binary with `args`; the process and the address it prints once
/// listening.
pub fn spawn_server(
    args: impl IntoIterator<Item = impl AsRef<OsStr>>,
) -> (ServerProcess, SocketAddr) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gi-server"))
        .args(args)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("gi-server starts");
    let stdout = child.stdout.take().unwrap();
    let child = ServerProcess(child);
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).unwrap();
    let addr = line
        .trim()
        .strip_prefix("gi-server listening on http://")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
        .parse()
        .unwrap();
    (child, addr)
}

/// Waits for the process to exit; fails after `timeout`.
pub fn wait_exit(child: &mut ServerProcess, timeout: Duration) -> ExitStatus {
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        assert!(started.elapsed() < timeout, "gi-server did not exit");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The value of the sample `series` (name and labels exactly as exposed) in a `/metrics` text.
pub fn metric(text: &str, series: &str) -> Option<f64> {
    text.lines()
        .find_map(|line| line.strip_prefix(series)?.strip_prefix(' ')?.parse().ok())
}

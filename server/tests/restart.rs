//! The real `gi-server` binary killed with SIGKILL mid-job and started again over the same data
//! folder: finished results are still served byte for byte, queued jobs are still queued, the
//! interrupted job runs again, and nothing is lost. Then SIGTERM stops it gracefully.

mod common;

use std::{
    io::{BufRead, BufReader},
    net::SocketAddr,
    path::Path,
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

use common::*;
use serde_json::json;

/// The server process, killed if the test ends without stopping it.
struct ServerProcess(Child);

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

/// Starts the binary on a free port over `dir`; the process and its address (read from the
/// line it prints once listening).
fn start(dir: &Path) -> (ServerProcess, SocketAddr) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gi-server"))
        .args(["--bind", "127.0.0.1:0", "--no-gpu", "--reference-pool", "1"])
        .arg("--data-dir")
        .arg(dir.join("data"))
        .arg("--cache-dir")
        .arg(dir.join("cache"))
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

fn wait_exit(child: &mut ServerProcess, timeout: Duration) -> std::process::ExitStatus {
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        assert!(started.elapsed() < timeout, "gi-server did not exit");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_killed_server_loses_no_job_and_a_terminated_one_stops_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let (mut server, addr) = start(dir.path());

    let small =
        json!({"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12, "spp": 1});
    let finished = submit(addr, &small);
    assert_eq!(
        wait_final(addr, &finished, Duration::from_secs(60))["state"],
        "done"
    );
    let image = get(addr, &format!("/v1/jobs/{finished}/image.png")).body;
    let record = get(addr, &format!("/v1/jobs/{finished}")).json();

    // A comparison whose reference takes a few seconds, and two jobs queued behind it.
    let interrupted = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 32, "height": 24, "spp": 1,
                "compare": true, "reference_spp": 4096}),
    );
    let queued: Vec<String> = (0..2).map(|_| submit(addr, &small)).collect();
    wait_for(addr, &interrupted, Duration::from_secs(60), |job| {
        job["progress"]["stage"] == "reference"
    });
    for id in &queued {
        assert_eq!(
            get(addr, &format!("/v1/jobs/{id}")).json()["state"],
            "queued"
        );
    }

    server.kill().unwrap(); // SIGKILL: no chance to save anything
    server.wait().unwrap();

    let (mut server, addr) = start(dir.path());
    // A second service cannot take the same data folder.
    let second = Command::new(env!("CARGO_BIN_EXE_gi-server"))
        .args(["--bind", "127.0.0.1:0", "--no-gpu", "--data-dir"])
        .arg(dir.path().join("data"))
        .output()
        .unwrap();
    assert!(!second.status.success());
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(
        stderr.contains("another gi-server is using this data folder"),
        "{stderr}"
    );
    // The finished job is served as it was.
    let again = get(addr, &format!("/v1/jobs/{finished}")).json();
    assert_eq!(again, record);
    assert_eq!(
        get(addr, &format!("/v1/jobs/{finished}/image.png")).body,
        image
    );
    // Every other job runs to the end; the interrupted one a second time.
    let job = wait_final(addr, &interrupted, Duration::from_secs(120));
    assert_eq!(job["state"], "done", "{job}");
    assert_eq!(job["attempts"], 2);
    assert_eq!(job["result"]["comparison"]["reference_spp"], 4096);
    for id in &queued {
        let job = wait_final(addr, id, Duration::from_secs(60));
        assert_eq!(job["state"], "done", "{job}");
        assert_eq!(job["attempts"], 1);
    }
    let all = get(addr, "/v1/jobs").json();
    assert_eq!(all["total"], 4);

    // SIGTERM while a job runs: the server stops within its grace period and exits cleanly;
    // the job is queued again, not lost and not counted as a failed start.
    let long = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48, "spp": 1,
                "compare": true, "reference_spp": 4096}),
    );
    wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["progress"]["stage"] == "reference"
    });
    let status = Command::new("kill")
        .args(["-TERM", &server.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = wait_exit(&mut server, Duration::from_secs(20));
    assert!(exit.success(), "{exit:?}");

    let (mut server, addr) = start(dir.path());
    let job = get(addr, &format!("/v1/jobs/{long}")).json();
    assert!(
        matches!(job["state"].as_str(), Some("queued" | "running")),
        "{job}"
    );
    assert_eq!(delete(addr, &format!("/v1/jobs/{long}")).status, 200);
    server.kill().unwrap();
    server.wait().unwrap();
}

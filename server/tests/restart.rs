//! The real `gi-server` binary killed with SIGKILL mid-job and started again over the same data
//! folder: finished results are still served byte for byte, queued jobs are still queued, the
//! interrupted job runs again, and nothing is lost. Then SIGTERM stops it gracefully, within
//! its grace period even while a render that cannot be interrupted still runs.

mod common;

use std::{
    net::SocketAddr,
    path::Path,
    process::Command,
    time::{Duration, Instant},
};

use common::*;
use serde_json::json;

/// Starts the binary on a free port over `dir` with `extra` flags; the process and its
/// address.
fn start(dir: &Path, extra: &[&str]) -> (ServerProcess, SocketAddr) {
    let cpu_only = ["--no-gpu", "--reference-pool", "1"];
    spawn_embedded(dir, cpu_only.iter().chain(extra))
}

#[test]
fn a_killed_server_loses_no_job_and_a_terminated_one_stops_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let (mut server, addr) = start(dir.path(), &[]);

    let small = json!({"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12, "spp": 1, "compare": false});
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

    let (mut server, addr) = start(dir.path(), &[]);
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

    let (mut server, addr) = start(dir.path(), &[]);
    let job = get(addr, &format!("/v1/jobs/{long}")).json();
    assert!(
        matches!(job["state"].as_str(), Some("queued" | "running")),
        "{job}"
    );
    assert_eq!(delete(addr, &format!("/v1/jobs/{long}")).status, 200);
    server.kill().unwrap();
    server.wait().unwrap();
}

#[test]
fn a_terminated_server_exits_within_its_grace_while_a_render_cannot_stop() {
    let dir = tempfile::tempdir().unwrap();
    let grace_s = 1;
    let (mut server, addr) = start(
        dir.path(),
        &[
            "--shutdown-grace-s",
            &grace_s.to_string(),
            "--max-spp",
            "1048576",
        ],
    );
    // The reference tier renders all of a frame's samples in one call that checks for no
    // stop: hours at this many samples.
    let long = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48,
                "spp": 1 << 20}),
    );
    wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["progress"]["stage"] == "frames"
    });
    let signalled = Instant::now();
    let status = Command::new("kill")
        .args(["-TERM", &server.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = wait_exit(&mut server, Duration::from_secs(30));
    let took = signalled.elapsed();
    assert!(exit.success(), "{exit:?}");
    assert!(
        took < Duration::from_secs(grace_s + 3),
        "exited {took:?} after SIGTERM with a grace of {grace_s} s"
    );

    // The job was queued again on disk before the exit, its interrupted start not counted.
    let (_server, addr) = start(dir.path(), &["--max-spp", "1048576"]);
    let job = get(addr, &format!("/v1/jobs/{long}")).json();
    assert!(
        matches!(job["state"].as_str(), Some("queued" | "running")),
        "{job}"
    );
    assert!(job["attempts"].as_u64().unwrap_or(0) <= 1, "{job}");
    assert_eq!(delete(addr, &format!("/v1/jobs/{long}")).status, 200);
}

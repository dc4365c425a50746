//! `gi-bench churn` in a tiny mode: renderers created one after another on one shared device.

mod common;

use std::process::Command;

use common::gi_bench_json;
use gi_gpu::GpuContext;

#[test]
fn churn_benchmark_creates_renderer_after_renderer() {
    if GpuContext::new_or_skip("churn_benchmark_creates_renderer_after_renderer").is_none() {
        return;
    }
    let (stdout, report) = gi_bench_json(
        &[
            "churn",
            "--tier",
            "pc",
            "--rounds",
            "3",
            "--size",
            "32x24",
            "--frames",
            "1",
            "--sharing",
            "shared",
        ],
        "gi-bench-churn.json",
    );
    assert!(stdout.contains("all 3 rounds completed"), "{stdout}");
    assert_eq!(report["sharing"], "shared");
    assert_eq!(report["completed"], 3);
    assert!(report["failure"].is_null(), "{report}");
    let rounds = report["rounds"].as_array().expect("rounds");
    assert_eq!(rounds.len(), 3);
    for round in rounds {
        let create = round["create_ms"].as_f64().expect("create_ms");
        assert!(create.is_finite() && create > 0.0, "{round}");
        // The GPU's passes run inside the frames' wall-clock time: each frame waits for them.
        let (wall, gpu) = (
            round["frames_ms"].as_f64().expect("frames_ms"),
            round["gpu_ms"].as_f64().expect("gpu_ms"),
        );
        assert!(gpu > 0.0 && gpu <= wall, "{round}");
    }
    assert!(stdout.contains("a frame: GPU passes (ms)"), "{stdout}");

    let bad = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args(["churn", "--sharing", "sometimes"])
        .output()
        .expect("gi-bench starts");
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("auto, shared or dedicated"), "{stderr}");
}

//! `gi-bench path` in a tiny mode, so the benchmark keeps building and running in CI.

use std::process::Command;

use gi_gpu::GpuContext;

#[test]
fn path_benchmark_runs_and_writes_json() {
    // The benchmark needs an adapter; this skips loudly (or fails under GI_REQUIRE_GPU) first.
    if GpuContext::new_or_skip("path_benchmark_runs_and_writes_json").is_none() {
        return;
    }
    let json = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("gi-bench-path.json");
    let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args([
            "path", "--scene", "atrium", "--width", "16", "--height", "8", "--spp", "1",
            "--frames", "2",
        ])
        .arg("--json")
        .arg(&json)
        .output()
        .expect("gi-bench starts");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "gi-bench failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("| path/trace |"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("JSON written"))
            .expect("JSON parses");
    assert_eq!(report["width"], 16);
    let rate = report["samples_per_second"].as_f64().expect("rate");
    assert!(rate.is_finite() && rate > 0.0, "{rate}");
}

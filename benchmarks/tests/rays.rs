//! `gi-bench rays` in a tiny mode, so the benchmark keeps building and running in CI.

use std::process::Command;

use gi_gpu::GpuContext;

#[test]
fn rays_benchmark_runs_and_writes_json() {
    // The benchmark needs an adapter; this skips loudly (or fails under GI_REQUIRE_GPU) first.
    if GpuContext::new_or_skip("rays_benchmark_runs_and_writes_json").is_none() {
        return;
    }
    let json = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("gi-bench-rays.json");
    let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args([
            "rays",
            "--scene",
            "cornell-box",
            "--rays",
            "500",
            "--repeats",
            "1",
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
    assert!(
        stdout.contains("| incoherent | closest | 500 |"),
        "{stdout}"
    );

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("JSON written"))
            .expect("JSON parses");
    let kinds = report["kinds"].as_array().expect("kinds");
    let names: Vec<_> = kinds.iter().map(|k| k["kind"].as_str().unwrap()).collect();
    assert_eq!(names, ["primary", "shadow", "incoherent"]);
    for kind in kinds {
        assert_eq!(kind["rays"], 500);
        for rate in ["gpu_mrays_per_s", "cpu_mrays_per_s"] {
            let value = kind[rate].as_f64().expect(rate);
            assert!(value.is_finite() && value > 0.0, "{rate} = {value}");
        }
    }
}

/// The animated scene runs over the two-level structure with an instance per moving node and
/// reports the per-frame top-level update.
#[test]
fn rays_benchmark_reports_the_dynamic_scene_update() {
    if GpuContext::new_or_skip("rays_benchmark_reports_the_dynamic_scene_update").is_none() {
        return;
    }
    let json = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("gi-bench-rays-dyn.json");
    let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args([
            "rays",
            "--scene",
            "dynamic",
            "--rays",
            "200",
            "--repeats",
            "2",
        ])
        .arg("--json")
        .arg(&json)
        .output()
        .expect("gi-bench starts");
    assert!(
        output.status.success(),
        "gi-bench failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("JSON written"))
            .expect("JSON parses");
    assert!(report["instances"].as_u64().expect("instances") > 1);
    let update = report["update_ms"].as_f64().expect("update_ms");
    assert!(update.is_finite() && update > 0.0, "update_ms = {update}");
}

//! `gi-bench rays` in a tiny mode, so the benchmark keeps building and running in CI.

mod common;

use common::gi_bench_json;
use gi_gpu::GpuContext;

#[test]
fn rays_benchmark_runs_and_writes_json() {
    // The benchmark needs an adapter; this skips loudly (or fails under GI_REQUIRE_GPU) first.
    if GpuContext::new_or_skip("rays_benchmark_runs_and_writes_json").is_none() {
        return;
    }
    let (stdout, report) = gi_bench_json(
        &[
            "rays",
            "--scene",
            "cornell-box",
            "--rays",
            "500",
            "--repeats",
            "1",
        ],
        "gi-bench-rays.json",
    );
    assert!(
        stdout.contains("| incoherent | closest | 500 |"),
        "{stdout}"
    );

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
    let (_, report) = gi_bench_json(
        &[
            "rays",
            "--scene",
            "dynamic",
            "--rays",
            "200",
            "--repeats",
            "2",
        ],
        "gi-bench-rays-dyn.json",
    );
    assert!(report["instances"].as_u64().expect("instances") > 1);
    let update = report["update_ms"].as_f64().expect("update_ms");
    assert!(update.is_finite() && update > 0.0, "update_ms = {update}");
}

//! `gi-bench path` in a tiny mode, so the benchmark keeps building and running in CI.

mod common;

use common::gi_bench_json;
use gi_gpu::GpuContext;

#[test]
fn path_benchmark_runs_and_writes_json() {
    // The benchmark needs an adapter; this skips loudly (or fails under GI_REQUIRE_GPU) first.
    if GpuContext::new_or_skip("path_benchmark_runs_and_writes_json").is_none() {
        return;
    }
    let (stdout, report) = gi_bench_json(
        &[
            "path", "--scene", "atrium", "--width", "16", "--height", "8", "--spp", "1",
            "--frames", "2",
        ],
        "gi-bench-path.json",
    );
    assert!(stdout.contains("| path/trace |"), "{stdout}");
    assert_eq!(report["width"], 16);
    let rate = report["samples_per_second"].as_f64().expect("rate");
    assert!(rate.is_finite() && rate > 0.0, "{rate}");
}

//! `gi-bench cache-update` in a tiny mode, so the benchmark keeps building and running in CI.

mod common;

use common::gi_bench_json;
use gi_gpu::GpuContext;

#[test]
fn cache_update_benchmark_runs_and_writes_json() {
    // The benchmark needs an adapter; this skips loudly (or fails under GI_REQUIRE_GPU) first.
    if GpuContext::new_or_skip("cache_update_benchmark_runs_and_writes_json").is_none() {
        return;
    }
    // A small pool and few levels keep the lighting passes short on a software adapter; the
    // G-buffer is tiny.
    let (stdout, report) = gi_bench_json(
        &[
            "cache-update",
            "--scene",
            "cornell-box",
            "--frames",
            "3",
            "--levels",
            "2",
            "--pool-bricks",
            "256",
            "--screen-inject",
            "--size",
            "16x8",
        ],
        "gi-bench-cache-update.json",
    );
    assert!(stdout.contains("| cache/propagate |"), "{stdout}");
    assert_eq!(report["frames"], 3);
    assert_eq!(report["config"]["levels"], 2);
    // The fill frame voxelizes the whole box, and screen injection skips bricks voxelized in
    // the same update: it runs from the second frame on.
    let fill = &report["fill"]["passes_ms"];
    let steady = &report["steady"]["passes_ms"];
    for (passes, names) in [
        (
            fill,
            &["cache/voxelize", "cache/inject", "cache/propagate"][..],
        ),
        (
            steady,
            &["cache/screen_inject", "cache/inject", "cache/propagate"][..],
        ),
    ] {
        for pass in names {
            let ms = passes[pass]
                .as_f64()
                .unwrap_or_else(|| panic!("{pass} in {passes}"));
            assert!(ms.is_finite() && ms >= 0.0, "{pass}: {ms}");
        }
    }
    let allocated = report["bricks"]["allocated"].as_u64().expect("allocated");
    assert!(allocated > 0 && allocated <= 256, "{allocated}");
    let cache_bytes = report["memory"]["cache_bytes"].as_u64().expect("bytes");
    let lighting_bytes = report["memory"]["lighting_bytes"].as_u64().expect("bytes");
    assert!(lighting_bytes > 0 && cache_bytes > lighting_bytes);
    let frames = report["per_frame"].as_array().expect("per-frame rows");
    assert_eq!(frames.len(), 3);
    assert!(
        frames[0]["scheduled"]["new"].as_u64().unwrap() > 0,
        "{}",
        frames[0]
    );
}

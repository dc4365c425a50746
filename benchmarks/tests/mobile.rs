//! `gi-bench mobile` and `gi-bench stability` (`mobile-stability`, and `--tier pc`) in a tiny
//! mode, so they keep building and running in CI.

mod common;

use std::process::Command;

use common::gi_bench_json;
use gi_gpu::GpuContext;

#[test]
fn mobile_benchmark_reports_gi_passes_and_memory() {
    if GpuContext::new_or_skip("mobile_benchmark_reports_gi_passes_and_memory").is_none() {
        return;
    }
    // The smallest bundled scene twice, by name and from its glTF file: the code path is under
    // test here (scenes named either way, both probe modes, the clock settling), not the
    // figures, and every scene costs the software adapter 16 frames of clock settling per mode.
    let gltf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf");
    let scenes = format!("cornell-box,{}", gltf.display());
    let (stdout, report) = gi_bench_json(
        &[
            "mobile",
            "--scenes",
            &scenes,
            "--size",
            "32x24",
            "--warmup",
            "2",
            "--frames",
            "3",
            "--screen-probes",
            "both",
            "--settle-s",
            "0.001",
        ],
        "gi-bench-mobile.json",
    );
    assert!(
        stdout.contains("| **GI (cache/* + mobile/*)** |"),
        "{stdout}"
    );
    assert!(stdout.contains("the 32 MB bar"), "{stdout}");
    assert_eq!(report["frames"], 3);
    assert_eq!(report["warmup"], 2);
    assert_eq!(report["settle_s"], 0.001);
    let runs = report["runs"].as_array().expect("runs");
    // Both scenes in both modes, in the order given.
    let keys: Vec<(String, String)> = runs
        .iter()
        .map(|r| {
            (
                r["scene"].as_str().unwrap().to_owned(),
                r["screen_probes"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    let expected = [
        ("cornell-box", "hsgi"),
        ("cornell-box", "smartgi"),
        ("cornell-box", "hsgi"),
        ("cornell-box", "smartgi"),
    ]
    .map(|(s, m)| (s.to_owned(), m.to_owned()));
    assert_eq!(keys, expected);
    for run in runs {
        let passes = run["passes_ms"].as_object().expect("passes");
        let gi: f64 = passes
            .iter()
            .filter(|(name, _)| name.starts_with("cache/") || name.starts_with("mobile/"))
            .map(|(_, ms)| ms.as_f64().unwrap())
            .sum();
        let all: f64 = passes.values().map(|ms| ms.as_f64().unwrap()).sum();
        assert!(gi > 0.0, "{run}");
        assert!(
            (run["gi_ms"].as_f64().unwrap() - gi).abs() <= 1e-9 * gi,
            "{run}"
        );
        let other = run["other_ms"].as_f64().unwrap();
        assert!((gi + other - all).abs() <= 1e-9 * all, "{run}");
        // The per-frame GI spread is ordered, and the clock settling rendered whole
        // 16-frame windows (at 0.001 s, one window, or two when the first was fast).
        let spread = |q: &str| run["gi_spread_ms"][q].as_f64().unwrap();
        assert!(
            0.0 < spread("p10") && spread("p10") <= spread("median"),
            "{run}"
        );
        assert!(spread("median") <= spread("p90"), "{run}");
        // Both frame loops ran: waiting for each frame and pipelined.
        for field in ["waiting_ms", "pipelined_ms", "pipelined_gi_ms"] {
            let ms = run["frame_wall"][field]
                .as_f64()
                .unwrap_or_else(|| panic!("{field}"));
            assert!(ms > 0.0, "{run}");
        }
        let settled = run["settle"]["frames"].as_u64().unwrap();
        assert!(settled >= 16 && settled % 16 == 0, "{run}");
        let memory = &run["memory"];
        let bytes = |field: &str| memory[field].as_u64().unwrap_or_else(|| panic!("{field}"));
        assert!(
            bytes("coverage_bytes") > 0 && bytes("screen_bytes") > 0,
            "{memory}"
        );
        assert_eq!(
            bytes("gi_bytes"),
            bytes("coverage_bytes") + bytes("screen_bytes")
        );
    }
}

#[test]
fn mobile_stability_benchmark_reports_flicker_and_settle() {
    if GpuContext::new_or_skip("mobile_stability_benchmark_reports_flicker_and_settle").is_none() {
        return;
    }
    let (stdout, report) = gi_bench_json(
        &[
            "mobile-stability",
            "--size",
            "32x24",
            "--warmup",
            "2",
            "--frames",
            "2",
            "--path-scene",
            "cornell-box",
            "--settle-scene",
            "thin-wall",
            "--settle-frames",
            "11",
            "--converged-frames",
            "2",
            "--clock-settle-s",
            "0",
        ],
        "gi-bench-stability.json",
    );
    assert!(stdout.contains("settle frames"), "{stdout}");
    let runs = report["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 1);
    let run = &runs[0];
    assert_eq!(run["screen_probes"], "hsgi");
    let cases: Vec<&str> = run["flicker"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["case"].as_str().unwrap())
        .collect();
    assert_eq!(cases, ["still", "animated", "camera path"]);
    for case in run["flicker"].as_array().unwrap() {
        // Most of the still camera's pixels see static walls; the path moves slowly.
        assert!(case["pixels"].as_u64().unwrap() > 0, "{case}");
        let change = case["mean_abs_change"].as_f64().unwrap();
        assert!(change.is_finite() && change >= 0.0, "{case}");
        assert!(case["mean_luminance"].as_f64().unwrap() > 0.0, "{case}");
    }
    let settle = &run["settle"];
    assert_eq!(settle["scene"], "thin-wall");
    // Eleven frames after the turn, the last two converged: nine errors. The floor is taken
    // over errors 5 (the middle) to 5 (four before the converged window): the fifth.
    let errors: Vec<f64> = settle["errors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_f64().unwrap())
        .collect();
    assert_eq!(errors.len(), 9);
    assert_eq!(settle["floor"].as_f64(), Some(errors[4]), "{settle}");
    let to_floor = settle["floor_frames"].as_u64().unwrap() as usize;
    assert!((1..=5).contains(&to_floor), "{settle}");
    assert!(
        errors[..to_floor - 1].iter().all(|&e| e > errors[4]),
        "{settle}"
    );
    let noise = settle["noise"].as_f64().unwrap();
    assert!(
        (settle["threshold"].as_f64().unwrap() - 2.0 * noise).abs() <= 1e-12,
        "{settle}"
    );
    assert!(settle["light_change"].as_f64().unwrap() > 0.0, "{settle}");
    assert!(
        settle["converged_drift"].as_f64().unwrap() >= 0.0,
        "{settle}"
    );
    // The GI time of every frame after the turn, and its summaries.
    let cost = &settle["cost_ms"];
    assert_eq!(cost["clock_settle"]["frames"], 0, "{cost}");
    let after: Vec<f64> = cost["after"]
        .as_array()
        .unwrap()
        .iter()
        .map(|ms| ms.as_f64().unwrap())
        .collect();
    assert_eq!(after.len(), 11, "{cost}");
    assert!(after.iter().all(|&ms| ms > 0.0), "{cost}");
    let peak = cost["peak"].as_f64().unwrap();
    assert_eq!(peak, after.iter().copied().fold(0.0, f64::max), "{cost}");
    assert!(cost["before"].as_f64().unwrap() > 0.0, "{cost}");
    // Through the last frame above the baseline's 110%: null when the last frame still is.
    let before = cost["before"].as_f64().unwrap();
    match cost["elevated_frames"].as_u64() {
        Some(n) => {
            let n = n as usize;
            assert!(n < after.len(), "{cost}");
            assert!(after[n..].iter().all(|&ms| ms <= 1.1 * before), "{cost}");
            assert!(n == 0 || after[n - 1] > 1.1 * before, "{cost}");
        }
        None => assert!(after[after.len() - 1] > 1.1 * before, "{cost}"),
    }
    // The first unbroken run above it ends no later than the last frame above it.
    match (
        cost["relight_frames"].as_u64(),
        cost["elevated_frames"].as_u64(),
    ) {
        (Some(relit), Some(elevated)) => assert!(relit <= elevated, "{cost}"),
        (Some(relit), None) => assert!((relit as usize) < after.len(), "{cost}"),
        (None, elevated) => assert!(elevated.is_none(), "{cost}"),
    }
    // Medians of frames after the turn: within them.
    for field in ["first_after", "converged"] {
        let ms = cost[field].as_f64().unwrap();
        assert!(ms > 0.0 && ms <= peak, "{field}: {cost}");
    }
    assert!(
        stdout.contains("| mobile hsgi | thin-wall | none |"),
        "{stdout}"
    );
}

#[test]
fn mobile_benchmarks_reject_bad_input_clearly() {
    let run = |args: &[&str]| {
        let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
            .args(args)
            .output()
            .expect("gi-bench starts");
        assert!(!output.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let err = run(&["mobile", "--screen-probes", "lumen"]);
    assert!(
        err.contains("unknown screen-probe mode `lumen` (expected hsgi, smartgi or both)"),
        "{err}"
    );
    let err = run(&["mobile-stability", "--size", "0x3"]);
    assert!(err.contains("WIDTHxHEIGHT"), "{err}");
    let err = run(&[
        "mobile-stability",
        "--settle-frames",
        "4",
        "--converged-frames",
        "4",
    ]);
    assert!(err.contains("--converged-frames"), "{err}");
    let err = run(&["stability", "--tier", "pc", "--screen-probes", "hsgi"]);
    assert!(
        err.contains("--screen-probes applies to the mobile tier only"),
        "{err}"
    );
    // Settle scenes that cannot settle, refused when loaded (before the flicker cases render).
    let err = run(&["stability", "--settle-scene", "cornell-box"]);
    assert!(
        err.contains("cornell-box has no punctual light to turn"),
        "{err}"
    );
    let err = run(&["stability", "--settle-scene", "dynamic"]);
    assert!(err.contains("dynamic is animated"), "{err}");
    let err = run(&["stability", "--tier", "path"]);
    assert!(
        err.contains("'path'") && err.contains("mobile, pc"),
        "{err}"
    );
    for bad in ["-1", "61", "NaN", "soon"] {
        let err = run(&["pc", &format!("--settle-s={bad}")]);
        assert!(
            err.contains(&format!("expected seconds within 0..=60, not `{bad}`")),
            "{err}"
        );
    }
}

#[test]
fn pc_stability_benchmark_reports_flicker_and_settle() {
    if GpuContext::new_or_skip("pc_stability_benchmark_reports_flicker_and_settle").is_none() {
        return;
    }
    let (stdout, report) = gi_bench_json(
        &[
            "stability",
            "--tier",
            "pc",
            "--size",
            "24x16",
            "--warmup",
            "1",
            "--frames",
            "2",
            "--path-scene",
            "cornell-box",
            "--settle-scene",
            "atrium",
            "--settle-frames",
            "4",
            "--converged-frames",
            "2",
            "--clock-settle-s",
            "0",
        ],
        "gi-bench-pc-stability.json",
    );
    assert!(stdout.contains("| pc | still | dynamic |"), "{stdout}");
    let runs = report["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 1);
    let run = &runs[0];
    assert_eq!(run["tier"], "pc");
    assert!(run["screen_probes"].is_null(), "{run}");
    for case in run["flicker"].as_array().unwrap() {
        assert!(case["pixels"].as_u64().unwrap() > 0, "{case}");
        let change = case["mean_abs_change"].as_f64().unwrap();
        assert!(change.is_finite() && change >= 0.0, "{case}");
    }
    let settle = &run["settle"];
    assert_eq!(settle["scene"], "atrium");
    // Four frames after the turn, the last two converged: two errors.
    assert_eq!(settle["errors"].as_array().unwrap().len(), 2);
    assert!(settle["light_change"].as_f64().unwrap() > 0.0, "{settle}");
}

/// `--change move`: cornell-box's tall block slides away after the warm-up, and the settle
/// figures are taken over the pixels it leaves (its trail), where the GI changed most.
#[test]
fn a_moved_node_is_measured_over_the_pixels_it_leaves() {
    if GpuContext::new_or_skip("a_moved_node_is_measured_over_the_pixels_it_leaves").is_none() {
        return;
    }
    let strip_dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("stability-strips");
    let (stdout, report) = gi_bench_json(
        &[
            "stability",
            "--size",
            "32x24",
            "--warmup",
            "2",
            "--no-flicker",
            "--settle-scene",
            "cornell-box",
            "--change",
            "move",
            "--move-node",
            "Tall block",
            "--settle-frames",
            "8",
            "--converged-frames",
            "2",
            "--clock-settle-s",
            "0",
            "--strip-dir",
            strip_dir.to_str().unwrap(),
        ],
        "gi-bench-move.json",
    );
    assert!(stdout.contains("node 'Tall block' moved away"), "{stdout}");
    // The contact strip: before, 1, 2, 4 and 8 frames after and converged, each 320 pixels
    // wide with 10 between, under two lines of text.
    let strip = image::open(strip_dir.join("cornell-box-move-mobile-hsgi.png"))
        .expect("the strip")
        .to_rgb8();
    assert_eq!(strip.dimensions(), (6 * 330 + 10, 50 + 240 + 10));
    assert_eq!(report["settle_options"]["change"], "move");
    assert_eq!(report["settle_options"]["move_node"], "Tall block");
    let settle = &report["runs"][0]["settle"];
    // The block's own GI gave way to the floor's and the back wall's behind it.
    assert!(settle["light_change"].as_f64().unwrap() > 0.0, "{settle}");
    assert_eq!(settle["errors"].as_array().unwrap().len(), 6, "{settle}");

    // A move needs a node that exists.
    let refused = |node: &[&str]| {
        let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
            .args([
                "stability",
                "--settle-scene",
                "cornell-box",
                "--change",
                "move",
            ])
            .args(node)
            .output()
            .expect("gi-bench starts");
        assert!(!output.status.success(), "{node:?} succeeded");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let err = refused(&[]);
    assert!(err.contains("--change move needs --move-node"), "{err}");
    let err = refused(&["--move-node", "Piano"]);
    assert!(
        err.contains("cornell-box has no node 'Piano'") && err.contains("Tall block"),
        "{err}"
    );
}

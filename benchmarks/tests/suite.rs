//! The benchmark suite (`gi-bench` without a subcommand) in a tiny mode: one scene, every
//! tier, 40x30, so it keeps building and running in CI; then its regression check against the
//! first run and against a baseline edited to claim a better tier.

use std::{
    path::{Path, PathBuf},
    process::{Command, Output},
};

use gi_gpu::GpuContext;
use serde_json::Value;

const TIERS: [&str; 5] = ["reference", "direct", "path", "mobile", "pc"];

/// Runs the suite on the Cornell box at 40x30 into `out`, with `extra` arguments.
fn suite(out: &Path, cache: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args([
            "--scenes",
            "cornell-box",
            "--size",
            "40x30",
            "--frames",
            "2",
            "--warmup",
            "2",
            "--repeats",
            "2",
            "--reference-spp",
            "16",
        ])
        .arg("--cache-dir")
        .arg(cache)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("gi-bench starts")
}

fn text(output: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("results.json written"))
        .expect("results.json parses")
}

/// Decodes the PNG at `path` and returns its size.
fn png_size(path: &Path) -> (u32, u32) {
    let image = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (image.width(), image.height())
}

fn finite(value: &Value, what: &str) -> f64 {
    let number = value
        .as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {value}"));
    assert!(number.is_finite(), "{what} = {number}");
    number
}

fn cell<'a>(results: &'a Value, tier: &str) -> &'a Value {
    results["cells"]
        .as_array()
        .expect("cells")
        .iter()
        .find(|c| c["tier"] == tier)
        .unwrap_or_else(|| panic!("no {tier} cell"))
}

#[test]
fn suite_measures_every_tier_and_flags_regressions() {
    if GpuContext::new_or_skip("suite_measures_every_tier_and_flags_regressions").is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("temporary folder");
    let cache = dir.path().join("cache");
    let first: PathBuf = dir.path().join("first");

    let output = suite(&first, &cache, &[]);
    assert!(output.status.success(), "{}", text(&output));
    let results = read_json(&first.join("results.json"));
    check_results(&results);
    check_markdown(&std::fs::read_to_string(first.join("results.md")).expect("results.md"));
    check_pictures(&first);
    assert!(
        String::from_utf8_lossy(&output.stdout).contains("| cornell-box | pc |"),
        "the table is printed: {}",
        text(&output)
    );

    // The same run again against the first: the reference now comes from the cache, seeded
    // renders give the same errors and the memory is deterministic, so neither is flagged.
    // Times are noisy: with two repeats per run the rule still flags about one comparison in
    // forty of identical timings, so a flagged time is only checked to follow the rule.
    let second = dir.path().join("second");
    let baseline = first.join("results.json");
    let output = suite(
        &second,
        &cache,
        &[
            "--baseline",
            baseline.to_str().unwrap(),
            "--fail-on-regression",
        ],
    );
    let again = read_json(&second.join("results.json"));
    assert_eq!(again["references"][0]["cached"], true, "{}", text(&output));
    let comparison = &again["regressions"];
    assert!(
        comparison["compared"].as_u64().unwrap() >= 3 * TIERS.len() as u64,
        "{comparison}"
    );
    for flag in comparison["flagged"].as_array().expect("flagged") {
        assert_eq!(flag["metric"], "ms_per_frame", "{flag}");
        let increase = finite(&flag["new_mean"], "new") - finite(&flag["old_mean"], "old");
        let (old_sd, new_sd) = (finite(&flag["old_sd"], "sd"), finite(&flag["new_sd"], "sd"));
        assert!(increase > 3.0 * old_sd.hypot(new_sd), "{flag}");
    }
    let timings_only = comparison["flagged"].as_array().unwrap().is_empty();
    assert_eq!(output.status.success(), timings_only, "{}", text(&output));
    assert!(
        std::fs::read_to_string(second.join("results.md"))
            .unwrap()
            .contains("## Regressions against"),
    );

    // A baseline claiming `direct` was ten times as accurate and far faster: flagged, and
    // --fail-on-regression fails the run.
    let mut edited = results.clone();
    let direct = edited["cells"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|c| c["tier"] == "direct")
        .unwrap();
    for (metric, factor) in [("rmse_srgb8", 0.1), ("flip", 0.1), ("ms_per_frame", 1e-6)] {
        let mean = direct[metric]["mean"].as_f64().unwrap();
        direct[metric]["mean"] = (mean * factor).into();
        direct[metric]["sd"] = 0.0.into();
    }
    let edited_path = dir.path().join("edited.json");
    std::fs::write(&edited_path, serde_json::to_string(&edited).unwrap()).unwrap();
    let third = dir.path().join("third");
    let output = suite(
        &third,
        &cache,
        &[
            "--tiers",
            "direct",
            "--baseline",
            edited_path.to_str().unwrap(),
            "--fail-on-regression",
        ],
    );
    assert!(!output.status.success(), "{}", text(&output));
    let flagged = read_json(&third.join("results.json"))["regressions"]["flagged"].clone();
    assert!(
        flagged
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f["tier"] == "direct" && f["metric"] == "rmse_srgb8"),
        "{flagged}"
    );
    assert!(
        flagged
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f["tier"] == "direct" && f["metric"] == "flip"),
        "{flagged}"
    );
    assert!(
        text(&output).contains("cornell-box/direct rmse_srgb8:"),
        "the flagged line is printed: {}",
        text(&output)
    );
}

fn check_results(results: &Value) {
    for field in ["commit", "date"] {
        assert!(
            !results[field].as_str().unwrap_or_default().is_empty(),
            "{field}: {results}"
        );
    }
    let date = results["date"].as_str().unwrap();
    assert!(
        date.len() == 20 && &date[10..11] == "T" && date.ends_with('Z'),
        "{date}"
    );
    let adapter = &results["adapter"];
    for field in ["name", "device_type", "driver", "driver_info"] {
        assert!(adapter[field].is_string(), "adapter {field}: {adapter}");
    }
    assert!(!adapter["name"].as_str().unwrap().is_empty());
    assert!(results["cpu_count"].as_u64().unwrap() >= 1);
    assert_eq!(results["options"]["repeats"], 2);
    assert_eq!(
        results["failures"].as_array().unwrap().len(),
        0,
        "{results}"
    );
    assert_eq!(results["references"][0]["cached"], false);
    // `--reference-engine auto`: the CPU, or the GPU path tier on a hardware adapter.
    assert_eq!(results["options"]["reference_engine"], "auto");
    let engine = results["references"][0]["engine"].as_str().unwrap();
    assert!(engine == "cpu" || engine.starts_with("gpu: "), "{engine}");

    let tiers: Vec<&str> = results["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["tier"].as_str().unwrap())
        .collect();
    assert_eq!(tiers, TIERS);
    for tier in TIERS {
        let cell = cell(results, tier);
        assert_eq!(cell["repeats"], 2, "{cell}");
        assert!(cell["error"].is_null(), "{cell}");
        for metric in [
            "rmse_srgb8",
            "flip",
            "rmse_linear",
            "ms_per_frame",
            "memory_bytes",
        ] {
            let stat = &cell[metric];
            finite(&stat["mean"], metric);
            finite(&stat["sd"], metric);
            assert_eq!(
                stat["values"].as_array().unwrap().len(),
                2,
                "{tier} {metric}"
            );
        }
        let rmse = finite(&cell["rmse_srgb8"]["mean"], "rmse");
        assert!((0.0..255.0).contains(&rmse), "{tier} rmse {rmse}");
        let flip = finite(&cell["flip"]["mean"], "flip");
        assert!((0.0..1.0).contains(&flip), "{tier} flip {flip}");
        assert!(!cell["passes_ms"].as_array().unwrap().is_empty(), "{cell}");
        finite(&cell["gain_vs_direct"]["mean"], "gain");
    }
    // Each repeat divides by its own direct error.
    assert_eq!(cell(results, "direct")["gain_vs_direct"]["mean"], 1.0);
    for tier in ["mobile", "pc"] {
        let cell = cell(results, tier);
        assert_eq!(cell["warmup"], 2, "{cell}");
        let gi = finite(&cell["gi_ms"]["mean"], "gi_ms");
        assert!(gi <= finite(&cell["ms_per_frame"]["mean"], "ms") + 1e-9);
        assert!(cell["memory_bytes"]["mean"].as_f64().unwrap() > 0.0);
    }
    assert!(cell(results, "path")["gi_ms"].is_null());
}

fn check_markdown(markdown: &str) {
    for needle in [
        "| scene | tier | rmse_srgb8 | flip | gain_vs_direct | ms/frame | GI ms | memory MB |",
        "| cornell-box | mobile |",
        "## Per-pass cost",
        "### pc",
        "| pass | cornell-box |",
        "| **frame** |",
    ] {
        assert!(
            markdown.contains(needle),
            "results.md lacks {needle:?}:\n{markdown}"
        );
    }
}

fn check_pictures(out: &Path) {
    assert_eq!(png_size(&out.join("error_vs_time.png")), (1300, 720));
    for tier in ["path", "mobile", "pc"] {
        let (w, h) = png_size(&out.join(format!("passes_{tier}.png")));
        assert!(w >= 640 && h >= 560, "passes_{tier}.png is {w}x{h}");
    }
    // Five rows of four 320x240 thumbnails (image, reference, error, FLIP) with their labels.
    let sheet = image::open(out.join("contact_cornell-box.png"))
        .expect("contact sheet decodes")
        .to_rgb8();
    assert_eq!(sheet.width(), 4 * 320 + 5 * 10);
    assert!(sheet.height() >= 5 * 240, "{}", sheet.height());
    // The reference column of the first row holds the image, not the white background.
    let non_white = (0..240)
        .flat_map(|y| (0..320).map(move |x| (340 + x, 64 + y)))
        .filter(|&(x, y)| sheet.get_pixel(x, y).0 != [255, 255, 255])
        .count();
    assert!(non_white > 320 * 240 / 2, "{non_white} pixels drawn");
    for tier in TIERS {
        let images = out.join("images");
        assert_eq!(
            png_size(&images.join(format!("cornell-box_{tier}.png"))),
            (40, 30)
        );
        for map in ["error", "flip"] {
            assert_eq!(
                png_size(&images.join(format!("cornell-box_{tier}_{map}.png"))),
                (40, 30)
            );
        }
    }
    // The FLIP column of the first row holds the map: magma is dark where the error is low,
    // never the white background.
    let flip_column = (0..240)
        .flat_map(|y| (0..320).map(move |x| (3 * 330 + 10 + x, 64 + y)))
        .filter(|&(x, y)| sheet.get_pixel(x, y).0 != [255, 255, 255])
        .count();
    assert_eq!(flip_column, 320 * 240, "the FLIP map fills its column");
    assert_eq!(
        png_size(&out.join("images/cornell-box_reference.png")),
        (40, 30)
    );
}

#[test]
fn an_unknown_reference_engine_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let output = suite(
        &dir.path().join("out"),
        &dir.path().join("cache"),
        &["--reference-engine", "vulkan"],
    );
    assert!(!output.status.success());
    let text = text(&output);
    assert!(
        text.contains("vulkan") && text.contains("auto, gpu or cpu"),
        "{text}"
    );
    assert!(!dir.path().join("out/results.json").exists());
}

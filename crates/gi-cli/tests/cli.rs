//! End-to-end tests of the `gi` command: real renders at small sizes, and bad input that must
//! exit non-zero with a clear one-line error.

use std::{path::Path, process::Command};

fn gi(args: &[&str], cwd: &Path) -> std::process::Output {
    gi_with_env(args, cwd, &[])
}

/// `gi` with the variables `env` set as well.
fn gi_with_env(
    args: &[&str],
    cwd: &Path,
    env: &[(&str, &std::ffi::OsStr)],
) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gi"))
        .args(args)
        .current_dir(cwd)
        // Keep the reference cache inside the test's folder.
        .env("GI_CACHE_DIR", cwd.join("cache"))
        .envs(env.iter().copied())
        .env_remove("RUST_LOG")
        .output()
        .expect("gi runs")
}

fn stderr(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Asserts a failure whose message is one `error:` line containing `needle`.
fn assert_fails_with(output: &std::process::Output, needle: &str) {
    let err = stderr(output);
    assert!(!output.status.success(), "expected failure, got success");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got:\n{err}");
    assert!(lines[0].starts_with("error"), "not an error line: {err}");
    assert!(
        lines[0].contains(needle),
        "error does not mention '{needle}': {err}"
    );
}

#[test]
fn scenes_lists_every_bundled_scene() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(&["scenes"], dir.path());
    assert!(output.status.success(), "{}", stderr(&output));
    let text = String::from_utf8_lossy(&output.stdout);
    for (name, _) in gi_scene::BUNDLED_SCENES {
        assert!(text.contains(name), "{name} missing from:\n{text}");
    }
}

#[test]
fn render_writes_png_exr_and_stats() {
    let dir = tempfile::tempdir().unwrap();
    for (tier, file) in [("reference", "ref.exr"), ("direct", "direct.png")] {
        let output = gi(
            &[
                "render",
                "cornell-box",
                "--tier",
                tier,
                "--width",
                "24",
                "--height",
                "16",
                "--spp",
                "2",
                "--out",
                file,
                "--stats",
                "stats.json",
            ],
            dir.path(),
        );
        assert!(output.status.success(), "{}", stderr(&output));
        let image = gi_image::load(dir.path().join(file)).unwrap();
        assert_eq!((image.width, image.height), (24, 16));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
        assert_eq!(stats["tier"], tier);
        assert_eq!(stats["spp"], 2);
        assert!(stats["samples_per_second"].as_f64().unwrap() > 0.0);
        assert!(stats["rays_per_second"].as_f64().unwrap() > 0.0);
    }
}

#[test]
fn render_with_the_gpu_path_tier_reports_its_passes() {
    if gi_gpu::GpuContext::new_or_skip("render_with_the_gpu_path_tier").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--tier",
            "path",
            "--width",
            "24",
            "--height",
            "16",
            "--spp",
            "2",
            "--out",
            "path.png",
            "--stats",
            "stats.json",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let image = gi_image::load(dir.path().join("path.png")).unwrap();
    assert_eq!((image.width, image.height), (24, 16));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["tier"], "path");
    assert!(stats["passes"]["path/trace"].is_number(), "{stats}");
    assert!(stats["samples_per_second"].as_f64().unwrap() > 0.0);
    assert!(stats["rays_per_second"].as_f64().unwrap() > 0.0);
    assert!(stats["memory_bytes"].as_u64().unwrap() > 0);
}

#[test]
fn compare_writes_table_json_and_reuses_cached_reference() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "compare",
        "cornell-box",
        "--tiers",
        "direct,reference",
        "--width",
        "16",
        "--height",
        "12",
        "--spp",
        "4",
        "--reference-spp",
        "16",
        "--out-dir",
        "cmp",
    ];
    let first = gi(&args, dir.path());
    assert!(first.status.success(), "{}", stderr(&first));
    let table = String::from_utf8_lossy(&first.stdout);
    assert!(
        table.contains("rmse_srgb8")
            && table.contains(" flip ")
            && table.contains("gain_vs_direct"),
        "{table}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cmp/compare.json")).unwrap())
            .unwrap();
    assert_eq!(json["scene"], "cornell-box");
    assert_eq!(json["reference"]["spp"], 16);
    assert_eq!(json["reference"]["cached"], false);
    // Auto: the CPU, or the GPU path tier on a hardware adapter; the header names it.
    let engine = json["reference"]["engine"].as_str().unwrap();
    assert!(engine == "cpu" || engine.starts_with("gpu: "), "{engine}");
    assert!(table.contains(engine), "{table}");
    let tiers = json["tiers"].as_array().unwrap();
    assert_eq!(tiers.len(), 2);
    let direct = &tiers[0];
    assert_eq!(direct["tier"], "direct");
    // The direct tier is its own baseline.
    assert!((direct["gain_vs_direct"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    for tier in tiers {
        for field in [
            "rmse_srgb8",
            "flip",
            "rmse_linear",
            "ms_per_frame",
            "memory_bytes",
        ] {
            assert!(tier[field].is_number(), "{field} missing in {tier}");
        }
        let flip = tier["flip"].as_f64().unwrap();
        assert!(0.0 < flip && flip < 1.0, "flip {flip} in {tier}");
        assert!(tier["passes"].is_object());
    }
    // FLIP, like rmse_srgb8, finds direct lighting further from the reference than a path
    // tracer.
    assert!(tiers[1]["flip"].as_f64().unwrap() < direct["flip"].as_f64().unwrap());
    for file in [
        "reference_16spp.exr",
        "reference_16spp.png",
        "reference.png",
        "direct.png",
        "reference_error.png",
        "reference_flip.png",
        "direct_flip.png",
    ] {
        assert!(dir.path().join("cmp").join(file).is_file(), "{file}");
    }
    // In the Cornell box all light on the walls is indirect: the path tracer must be much
    // closer to the reference than direct lighting is.
    assert!(tiers[1]["gain_vs_direct"].as_f64().unwrap() < 1.0);

    let second = gi(&args, dir.path());
    assert!(second.status.success(), "{}", stderr(&second));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cmp/compare.json")).unwrap())
            .unwrap();
    assert_eq!(json["reference"]["cached"], true);
}

#[test]
fn the_reference_engine_is_chosen_recorded_and_checked() {
    let dir = tempfile::tempdir().unwrap();
    let compare = |engine: &str| {
        let args = [
            "compare",
            "cornell-box",
            "--tiers",
            "direct",
            "--width",
            "8",
            "--height",
            "6",
            "--spp",
            "1",
            "--reference-spp",
            "4",
            "--out-dir",
            "cmp",
            "--reference-engine",
            engine,
        ];
        let output = gi(&args, dir.path());
        assert!(output.status.success(), "{}", stderr(&output));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("cmp/compare.json")).unwrap())
                .unwrap();
        let reference = &json["reference"];
        (
            reference["engine"].as_str().unwrap().to_string(),
            reference["cached"].as_bool().unwrap(),
        )
    };
    assert_eq!(compare("cpu"), ("cpu".to_string(), false));
    assert_eq!(compare("cpu"), ("cpu".to_string(), true));
    // Auto takes the CPU's reference whatever it would render with.
    assert_eq!(compare("auto"), ("cpu".to_string(), true));

    let bad = gi(&["compare", "--reference-engine", "vulkan"], dir.path());
    let err = stderr(&bad);
    assert!(!bad.status.success());
    assert!(
        err.contains("vulkan") && err.contains("auto, gpu or cpu"),
        "{err}"
    );

    if gi_gpu::GpuContext::new_or_skip("the_reference_engine_on_the_gpu").is_none() {
        return;
    }
    // An explicit GPU choice renders its own on any adapter (lavapipe too), then finds it.
    let (engine, cached) = compare("gpu");
    assert!(engine.starts_with("gpu: ") && !cached, "{engine}");
    assert_eq!(compare("gpu"), (engine.clone(), true));
    assert_eq!(compare("auto"), (engine, true));
    assert_eq!(compare("cpu"), ("cpu".to_string(), false));
}

#[test]
fn missing_scene_file_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &["render", "nowhere/scene.gltf", "--out", "a.png"],
        dir.path(),
    );
    assert_fails_with(&output, "nowhere/scene.gltf");
}

#[test]
fn unknown_scene_name_lists_the_bundled_ones() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(&["render", "no-such-scene", "--out", "a.png"], dir.path());
    assert_fails_with(&output, "cornell-box");
}

#[test]
fn malformed_gltf_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("broken.gltf"), "{ this is not json").unwrap();
    let output = gi(&["render", "broken.gltf", "--out", "a.png"], dir.path());
    assert_fails_with(&output, "broken.gltf");
}

#[test]
fn unknown_tier_lists_the_available_ones() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &["render", "cornell-box", "--tier", "ultra", "--out", "a.png"],
        dir.path(),
    );
    let err = stderr(&output);
    assert!(!output.status.success());
    assert!(err.contains("ultra") && err.contains("reference"), "{err}");
}

#[test]
fn zero_and_huge_sizes_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, value, needle) in [
        ("--width", "0", "--width 0"),
        ("--height", "100000", "--height 100000"),
        ("--spp", "0", "--spp 0"),
        ("--frames", "0", "--frames 0"),
    ] {
        let output = gi(
            &["render", "cornell-box", flag, value, "--out", "a.png"],
            dir.path(),
        );
        assert_fails_with(&output, needle);
    }
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--width",
            "16384",
            "--height",
            "16384",
            "--out",
            "a.png",
        ],
        dir.path(),
    );
    assert_fails_with(&output, "pixels");
    assert!(!dir.path().join("a.png").exists());
}

#[test]
fn unsupported_output_format_is_rejected_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(&["render", "cornell-box", "--out", "a.bmp"], dir.path());
    assert_fails_with(&output, "a.bmp");
}

#[test]
fn debug_cache_writes_the_view_and_reports_the_cache() {
    if gi_gpu::GpuContext::new_or_skip("debug_cache_writes_the_view_and_reports_the_cache")
        .is_none()
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "debug-cache",
            "cornell-box",
            "--view",
            "occupancy",
            "--size",
            "32x24",
            "--frames",
            "1",
            "--out",
            "occupancy.png",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("bricks") && stdout.contains("MiB"),
        "{stdout}"
    );
    let image = gi_image::load(dir.path().join("occupancy.png")).unwrap();
    assert_eq!((image.width, image.height), (32, 24));
    // The camera looks into the box: most pixels see its voxels (the rest look past its open
    // front edges into empty space).
    let seen = image
        .enumerate_pixels()
        .filter(|(_, _, p)| p.max_element() > 0.0)
        .count();
    assert!(seen * 2 >= 32 * 24, "{seen} of {} pixels hit", 32 * 24);
}

/// A pool too small for the scene's bricks: the cache warns once, naming the setting, and the
/// report counts what was left out; an absurd pool size is refused before anything runs.
#[test]
fn a_full_cache_pool_warns_once_and_bad_pool_sizes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (args, value) in [
        (&["render", "cornell-box", "--tier", "mobile"][..], "0"),
        (&["render", "cornell-box", "--tier", "pc"][..], "99999999"),
        (&["debug-cache", "cornell-box"][..], "0"),
    ] {
        let flag = if args[0] == "debug-cache" {
            "--pool-bricks"
        } else {
            "--cache-pool-bricks"
        };
        let mut all = args.to_vec();
        all.extend([flag, value, "--out", "a.png"]);
        let output = gi(&all, dir.path());
        assert_fails_with(&output, "pool_bricks");
        assert!(!dir.path().join("a.png").exists());
    }
    if gi_gpu::GpuContext::new_or_skip("a_full_cache_pool_warns_once").is_none() {
        return;
    }
    let output = gi(
        &[
            "debug-cache",
            "cornell-box",
            "--size",
            "16x12",
            "--frames",
            "2",
            "--pool-bricks",
            "8",
            "--out",
            "occupancy.png",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let err = stderr(&output);
    assert_eq!(err.matches("pool of 8 bricks is full").count(), 1, "{err}");
    assert!(err.contains("CacheConfig::pool_bricks"), "{err}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let dropped = stdout
        .lines()
        .find_map(|l| l.strip_prefix("dropped"))
        .and_then(|rest| rest.split_whitespace().next()?.parse::<u32>().ok())
        .expect("a dropped line");
    assert!(dropped > 0, "{stdout}");
}

#[test]
fn debug_cache_lights_the_cache_on_the_gpu() {
    if gi_gpu::GpuContext::new_or_skip("debug_cache_lights_the_cache_on_the_gpu").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "debug-cache",
            "cornell-box",
            "--view",
            "irradiance",
            "--size",
            "32x24",
            "--frames",
            "3",
            "--out",
            "irradiance.png",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("cache/inject") && stdout.contains("cache/propagate"),
        "{stdout}"
    );
    // The ceiling light reaches every wall within one update (emitters are sampled directly),
    // so most of the voxels the camera sees hold light.
    let image = gi_image::load(dir.path().join("irradiance.png")).unwrap();
    let lit = image
        .enumerate_pixels()
        .filter(|(_, _, p)| p.max_element() > 0.0)
        .count();
    assert!(lit * 2 >= 32 * 24, "{lit} of {} pixels lit", 32 * 24);
}

#[test]
fn debug_cache_rejects_unknown_views_and_scenes_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &["debug-cache", "cornell-box", "--view", "albedos"],
        dir.path(),
    );
    assert_fails_with(&output, "unknown cache debug view `albedos`");
    let output = gi(
        &["debug-cache", "no-such-scene", "--view", "albedo"],
        dir.path(),
    );
    assert_fails_with(&output, "no-such-scene");
    let output = gi(
        &["debug-cache", "cornell-box", "--size", "0x10"],
        dir.path(),
    );
    assert_fails_with(&output, "--size");
}

#[test]
fn tiers_without_history_skip_the_warm_up_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--tier",
            "direct",
            "--width",
            "8",
            "--height",
            "6",
            "--spp",
            "1",
            "--warmup",
            "5",
            "--out",
            "direct.png",
            "--stats",
            "stats.json",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["warmup"], 0, "{stats}");
    assert!(stats["mobile"].is_null(), "{stats}");
}

#[test]
fn render_with_the_mobile_tier_reports_its_gi_time_and_memory() {
    if gi_gpu::GpuContext::new_or_skip("render_with_the_mobile_tier").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--tier",
            "mobile",
            "--screen-probes",
            "smartgi",
            "--width",
            "32",
            "--height",
            "24",
            "--warmup",
            "3",
            "--frames",
            "2",
            "--out",
            "mobile.png",
            "--stats",
            "stats.json",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("smartgi screen probes"), "{stdout}");
    let image = gi_image::load(dir.path().join("mobile.png")).unwrap();
    assert_eq!((image.width, image.height), (32, 24));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["tier"], "mobile");
    assert_eq!(stats["warmup"], 3);
    assert_eq!(stats["frames"], 2);
    let mobile = &stats["mobile"];
    assert_eq!(mobile["screen_probes"], "smartgi");
    assert_mobile_report(
        mobile,
        &stats["passes"],
        stats["ms_per_frame"].as_f64().unwrap(),
    );
}

/// The mobile tier's report: its GI time is the sum of its `cache/*` and `mobile/*` passes,
/// within the frame's time, and its memory breakdown adds up.
fn assert_mobile_report(mobile: &serde_json::Value, passes: &serde_json::Value, frame_ms: f64) {
    assert_gi_report("mobile/", mobile, passes, frame_ms);
}

/// A GPU tier's GI report: its GI time is the sum of its `cache/*` passes and those starting
/// with `prefix`, within the frame's time, and its memory breakdown adds up.
fn assert_gi_report(
    prefix: &str,
    mobile: &serde_json::Value,
    passes: &serde_json::Value,
    frame_ms: f64,
) {
    let passes = passes.as_object().expect("passes");
    assert!(passes.keys().any(|p| p.starts_with(prefix)), "{passes:?}");
    let gi_sum: f64 = passes
        .iter()
        .filter(|(name, _)| name.starts_with("cache/") || name.starts_with(prefix))
        .map(|(_, ms)| ms.as_f64().unwrap())
        .sum();
    let gi_ms = mobile["gi_ms"].as_f64().expect("gi_ms");
    assert!(
        (gi_ms - gi_sum).abs() <= 1e-9 * gi_sum.max(1.0),
        "{gi_ms} vs {gi_sum}"
    );
    assert!(
        gi_ms > 0.0 && gi_ms <= frame_ms * (1.0 + 1e-9),
        "{gi_ms} of {frame_ms}"
    );
    let memory = &mobile["memory"];
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

#[test]
fn compare_with_the_mobile_tier_reports_its_gi_time_and_memory() {
    if gi_gpu::GpuContext::new_or_skip("compare_with_the_mobile_tier").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "compare",
            "cornell-box",
            "--tiers",
            "mobile",
            "--width",
            "32",
            "--height",
            "24",
            "--spp",
            "1",
            "--warmup",
            "4",
            "--reference-spp",
            "8",
            "--out-dir",
            "cmp",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let table = String::from_utf8_lossy(&output.stdout);
    assert!(
        table.contains("mobile (hsgi screen probes, measured after 4 warm-up frames): GI"),
        "{table}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cmp/compare.json")).unwrap())
            .unwrap();
    assert_eq!(json["warmup"], 4);
    let tiers = json["tiers"].as_array().unwrap();
    assert_eq!(tiers.len(), 1);
    let mobile = &tiers[0];
    assert_eq!(mobile["tier"], "mobile");
    assert_eq!(mobile["warmup"], 4);
    assert_eq!(mobile["mobile"]["screen_probes"], "hsgi");
    for field in ["rmse_srgb8", "flip", "gain_vs_direct", "ms_per_frame"] {
        assert!(mobile[field].is_number(), "{field} missing in {mobile}");
    }
    assert_mobile_report(
        &mobile["mobile"],
        &mobile["passes"],
        mobile["ms_per_frame"].as_f64().unwrap(),
    );
    for file in [
        "mobile.png",
        "mobile.exr",
        "mobile_error.png",
        "mobile_flip.png",
    ] {
        assert!(dir.path().join("cmp").join(file).is_file(), "{file}");
    }
}

#[test]
fn render_with_the_pc_tier_reports_its_variant_gi_time_and_memory() {
    if gi_gpu::GpuContext::new_or_skip("render_with_the_pc_tier").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--tier",
            "pc",
            "--pc-without",
            "spatial",
            "--width",
            "32",
            "--height",
            "24",
            "--warmup",
            "3",
            "--out",
            "pc.png",
            "--stats",
            "stats.json",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("pc (without spatial, trace scale 2"),
        "{stdout}"
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["tier"], "pc");
    assert!(stats["mobile"].is_null(), "{stats}");
    let pc = &stats["pc"];
    assert_eq!(pc["without"], "spatial");
    assert_eq!(pc["trace_scale"], 2);
    let passes = stats["passes"].as_object().unwrap();
    assert!(passes.contains_key("pc/trace") && !passes.contains_key("pc/spatial"));
    assert_gi_report(
        "pc/",
        pc,
        &stats["passes"],
        stats["ms_per_frame"].as_f64().unwrap(),
    );
    let image = gi_image::load(dir.path().join("pc.png")).unwrap();
    assert_eq!((image.width, image.height), (32, 24));
}

#[test]
fn unknown_pc_stages_and_trace_scales_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (flag, value, expect) in [
        ("--pc-without", "denoise", "temporal"),
        ("--pc-with", "spatial", "on by default"),
        ("--pc-trace-scale", "4", "trace_scale"),
    ] {
        let output = gi(
            &[
                "render",
                "cornell-box",
                "--tier",
                "pc",
                flag,
                value,
                "--out",
                "a.png",
            ],
            dir.path(),
        );
        assert!(!output.status.success());
        let err = stderr(&output);
        assert!(err.contains(value) && err.contains(expect), "{err}");
        assert!(!dir.path().join("a.png").exists());
    }
}

#[test]
fn unknown_screen_probes_and_bad_warm_ups_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--tier",
            "mobile",
            "--screen-probes",
            "lumen",
            "--out",
            "a.png",
        ],
        dir.path(),
    );
    let err = stderr(&output);
    assert!(!output.status.success());
    assert!(
        err.contains("lumen") && err.contains("hsgi") && err.contains("smartgi"),
        "{err}"
    );
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--warmup",
            "many",
            "--out",
            "a.png",
        ],
        dir.path(),
    );
    assert!(!output.status.success());
    let err = stderr(&output);
    assert!(err.contains("'many'") && err.contains("--warmup"), "{err}");
    let output = gi(
        &[
            "render",
            "cornell-box",
            "--warmup",
            "2000000",
            "--out",
            "a.png",
        ],
        dir.path(),
    );
    assert_fails_with(&output, "--warmup 2000000");
    assert!(!dir.path().join("a.png").exists());
}

#[test]
fn error_splits_two_seeds_into_noise_and_bias_and_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let code = |c: u8| gi_image::tonemap::srgb8_to_linear(c);
    // Reference code 100; renders 106 +- 3 with orthogonal sign patterns: bias 6, noise 3.
    let reference = gi_image::Image::from_fn(8, 2, |_, _| glam::Vec3::splat(code(100)));
    let render = |pattern: [i32; 4]| {
        gi_image::Image::from_fn(8, 2, |x, _| {
            glam::Vec3::splat(code((106 + 3 * pattern[(x % 4) as usize]) as u8))
        })
    };
    let path = |name: &str| dir.path().join(name);
    gi_image::write_exr(&reference, path("ref.exr")).unwrap();
    gi_image::write_exr(&render([1, 1, -1, -1]), path("a.exr")).unwrap();
    gi_image::write_exr(&render([1, -1, 1, -1]), path("b.exr")).unwrap();
    let output = gi(
        &[
            "error",
            "--reference",
            "ref.exr",
            "a.exr",
            "--second",
            "b.exr",
        ],
        dir.path(),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let value = |key: &str| -> f64 {
        let line = stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(key))
            .unwrap_or_else(|| panic!("no {key} in:\n{stdout}"));
        let field = line.split_whitespace().nth(1).unwrap();
        field.trim_end_matches('%').parse().unwrap()
    };
    assert!(
        (value("rmse_srgb8") - 45f64.sqrt()).abs() < 1e-3,
        "{stdout}"
    );
    // Noise of 3 codes around a bias of 6 on a flat image: visible, far from the worst.
    let flip = value("flip");
    assert!(0.0 < flip && flip < 0.5, "{stdout}");
    assert!((value("noise_srgb8") - 3.0).abs() < 1e-3, "{stdout}");
    assert!((value("bias_srgb8") - 6.0).abs() < 1e-3, "{stdout}");
    assert!(value("luminance_bias") > 0.0, "{stdout}");

    let missing = gi(
        &["error", "--reference", "missing.exr", "a.exr"],
        dir.path(),
    );
    assert_fails_with(&missing, "missing.exr");
    // The I/O error that the image error quotes is not repeated as its cause.
    assert_eq!(
        stderr(&missing).matches("os error").count(),
        1,
        "{}",
        stderr(&missing)
    );
    gi_image::write_exr(&gi_image::Image::new(4, 2), path("small.exr")).unwrap();
    assert_fails_with(
        &gi(
            &["error", "--reference", "ref.exr", "small.exr"],
            dir.path(),
        ),
        "size",
    );
    assert_fails_with(
        &gi(
            &[
                "error",
                "--reference",
                "ref.exr",
                "a.exr",
                "--exposure",
                "0",
            ],
            dir.path(),
        ),
        "--exposure",
    );
}

/// `gi scenes | head -1`: a reader that closes the pipe early ends the output, not in a panic.
/// The pipe's read end is closed before `gi` starts, so every write meets a gone reader.
#[test]
fn a_reader_that_closes_the_pipe_early_ends_the_output_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let output = Command::new(env!("CARGO_BIN_EXE_gi"))
        .arg("scenes")
        .current_dir(dir.path())
        .env_remove("RUST_LOG")
        .stdout(writer)
        .output()
        .expect("gi runs");
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).is_empty(), "{}", stderr(&output));
}

/// On a machine without a Vulkan driver (simulated by pointing the Vulkan loader at a driver
/// file that does not exist), the main job still renders the CPU tiers, prints its table with
/// the GPU tiers marked as not rendered and the command that adds them, and succeeds; a GPU
/// tier asked for by name is an error.
#[test]
fn compare_without_a_vulkan_driver_renders_the_cpu_tiers_and_marks_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-driver.json");
    let without_vulkan = |args: &[&str]| {
        // An empty adapter filter is no filter.
        let env = [
            ("VK_DRIVER_FILES", missing.as_os_str()),
            ("VK_ICD_FILENAMES", missing.as_os_str()),
            ("GI_ADAPTER", std::ffi::OsStr::new("")),
        ];
        gi_with_env(args, dir.path(), &env)
    };
    let size = [
        "--width",
        "8",
        "--height",
        "6",
        "--spp",
        "1",
        "--reference-spp",
        "4",
    ];
    let output =
        without_vulkan(&[&["compare", "cornell-box", "--out-dir", "cmp"][..], &size].concat());
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    for tier in ["reference", "direct"] {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with(tier) && !l.contains("not rendered")),
            "{tier} missing from:\n{stdout}"
        );
    }
    for tier in ["path", "mobile", "pc"] {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with(tier) && l.contains("not rendered")),
            "{tier} not marked in:\n{stdout}"
        );
    }
    assert!(
        stdout.contains("sudo apt-get install mesa-vulkan-drivers libvulkan1"),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cmp/compare.json")).unwrap())
            .unwrap();
    let rendered: Vec<&str> = (json["tiers"].as_array().unwrap().iter())
        .map(|t| t["tier"].as_str().unwrap())
        .collect();
    let missing: Vec<&str> = (json["missing"].as_array().unwrap().iter())
        .map(|t| t["tier"].as_str().unwrap())
        .collect();
    assert_eq!(rendered, ["reference", "direct"]);
    assert_eq!(missing, ["path", "mobile", "pc"]);

    let named =
        without_vulkan(&[&["compare", "cornell-box", "--tiers", "path"][..], &size].concat());
    assert!(!named.status.success());
    assert!(
        stderr(&named).contains("the path tier is not available"),
        "{}",
        stderr(&named)
    );
}

//! The benchmark suite (`gi-bench` without a subcommand): every scene x tier against a cached
//! path-traced reference, as `results.json`, `results.md` (the HSGI comparison table and per-pass
//! costs), PNG plots and contact sheets.
//!
//! # What a cell measures
//!
//! A cell is one scene and one tier, run `--repeats` times, each repeat a fresh renderer (seed
//! = repeat index + 1) through the scene's default camera: the tier's still warm-up
//! ([`gi_tiers::TierKind::default_warmup`] or `--warmup`), then `--frames` measured frames
//! (`--cpu-frames` for tiers that run on the CPU: they keep no history, and each of their
//! frames is a full CPU path trace). Per repeat: the last frame's `rmse_srgb8`, `flip` (mean
//! FLIP, LDR: [`gi_image::flip_ldr`]), `rmse_linear` and `gain_vs_direct` against the
//! reference of the same camera and scene time
//! (`--reference-spp`, [`gi_reference::cache::REFERENCE_SEED`], cached in `--cache-dir`,
//! rendered by `--reference-engine`: the GPU path tier on a hardware GPU, else the CPU), the
//! median over the measured frames of the frame time, of the GI passes' sum and of each pass,
//! and the tier's memory. Each metric is then reported as the mean and sample standard
//! deviation over the repeats.
//!
//! # Regressions
//!
//! With `--baseline` (an earlier `results.json`), a metric regressed when it got worse by more
//! than the run-to-run spread both runs measured: `new_mean - old_mean > 3 * sqrt(sd_old^2 +
//! sd_new^2)` for `rmse_srgb8` and `ms_per_frame`, and any increase of `memory_bytes`, which
//! is deterministic (see [`regress`]). The flagged lines are printed and written into both
//! result files; `--fail-on-regression` makes them fail the run.
//!
//! # Processes
//!
//! Every GPU tier opens its own device, and a driver has been seen to stop finding its adapter
//! after about 30 in one process. So the suite runs one child process per scene (this binary's
//! hidden `suite-scene` subcommand), reads its [`child::Event`]s line by line from its stdout,
//! and folds them. A failed cell or scene is recorded with its error and the suite goes on; the
//! run exits non-zero at the end if anything failed.

mod child;
mod markdown;
pub(crate) mod plots;
pub mod regress;
mod results;

pub(crate) use results::median;

use std::{
    collections::BTreeMap,
    io::{BufRead, BufReader, Read},
    path::{Path, PathBuf},
    process::{Command, Stdio},
    time::SystemTime,
};

use anyhow::{Context, Result, bail};
use clap::Args;
use gi_reference::cache;
use gi_reference::engine::EngineChoice;
use gi_tiers::TierKind;
use indicatif::{ProgressBar, ProgressStyle};

use self::{
    child::Event,
    results::{Cell, CellRun, Failure, Options, Results, SCHEMA_VERSION},
};

/// The suite's command-line options (top level of `gi-bench`).
#[derive(Args, Debug)]
pub struct SuiteArgs {
    /// Comma-separated bundled scene names or glTF paths (default: every bundled scene).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Comma-separated tiers (default: reference, direct, path, mobile, pc).
    #[arg(long, value_delimiter = ',', value_parser = |s: &str| s.parse::<TierKind>())]
    tiers: Vec<TierKind>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = crate::parse_size)]
    size: (u32, u32),
    /// Measured frames per repeat after the warm-up; the times are their medians and the last
    /// one's image is compared with the reference.
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// Measured frames of tiers that run on the CPU (the reference tier; `direct` without a
    /// hardware GPU), at most `--frames`. Each is a full CPU path trace and they keep no
    /// history, so fewer frames only cost spread, which the repeats measure.
    #[arg(long, default_value_t = 1)]
    cpu_frames: u32,
    /// Still warm-up frames before the measured frames, for every tier (default: each tier's
    /// own, 63 for mobile and pc, 0 for the others).
    #[arg(long)]
    warmup: Option<u32>,
    /// Samples per pixel per frame of the reference and path tiers (anti-aliasing samples of
    /// `direct`), as `gi compare` renders them.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Runs per cell, each a fresh renderer with seed = repeat index + 1; their spread is what
    /// the regression check compares against. At least 2 for the check to judge noisy
    /// metrics.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Samples per pixel of each scene's reference (rendered once, then cached).
    #[arg(long, default_value_t = 256)]
    reference_spp: u32,
    /// What renders the references: auto (the GPU path tier on a hardware GPU, else the CPU
    /// path tracer; takes a cached reference of either), gpu or cpu (each takes only cached
    /// references of its own), as `gi compare`.
    #[arg(long, default_value_t = EngineChoice::Auto)]
    reference_engine: EngineChoice,
    /// Reference cache folder (default: $GI_CACHE_DIR, $XDG_CACHE_HOME/gi or ~/.cache/gi, as
    /// `gi compare`).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Output folder for results.json, results.md, the plots and images/.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
    /// An earlier results.json to check for regressions against.
    #[arg(long)]
    baseline: Option<PathBuf>,
    /// Exit non-zero when the baseline comparison flags a regression.
    #[arg(long, requires = "baseline")]
    fail_on_regression: bool,
    /// Lighting file (JSON: sun, sky, exposure, default camera) applied to every scene;
    /// without it, each scene file's `<stem>.lighting.json` is used when it exists.
    #[arg(long, value_name = "FILE")]
    lighting: Option<PathBuf>,
}

/// The hidden subcommand a scene's process runs.
#[derive(Args, Debug)]
pub struct SceneArgs {
    /// The scene to measure.
    #[arg(long)]
    scene: String,
    /// The suite's resolved [`Options`] as JSON.
    #[arg(long)]
    options: String,
}

/// A scene name or path as a file name part (`cornell-box`, `scenes_room.gltf`).
pub fn file_stem(scene: &str) -> String {
    scene
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The commit this binary was built from, or `$GI_COMMIT` when the build knew none.
fn commit() -> String {
    let built = env!("GI_BUILD_COMMIT");
    match std::env::var("GI_COMMIT") {
        Ok(commit) if built == "unknown" && !commit.is_empty() => commit,
        _ => built.to_owned(),
    }
}

/// Runs a scene's measurement (the child side).
pub fn run_scene(args: &SceneArgs) -> Result<()> {
    let options: Options = serde_json::from_str(&args.options).context("parsing --options")?;
    child::run(&args.scene, &options)
}

/// Runs the suite (the parent side).
pub fn run(args: &SuiteArgs) -> Result<()> {
    anyhow::ensure!(args.frames >= 1, "--frames must be at least 1");
    anyhow::ensure!(args.cpu_frames >= 1, "--cpu-frames must be at least 1");
    anyhow::ensure!(args.repeats >= 1, "--repeats must be at least 1");
    anyhow::ensure!(
        args.spp >= 1 && args.reference_spp >= 1,
        "--spp and --reference-spp must be at least 1"
    );
    // A baseline that cannot be read should stop the run before it costs anything.
    let baseline = args.baseline.as_deref().map(read_results).transpose()?;
    plots::register_font()?;

    let options = Options {
        scenes: if args.scenes.is_empty() {
            gi_scene::BUNDLED_SCENES
                .iter()
                .map(|(name, _)| (*name).to_owned())
                .collect()
        } else {
            args.scenes.clone()
        },
        tiers: if args.tiers.is_empty() {
            TierKind::ALL.to_vec()
        } else {
            args.tiers.clone()
        }
        .into_iter()
        .map(|tier| tier.name().to_owned())
        .collect(),
        width: args.size.0,
        height: args.size.1,
        frames: args.frames,
        cpu_frames: args.cpu_frames.min(args.frames),
        warmup: args.warmup,
        spp: args.spp,
        repeats: args.repeats,
        reference_spp: args.reference_spp,
        reference_seed: cache::REFERENCE_SEED,
        reference_engine: args.reference_engine,
        lighting: args.lighting.as_ref().map(|p| p.display().to_string()),
        cache_dir: args
            .cache_dir
            .clone()
            .unwrap_or_else(cache::default_dir)
            .display()
            .to_string(),
        out_dir: args.out.display().to_string(),
    };
    let images = args.out.join("images");
    std::fs::create_dir_all(&images).with_context(|| format!("creating {}", images.display()))?;

    let mut results = Results {
        schema: SCHEMA_VERSION,
        commit: commit(),
        date: humantime::format_rfc3339_seconds(SystemTime::now()).to_string(),
        command: std::env::args().collect(),
        cpu_count: std::thread::available_parallelism().map_or(1, |n| n.get()),
        adapter: None,
        options: options.clone(),
        references: Vec::new(),
        cells: Vec::new(),
        failures: Vec::new(),
        regressions: None,
    };
    let total = (options.scenes.len() * options.tiers.len()) as u64 * u64::from(options.repeats);
    let bar = ProgressBar::new(total).with_style(
        ProgressStyle::with_template("[{elapsed_precise}] {bar:32} {pos}/{len} cells  {msg}")
            .expect("the template parses"),
    );
    for scene in &options.scenes {
        run_scene_process(scene, &options, &bar, &mut results)?;
    }
    bar.finish_and_clear();

    if let (Some(path), Some(old)) = (&args.baseline, &baseline) {
        results.regressions = Some(regress::compare(&path.display().to_string(), old, &results));
    }
    let written = write_outputs(&results, &args.out)?;

    out!("{}\n", markdown::scene_tier_table(&results));
    if let Some(comparison) = &results.regressions {
        out!("{}", markdown::regression_section(comparison));
    }
    for failure in &results.failures {
        let what = failure
            .tier
            .as_ref()
            .map_or(failure.scene.clone(), |t| format!("{}/{t}", failure.scene));
        out!("FAILED {what}: {}\n", failure.error);
    }
    out!("\nwrote into {}:\n", args.out.display());
    for file in &written {
        out!("  {file}\n");
    }
    out!("  images/ (each tier's image, error heat map and FLIP map, each scene's reference)\n");

    let flagged = results.regressions.as_ref().map_or(0, |c| c.flagged.len());
    match (results.failures.len(), flagged) {
        (0, 0) => Ok(()),
        (0, n) if args.fail_on_regression => bail!("{n} regressions flagged"),
        (0, _) => Ok(()),
        (n, _) => bail!("{n} cells or scenes failed (see results.md)"),
    }
}

fn read_results(path: &Path) -> Result<Results> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let results: Results = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a suite results.json", path.display()))?;
    anyhow::ensure!(
        results.schema == SCHEMA_VERSION,
        "{} has schema {}, this build writes {SCHEMA_VERSION}",
        path.display(),
        results.schema
    );
    Ok(results)
}

/// What one scene's process reported.
#[derive(Default)]
struct SceneReport {
    runs: BTreeMap<String, Vec<(u32, CellRun)>>,
    errors: BTreeMap<String, String>,
    failed: Option<String>,
}

/// Runs the process of `scene`, following its events on the progress bar, and adds its cells.
fn run_scene_process(
    scene: &str,
    options: &Options,
    bar: &ProgressBar,
    results: &mut Results,
) -> Result<()> {
    let exe = std::env::current_exe().context("finding the gi-bench executable")?;
    let mut process = Command::new(exe)
        .arg("suite-scene")
        .arg("--scene")
        .arg(scene)
        .arg("--options")
        .arg(serde_json::to_string(options)?)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .context("starting a scene process")?;
    // Read stderr on its own thread, so a chatty child never blocks on a full pipe.
    let mut stderr = process.stderr.take().expect("stderr is piped");
    let stderr = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stderr.read_to_string(&mut text);
        text
    });
    let stdout = process.stdout.take().expect("stdout is piped");
    let mut report = SceneReport::default();
    for line in BufReader::new(stdout).lines() {
        let Ok(event) = serde_json::from_str::<Event>(&line?) else {
            continue; // not an event (a library's own print)
        };
        match event {
            Event::Adapter { adapter, .. } => {
                if results.adapter.is_none() {
                    results.adapter = adapter;
                }
            }
            Event::Start { tier, repeat } => bar.set_message(match repeat {
                Some(r) => format!("{scene}: {tier} (repeat {}/{})", r + 1, options.repeats),
                None => format!("{scene}: {tier}"),
            }),
            Event::Reference(info) => results.references.push(info),
            Event::Cell {
                tier,
                repeat,
                run,
                error,
            } => {
                bar.inc(1);
                if let Some(run) = run {
                    report
                        .runs
                        .entry(tier.clone())
                        .or_default()
                        .push((repeat, run));
                }
                if let Some(error) = error {
                    report.errors.entry(tier).or_insert(error);
                }
            }
            Event::SceneFailed { error } => report.failed = Some(error),
        }
    }
    let status = process.wait().context("waiting for a scene process")?;
    let stderr = stderr.join().unwrap_or_default();
    if !status.success() && report.failed.is_none() {
        report.failed = Some(format!(
            "the scene's process ended with {status}: {}",
            tail(&stderr, 1500)
        ));
    }
    fold_scene(scene, options, report, results);
    Ok(())
}

/// Adds a scene's cells (every listed tier, finished or not) and failures to `results`.
fn fold_scene(scene: &str, options: &Options, mut report: SceneReport, results: &mut Results) {
    if let Some(error) = &report.failed {
        results.failures.push(Failure {
            scene: scene.to_owned(),
            tier: None,
            error: error.clone(),
        });
    }
    for tier in &options.tiers {
        let mut runs = report.runs.remove(tier).unwrap_or_default();
        runs.sort_by_key(|(repeat, _)| *repeat);
        let runs: Vec<CellRun> = runs.into_iter().map(|(_, run)| run).collect();
        let mut error = report.errors.remove(tier);
        if error.is_none() && runs.len() < options.repeats as usize {
            error = Some(match &report.failed {
                Some(_) => "not measured: the scene failed".to_owned(),
                None => "not measured: the scene's process stopped early".to_owned(),
            });
        }
        if let Some(error) = &error {
            results.failures.push(Failure {
                scene: scene.to_owned(),
                tier: Some(tier.clone()),
                error: error.clone(),
            });
        }
        results
            .cells
            .push(Cell::from_runs(scene, tier, &runs, error));
    }
}

/// The last `max` bytes of `text` (on a character boundary).
fn tail(text: &str, max: usize) -> &str {
    let mut start = text.len().saturating_sub(max);
    while !text.is_char_boundary(start) {
        start += 1;
    }
    text[start..].trim()
}

/// Writes results.json, results.md and the plots; returns their names.
fn write_outputs(results: &Results, out: &Path) -> Result<Vec<String>> {
    let mut written = Vec::new();
    let mut write = |name: String, text: String| -> Result<()> {
        let path = out.join(&name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
        written.push(name);
        Ok(())
    };
    write(
        "results.json".into(),
        serde_json::to_string_pretty(results)?,
    )?;
    write("results.md".into(), markdown::document(results))?;

    plots::error_vs_time(results, &out.join("error_vs_time.png"))?;
    written.push("error_vs_time.png".into());
    let gpu_tiers = results.options.tiers.iter().filter(|tier| {
        results
            .cells
            .iter()
            .any(|c| &c.tier == *tier && c.on_cpu == Some(false))
    });
    for tier in gpu_tiers {
        let name = format!("passes_{tier}.png");
        if plots::passes(results, tier, &out.join(&name))? {
            written.push(name);
        }
    }
    for scene in &results.options.scenes {
        let name = format!("contact_{}.png", file_stem(scene));
        if plots::contact_sheet(results, scene, &out.join("images"), &out.join(&name))? {
            written.push(name);
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_paths_become_file_names() {
        assert_eq!(file_stem("cornell-box"), "cornell-box");
        assert_eq!(file_stem("scenes/my room.glb"), "scenes_my_room.glb");
    }
}

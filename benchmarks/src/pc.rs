//! `gi-bench pc`: what a frame of the PC tier costs and how much memory it holds, per scene and
//! pipeline variant (the default, one stage switched off, or `with-<stage>` one switched on
//! that is off by default: the ablation's cost column), in
//! the form of HSGI's per-pass table.
//!
//! Each run makes a PC tier for the scene's default camera, renders a still warm-up
//! ([`Renderer::warm_up`]), then still frames until the GPU's clock has settled
//! ([`crate::settle`]), and measures `frames` frames; each pass's figure is its median over
//! them ([`PassTimings::median`](gi_gpu::PassTimings::median)) and the GI cost is the sum of the `cache/*` and `pc/*`
//! medians ([`TierKind::is_gi_pass`]).

use anyhow::Context;
use gi_tiers::pc::denoise::AtrousKernel;
use gi_tiers::pc::{HitLights, PC_OPTIONAL_STAGES, PC_STAGES, TraceMode};
use gi_tiers::{CameraMode, PcConfig, PcTier, Renderer, TierKind, TierSettings};

use crate::realtime::{MIB, Measured, Schedule};

/// A pipeline variant: `default`, the name of a stage to switch off ([`PC_STAGES`]),
/// `with-` and the name of one to switch on ([`PC_OPTIONAL_STAGES`]), or `atrous-K-N`: the
/// default with the denoiser's a-trous kernel `K` (`5x5` or `3x3`) and `N` iterations, or
/// `hit-lights-cache` (the hits' punctual lights from the brick cache, [`HitLights::Cache`]).
pub fn parse_variant(value: &str) -> Result<String, String> {
    let switched_on = value
        .strip_prefix("with-")
        .is_some_and(|stage| PC_OPTIONAL_STAGES.contains(&stage));
    if value == "default" || PC_STAGES.contains(&value) || switched_on {
        return Ok(value.to_string());
    }
    if value == "hit-lights-cache" {
        return Ok(value.to_string());
    }
    if value.starts_with("atrous-") {
        return variant_config(value).map(|_| value.to_string());
    }
    Err(format!(
        "unknown variant `{value}` (expected default, one of {}, with-{}, hit-lights-cache or \
         atrous-K-N with K one of {} and N iterations)",
        PC_STAGES.join(", "),
        PC_OPTIONAL_STAGES.join(", with-"),
        AtrousKernel::NAMES.join(", ")
    ))
}

/// The configuration of a variant [`parse_variant`] accepted.
fn variant_config(variant: &str) -> Result<PcConfig, String> {
    if variant == "default" {
        return Ok(PcConfig::default());
    }
    if variant == "hit-lights-cache" {
        return Ok(PcConfig {
            hit_lights: HitLights::Cache,
            ..PcConfig::default()
        });
    }
    if let Some(atrous) = variant.strip_prefix("atrous-") {
        let (kernel, iterations) = atrous
            .split_once('-')
            .ok_or_else(|| format!("variant `{variant}`: expected atrous-K-N"))?;
        let mut config = PcConfig::default();
        config.denoise.atrous_kernel = kernel.parse()?;
        config.denoise.atrous_iterations = iterations
            .parse()
            .map_err(|_| format!("variant `{variant}`: `{iterations}` is not a count"))?;
        config.validate()?;
        return Ok(config);
    }
    match variant.strip_prefix("with-") {
        Some(stage) => PcConfig::with(stage),
        None => PcConfig::without(variant),
    }
}

/// A variant's column label.
fn variant_label(variant: &str) -> String {
    if variant == "default" || variant.starts_with("atrous-") || variant == "hit-lights-cache" {
        return variant.to_string();
    }
    match variant.strip_prefix("with-") {
        Some(stage) => format!("with {stage}"),
        None => format!("without {variant}"),
    }
}

/// What `gi-bench pc` runs.
#[derive(Clone, Debug)]
pub struct PcOptions {
    pub scenes: Vec<String>,
    pub size: (u32, u32),
    /// The frames of each run.
    pub schedule: Schedule,
    pub variants: Vec<String>,
    pub trace_scale: u32,
    /// What the diffuse rays read (`rays` or `probes`).
    pub trace_mode: TraceMode,
}

/// One scene in one variant.
pub struct PcRun {
    pub scene: String,
    pub variant: String,
    pub measured: Measured,
}

pub struct PcReport {
    pub options: PcOptions,
    pub runs: Vec<PcRun>,
}

/// The settings the benchmarks give a GPU GI tier: `size`, one sample per pixel, seed 1.
pub fn bench_settings(size: (u32, u32)) -> TierSettings {
    TierSettings {
        width: size.0,
        height: size.1,
        spp: 1,
        seed: 1,
        textures: gi_tiers::TextureOptions::DEFAULT,
    }
}

/// A renderer of `scene` with a PC tier of `config` at `size`.
pub fn pc_renderer(
    scene: gi_scene::Scene,
    size: (u32, u32),
    config: PcConfig,
    camera: CameraMode,
) -> anyhow::Result<Renderer> {
    let tier = PcTier::open(bench_settings(size), config)?;
    Ok(Renderer::with_tier(scene, Box::new(tier), camera))
}

/// Renders every scene in every variant and measures it.
pub fn run(options: &PcOptions) -> anyhow::Result<PcReport> {
    options.schedule.check()?;
    anyhow::ensure!(!options.scenes.is_empty(), "--scenes names no scene");
    let schedule = options.schedule;
    let mut runs = Vec::new();
    for name in &options.scenes {
        let scene = gi_scene::load(name).with_context(|| format!("loading {name}"))?;
        for variant in &options.variants {
            let mut config = variant_config(variant).map_err(anyhow::Error::msg)?;
            config.trace_scale = options.trace_scale;
            config.trace_mode = options.trace_mode;
            let mut renderer =
                pc_renderer(scene.clone(), options.size, config, CameraMode::Default)?;
            runs.push(PcRun {
                scene: scene.name.clone(),
                variant: variant.clone(),
                measured: Measured::of(&mut renderer, &schedule)?,
            });
        }
    }
    Ok(PcReport {
        options: options.clone(),
        runs,
    })
}

impl PcReport {
    /// Markdown: per scene a pass table with one column per variant, GI sum and memory.
    pub fn table(&self) -> String {
        let o = &self.options;
        let mut out = String::new();
        let mut scenes: Vec<&str> = self.runs.iter().map(|r| r.scene.as_str()).collect();
        scenes.dedup();
        for scene in scenes {
            let runs: Vec<&PcRun> = self.runs.iter().filter(|r| r.scene == scene).collect();
            let clock = runs[0].measured.clock();
            out += &format!(
                "{scene} {}x{}, trace scale {}, trace mode {}, on {}: median of {} frames after \
                 {} still warm-up frames ({clock}), ms\n\n",
                o.size.0,
                o.size.1,
                o.trace_scale,
                o.trace_mode.name(),
                runs[0].measured.adapter,
                o.schedule.frames,
                o.schedule.warmup
            );
            for run in &runs {
                out += &format!(
                    "- {}: {}\n",
                    variant_label(&run.variant),
                    run.measured.settled.describe()
                );
            }
            out += "\n| pass |";
            for run in &runs {
                out += &format!(" {} |", variant_label(&run.variant));
            }
            out += &format!("\n|---|{}\n", "---:|".repeat(runs.len()));
            let mut names: Vec<&str> = Vec::new();
            for run in &runs {
                for (name, _) in &run.measured.median.0 {
                    if !names.contains(&name.as_str()) {
                        names.push(name);
                    }
                }
            }
            let row = |label: &str, value: &dyn Fn(&Measured) -> Option<f64>| {
                let mut line = format!("| {label} |");
                for run in &runs {
                    match value(&run.measured) {
                        Some(ms) => line += &format!(" {ms:.3} |"),
                        None => line += " - |",
                    }
                }
                line + "\n"
            };
            for name in names.iter().filter(|n| TierKind::Pc.is_gi_pass(n)) {
                out += &row(name, &|run| run.median.get(name));
            }
            out += &row("**GI (cache/* + pc/*)**", &|run| Some(run.gi_ms()));
            out += &row("GI per frame, 10th percentile", &|run| Some(run.spread.p10));
            out += &row("GI per frame, 90th percentile", &|run| Some(run.spread.p90));
            for name in names.iter().filter(|n| !TierKind::Pc.is_gi_pass(n)) {
                out += &row(name, &|run| run.median.get(name));
            }
            out += &row("frame wall-clock, waiting for the GPU", &|run| {
                Some(run.wall.waiting_ms)
            });
            out += &row("frame wall-clock, pipelined", &|run| {
                Some(run.wall.pipelined_ms)
            });
            out += &row("GI of the pipelined frames", &|run| {
                Some(run.wall.pipelined_gi_ms)
            });
            out += &row("GI memory MiB (coverage + screen)", &|run| {
                Some(run.memory.gi_bytes() as f64 / MIB)
            });
            out += &row("screen buffers MiB", &|run| {
                Some(run.memory.screen_bytes as f64 / MIB)
            });
            out += "\n";
        }
        out
    }

    pub fn json(&self) -> serde_json::Value {
        let o = &self.options;
        serde_json::json!({
            "width": o.size.0,
            "height": o.size.1,
            "warmup": o.schedule.warmup,
            "settle_s": o.schedule.settle_s,
            "frames": o.schedule.frames,
            "trace_scale": o.trace_scale,
            "trace_mode": o.trace_mode.name(),
            "runs": self.runs.iter().map(|run| run.measured.json(serde_json::json!({
                "scene": run.scene,
                "variant": run.variant,
            }))).collect::<Vec<_>>(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variants_are_default_or_a_stage() {
        for good in ["default", "spatial", "with-temporal"] {
            assert!(parse_variant(good).is_ok(), "{good}");
            assert!(variant_config(good).is_ok(), "{good}");
        }
        assert!(variant_config("with-temporal").unwrap().restir.temporal);
        assert!(!variant_config("default").unwrap().restir.temporal);
        let err = parse_variant("denoise").unwrap_err();
        assert!(
            err.contains("denoise") && err.contains("with-temporal"),
            "{err}"
        );
        assert!(parse_variant("with-spatial").is_err());
    }

    /// The tiny mode: the benchmark runs end to end, so it cannot rot.
    #[test]
    fn tiny_run_reports_every_variant() {
        if gi_gpu::GpuContext::new_or_skip("pc::tiny_run_reports_every_variant").is_none() {
            return;
        }
        let report = run(&PcOptions {
            scenes: vec!["cornell-box".into()],
            size: (32, 24),
            schedule: Schedule {
                warmup: 1,
                settle_s: 0.0,
                frames: 2,
            },
            variants: vec!["default".into(), "spatial".into(), "with-temporal".into()],
            trace_scale: 2,
            trace_mode: TraceMode::Rays,
        })
        .unwrap();
        assert_eq!(report.runs.len(), 3);
        let table = report.table();
        assert!(
            table.contains("pc/trace")
                && table.contains("without spatial")
                && table.contains("with temporal"),
            "{table}"
        );
        assert!(table.contains("frame wall-clock, pipelined"), "{table}");
        for run in &report.runs {
            let wall = run.measured.wall;
            assert!(
                wall.waiting_ms > 0.0 && wall.pipelined_ms > 0.0 && wall.pipelined_gi_ms > 0.0,
                "{wall:?}"
            );
        }
        assert!(report.runs[0].measured.median.get("pc/spatial").is_some());
        assert!(report.runs[1].measured.median.get("pc/spatial").is_none());
        // Temporal reuse is off by default: its pass runs only when switched on.
        assert!(report.runs[0].measured.median.get("pc/temporal").is_none());
        assert!(report.runs[2].measured.median.get("pc/temporal").is_some());
    }
}

//! `gi-bench mobile`: what a frame of the mobile tier costs and how much memory it holds, per
//! scene and screen-probe mode, in the form of HSGI's per-pass table.
//!
//! Each run makes a mobile tier for the scene's default camera, renders a still warm-up
//! ([`Renderer::warm_up`], by default [`TierKind::default_warmup`](gi_tiers::TierKind::default_warmup) frames showing frame 0), then
//! still frames until the GPU's clock has settled ([`crate::settle`]), and then measures
//! `frames` frames (scene time advancing, so animated scenes move). Each pass's
//! figure is its median over the measured frames ([`PassTimings::median`](gi_gpu::PassTimings::median)); the GI cost is the
//! sum of the `cache/*` and `mobile/*` medians ([`TierKind::is_gi_pass`](gi_tiers::TierKind::is_gi_pass)), the frame's other
//! passes (G-buffer, direct light) are listed apart. Memory is the tier's own breakdown after
//! the last frame, compared with the 32 MB bar (32 * 10^6 bytes, 30.5 MiB) for GI memory.

use anyhow::Context;
use gi_tiers::{
    CameraMode, GiMemory, MobileConfig, MobileTier, Renderer,
    mobile::{ScreenConfig, ScreenProbeMode},
};

use crate::realtime::{GI_MEMORY_BAR_BYTES, MIB, Measured, Schedule};

/// The screen-probe modes a run covers (`--screen-probes hsgi|smartgi|both`).
pub fn parse_modes(value: &str) -> Result<Vec<ScreenProbeMode>, String> {
    match value {
        "hsgi" => Ok(vec![ScreenProbeMode::Hsgi]),
        "smartgi" => Ok(vec![ScreenProbeMode::SmartGi]),
        "both" => Ok(vec![ScreenProbeMode::Hsgi, ScreenProbeMode::SmartGi]),
        other => Err(format!(
            "unknown screen-probe mode `{other}` (expected hsgi, smartgi or both)"
        )),
    }
}

/// The mobile tier's default configuration with the screen probes of `mode` (the default's
/// own screen settings when it already uses `mode`).
pub fn config_for(mode: ScreenProbeMode) -> MobileConfig {
    let mut config = MobileConfig::default();
    if config.screen.mode != mode {
        config.screen = match mode {
            ScreenProbeMode::Hsgi => ScreenConfig::default(),
            ScreenProbeMode::SmartGi => ScreenConfig::smartgi(),
        };
    }
    config
}

/// A renderer of `scene` with a mobile tier of `mode` at `size`.
pub fn mobile_renderer(
    scene: gi_scene::Scene,
    size: (u32, u32),
    mode: ScreenProbeMode,
    camera: CameraMode,
) -> anyhow::Result<Renderer> {
    mobile_renderer_with(scene, size, config_for(mode), camera)
}

/// [`mobile_renderer`] with the mobile tier configured as `config`.
pub fn mobile_renderer_with(
    scene: gi_scene::Scene,
    size: (u32, u32),
    config: MobileConfig,
    camera: CameraMode,
) -> anyhow::Result<Renderer> {
    let tier = MobileTier::open(crate::pc::bench_settings(size), config)?;
    Ok(Renderer::with_tier(scene, Box::new(tier), camera))
}

/// The mobile tier behind a renderer made by [`mobile_renderer`].
pub fn mobile(renderer: &Renderer) -> &MobileTier {
    renderer
        .tier_as::<MobileTier>()
        .expect("the renderer holds a mobile tier")
}

/// What `gi-bench mobile` runs.
#[derive(Clone, Debug)]
pub struct MobileOptions {
    pub scenes: Vec<String>,
    pub size: (u32, u32),
    /// The frames of each run.
    pub schedule: Schedule,
    pub modes: Vec<ScreenProbeMode>,
}

/// One scene in one screen-probe mode.
pub struct MobileRun {
    pub scene: String,
    pub mode: ScreenProbeMode,
    pub measured: Measured,
}

/// What `gi-bench mobile` measured.
pub struct MobileReport {
    pub options: MobileOptions,
    pub runs: Vec<MobileRun>,
}

/// Renders every scene in every mode and measures it.
pub fn run(options: &MobileOptions) -> anyhow::Result<MobileReport> {
    options.schedule.check()?;
    anyhow::ensure!(!options.scenes.is_empty(), "--scenes names no scene");
    let schedule = options.schedule;
    let mut runs = Vec::new();
    for name in &options.scenes {
        let scene = gi_scene::load(name).with_context(|| format!("loading {name}"))?;
        for &mode in &options.modes {
            let mut renderer =
                mobile_renderer(scene.clone(), options.size, mode, CameraMode::Default)?;
            runs.push(MobileRun {
                scene: scene.name.clone(),
                mode,
                measured: Measured::of(&mut renderer, &schedule)?,
            });
        }
    }
    Ok(MobileReport {
        options: options.clone(),
        runs,
    })
}

impl MobileReport {
    /// Markdown: per run the pass table (GI passes, their sum, the other passes) and the
    /// memory; then a summary row per run.
    pub fn table(&self) -> String {
        let o = &self.options;
        let mut out = String::new();
        for MobileRun {
            scene,
            mode,
            measured: run,
        } in &self.runs
        {
            let clock = run.clock();
            out += &format!(
                "{} {}x{}, {} screen probes, on {}: median of {} frames after {} still \
                 warm-up frames and {} ({clock})\n\n| pass | ms |\n|---|---:|\n",
                scene,
                o.size.0,
                o.size.1,
                mode.name(),
                run.adapter,
                o.schedule.frames,
                o.schedule.warmup,
                run.settled.describe(),
            );
            for (name, ms) in run.passes(true) {
                out += &format!("| {name} | {ms:.3} |\n");
            }
            out += &format!("| **GI (cache/* + mobile/*)** | **{:.3}** |\n", run.gi_ms());
            out += &format!(
                "| GI per frame, 10th / 90th percentile | {:.3} / {:.3} |\n",
                run.spread.p10, run.spread.p90
            );
            for (name, ms) in run.passes(false) {
                out += &format!("| {name} | {ms:.3} |\n");
            }
            out += &format!(
                "| frame (sum of medians) | {:.3} |\n\
                 | frame wall-clock, waiting for the GPU | {:.3} |\n\
                 | frame wall-clock, pipelined | {:.3} |\n\
                 | GI of the pipelined frames | {:.3} |\n\n",
                run.gi_ms() + run.other_ms(),
                run.wall.waiting_ms,
                run.wall.pipelined_ms,
                run.wall.pipelined_gi_ms,
            );
            out += &format!("{}\n\n", memory_line(&run.memory));
        }
        if self.runs.len() > 1 {
            out += "| scene | screen probes | GI ms | other ms | GI MiB | coverage MiB | \
                    screen MiB |\n|---|---|---:|---:|---:|---:|---:|\n";
            for run in &self.runs {
                let m = &run.measured.memory;
                out += &format!(
                    "| {} | {} | {:.3} | {:.3} | {:.2} | {:.2} | {:.2} |\n",
                    run.scene,
                    run.mode.name(),
                    run.measured.gi_ms(),
                    run.measured.other_ms(),
                    m.gi_bytes() as f64 / MIB,
                    m.coverage_bytes as f64 / MIB,
                    m.screen_bytes as f64 / MIB,
                );
            }
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
            "gi_memory_bar_bytes": GI_MEMORY_BAR_BYTES,
            "runs": self.runs.iter().map(|run| run.measured.json(serde_json::json!({
                "scene": run.scene,
                "screen_probes": run.mode.name(),
            }))).collect::<Vec<_>>(),
        })
    }
}

/// The memory breakdown in one line, against the bar.
pub fn memory_line(m: &GiMemory) -> String {
    let gi = m.gi_bytes();
    format!(
        "memory: coverage {:.2} MiB + screen {:.2} MiB = GI {:.2} MiB ({} the 32 MB bar, {:.1} \
         MiB); frame (scene, BVH, G-buffer, direct) {:.2} MiB",
        m.coverage_bytes as f64 / MIB,
        m.screen_bytes as f64 / MIB,
        gi as f64 / MIB,
        if gi <= GI_MEMORY_BAR_BYTES {
            "within"
        } else {
            "OVER"
        },
        GI_MEMORY_BAR_BYTES as f64 / MIB,
        m.frame_bytes as f64 / MIB,
    )
}

//! `gi-bench mobile`: what a frame of the mobile tier costs and how much memory it holds, per
//! scene and screen-probe mode, in the form of HSGI's per-pass table.
//!
//! Each run makes a mobile tier for the scene's default camera, renders a still warm-up
//! ([`Renderer::warm_up`], by default [`TierKind::default_warmup`] frames showing frame 0), then
//! still frames until the GPU's clock has settled ([`crate::settle`]), and then measures
//! `frames` frames (scene time advancing, so animated scenes move). Each pass's
//! figure is its median over the measured frames ([`PassTimings::median`]); the GI cost is the
//! sum of the `cache/*` and `mobile/*` medians ([`TierKind::is_gi_pass`]), the frame's other
//! passes (G-buffer, direct light) are listed apart. Memory is the tier's own breakdown after
//! the last frame, compared with the 32 MB bar (32 * 10^6 bytes, 30.5 MiB) for GI memory.

use anyhow::Context;
use gi_gpu::PassTimings;
use gi_tiers::{
    CameraMode, MobileConfig, MobileTier, Renderer, TierKind,
    mobile::{MobileMemory, ScreenConfig, ScreenProbeMode},
};

use crate::settle::{self, FrameWall, GiSpread, Settled};

/// The GI memory bar of the issue: 32 MB, read as 32 * 10^6 bytes (the stricter reading).
pub const GI_MEMORY_BAR_BYTES: u64 = 32_000_000;

const MIB: f64 = (1 << 20) as f64;

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
    let tier = MobileTier::open(crate::pc::bench_settings(size), config_for(mode))?;
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
    pub warmup: u32,
    /// Measured frames after the warm-up (at least 1).
    pub frames: u32,
    pub modes: Vec<ScreenProbeMode>,
    /// Least seconds of still frames after the warm-up for the GPU's clock to settle
    /// ([`settle::settle`]); 0 measures at once.
    pub settle_s: f64,
}

/// One scene in one screen-probe mode.
pub struct MobileRun {
    pub scene: String,
    pub mode: ScreenProbeMode,
    pub adapter: String,
    pub gpu_timestamps: bool,
    /// Median milliseconds per pass over the measured frames, in the first frame's order.
    pub median: PassTimings,
    /// How the measured frames' GI time spread.
    pub spread: GiSpread,
    /// A frame's wall-clock time, waiting for the GPU and pipelined.
    pub wall: FrameWall,
    /// The still frames rendered for the clock after the warm-up.
    pub settled: Settled,
    pub memory: MobileMemory,
}

impl MobileRun {
    /// Sum of the GI passes' medians (`cache/*` and `mobile/*`).
    pub fn gi_ms(&self) -> f64 {
        settle::gi_ms(TierKind::Mobile, &self.median.0)
    }

    /// Sum of the other passes' medians.
    pub fn other_ms(&self) -> f64 {
        self.other_passes().map(|(_, ms)| ms).sum()
    }

    fn gi_passes(&self) -> impl Iterator<Item = (&str, f64)> {
        self.median
            .0
            .iter()
            .filter(|(name, _)| TierKind::Mobile.is_gi_pass(name))
            .map(|(name, ms)| (name.as_str(), *ms))
    }

    fn other_passes(&self) -> impl Iterator<Item = (&str, f64)> {
        self.median
            .0
            .iter()
            .filter(|(name, _)| !TierKind::Mobile.is_gi_pass(name))
            .map(|(name, ms)| (name.as_str(), *ms))
    }
}

/// What `gi-bench mobile` measured.
pub struct MobileReport {
    pub options: MobileOptions,
    pub runs: Vec<MobileRun>,
}

/// Renders every scene in every mode and measures it.
pub fn run(options: &MobileOptions) -> anyhow::Result<MobileReport> {
    anyhow::ensure!(options.frames >= 1, "--frames must be at least 1");
    anyhow::ensure!(!options.scenes.is_empty(), "--scenes names no scene");
    let mut runs = Vec::new();
    for name in &options.scenes {
        let scene = gi_scene::load(name).with_context(|| format!("loading {name}"))?;
        for &mode in &options.modes {
            let mut renderer =
                mobile_renderer(scene.clone(), options.size, mode, CameraMode::Default)?;
            renderer.warm_up(options.warmup, None)?;
            let settled = settle::settle(&mut renderer, TierKind::Mobile, options.settle_s)?;
            let (frames, wall) =
                settle::time_frames(&mut renderer, TierKind::Mobile, options.frames)?;
            let tier = mobile(&renderer);
            runs.push(MobileRun {
                scene: scene.name.clone(),
                mode,
                adapter: tier.context().adapter_info.name.clone(),
                gpu_timestamps: tier.context().supports_timestamps(),
                median: PassTimings::median(&frames),
                spread: GiSpread::of(TierKind::Mobile, &frames),
                wall,
                settled,
                memory: tier.memory(),
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
        for run in &self.runs {
            let clock = if run.gpu_timestamps {
                "GPU timestamps"
            } else {
                "CPU wall-clock"
            };
            out += &format!(
                "{} {}x{}, {} screen probes, on {}: median of {} frames after {} still \
                 warm-up frames and {} ({clock})\n\n| pass | ms |\n|---|---:|\n",
                run.scene,
                o.size.0,
                o.size.1,
                run.mode.name(),
                run.adapter,
                o.frames,
                o.warmup,
                run.settled.describe(),
            );
            for (name, ms) in run.gi_passes() {
                out += &format!("| {name} | {ms:.3} |\n");
            }
            out += &format!("| **GI (cache/* + mobile/*)** | **{:.3}** |\n", run.gi_ms());
            out += &format!(
                "| GI per frame, 10th / 90th percentile | {:.3} / {:.3} |\n",
                run.spread.p10, run.spread.p90
            );
            for (name, ms) in run.other_passes() {
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
                let m = &run.memory;
                out += &format!(
                    "| {} | {} | {:.3} | {:.3} | {:.2} | {:.2} | {:.2} |\n",
                    run.scene,
                    run.mode.name(),
                    run.gi_ms(),
                    run.other_ms(),
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
            "warmup": o.warmup,
            "settle_s": o.settle_s,
            "frames": o.frames,
            "gi_memory_bar_bytes": GI_MEMORY_BAR_BYTES,
            "runs": self.runs.iter().map(|run| serde_json::json!({
                "scene": run.scene,
                "screen_probes": run.mode.name(),
                "adapter": run.adapter,
                "gpu_timestamps": run.gpu_timestamps,
                "passes_ms": run.median.0.iter()
                    .map(|(name, ms)| (name.clone(), (*ms).into()))
                    .collect::<serde_json::Map<_, _>>(),
                "gi_ms": run.gi_ms(),
                "gi_spread_ms": run.spread.json(),
                "settle": run.settled.json(),
                "frame_wall": run.wall.json(),
                "other_ms": run.other_ms(),
                "memory": memory_json(&run.memory),
            })).collect::<Vec<_>>(),
        })
    }
}

/// The memory breakdown in one line, against the bar.
pub fn memory_line(m: &MobileMemory) -> String {
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

pub fn memory_json(m: &MobileMemory) -> serde_json::Value {
    serde_json::json!({
        "coverage_bytes": m.coverage_bytes,
        "screen_bytes": m.screen_bytes,
        "frame_bytes": m.frame_bytes,
        "gi_bytes": m.gi_bytes(),
        "within_bar": m.gi_bytes() <= GI_MEMORY_BAR_BYTES,
    })
}

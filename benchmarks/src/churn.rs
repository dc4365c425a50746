//! `gi-bench churn`: creates renderers one after another in one process, as the render
//! service does job after job, and reports what each creation cost and whether any failed.
//!
//! Each round opens a GPU context with the chosen [`DeviceSharing`], creates the tier on it,
//! renders `frames` frames and drops everything. With `dedicated` every round opens and
//! destroys a device of its own; with `shared` (the default on hardware adapters) every round
//! after the first reuses the process's device. A round whose context or tier cannot be
//! created ends the run, and the report says which round failed and why. Each round's frames
//! are timed on the wall clock and by the GPU's pass timestamps: the difference per frame is
//! the time the GPU was not rendering the frame.

use std::time::Instant;

use anyhow::Context;
use gi_gpu::{DeviceSharing, GpuContext, GpuOptions, PassTimings};
use gi_tiers::{
    CameraMode, Renderer, Tier, TierKind,
    mobile::{MobileConfig, MobileTier},
    pc::{PcConfig, PcTier},
};

use crate::suite::median;

/// What `gi-bench churn` was asked to do.
pub struct ChurnOptions {
    pub tier: TierKind,
    pub scene: String,
    pub size: (u32, u32),
    pub rounds: u32,
    pub frames: u32,
    pub sharing: DeviceSharing,
}

/// One round: a context, a tier, its frames.
#[derive(Clone, Debug)]
pub struct Round {
    /// Wall-clock milliseconds to open the context and create the tier.
    pub create_ms: f64,
    /// Wall-clock milliseconds of the round's frames (uploads and first use included).
    pub frames_ms: f64,
    /// GPU milliseconds of the same frames: every pass's timestamps, summed. The wall-clock
    /// time less this is what the GPU did not run: CPU work, submission and waiting (each
    /// frame waits for its GPU work before the next one starts).
    pub gpu_ms: f64,
    /// The process's resident memory after the round's renderer was dropped, MiB (Linux).
    pub rss_mib: Option<f64>,
}

/// What `gi-bench churn` measured.
pub struct ChurnReport {
    pub tier: TierKind,
    pub scene: String,
    pub adapter: String,
    pub sharing: DeviceSharing,
    pub size: (u32, u32),
    pub frames: u32,
    pub requested: u32,
    pub rounds: Vec<Round>,
    /// The round (0-based) that could not be created, and the error.
    pub failure: Option<(u32, String)>,
}

impl ChurnReport {
    fn create_ms(&self) -> Vec<f64> {
        self.rounds.iter().map(|r| r.create_ms).collect()
    }

    /// Median creation time of the rounds after the first (which pays the process's first
    /// device and shader composition); `None` with fewer than two rounds.
    pub fn later_create_ms(&self) -> Option<f64> {
        (self.rounds.len() >= 2).then(|| median(&self.create_ms()[1..]))
    }

    /// A markdown table of the results.
    pub fn table(&self) -> String {
        let ms = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.1}"));
        let mib = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.0}"));
        let create = self.create_ms();
        let frames: Vec<f64> = self.rounds.iter().map(|r| r.frames_ms).collect();
        let per_frame = |v: f64| v / f64::from(self.frames.max(1));
        let wall: Vec<f64> = self.rounds.iter().map(|r| per_frame(r.frames_ms)).collect();
        let gpu: Vec<f64> = self.rounds.iter().map(|r| per_frame(r.gpu_ms)).collect();
        let ms2 = |v: &[f64]| {
            (!v.is_empty())
                .then(|| median(v))
                .map_or("-".to_owned(), |v| format!("{v:.2}"))
        };
        let first = self.rounds.first();
        let last = self.rounds.last();
        let outcome = match &self.failure {
            None => format!("all {} rounds completed", self.requested),
            Some((round, error)) => format!(
                "round {} of {} FAILED after {} completed: {error}",
                round + 1,
                self.requested,
                self.rounds.len()
            ),
        };
        format!(
            "{tier} on {scene}, {w}x{h}, {frames} frame(s) a round, device sharing {sharing:?}, \
             on {adapter}: {outcome}\n\
             | rounds | create, first (ms) | create, median of later (ms) | create, max (ms) \
             | frames, median (ms) | a frame: wall (ms) | a frame: GPU passes (ms) | RSS \
             after first (MiB) | RSS after last (MiB) |\n\
             |---:|---:|---:|---:|---:|---:|---:|---:|---:|\n\
             | {n} | {c0} | {c1} | {cmax} | {f} | {fw} | {fg} | {r0} | {r1} |\n",
            tier = self.tier,
            scene = self.scene,
            w = self.size.0,
            h = self.size.1,
            frames = self.frames,
            sharing = self.sharing,
            adapter = self.adapter,
            n = self.rounds.len(),
            c0 = ms(first.map(|r| r.create_ms)),
            c1 = ms(self.later_create_ms()),
            cmax = ms(create.iter().copied().reduce(f64::max)),
            f = ms((!frames.is_empty()).then(|| median(&frames))),
            fw = ms2(&wall),
            fg = ms2(&gpu),
            r0 = mib(first.and_then(|r| r.rss_mib)),
            r1 = mib(last.and_then(|r| r.rss_mib)),
        )
    }

    /// The results as JSON, every round included.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "tier": self.tier.name(),
            "scene": self.scene,
            "adapter": self.adapter,
            "sharing": format!("{:?}", self.sharing).to_lowercase(),
            "width": self.size.0,
            "height": self.size.1,
            "frames": self.frames,
            "requested": self.requested,
            "completed": self.rounds.len(),
            "failure": self.failure.as_ref().map(|(round, error)| serde_json::json!({
                "round": round,
                "error": error,
            })),
            "later_create_ms": self.later_create_ms(),
            "rounds": self.rounds.iter().map(|r| serde_json::json!({
                "create_ms": r.create_ms,
                "frames_ms": r.frames_ms,
                "gpu_ms": r.gpu_ms,
                "rss_mib": r.rss_mib,
            })).collect::<Vec<_>>(),
        })
    }
}

/// Parses `auto`, `shared` or `dedicated`.
pub fn parse_sharing(text: &str) -> Result<DeviceSharing, String> {
    match text {
        "auto" => Ok(DeviceSharing::Auto),
        "shared" => Ok(DeviceSharing::Shared),
        "dedicated" => Ok(DeviceSharing::Dedicated),
        other => Err(format!(
            "unknown device sharing {other:?}: auto, shared or dedicated"
        )),
    }
}

/// The process's resident set size in MiB, from `/proc/self/status` (Linux only).
fn rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// The tier `options` name, on a context with their device sharing, and its adapter's name.
fn create_tier(options: &ChurnOptions) -> anyhow::Result<(Box<dyn Tier>, String)> {
    let ctx = GpuContext::with_options(&GpuOptions {
        sharing: options.sharing,
        ..GpuOptions::from_env()
    })?;
    let adapter = ctx.adapter_info.name.clone();
    // As `pc_renderer` and `mobile_renderer` make them, on this context.
    let settings = crate::pc::bench_settings(options.size);
    let tier: Box<dyn Tier> = match options.tier {
        TierKind::Pc => Box::new(PcTier::new(settings, PcConfig::default(), ctx)?),
        TierKind::Mobile => Box::new(MobileTier::new(settings, MobileConfig::default(), ctx)?),
        other => anyhow::bail!("churn measures the GPU GI tiers (pc, mobile), not {other}"),
    };
    Ok((tier, adapter))
}

pub fn run(options: &ChurnOptions) -> anyhow::Result<ChurnReport> {
    anyhow::ensure!(options.rounds >= 1, "--rounds must be at least 1");
    let scene =
        gi_scene::load(&options.scene).with_context(|| format!("loading {}", options.scene))?;
    let mut report = ChurnReport {
        tier: options.tier,
        scene: options.scene.clone(),
        adapter: String::new(),
        sharing: options.sharing,
        size: options.size,
        frames: options.frames,
        requested: options.rounds,
        rounds: Vec::new(),
        failure: None,
    };
    for round in 0..options.rounds {
        let start = Instant::now();
        let (tier, adapter) = match create_tier(options) {
            Ok(created) => created,
            Err(error) if round > 0 => {
                report.failure = Some((round, format!("{error:#}")));
                break;
            }
            // The first round failing says nothing about churn: the tier cannot run here.
            Err(error) => return Err(error),
        };
        let create_ms = start.elapsed().as_secs_f64() * 1e3;
        report.adapter = adapter;
        let mut renderer = Renderer::with_tier(scene.clone(), tier, CameraMode::Default);
        let start = Instant::now();
        let mut gpu_ms = 0.0;
        for _ in 0..options.frames {
            gpu_ms += PassTimings(renderer.advance_frame(None)?).total_ms();
        }
        let frames_ms = start.elapsed().as_secs_f64() * 1e3;
        drop(renderer);
        report.rounds.push(Round {
            create_ms,
            frames_ms,
            gpu_ms,
            rss_mib: rss_mib(),
        });
    }
    Ok(report)
}

//! What `gi-bench mobile` and `gi-bench pc` share: one measurement of a real-time GI tier's
//! renderer ([`Measured`]: the still warm-up, the clock's settling, the timed frames, the
//! memory) and its JSON fields.

use gi_gpu::PassTimings;
use gi_tiers::{GiMemory, MobileTier, PcTier, Renderer, TierKind};

use crate::settle::{self, FrameWall, GiSpread, Settled};

/// Mebibytes.
pub const MIB: f64 = (1 << 20) as f64;

/// How many frames a measurement renders.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    /// Still warm-up frames ([`Renderer::warm_up`]).
    pub warmup: u32,
    /// Least seconds of still frames after the warm-up for the GPU's clock to settle
    /// ([`settle::settle`]); 0 measures at once.
    pub settle_s: f64,
    /// Measured frames (at least 1), scene time advancing.
    pub frames: u32,
}

impl Schedule {
    /// An error unless it measures a frame at least.
    pub fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(self.frames >= 1, "--frames must be at least 1");
        Ok(())
    }
}

/// One renderer of a real-time GI tier, measured.
pub struct Measured {
    pub kind: TierKind,
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
    pub memory: GiMemory,
}

impl Measured {
    /// Warms `renderer` up, lets the clock settle and times its frames, as `schedule` says.
    /// The renderer holds a mobile or a PC tier.
    pub fn of(renderer: &mut Renderer, schedule: &Schedule) -> anyhow::Result<Self> {
        let kind = renderer.tier();
        renderer.warm_up(schedule.warmup, None)?;
        let settled = settle::settle(renderer, kind, schedule.settle_s)?;
        let (frames, wall) = settle::time_frames(renderer, kind, schedule.frames)?;
        let memory = match (
            renderer.tier_as::<MobileTier>(),
            renderer.tier_as::<PcTier>(),
        ) {
            (Some(mobile), _) => mobile.memory(),
            (_, Some(pc)) => pc.memory(),
            _ => anyhow::bail!("{kind} is not a real-time GI tier"),
        };
        let ctx = renderer
            .context()
            .expect("a real-time tier renders on a GPU");
        Ok(Self {
            kind,
            adapter: ctx.adapter_info.name.clone(),
            gpu_timestamps: ctx.supports_timestamps(),
            median: PassTimings::median(&frames),
            spread: GiSpread::of(kind, &frames),
            wall,
            settled,
            memory,
        })
    }

    /// Sum of the GI passes' medians (`cache/*` and the tier's own).
    pub fn gi_ms(&self) -> f64 {
        settle::gi_ms(self.kind, &self.median.0)
    }

    /// Sum of the other passes' medians.
    pub fn other_ms(&self) -> f64 {
        self.passes(false).map(|(_, ms)| ms).sum()
    }

    /// The GI passes (`gi`) or the others, with their medians, in order.
    pub fn passes(&self, gi: bool) -> impl Iterator<Item = (&str, f64)> {
        self.median
            .0
            .iter()
            .filter(move |(name, _)| self.kind.is_gi_pass(name) == gi)
            .map(|(name, ms)| (name.as_str(), *ms))
    }

    /// How the frames were timed, for table captions.
    pub fn clock(&self) -> &'static str {
        if self.gpu_timestamps {
            "GPU timestamps"
        } else {
            "CPU wall-clock"
        }
    }

    /// The measurement's JSON fields, added to `fields` (a run's scene and variant).
    pub fn json(&self, mut fields: serde_json::Value) -> serde_json::Value {
        let measured = serde_json::json!({
            "adapter": self.adapter,
            "gpu_timestamps": self.gpu_timestamps,
            "passes_ms": self.median.0.iter()
                .map(|(name, ms)| (name.clone(), (*ms).into()))
                .collect::<serde_json::Map<_, _>>(),
            "gi_ms": self.gi_ms(),
            "gi_spread_ms": self.spread.json(),
            "settle": self.settled.json(),
            "frame_wall": self.wall.json(),
            "other_ms": self.other_ms(),
            "memory": memory_json(&self.memory),
        });
        if let (Some(fields), serde_json::Value::Object(measured)) =
            (fields.as_object_mut(), measured)
        {
            fields.extend(measured);
        }
        fields
    }
}

/// The GI memory bar of the mobile tier's issue: 32 MB, read as 32 * 10^6 bytes (the stricter
/// reading).
pub const GI_MEMORY_BAR_BYTES: u64 = 32_000_000;

/// The memory breakdown in JSON, with whether the GI fits [`GI_MEMORY_BAR_BYTES`].
pub fn memory_json(m: &GiMemory) -> serde_json::Value {
    serde_json::json!({
        "coverage_bytes": m.coverage_bytes,
        "screen_bytes": m.screen_bytes,
        "frame_bytes": m.frame_bytes,
        "gi_bytes": m.gi_bytes(),
        "within_bar": m.gi_bytes() <= GI_MEMORY_BAR_BYTES,
    })
}

//! What every tier is: created from a scene and settings, renders frames, reports its passes'
//! timings and its memory.

use gi_gpu::TextureOptions;
use std::{any::Any, fmt, str::FromStr};

use gi_image::Image;
use gi_reference::RenderStats;
use gi_scene::{Scene, SceneFrame};

/// The tiers this build can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TierKind {
    /// The CPU path tracer: full light transport, the ground truth and the no-GPU fallback.
    Reference,
    /// Direct lighting only (the "None" baseline): punctual lights with exact shadows, plus
    /// emitters and sky seen directly by the camera. Runs on a hardware GPU when there is one
    /// and on the CPU otherwise, with the same image.
    Direct,
    /// The GPU path tracer: the reference's full transport in a compute shader, the same image
    /// as `reference` for the same seed and samples. Progressive: each frame adds its samples
    /// to those of the frames before it while the camera and scene stay still.
    Path,
    /// The mobile tier: the brick radiance cache, a probe volume and deferred screen probes
    /// with a temporal filter (`crate::MobileTier`). Temporal: it converges over frames.
    Mobile,
    /// The PC tier: BVH-traced ReSTIR GI over the brick cache, with a visibility ray,
    /// multi-sample shading and SVGF (`crate::PcTier`). Temporal.
    Pc,
}

impl TierKind {
    /// Every tier, in the order tables list them.
    pub const ALL: [TierKind; 5] = [
        TierKind::Reference,
        TierKind::Direct,
        TierKind::Path,
        TierKind::Mobile,
        TierKind::Pc,
    ];

    /// The name used on the command line, in JSON and in pass names.
    pub fn name(self) -> &'static str {
        match self {
            TierKind::Reference => "reference",
            TierKind::Direct => "direct",
            TierKind::Path => "path",
            TierKind::Mobile => "mobile",
            TierKind::Pc => "pc",
        }
    }

    /// Still warm-up frames a measurement of this tier renders before its measured frames
    /// ([`crate::Renderer::warm_up`]): 63 for `mobile`, so the measured frame is the 64th of a
    /// still view, when its temporal filter (at most 32 frames of history per pixel, 64 per
    /// probe face) has converged; 63 for `pc` too (its reservoirs count at most 5 frames, its
    /// denoiser's long history 50, and the cache under both converges as the mobile tier's);
    /// 0 for the others. The path tier's progressive accumulation
    /// is controlled by its samples per pixel and frames instead, and the CPU tiers keep no
    /// history. More warm-up costs time linearly and only changes temporal tiers.
    pub fn default_warmup(self) -> u32 {
        match self {
            TierKind::Mobile | TierKind::Pc => 63,
            TierKind::Reference | TierKind::Direct | TierKind::Path => 0,
        }
    }

    /// True when the pass named `pass` (`group/name`) is part of this tier's GI cost, the
    /// figure compared with a GI budget: the mobile tier's `cache/*` and `mobile/*` passes,
    /// not the G-buffer (`gbuffer/*`) or direct light (`direct/*`) every tier needs. The other
    /// tiers compute their whole image as one transport, so no pass of theirs is split out.
    pub fn is_gi_pass(self, pass: &str) -> bool {
        match self {
            TierKind::Mobile => pass.starts_with("cache/") || pass.starts_with("mobile/"),
            TierKind::Pc => pass.starts_with("cache/") || pass.starts_with("pc/"),
            TierKind::Reference | TierKind::Direct | TierKind::Path => false,
        }
    }
}

impl fmt::Display for TierKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for TierKind {
    type Err = TierError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        TierKind::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| TierError::UnknownTier {
                name: s.to_string(),
                available: TierKind::ALL.map(TierKind::name).join(", "),
            })
    }
}

/// What a caller asks [`crate::Renderer::new`] for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TierChoice {
    /// The best real-time GI tier for the adapter, without a frame budget: `pc` on a discrete
    /// or virtual GPU, `mobile` on an integrated one, the CPU `reference` on a software
    /// adapter or without one ([`crate::select`] has the whole policy).
    /// [`crate::Renderer::selection`] says what it chose and why.
    Auto,
    /// The best real-time GI tier whose estimated frame time on the adapter fits the budget;
    /// `mobile` with a reason saying so when none fits ([`crate::select`]).
    AutoWithin(FrameBudget),
    /// One tier by kind, with its default configuration ([`crate::Renderer::with_tier`] takes
    /// one configured otherwise): `mobile` and `pc` need a Vulkan adapter, `path` too
    /// (`Unavailable` without one); `direct` runs on a hardware GPU when there is one, else on
    /// the CPU; `reference` is the CPU path tracer, the ground truth, and needs no GPU.
    Tier(TierKind),
}

/// `auto` or a tier's name ([`TierKind::name`]); an unknown name is
/// [`TierError::UnknownTier`], listing `auto` with the tiers.
impl FromStr for TierChoice {
    type Err = TierError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "auto" {
            return Ok(TierChoice::Auto);
        }
        s.parse()
            .map(TierChoice::Tier)
            .map_err(|_| TierError::UnknownTier {
                name: s.to_string(),
                available: format!("auto, {}", TierKind::ALL.map(TierKind::name).join(", ")),
            })
    }
}

impl From<TierKind> for TierChoice {
    fn from(kind: TierKind) -> Self {
        TierChoice::Tier(kind)
    }
}

impl TierChoice {
    /// The frame budget of [`TierChoice::AutoWithin`], `None` for every other choice.
    pub fn budget(self) -> Option<FrameBudget> {
        match self {
            TierChoice::AutoWithin(budget) => Some(budget),
            _ => None,
        }
    }

    /// True for the choices the policy decides ([`TierChoice::Auto`] and
    /// [`TierChoice::AutoWithin`]).
    pub fn is_auto(self) -> bool {
        matches!(self, TierChoice::Auto | TierChoice::AutoWithin(_))
    }
}

/// Settings shared by every tier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TierSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel per frame: path samples for the path tracers, anti-aliasing samples
    /// for `direct`. More samples cost time linearly and reduce noise as 1/sqrt(spp).
    pub spp: u32,
    /// Seed of every random decision; the same seed gives the same image.
    pub seed: u64,
    /// How much of the scene's textures the GPU tiers upload: a memory budget (textures over
    /// it are downscaled, with a warning) and the largest size.
    pub textures: TextureOptions,
}

impl TierSettings {
    /// Checks that the settings can render anything: an image of at least one pixel within
    /// the reference's size limits (`gi_reference::MAX_SIDE` per side,
    /// `gi_reference::MAX_PIXELS` in all) and at least one sample per pixel. Every tier runs
    /// it before it creates anything.
    pub fn validate(&self) -> Result<(), TierError> {
        gi_reference::RenderSettings {
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            ..gi_reference::RenderSettings::default()
        }
        .validate()
        .map_err(TierError::from)
    }
}

/// One frame handed to a tier.
pub struct FrameInput<'a> {
    pub scene: &'a Scene,
    /// The scene evaluated at this frame's time, seen through this frame's camera.
    pub frame: &'a SceneFrame,
    /// Frames rendered before this one since the tier was created, warm-up frames included
    /// (so per-frame jitter keeps changing through a still warm-up).
    pub index: u32,
    /// Called with the samples per pixel done so far, for progress bars.
    pub progress: Option<&'a (dyn Fn(u32) + Sync)>,
}

/// What a tier returns for a frame.
pub struct FrameOutput {
    /// Linear HDR radiance.
    pub image: Image,
    /// Named passes (`"reference/trace"`) and their time in milliseconds, in execution order.
    pub passes: Vec<(String, f64)>,
    /// Path-tracing throughput of the frame, for tiers that trace paths (on the CPU or GPU).
    pub stats: Option<RenderStats>,
}

/// The passes of a frame [`Tier::submit`] rendered, reported once the GPU has finished it.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTimings {
    /// The frame's [`FrameInput::index`].
    pub index: u32,
    /// Named passes and their time in milliseconds, in execution order, as
    /// [`FrameOutput::passes`].
    pub passes: Vec<(String, f64)>,
}

impl FrameTimings {
    /// The frames a [`gi_gpu::GpuTimer`] reported, each tagged with its frame index.
    pub(crate) fn from_timer(reported: Vec<(u32, gi_gpu::PassTimings)>) -> Vec<Self> {
        reported
            .into_iter()
            .map(|(index, timings)| Self {
                index,
                passes: timings.0,
            })
            .collect()
    }
}

impl FrameOutput {
    /// The frame's total time: the sum of its passes.
    pub fn ms_total(&self) -> f64 {
        self.passes.iter().map(|(_, ms)| ms).sum()
    }

    /// The frame's GI cost for `kind`: the sum of its passes that [`TierKind::is_gi_pass`].
    pub fn gi_ms(&self, kind: TierKind) -> f64 {
        self.passes
            .iter()
            .filter(|(name, _)| kind.is_gi_pass(name))
            .map(|(_, ms)| ms)
            .sum()
    }
}

/// A GI technique that renders frames of a scene, possibly reusing history between them.
///
/// `Any` lets a caller that knows the concrete tier reach its own methods through
/// [`crate::Renderer::tier_as`] (the mobile tier's frame data and memory breakdown).
pub trait Tier: Send + Any {
    fn kind(&self) -> TierKind;

    /// True when the tier reuses history, so every frame must be rendered in order. Tiers
    /// without history render only the frames that are asked for.
    fn is_temporal(&self) -> bool;

    /// True when the tier places the shading of moving skinned meshes itself (the GPU tiers
    /// skin them on the GPU: `gi_gpu::gpu_skinned_nodes`), so [`crate::Renderer`] evaluates
    /// their frames without those meshes' normals and tangents
    /// ([`gi_scene::Evaluation::positions_only`]). False unless the tier says otherwise.
    fn skins_on_gpu(&self) -> bool {
        false
    }

    /// Renders one frame.
    ///
    /// A tier keeps what it uploaded for the scene of its first frame (geometry,
    /// acceleration structures, caches) and reuses it for later frames: every frame given to
    /// one tier must come from the same [`Scene`](gi_scene::Scene) (at any time and through
    /// any camera). Render another scene with another tier; [`crate::Renderer`] does this.
    fn render(&mut self, input: &FrameInput) -> Result<FrameOutput, TierError>;

    /// Renders one frame as [`Tier::render`] does but does not hand its image over: for
    /// warm-up frames and timing runs, which need the tier's state and its pass times, not
    /// the pixels. GPU tiers keep the image on the GPU (no readback, which at 1080p costs
    /// more than the frame and leaves the GPU idle); others render it and drop it. Returns the
    /// frame's passes.
    fn advance(&mut self, input: &FrameInput) -> Result<Vec<(String, f64)>, TierError> {
        self.render(input).map(|output| output.passes)
    }

    /// Renders one frame as [`Tier::advance`] does without waiting for the GPU to finish it,
    /// as an engine's frame loop runs: the CPU records the next frame while the GPU works on
    /// this one, and the frame's time is the larger of the two rather than their sum. Returns
    /// the passes of the frames the GPU has finished since the last call, oldest first, each
    /// under its [`FrameInput::index`]; this frame's come from a later call or from
    /// [`Tier::flush`]. The PC and mobile tiers keep at most [`gi_gpu::FRAMES_IN_FLIGHT`]
    /// frames in flight (a frame waits for the oldest beyond that); the others (the CPU tiers,
    /// and the path tier, which reads its image back every frame) render the frame and report
    /// it at once. The tier's state after a frame is the same either way: a frame rendered
    /// after `submit`s shows what it would after `advance`s.
    fn submit(&mut self, input: &FrameInput) -> Result<Vec<FrameTimings>, TierError> {
        let passes = self.advance(input)?;
        Ok(vec![FrameTimings {
            index: input.index,
            passes,
        }])
    }

    /// Waits for every frame [`Tier::submit`] left in flight and returns their passes,
    /// oldest first.
    fn flush(&mut self) -> Vec<FrameTimings> {
        Vec::new()
    }

    /// Bytes of every buffer, texture and acceleration structure the tier owns now.
    fn memory_bytes(&self) -> u64;

    /// Where the last frame's images lie on the tier's GPU, for [`crate::OutputTextures`];
    /// `None` for a tier that renders on the CPU or before its first frame.
    fn gpu_output(&self) -> Option<crate::output::GpuOutput<'_>> {
        None
    }

    /// The device the tier renders on; `None` for a tier that renders on the CPU.
    fn gpu_context(&self) -> Option<&gi_gpu::GpuContext> {
        None
    }
}

/// Why a tier could not be created or could not render.
#[derive(Debug, thiserror::Error)]
pub enum TierError {
    #[error("unknown tier '{name}' (available: {available})")]
    UnknownTier { name: String, available: String },
    #[error("the {tier} tier is not available: {reason}")]
    Unavailable { tier: &'static str, reason: String },
    #[error(transparent)]
    Render(#[from] gi_reference::RenderError),
    /// A request the renderer cannot honour: a node that does not exist or is not movable, a
    /// camera that is no perspective camera.
    #[error("{0}")]
    InvalidRequest(String),
    /// The frame stopped before its end because its caller asked ([`crate::CpuTier::with_cancel`]).
    #[error("the frame was cancelled")]
    Cancelled,
}

/// A frame-time budget, kept in whole microseconds so it stays `Copy + Eq` inside
/// [`TierChoice`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameBudget {
    micros: u64,
}

impl FrameBudget {
    /// A budget of `ms` milliseconds, rounded to the microsecond; negative or non-finite values
    /// give a zero budget, which nothing fits.
    pub fn from_ms(ms: f64) -> Self {
        let micros = if ms.is_finite() && ms > 0.0 {
            (ms * 1000.0).round() as u64
        } else {
            0
        };
        Self { micros }
    }

    /// The budget in milliseconds.
    pub fn ms(self) -> f64 {
        self.micros as f64 / 1000.0
    }
}

impl fmt::Display for FrameBudget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ms", self.ms())
    }
}

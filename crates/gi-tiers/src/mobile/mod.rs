//! The mobile tier (`mobile`): the surfel brick radiance cache (gi-cache), a world-space probe
//! volume and deferred screen probes with a temporal filter, after HSGI's mobile solution
//! (GDC 2023) and SmartGI's screen-probe economy (SIGGRAPH 2024).

mod config;
mod volume;

pub use config::{MobileConfig, PROBE_TEXELS, ScreenConfig, ScreenProbeMode, VolumeConfig};
pub use volume::ProbeVolume;

use gi_gpu::GpuContext;
use gi_image::Image;

use crate::tier::{FrameInput, FrameOutput, Tier, TierError, TierKind, TierSettings};

/// GPU memory of the mobile tier by what it scales with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MobileMemory {
    /// World-space GI structures, fixed by the configuration's coverage: the brick cache and
    /// the probe volume.
    pub coverage_bytes: u64,
    /// Resolution-dependent GI buffers: lite G-buffer, screen probes, half-resolution
    /// irradiance and its history, full-resolution GI.
    pub screen_bytes: u64,
    /// What every tier of the product needs besides GI: scene, BVH, G-buffer, direct light.
    pub frame_bytes: u64,
}

impl MobileMemory {
    /// The GI's own memory: coverage plus screen buffers.
    pub fn gi_bytes(&self) -> u64 {
        self.coverage_bytes + self.screen_bytes
    }
}

/// One frame's GI and what identifies its pixels, one entry per pixel in row-major order.
#[derive(Clone, Debug)]
pub struct MobileFrameData {
    /// The GI term: linear radiance the tier added to the direct light (diffuse albedo times
    /// the gathered irradiance over pi, plus the approximate specular part).
    pub gi: Image,
    /// The gathered irradiance itself (before albedo), full resolution.
    pub irradiance: Image,
    /// Pixels showing a node moved by an animation (the lite G-buffer's mask bit).
    pub dynamic: Vec<bool>,
    /// `gbuffer.motion`: previous pixel position minus this pixel's center, in pixels.
    pub motion: Vec<[f32; 2]>,
    /// `gbuffer.depth`: distance along the pixel's unit ray, `+inf` for sky.
    pub depth: Vec<f32>,
}

/// The mobile tier. See the module docs.
pub struct MobileTier {
    settings: TierSettings,
    config: MobileConfig,
    ctx: GpuContext,
}

impl MobileTier {
    /// A mobile tier on `ctx`.
    pub fn new(
        settings: TierSettings,
        config: MobileConfig,
        ctx: GpuContext,
    ) -> Result<Self, TierError> {
        Ok(Self {
            settings,
            config,
            ctx,
        })
    }

    /// Opens the default GPU context and makes a mobile tier on it; `Unavailable` with the GPU
    /// error when there is no adapter.
    pub fn open(settings: TierSettings, config: MobileConfig) -> Result<Self, TierError> {
        let ctx = GpuContext::new().map_err(|e| TierError::Unavailable {
            tier: "mobile",
            reason: e.to_string(),
        })?;
        Self::new(settings, config, ctx)
    }

    pub fn config(&self) -> &MobileConfig {
        &self.config
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The last frame's GI term and the G-buffer data needed to compare it across frames,
    /// read back from the GPU (stalls); `None` before the first frame. For tests and metrics.
    pub fn frame_data(&self) -> Option<MobileFrameData> {
        None
    }

    /// The tier's GPU memory now, by what it scales with.
    pub fn memory(&self) -> MobileMemory {
        MobileMemory::default()
    }
}

impl Tier for MobileTier {
    fn kind(&self) -> TierKind {
        TierKind::Mobile
    }

    fn is_temporal(&self) -> bool {
        true
    }

    fn render(&mut self, _input: &FrameInput) -> Result<FrameOutput, TierError> {
        let _ = self.settings;
        Err(TierError::Unavailable {
            tier: "mobile",
            reason: "not wired yet".to_string(),
        })
    }

    fn memory_bytes(&self) -> u64 {
        self.ctx.memory().total_bytes()
    }
}

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

    /// The GI term of the last frame (linear radiance the tier added to the direct light),
    /// read back from the GPU; `None` before the first frame. For tests and metrics.
    pub fn gi_image(&self) -> Option<Image> {
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

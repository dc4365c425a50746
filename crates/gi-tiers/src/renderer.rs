//! The [`Renderer`] facade: a scene, a tier and a frame counter.

use gi_scene::{CameraView, Scene};

use gi_gpu::{GpuContext, wgpu};

use crate::{
    cpu::CpuTier,
    mobile::{MobileConfig, MobileTier},
    path::GpuPathTier,
    tier::{FrameInput, FrameOutput, Tier, TierChoice, TierError, TierKind, TierSettings},
};

/// Which camera the frames look through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMode {
    /// The scene's default camera (moving with its node if the node is animated).
    Default,
    /// The scene's camera path (from its extras) at each frame's time.
    Path,
}

/// Renders the frames of one scene with one tier. Frame `i` shows the scene at time
/// `scene.frame_time(i)`.
pub struct Renderer {
    scene: Scene,
    tier: Box<dyn Tier>,
    camera: CameraMode,
    next_frame: u32,
}

impl Renderer {
    /// Creates the tier `choice` resolves to for `scene`.
    pub fn new(
        scene: Scene,
        choice: TierChoice,
        settings: TierSettings,
        camera: CameraMode,
    ) -> Result<Self, TierError> {
        let tier: Box<dyn Tier> = match choice {
            TierChoice::Mobile | TierChoice::Tier(TierKind::Mobile) => {
                Box::new(MobileTier::open(settings, MobileConfig::default())?)
            }
            TierChoice::Pc => return Err(not_built("pc")),
            TierChoice::Path | TierChoice::Tier(TierKind::Path) => {
                Box::new(GpuPathTier::open(TierKind::Path, settings)?)
            }
            TierChoice::Auto => match hardware_gpu() {
                Some(ctx) => Box::new(GpuPathTier::new(TierKind::Path, settings, ctx)?),
                None => Box::new(CpuTier::new(TierKind::Reference, settings)?),
            },
            TierChoice::Tier(TierKind::Direct) => match hardware_gpu() {
                Some(ctx) => Box::new(GpuPathTier::new(TierKind::Direct, settings, ctx)?),
                None => Box::new(CpuTier::new(TierKind::Direct, settings)?),
            },
            TierChoice::Tier(kind) => Box::new(CpuTier::new(kind, settings)?),
        };
        Ok(Self {
            scene,
            tier,
            camera,
            next_frame: 0,
        })
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn tier(&self) -> TierKind {
        self.tier.kind()
    }

    /// Index of the frame the next call renders.
    pub fn next_frame(&self) -> u32 {
        self.next_frame
    }

    /// Scene time of frame `index`.
    pub fn frame_time(&self, index: u32) -> f32 {
        self.scene.frame_time(index)
    }

    /// The camera of frame `index`.
    pub fn view(&self, index: u32) -> CameraView {
        let time = self.frame_time(index);
        match self.camera {
            CameraMode::Default => self.scene.default_view(time),
            CameraMode::Path => self.scene.path_view(time),
        }
    }

    /// Renders the next frame.
    pub fn render_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<FrameOutput, TierError> {
        let index = self.next_frame;
        let frame = self
            .scene
            .evaluate(self.frame_time(index), Some(self.view(index)));
        let output = self.tier.render(&FrameInput {
            scene: &self.scene,
            frame: &frame,
            index,
            progress,
        })?;
        self.next_frame += 1;
        Ok(output)
    }

    /// Advances `count` frames (at least one) and returns the last: warm-up frames, then the
    /// measured one. Tiers without history skip straight to the last frame.
    pub fn render_frames(
        &mut self,
        count: u32,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<FrameOutput, TierError> {
        let count = count.max(1);
        if !self.tier.is_temporal() {
            self.next_frame += count - 1;
        } else {
            for _ in 1..count {
                self.render_frame(None)?;
            }
        }
        self.render_frame(progress)
    }

    /// Bytes the tier owns now.
    pub fn memory_bytes(&self) -> u64 {
        self.tier.memory_bytes()
    }
}

/// A context on a hardware GPU, or `None` when there is no adapter or only a software one
/// (which runs the GPU tiers slower than the CPU runs the reference).
fn hardware_gpu() -> Option<GpuContext> {
    GpuContext::new()
        .ok()
        .filter(|ctx| ctx.adapter_info.device_type != wgpu::DeviceType::Cpu)
}

fn not_built(tier: &'static str) -> TierError {
    TierError::Unavailable {
        tier,
        reason: "this tier is not built yet".to_string(),
    }
}

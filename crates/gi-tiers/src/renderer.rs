//! The [`Renderer`] facade: a scene, a tier and a frame counter.

use std::any::Any;

use gi_scene::{CameraView, Scene};

use gi_gpu::{GpuContext, wgpu};

use crate::{
    cpu::CpuTier,
    mobile::{MobileConfig, MobileTier},
    path::GpuPathTier,
    pc::{PcConfig, PcTier},
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
    /// Still warm-up frames rendered so far ([`Renderer::warm_up`]); they show an existing
    /// frame again, so they do not advance `next_frame`.
    warm_up_frames: u32,
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
            TierChoice::Pc | TierChoice::Tier(TierKind::Pc) => {
                Box::new(PcTier::open(settings, PcConfig::default())?)
            }
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
        Ok(Self::with_tier(scene, tier, camera))
    }

    /// Renders `scene` with a tier the caller made, e.g. a [`MobileTier`] with another
    /// [`MobileConfig`] than the default `new` uses.
    pub fn with_tier(scene: Scene, tier: Box<dyn Tier>, camera: CameraMode) -> Self {
        Self {
            scene,
            tier,
            camera,
            next_frame: 0,
            warm_up_frames: 0,
        }
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene, to change it between frames (e.g. turn a light to measure how fast a
    /// temporal tier settles). Every frame is evaluated from it afresh, but a tier may keep
    /// what it prepared from earlier frames ([`Tier::render`]): geometry always, and the CPU
    /// and path tiers their whole prepared scene until the camera or the animation time
    /// changes. So an edit reaches the image only through a tier that reads it per frame;
    /// meshes, materials and the node count must not change (render another scene with a new
    /// `Renderer`).
    pub fn scene_mut(&mut self) -> &mut Scene {
        &mut self.scene
    }

    pub fn tier(&self) -> TierKind {
        self.tier.kind()
    }

    /// The tier as its concrete type, to reach what only that tier offers (the mobile tier's
    /// [`MobileTier::frame_data`] and [`MobileTier::memory`]); `None` if it is another type.
    pub fn tier_as<T: Tier>(&self) -> Option<&T> {
        let tier: &dyn Any = self.tier.as_ref();
        tier.downcast_ref()
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

    /// Still warm-up frames rendered so far.
    pub fn warm_up_frames(&self) -> u32 {
        self.warm_up_frames
    }

    /// Renders the next frame.
    pub fn render_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<FrameOutput, TierError> {
        let output = self.still(progress, |tier, input| tier.render(input))?;
        self.next_frame += 1;
        Ok(output)
    }

    /// Renders the next frame as [`Renderer::render_frame`] does but without its image
    /// ([`Tier::advance`]): for frames that are timed or only lead up to the one that is
    /// looked at. Returns the frame's passes.
    pub fn advance_frame(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<Vec<(String, f64)>, TierError> {
        let passes = self.still(progress, |tier, input| tier.advance(input))?;
        self.next_frame += 1;
        Ok(passes)
    }

    /// A still warm-up for temporal tiers: renders `frames` frames that all show the next
    /// frame (frame 0 on a new renderer: its time and camera) without advancing the frame
    /// counter, so history-based tiers converge on a still view before the frames that are
    /// measured. Tiers without history ([`Tier::is_temporal`] false) skip it. Each warm-up
    /// frame costs a full frame; [`TierKind::default_warmup`] is how many a measurement of a
    /// tier wants. `progress` is called with the warm-up frames done so far.
    pub fn warm_up(
        &mut self,
        frames: u32,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<(), TierError> {
        if !self.tier.is_temporal() {
            return Ok(());
        }
        for done in 1..=frames {
            self.still(None, |tier, input| tier.advance(input))?;
            self.warm_up_frames += 1;
            if let Some(progress) = progress {
                progress(done);
            }
        }
        Ok(())
    }

    /// Renders the next frame through `render` (the tier's `render` or `advance`) without
    /// advancing the frame counter. The tier's frame index counts every frame it rendered,
    /// warm-up included.
    fn still<T>(
        &mut self,
        progress: Option<&(dyn Fn(u32) + Sync)>,
        render: impl FnOnce(&mut dyn Tier, &FrameInput) -> Result<T, TierError>,
    ) -> Result<T, TierError> {
        let shown = self.next_frame;
        let frame = self
            .scene
            .evaluate(self.frame_time(shown), Some(self.view(shown)));
        render(
            self.tier.as_mut(),
            &FrameInput {
                scene: &self.scene,
                frame: &frame,
                index: self.next_frame + self.warm_up_frames,
                progress,
            },
        )
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
                self.advance_frame(None)?;
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

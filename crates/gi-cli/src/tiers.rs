//! How the `gi` command runs one render of a tier through the gi-tiers [`Renderer`].

use std::collections::BTreeMap;

use anyhow::Result;
use gi_image::Image;
use gi_reference::RenderStats;
use gi_scene::{CameraView, Scene};
use gi_tiers::{CameraMode, Renderer, TierChoice, TierKind, TierSettings};
use serde::Serialize;

/// Which camera a render looks through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraChoice {
    /// The scene's default camera (animated with its node, if the node moves).
    Default,
    /// The scene's camera path from its extras, at the frame's time.
    Path,
}

impl From<CameraChoice> for CameraMode {
    fn from(choice: CameraChoice) -> Self {
        match choice {
            CameraChoice::Default => CameraMode::Default,
            CameraChoice::Path => CameraMode::Path,
        }
    }
}

/// What a render asks of a tier.
#[derive(Clone, Debug)]
pub struct RenderRequest {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel for the path tracer; anti-aliasing samples for `direct`.
    pub spp: u32,
    /// Frames simulated; the last one is the image returned.
    pub frames: u32,
    pub seed: u64,
    pub camera: CameraChoice,
}

impl RenderRequest {
    /// Scene time of the measured (last) frame.
    pub fn time_s(&self, scene: &Scene) -> f32 {
        scene.frame_time(self.frames.saturating_sub(1))
    }

    /// Camera of the measured (last) frame.
    pub fn view(&self, scene: &Scene) -> CameraView {
        let time = self.time_s(scene);
        match self.camera {
            CameraChoice::Default => scene.default_view(time),
            CameraChoice::Path => scene.path_view(time),
        }
    }
}

/// The result of one tier render.
pub struct TierRender {
    pub image: Image,
    /// Time of the measured frame in milliseconds (the sum of its passes).
    pub ms_per_frame: f64,
    /// Named passes of the measured frame and their time in milliseconds.
    pub passes: BTreeMap<String, f64>,
    /// Bytes the tier owns after the measured frame.
    pub memory_bytes: u64,
    pub stats: Option<RenderStats>,
}

/// Renders `request.frames` frames of `scene` with `tier` and returns the last.
pub fn render_tier(
    scene: &Scene,
    tier: TierKind,
    request: &RenderRequest,
    progress: &(dyn Fn(u32) + Sync),
) -> Result<TierRender> {
    let settings = TierSettings {
        width: request.width,
        height: request.height,
        spp: request.spp,
        seed: request.seed,
    };
    let mut renderer = Renderer::new(
        scene.clone(),
        TierChoice::Tier(tier),
        settings,
        request.camera.into(),
    )?;
    let frame = renderer.render_frames(request.frames, Some(progress))?;
    Ok(TierRender {
        ms_per_frame: frame.ms_total(),
        passes: frame.passes.iter().cloned().collect(),
        memory_bytes: renderer.memory_bytes(),
        image: frame.image,
        stats: frame.stats,
    })
}

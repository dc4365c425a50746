//! The tiers the `gi` command can run, and how one render of a tier is carried out.

use std::{collections::BTreeMap, fmt, str::FromStr, time::Instant};

use anyhow::Result;
use gi_image::Image;
use gi_reference::{Mode, Reference, RenderSettings, RenderStats, Strategy};
use gi_scene::{CameraView, Scene, SceneFrame};
use serde::Serialize;

/// A tier selectable with `--tier`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tier {
    /// The CPU path tracer: full light transport, the ground truth.
    Reference,
    /// Direct lighting only (the "None" baseline): punctual lights with shadows, plus
    /// emitters and sky seen directly by the camera.
    Direct,
}

impl Tier {
    pub const ALL: [Tier; 2] = [Tier::Reference, Tier::Direct];

    pub fn name(self) -> &'static str {
        match self {
            Tier::Reference => "reference",
            Tier::Direct => "direct",
        }
    }
}

impl fmt::Display for Tier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Tier {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Tier::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Tier::ALL.iter().map(|t| t.name()).collect();
                format!("unknown tier '{s}' (available: {})", names.join(", "))
            })
    }
}

/// Which camera a render looks through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraChoice {
    /// The scene's default camera (animated with its node, if the node moves).
    Default,
    /// The scene's camera path from its extras, at the frame's time.
    Path,
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

    pub fn view(&self, scene: &Scene) -> CameraView {
        let time = self.time_s(scene);
        match self.camera {
            CameraChoice::Default => scene.default_view(time),
            CameraChoice::Path => scene.path_view(time),
        }
    }

    pub fn evaluate(&self, scene: &Scene) -> SceneFrame {
        scene.evaluate(self.time_s(scene), Some(self.view(scene)))
    }
}

/// The result of one tier render.
pub struct TierRender {
    pub image: Image,
    /// Wall time of the measured frame in milliseconds.
    pub ms_per_frame: f64,
    /// Named passes of the frame and their time in milliseconds.
    pub passes: BTreeMap<String, f64>,
    /// Bytes of acceleration structures, scene data and image buffers the tier holds.
    pub memory_bytes: u64,
    pub stats: RenderStats,
    pub triangles: usize,
}

/// Renders the last frame of `request` with `tier`. The CPU tiers keep no history between
/// frames, so only the measured frame is rendered; temporal tiers will run every frame.
pub fn render_tier(
    scene: &Scene,
    tier: Tier,
    request: &RenderRequest,
    progress: &(dyn Fn(u32) + Sync),
) -> Result<TierRender> {
    let frame = request.evaluate(scene);
    let triangles = frame.triangles.len();
    let started = Instant::now();
    let reference = Reference::new(scene, frame);
    let setup_ms = started.elapsed().as_secs_f64() * 1e3;
    let settings = RenderSettings {
        width: request.width,
        height: request.height,
        spp: request.spp,
        seed: request.seed,
        mode: match tier {
            Tier::Reference => Mode::Full,
            Tier::Direct => Mode::Direct,
        },
        strategy: Strategy::Mis,
        ..RenderSettings::default()
    };
    let output = reference.render(&settings, progress)?;
    let render_ms = output.stats.seconds * 1e3;
    let mut passes = BTreeMap::new();
    passes.insert("scene/bvh_build".to_string(), setup_ms);
    passes.insert(format!("{}/trace", tier.name()), render_ms);
    Ok(TierRender {
        ms_per_frame: setup_ms + render_ms,
        passes,
        memory_bytes: reference.memory_bytes()
            + u64::from(request.width) * u64::from(request.height) * 12,
        image: output.image,
        stats: output.stats,
        triangles,
    })
}

//! How the `gi` command runs one render of a tier through the gi-tiers [`Renderer`].

use std::collections::BTreeMap;

use anyhow::Result;
use gi_image::Image;
use gi_reference::RenderStats;
use gi_scene::{CameraView, Scene};
use gi_tiers::{
    CameraMode, GiMemory, MobileConfig, MobileTier, PcConfig, PcTier, Renderer, TierChoice,
    TierKind, TierSettings,
    mobile::{ScreenConfig, ScreenProbeMode},
};
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

/// How the mobile tier schedules its screen probes (`--screen-probes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScreenProbes {
    /// HSGI mobile: one freshly traced probe per 64-pixel tile every frame.
    Hsgi,
    /// SmartGI: 16-pixel tiles in 2 x 2 groups, one probe per group traced per frame, the
    /// others reprojected from history.
    Smartgi,
}

impl ScreenProbes {
    pub fn config(self) -> ScreenConfig {
        match self {
            ScreenProbes::Hsgi => ScreenConfig::default(),
            ScreenProbes::Smartgi => ScreenConfig::smartgi(),
        }
    }

    /// The mobile tier's configuration: its default with these screen probes (the default's
    /// own screen settings when it already uses them), or the default itself for `None`.
    pub fn mobile_config(choice: Option<Self>) -> MobileConfig {
        let mut config = MobileConfig::default();
        if let Some(choice) = choice
            && config.screen.mode != choice.mode()
        {
            config.screen = choice.config();
        }
        config
    }

    fn mode(self) -> ScreenProbeMode {
        match self {
            ScreenProbes::Hsgi => ScreenProbeMode::Hsgi,
            ScreenProbes::Smartgi => ScreenProbeMode::SmartGi,
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
    /// Still warm-up frames before the frames ([`Renderer::warm_up`]); `None`: the tier's
    /// [`TierKind::default_warmup`].
    pub warmup: Option<u32>,
    /// The mobile tier's configuration (ignored by the other tiers).
    pub mobile: MobileConfig,
    /// The PC tier's configuration (ignored by the other tiers), and the stage it has
    /// switched off (`--pc-without`) or on (`--pc-with`), if any.
    pub pc: PcConfig,
    pub pc_without: Option<String>,
    pub pc_with: Option<String>,
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
    /// Named passes of the measured frame and their time in milliseconds (a pass recorded
    /// several times, summed).
    pub passes: BTreeMap<String, f64>,
    /// Bytes the tier owns after the measured frame.
    pub memory_bytes: u64,
    pub stats: Option<RenderStats>,
    /// Warm-up frames rendered (0 for tiers without history, which skip it).
    pub warmup: u32,
    /// What only the mobile tier reports.
    pub mobile: Option<MobileReport>,
    /// What only the PC tier reports.
    pub pc: Option<PcReport>,
    /// Wall seconds to open the tier (device, shaders, pipelines).
    pub open_s: f64,
    /// Wall seconds of the first frame, which uploads the scene (BVH build, texture mip
    /// chains) and, in the GI tiers, fills the brick cache; `None` when the first frame was
    /// not timed apart (several measured frames of a tier without history).
    pub first_frame_s: Option<f64>,
}

/// The mobile tier's GI cost and memory breakdown, in the JSON reports.
#[derive(Clone, Debug, Serialize)]
pub struct MobileReport {
    /// `hsgi` or `smartgi`.
    pub screen_probes: &'static str,
    /// Milliseconds of the measured frame's GI passes (`cache/*` and `mobile/*`).
    pub gi_ms: f64,
    pub memory: GiMemoryReport,
}

/// A real-time tier's memory breakdown ([`GiMemory`]), in the JSON reports.
#[derive(Clone, Debug, Serialize)]
pub struct GiMemoryReport {
    /// Brick cache, and the mobile tier's probe volume (fixed by the coverage).
    pub coverage_bytes: u64,
    /// Resolution-dependent GI buffers.
    pub screen_bytes: u64,
    /// Scene, BVH, G-buffer and direct light (what every tier needs).
    pub frame_bytes: u64,
    /// coverage + screen.
    pub gi_bytes: u64,
}

impl From<GiMemory> for GiMemoryReport {
    fn from(memory: GiMemory) -> Self {
        Self {
            coverage_bytes: memory.coverage_bytes,
            screen_bytes: memory.screen_bytes,
            frame_bytes: memory.frame_bytes,
            gi_bytes: memory.gi_bytes(),
        }
    }
}

/// The PC tier's GI cost and memory breakdown, in the JSON reports.
#[derive(Clone, Debug, Serialize)]
pub struct PcReport {
    /// The stage switched off (`--pc-without`), or null.
    pub without: Option<String>,
    /// The stage switched on that is off by default (`--pc-with`), or null.
    pub with: Option<String>,
    /// Full-resolution pixels per trace pixel along each axis.
    pub trace_scale: u32,
    /// What the diffuse rays read: `rays` or `probes` (trace-probe mode).
    pub trace_mode: &'static str,
    /// Roughness below which specular rays are traced (0 when they are off).
    pub specular_max_roughness: f32,
    /// Milliseconds of the measured frame's GI passes (`cache/*` and `pc/*`).
    pub gi_ms: f64,
    /// Brick cache (coverage), resolution-dependent GI buffers (screen), the rest (frame).
    pub memory: GiMemoryReport,
}

impl PcReport {
    /// One line for the printed tables.
    pub fn line(&self, ms_per_frame: f64, warmup: u32) -> String {
        let mib = |bytes: u64| bytes as f64 / (1 << 20) as f64;
        let m = &self.memory;
        let variant = match (&self.without, &self.with) {
            (Some(stage), _) => format!("without {stage}"),
            (None, Some(stage)) => format!("with {stage}"),
            (None, None) => "default stages".to_string(),
        };
        format!(
            "pc ({variant}, trace scale {}, trace mode {}, specular rays below roughness {}, \
             measured after {warmup} warm-up frames): GI {:.2} ms of {ms_per_frame:.2} ms/frame (cache/* + pc/*); GI memory {:.2} MiB (coverage {:.2} \
             + screen {:.2}), frame {:.2} MiB",
            self.trace_scale,
            self.trace_mode,
            self.specular_max_roughness,
            self.gi_ms,
            mib(m.gi_bytes),
            mib(m.coverage_bytes),
            mib(m.screen_bytes),
            mib(m.frame_bytes),
        )
    }
}

impl MobileReport {
    /// One line for the printed tables.
    pub fn line(&self, ms_per_frame: f64, warmup: u32) -> String {
        let mib = |bytes: u64| bytes as f64 / (1 << 20) as f64;
        let m = &self.memory;
        format!(
            "mobile ({} screen probes, measured after {warmup} warm-up frames): GI {:.2} ms of \
             {ms_per_frame:.2} ms/frame (cache/* + mobile/*); GI memory {:.2} MiB (coverage \
             {:.2} + screen {:.2}), frame {:.2} MiB",
            self.screen_probes,
            self.gi_ms,
            mib(m.gi_bytes),
            mib(m.coverage_bytes),
            mib(m.screen_bytes),
            mib(m.frame_bytes),
        )
    }
}

/// Renders `request.frames` frames of `scene` with `tier`, after the request's still warm-up,
/// and returns the last.
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
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let opening = std::time::Instant::now();
    let mut renderer = if tier == TierKind::Mobile {
        let mobile = MobileTier::open(settings, request.mobile.clone())?;
        Renderer::with_tier(scene.clone(), Box::new(mobile), request.camera.into())
    } else if tier == TierKind::Pc {
        let pc = PcTier::open(settings, request.pc.clone())?;
        Renderer::with_tier(scene.clone(), Box::new(pc), request.camera.into())
    } else {
        Renderer::new(
            scene.clone(),
            TierChoice::Tier(tier),
            settings,
            request.camera.into(),
        )?
    };
    let open_s = opening.elapsed().as_secs_f64();
    // The first frame is timed apart: the first warm-up frame, or the only measured one.
    let warmup = request.warmup.unwrap_or(tier.default_warmup());
    let first = std::time::Instant::now();
    renderer.warm_up(warmup.min(1), None)?;
    let mut first_frame_s = (renderer.warm_up_frames() > 0).then(|| first.elapsed().as_secs_f64());
    renderer.warm_up(warmup.saturating_sub(1), None)?;
    let measured = std::time::Instant::now();
    let frame = renderer.render_frames(request.frames, Some(progress))?;
    if first_frame_s.is_none() && request.frames == 1 {
        first_frame_s = Some(measured.elapsed().as_secs_f64());
    }
    let mobile = renderer.tier_as::<MobileTier>().map(|mobile| MobileReport {
        screen_probes: mobile.config().screen.mode.name(),
        gi_ms: frame.gi_ms(TierKind::Mobile),
        memory: mobile.memory().into(),
    });
    let pc = renderer.tier_as::<PcTier>().map(|pc| PcReport {
        without: request.pc_without.clone(),
        with: request.pc_with.clone(),
        trace_scale: pc.config().trace_scale,
        trace_mode: pc.config().trace_mode.name(),
        specular_max_roughness: if pc.config().specular.traced {
            pc.config().specular.max_roughness
        } else {
            0.0
        },
        gi_ms: frame.gi_ms(TierKind::Pc),
        memory: pc.memory().into(),
    });
    Ok(TierRender {
        open_s,
        first_frame_s,
        ms_per_frame: frame.ms_total(),
        // A pass recorded several times in a frame (the PC denoiser's a-trous iterations)
        // reports its total, as `PassTimings::get` does.
        passes: frame
            .passes
            .iter()
            .fold(BTreeMap::new(), |mut passes, (name, ms)| {
                *passes.entry(name.clone()).or_insert(0.0) += ms;
                passes
            }),
        memory_bytes: renderer.memory_bytes(),
        image: frame.image,
        stats: frame.stats,
        warmup: renderer.warm_up_frames(),
        mobile,
        pc,
    })
}

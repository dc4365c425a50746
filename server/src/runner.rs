//! The blocking part of a job: preparing its scene and camera, rendering its tier through the
//! gi-tiers [`Renderer`], and measuring the image against the reference. Runs on the GPU
//! worker or the CPU pool, never on the async runtime's threads.

use std::{
    collections::{BTreeMap, HashMap},
    io,
    path::Path,
    sync::{Arc, Mutex},
    time::Instant,
};

use gi_image::{Flip, Image};
use gi_reference::cache::{REFERENCE_SEED, ReferenceCache, ReferenceKey, ReferenceRequest};
use gi_scene::{CameraKey, CameraPath, CameraView, Scene};
use gi_tiers::{
    CameraMode, CancelCheck, CpuTier, Renderer, TierChoice, TierError, TierKind, TierSettings,
    select::RunsOn,
};

use crate::{
    error::ApiError,
    job::{CameraSpec, Comparison, JobResult, JobSpec, Progress},
    store::Writer,
};

/// Where a job's tier renders and how it is asked for. In JSON (a job process's task):
/// `cpu:<tier>`, `gpu:<tier>` or `gpu:auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(into = "String", try_from = "String")]
pub enum TierPlan {
    /// A CPU tier (`reference` or `direct`), made directly so nothing probes for a GPU.
    Cpu(TierKind),
    /// Whatever [`Renderer::new`] makes of the choice, on the GPU worker.
    Gpu(TierChoice),
}

impl From<TierPlan> for String {
    fn from(plan: TierPlan) -> String {
        match plan {
            TierPlan::Cpu(kind) => format!("cpu:{}", kind.name()),
            TierPlan::Gpu(TierChoice::Tier(kind)) => format!("gpu:{}", kind.name()),
            // A frame budget is not a plan the service makes.
            TierPlan::Gpu(TierChoice::Auto | TierChoice::AutoWithin(_)) => "gpu:auto".into(),
        }
    }
}

impl TryFrom<String> for TierPlan {
    type Error = String;

    fn try_from(plan: String) -> Result<Self, String> {
        let tier = |name: &str| {
            name.parse::<TierKind>()
                .map_err(|e| format!("{plan:?}: {e}"))
        };
        match plan.split_once(':') {
            Some(("gpu", "auto")) => Ok(TierPlan::Gpu(TierChoice::Auto)),
            Some(("gpu", name)) => Ok(TierPlan::Gpu(TierChoice::Tier(tier(name)?))),
            Some(("cpu", name)) => Ok(TierPlan::Cpu(tier(name)?)),
            _ => Err(format!("{plan:?} is not cpu:<tier> or gpu:<tier>")),
        }
    }
}

/// A job ready to render: its scene with the job's camera applied, and its settings.
pub struct PreparedJob {
    pub scene: Arc<Scene>,
    pub camera: CameraMode,
    pub settings: TierSettings,
    pub plan: TierPlan,
    pub frames: u32,
    pub warmup: Option<u32>,
    /// The adapter GPU tiers run on (for the result's `device`).
    pub gpu_name: Option<String>,
}

impl PreparedJob {
    /// Scene time of the measured (last) frame.
    pub fn time_s(&self) -> f32 {
        self.scene.frame_time(self.frames.saturating_sub(1))
    }

    /// Camera of the measured frame, as the renderer sees it.
    pub fn view(&self) -> CameraView {
        let time_s = self.time_s();
        match self.camera {
            CameraMode::Default => self.scene.default_view(time_s),
            CameraMode::Path => self.scene.path_view(time_s),
        }
    }
}

/// Checks that the job's camera exists in `scene`, without copying anything.
pub fn check_camera(scene: &Scene, camera: &CameraSpec) -> Result<(), ApiError> {
    match camera {
        CameraSpec::Named(name) if name == "default" => Ok(()),
        CameraSpec::Named(name) if name == "path" => {
            if scene.camera_path.is_some() {
                Ok(())
            } else {
                Err(ApiError::invalid(
                    "invalid_camera",
                    format!("scene {:?} has no camera path", scene.name),
                ))
            }
        }
        CameraSpec::Named(name) => camera_node(scene, name).map(|_| ()),
        CameraSpec::LookAt(_) => Ok(()),
    }
}

fn camera_node(scene: &Scene, name: &str) -> Result<usize, ApiError> {
    let cameras: Vec<&str> = scene
        .nodes
        .iter()
        .filter(|n| n.camera.is_some())
        .map(|n| n.name.as_str())
        .collect();
    scene
        .nodes
        .iter()
        .position(|n| n.camera.is_some() && n.name == name)
        .ok_or_else(|| {
            ApiError::invalid(
                "invalid_camera",
                format!(
                    "scene {:?} has no camera {name:?} (use \"default\", \"path\", a camera \
                     node's name [{}], or {{\"position\", \"target\", \"fov_deg\"}})",
                    scene.name,
                    cameras.join(", ")
                ),
            )
        })
}

/// The job's scene and camera mode: a named camera node becomes the default camera, and an
/// explicit camera a one-key camera path, so the renderer and the reference see the same view.
pub fn prepare(
    scene: Arc<Scene>,
    spec: &JobSpec,
    plan: TierPlan,
    gpu_name: Option<String>,
) -> Result<PreparedJob, ApiError> {
    check_camera(&scene, &spec.camera)?;
    let (scene, camera) = match &spec.camera {
        CameraSpec::Named(name) if name == "default" => (scene, CameraMode::Default),
        CameraSpec::Named(name) if name == "path" => (scene, CameraMode::Path),
        CameraSpec::Named(name) => {
            let node = camera_node(&scene, name)?;
            let mut scene = Scene::clone(&scene);
            scene.default_camera_node = Some(node);
            (Arc::new(scene), CameraMode::Default)
        }
        CameraSpec::LookAt(look) => {
            let mut scene = Scene::clone(&scene);
            scene.camera_path = Some(CameraPath {
                keys: vec![CameraKey {
                    time_s: 0.0,
                    position: look.position.into(),
                    target: look.target.into(),
                }],
                yfov: look.fov_deg.to_radians(),
            });
            (Arc::new(scene), CameraMode::Path)
        }
    };
    Ok(PreparedJob {
        scene,
        camera,
        settings: TierSettings {
            width: spec.width,
            height: spec.height,
            spp: spec.spp,
            seed: spec.seed,
            textures: gi_tiers::TextureOptions::DEFAULT,
        },
        plan,
        frames: spec.frames,
        warmup: spec.warmup,
        gpu_name,
    })
}

/// A rendered tier image and what was measured while rendering it.
pub struct TierOutput {
    pub image: Image,
    pub result: JobResult,
}

/// Renders the job's tier: the still warm-up, then the frames, checking `stop` between frames
/// and between the passes of a CPU frame (`Ok(None)` when it stopped). `progress` hears of
/// every frame, and of every pass of a CPU render's samples.
pub fn render_tier(
    job: &PreparedJob,
    progress: &(dyn Fn(Progress) + Sync),
    stop: CancelCheck,
    share: f64,
) -> Result<Option<TierOutput>, String> {
    let started = Instant::now();
    let scene = Scene::clone(&job.scene);
    let mut renderer = match job.plan {
        TierPlan::Cpu(kind) => {
            let tier = CpuTier::new(kind, job.settings)
                .map_err(|e| e.to_string())?
                .with_cancel(stop.clone());
            Renderer::with_tier(scene, Box::new(tier), job.camera)
        }
        TierPlan::Gpu(choice) => {
            Renderer::new(scene, choice, job.settings, job.camera).map_err(|e| e.to_string())?
        }
    };
    let kind = renderer.tier();
    // The CPU tiers keep no history: they render only the measured frame.
    let temporal = renderer.tier_as::<CpuTier>().is_none();
    let warmup = if temporal {
        job.warmup.unwrap_or(kind.default_warmup())
    } else {
        0
    };
    let steps = f64::from(warmup + job.frames);
    let report = |stage: &'static str, done: u32, total: u32, step: f64| {
        progress(Progress {
            stage,
            done,
            total,
            fraction: share * (step / steps).min(1.0),
        })
    };
    let spp = job.settings.spp;
    let last_frame = f64::from(warmup + job.frames - 1);
    let frame_progress = |done: u32| {
        report(
            "frames",
            job.frames - 1,
            job.frames,
            last_frame + f64::from(done) / f64::from(spp),
        )
    };
    let frame = if temporal {
        for done in 0..warmup {
            if stop() {
                return Ok(None);
            }
            renderer.warm_up(1, None).map_err(|e| e.to_string())?;
            report("warmup", done + 1, warmup, f64::from(done + 1));
        }
        for done in 1..job.frames {
            if stop() {
                return Ok(None);
            }
            renderer.advance_frame(None).map_err(|e| e.to_string())?;
            report("frames", done, job.frames, f64::from(warmup + done));
        }
        if stop() {
            return Ok(None);
        }
        renderer.render_frame(Some(&frame_progress))
    } else {
        renderer.render_frames(job.frames, Some(&frame_progress))
    };
    let frame = match frame {
        Err(TierError::Cancelled) => return Ok(None),
        other => other.map_err(|e| e.to_string())?,
    };
    report("frames", job.frames, job.frames, steps);

    let passes = frame
        .passes
        .iter()
        .fold(BTreeMap::new(), |mut passes, (name, ms)| {
            *passes.entry(name.clone()).or_insert(0.0) += ms;
            passes
        });
    let gi_ms = frame
        .passes
        .iter()
        .any(|(name, _)| kind.is_gi_pass(name))
        .then(|| frame.gi_ms(kind));
    // `auto` may have fallen back to the CPU reference on the GPU worker.
    let on_cpu = renderer
        .selection()
        .is_some_and(|s| s.runs_on == RunsOn::Cpu);
    let device = match (&job.plan, &job.gpu_name) {
        (TierPlan::Gpu(_), _) if on_cpu => "cpu".to_string(),
        (TierPlan::Gpu(_), Some(name)) => format!("gpu ({name})"),
        (TierPlan::Gpu(_), None) => "gpu".to_string(),
        (TierPlan::Cpu(_), _) => "cpu".to_string(),
    };
    let result = JobResult {
        tier: kind.name().to_string(),
        device,
        width: job.settings.width,
        height: job.settings.height,
        frames: job.frames,
        warmup: renderer.warm_up_frames(),
        ms_per_frame: frame.ms_total(),
        passes,
        gi_ms,
        memory_bytes: renderer.memory_bytes(),
        samples_per_second: frame.stats.as_ref().map(|s| s.samples_per_second),
        rays_per_second: frame.stats.as_ref().map(|s| s.rays_per_second),
        render_seconds: started.elapsed().as_secs_f64(),
        comparison: None,
    };
    Ok(Some(TierOutput {
        image: frame.image,
        result,
    }))
}

/// Where comparisons get their references: the cache shared with `gi compare`, and one lock
/// per reference being made, so jobs comparing the same view at the same time wait for one
/// path tracer and then read its image from the cache instead of each tracing it.
pub struct References {
    cache: ReferenceCache,
    rendering: Mutex<HashMap<String, Arc<Mutex<()>>>>,
}

impl References {
    pub fn new(cache: ReferenceCache) -> Self {
        Self {
            cache,
            rendering: Mutex::new(HashMap::new()),
        }
    }

    fn lock_for(&self, key: &ReferenceKey) -> Arc<Mutex<()>> {
        let name = serde_json::to_string(key).unwrap_or_default();
        let mut locks = self.rendering.lock().unwrap_or_else(|e| e.into_inner());
        // Forget the locks nobody holds any more.
        locks.retain(|_, lock| Arc::strong_count(lock) > 1);
        locks.entry(name).or_default().clone()
    }
}

/// The reference image of a comparison, the FLIP error map against it and the metrics.
pub struct Compared {
    pub reference: Image,
    pub flip: Flip,
    pub comparison: Comparison,
}

/// Measures `output` against the reference (from the cache, or path traced now and cached)
/// and the direct-only image against the same reference, for `gain_vs_direct`. Progress runs
/// from `start` to 1.
pub fn compare(
    job: &PreparedJob,
    output: &TierOutput,
    reference_spp: u32,
    references: &References,
    progress: &(dyn Fn(Progress) + Sync),
    stop: &dyn Fn() -> bool,
    start: f64,
) -> Result<Option<Compared>, String> {
    let request = ReferenceRequest::new(
        &job.scene,
        job.view(),
        job.time_s(),
        (job.settings.width, job.settings.height),
        reference_spp,
        REFERENCE_SEED,
    );
    let reference_share = (1.0 - start) * 0.9;
    let reference_progress = |done: u32| {
        progress(Progress {
            stage: "reference",
            done,
            total: reference_spp,
            fraction: start + reference_share * f64::from(done) / f64::from(reference_spp),
        })
    };
    let lock = references.lock_for(&request.key());
    let found = {
        let _rendering = lock.lock().unwrap_or_else(|e| e.into_inner());
        references
            .cache
            .get_or_render(&request, true, &reference_progress, stop)
    };
    let Some(reference) = found.map_err(|e| format!("reference: {e}"))? else {
        return Ok(None);
    };
    if stop() {
        return Ok(None);
    }
    // The direct-only baseline, as `gi compare` computes it: the same settings, the CPU tier
    // (the same image as the GPU's).
    let direct_image = if output.result.tier == TierKind::Direct.name() {
        None
    } else {
        progress(Progress {
            stage: "direct",
            done: 0,
            total: 1,
            fraction: start + reference_share,
        });
        let tier = CpuTier::new(TierKind::Direct, job.settings).map_err(|e| e.to_string())?;
        let mut renderer =
            Renderer::with_tier(Scene::clone(&job.scene), Box::new(tier), job.camera);
        let frame = renderer
            .render_frames(job.frames, None)
            .map_err(|e| format!("direct: {e}"))?;
        Some(frame.image)
    };
    let direct = direct_image.as_ref().unwrap_or(&output.image);
    let exposure = job.scene.exposure;
    let metric = |e: gi_image::ImageError| e.to_string();
    let rmse_srgb8 =
        gi_image::rmse_srgb8(&output.image, &reference.image, exposure).map_err(metric)?;
    let direct_rmse_srgb8 =
        gi_image::rmse_srgb8(direct, &reference.image, exposure).map_err(metric)?;
    let flip = gi_image::flip_ldr(&output.image, &reference.image, exposure).map_err(metric)?;
    let comparison = Comparison {
        rmse_srgb8,
        flip: Some(flip.mean),
        rmse_linear: gi_image::rmse_linear(&output.image, &reference.image).map_err(metric)?,
        rel_mse: gi_image::rel_mse(&output.image, &reference.image).map_err(metric)?,
        gain_vs_direct: gi_image::gain_vs_direct(rmse_srgb8, direct_rmse_srgb8),
        direct_rmse_srgb8,
        reference_spp,
        reference_seed: REFERENCE_SEED,
        reference_seconds: reference.seconds,
        reference_cached: reference.cached,
        reference_engine: reference.engine,
    };
    Ok(Some(Compared {
        reference: reference.image,
        flip,
        comparison,
    }))
}

/// Writes a finished job's images into its folder, each atomically: `image.png` (with the
/// scene's exposure), `image.exr` (linear), and for comparisons (the reference and the FLIP
/// of the image against it) `reference.png`, `error.png` (the per-pixel error heat map) and
/// `flip.png` (the FLIP error map).
pub fn write_images(
    writer: &Writer,
    dir: &Path,
    exposure: f32,
    image: &Image,
    compared: Option<(&Image, &Flip)>,
) -> io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let encode = |e: gi_image::ImageError| io::Error::other(e.to_string());
    writer.write_with(&dir.join("image.png"), |tmp| {
        gi_image::write_png(image, tmp, exposure).map_err(encode)
    })?;
    writer.write_with(&dir.join("image.exr"), |tmp| {
        gi_image::write_exr(image, tmp).map_err(encode)
    })?;
    if let Some((reference, flip)) = compared {
        writer.write_with(&dir.join("reference.png"), |tmp| {
            gi_image::write_png(reference, tmp, exposure).map_err(encode)
        })?;
        writer.write_with(&dir.join("error.png"), |tmp| {
            gi_image::write_error_heatmap(image, reference, exposure, tmp)
                .map(|_| ())
                .map_err(encode)
        })?;
        let flip_map = gi_image::flip_error_map(flip).map_err(encode)?;
        writer.write_with(&dir.join("flip.png"), |tmp| {
            gi_image::write_heatmap_png(&flip_map, tmp).map_err(encode)
        })?;
    }
    Ok(())
}

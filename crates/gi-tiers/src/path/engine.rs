//! The reference on the GPU: a [`ReferenceEngine`] that renders gi-reference's
//! [`ReferenceRequest`]s with the `path` tier, and [`reference_engine`], which turns the user's
//! [`EngineChoice`] into an engine.
//!
//! The path tier draws the CPU reference's random numbers (same seed, same per-sample PCG32
//! streams, the same `max_depth` and MIS), so its render of a request equals the CPU's up to
//! f32 rounding, and the reference cache treats the two as one estimator.

use std::{path::PathBuf, sync::Arc, time::Instant};

use gi_gpu::{GpuContext, GpuOptions, wgpu};
use gi_image::Image;
use gi_reference::RenderStats;
use gi_reference::cache::{CacheError, ReferenceCache, ReferenceRequest};
use gi_reference::engine::{CpuEngine, EngineChoice, EngineKind, ReferenceEngine};

use super::GpuPathTier;
use crate::tier::{FrameInput, Tier, TierError, TierKind, TierSettings};

/// Camera paths per frame of a GPU reference render (64 Mi: 32 spp at 1080p). Progress and
/// cancellation are checked between frames, and each frame reads its image back. Higher:
/// less read-back; lower: quicker progress and cancellation.
pub const REFERENCE_FRAME_PATHS: u64 = 1 << 26;

/// Renders references with the GPU path tier on one Vulkan adapter.
#[derive(Debug)]
pub struct GpuReferenceEngine {
    options: GpuOptions,
    adapter: wgpu::AdapterInfo,
}

impl GpuReferenceEngine {
    /// The engine on the adapter [`GpuContext::new`] opens (the best one, or the one
    /// `GI_ADAPTER` names), software adapters included; `Unavailable` without one.
    pub fn open() -> Result<Self, TierError> {
        let options = GpuOptions::from_env();
        let ctx = GpuContext::with_options(&options).map_err(|e| TierError::Unavailable {
            tier: TierKind::Path.name(),
            reason: format!("no GPU to render the reference on: {e}"),
        })?;
        Ok(Self {
            options,
            adapter: ctx.adapter_info.clone(),
        })
    }

    /// Whether the adapter is a hardware GPU (not a software one such as lavapipe).
    pub fn is_hardware(&self) -> bool {
        self.adapter.device_type != wgpu::DeviceType::Cpu
    }
}

impl ReferenceEngine for GpuReferenceEngine {
    fn kind(&self) -> EngineKind {
        EngineKind::Gpu
    }

    fn description(&self) -> String {
        format!("{}: {}", EngineKind::Gpu.name(), self.adapter.name)
    }

    /// Renders in frames of about [`REFERENCE_FRAME_PATHS`] paths, each continuing the
    /// accumulation of the frames before it. The stats' seconds are wall-clock time, upload
    /// and read-backs included.
    fn render(
        &self,
        request: &ReferenceRequest,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<(Image, RenderStats)>, CacheError> {
        let settings = request.settings();
        settings.validate()?;
        let failed = |error: TierError| CacheError::Engine {
            engine: self.description(),
            message: error.to_string(),
        };
        let started = Instant::now();
        let ctx = GpuContext::with_options(&self.options).map_err(|e| {
            failed(TierError::Unavailable {
                tier: TierKind::Path.name(),
                reason: e.to_string(),
            })
        })?;
        let frame_spp = (REFERENCE_FRAME_PATHS / settings.pixel_count())
            .clamp(1, u64::from(settings.spp)) as u32;
        let tier_settings = TierSettings {
            width: settings.width,
            height: settings.height,
            spp: frame_spp,
            seed: settings.seed,
            textures: gi_gpu::TextureOptions::DEFAULT,
        };
        let mut tier = GpuPathTier::new(TierKind::Path, tier_settings, ctx).map_err(failed)?;
        let frame = request.scene.evaluate(request.time_s, Some(request.view));
        let (mut done, mut index) = (0, 0);
        let mut image = None;
        let mut stats = RenderStats::default();
        while done < settings.spp {
            if cancelled() {
                return Ok(None);
            }
            let spp = frame_spp.min(settings.spp - done);
            tier.set_samples_per_frame(spp);
            let input = FrameInput {
                scene: request.scene,
                frame: &frame,
                index,
                progress: None,
            };
            let output = tier.render(&input).map_err(failed)?;
            done += spp;
            index += 1;
            progress(done);
            if let Some(frame_stats) = output.stats {
                stats.samples += frame_stats.samples;
                stats.rays += frame_stats.rays;
                stats.nonfinite_samples += frame_stats.nonfinite_samples;
                stats.bvh_build_seconds = frame_stats.bvh_build_seconds;
            }
            image = Some(output.image);
        }
        stats.seconds = (started.elapsed().as_secs_f64() - stats.bvh_build_seconds).max(0.0);
        if stats.seconds > 0.0 {
            stats.samples_per_second = stats.samples as f64 / stats.seconds;
            stats.rays_per_second = stats.rays as f64 / stats.seconds;
        }
        Ok(image.map(|image| (image, stats)))
    }
}

/// The engine `choice` asks for: the CPU path tracer for [`EngineChoice::Cpu`]; the GPU path
/// tier for [`EngineChoice::Gpu`] (`Unavailable` without a Vulkan adapter); for
/// [`EngineChoice::Auto`] the GPU path tier on a hardware adapter and the CPU otherwise (a
/// software adapter is slower than the CPU path tracer).
pub fn reference_engine(choice: EngineChoice) -> Result<Arc<dyn ReferenceEngine>, TierError> {
    Ok(match choice {
        EngineChoice::Cpu => Arc::new(CpuEngine),
        EngineChoice::Gpu => Arc::new(GpuReferenceEngine::open()?),
        EngineChoice::Auto => match GpuReferenceEngine::open() {
            Ok(engine) if engine.is_hardware() => Arc::new(engine),
            _ => Arc::new(CpuEngine),
        },
    })
}

/// The reference cache in `dir` rendering with the engine `choice` asks for
/// ([`reference_engine`]) and accepting the entries that choice accepts.
pub fn reference_cache(
    dir: impl Into<PathBuf>,
    choice: EngineChoice,
) -> Result<ReferenceCache, TierError> {
    Ok(ReferenceCache::new(dir).with_engine(reference_engine(choice)?, choice))
}

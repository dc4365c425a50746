//! The GPU path tracer tier (`path`) and the GPU direct-light tier (`direct` on a GPU): the
//! reference's light transport in a compute shader, accumulated progressively while nothing
//! moves.
//!
//! Both follow gi-reference's transport contract and draw the reference's random numbers, so a
//! GPU render equals the CPU render of the same seed and sample count up to f32 rounding.
//!
//! [`GpuReferenceEngine`] renders the reference cache's requests with this tier.
//!
//! A frame's samples go to the GPU in dispatches of bounded cost (the tracer's
//! [`dispatch`](crate::tracer::dispatch) rule), so any sample count per frame renders on
//! lavapipe and stays clear of a desktop GPU's watchdog.

mod engine;

pub use engine::{GpuReferenceEngine, REFERENCE_FRAME_PATHS, reference_cache, reference_engine};

use crate::tracer::dispatch::DispatchPlan;
use crate::tracer::{Accumulation, PathPipelines, PathUniforms, TraceStats};

use gi_gpu::{GpuContext, GpuScene, GpuTimer, PassTimings};
use gi_image::Image;
use gi_reference::RenderStats;
use gi_scene::{CameraView, SceneFrame};
use glam::Vec3;

use crate::output::GpuOutput;
use crate::requirements::{FrameCost, Requirements, image_bytes};
use crate::tier::{FrameInput, FrameOutput, Tier, TierError, TierKind, TierSettings};

/// What `path/trace` and `path/resolve` need of an adapter at `settings`' resolution:
/// `path/trace` binds the scene (7 storage buffers), its accumulation buffers (3) and the BVH
/// (4), and the scene's texture arrays in group 3, 8 x 8 invocations; `path/resolve` 64 x 1.
/// The `direct` tier runs the same shader.
pub fn requirements(settings: &TierSettings) -> Requirements {
    Requirements::compute(14, image_bytes(settings))
}

/// The `direct` tier's measured cost per frame on an H100, for [`crate::select`].
pub const DIRECT_H100_COST: FrameCost = FrameCost {
    kind: TierKind::Direct,
    points: &[(0.9216, 0.446)],
    source: "benchmarks/RESULTS-history.md, benchmark suite at 1280x720: the direct tier's \
             dearest scene (open-world) 7.129 ms at 16 samples per pixel, 0.446 ms per sample",
};

/// Passes per frame the timer has room for at first (`<tier>/trace`, `<tier>/resolve`); a
/// frame of more `<tier>/trace` passes makes a larger timer.
const TIMER_SCOPES: u32 = 4;

/// A GPU tier: [`TierKind::Path`] (full transport) or [`TierKind::Direct`] (the direct-only
/// baseline). Each frame adds [`TierSettings::spp`] samples per pixel to a running
/// accumulation and returns the mean so far; the accumulation restarts when the camera moves
/// or an animated scene advances, so a still view converges like one long render.
pub struct GpuPathTier {
    kind: TierKind,
    settings: TierSettings,
    ctx: GpuContext,
    pipelines: PathPipelines,
    timer: GpuTimer,
    /// Passes per frame `timer` has room for.
    timer_scopes: u32,
    prepared: Option<Prepared>,
}

/// The uploaded scene and its accumulation, with what they were made for.
struct Prepared {
    /// The frame it was made for, without its geometry.
    previous: SceneFrame,
    camera: CameraView,
    scene: GpuScene,
    accumulation: Accumulation,
    /// Non-finite samples counted by earlier frames, so each frame reports its own.
    nonfinite_before: u64,
    /// Size of the scene the upload was made for; another size means another scene.
    triangle_count: usize,
    node_count: usize,
}

/// Per-pixel statistics of the accumulation so far, read back from the GPU.
#[derive(Clone, Debug)]
pub struct Moments {
    /// Samples per pixel accumulated.
    pub samples: u32,
    /// Mean radiance per pixel.
    pub mean: Image,
    /// Per pixel and channel, `sqrt(sample variance / samples)` (zero below two samples).
    pub standard_error: Image,
    /// Samples that came out non-finite and were counted as black (zero unless broken).
    pub nonfinite_samples: u64,
}

impl GpuPathTier {
    /// A GPU tier of `kind` (`Path` or `Direct`) on `ctx`. Fails when the shaders do not
    /// compile on the device or the kind has no GPU version.
    pub fn new(kind: TierKind, settings: TierSettings, ctx: GpuContext) -> Result<Self, TierError> {
        let unavailable = |reason: String| TierError::Unavailable {
            tier: kind.name(),
            reason,
        };
        if !matches!(kind, TierKind::Path | TierKind::Direct) {
            return Err(unavailable("it has no GPU version".to_string()));
        }
        crate::scene_state::check_frame_settings(kind, &settings, &requirements(&settings), &ctx)?;
        let pipelines =
            PathPipelines::new(&ctx, kind.name()).map_err(|e| unavailable(e.to_string()))?;
        let timer = GpuTimer::new(&ctx, kind.name(), TIMER_SCOPES);
        Ok(Self {
            kind,
            settings,
            ctx,
            pipelines,
            timer,
            timer_scopes: TIMER_SCOPES,
            prepared: None,
        })
    }

    /// Opens the default GPU context and makes a tier of `kind` on it; `Unavailable` with the
    /// GPU error when there is no adapter.
    pub fn open(kind: TierKind, settings: TierSettings) -> Result<Self, TierError> {
        let ctx = GpuContext::new().map_err(|e| TierError::Unavailable {
            tier: kind.name(),
            reason: e.to_string(),
        })?;
        Self::new(kind, settings, ctx)
    }

    /// The GPU context the tier renders with.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Sets the samples per pixel the following frames add ([`TierSettings::spp`]); the
    /// accumulation goes on. For a caller that renders a sample count in frames of its own
    /// size (a reference with progress between frames).
    pub fn set_samples_per_frame(&mut self, spp: u32) {
        self.settings.spp = spp;
    }

    /// How the next frame's `<tier>/trace` samples are cut into dispatches; `None` before the
    /// first frame.
    pub fn dispatch_plan(&self) -> Option<DispatchPlan> {
        let prepared = self.prepared.as_ref()?;
        Some(prepared.accumulation.plan(&prepared.scene))
    }

    /// Reads the accumulation back: mean, standard error and non-finite count per pixel.
    /// `None` before the first frame. Stalls the GPU; for tests and tools.
    pub fn moments(&self) -> Option<Moments> {
        let prepared = self.prepared.as_ref()?;
        let accumulation = &prepared.accumulation;
        let sum: Vec<[f32; 4]> = self.ctx.read_buffer(&accumulation.sum);
        let sum_sq: Vec<[f32; 4]> = self.ctx.read_buffer(&accumulation.sum_sq);
        let n = f64::from(accumulation.samples);
        let image = |pixels| Image {
            width: accumulation.size.0,
            height: accumulation.size.1,
            pixels,
        };
        let mean = sum
            .iter()
            .map(|s| (Vec3::from_slice(s).as_dvec3() / n.max(1.0)).as_vec3())
            .collect();
        let standard_error = sum
            .iter()
            .zip(&sum_sq)
            .map(|(s, sq)| {
                if n < 2.0 {
                    return Vec3::ZERO;
                }
                let s = Vec3::from_slice(s).as_dvec3();
                let sq = Vec3::from_slice(sq).as_dvec3();
                let variance = ((sq - s * (s / n)) / (n - 1.0)).max(glam::DVec3::ZERO);
                (variance / n).map(f64::sqrt).as_vec3()
            })
            .collect();
        Some(Moments {
            samples: accumulation.samples,
            mean: image(mean),
            standard_error: image(standard_error),
            nonfinite_samples: sum.iter().map(|s| s[3] as u64).sum(),
        })
    }

    /// Makes the GPU state match `input`. The scene and its BVH are uploaded once; a camera
    /// move only restarts the accumulation, and a new time of an animated scene updates the
    /// BVH's top level and the shading data ([`GpuScene::update`]) before restarting it.
    fn prepare(&mut self, input: &FrameInput) -> Result<(), TierError> {
        let frame = input.frame;
        let unavailable = |e: &dyn std::fmt::Display| TierError::Unavailable {
            tier: self.kind.name(),
            reason: e.to_string(),
        };
        let size = (self.settings.width, self.settings.height);
        let same_scene = self.prepared.as_ref().is_some_and(|p| {
            p.triangle_count == frame.triangles.len() && p.node_count == frame.world_from_node.len()
        });
        if !same_scene {
            if let Some(old) = self.prepared.take() {
                old.accumulation.release(&self.ctx);
                old.scene.release(&self.ctx);
            }
            let scene =
                GpuScene::upload_with(&self.ctx, input.scene, frame, &self.settings.textures)
                    .map_err(|e| unavailable(&e))?;
            let uniforms = PathUniforms::new(frame, &scene, size, self.settings.seed);
            let accumulation = Accumulation::new(&self.ctx, &self.pipelines, &scene, uniforms);
            self.prepared = Some(Prepared {
                previous: frame.without_geometry(),
                camera: frame.camera,
                scene,
                accumulation,
                nonfinite_before: 0,
                triangle_count: frame.triangles.len(),
                node_count: frame.world_from_node.len(),
            });
            return Ok(());
        }
        let prepared = self.prepared.as_mut().expect("checked above");
        let moved = frame.content_changed_from(&prepared.previous);
        if prepared.camera == frame.camera && !moved {
            return Ok(());
        }
        let mut replaced = false;
        if moved {
            replaced = prepared
                .scene
                .update(&self.ctx, input.scene, frame)
                .map_err(|e| unavailable(&e))?;
        }
        let uniforms = PathUniforms::new(frame, &prepared.scene, size, self.settings.seed);
        if replaced {
            let old = std::mem::replace(
                &mut prepared.accumulation,
                Accumulation::new(&self.ctx, &self.pipelines, &prepared.scene, uniforms),
            );
            old.release(&self.ctx);
        } else {
            prepared.accumulation.restart(uniforms);
        }
        prepared.previous = frame.without_geometry();
        prepared.camera = frame.camera;
        prepared.nonfinite_before = 0;
        Ok(())
    }

    /// Adds `spp` samples per pixel to the prepared accumulation and resolves its mean; returns
    /// the passes' times and what the trace counted. When the device cut an invocation's loops
    /// short (lavapipe's loop limit: the cost estimate was too low for this scene), the
    /// accumulation is rendered again from its first sample with half the invocation budget,
    /// until it holds or one sample per dispatch still does not fit (an error).
    fn add_samples(&mut self, spp: u32) -> Result<(PassTimings, TraceStats), TierError> {
        let prepared = self
            .prepared
            .as_mut()
            .expect("prepared before samples are added");
        let mut spp = spp;
        loop {
            let accumulation = &mut prepared.accumulation;
            let passes = accumulation.passes_for(&prepared.scene, spp);
            if passes > self.timer_scopes {
                self.timer = GpuTimer::new(&self.ctx, self.kind.name(), passes);
                self.timer_scopes = passes;
            }
            let timings =
                accumulation.add_samples(&self.ctx, &prepared.scene, &mut self.timer, spp);
            let trace = accumulation.trace_stats(&self.ctx);
            if trace.cut_invocations == 0 {
                return Ok((timings, trace));
            }
            let plan = accumulation.plan(&prepared.scene);
            if !accumulation.halve_budget(&prepared.scene) {
                return Err(TierError::Unavailable {
                    tier: self.kind.name(),
                    reason: format!(
                        "one sample of this scene runs more loop iterations than the device \
                         allows one invocation ({} invocations were cut short; lavapipe \
                         allows 65,535)",
                        trace.cut_invocations
                    ),
                });
            }
            tracing::warn!(
                tier = self.kind.name(),
                cut = trace.cut_invocations,
                samples_per_dispatch = plan.samples,
                "the device cut loops short; rendering the accumulation again with smaller dispatches"
            );
            spp = accumulation.samples;
            accumulation.rewind();
        }
    }

    /// Times the scene's BVH was placed (its first top level plus one per update), and the
    /// seconds of its bottom-level builds: for tests that a camera move rebuilds nothing.
    pub fn bvh_builds(&self) -> Option<(u32, f64)> {
        let bvh = &self.prepared.as_ref()?.scene.bvh;
        Some((bvh.update_count, bvh.build_seconds))
    }
}

impl Tier for GpuPathTier {
    fn kind(&self) -> TierKind {
        self.kind
    }

    /// Temporal: every frame continues the accumulation of the frames before it.
    fn is_temporal(&self) -> bool {
        true
    }

    fn skins_on_gpu(&self) -> bool {
        true
    }

    fn render(&mut self, input: &FrameInput) -> Result<FrameOutput, TierError> {
        self.prepare(input)?;
        let (timings, trace) = self.add_samples(self.settings.spp)?;
        let prepared = self.prepared.as_mut().expect("prepared above");
        let accumulation = &prepared.accumulation;
        if let Some(progress) = input.progress {
            progress(accumulation.samples);
        }
        let mean: Vec<[f32; 4]> = self.ctx.read_buffer(&accumulation.mean);
        let image = Image {
            width: accumulation.size.0,
            height: accumulation.size.1,
            pixels: mean.iter().map(|m| Vec3::from_slice(m)).collect(),
        };
        // The resolve carries each pixel's count of non-finite samples so far in w.
        let nonfinite_total: u64 = mean.iter().map(|m| m[3] as u64).sum();
        let nonfinite_samples = nonfinite_total - prepared.nonfinite_before;
        prepared.nonfinite_before = nonfinite_total;
        let seconds = timings.get(&format!("{}/trace", self.kind)).unwrap_or(0.0) * 1e-3;
        let pixels = u64::from(self.settings.width) * u64::from(self.settings.height);
        let samples = pixels * u64::from(self.settings.spp);
        // After a re-render (see `add_samples`), the rays of all the accumulation's samples.
        let rays = trace.rays;
        let per_second = |count: u64| {
            if seconds > 0.0 {
                count as f64 / seconds
            } else {
                0.0
            }
        };
        let stats = RenderStats {
            samples,
            rays,
            seconds,
            samples_per_second: per_second(samples),
            rays_per_second: per_second(rays),
            bvh_build_seconds: prepared.scene.bvh_build_seconds,
            nonfinite_samples,
        };
        // Seconds are the trace pass's alone: GPU time when the adapter has timestamps.
        Ok(FrameOutput {
            image,
            passes: timings.0,
            stats: Some(stats),
        })
    }

    /// Everything counted by the tier's own context: scene, BVH, accumulation and timer.
    fn memory_bytes(&self) -> u64 {
        self.ctx.memory().total_bytes()
    }

    fn gpu_context(&self) -> Option<&GpuContext> {
        Some(&self.ctx)
    }

    fn gpu_output(&self) -> Option<GpuOutput<'_>> {
        let prepared = self.prepared.as_ref()?;
        Some(GpuOutput {
            ctx: &self.ctx,
            image: &prepared.accumulation.mean,
            direct: None,
            size: (self.settings.width, self.settings.height),
        })
    }
}

//! `gi-bench cache-update`: what one frame of the brick radiance cache costs. A
//! [`RadianceCache`] with its [`CacheLighting`] follows the scene's camera path for `frames`
//! frames (time advancing by the scene's frame time; animated scenes move their BVH and shading
//! data each frame as the `path` tier does), optionally with a ray-cast G-buffer feeding
//! `cache/screen_inject`.
//!
//! The first frame fills the cache from nothing (up to `voxelize_bricks_per_frame` bricks), so
//! its pass times are reported apart; the steady-state figure is the median per pass over the
//! remaining frames. `cpu update` is the wall-clock time of [`RadianceCache::update`] itself
//! (window moves, binning, allocation, uploads and recording: the CPU work outside the GPU);
//! `scene update` that of [`GpuScene::update`] on animated scenes.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, bail};
use gi_cache::{
    CacheBuffers, CacheConfig, CacheFrame, CacheInputs, CacheLighting, CacheLightingHook,
    CacheStats, CacheUpdateStats, CpuSteps, LightingInputs, RadianceCache, ScheduleCounts,
    ScreenInputs,
};
use gi_gpu::{
    GBuffer, GBufferInputs, GpuContext, GpuScene, GpuTimer, PassTimings, Recorder, ShaderLibrary,
    Technique, wgpu,
};
use gi_scene::Evaluation;

/// Passes a frame can record: `gbuffer/primary` and the five cache passes, with room to spare.
const TIMER_SCOPES: u32 = 12;

/// The cache passes reported, in frame order.
pub const CACHE_PASSES: [&str; 5] = [
    "cache/voxelize",
    "cache/screen_inject",
    "cache/inject",
    "cache/propagate",
    "cache/propagate_resolve",
];

/// What `gi-bench cache-update` runs.
#[derive(Clone, Debug)]
pub struct CacheUpdateOptions {
    pub scene: String,
    /// Frames along the camera path (the first is the fill frame).
    pub frames: u32,
    /// The cache's configuration (the default, with the command line's overrides).
    pub config: CacheConfig,
    /// G-buffer size for `cache/screen_inject`; `None` skips the G-buffer and the pass.
    pub screen_inject: Option<(u32, u32)>,
    /// Seconds of G-buffer frames at the first view before the fill frame, so that the GPU's
    /// clock has climbed before anything is timed ([`crate::settle`]); only with a G-buffer.
    pub settle_s: f64,
}

/// One frame's measurements.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    pub time_s: f32,
    /// Milliseconds per pass (GPU timestamps when the adapter has them).
    pub passes: PassTimings,
    /// Wall-clock milliseconds of `RadianceCache::update` on the CPU.
    pub cpu_update_ms: f64,
    /// Wall-clock milliseconds of `GpuScene::update` (0 for still scenes).
    pub scene_update_ms: f64,
    pub update: CacheUpdateStats,
    /// Bricks the lighting relit (new, near field, far field).
    pub scheduled: ScheduleCounts,
}

/// What `gi-bench cache-update` measured.
pub struct CacheUpdateReport {
    pub scene: String,
    pub triangles: usize,
    pub animated: bool,
    pub adapter: String,
    pub gpu_timestamps: bool,
    pub options: CacheUpdateOptions,
    pub frames: Vec<FrameRecord>,
    /// The cache after the last frame.
    pub stats: CacheStats,
    /// Bytes of every `cache.*` buffer, lighting included, per label.
    pub memory_by_label: Vec<(String, u64)>,
}

/// The lighting hook of [`CacheLighting`], keeping each update's schedule where the benchmark
/// can read it (the cache owns its hook as a `Send` trait object).
struct ScheduledLighting {
    lighting: CacheLighting,
    last: Arc<Mutex<ScheduleCounts>>,
}

impl CacheLightingHook for ScheduledLighting {
    fn record(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        frame: &CacheFrame<'_>,
    ) {
        let inputs = LightingInputs::from_frame(frame);
        let counts = self.lighting.record(ctx, timer, encoder, &inputs);
        *self.last.lock().expect("not poisoned") = counts;
    }

    fn converging(&self) -> bool {
        CacheLightingHook::converging(&self.lighting)
    }

    fn schedule_ms(&self) -> f64 {
        CacheLightingHook::schedule_ms(&self.lighting)
    }
}

/// Runs the cache along `options.scene`'s camera path and measures every frame.
pub fn run(options: &CacheUpdateOptions) -> anyhow::Result<CacheUpdateReport> {
    if options.frames == 0 {
        bail!("--frames must be at least 1");
    }
    options.config.validate()?;
    let scene =
        gi_scene::load(&options.scene).with_context(|| format!("loading {}", options.scene))?;
    let ctx = GpuContext::new()?;
    let shaders = ShaderLibrary::new();

    let view_at = |index: u32| {
        let time_s = scene.frame_time(index);
        scene.evaluate(time_s, Some(scene.path_view(time_s)))
    };
    // As the renderer does: a scene without animation is evaluated once and then only gets
    // each frame's time and camera; an animated one's last frame is moved to the next time in
    // place (`Scene::evaluate_into`: its revision changes only where geometry did, so the
    // cache's triangle index costs nothing while the animated nodes hold still). The last
    // frame is kept without its triangles.
    let mut frame = view_at(0);
    let mut previous = frame.without_geometry();
    let mut gpu_scene = GpuScene::upload(&ctx, &scene, &frame)?;
    let mut cache = RadianceCache::new(&ctx, &options.config)?;
    let lighting = CacheLighting::new(
        &ctx,
        &shaders,
        &options.config,
        &CacheBuffers::bind_group_layout(&ctx),
    )?;
    let scheduled = Arc::new(Mutex::new(ScheduleCounts::default()));
    cache.lighting = Some(Box::new(ScheduledLighting {
        lighting,
        last: scheduled.clone(),
    }));
    let mut gbuffer = match options.screen_inject {
        Some((width, height)) => Some(GBuffer::new(&ctx, &shaders, width, height)?),
        None => None,
    };
    let mut timer = GpuTimer::new(&ctx, "bench.cache_update", TIMER_SCOPES);
    let mut frames = Vec::new();
    for index in 0..options.frames {
        if index > 0 {
            if scene.is_animated() {
                let time_s = scene.frame_time(index);
                let camera = Some(scene.path_view(time_s));
                scene.evaluate_into(&mut frame, time_s, camera, &Evaluation::default());
            } else {
                frame.time_s = scene.frame_time(index);
                frame.camera = scene.path_view(frame.time_s);
            }
        }
        let mut scene_update_ms = 0.0;
        if index > 0 && scene.is_animated() {
            let started = Instant::now();
            // A replaced buffer needs no new bind group here: the cache's lighting makes its
            // bind group over the scene's buffers every update.
            gpu_scene.update(&ctx, &scene, &frame)?;
            scene_update_ms = started.elapsed().as_secs_f64() * 1e3;
        }
        if let Some(gbuffer) = gbuffer.as_mut() {
            let inputs = GBufferInputs {
                frame: &frame,
                scene: &gpu_scene,
                previous: &previous,
            };
            if index == 0 {
                // A GPU left idle sits at a low clock: without this the first second of frames
                // read several times their cost (every pass alike, `gbuffer/primary` too).
                let started = Instant::now();
                while started.elapsed().as_secs_f64() < options.settle_s {
                    let mut settle = Recorder::new(&ctx, &mut timer, "bench.cache_update.settle");
                    gbuffer.record(&mut settle, &inputs);
                    let settle = settle.into_encoder();
                    timer.finish(&ctx, settle);
                }
            }
        }
        let mut rec = Recorder::new(&ctx, &mut timer, "bench.cache_update");
        let screen = match gbuffer.as_mut() {
            Some(gbuffer) => {
                let inputs = GBufferInputs {
                    frame: &frame,
                    scene: &gpu_scene,
                    previous: &previous,
                };
                Some(ScreenInputs::new(
                    &gbuffer.record(&mut rec, &inputs),
                    &frame.camera,
                ))
            }
            None => None,
        };
        *scheduled.lock().expect("not poisoned") = ScheduleCounts::default();
        let started = Instant::now();
        let update = cache
            .record(
                &mut rec,
                &CacheInputs {
                    scene: &scene,
                    frame: &frame,
                    gpu_scene: &gpu_scene,
                    camera_position: frame.camera.position,
                    gbuffer: screen,
                },
            )
            .stats;
        let cpu_update_ms = started.elapsed().as_secs_f64() * 1e3;
        let encoder = rec.into_encoder();
        let passes = timer.finish(&ctx, encoder);
        frames.push(FrameRecord {
            time_s: frame.time_s,
            passes,
            cpu_update_ms,
            scene_update_ms,
            update,
            scheduled: *scheduled.lock().expect("not poisoned"),
        });
        previous = frame.without_geometry();
    }

    let memory_by_label = ctx
        .memory()
        .by_label
        .into_iter()
        .filter(|(label, _)| label.starts_with("cache."))
        .collect();
    let report = CacheUpdateReport {
        scene: scene.name.clone(),
        triangles: frame.triangles.len(),
        animated: scene.is_animated(),
        adapter: ctx.adapter_info.name.clone(),
        gpu_timestamps: ctx.supports_timestamps(),
        options: options.clone(),
        frames,
        stats: cache.stats(),
        memory_by_label,
    };
    if let Some(gbuffer) = gbuffer {
        gbuffer.release(&ctx);
    }
    cache.release_buffers(&ctx);
    gpu_scene.release(&ctx);
    Ok(report)
}

/// Median of `values` (the mean of the middle two for an even count); 0 when empty.
fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut values: Vec<f64> = values.into_iter().collect();
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    if values.len() % 2 == 1 {
        values[mid]
    } else {
        0.5 * (values[mid - 1] + values[mid])
    }
}

/// One row of the pass table: a frame's (or the median frame's) times.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassRow {
    /// Milliseconds of each of [`CACHE_PASSES`]; `None` when the pass did not run.
    pub cache_ms: [Option<f64>; CACHE_PASSES.len()],
    /// Milliseconds of `gbuffer/primary`, when the G-buffer ran.
    pub gbuffer_ms: Option<f64>,
    pub cpu_update_ms: f64,
    pub scene_update_ms: f64,
}

impl PassRow {
    /// GPU milliseconds of the cache's passes.
    pub fn cache_gpu_ms(&self) -> f64 {
        self.cache_ms.iter().flatten().sum()
    }

    fn of(frame: &FrameRecord) -> Self {
        Self {
            cache_ms: CACHE_PASSES.map(|name| frame.passes.get(name)),
            gbuffer_ms: frame.passes.get("gbuffer/primary"),
            cpu_update_ms: frame.cpu_update_ms,
            scene_update_ms: frame.scene_update_ms,
        }
    }

    /// Per pass, the median over the frames that ran it (a pass that ran in none stays
    /// `None`); frames that skipped a pass (nothing queued to voxelize) do not count as 0.
    fn median_of(frames: &[FrameRecord]) -> Self {
        let rows: Vec<PassRow> = frames.iter().map(PassRow::of).collect();
        let pass = |get: &dyn Fn(&PassRow) -> Option<f64>| {
            let values: Vec<f64> = rows.iter().filter_map(get).collect();
            (!values.is_empty()).then(|| median(values))
        };
        Self {
            cache_ms: std::array::from_fn(|i| pass(&|r| r.cache_ms[i])),
            gbuffer_ms: pass(&|r| r.gbuffer_ms),
            cpu_update_ms: median(rows.iter().map(|r| r.cpu_update_ms)),
            scene_update_ms: median(rows.iter().map(|r| r.scene_update_ms)),
        }
    }

    fn json(&self) -> serde_json::Value {
        let mut passes = serde_json::Map::new();
        for (name, ms) in CACHE_PASSES.iter().zip(self.cache_ms) {
            passes.insert((*name).to_owned(), ms.into());
        }
        passes.insert("gbuffer/primary".to_owned(), self.gbuffer_ms.into());
        serde_json::json!({
            "passes_ms": passes,
            "cache_gpu_ms": self.cache_gpu_ms(),
            "cpu_update_ms": self.cpu_update_ms,
            "scene_update_ms": self.scene_update_ms,
        })
    }
}

impl CacheUpdateReport {
    /// The fill frame's times.
    pub fn fill(&self) -> PassRow {
        self.frames.first().map(PassRow::of).unwrap_or_default()
    }

    /// The median per pass over the frames after the fill (empty with a single frame).
    pub fn steady(&self) -> PassRow {
        PassRow::median_of(self.frames.get(1..).unwrap_or_default())
    }

    /// Bytes of every `cache.*` buffer, lighting included.
    pub fn cache_bytes(&self) -> u64 {
        self.memory_by_label.iter().map(|(_, bytes)| bytes).sum()
    }

    /// Bytes of the lighting's buffers (`cache.lighting.*`).
    pub fn lighting_bytes(&self) -> u64 {
        self.memory_by_label
            .iter()
            .filter(|(label, _)| label.starts_with("cache.lighting"))
            .map(|(_, bytes)| bytes)
            .sum()
    }

    /// Markdown tables: passes (fill frame, then the steady-state median), then every frame.
    pub fn table(&self) -> String {
        let config = &self.options.config;
        let clock = if self.gpu_timestamps {
            "GPU timestamps"
        } else {
            "CPU wall-clock"
        };
        let mib = |bytes: u64| bytes as f64 / (1 << 20) as f64;
        let mut out = format!(
            "{} ({} triangles{}) on {}, {} frames along the camera path ({clock})\n\
             cache: {} levels of {:?} bricks, voxels {} m to {} m, pool {} bricks{}\n\n",
            self.scene,
            self.triangles,
            if self.animated { ", animated" } else { "" },
            self.adapter,
            self.frames.len(),
            config.levels,
            config.level_bricks,
            config.voxel_size_m,
            config.voxel_size_at(config.levels - 1),
            config.pool_bricks,
            match self.options.screen_inject {
                Some((w, h)) => format!(", screen injection from a {w}x{h} G-buffer"),
                None => String::new(),
            },
        );
        let ms = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.3}"));
        out += "| pass | fill frame ms | steady median ms |\n|---|---:|---:|\n";
        let (fill, steady) = (self.fill(), self.steady());
        let steady_frames = self.frames.len() > 1;
        let steady_ms = |v: Option<f64>| if steady_frames { ms(v) } else { "-".to_owned() };
        if self.options.screen_inject.is_some() {
            out += &format!(
                "| gbuffer/primary | {} | {} |\n",
                ms(fill.gbuffer_ms),
                steady_ms(steady.gbuffer_ms)
            );
        }
        for (i, name) in CACHE_PASSES.iter().enumerate() {
            out += &format!(
                "| {name} | {} | {} |\n",
                ms(fill.cache_ms[i]),
                steady_ms(steady.cache_ms[i])
            );
        }
        out += &format!(
            "| cache GPU total | {:.3} | {} |\n| cpu update | {:.3} | {} |\n",
            fill.cache_gpu_ms(),
            steady_ms(Some(steady.cache_gpu_ms())),
            fill.cpu_update_ms,
            steady_ms(Some(steady.cpu_update_ms)),
        );
        if self.animated {
            out += &format!(
                "| scene update | - | {} |\n",
                steady_ms(Some(steady.scene_update_ms))
            );
        }
        let stats = &self.stats;
        out += &format!(
            "\nbricks: {} allocated, {} queued, {} dropped for pool (per level {:?})\n\
             memory: {:.2} MiB in cache.* ({:.3} MiB of it lighting)\n\n",
            stats.allocated_bricks,
            stats.queued_bricks,
            stats.dropped_for_pool,
            stats.bricks_per_level,
            mib(self.cache_bytes()),
            mib(self.lighting_bytes()),
        );
        if self.frames.len() > 1 {
            let after_fill = &self.frames[1..];
            let worst = |value: &dyn Fn(&FrameRecord) -> f64| {
                after_fill.iter().map(value).fold(0.0, f64::max)
            };
            out += &format!(
                "after the fill frame, the worst frame: cache GPU {:.3} ms, cpu update {:.3} ms, \
                 {} triangle entries scanned\n\n",
                worst(&|f| PassRow::of(f).cache_gpu_ms()),
                worst(&|f| f.cpu_update_ms),
                after_fill
                    .iter()
                    .map(|f| f.update.scanned_triangles)
                    .max()
                    .unwrap_or(0),
            );
            let step = |value: &dyn Fn(&CpuSteps) -> f64| {
                let values: Vec<f64> = after_fill.iter().map(|f| value(&f.update.cpu)).collect();
                (
                    median(values.iter().copied()),
                    values.iter().copied().fold(0.0, f64::max),
                )
            };
            out += "cpu update steps after the fill frame, median / worst ms:";
            for (name, (med, max)) in [
                ("index", step(&|c| c.index_ms)),
                ("windows", step(&|c| c.windows_ms)),
                ("dynamic", step(&|c| c.dynamic_ms)),
                ("select", step(&|c| c.select_ms)),
                ("binning", step(&|c| c.binning_ms)),
                ("allocate", step(&|c| c.allocate_ms)),
                ("record", step(&|c| c.record_ms)),
                ("screen selection", step(&|c| c.screen_select_ms)),
                ("screen", step(&|c| c.screen_ms)),
                ("schedule", step(&|c| c.schedule_ms)),
                ("lighting", step(&|c| c.lighting_ms)),
            ] {
                out += &format!(" {name} {med:.3} / {max:.3};");
            }
            out += "\n\n";
        }
        out += "| frame | time s | voxelized (list entries/parts) | queued | \
                scheduled (new/near/far/settle) | cache GPU ms | cpu update ms |\n\
                |---:|---:|---:|---:|---|---:|---:|\n";
        for (index, frame) in self.frames.iter().enumerate() {
            let s = frame.scheduled;
            out += &format!(
                "| {index} | {:.3} | {} ({}/{}) | {} | {} ({}/{}/{}/{}) | {:.3} | {:.3} |\n",
                frame.time_s,
                frame.update.voxelized,
                frame.update.voxelized_triangles,
                frame.update.voxelize_parts,
                frame.update.queued_remaining,
                s.total(),
                s.new,
                s.near,
                s.far,
                s.settle,
                PassRow::of(frame).cache_gpu_ms(),
                frame.cpu_update_ms,
            );
        }
        out
    }

    /// The results as JSON.
    pub fn json(&self) -> serde_json::Value {
        let config = &self.options.config;
        let stats = &self.stats;
        serde_json::json!({
            "scene": self.scene,
            "triangles": self.triangles,
            "animated": self.animated,
            "adapter": self.adapter,
            "gpu_timestamps": self.gpu_timestamps,
            "frames": self.frames.len(),
            "config": {
                "voxel_size_m": config.voxel_size_m,
                "levels": config.levels,
                "level_bricks": config.level_bricks,
                "pool_bricks": config.pool_bricks,
                "voxelize_bricks_per_frame": config.voxelize_bricks_per_frame,
                "voxelize_scan_per_frame": config.voxelize_scan_per_frame,
                "voxelize_part_triangles": config.voxelize_part_triangles,
                "screen_inject_bricks_per_frame": config.screen_inject_bricks_per_frame,
                "light_bricks_per_frame": config.light_bricks_per_frame,
                "settle_bricks_per_frame": config.settle_bricks_per_frame,
                "relight_bricks_per_frame": config.relight_bricks_per_frame,
                "settle_updates": config.settle_updates,
            },
            "settle_s": self.options.settle_s,
            "screen_inject": self.options.screen_inject.map(|(w, h)| serde_json::json!({
                "width": w,
                "height": h,
            })),
            "fill": self.fill().json(),
            "steady": (self.frames.len() > 1).then(|| self.steady().json()),
            "bricks": {
                "allocated": stats.allocated_bricks,
                "free": stats.free_bricks,
                "queued": stats.queued_bricks,
                "dropped_for_pool": stats.dropped_for_pool,
                "per_level": stats.bricks_per_level,
            },
            "memory": {
                "cache_bytes": self.cache_bytes(),
                "lighting_bytes": self.lighting_bytes(),
                "by_label": self.memory_by_label.iter()
                    .map(|(label, bytes)| (label.clone(), (*bytes).into()))
                    .collect::<serde_json::Map<_, _>>(),
            },
            "per_frame": self.frames.iter().map(|f| {
                let row = PassRow::of(f);
                serde_json::json!({
                    "time_s": f.time_s,
                    "passes_ms": f.passes.0.iter()
                        .map(|(name, _)| (name.clone(), f.passes.get(name).into()))
                        .collect::<serde_json::Map<_, _>>(),
                    "cache_gpu_ms": row.cache_gpu_ms(),
                    "cpu_update_ms": f.cpu_update_ms,
                    "scene_update_ms": f.scene_update_ms,
                    "voxelized": f.update.voxelized,
                    "scanned_triangles": f.update.scanned_triangles,
                    "voxelized_triangles": f.update.voxelized_triangles,
                    "voxelize_parts": f.update.voxelize_parts,
                    "cpu_steps_ms": {
                        "index": f.update.cpu.index_ms,
                        "windows": f.update.cpu.windows_ms,
                        "dynamic": f.update.cpu.dynamic_ms,
                        "select": f.update.cpu.select_ms,
                        "binning": f.update.cpu.binning_ms,
                        "allocate": f.update.cpu.allocate_ms,
                        "record": f.update.cpu.record_ms,
                        "screen_select": f.update.cpu.screen_select_ms,
                        "screen": f.update.cpu.screen_ms,
                        "schedule": f.update.cpu.schedule_ms,
                        "lighting": f.update.cpu.lighting_ms,
                    },
                    "queued_remaining": f.update.queued_remaining,
                    "dropped_for_pool": f.update.dropped_for_pool,
                    "evicted": f.update.evicted,
                    "levels_moved": f.update.levels_moved,
                    "screen_injected": f.update.screen_injected,
                    "scheduled": {
                        "total": f.scheduled.total(),
                        "new": f.scheduled.new,
                        "near": f.scheduled.near,
                        "far": f.scheduled.far,
                        "settle": f.scheduled.settle,
                    },
                })
            }).collect::<Vec<_>>(),
        })
    }
}

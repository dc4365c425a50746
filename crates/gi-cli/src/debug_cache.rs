//! `gi debug-cache`: renders what the brick radiance cache holds for a scene, seen from the
//! scene's camera through the cache's hierarchical DDA (albedo, normals, radiance, occupancy
//! per level, ...), and reports the cache's size, memory and pass times.
//!
//! The cache runs as the real-time tiers run it: a [`RadianceCache`] with its [`CacheLighting`]
//! is updated `--frames` times at the requested time and camera (voxelizing on the GPU, then
//! injecting direct light and gathering bounces), so the `radiance` and `irradiance` views show
//! the lighting accumulated over those updates. One update adds one bounce; the default of 32
//! updates reaches the accumulation cap of the default configuration on small scenes.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use gi_cache::{CacheConfig, CacheInputs, CacheLighting, CacheTracer, DebugView, RadianceCache};
use gi_gpu::{GpuContext, GpuScene, GpuTimer, PassTimings, Recorder, ShaderLibrary, Technique};

/// Arguments of `gi debug-cache`.
#[derive(Args, Debug)]
pub struct DebugCacheArgs {
    /// Bundled scene name or path to a .gltf/.glb file.
    scene: String,
    /// Lighting file (JSON: sun, sky, exposure, default camera) applied to the scene; without
    /// it, `<stem>.lighting.json` beside the scene file is used when it exists.
    #[arg(long, value_name = "FILE")]
    lighting: Option<PathBuf>,
    /// What to show: albedo, normal, radiance, irradiance, occupancy, face or distance.
    #[arg(long, default_value = "occupancy")]
    view: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: String,
    /// Scene time in seconds (animated scenes).
    #[arg(long, default_value_t = 0.0)]
    time: f32,
    /// Cache updates (voxelization and lighting) before the view is rendered. More updates fill
    /// larger views and converge the lighting further (one bounce per update) at the cost of
    /// run time; small scenes settle within the default.
    #[arg(long, default_value_t = 32)]
    frames: u32,
    /// Bricks the cache's pool holds (default 12288).
    #[arg(long, value_name = "N")]
    pool_bricks: Option<u32>,
    /// Output PNG (default `debug-cache-<scene>-<view>.png`).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Parses `WIDTHxHEIGHT` within the command line's limits.
fn parse_size(size: &str) -> anyhow::Result<(u32, u32)> {
    let parsed = size
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    let Some((width, height)) = parsed else {
        anyhow::bail!("--size {size}: expected WIDTHxHEIGHT, e.g. 320x240");
    };
    anyhow::ensure!(
        (1..=crate::MAX_SIDE).contains(&width) && (1..=crate::MAX_SIDE).contains(&height),
        "--size {size} is out of range (each side 1..={})",
        crate::MAX_SIDE
    );
    Ok((width, height))
}

pub fn run(args: &DebugCacheArgs) -> anyhow::Result<()> {
    let view: DebugView = args.view.parse()?;
    let (width, height) = parse_size(&args.size)?;
    anyhow::ensure!(
        args.time.is_finite() && args.time >= 0.0,
        "--time {} must be a non-negative number of seconds",
        args.time
    );
    anyhow::ensure!(args.frames >= 1, "--frames must be at least 1");
    let out = args.out.clone().unwrap_or_else(|| {
        let stem = std::path::Path::new(&args.scene)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".to_owned());
        PathBuf::from(format!("debug-cache-{stem}-{view}.png"))
    });
    anyhow::ensure!(
        out.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png")),
        "--out {}: debug views are written as .png",
        out.display()
    );

    let scene = crate::load_scene(&args.scene, args.lighting.as_deref())?;
    let frame = scene.evaluate(args.time, None);
    let ctx = GpuContext::new().context("debug-cache needs a GPU (or lavapipe)")?;
    let shaders = ShaderLibrary::new();
    let mut config = CacheConfig::default();
    if let Some(bricks) = args.pool_bricks {
        config.pool_bricks = bricks;
    }
    config.validate()?;
    let gpu_scene = GpuScene::upload(&ctx, &scene, &frame)?;
    let mut cache = RadianceCache::new(&ctx, &config)?;
    CacheLighting::attach(&ctx, &shaders, &mut cache)?;
    let mut timer = GpuTimer::new(&ctx, "debug_cache.timer", 12);
    let started = Instant::now();
    let mut last = PassTimings::default();
    for _ in 0..args.frames {
        let mut rec = Recorder::new(&ctx, &mut timer, "debug_cache.update");
        cache.record(
            &mut rec,
            &CacheInputs {
                scene: &scene,
                frame: &frame,
                gpu_scene: &gpu_scene,
                camera_position: frame.camera.position,
                gbuffer: None,
            },
        );
        let encoder = rec.into_encoder();
        last = timer.finish(&ctx, encoder);
    }
    let update_s = started.elapsed().as_secs_f64();
    let tracer = CacheTracer::new(&ctx, &shaders)?;
    let image = tracer.render_debug_view(&ctx, cache.buffers(), view, &frame.camera, width, height);
    // Views of stored light use the scene's exposure; the others are colors in [0, 1].
    let exposure = match view {
        DebugView::Radiance | DebugView::Irradiance => scene.exposure,
        _ => 1.0,
    };
    gi_image::write_png(&image, &out, exposure)
        .with_context(|| format!("writing {}", out.display()))?;

    let stats = cache.stats();
    let memory = ctx.memory();
    let mib = |bytes: u64| bytes as f64 / (1024.0 * 1024.0);
    outln!("scene          {}", scene.name);
    outln!("view           {view} ({width}x{height})");
    outln!(
        "levels         {} x {:?} bricks, voxels {} m to {} m",
        config.levels,
        config.level_bricks,
        config.voxel_size_at(0),
        config.voxel_size_at(config.levels - 1)
    );
    outln!(
        "bricks         {} of {} in the pool, {} still queued",
        stats.allocated_bricks,
        config.pool_bricks,
        stats.queued_bricks
    );
    outln!("per level      {:?}", stats.bricks_per_level);
    outln!(
        "dropped        {} (bricks with geometry left out: pool full)",
        stats.dropped_for_pool
    );
    outln!(
        "memory         {:.2} MiB on the GPU ({:.3} MiB of it lighting)",
        mib(memory.bytes_with_prefix("cache.")),
        mib(memory.bytes_with_prefix("cache.lighting"))
    );
    outln!(
        "updated        {} frames in {update_s:.2} s (voxelization and lighting on the GPU)",
        args.frames
    );
    outln!("last frame     ms per pass ({:?} timer):", timer.mode());
    for (pass, ms) in &last.0 {
        outln!("  {pass:<18} {ms:>10.3}");
    }
    outln!("wrote          {}", out.display());
    cache.release_buffers(&ctx);
    gpu_scene.release(&ctx);
    Ok(())
}

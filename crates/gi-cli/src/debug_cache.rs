//! `gi debug-cache`: renders what the brick radiance cache holds for a scene, seen from the
//! scene's camera through the cache's hierarchical DDA (albedo, normals, radiance, occupancy
//! per level, ...), and reports the cache's size.
//!
//! The cache is filled on the CPU (`CpuCache`: the same voxels the GPU voxelizer writes) around
//! the camera. It is not lit here, so the `radiance` and `irradiance` views show only what the
//! cache holds before lighting: emission, and black elsewhere.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use gi_cache::{CacheConfig, CpuCache, DebugView, render_debug_view};
use gi_gpu::GpuContext;

/// Arguments of `gi debug-cache`.
#[derive(Args, Debug)]
pub struct DebugCacheArgs {
    /// Bundled scene name or path to a .gltf/.glb file.
    scene: String,
    /// What to show: albedo, normal, radiance, irradiance, occupancy, face or distance.
    #[arg(long, default_value = "occupancy")]
    view: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: String,
    /// Scene time in seconds (animated scenes).
    #[arg(long, default_value_t = 0.0)]
    time: f32,
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

    let scene = gi_scene::load(&args.scene)?;
    let frame = scene.evaluate(args.time, None);
    let ctx = GpuContext::new().context("debug-cache needs a GPU (or lavapipe)")?;
    let config = CacheConfig::default();
    let started = std::time::Instant::now();
    let cache = CpuCache::build(&config, &scene, &frame, frame.camera.position)?;
    let build_s = started.elapsed().as_secs_f64();
    let buffers = cache.upload(&ctx);
    let image = render_debug_view(&ctx, &buffers, view, &frame.camera, width, height)?;
    // Views of stored light use the scene's exposure; the others are colors in [0, 1].
    let exposure = match view {
        DebugView::Radiance | DebugView::Irradiance => scene.exposure,
        _ => 1.0,
    };
    gi_image::write_png(&image, &out, exposure)
        .with_context(|| format!("writing {}", out.display()))?;

    let per_level = cache.bricks_per_level();
    let total: u32 = per_level.iter().sum();
    println!("scene          {}", scene.name);
    println!("view           {view} ({width}x{height})");
    println!(
        "levels         {} x {:?} bricks, voxels {} m to {} m",
        config.levels,
        config.level_bricks,
        config.voxel_size_at(0),
        config.voxel_size_at(config.levels - 1)
    );
    println!(
        "bricks         {total} of {} in the pool",
        config.pool_bricks
    );
    println!("per level      {per_level:?}");
    println!(
        "dropped        {} (bricks with geometry left out: pool full)",
        cache.dropped_for_pool
    );
    println!(
        "memory         {:.2} MiB on the GPU",
        buffers.bytes() as f64 / (1024.0 * 1024.0)
    );
    println!("filled in      {build_s:.2} s (CPU voxelizer)");
    if matches!(view, DebugView::Radiance | DebugView::Irradiance) {
        println!("note           the cache is not lit by this command: only emission shows");
    }
    println!("wrote          {}", out.display());
    buffers.release(&ctx);
    Ok(())
}

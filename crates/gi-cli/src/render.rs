//! `gi render`: one image of a scene at one tier.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use gi_tiers::TierKind;

use crate::{ViewArgs, parse_tier, tiers::render_tier};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Bundled scene name (see `gi scenes`) or path to a .gltf/.glb file.
    scene: String,
    /// Lighting file (JSON: sun, sky, exposure, default camera) applied to the scene; without
    /// it, `<stem>.lighting.json` beside the scene file is used when it exists.
    #[arg(long, value_name = "FILE")]
    lighting: Option<PathBuf>,
    /// Tier to render with: reference, direct, path, mobile, pc.
    #[arg(long, value_parser = parse_tier, default_value = "reference")]
    tier: TierKind,
    #[command(flatten)]
    view: ViewArgs,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Output image: .png (tonemapped with the scene's exposure) or .exr (linear HDR).
    #[arg(long)]
    out: PathBuf,
    /// Also write render statistics as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
}

/// The `--stats` JSON.
#[derive(Serialize)]
pub struct RenderReport {
    pub scene: String,
    pub tier: &'static str,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub frames: u32,
    /// Still warm-up frames rendered before the frames (0 for tiers without history).
    pub warmup: u32,
    pub time_s: f32,
    pub triangles: usize,
    pub ms_per_frame: f64,
    pub passes: std::collections::BTreeMap<String, f64>,
    pub memory_bytes: u64,
    /// Path-tracing throughput; null for tiers that don't trace paths on the CPU.
    pub samples_per_second: Option<f64>,
    pub rays_per_second: Option<f64>,
    pub bvh_build_ms: Option<f64>,
    /// The mobile tier's GI time and memory breakdown; null for the other tiers.
    pub mobile: Option<crate::tiers::MobileReport>,
    /// The PC tier's GI time and memory breakdown; null for the other tiers.
    pub pc: Option<crate::tiers::PcReport>,
    /// Wall seconds of the scene's import (decoding its images, generating tangents).
    pub load_s: f64,
    /// Wall seconds to open the tier (device, shaders, pipelines).
    pub open_s: f64,
    /// Wall seconds of the first frame (the scene's upload: BVH, textures; the cache's fill);
    /// null when not timed apart.
    pub first_frame_s: Option<f64>,
}

/// A progress bar over samples per pixel; indicatif hides it when stderr is not a terminal.
pub fn progress_bar(total_spp: u32, label: &str) -> ProgressBar {
    let bar = ProgressBar::new(u64::from(total_spp));
    let style = ProgressStyle::with_template(
        "{prefix:>10} [{bar:30}] {pos}/{len} spp  {elapsed_precise} (eta {eta})",
    )
    .expect("the template is valid")
    .progress_chars("=> ");
    bar.set_style(style);
    bar.set_prefix(label.to_string());
    bar
}

fn check_output_extension(path: &std::path::Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("png" | "exr") => Ok(()),
        _ => anyhow::bail!(
            "--out {}: unsupported image format (use .png or .exr)",
            path.display()
        ),
    }
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let request = args.view.request(args.spp)?;
    // Check the output before spending time on the render.
    check_output_extension(&args.out)?;
    let loading = std::time::Instant::now();
    let scene = crate::load_scene(&args.scene, args.lighting.as_deref())?;
    let load_s = loading.elapsed().as_secs_f64();
    let bar = progress_bar(request.spp, args.tier.name());
    let result = render_tier(&scene, args.tier, &request, &|done| {
        bar.set_position(u64::from(done))
    })?;
    bar.finish_and_clear();
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    gi_image::save(&result.image, &args.out, scene.exposure)?;
    let report = RenderReport {
        scene: scene.name.clone(),
        tier: args.tier.name(),
        width: request.width,
        height: request.height,
        spp: request.spp,
        frames: request.frames,
        warmup: result.warmup,
        time_s: request.time_s(&scene),
        triangles: scene
            .evaluate(request.time_s(&scene), Some(request.view(&scene)))
            .triangles
            .len(),
        ms_per_frame: result.ms_per_frame,
        passes: result.passes.clone(),
        memory_bytes: result.memory_bytes,
        samples_per_second: result.stats.as_ref().map(|s| s.samples_per_second),
        rays_per_second: result.stats.as_ref().map(|s| s.rays_per_second),
        bvh_build_ms: result.stats.as_ref().map(|s| s.bvh_build_seconds * 1e3),
        mobile: result.mobile.clone(),
        pc: result.pc.clone(),
        load_s,
        open_s: result.open_s,
        first_frame_s: result.first_frame_s,
    };
    let throughput = match (report.samples_per_second, report.rays_per_second) {
        (Some(samples), Some(rays)) => {
            format!(
                ", {:.3} Msamples/s, {:.2} Mrays/s",
                samples / 1e6,
                rays / 1e6
            )
        }
        _ => String::new(),
    };
    outln!(
        "{} {} {}x{} {} spp: {:.1} ms{throughput} -> {}",
        report.scene,
        report.tier,
        report.width,
        report.height,
        report.spp,
        report.ms_per_frame,
        args.out.display()
    );
    outln!(
        "load {:.2} s (import), tier {:.2} s (device, shaders), first frame {} (scene upload: \
         BVH, textures; cache fill)",
        report.load_s,
        report.open_s,
        report
            .first_frame_s
            .map_or("not timed apart".to_string(), |s| format!("{s:.2} s"))
    );
    if let Some(mobile) = &report.mobile {
        outln!("{}", mobile.line(report.ms_per_frame, report.warmup));
    }
    if let Some(pc) = &report.pc {
        outln!("{}", pc.line(report.ms_per_frame, report.warmup));
    }
    if let Some(path) = &args.stats {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

//! `gi compare`: render tiers, measure them against a path-traced reference, print a table.

use std::{collections::BTreeMap, path::PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use gi_reference::cache::{self, CachedReference, ReferenceRequest};
use gi_reference::engine::EngineChoice;
use serde::Serialize;

use gi_tiers::TierKind;

use crate::{
    ViewArgs, parse_tier,
    render::progress_bar,
    tiers::{MobileReport, PcReport, render_tier},
};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Bundled scene name (see `gi scenes`) or path to a .gltf/.glb file.
    #[arg(default_value = "cornell-box")]
    scene: String,
    /// Lighting file (JSON: sun, sky, exposure, default camera) applied to the scene; without
    /// it, `<stem>.lighting.json` beside the scene file is used when it exists.
    #[arg(long, value_name = "FILE")]
    lighting: Option<PathBuf>,
    /// Comma-separated tiers to compare (default: every tier: reference, direct, path, mobile,
    /// pc).
    #[arg(long, value_delimiter = ',', value_parser = parse_tier)]
    tiers: Vec<TierKind>,
    #[command(flatten)]
    view: ViewArgs,
    /// Samples per pixel of each tier's render.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// Samples per pixel of the reference.
    #[arg(long, default_value_t = cache::DEFAULT_REFERENCE_SPP)]
    reference_spp: u32,
    /// Seed of the reference render (kept apart from `--seed` so a tier's noise is never
    /// correlated with the reference's).
    #[arg(long, default_value_t = cache::REFERENCE_SEED)]
    reference_seed: u64,
    /// Folder for the images (default: `out/<scene>`).
    #[arg(long)]
    out_dir: Option<PathBuf>,
    /// Write the table as JSON here (default: `<out-dir>/compare.json`).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Reference cache folder (default: $GI_CACHE_DIR, $XDG_CACHE_HOME/gi or ~/.cache/gi).
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Render the reference even when a cached one exists.
    #[arg(long)]
    no_cache: bool,
    /// What renders the reference: auto (the GPU path tier on a hardware GPU, else the CPU
    /// path tracer; takes a cached reference of either), gpu (the GPU path tier, on any
    /// Vulkan adapter, a software one too) or cpu. The two compute the same image up to
    /// rounding; the GPU is many times faster. An explicit choice takes only cached
    /// references its own engine made.
    #[arg(long, default_value_t = EngineChoice::Auto)]
    reference_engine: EngineChoice,
}

#[derive(Serialize)]
struct ReferenceReport {
    spp: u32,
    seconds: f64,
    cached: bool,
    /// The engine that rendered it: `cpu` or `gpu: <adapter name>`.
    engine: String,
}

#[derive(Serialize)]
struct TierReport {
    tier: &'static str,
    rmse_srgb8: f64,
    /// Mean FLIP (LDR) against the reference, in 0..1 (`gi_image::flip_ldr`).
    flip: f64,
    rmse_linear: f64,
    rel_mse: f64,
    gain_vs_direct: Option<f64>,
    ms_per_frame: f64,
    passes: BTreeMap<String, f64>,
    memory_bytes: u64,
    /// Still warm-up frames rendered before the frames (0 for tiers without history).
    warmup: u32,
    /// The mobile tier's GI time (`cache/*` + `mobile/*` passes) and memory breakdown; absent
    /// for the other tiers.
    #[serde(skip_serializing_if = "Option::is_none")]
    mobile: Option<MobileReport>,
    /// The PC tier's GI time (`cache/*` + `pc/*` passes) and memory breakdown; absent for the
    /// other tiers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pc: Option<PcReport>,
    /// Path-tracing throughput; null for tiers that don't trace paths on the CPU.
    samples_per_second: Option<f64>,
    rays_per_second: Option<f64>,
}

/// A tier that could not render on this machine (`gi_tiers::TierError::Unavailable`).
#[derive(Serialize)]
struct MissingTier {
    tier: &'static str,
    reason: String,
}

#[derive(Serialize)]
struct CompareReport {
    scene: String,
    width: u32,
    height: u32,
    spp: u32,
    frames: u32,
    /// `--warmup` as given; null: each tier's default (the tiers' `warmup` say what ran).
    warmup: Option<u32>,
    reference: ReferenceReport,
    tiers: Vec<TierReport>,
    /// Tiers of the default list that could not render here, with why (asked for by name with
    /// `--tiers`, such a tier is an error instead).
    missing: Vec<MissingTier>,
}

/// The reference image: from the cache when an identical render exists, else rendered now.
fn reference_image(args: &CompareArgs, scene: &gi_scene::Scene) -> Result<CachedReference> {
    let request = args.view.request(args.reference_spp)?;
    let reference = ReferenceRequest::new(
        scene,
        request.view(scene),
        request.time_s(scene),
        (request.width, request.height),
        request.spp,
        args.reference_seed,
    );
    let dir = args.cache_dir.clone().unwrap_or_else(cache::default_dir);
    let cache = gi_tiers::reference_cache(dir, args.reference_engine)
        .with_context(|| format!("--reference-engine {}", args.reference_engine))?;
    let bar = progress_bar(request.spp, "reference");
    let found = cache.get_or_render(
        &reference,
        !args.no_cache,
        &|done| bar.set_position(u64::from(done)),
        &|| false,
    )?;
    bar.finish_and_clear();
    found.context("the reference render stopped before it finished")
}

pub fn run(args: &CompareArgs) -> Result<()> {
    let request = args.view.request(args.spp)?;
    args.view.request(args.reference_spp)?;
    let tiers = if args.tiers.is_empty() {
        TierKind::ALL.to_vec()
    } else {
        args.tiers.clone()
    };
    let scene = crate::load_scene(&args.scene, args.lighting.as_deref())?;
    let out_dir = args
        .out_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    std::fs::create_dir_all(&out_dir).with_context(|| format!("creating {}", out_dir.display()))?;

    let CachedReference {
        image: reference,
        seconds: reference_seconds,
        cached,
        engine: reference_engine,
    } = reference_image(args, &scene)?;
    // Named apart from the `reference` tier's own (low-spp) render.
    let truth = format!("reference_{}spp", args.reference_spp);
    gi_image::save(&reference, out_dir.join(format!("{truth}.exr")), 1.0)?;
    gi_image::save(
        &reference,
        out_dir.join(format!("{truth}.png")),
        scene.exposure,
    )?;

    // gain_vs_direct needs the direct-only error even when `direct` is not in the list.
    let mut renders = Vec::new();
    let mut missing = Vec::new();
    for &tier in &tiers {
        let bar = progress_bar(request.spp, tier.name());
        let render = render_tier(&scene, tier, &request, &|done| {
            bar.set_position(u64::from(done))
        });
        bar.finish_and_clear();
        match render {
            Ok(render) => renders.push((tier, render)),
            // The default list renders what this machine can (the CPU tiers without a Vulkan
            // driver) and marks the rest; tiers asked for by name must render.
            Err(err) if args.tiers.is_empty() && is_unavailable(&err) => {
                missing.push(MissingTier {
                    tier: tier.name(),
                    reason: format!("{err:#}"),
                });
            }
            Err(err) => return Err(err),
        }
    }
    let direct_rmse = match renders.iter().find(|(t, _)| *t == TierKind::Direct) {
        Some((_, render)) => gi_image::rmse_srgb8(&render.image, &reference, scene.exposure)?,
        None => {
            let render = render_tier(&scene, TierKind::Direct, &request, &|_| {})?;
            gi_image::rmse_srgb8(&render.image, &reference, scene.exposure)?
        }
    };

    let mut reports = Vec::new();
    for (tier, render) in &renders {
        let rmse_srgb8 = gi_image::rmse_srgb8(&render.image, &reference, scene.exposure)?;
        let name = tier.name();
        gi_image::save(
            &render.image,
            out_dir.join(format!("{name}.png")),
            scene.exposure,
        )?;
        gi_image::save(
            &render.image,
            out_dir.join(format!("{name}.exr")),
            scene.exposure,
        )?;
        gi_image::write_error_heatmap(
            &render.image,
            &reference,
            scene.exposure,
            out_dir.join(format!("{name}_error.png")),
        )?;
        let flip = gi_image::write_flip_map(
            &render.image,
            &reference,
            scene.exposure,
            out_dir.join(format!("{name}_flip.png")),
        )?;
        reports.push(TierReport {
            tier: tier.name(),
            rmse_srgb8,
            flip: flip.mean,
            rmse_linear: gi_image::rmse_linear(&render.image, &reference)?,
            rel_mse: gi_image::rel_mse(&render.image, &reference)?,
            gain_vs_direct: gi_image::gain_vs_direct(rmse_srgb8, direct_rmse),
            ms_per_frame: render.ms_per_frame,
            passes: render.passes.clone(),
            memory_bytes: render.memory_bytes,
            warmup: render.warmup,
            mobile: render.mobile.clone(),
            pc: render.pc.clone(),
            samples_per_second: render.stats.as_ref().map(|s| s.samples_per_second),
            rays_per_second: render.stats.as_ref().map(|s| s.rays_per_second),
        });
    }
    let report = CompareReport {
        scene: scene.name.clone(),
        width: request.width,
        height: request.height,
        spp: request.spp,
        frames: request.frames,
        warmup: request.warmup,
        reference: ReferenceReport {
            spp: args.reference_spp,
            seconds: reference_seconds,
            cached,
            engine: reference_engine,
        },
        tiers: reports,
        missing,
    };
    print_table(&report)?;
    let json = args
        .json
        .clone()
        .unwrap_or_else(|| out_dir.join("compare.json"));
    std::fs::write(&json, serde_json::to_string_pretty(&report)?)
        .with_context(|| format!("writing {}", json.display()))?;
    outln!("images and JSON: {}", out_dir.display());
    Ok(())
}

/// Whether `err` says a tier cannot run on this machine (no Vulkan adapter, a device too
/// small), rather than that the render failed.
fn is_unavailable(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        matches!(
            cause.downcast_ref::<gi_tiers::TierError>(),
            Some(gi_tiers::TierError::Unavailable { .. })
        )
    })
}

/// The command that adds the GPU tiers when no Vulkan adapter exists, or `None` when one does
/// (or an adapter filter excludes them: the filter is the user's to change).
fn vulkan_install_hint() -> Option<&'static str> {
    match gi_gpu::GpuContext::new() {
        Err(gi_gpu::GpuError::NoAdapter { filter: None }) => Some(
            "sudo apt-get install mesa-vulkan-drivers libvulkan1   (Debian/Ubuntu: Vulkan on \
             the CPU, lavapipe; a GPU's own Vulkan driver is faster)",
        ),
        _ => None,
    }
}

fn print_table(report: &CompareReport) -> std::io::Result<()> {
    outln!(
        "{} {}x{}, {} spp per tier; reference {} spp ({}, {:.1} s{})",
        report.scene,
        report.width,
        report.height,
        report.spp,
        report.reference.spp,
        report.reference.engine,
        report.reference.seconds,
        if report.reference.cached {
            ", cached"
        } else {
            ""
        }
    );
    outln!(
        "{:<10} {:>10} {:>7} {:>11} {:>14} {:>11} {:>10}",
        "tier",
        "rmse_srgb8",
        "flip",
        "rmse_linear",
        "gain_vs_direct",
        "ms/frame",
        "memory_MB"
    );
    for tier in &report.tiers {
        let gain = tier
            .gain_vs_direct
            .map_or("-".to_string(), |g| format!("{g:.3}"));
        outln!(
            "{:<10} {:>10.2} {:>7.4} {:>11.4} {:>14} {:>11.1} {:>10.2}",
            tier.tier,
            tier.rmse_srgb8,
            tier.flip,
            tier.rmse_linear,
            gain,
            tier.ms_per_frame,
            tier.memory_bytes as f64 / (1 << 20) as f64
        );
    }
    for missing in &report.missing {
        outln!(
            "{:<10} {:>10}  not rendered: {}",
            missing.tier,
            "-",
            missing.reason
        );
    }
    for tier in &report.tiers {
        if let Some(mobile) = &tier.mobile {
            outln!("{}", mobile.line(tier.ms_per_frame, tier.warmup));
        }
        if let Some(pc) = &tier.pc {
            outln!("{}", pc.line(tier.ms_per_frame, tier.warmup));
        }
    }
    if !report.missing.is_empty() {
        let names: Vec<&str> = report.missing.iter().map(|m| m.tier).collect();
        match vulkan_install_hint() {
            Some(command) => outln!(
                "{} need a Vulkan driver; add them with:\n  {command}\nthen run this command again",
                names.join(", ")
            ),
            None => outln!("{} could not render here (see above)", names.join(", ")),
        }
    }
    Ok(())
}

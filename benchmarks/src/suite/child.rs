//! The process that measures one scene (`gi-bench suite-scene`, started by the suite): it
//! finds or renders the scene's reference, runs every tier `repeats` times and prints one
//! [`Event`] per line of JSON on stdout as it goes.
//!
//! Each repeat is a fresh [`Renderer`] (seed = repeat index + 1) that renders the tier's still
//! warm-up and then the measured frames; the last measured frame is the image compared with
//! the reference, which shows the same camera (the default) at the same scene time.

use std::{path::Path, time::Instant};

use anyhow::{Context, Result};
use gi_image::{Flip, Image};
use gi_reference::cache::ReferenceRequest;
use gi_scene::Scene;
use gi_tiers::{CameraMode, CpuTier, Renderer, TierChoice, TierKind, TierSettings};
use serde::{Deserialize, Serialize};

use super::{
    file_stem,
    results::{Adapter, CellRun, Options, ReferenceInfo, median},
};

/// One line of a scene process's stdout.
#[derive(Debug, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "kebab-case")]
pub enum Event {
    /// The adapter a GPU context opens in this process, or why none opened.
    Adapter {
        adapter: Option<Adapter>,
        error: Option<String>,
    },
    /// A step begins (`reference`, or a tier and repeat), for the progress bar.
    Start {
        tier: String,
        repeat: Option<u32>,
    },
    Reference(ReferenceInfo),
    /// One repeat of one tier, measured or failed.
    Cell {
        tier: String,
        repeat: u32,
        run: Option<CellRun>,
        error: Option<String>,
    },
    /// The scene could not be measured at all (load or reference failed).
    SceneFailed {
        error: String,
    },
}

fn emit(event: &Event) {
    // One write per line, so the parent never reads half an event.
    println!(
        "{}",
        serde_json::to_string(event).expect("events serialize")
    );
}

/// Measures `scene_name` with `options` (the parent's, as JSON), printing events.
pub fn run(scene_name: &str, options: &Options) -> Result<()> {
    let adapter = gi_gpu::GpuContext::new();
    emit(&Event::Adapter {
        adapter: adapter
            .as_ref()
            .ok()
            .map(|ctx| Adapter::from_info(&ctx.adapter_info)),
        error: adapter.as_ref().err().map(|e| e.to_string()),
    });
    // Only its description was wanted: one context fewer for the driver to hold.
    drop(adapter);

    match measure_scene(scene_name, options) {
        Ok(()) => Ok(()),
        Err(error) => {
            emit(&Event::SceneFailed {
                error: format!("{error:#}"),
            });
            Err(error)
        }
    }
}

fn measure_scene(scene_name: &str, options: &Options) -> Result<()> {
    let lighting = options.lighting.as_deref().map(std::path::Path::new);
    let loaded = gi_scene::load_with_lighting(scene_name, lighting)
        .with_context(|| format!("loading {scene_name}"))?;
    for warning in &loaded.warnings {
        eprintln!("warning: {scene_name}: {warning}");
    }
    let scene = loaded.scene;
    let images = Path::new(&options.out_dir).join("images");
    std::fs::create_dir_all(&images).with_context(|| format!("creating {}", images.display()))?;

    emit(&Event::Start {
        tier: "reference image".into(),
        repeat: None,
    });
    let (reference, info) = reference(&scene, scene_name, options)?;
    gi_image::save(
        &reference,
        images.join(format!("{}_reference.png", file_stem(scene_name))),
        scene.exposure,
    )?;
    emit(&Event::Reference(info));

    let tiers: Vec<TierKind> = options
        .tiers
        .iter()
        .map(|name| name.parse())
        .collect::<Result<_, _>>()?;
    // gain_vs_direct divides by the direct-only error of the same repeat, so `direct` runs
    // first; without it in the list, one direct render (seed 1) serves every repeat.
    let mut order = tiers.clone();
    order.sort_by_key(|&tier| tier != TierKind::Direct);
    let direct_listed = tiers.contains(&TierKind::Direct);
    let mut direct_rmse: Vec<Option<f64>> = Vec::new();
    if !direct_listed {
        let direct = measure(&scene, TierKind::Direct, 0, options)
            .and_then(|(_, image)| rmse_srgb8(&image, &reference, &scene));
        direct_rmse.push(direct.ok());
    }

    for tier in order {
        for repeat in 0..options.repeats {
            emit(&Event::Start {
                tier: tier.name().into(),
                repeat: Some(repeat),
            });
            let direct = if direct_listed {
                direct_rmse.get(repeat as usize).copied().flatten()
            } else {
                direct_rmse[0]
            };
            let result = measure_cell(&scene, tier, repeat, options, &reference, direct);
            let (run, error) = match result {
                Ok((mut run, image, flip)) => {
                    if tier == TierKind::Direct {
                        direct_rmse.push(Some(run.rmse_srgb8));
                        run.gain_vs_direct =
                            gi_image::gain_vs_direct(run.rmse_srgb8, run.rmse_srgb8);
                    }
                    if repeat == 0 {
                        let stem = format!("{}_{}", file_stem(scene_name), tier.name());
                        save_images(&scene, &stem, &image, &reference, &flip, &images)?;
                    }
                    (Some(run), None)
                }
                Err(error) => {
                    if tier == TierKind::Direct {
                        direct_rmse.push(None);
                    }
                    (None, Some(format!("{error:#}")))
                }
            };
            emit(&Event::Cell {
                tier: tier.name().into(),
                repeat,
                run,
                error,
            });
        }
    }
    Ok(())
}

/// The scene's reference at the measured frame's time and camera, from the cache or rendered.
fn reference(scene: &Scene, name: &str, options: &Options) -> Result<(Image, ReferenceInfo)> {
    let time_s = scene.frame_time(options.frames.saturating_sub(1));
    let request = ReferenceRequest::new(
        scene,
        scene.default_view(time_s),
        time_s,
        (options.width, options.height),
        options.reference_spp,
        options.reference_seed,
    );
    let cache = gi_tiers::reference_cache(&options.cache_dir, options.reference_engine)
        .with_context(|| format!("--reference-engine {}", options.reference_engine))?;
    let found = cache
        .get_or_render(&request, true, &|_| {}, &|| false)?
        .context("the reference render stopped before it finished")?;
    let info = ReferenceInfo {
        scene: name.to_owned(),
        spp: options.reference_spp,
        time_s,
        seconds: found.seconds,
        cached: found.cached,
        engine: found.engine,
    };
    Ok((found.image, info))
}

fn rmse_srgb8(image: &Image, reference: &Image, scene: &Scene) -> Result<f64> {
    Ok(gi_image::rmse_srgb8(image, reference, scene.exposure)?)
}

/// One repeat of `tier`: its measurement, the last frame's image and its FLIP against the
/// reference.
fn measure_cell(
    scene: &Scene,
    tier: TierKind,
    repeat: u32,
    options: &Options,
    reference: &Image,
    direct_rmse: Option<f64>,
) -> Result<(CellRun, Image, Flip)> {
    let (mut run, image) = measure(scene, tier, repeat, options)?;
    anyhow::ensure!(image.is_finite(), "the image has non-finite pixels");
    run.rmse_srgb8 = rmse_srgb8(&image, reference, scene)?;
    let flip = gi_image::flip_ldr(&image, reference, scene.exposure)?;
    run.flip = flip.mean;
    run.rmse_linear = gi_image::rmse_linear(&image, reference)?;
    run.gain_vs_direct =
        direct_rmse.and_then(|direct| gi_image::gain_vs_direct(run.rmse_srgb8, direct));
    Ok((run, image, flip))
}

/// Renders the warm-up and the measured frames of one repeat of `tier`. The errors are left
/// at 0 for the caller to fill.
fn measure(
    scene: &Scene,
    tier: TierKind,
    repeat: u32,
    options: &Options,
) -> Result<(CellRun, Image)> {
    let settings = TierSettings {
        width: options.width,
        height: options.height,
        spp: options.spp,
        seed: u64::from(repeat) + 1,
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let mut renderer = Renderer::new(
        scene.clone(),
        TierChoice::Tier(tier),
        settings,
        CameraMode::Default,
    )?;
    let on_cpu = renderer.tier_as::<CpuTier>().is_some();
    renderer.warm_up(options.warmup.unwrap_or(tier.default_warmup()), None)?;

    // Every frame ends on frame `frames - 1`, the reference's. A CPU tier keeps no history,
    // so it skips to its last `cpu_frames` frames: each costs a full CPU path trace.
    let frames = options.frames.max(1);
    let measured = if on_cpu {
        options.cpu_frames.clamp(1, frames)
    } else {
        frames
    };
    let mut timed: Vec<Vec<(String, f64)>> = Vec::new();
    let started = Instant::now();
    let last = if on_cpu {
        let first = renderer.render_frames(frames - measured + 1, None)?;
        if measured == 1 {
            first
        } else {
            timed.push(first.passes.clone());
            for _ in 2..measured {
                timed.push(renderer.advance_frame(None)?);
            }
            renderer.render_frame(None)?
        }
    } else {
        for _ in 1..frames {
            timed.push(renderer.advance_frame(None)?);
        }
        renderer.render_frame(None)?
    };
    timed.push(last.passes.clone());
    log_repeat(tier, repeat, started.elapsed().as_secs_f64());

    let totals: Vec<f64> = timed
        .iter()
        .map(|f| f.iter().map(|(_, ms)| ms).sum())
        .collect();
    let has_gi_split = timed
        .iter()
        .flatten()
        .any(|(name, _)| tier.is_gi_pass(name));
    let gi: Vec<f64> = timed
        .iter()
        .map(|f| {
            f.iter()
                .filter(|(name, _)| tier.is_gi_pass(name))
                .map(|(_, ms)| ms)
                .sum()
        })
        .collect();
    let run = CellRun {
        rmse_srgb8: 0.0,
        flip: 0.0,
        rmse_linear: 0.0,
        gain_vs_direct: None,
        ms_per_frame: median(&totals),
        gi_ms: has_gi_split.then(|| median(&gi)),
        passes_ms: pass_medians(&timed),
        memory_bytes: renderer.memory_bytes(),
        warmup: renderer.warm_up_frames(),
        measured_frames: measured,
        on_cpu,
    };
    Ok((run, last.image))
}

/// Wall-clock time of a repeat on stderr (the parent keeps it for failure reports).
fn log_repeat(tier: TierKind, repeat: u32, seconds: f64) {
    eprintln!("{tier} repeat {repeat}: {seconds:.2} s");
}

/// Each pass's median over the frames, in the first frame's order; a pass recorded several
/// times in one frame (the PC denoiser's a-trous iterations) counts with its sum, as
/// `PassTimings::get` does.
fn pass_medians(frames: &[Vec<(String, f64)>]) -> Vec<(String, f64)> {
    let summed: Vec<gi_gpu::PassTimings> = frames
        .iter()
        .map(|frame| {
            let mut passes: Vec<(String, f64)> = Vec::new();
            for (name, ms) in frame {
                match passes.iter_mut().find(|(n, _)| n == name) {
                    Some((_, total)) => *total += ms,
                    None => passes.push((name.clone(), *ms)),
                }
            }
            gi_gpu::PassTimings(passes)
        })
        .collect();
    gi_gpu::PassTimings::median(&summed).0
}

/// The tier's image, error heat map and FLIP map of repeat 0 as `<stem>.png`,
/// `<stem>_error.png` and `<stem>_flip.png`, as `gi compare` writes them.
fn save_images(
    scene: &Scene,
    stem: &str,
    image: &Image,
    reference: &Image,
    flip: &Flip,
    dir: &Path,
) -> Result<()> {
    gi_image::save(image, dir.join(format!("{stem}.png")), scene.exposure)?;
    gi_image::write_error_heatmap(
        image,
        reference,
        scene.exposure,
        dir.join(format!("{stem}_error.png")),
    )?;
    gi_image::write_heatmap_png(
        &gi_image::flip_error_map(flip)?,
        dir.join(format!("{stem}_flip.png")),
    )?;
    Ok(())
}

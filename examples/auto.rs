//! The library end to end: load a scene, let `TierChoice::Auto` pick the tier for this machine
//! (and a frame budget, if given), render the scene's camera path, save the last frame as a
//! PNG and print its passes and the tier's memory.
//!
//! ```text
//! cargo run --release -p gi-examples --bin auto -- [scene] [--frames N] [--budget-ms B]
//!     [--width W] [--height H] [--out last.png]
//! ```
//!
//! `scene` is a bundled scene name or a glTF path (default `atrium`, which has a camera path).

use std::{error::Error, process::ExitCode};

use clap::Parser;
use gi_tiers::{CameraMode, FrameBudget, Renderer, TierChoice, TierSettings};

/// Renders a scene's camera path with the tier `Auto` picks, saves the last frame and prints
/// its passes and the memory.
#[derive(Parser)]
struct Args {
    /// A bundled scene name or a glTF path.
    #[arg(default_value = "atrium")]
    scene: String,
    /// Frames to render (warm-up frames, then the one saved).
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// A frame budget in milliseconds: the best tier whose estimated frame fits it.
    #[arg(long)]
    budget_ms: Option<f64>,
    #[arg(long, default_value_t = 320)]
    width: u32,
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Where the last frame is saved.
    #[arg(long, default_value = "last.png")]
    out: String,
}

fn run(args: &Args) -> Result<(), Box<dyn Error>> {
    let scene = gi_scene::load(&args.scene)?;
    let exposure = scene.exposure;
    let camera = if scene.camera_path.is_some() {
        CameraMode::Path
    } else {
        println!(
            "{} has no camera path: rendering its default camera",
            args.scene
        );
        CameraMode::Default
    };
    let settings = TierSettings {
        width: args.width,
        height: args.height,
        spp: 1,
        seed: 1,
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let choice = match args.budget_ms {
        Some(ms) => TierChoice::AutoWithin(FrameBudget::from_ms(ms)),
        None => TierChoice::Auto,
    };
    let mut renderer = Renderer::new(scene, choice, settings, camera)?;
    let selection = renderer.selection().expect("auto records its selection");
    println!(
        "adapter: {}",
        selection.adapter.as_deref().unwrap_or("none")
    );
    println!(
        "tier: {} on the {:?} ({})",
        selection.chosen, selection.runs_on, selection.reason
    );
    for (kind, why) in &selection.plan.rejected {
        println!("  not {kind}: {why}");
    }
    for (kind, error) in &selection.fallbacks {
        println!("  {kind} could not be created: {error}");
    }

    let frame = renderer.render_frames(args.frames, None)?;
    gi_image::save(&frame.image, &args.out, exposure)?;
    println!(
        "frame {} of the path saved to {}",
        renderer.next_frame() - 1,
        args.out
    );
    println!("{:<32} {:>10}", "pass", "ms");
    for (name, ms) in &frame.passes {
        println!("{name:<32} {ms:>10.3}");
    }
    println!("{:<32} {:>10.3}", "total", frame.ms_total());
    println!(
        "memory: {:.2} MiB",
        renderer.memory_bytes() as f64 / (1024.0 * 1024.0)
    );
    Ok(())
}

fn main() -> ExitCode {
    if let Err(error) = run(&Args::parse()) {
        eprintln!("error: {error}");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

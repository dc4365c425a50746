//! The library end to end: load a scene, let `TierChoice::Auto` pick the tier for this machine
//! (and a frame budget, if given), render the scene's camera path, save the last frame as a
//! PNG and print its passes and the tier's memory.
//!
//! ```text
//! cargo run --release -p gi-tiers --example auto -- [scene] [--frames N] [--budget-ms B]
//!     [--width W] [--height H] [--out last.png]
//! ```
//!
//! `scene` is a bundled scene name or a glTF path (default `atrium`, which has a camera path).

use std::{error::Error, process::ExitCode};

use gi_tiers::{CameraMode, FrameBudget, Renderer, TierChoice, TierSettings};

struct Args {
    scene: String,
    frames: u32,
    budget_ms: Option<f64>,
    width: u32,
    height: u32,
    out: String,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        scene: "atrium".to_string(),
        frames: 16,
        budget_ms: None,
        width: 320,
        height: 240,
        out: "last.png".to_string(),
    };
    let mut scene = None;
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        let number = |name: &str, text: String| {
            text.parse::<f64>()
                .map_err(|e| format!("{name} {text:?}: {e}"))
        };
        match arg.as_str() {
            "--frames" => args.frames = number("--frames", value("--frames")?)? as u32,
            "--budget-ms" => args.budget_ms = Some(number("--budget-ms", value("--budget-ms")?)?),
            "--width" => args.width = number("--width", value("--width")?)? as u32,
            "--height" => args.height = number("--height", value("--height")?)? as u32,
            "--out" => args.out = value("--out")?,
            "-h" | "--help" => {
                return Err(
                    "usage: auto [scene] [--frames N] [--budget-ms B] [--width W] \
                            [--height H] [--out last.png]"
                        .to_string(),
                );
            }
            flag if flag.starts_with("--") => return Err(format!("unknown option {flag}")),
            name if scene.is_none() => scene = Some(name.to_string()),
            extra => return Err(format!("unexpected argument {extra:?}")),
        }
    }
    if let Some(scene) = scene {
        args.scene = scene;
    }
    Ok(args)
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
    let args = match parse_args() {
        Ok(args) => args,
        Err(message) => {
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

//! A scene built in code, rendered as a sequence the way an engine drives the library: one
//! request per frame with the camera (orbiting the scene) and the time, a box moved between
//! frames through its node, each frame saved as a PNG.
//!
//! ```text
//! cargo run --release -p gi-examples --bin sequence -- [--tier auto|reference|direct|path|mobile|pc]
//!     [--frames N] [--width W] [--height H] [--out frames/]
//! ```
//!
//! The scene: a grey courtyard floor between a red and a green wall, under a sun and a blue
//! sky, with a white box (a movable node) sliding across it. The walls bleed their colour onto
//! the floor and the box: the indirect light each GI tier estimates.

use std::{error::Error, path::PathBuf, process::ExitCode, time::Instant};

use clap::Parser;
use gi_scene::{CameraView, Light, LightKind, Node, Scene, Sky};
use gi_tiers::{FrameRequest, Renderer, TierChoice, TierKind};
use glam::{Quat, Vec3};

/// Renders a scene built in code as a PNG sequence.
#[derive(Parser)]
struct Args {
    /// `auto` or a tier name (reference, direct, path, mobile, pc).
    #[arg(long, default_value = "auto")]
    tier: TierChoice,
    /// Frames to render.
    #[arg(long, default_value_t = 8)]
    frames: u32,
    #[arg(long, default_value_t = 320)]
    width: u32,
    #[arg(long, default_value_t = 180)]
    height: u32,
    /// Folder the frames are written to (`frame-000.png`, ...).
    #[arg(long, default_value = "frames")]
    out: PathBuf,
}

/// A Lambert parallelogram `center +- u +- v` of `color`, under `parent`; returns its node.
fn panel(scene: &mut Scene, center: Vec3, u: Vec3, v: Vec3, color: Vec3, parent: Option<usize>) {
    let node = scene.add_diffuse_quad(center, u, v, 1.0);
    let material = scene.materials.last_mut().expect("the panel's material");
    material.base_color = color.extend(1.0);
    material.double_sided = true;
    scene.nodes[node].parent = parent;
}

/// The courtyard, and the node of its movable box.
fn courtyard() -> (Scene, usize) {
    let mut scene = Scene {
        name: "courtyard".into(),
        sky: Sky::Constant {
            radiance: Vec3::new(0.35, 0.5, 0.8),
        },
        exposure: 1.0,
        ..Default::default()
    };
    let grey = Vec3::splat(0.6);
    panel(
        &mut scene,
        Vec3::ZERO,
        Vec3::X * 4.0,
        Vec3::NEG_Z * 4.0,
        grey,
        None,
    );
    let red = Vec3::new(0.8, 0.1, 0.08);
    let green = Vec3::new(0.1, 0.7, 0.12);
    panel(
        &mut scene,
        Vec3::new(-4.0, 2.0, 0.0),
        Vec3::Z * 4.0,
        Vec3::Y * 2.0,
        red,
        None,
    );
    panel(
        &mut scene,
        Vec3::new(4.0, 2.0, 0.0),
        Vec3::NEG_Z * 4.0,
        Vec3::Y * 2.0,
        green,
        None,
    );
    // The box: a movable node with its six faces as children.
    scene.nodes.push(Node {
        name: "box".into(),
        translation: Vec3::new(-1.5, 0.0, 0.0),
        movable: true,
        ..Node::default()
    });
    let box_node = scene.nodes.len() - 1;
    let white = Vec3::splat(0.85);
    let h = 0.6;
    for (axis, up) in [(Vec3::X, Vec3::Y), (Vec3::Y, Vec3::Z), (Vec3::Z, Vec3::X)] {
        for side in [-1.0, 1.0] {
            let normal = axis * side;
            let u = up * h;
            let v = normal.cross(u);
            panel(
                &mut scene,
                Vec3::Y * h + normal * h,
                u,
                v,
                white,
                Some(box_node),
            );
        }
    }
    scene.lights.push(Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: Vec3::new(1.0, 0.95, 0.85),
        intensity: 4.0,
        range: None,
    });
    scene.nodes.push(Node {
        name: "sun".into(),
        light: Some(0),
        rotation: Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.9),
        ..Node::default()
    });
    (scene, box_node)
}

fn run(args: &Args) -> Result<(), Box<dyn Error>> {
    let (scene, box_node) = courtyard();
    let exposure = scene.exposure;
    let mut renderer = Renderer::builder(scene)
        .tier(args.tier)
        .size(args.width, args.height)
        .build()?;
    match renderer.selection() {
        Some(selection) => println!("tier: {} ({})", selection.chosen, selection.reason),
        None => println!("tier: {}", renderer.tier()),
    }
    std::fs::create_dir_all(&args.out)?;
    let frames = args.frames.max(1);
    for frame in 0..frames {
        let t = frame as f32 / frames as f32;
        let angle = std::f32::consts::FRAC_PI_4 * (t - 0.5);
        let eye = Vec3::new(9.0 * angle.sin(), 4.0, 9.0 * angle.cos());
        let camera = CameraView::look_at(eye, Vec3::new(0.0, 0.8, 0.0), 0.8);
        let slide = Vec3::new(-1.5 + 3.0 * t, 0.0, 0.0);
        renderer.set_node_transform(box_node, slide, Quat::from_rotation_y(t), Vec3::ONE)?;
        let started = Instant::now();
        let request = FrameRequest::at(t).with_camera(camera);
        let output = renderer.render(&request)?;
        let path = args.out.join(format!("frame-{frame:03}.png"));
        gi_image::save(&output.image, &path, exposure)?;
        let mut passes = output.passes.clone();
        passes.sort_by(|a, b| b.1.total_cmp(&a.1));
        let dearest: Vec<String> = passes
            .iter()
            .take(3)
            .map(|(name, ms)| format!("{name} {ms:.3}"))
            .collect();
        println!(
            "{}: {:.1} ms on the clock, {:.3} ms of passes (dearest: {})",
            path.display(),
            started.elapsed().as_secs_f64() * 1e3,
            output.ms_total(),
            dearest.join(", ")
        );
    }
    if renderer.tier() != TierKind::Reference {
        println!(
            "memory: {:.2} MiB",
            renderer.memory_bytes() as f64 / (1024.0 * 1024.0)
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    if let Err(error) = run(&Args::parse()) {
        eprintln!("error: {error}");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

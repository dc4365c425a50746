//! The Renderer facade and the CPU tiers behind it.

use gi_reference::{Mode, Reference, RenderSettings};
use gi_tiers::{CameraMode, Renderer, TierChoice, TierError, TierKind, TierSettings};

const SETTINGS: TierSettings = TierSettings {
    width: 24,
    height: 16,
    spp: 2,
    seed: 7,
};

fn renderer(scene: &str, kind: TierKind) -> Renderer {
    let scene = gi_scene::load(scene).unwrap();
    Renderer::new(scene, TierChoice::Tier(kind), SETTINGS, CameraMode::Default).unwrap()
}

#[test]
fn direct_tier_renders_exactly_what_the_reference_crate_renders() {
    let mut renderer = renderer("glossy", TierKind::Direct);
    let output = renderer.render_frame(None).unwrap();
    let scene = renderer.scene();
    let reference = Reference::new(scene, scene.evaluate(0.0, None));
    let expected = reference
        .render(
            &RenderSettings {
                width: SETTINGS.width,
                height: SETTINGS.height,
                spp: SETTINGS.spp,
                seed: SETTINGS.seed,
                mode: Mode::Direct,
                ..RenderSettings::default()
            },
            &|_| {},
        )
        .unwrap();
    // On a hardware GPU the direct tier runs there (tests/path.rs bounds its f32 rounding);
    // on the CPU it is the reference crate itself, bit for bit.
    let on_gpu = output
        .passes
        .iter()
        .any(|(name, _)| name == "direct/resolve");
    if on_gpu {
        let sum = |pixels: &[glam::Vec3]| pixels.iter().sum::<glam::Vec3>();
        let (gpu, cpu) = (sum(&output.image.pixels), sum(&expected.image.pixels));
        assert!((gpu - cpu).abs().max_element() <= 1e-3 * cpu.abs().max_element().max(1.0));
    } else {
        assert_eq!(output.image.pixels, expected.image.pixels);
    }
    assert!(output.passes.iter().any(|(name, _)| name == "direct/trace"));
    assert!(renderer.memory_bytes() > 0);
}

#[test]
fn static_scenes_prepare_once_and_animated_scenes_every_frame() {
    let prepares = |outputs: &[gi_tiers::FrameOutput]| -> Vec<bool> {
        outputs
            .iter()
            .map(|o| o.passes.iter().any(|(name, _)| name == "scene/prepare"))
            .collect()
    };
    let mut still = renderer("cornell-box", TierKind::Direct);
    let outputs: Vec<_> = (0..2).map(|_| still.render_frame(None).unwrap()).collect();
    assert_eq!(prepares(&outputs), [true, false]);
    assert_eq!(outputs[0].image.pixels, outputs[1].image.pixels);

    let mut moving = renderer("dynamic", TierKind::Direct);
    let outputs: Vec<_> = (0..2).map(|_| moving.render_frame(None).unwrap()).collect();
    assert_eq!(prepares(&outputs), [true, true]);
    // The light moves between frames, so the direct image changes.
    assert_ne!(outputs[0].image.pixels, outputs[1].image.pixels);
}

#[test]
fn render_frames_measures_the_last_frame() {
    let mut skipped = renderer("dynamic", TierKind::Direct);
    let last = skipped.render_frames(5, None).unwrap();
    assert_eq!(skipped.next_frame(), 5);

    let mut stepped = renderer("dynamic", TierKind::Direct);
    for _ in 0..4 {
        stepped.render_frame(None).unwrap();
    }
    let fifth = stepped.render_frame(None).unwrap();
    assert_eq!(last.image.pixels, fifth.image.pixels);
}

#[test]
fn camera_path_mode_follows_the_path() {
    let scene = gi_scene::load("atrium").unwrap();
    let renderer = Renderer::new(scene, TierChoice::Auto, SETTINGS, CameraMode::Path).unwrap();
    let path = renderer
        .scene()
        .camera_path
        .clone()
        .expect("atrium has a path");
    let late = path.keys.last().unwrap().time_s;
    let late_frame = (late / renderer.scene().frame_time_s) as u32;
    assert_eq!(renderer.view(0), path.view(0.0));
    assert_ne!(renderer.view(0), renderer.view(late_frame));
}

#[test]
fn unknown_unbuilt_and_invalid_requests_are_errors() {
    let err = "ultra".parse::<TierKind>().unwrap_err().to_string();
    assert!(err.contains("ultra") && err.contains("reference") && err.contains("direct"));
    // The path tier's choices are tested with the GPU tiers (tests/path.rs).
    for choice in [TierChoice::Mobile, TierChoice::Pc] {
        let scene = gi_scene::load("cornell-box").unwrap();
        let result = Renderer::new(scene, choice, SETTINGS, CameraMode::Default);
        assert!(matches!(result, Err(TierError::Unavailable { .. })));
    }
    let scene = gi_scene::load("cornell-box").unwrap();
    let zero = TierSettings {
        width: 0,
        ..SETTINGS
    };
    let result = Renderer::new(scene, TierChoice::Auto, zero, CameraMode::Default);
    assert!(matches!(result, Err(TierError::Render(_))));
}

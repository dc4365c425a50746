//! The Renderer facade and the CPU tiers behind it.

use gi_reference::{Mode, Reference, RenderSettings};
use gi_tiers::{
    CameraMode, CpuTier, MobileConfig, MobileTier, PcConfig, PcTier, Renderer, Tier, TierChoice,
    TierError, TierKind, TierSettings,
};

const SETTINGS: TierSettings = TierSettings {
    width: 24,
    height: 16,
    spp: 2,
    seed: 7,
    textures: gi_tiers::TextureOptions::DEFAULT,
};

/// The GPU tiers' tests: 32 x 24, one sample per pixel.
const GPU_SETTINGS: TierSettings = TierSettings {
    width: 32,
    height: 24,
    spp: 1,
    seed: 7,
    textures: gi_tiers::TextureOptions::DEFAULT,
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
    // On a hardware GPU the direct tier runs there (tests/path.rs bounds its f32 rounding
    // against the reference pixel by pixel, on any adapter); without one (no adapter, or only
    // a software one such as lavapipe, slower than the CPU) it is the reference crate itself,
    // bit for bit. The renderer must have chosen by that rule.
    let on_gpu = output
        .passes
        .iter()
        .any(|(name, _)| name == "direct/resolve");
    let hardware = gi_gpu::GpuContext::new()
        .is_ok_and(|ctx| ctx.adapter_info.device_type != gi_gpu::wgpu::DeviceType::Cpu);
    assert_eq!(
        on_gpu, hardware,
        "the direct tier ran on the wrong processor"
    );
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
fn unknown_and_invalid_requests_are_errors() {
    let err = "ultra".parse::<TierKind>().unwrap_err().to_string();
    assert!(err.contains("ultra") && err.contains("reference") && err.contains("direct"));
    // The path tier's choices are tested with the GPU tiers (tests/path.rs).
    // The mobile and PC tiers need a Vulkan adapter, and say so without one.
    for (choice, kind) in [
        (TierChoice::Tier(TierKind::Mobile), TierKind::Mobile),
        (TierChoice::Tier(TierKind::Pc), TierKind::Pc),
    ] {
        let scene = gi_scene::load("cornell-box").unwrap();
        match Renderer::new(scene, choice, SETTINGS, CameraMode::Default) {
            Ok(renderer) => assert_eq!(renderer.tier(), kind),
            Err(error) => assert!(
                matches!(error, TierError::Unavailable { tier, .. } if tier == kind.name()),
                "{error}"
            ),
        }
    }
    let scene = gi_scene::load("cornell-box").unwrap();
    let zero = TierSettings {
        width: 0,
        ..SETTINGS
    };
    let result = Renderer::new(scene, TierChoice::Auto, zero, CameraMode::Default);
    assert!(matches!(result, Err(TierError::Render(_))));
}

#[test]
fn default_warm_up_is_for_the_temporal_gpu_tiers_only() {
    for kind in TierKind::ALL {
        let expected = if matches!(kind, TierKind::Mobile | TierKind::Pc) {
            63
        } else {
            0
        };
        assert_eq!(kind.default_warmup(), expected, "{kind}");
    }
}

#[test]
fn tiers_without_history_skip_the_warm_up() {
    for kind in [TierKind::Reference, TierKind::Direct] {
        let mut warmed = renderer("dynamic", kind);
        let calls = std::sync::atomic::AtomicU32::new(0);
        let count = |_| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        };
        warmed.warm_up(5, Some(&count)).unwrap();
        assert_eq!(calls.into_inner(), 0, "{kind} rendered warm-up frames");
        assert_eq!((warmed.next_frame(), warmed.warm_up_frames()), (0, 0));
        let after = warmed.render_frames(3, None).unwrap();
        let plain = renderer("dynamic", kind).render_frames(3, None).unwrap();
        assert_eq!(after.image.pixels, plain.image.pixels, "{kind}");
        assert_eq!(warmed.next_frame(), 3);
    }
}

#[test]
fn tier_as_reaches_the_concrete_tier() {
    let direct = renderer("cornell-box", TierKind::Reference);
    assert!(direct.tier_as::<CpuTier>().is_some());
    assert!(direct.tier_as::<MobileTier>().is_none());
}

#[test]
fn mobile_warm_up_renders_still_frames_without_advancing_the_frame_counter() {
    let Some(ctx) = gi_gpu::GpuContext::new_or_skip("mobile_warm_up_renders_still_frames") else {
        return;
    };
    let settings = GPU_SETTINGS;
    let tier = MobileTier::new(settings, MobileConfig::default(), ctx).unwrap();
    let scene = gi_scene::load("dynamic").unwrap();
    let mut renderer = Renderer::with_tier(scene, Box::new(tier), CameraMode::Default);
    let done = std::sync::Mutex::new(Vec::new());
    let record = |n| done.lock().unwrap().push(n);
    renderer.warm_up(3, Some(&record)).unwrap();
    assert_eq!(done.into_inner().unwrap(), [1, 2, 3]);
    assert_eq!((renderer.next_frame(), renderer.warm_up_frames()), (0, 3));
    let mobile = renderer.tier_as::<MobileTier>().expect("the mobile tier");
    let data = mobile.frame_data().expect("frame data after the warm-up");
    assert_eq!((data.gi.width, data.gi.height), (32, 24));
    assert_eq!(data.dynamic.len(), 32 * 24);
    // The measured frames start at frame 0: the warm-up showed it but did not count it.
    let frame = renderer.render_frames(2, None).unwrap();
    assert_eq!(renderer.next_frame(), 2);
    assert_eq!((frame.image.width, frame.image.height), (32, 24));
    assert!(
        frame
            .passes
            .iter()
            .any(|(name, _)| name.starts_with("mobile/"))
    );
}

/// Frames submitted without waiting for the GPU leave a tier as frames advanced one by one
/// do: the same image after them, bit for bit, and every frame's passes reported once, in
/// order, never more than `FRAMES_IN_FLIGHT` frames late.
#[test]
fn submitted_frames_render_as_advanced_frames_and_report_each_frame_once() {
    if gi_gpu::GpuContext::new_or_skip("submitted_frames_render_as_advanced_frames").is_none() {
        return;
    }
    let settings = GPU_SETTINGS;
    // The animated scene re-voxelizes its moving objects and moves its light every frame. The
    // cache relights 16 bricks a frame, which keeps every pass running at a fraction of the
    // default's cost on a software adapter.
    let tier = |kind: TierKind| -> Box<dyn Tier> {
        let ctx = gi_gpu::GpuContext::new().unwrap();
        match kind {
            TierKind::Mobile => {
                let mut config = MobileConfig::default();
                config.cache.settle_bricks_per_frame = 0;
                config.cache.light_bricks_per_frame = 16;
                Box::new(MobileTier::new(settings, config, ctx).unwrap())
            }
            _ => {
                let mut config = PcConfig::default();
                config.cache.settle_bricks_per_frame = 0;
                config.cache.light_bricks_per_frame = 16;
                Box::new(PcTier::new(settings, config, ctx).unwrap())
            }
        }
    };
    let renderer = |kind| {
        let scene = gi_scene::load("dynamic").unwrap();
        Renderer::with_tier(scene, tier(kind), CameraMode::Default)
    };
    let frames = 5;
    for kind in [TierKind::Mobile, TierKind::Pc] {
        let mut advanced = renderer(kind);
        let names = |passes: &[(String, f64)]| -> Vec<String> {
            passes.iter().map(|(name, _)| name.clone()).collect()
        };
        let expected: Vec<Vec<String>> = (0..frames)
            .map(|_| names(&advanced.advance_frame(None).unwrap()))
            .collect();
        let advanced_image = advanced.render_frame(None).unwrap().image;

        let mut submitted = renderer(kind);
        let mut reported = Vec::new();
        for frame in 0..frames {
            reported.extend(submitted.submit_frame(None).unwrap());
            assert!(
                reported.len() + gi_gpu::FRAMES_IN_FLIGHT > frame,
                "{kind}: {} frames reported after submitting frame {frame}",
                reported.len()
            );
        }
        reported.extend(submitted.flush_frames());
        assert!(submitted.flush_frames().is_empty(), "{kind}: flushed twice");
        let submitted_image = submitted.render_frame(None).unwrap().image;

        let indices: Vec<u32> = reported.iter().map(|f| f.index).collect();
        assert_eq!(indices, (0..frames as u32).collect::<Vec<_>>(), "{kind}");
        for (frame, expected) in reported.iter().zip(&expected) {
            assert_eq!(
                &names(&frame.passes),
                expected,
                "{kind} frame {}",
                frame.index
            );
            assert!(
                frame
                    .passes
                    .iter()
                    .all(|(_, ms)| ms.is_finite() && *ms >= 0.0),
                "{kind} frame {}: {:?}",
                frame.index,
                frame.passes
            );
        }
        assert!(
            submitted_image.pixels == advanced_image.pixels,
            "{kind}: the image after submitted frames differs from the one after advanced frames"
        );
    }
}

#[test]
fn path_warm_up_adds_samples_to_the_still_view() {
    if gi_gpu::GpuContext::new_or_skip("path_warm_up_adds_samples").is_none() {
        return;
    }
    let scene = gi_scene::load("cornell-box").unwrap();
    let mut renderer = Renderer::new(
        scene,
        TierChoice::Tier(TierKind::Path),
        SETTINGS,
        CameraMode::Default,
    )
    .expect("a path tier on the adapter");
    renderer.warm_up(2, None).unwrap();
    let samples = std::sync::atomic::AtomicU32::new(0);
    let record = |n| samples.store(n, std::sync::atomic::Ordering::Relaxed);
    renderer.render_frame(Some(&record)).unwrap();
    // Two warm-up frames and the measured one accumulate on the same view.
    assert_eq!(samples.into_inner(), 3 * SETTINGS.spp);
    assert_eq!(renderer.next_frame(), 1);
}

#[test]
fn the_mobile_gi_cost_counts_cache_and_mobile_passes_only() {
    let frame = gi_tiers::FrameOutput {
        image: gi_image::Image::new(1, 1),
        passes: [
            ("gbuffer/primary", 1.0),
            ("cache/inject", 2.0),
            ("direct/shadow", 4.0),
            ("mobile/trace", 8.0),
            ("mobile/upsample", 16.0),
            ("cachex/other", 32.0),
        ]
        .map(|(name, ms)| (name.to_string(), ms))
        .to_vec(),
        stats: None,
    };
    assert_eq!(frame.gi_ms(TierKind::Mobile), 26.0);
    assert_eq!(frame.ms_total(), 63.0);
    for kind in [TierKind::Reference, TierKind::Direct, TierKind::Path] {
        assert_eq!(frame.gi_ms(kind), 0.0, "{kind}");
    }
}

/// A tier that renders nothing and keeps a description of every frame it was given.
struct Recorder {
    frames: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
}

impl gi_tiers::Tier for Recorder {
    fn kind(&self) -> TierKind {
        TierKind::Direct
    }

    fn is_temporal(&self) -> bool {
        true
    }

    fn render(&mut self, input: &gi_tiers::FrameInput) -> Result<gi_tiers::FrameOutput, TierError> {
        self.frames
            .lock()
            .unwrap()
            .push(frame_contents(input.frame));
        Ok(gi_tiers::FrameOutput {
            image: gi_image::Image::new(1, 1),
            passes: Vec::new(),
            stats: None,
        })
    }

    fn memory_bytes(&self) -> u64 {
        0
    }
}

/// Every frame the renderer hands a tier is the scene evaluated at that frame's time through
/// that frame's camera, whether it evaluated it afresh (an animated scene) or reused the last
/// evaluation of a scene without animation with a new time and camera; an edit through
/// `scene_mut` reaches the next frame.
#[test]
fn each_frame_is_the_scene_at_its_time_and_camera() {
    // A scene with no camera node and no animation: its default view frames its bounds.
    let mut camera_less = gi_scene::Scene {
        frame_time_s: 1.0 / 30.0,
        ..gi_scene::Scene::default()
    };
    camera_less.add_diffuse_quad(glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Z, 0.5);
    camera_less.lights.push(gi_scene::Light {
        name: "bulb".into(),
        kind: gi_scene::LightKind::Point,
        color: glam::Vec3::ONE,
        intensity: 10.0,
        range: None,
    });
    camera_less.nodes.push(gi_scene::Node {
        light: Some(0),
        translation: glam::Vec3::Y,
        ..gi_scene::Node::default()
    });
    // Frames are compared by what they hold (every evaluation draws a new geometry revision).
    for (name, mode) in [
        ("atrium", CameraMode::Path),
        ("dynamic", CameraMode::Path),
        ("camera-less", CameraMode::Default),
    ] {
        let scene = match name {
            "camera-less" => camera_less.clone(),
            _ => gi_scene::load(name).unwrap(),
        };
        let frames = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let recorder = Recorder {
            frames: frames.clone(),
        };
        let mut renderer = Renderer::with_tier(scene, Box::new(recorder), mode);
        let expected = |renderer: &Renderer, index: u32| {
            let scene = renderer.scene();
            let time = scene.frame_time(index);
            let view = match mode {
                CameraMode::Path => scene.path_view(time),
                CameraMode::Default => scene.default_view(time),
            };
            frame_contents(&scene.evaluate(time, Some(view)))
        };
        let mut wanted = Vec::new();
        for index in 0..3 {
            wanted.push(expected(&renderer, index));
            renderer.advance_frame(None).unwrap();
        }
        renderer.warm_up_frame().unwrap();
        wanted.push(expected(&renderer, 3));
        // Brighten the first light between frames.
        renderer.scene_mut().lights[0].intensity *= 2.0;
        wanted.push(expected(&renderer, 3));
        renderer.render_frame(None).unwrap();
        let got = frames.lock().unwrap().clone();
        assert_eq!(got.len(), wanted.len(), "{name}");
        for (index, (got, wanted)) in got.iter().zip(&wanted).enumerate() {
            assert!(
                got == wanted,
                "{name}: frame {index} differs from its evaluation"
            );
        }
        // The camera moves along the path (and the time), so the frames differ.
        assert_ne!(got[0], got[1], "{name}");
        assert_ne!(got[3], got[4], "{name}: the edit did not reach the frame");
    }
}

/// Everything a frame holds but its geometry revision, which names an evaluation rather than
/// its contents.
fn frame_contents(frame: &gi_scene::SceneFrame) -> String {
    let mut frame = frame.clone();
    frame.geometry_revision = 0;
    format!("{frame:?}")
}

/// A scene without a camera node is framed once, from its bounds at time 0: an animation that
/// moves its bounds later does not move the camera (framing them every frame was a pass over
/// every vertex per frame), and an edit through `scene_mut` frames it again.
#[test]
fn a_scene_without_a_camera_is_framed_once() {
    let scene = gi_scene::generate::skinned_tube(8, 6);
    assert!(scene.default_camera_node.is_none() && scene.is_animated());
    let bent = scene.frame_time(30);
    assert_ne!(
        scene.default_view(0.0),
        scene.default_view(bent),
        "the bounds move"
    );
    let frames = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let recorder = Recorder { frames };
    let mut renderer = Renderer::with_tier(scene, Box::new(recorder), CameraMode::Default);
    let framing = renderer.scene().default_view(0.0);
    assert_eq!(renderer.view(30), framing);
    // Moved by an edit, the scene is framed again from its new bounds.
    for node in &mut renderer.scene_mut().nodes {
        node.translation += glam::Vec3::new(0.0, 0.0, -4.0);
    }
    renderer.render_frame(None).unwrap();
    let moved = renderer.scene().default_view(0.0);
    assert_ne!(moved, framing);
    assert_eq!(renderer.view(30), moved);
}

/// Mean of every channel of every pixel.
fn image_mean(image: &gi_image::Image) -> f64 {
    let sum: f64 = (image.pixels.iter())
        .map(|p| f64::from(p.x + p.y + p.z))
        .sum();
    sum / (3 * image.pixels.len()) as f64
}

/// cornell-box's light panel, its only light, switched off with `Renderer::set_material`: the
/// path tracers' next frame is black to the bit; the real-time tiers' image fades within a few
/// frames and stays dark (the material and emitter tables are uploaded again, the cache voxelizes
/// the panel again and follows the change as a light's, and the mobile tier's gather leaves its
/// probe volume, which still holds the old light, until the cache has converged). Before this,
/// the mobile tier kept 43% of its light 4 frames after and 32% 16 frames after; the bounds
/// leave room for another adapter's rounding around today's 9% and 1%. Edits the renderer
/// cannot take are refused.
#[test]
fn a_light_panel_switched_off_goes_dark_in_every_tier() {
    if gi_gpu::GpuContext::new_or_skip("a_light_panel_switched_off_goes_dark").is_none() {
        return;
    }
    let scene = gi_scene::load("cornell-box").unwrap();
    let light = (scene.materials.iter())
        .position(|m| m.emissive != glam::Vec3::ZERO)
        .expect("cornell-box has an emitter");
    let mut off = scene.materials[light].clone();
    off.emissive = glam::Vec3::ZERO;
    let tier = |kind: TierKind| -> Box<dyn Tier> {
        let ctx = || gi_gpu::GpuContext::new().unwrap();
        match kind {
            TierKind::Path => {
                Box::new(gi_tiers::GpuPathTier::new(kind, GPU_SETTINGS, ctx()).unwrap())
            }
            TierKind::Mobile => {
                Box::new(MobileTier::new(GPU_SETTINGS, MobileConfig::default(), ctx()).unwrap())
            }
            TierKind::Pc => {
                Box::new(PcTier::new(GPU_SETTINGS, PcConfig::default(), ctx()).unwrap())
            }
            _ => Box::new(CpuTier::new(kind, SETTINGS).unwrap()),
        }
    };
    for kind in [
        TierKind::Reference,
        TierKind::Path,
        TierKind::Mobile,
        TierKind::Pc,
    ] {
        let mut renderer = Renderer::with_tier(scene.clone(), tier(kind), CameraMode::Default);
        let before = image_mean(&renderer.render_frames(24, None).unwrap().image);
        assert!(before > 0.01, "{kind}: {before}");
        let mut blended = off.clone();
        blended.alpha_mode = gi_scene::AlphaMode::Blend;
        for error in [
            renderer.set_material(light, blended).unwrap_err(),
            renderer
                .set_material(scene.materials.len(), off.clone())
                .unwrap_err(),
        ] {
            assert!(matches!(error, TierError::InvalidRequest(_)), "{error}");
        }
        renderer.set_material(light, off.clone()).unwrap();
        if matches!(kind, TierKind::Reference | TierKind::Path) {
            let image = renderer.render_frame(None).unwrap().image;
            assert!(
                image.pixels.iter().all(|&p| p == glam::Vec3::ZERO),
                "{kind}: light without a light"
            );
            continue;
        }
        // Past the cache's converging updates (its `max_age`, 32) the mobile tier reads its
        // volume again.
        let left: Vec<f64> = (0..48)
            .map(|_| image_mean(&renderer.render_frame(None).unwrap().image) / before)
            .collect();
        println!("{kind}: {before:.4} before, then {left:.4?} of it");
        assert!(
            left[3] <= 0.25,
            "{kind}: {:.3} left after 4 frames",
            left[3]
        );
        let late = left[15..].iter().copied().fold(0.0, f64::max);
        assert!(late <= 0.03, "{kind}: {late:.4} left 16 to 48 frames after");
    }
}

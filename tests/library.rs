//! The library as an engine programmer uses it, end to end: a scene built in code is written
//! as glTF (with its texture as a PNG beside it) into a temporary folder and imported from
//! disk; a [`Renderer`] made with [`Renderer::builder`], once with `auto` and once with the GPU
//! `path` tier on the caller's device, renders frames through a moving camera
//! ([`FrameRequest`]), then a frame after a node was moved and a light edited; every frame is
//! read back and checked against the CPU reference's render of the same frame.
//!
//! The check splits the error into bias and noise as `golden.rs` does, with four independent
//! renders of each frame: the tier's with seeds 1 and 2 (`a`, `b`) and the reference's with
//! seeds 3 and 4 (`r`, `s`). Per pixel and channel (linear radiance times exposure),
//! `(a - r)(b - s)` has exactly the squared bias as its expectation (the four are
//! independent), and `(a - b)^2 / 2` and `(r - s)^2 / 2` the two renders' variances. The
//! means over the image and their standard errors, measured from the spread of the terms,
//! give the bounds: an unbiased tier may show no squared bias beyond five standard errors,
//! and its variance per sample must equal the reference's within five standard errors (the
//! GPU path tier draws the reference's random numbers, so it is the same estimator). The same
//! bias estimate against references of the frame without the node's move, and without the
//! light's edit, and against the previous camera's reference for the moving frames, must exceed
//! twice its bound: the tolerance can tell a lost edit or a camera that did not move.

mod common;

use std::path::{Path, PathBuf};

use common::{PANEL, SUN};
use gi_gpu::GpuContext;
use gi_image::Image;
use gi_reference::{Mode, Reference, RenderSettings};
use gi_scene::{CameraView, Scene};
use gi_tiers::{
    FrameRequest, Renderer, TierChoice, TierKind, TierSettings,
    select::{self, AdapterDescription},
};
use glam::{Quat, Vec3};

const SIZE: (u32, u32) = (32, 24);
/// Samples per pixel of the tier's frame.
const SPP: u32 = 16;
/// Samples per pixel of each reference render: more than the tier's, so the reference's noise
/// takes a smaller share of the bound.
const REFERENCE_SPP: u32 = 64;
/// Frames through the moving camera before the checked one.
const MOVING_FRAMES: u32 = 3;
/// Seeds of the tier's two renders and of the reference's two.
const TIER_SEEDS: [u64; 2] = [1, 2];
const REFERENCE_SEEDS: [u64; 2] = [3, 4];
/// The sun after its edit: brighter and warmer.
const SUN_INTENSITY: f32 = 3.5;
const SUN_COLOR: Vec3 = Vec3::new(1.0, 0.7, 0.4);
/// How many standard errors the estimates may stray.
const STANDARD_ERRORS: f64 = 5.0;

/// Where the panel goes before the last frame: to the right and back, turned towards the sun.
fn panel_moved() -> (Vec3, Quat) {
    (Vec3::new(1.2, 0.0, -1.0), Quat::from_rotation_y(0.8))
}

/// The camera of frame `frame`: around the yard in steps of 0.25 rad, at the yard's height.
fn orbit(frame: u32) -> CameraView {
    let angle = 0.25 * frame as f32;
    let position = Vec3::new(5.0 * angle.sin(), 2.0, 5.0 * angle.cos());
    CameraView::look_at(position, Vec3::new(0.0, 0.5, 0.0), 0.9)
}

/// The request of frame `frame`: the scene at its time through [`orbit`].
fn request(frame: u32) -> FrameRequest {
    FrameRequest::at(frame as f32 / 60.0).with_camera(orbit(frame))
}

/// The yard as imported from its glTF file, with what the flow changes in it.
struct Imported {
    /// Holds the files until the test ends.
    _dir: tempfile::TempDir,
    scene: Scene,
    panel: usize,
    sun: usize,
}

/// Writes the yard into a temporary folder and imports it from there, as an engine loads an
/// asset; marks its panel movable (not part of glTF: the engine knows what it moves).
fn import_yard() -> Imported {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("yard.gltf");
    let built = common::yard();
    gi_scene::write_gltf(&built, &path).expect("the yard exports");
    for file in ["yard.bin", "yard_0.png"] {
        assert!(
            dir.path().join(file).is_file(),
            "the export wrote no {file}"
        );
    }
    let (mut scene, warnings) = gi_scene::import_gltf(&path).expect("the yard imports");
    assert!(warnings.is_empty(), "{warnings:?}");
    // The texture came back from its PNG, texel for texel, and the ground samples it.
    assert_eq!(scene.textures.len(), 1);
    assert_eq!(scene.textures[0].texels, built.textures[0].texels);
    assert_eq!(scene.textures[0].encoding, built.textures[0].encoding);
    assert!(
        scene
            .materials
            .iter()
            .any(|m| m.base_color_texture.is_some())
    );
    assert_eq!(scene.exposure, common::EXPOSURE);
    let panel = common::node(&scene, PANEL);
    scene.nodes[panel].movable = true;
    let sun = (scene.lights.iter().position(|l| l.name == SUN)).expect("the sun imports");
    Imported {
        _dir: dir,
        scene,
        panel,
        sun,
    }
}

/// The flow's frames on `renderer`, each read back: the moving camera's, then, after the
/// panel was moved and the sun edited, the last.
fn run_flow(renderer: &mut Renderer, imported: &Imported) -> Vec<Image> {
    let tier = renderer.tier();
    let mut frames = Vec::new();
    for frame in 0..=MOVING_FRAMES {
        if frame == MOVING_FRAMES {
            let (translation, rotation) = panel_moved();
            (renderer.set_node_transform(imported.panel, translation, rotation, Vec3::ONE))
                .unwrap_or_else(|e| panic!("{tier}: {e}"));
            let sun = renderer.light_mut(imported.sun).expect("the sun");
            sun.intensity = SUN_INTENSITY;
            sun.color = SUN_COLOR;
        }
        let output = (renderer.render(&request(frame))).unwrap_or_else(|e| panic!("{tier}: {e}"));
        check_frame(&output.image, &format!("{tier} frame {frame}"));
        frames.push(output.image);
    }
    assert_eq!(renderer.next_frame(), MOVING_FRAMES + 1);
    frames
}

/// The frame has the requested size and finite, non-negative radiance, and is not black.
fn check_frame(image: &Image, what: &str) {
    assert_eq!(image.size(), SIZE, "{what}");
    assert!(image.is_finite(), "{what}: not finite");
    let all = image.pixels.iter().flat_map(|p| p.to_array());
    assert!(all.clone().all(|c| c >= 0.0), "{what}: negative radiance");
    assert!(all.fold(0.0f32, f32::max) > 0.05, "{what}: black");
}

/// The CPU reference's two renders of frame `frame` of `scene` (its time, [`orbit`]'s camera).
fn references(scene: &Scene, frame: u32) -> [Image; 2] {
    let evaluated = scene.evaluate(frame as f32 / 60.0, Some(orbit(frame)));
    let reference = Reference::new(scene, evaluated);
    REFERENCE_SEEDS.map(|seed| {
        let settings = RenderSettings {
            width: SIZE.0,
            height: SIZE.1,
            spp: REFERENCE_SPP,
            seed,
            mode: Mode::Full,
            ..RenderSettings::default()
        };
        let output = reference.render(&settings, &|_| {});
        output.expect("the reference renders").image
    })
}

/// The imported scene with the flow's edits made directly, and the two variants that each
/// miss one of them: what the last frame shows, and what it would show if an edit were lost.
fn edited_scenes(imported: &Imported) -> [(&'static str, Scene); 3] {
    let (translation, rotation) = panel_moved();
    let mut edited = imported.scene.clone();
    edited.nodes[imported.panel].translation = translation;
    edited.nodes[imported.panel].rotation = rotation;
    let mut unmoved = edited.clone();
    unmoved.nodes[imported.panel] = imported.scene.nodes[imported.panel].clone();
    edited.lights[imported.sun].intensity = SUN_INTENSITY;
    edited.lights[imported.sun].color = SUN_COLOR;
    let mut unedited = edited.clone();
    unedited.lights[imported.sun] = imported.scene.lights[imported.sun].clone();
    [
        ("edited", edited),
        ("without the node's move", unmoved),
        ("without the light's edit", unedited),
    ]
}

/// A mean over the image's channels and its standard error.
#[derive(Clone, Copy, Debug)]
struct Estimate {
    mean: f64,
    se: f64,
}

fn estimate(terms: &[f64]) -> Estimate {
    let (mean, se) = common::mean_and_se(terms);
    Estimate { mean, se }
}

/// The squared bias between the tier's renders `tier` and the reference's `reference`: the
/// mean of `(a - r)(b - s)`.
fn squared_bias(tier: [&Image; 2], reference: &[Image; 2], exposure: f32) -> Estimate {
    let [a, b] = tier.map(|i| common::channels(i, exposure));
    let [r, s] = reference.each_ref().map(|i| common::channels(i, exposure));
    let terms: Vec<f64> = (0..a.len())
        .map(|i| (a[i] - r[i]) * (b[i] - s[i]))
        .collect();
    estimate(&terms)
}

/// The variance of one render of a pair: the mean of `(a - b)^2 / 2`.
fn variance(pair: [&Image; 2], exposure: f32) -> Estimate {
    let [a, b] = pair.map(|i| common::channels(i, exposure));
    let terms: Vec<f64> = (0..a.len()).map(|i| (a[i] - b[i]).powi(2) / 2.0).collect();
    estimate(&terms)
}

/// Writes the tier's frame, the reference's and their heat map into the target's temporary
/// folder; returns their common path without extension.
fn write_failure(what: &str, render: &Image, reference: &Image, exposure: f32) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("library-failures");
    std::fs::create_dir_all(&dir).expect("the target folder is writable");
    let name: String = (what.chars())
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    let base = dir.join(name);
    gi_image::save(render, base.with_extension("actual.png"), exposure).expect("saves");
    gi_image::save(reference, base.with_extension("reference.png"), exposure).expect("saves");
    gi_image::write_error_heatmap(render, reference, exposure, base.with_extension("diff.png"))
        .expect("the heat map saves");
    base
}

/// Checks the tier's renders `tier` of a frame against the reference's `reference` of the
/// same frame: no squared bias beyond its bound, the same variance per sample.
fn check_against_reference(what: &str, tier: [&Image; 2], reference: &[Image; 2], exposure: f32) {
    let bias = squared_bias(tier, reference, exposure);
    let bias_bound = STANDARD_ERRORS * bias.se;
    // Per sample: a render's variance falls as 1 / spp.
    let tier_noise = variance(tier, exposure);
    let reference_noise = variance(reference.each_ref(), exposure);
    let (spp, reference_spp) = (f64::from(SPP), f64::from(REFERENCE_SPP));
    let noise_gap = tier_noise.mean * spp - reference_noise.mean * reference_spp;
    let noise_bound =
        STANDARD_ERRORS * (tier_noise.se * spp).hypot(reference_noise.se * reference_spp);
    let report = format!(
        "{what}: squared bias {:.3e} (bound {bias_bound:.3e}); variance per sample {:.3e}, \
         the reference's {:.3e} (bound on the gap {noise_bound:.3e})",
        bias.mean,
        tier_noise.mean * spp,
        reference_noise.mean * reference_spp,
    );
    println!("{report}");
    if bias.mean > bias_bound || noise_gap.abs() > noise_bound {
        let written = write_failure(what, tier[0], &reference[0], exposure);
        panic!(
            "{report}; render, reference and heat map: {}.*.png",
            written.display()
        );
    }
}

/// Checks that the tier's renders `tier` fail the bias bound against `wrong`, the reference
/// of another frame, by far: the bound tells that frame from the one rendered.
fn check_tells_apart(what: &str, tier: [&Image; 2], wrong: &[Image; 2], exposure: f32) {
    let bias = squared_bias(tier, wrong, exposure);
    println!(
        "{what}: squared bias {:.3e} ({:.0} standard errors)",
        bias.mean,
        bias.mean / bias.se
    );
    assert!(
        bias.mean > 2.0 * STANDARD_ERRORS * bias.se,
        "{what}: squared bias {:.3e}, within twice its bound {:.3e}: the check could not tell \
         these frames apart",
        bias.mean,
        STANDARD_ERRORS * bias.se
    );
}

/// Checks an unbiased tier's frames of the flow, `frames` with seed 1 and with seed 2, as the
/// module docs describe.
fn check_unbiased(frames: &[Vec<Image>; 2], imported: &Imported, what: &str) {
    let exposure = imported.scene.exposure;
    let pair = |frame: u32| frames.each_ref().map(|f| &f[frame as usize]);
    let mut before = None;
    for frame in 0..MOVING_FRAMES {
        let reference = references(&imported.scene, frame);
        let what = format!("{what} frame {frame}");
        check_against_reference(&what, pair(frame), &reference, exposure);
        if let Some(previous) = &before {
            let what = format!("{what} against the previous camera's reference");
            check_tells_apart(&what, pair(frame), previous, exposure);
        }
        before = Some(reference);
    }
    let [(_, edited), lost_move, lost_edit] = edited_scenes(imported);
    let what = format!("{what} last frame");
    let last = pair(MOVING_FRAMES);
    let reference = references(&edited, MOVING_FRAMES);
    check_against_reference(&what, last, &reference, exposure);
    for (name, scene) in [lost_move, lost_edit] {
        let wrong = references(&scene, MOVING_FRAMES);
        check_tells_apart(
            &format!("{what} against the reference {name}"),
            last,
            &wrong,
            exposure,
        );
    }
}

/// The settings both renderers are built with, as `select::plan` reads them.
fn settings(seed: u64) -> TierSettings {
    TierSettings {
        width: SIZE.0,
        height: SIZE.1,
        spp: SPP,
        seed,
        textures: gi_tiers::TextureOptions::DEFAULT,
    }
}

#[test]
fn auto_renders_an_imported_scene_through_a_moving_camera_and_edits() {
    // Auto renders with or without an adapter (on the CPU without); what it must choose
    // depends on the adapter.
    let adapter = GpuContext::new_or_skip("library: auto on a GPU (it plans for the CPU instead)")
        .map(|ctx| AdapterDescription::from_context(&ctx));
    let imported = import_yard();
    let expected = select::plan(adapter.as_ref(), &settings(TIER_SEEDS[0]), None);
    let frames = TIER_SEEDS.map(|seed| {
        let mut renderer = Renderer::builder(imported.scene.clone())
            .tier(TierChoice::Auto)
            .settings(settings(seed))
            .build()
            .expect("auto always finds a tier");
        let selection = renderer.selection().expect("auto says what it chose");
        assert_eq!(selection.chosen, expected.chosen().kind, "{selection:?}");
        assert_eq!(selection.runs_on, expected.chosen().runs_on);
        assert!(selection.fallbacks.is_empty(), "{selection:?}");
        assert_eq!(renderer.tier(), selection.chosen);
        run_flow(&mut renderer, &imported)
    });
    let chosen = expected.chosen().kind;
    match chosen {
        // The CPU reference on a software adapter (lavapipe) or none.
        TierKind::Reference | TierKind::Path => {
            check_unbiased(&frames, &imported, &format!("auto ({chosen})"))
        }
        // A real-time tier on a hardware GPU: its error after a few frames is an
        // approximation's, which the golden tests bound; here the frames only had to render.
        _ => println!("auto chose {chosen}, an approximating tier: frames checked, not its error"),
    }
}

#[test]
fn the_gpu_path_tier_on_the_callers_device_renders_the_reference_frame() {
    let Some(device) = GpuContext::new_or_skip("library: the path tier") else {
        return;
    };
    let imported = import_yard();
    let frames = TIER_SEEDS.map(|seed| {
        let mut renderer = Renderer::builder(imported.scene.clone())
            .tier(TierKind::Path)
            .settings(settings(seed))
            .context(device.share())
            .build()
            .expect("the path tier runs on any adapter");
        assert_eq!(renderer.tier(), TierKind::Path);
        assert!(
            renderer.selection().is_none(),
            "a named tier is not selected"
        );
        let ctx = renderer.context().expect("a GPU tier");
        assert!(ctx.shares_device_with(&device), "not the caller's device");
        run_flow(&mut renderer, &imported)
    });
    check_unbiased(&frames, &imported, "path");
}

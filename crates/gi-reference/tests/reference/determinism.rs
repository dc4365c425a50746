//! Reproducibility, progress reporting, stats and refused settings.

use std::sync::Mutex;

use gi_reference::{MAX_SIDE, Reference, RenderError, RenderSettings, Strategy};
use gi_scene::{CameraView, Primitive, Scene, Sky};
use glam::Vec3;

use crate::common::{SceneBuilder, diffuse, floor, render, settings, showcase};

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
        .install(f)
}

#[test]
fn images_depend_only_on_the_seed() {
    let reference = showcase();
    let s = settings(24, 8, 42, Strategy::Mis);
    let one = in_pool(1, || render(&reference, &s)).image;
    let two = in_pool(2, || render(&reference, &s)).image;
    let again = in_pool(2, || render(&reference, &s)).image;
    assert_eq!(one.pixels, two.pixels);
    assert_eq!(two.pixels, again.pixels);

    // However the samples are split into passes.
    let mut accumulator = reference.accumulator(&s).unwrap();
    for pass in [3, 1, 4] {
        accumulator.add_samples(pass);
    }
    assert_eq!(accumulator.samples_per_pixel(), 8);
    assert_eq!(accumulator.image().pixels, one.pixels);
    let rendered = reference.render(&s, &|_| {}).unwrap();
    assert_eq!(rendered.image.pixels, one.pixels);

    let other = render(&reference, &RenderSettings { seed: 43, ..s }).image;
    let differing = other
        .pixels
        .iter()
        .zip(&one.pixels)
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        differing > one.pixels.len() / 2,
        "only {differing} pixels changed with the seed"
    );
}

#[test]
fn progress_and_stats_are_reported() {
    let reference = showcase();
    let reports = Mutex::new(Vec::new());
    let s = settings(16, 300, 1, Strategy::Mis);
    let output = reference
        .render(&s, &|done| reports.lock().unwrap().push(done))
        .unwrap();
    let reports = reports.into_inner().unwrap();
    assert!(
        reports.len() > 1 && reports.windows(2).all(|w| w[0] < w[1]),
        "{reports:?}"
    );
    assert_eq!(reports.last(), Some(&300));
    let stats = output.stats;
    assert_eq!(stats.samples, 16 * 16 * 300);
    assert!(
        stats.rays > stats.samples,
        "every path traces a camera ray and shadow rays"
    );
    assert!(stats.seconds > 0.0 && stats.samples_per_second > 0.0 && stats.rays_per_second > 0.0);
    assert!(stats.bvh_build_seconds > 0.0);
    assert_eq!(stats.nonfinite_samples, 0);
}

#[test]
fn bad_settings_are_refused() {
    let reference = showcase();
    let good = settings(8, 1, 0, Strategy::Mis);
    let cases = [
        (
            RenderSettings { width: 0, ..good },
            RenderError::EmptyImage {
                width: 0,
                height: 8,
            },
        ),
        (
            RenderSettings { height: 0, ..good },
            RenderError::EmptyImage {
                width: 8,
                height: 0,
            },
        ),
        (
            RenderSettings {
                width: MAX_SIDE + 1,
                ..good
            },
            RenderError::ImageTooLarge {
                width: MAX_SIDE + 1,
                height: 8,
            },
        ),
        (
            RenderSettings {
                width: MAX_SIDE,
                height: MAX_SIDE,
                ..good
            },
            RenderError::ImageTooLarge {
                width: MAX_SIDE,
                height: MAX_SIDE,
            },
        ),
        (RenderSettings { spp: 0, ..good }, RenderError::ZeroSamples),
    ];
    for (bad, error) in cases {
        assert_eq!(reference.render(&bad, &|_| {}).err(), Some(error.clone()));
        assert_eq!(
            reference.accumulator(&bad).err().map(|e| e.to_string()),
            Some(error.to_string())
        );
    }
    assert!(
        RenderSettings {
            width: MAX_SIDE,
            height: 1,
            ..good
        }
        .validate()
        .is_ok()
    );
}

#[test]
fn degenerate_scenes_render_without_panicking() {
    let camera = CameraView::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, 0.8);
    let sky = Sky::Constant {
        radiance: Vec3::splat(0.5),
    };

    // Nothing at all: every pixel is the sky.
    let empty = Scene {
        sky,
        ..Default::default()
    };
    let r = render(
        &Reference::new(&empty, empty.evaluate(0.0, Some(camera))),
        &settings(8, 2, 0, Strategy::Mis),
    );
    assert!(r.image.pixels.iter().all(|p| *p == Vec3::splat(0.5)));

    // A material index out of range (the glTF default material is used), a zero-area triangle
    // and a zero normal.
    let mut builder = SceneBuilder::new(sky);
    builder.add(floor(Vec3::ZERO, 2.0), diffuse(0.5));
    builder.scene.meshes[0].primitives[0].material = 7;
    builder.add(
        Primitive {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            normals: vec![Vec3::ZERO; 3],
            uvs: Vec::new(),
            indices: vec![0, 1, 2],
            material: 0,
            ..Default::default()
        },
        diffuse(0.5),
    );
    let reference = builder.reference(camera);
    for mode in [gi_reference::Mode::Full, gi_reference::Mode::Direct] {
        let r = render(
            &reference,
            &RenderSettings {
                mode,
                ..settings(8, 4, 0, Strategy::Mis)
            },
        );
        assert!(
            r.image
                .pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0)
        );
    }
}

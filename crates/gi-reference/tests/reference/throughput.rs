//! Throughput measurement, run on demand:
//! `cargo test -p gi-reference --release -- --ignored --nocapture throughput`.

use gi_reference::{Mode, Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, Sky};
use glam::Vec3;

use crate::common::{SceneBuilder, emitter, floor, material, quad, render, settings, showcase};

/// Nine smooth spheres of 16k triangles each on a floor, lit by an area light and a sky.
fn spheres() -> Reference {
    let mut builder = SceneBuilder::new(Sky::Gradient {
        zenith: Vec3::new(0.3, 0.4, 0.8),
        horizon: Vec3::new(0.8, 0.8, 0.7),
        ground: Vec3::new(0.2, 0.2, 0.2),
    });
    builder.add(floor(Vec3::ZERO, 4.0), material(Vec3::splat(0.6), 0.0, 0.5));
    for i in 0..9 {
        let center = Vec3::new((i % 3) as f32 - 1.0, 0.3, (i / 3) as f32 - 1.0);
        let m = material(
            Vec3::new(0.9, 0.3 + 0.07 * i as f32, 0.2),
            (i % 2) as f32,
            0.2 + 0.08 * i as f32,
        );
        builder.add(crate::common::sphere(center, 0.3, 128, 64, false), m);
    }
    builder.add(
        quad(Vec3::new(0.0, 2.5, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5),
        emitter(Vec3::splat(10.0), false),
    );
    builder.reference(CameraView::look_at(
        Vec3::new(0.0, 2.0, 3.5),
        Vec3::ZERO,
        0.8,
    ))
}

#[test]
#[ignore = "a measurement, not a check; run in release"]
fn throughput() {
    for (name, reference) in [("showcase", showcase()), ("spheres", spheres())] {
        for (mode, spp) in [(Mode::Full, 64), (Mode::Direct, 16)] {
            let s = RenderSettings {
                mode,
                ..settings(128, spp, 0, Strategy::Mis)
            };
            let stats = render(&reference, &s).stats;
            println!(
                "{name} ({} triangles) {mode:?} 128x128 at {spp} spp on {} threads: {:.3} s, \
                 {:.3e} samples/s, {:.3e} rays/s, {:.2} rays/sample, BVH {:.1e} s",
                reference.frame().triangles.len(),
                rayon::current_num_threads(),
                stats.seconds,
                stats.samples_per_second,
                stats.rays_per_second,
                stats.rays as f64 / stats.samples as f64,
                stats.bvh_build_seconds
            );
        }
    }
}

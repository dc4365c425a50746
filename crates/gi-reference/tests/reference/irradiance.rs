//! `Reference::irradiance`: exact punctual lights plus cosine-sampled full transport, checked
//! against analytic irradiances.

use std::f32::consts::PI;

use gi_scene::{CameraView, LightKind, Sky};
use glam::Vec3;

use crate::common::{K_SIGMA, SceneBuilder, diffuse, emitter, floor, quad};

fn camera() -> CameraView {
    CameraView::look_at(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, 0.8)
}

#[test]
fn punctual_lights_are_exact_and_an_open_sky_gives_pi_l() {
    // A floor under a directional light and a constant sky: every
    // cosine ray from the floor's center escapes, so E = I cos(theta) + pi L with no noise.
    let (intensity, sky) = (2.0, 0.5);
    let mut builder = SceneBuilder::new(Sky::Constant {
        radiance: Vec3::splat(sky),
    });
    builder.add(floor(Vec3::ZERO, 4.0), diffuse(0.5));
    // A low roof far from the origin (seen edge-on from there) shadows the point under it.
    builder.add(
        quad(Vec3::new(30.0, 0.1, 0.0), Vec3::X * 0.6, Vec3::NEG_Z * 0.6),
        diffuse(0.0),
    );
    // No zero component in the direction: the CPU BVH misses occluders for shadow rays whose
    // direction has a -0.0 component, which `-direction` of an axis-aligned light produces.
    let light_dir = Vec3::new(0.3, -1.0, 1.5).normalize();
    let cos_theta = -light_dir.y;
    builder.light(LightKind::Directional, intensity, Vec3::ZERO, light_dir);
    let reference = builder.reference(camera());
    let e = reference.irradiance(Vec3::ZERO, Vec3::Y, 256, 1);
    let expected = intensity * cos_theta + PI * sky;
    println!("open floor: E = {e}, expected {expected}");
    assert!((e - Vec3::splat(expected)).abs().max_element() < 1e-4 * expected);
    // Under the roof the light is blocked; only sky (and the roof's black underside) remains.
    let shadowed = reference.irradiance(Vec3::new(30.0, 0.0, 0.0), Vec3::Y, 0, 1);
    println!("under the roof, punctual only: E = {shadowed}");
    assert_eq!(shadowed, Vec3::ZERO);
}

#[test]
fn an_emissive_rectangle_gives_pi_le_times_its_form_factor() {
    // A point facing a single emissive rectangle (black sky, nothing else that could reflect
    // its light back) receives E = pi Le F, with F the differential-area-to-parallel-rectangle
    // form factor (four corner rectangles of half-sizes a, b at height h). Cosine sampling
    // alone would be a hit-or-miss count of standard error pi Le sqrt(F (1 - F) / N); with
    // emitter sampling and MIS the error is smaller, so that bound is conservative.
    let (le, a, b, h) = (2.0f64, 0.5f64, 0.8f64, 1.0f64);
    let mut builder = SceneBuilder::new(Sky::default());
    let rectangle = quad(
        Vec3::new(0.0, h as f32, 0.0),
        Vec3::X * a as f32,
        Vec3::Z * b as f32,
    );
    builder.add(rectangle, emitter(Vec3::splat(le as f32), false));
    let reference = builder.reference(camera());
    let corner = |x: f64, y: f64| {
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    let form_factor = 4.0 * corner(a / h, b / h);
    let expected = std::f64::consts::PI * le * form_factor;
    let samples = 8192;
    let e = f64::from(reference.irradiance(Vec3::ZERO, Vec3::Y, samples, 7).x);
    let se =
        std::f64::consts::PI * le * (form_factor * (1.0 - form_factor) / f64::from(samples)).sqrt();
    println!("emissive rectangle: E = {e:.4}, expected {expected:.4} +- {se:.4}");
    assert!((e - expected).abs() < K_SIGMA * se);
}

//! `cornell-box`: the Cornell box, from the original measurements.
//!
//! Geometry follows the published Cornell box data (millimeters, a 556 mm room) scaled by
//! 1/278 so the room is about 2 m wide, rotated half a turn about +Y so the camera looks down
//! -Z with the red wall on its left. Colors and the light's radiance are the customary RGB
//! approximations of the measured spectra. All light comes from the emissive ceiling panel:
//! a direct-only render shows nothing but the panel, so every other pixel is global
//! illumination.

use glam::{Vec2, Vec3};

use super::builder::{Parts, SceneBuilder, dielectric, emitter};
use super::shapes::{prism, quad};
use crate::model::{Scene, Sky};

/// Millimeters of the original data to meters of the scene.
const SCALE: f32 = 1.0 / 278.0;
/// Original room: x 0..556 (right to left as seen by the camera), y 0..548.8, z 0..559.2
/// (front to back).
const WIDTH_MM: f32 = 556.0;
const HEIGHT_MM: f32 = 548.8;
const DEPTH_MM: f32 = 559.2;

/// A point of the original data in scene coordinates.
fn point(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(
        (WIDTH_MM / 2.0 - x) * SCALE,
        y * SCALE,
        (DEPTH_MM / 2.0 - z) * SCALE,
    )
}

/// A footprint corner (x, z) of the original data in scene (x, z).
fn corner(x: f32, z: f32) -> Vec2 {
    let p = point(x, 0.0, z);
    Vec2::new(p.x, p.z)
}

pub fn build() -> Scene {
    // Exposure 2 puts the walls between about 0.05 and 0.3; the panel itself is far above
    // white.
    let mut builder = SceneBuilder::new("cornell-box", Sky::default(), 2.0);
    let white = builder.material(dielectric("White", Vec3::new(0.725, 0.71, 0.68), 1.0));
    let red = builder.material(dielectric("Red", Vec3::new(0.63, 0.065, 0.05), 1.0));
    let green = builder.material(dielectric("Green", Vec3::new(0.14, 0.45, 0.091), 1.0));
    let light = builder.material(emitter(
        "Light",
        Vec3::splat(0.78),
        Vec3::new(17.0, 12.0, 4.0),
    ));

    // The room's five walls are single quads facing inwards, as in the original; the front
    // is open.
    let (w, h, d) = (WIDTH_MM * SCALE, HEIGHT_MM * SCALE, DEPTH_MM * SCALE);
    let min = Vec3::new(-w / 2.0, 0.0, -d / 2.0);
    let mut room = Parts::default();
    let walls = room.of(white);
    walls.append(&quad(min, Vec3::Z * d, Vec3::X * w));
    walls.append(&quad(min + Vec3::Y * h, Vec3::X * w, Vec3::Z * d));
    walls.append(&quad(min, Vec3::X * w, Vec3::Y * h));
    let red_wall = quad(min + Vec3::Z * d, Vec3::NEG_Z * d, Vec3::Y * h);
    room.of(red).append(&red_wall);
    let green_wall = quad(min + Vec3::X * w, Vec3::Z * d, Vec3::Y * h);
    room.of(green).append(&green_wall);
    builder.mesh_node("Room", room, Vec3::ZERO);

    // The 130 x 105 mm opening of the original, as a panel 5 mm below the ceiling facing down.
    let (a, b) = (
        point(343.0, HEIGHT_MM - 5.0, 227.0),
        point(213.0, 0.0, 332.0),
    );
    let panel = quad(a, Vec3::Z * (b.z - a.z), Vec3::X * (b.x - a.x));
    builder.single_mesh_node("Light", panel, light);

    let short_block = [
        corner(130.0, 65.0),
        corner(82.0, 225.0),
        corner(240.0, 272.0),
        corner(290.0, 114.0),
    ];
    let short = prism(&short_block, 0.0, 165.0 * SCALE);
    builder.single_mesh_node("Short block", short, white);
    let tall_block = [
        corner(423.0, 247.0),
        corner(265.0, 296.0),
        corner(314.0, 456.0),
        corner(472.0, 406.0),
    ];
    let tall = prism(&tall_block, 0.0, 330.0 * SCALE);
    builder.single_mesh_node("Tall block", tall, white);

    // The original pinhole: 35 mm focal length behind a 25 mm film, 800 mm in front of the
    // opening, at mid height.
    let yfov = 2.0 * (12.5f32 / 35.0).atan();
    let eye = point(278.0, 273.0, -800.0);
    let center = point(278.0, 273.0, DEPTH_MM / 2.0);
    builder.camera(eye, center, yfov);
    // A slow look around from in front of the opening, ending where it started.
    builder.camera_path(
        yfov,
        &[
            (0.0, eye, center),
            (2.0, Vec3::new(-0.6, 1.3, 3.0), Vec3::new(0.1, 0.8, -0.2)),
            (4.0, Vec3::new(0.5, 0.6, 2.4), Vec3::new(-0.2, 0.9, -0.4)),
            (6.0, eye, center),
        ],
    );
    builder.finish()
}

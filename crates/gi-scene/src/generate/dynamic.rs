//! `dynamic`: a closed room where a box and a point light move, looping every 4 s.
//!
//! The only light is the moving point light, so every change of the indirect lighting comes
//! from motion: the orange box drives a square around the room while turning, dragging its
//! shadow and its color bleeding across the floor and walls; the light circles at head height,
//! sweeping the red and blue walls' bleeding around the room and casting the central pedestal's
//! shadow. Both motions are glTF animations (linear keys, first key equal to the last), which
//! the model loops over their duration.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Quat, Vec3};

use super::builder::{Parts, SceneBuilder, dielectric};
use super::shapes::{box_between, cuboid};
use crate::model::{Animation, Channel, ChannelValues, Interpolation, LightKind, Scene, Sky};

/// Interior half size (x and z) and height.
const HALF: f32 = 4.0;
const HEIGHT: f32 = 3.0;
const WALL: f32 = 0.2;
/// Loop period of both motions.
const PERIOD_S: f32 = 4.0;

pub fn build() -> Scene {
    // Exposure for a floor lit from about 2 m by an 8 W/sr bulb plus the room's bounces.
    let mut builder = SceneBuilder::new("dynamic", Sky::default(), 1.5);
    let white = builder.material(dielectric("White paint", Vec3::new(0.72, 0.71, 0.68), 0.9));
    let red = builder.material(dielectric("Red paint", Vec3::new(0.60, 0.10, 0.08), 0.9));
    let blue = builder.material(dielectric("Blue paint", Vec3::new(0.10, 0.20, 0.60), 0.9));
    let floor = builder.material(dielectric("Wood floor", Vec3::new(0.55, 0.40, 0.25), 0.6));
    let orange = builder.material(dielectric("Orange", Vec3::new(0.80, 0.45, 0.08), 0.7));

    let (inner, outer) = (HALF, HALF + WALL);
    let mut room = Parts::default();
    room.of(floor).append(&box_between(
        Vec3::new(-outer, -WALL, -outer),
        Vec3::new(outer, 0.0, outer),
    ));
    room.of(white).append(&box_between(
        Vec3::new(-outer, HEIGHT, -outer),
        Vec3::new(outer, HEIGHT + WALL, outer),
    ));
    // West red, east blue; north and south white and running the full width over the corners.
    room.of(red).append(&box_between(
        Vec3::new(-outer, 0.0, -inner),
        Vec3::new(-inner, HEIGHT, inner),
    ));
    room.of(blue).append(&box_between(
        Vec3::new(inner, 0.0, -inner),
        Vec3::new(outer, HEIGHT, inner),
    ));
    for side in [-1.0, 1.0] {
        let (za, zb) = (side * inner, side * outer);
        room.of(white).append(&box_between(
            Vec3::new(-outer, 0.0, za.min(zb)),
            Vec3::new(outer, HEIGHT, za.max(zb)),
        ));
    }
    // A pedestal in the middle gives the light something to cast a shadow across the floor.
    room.of(white).append(&box_between(
        Vec3::new(-0.3, 0.0, -0.3),
        Vec3::new(0.3, 1.2, 0.3),
    ));
    builder.mesh_node("Room", room, Vec3::ZERO);

    // The box: mesh centered on its node, the node carried around a 4 x 3 m rectangle.
    let mut box_parts = Parts::default();
    box_parts.of(orange).append(&cuboid(Vec3::splat(0.4)));
    let corners = [
        Vec3::new(-2.0, 0.4, -1.5),
        Vec3::new(2.0, 0.4, -1.5),
        Vec3::new(2.0, 0.4, 1.5),
        Vec3::new(-2.0, 0.4, 1.5),
    ];
    let moving_box = builder.mesh_node("Moving box", box_parts, corners[0]);
    let box_times: Vec<f32> = (0..=4).map(|k| k as f32 * PERIOD_S / 4.0).collect();
    let box_path: Vec<Vec3> = (0..=4).map(|k| corners[k % 4]).collect();
    // A quarter turn per side; the last key is a full turn, the same orientation as the first.
    let box_turn: Vec<Quat> = (0..=4)
        .map(|k| Quat::from_rotation_y(k as f32 * FRAC_PI_2))
        .collect();

    // A 2.5 m circle at 2.2 m, bobbing 20 cm; eight linear segments.
    let light_times: Vec<f32> = (0..=8).map(|k| k as f32 * PERIOD_S / 8.0).collect();
    let light_path: Vec<Vec3> = (0..=8)
        .map(|k| {
            let angle = (k % 8) as f32 / 8.0 * TAU;
            let bob = if k % 2 == 0 { 0.1 } else { -0.1 };
            Vec3::new(2.5 * angle.sin(), 2.2 + bob, 2.5 * angle.cos())
        })
        .collect();
    let light = builder.light(
        "Moving light",
        LightKind::Point,
        Vec3::new(1.0, 0.85, 0.7),
        8.0,
        light_path[0],
        Vec3::NEG_Y,
    );

    let channel = |node, times: &Vec<f32>, values| Channel {
        node,
        times: times.clone(),
        values,
        interpolation: Interpolation::Linear,
    };
    builder.animation(Animation {
        name: "Motion".into(),
        channels: vec![
            channel(moving_box, &box_times, ChannelValues::Translation(box_path)),
            channel(moving_box, &box_times, ChannelValues::Rotation(box_turn)),
            channel(light, &light_times, ChannelValues::Translation(light_path)),
        ],
    });

    let yfov = 1.1;
    let eye = Vec3::new(3.5, 1.7, 3.5);
    let target = Vec3::new(-1.0, 0.6, -1.0);
    builder.camera(eye, target, yfov);
    // Around the room along the walls, always looking into its middle.
    builder.camera_path(
        yfov,
        &[
            (0.0, eye, target),
            (3.0, Vec3::new(-3.2, 2.0, 3.3), Vec3::new(1.0, 0.5, -1.0)),
            (6.0, Vec3::new(-3.3, 1.5, -3.2), Vec3::new(1.0, 0.6, 1.0)),
            (8.0, eye, target),
        ],
    );
    builder.finish()
}

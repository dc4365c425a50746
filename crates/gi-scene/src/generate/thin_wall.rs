//! `thin-wall`: a light-leak test.
//!
//! A closed room stands on open ground under a strong sun. Its east wall, the one the sun
//! shines on, is only 5 cm thick (a closed box, not a zero-thickness quad: every renderer must
//! handle a real wall thinner than its probe spacing or cache cell); every other wall, the
//! roof and the ground are 20-30 cm slabs. The ground runs on under the thin wall, so the
//! sunlit outdoor floor and the dark indoor floor meet exactly where caches like to leak. The
//! only opening is a door in the north wall, which no sun ray can pass: the interior sees
//! skylight and bounced light through the door and nothing else. The camera stands inside
//! looking at the thin wall.

use glam::{Vec2, Vec3};

use super::builder::{
    Parts, SUN_COLOR, SUN_IRRADIANCE, SceneBuilder, daylight_sky, dielectric, sun_direction,
};
use super::shapes::box_between;
use crate::model::{LightKind, Scene};

/// Interior: x from -4 to 0 (the thin wall's inner face), z from -3 (north) to 3, y up to 2.8.
const INNER_MIN: Vec2 = Vec2::new(-4.0, -3.0);
const INNER_MAX: Vec2 = Vec2::new(0.0, 3.0);
const HEIGHT: f32 = 2.8;
const WALL: f32 = 0.2;
const THIN_WALL: f32 = 0.05;
/// The door in the north wall: x range and height.
const DOOR_X: (f32, f32) = (-3.7, -2.3);
const DOOR_HEIGHT: f32 = 2.2;

pub fn build() -> Scene {
    // The interior only receives light through the door: exposure is set for it, so that any
    // sunlight leaking through the thin wall stands out as a glaring error.
    let mut builder = SceneBuilder::new("thin-wall", daylight_sky(), 10.0);
    let plaster = builder.material(dielectric("Plaster", Vec3::new(0.75, 0.73, 0.70), 0.9));
    let ground = builder.material(dielectric("Concrete", Vec3::new(0.42, 0.40, 0.37), 0.85));
    let wood = builder.material(dielectric("Wood", Vec3::new(0.45, 0.28, 0.15), 0.6));

    let (x0, x1) = (INNER_MIN.x, INNER_MAX.x);
    let (z0, z1) = (INNER_MIN.y, INNER_MAX.y);
    let outer_x = x1 + THIN_WALL;
    let mut parts = Parts::default();
    parts.of(ground).append(&box_between(
        Vec3::new(-30.0, -0.3, -30.0),
        Vec3::new(30.0, 0.0, 30.0),
    ));
    let walls = parts.of(plaster);
    // West wall, and the north and south walls running the full outer length so that the
    // corners overlap instead of meeting along an edge.
    walls.append(&box_between(
        Vec3::new(x0 - WALL, 0.0, z0 - WALL),
        Vec3::new(x0, HEIGHT, z1 + WALL),
    ));
    walls.append(&box_between(
        Vec3::new(x0 - WALL, 0.0, z1),
        Vec3::new(outer_x, HEIGHT, z1 + WALL),
    ));
    let north = |xa: f32, xb: f32, ya: f32| {
        box_between(Vec3::new(xa, ya, z0 - WALL), Vec3::new(xb, HEIGHT, z0))
    };
    walls.append(&north(x0 - WALL, DOOR_X.0, 0.0));
    walls.append(&north(DOOR_X.1, outer_x, 0.0));
    walls.append(&north(DOOR_X.0, DOOR_X.1, DOOR_HEIGHT));
    // The roof covers every wall's top.
    walls.append(&box_between(
        Vec3::new(x0 - WALL, HEIGHT, z0 - WALL),
        Vec3::new(outer_x, HEIGHT + WALL, z1 + WALL),
    ));
    builder.mesh_node("Room", parts, Vec3::ZERO);

    let thin = box_between(Vec3::new(x1, 0.0, z0), Vec3::new(outer_x, HEIGHT, z1));
    builder.single_mesh_node("Thin wall", thin, plaster);
    // A low cabinet against the thin wall adds contact corners where leaks also show.
    let cabinet = box_between(Vec3::new(x1 - 0.6, 0.0, 0.8), Vec3::new(x1, 0.9, 2.0));
    builder.single_mesh_node("Cabinet", cabinet, wood);

    // Sun from the east-south-east: it lights the thin wall's outer face at about 40 degrees
    // from its normal and never reaches the north door from outside.
    let to_sun = sun_direction(20.0, 35.0);
    builder.light(
        "Sun",
        LightKind::Directional,
        SUN_COLOR,
        SUN_IRRADIANCE,
        Vec3::new(20.0, 20.0, 8.0),
        -to_sun,
    );

    let yfov = 1.0;
    // From the west wall, the whole thin wall with both of its corners fills the view; the
    // door is behind the camera's left shoulder.
    let eye = Vec3::new(-3.6, 1.4, 0.0);
    let target = Vec3::new(0.0, 1.2, 0.0);
    builder.camera(eye, target, yfov);
    // Along the room towards the door, up to the foot of the thin wall, and back.
    builder.camera_path(
        yfov,
        &[
            (0.0, eye, target),
            (2.0, Vec3::new(-2.0, 1.6, -1.8), Vec3::new(0.0, 1.2, 1.0)),
            (4.0, Vec3::new(-1.0, 1.0, 0.0), Vec3::new(0.0, 0.4, -0.5)),
            (6.0, eye, target),
        ],
    );
    builder.finish()
}

//! `atrium`: a two-storey arcaded courtyard in the spirit of Sponza, much simplified.
//!
//! A 12 x 24 m courtyard open to the sky is lined on its long sides by galleries 4 m deep:
//! a ground-floor arcade of round columns, an upper arcade of square piers behind a
//! balustrade, and an attic wall above. Colored cloth banners hang in front of the upper
//! arcades and in two bays of the east ground floor. The sun comes in high from the east, so
//! the east wing shades half the courtyard while the west arcades, their banners and the
//! back of the west galleries are sunlit: most of what the camera sees is lit by several
//! bounces of stone- and cloth-colored light.

use glam::{Vec2, Vec3};

use super::builder::{
    Parts, SUN_COLOR, SUN_IRRADIANCE, SceneBuilder, daylight_sky, dielectric, sun_direction,
};
use super::shapes::{MeshData, box_between, cylinder, quad};
use crate::model::{LightKind, Material, Scene};

/// Courtyard half width (x) and half length (z); the galleries reach to `GALLERY_X`.
const COURT_X: f32 = 6.0;
const COURT_Z: f32 = 12.0;
const GALLERY_X: f32 = 10.0;
const WALL: f32 = 0.4;
/// Levels: ground arcade up to 4 m, first floor slab 4-4.5 m, upper arcade to 8 m, gallery
/// roof 8-8.5 m, attic and outer walls up to 10.5 m.
const FIRST_FLOOR: f32 = 4.0;
const SLAB: f32 = 0.5;
const UPPER_TOP: f32 = 8.0;
const TOP: f32 = 10.5;
/// Column and pier positions along z: eight per side, 3 m apart, seven bays between them.
const BAYS: usize = 7;
const BAY: f32 = 3.0;

fn column_z(index: usize) -> f32 {
    -COURT_Z + 1.5 + index as f32 * BAY
}

pub fn build() -> Scene {
    let mut builder = SceneBuilder::new("atrium", daylight_sky(), 0.6);
    let stone = builder.material(dielectric("Stone", Vec3::new(0.62, 0.55, 0.45), 0.8));
    let paving = builder.material(dielectric("Paving", Vec3::new(0.50, 0.46, 0.40), 0.7));
    let marble = builder.material(dielectric("Marble", Vec3::new(0.78, 0.75, 0.69), 0.5));
    let cloth = |name: &str, color: Vec3| Material {
        double_sided: true,
        ..dielectric(name, color, 1.0)
    };
    let red = builder.material(cloth("Red cloth", Vec3::new(0.70, 0.06, 0.05)));
    let blue = builder.material(cloth("Blue cloth", Vec3::new(0.05, 0.12, 0.60)));
    let green = builder.material(cloth("Green cloth", Vec3::new(0.08, 0.45, 0.10)));

    let mut parts = Parts::default();
    let (outer_x, outer_z) = (GALLERY_X + WALL, COURT_Z + WALL);
    parts.of(paving).append(&box_between(
        Vec3::new(-outer_x, -0.3, -outer_z),
        Vec3::new(outer_x, 0.0, outer_z),
    ));
    // End walls close the courtyard and both galleries at z = +-12.
    for side in [-1.0, 1.0] {
        let (za, zb) = (side * COURT_Z, side * outer_z);
        parts.of(stone).append(&box_between(
            Vec3::new(-outer_x, 0.0, za.min(zb)),
            Vec3::new(outer_x, TOP, za.max(zb)),
        ));
    }
    for side in [-1.0f32, 1.0] {
        add_wing(&mut parts, side, stone, marble);
    }
    builder.mesh_node("Courtyard", parts, Vec3::ZERO);

    let mut banners = Parts::default();
    let palette = [red, blue, green];
    for (wing, side) in [-1.0f32, 1.0].into_iter().enumerate() {
        for (k, bay) in [1, 3, 5].into_iter().enumerate() {
            let z = column_z(bay) + BAY / 2.0;
            let x = side * (COURT_X - 0.35);
            let banner = banner(x, z, 1.8, 5.0, UPPER_TOP);
            banners.of(palette[(k + wing) % 3]).append(&banner);
        }
    }
    // Curtains in two bays of the east ground floor (the camera path uses the west one).
    for (k, bay) in [2, 4].into_iter().enumerate() {
        let z = column_z(bay) + BAY / 2.0;
        let curtain = banner(COURT_X + 0.3, z, 2.0, 0.9, FIRST_FLOOR);
        banners.of(palette[k]).append(&curtain);
    }
    builder.mesh_node("Banners", banners, Vec3::ZERO);

    // Basin in the middle of the courtyard.
    let mut basin = Parts::default();
    let rim = basin.of(marble);
    for (min, max) in [
        (Vec2::new(-1.5, -1.5), Vec2::new(1.5, -1.2)),
        (Vec2::new(-1.5, 1.2), Vec2::new(1.5, 1.5)),
        (Vec2::new(-1.5, -1.2), Vec2::new(-1.2, 1.2)),
        (Vec2::new(1.2, -1.2), Vec2::new(1.5, 1.2)),
    ] {
        rim.append(&box_between(
            Vec3::new(min.x, 0.0, min.y),
            Vec3::new(max.x, 0.6, max.y),
        ));
    }
    rim.append(&cylinder(0.3, 1.4, 16));
    builder.mesh_node("Basin", basin, Vec3::ZERO);

    let to_sun = sun_direction(15.0, 55.0);
    builder.light(
        "Sun",
        LightKind::Directional,
        SUN_COLOR,
        SUN_IRRADIANCE,
        Vec3::new(0.0, 30.0, 0.0),
        -to_sun,
    );

    let yfov = 1.0;
    let eye = Vec3::new(0.0, 1.7, 10.5);
    let target = Vec3::new(0.0, 3.5, -12.0);
    builder.camera(eye, target, yfov);
    // Into the courtyard, through an arch into the sunlit west gallery, along it.
    builder.camera_path(
        yfov,
        &[
            (0.0, eye, target),
            (3.0, Vec3::new(2.5, 1.7, 2.5), Vec3::new(-8.0, 2.5, -1.0)),
            (6.0, Vec3::new(-8.5, 1.7, 0.0), Vec3::new(-8.5, 2.0, -11.0)),
            (9.0, Vec3::new(-8.5, 1.7, -8.0), Vec3::new(0.0, 5.0, -3.0)),
        ],
    );
    builder.finish()
}

/// One long side of the courtyard (`side` -1 west, +1 east): outer wall, floor slabs, both
/// arcades, balustrade and attic.
fn add_wing(parts: &mut Parts, side: f32, stone: usize, marble: usize) {
    // Boxes are given by their x range measured from the courtyard edge outwards.
    let span = |inner: f32, outer: f32, y0: f32, y1: f32| {
        let (xa, xb) = (side * inner, side * outer);
        box_between(
            Vec3::new(xa.min(xb), y0, -COURT_Z),
            Vec3::new(xa.max(xb), y1, COURT_Z),
        )
    };
    let walls = parts.of(stone);
    walls.append(&span(GALLERY_X, GALLERY_X + WALL, 0.0, TOP));
    walls.append(&span(
        COURT_X - 0.2,
        GALLERY_X,
        FIRST_FLOOR,
        FIRST_FLOOR + SLAB,
    ));
    walls.append(&span(COURT_X - 0.2, GALLERY_X, UPPER_TOP, UPPER_TOP + SLAB));
    walls.append(&span(COURT_X - 0.2, COURT_X + 0.2, UPPER_TOP + SLAB, TOP));
    let balustrade_top = FIRST_FLOOR + SLAB + 1.0;
    walls.append(&span(
        COURT_X - 0.1,
        COURT_X + 0.1,
        FIRST_FLOOR + SLAB,
        balustrade_top,
    ));

    let x = side * COURT_X;
    let column = cylinder(0.35, 3.4, 16);
    let block = |y0: f32, y1: f32, half: f32, z: f32| {
        box_between(
            Vec3::new(x - half, y0, z - half),
            Vec3::new(x + half, y1, z + half),
        )
    };
    let columns = parts.of(marble);
    for index in 0..=BAYS {
        let z = column_z(index);
        // Ground floor: plinth, round shaft, capital. Upper floor: a square pier.
        columns.append(&block(0.0, 0.3, 0.45, z));
        columns.add_at(&column, Vec3::new(x, 0.3, z));
        columns.append(&block(3.7, FIRST_FLOOR, 0.45, z));
        columns.append(&block(FIRST_FLOOR + SLAB, UPPER_TOP, 0.3, z));
    }
}

/// A hanging cloth `width` wide from `top` down to `bottom`, centered on (x, z) in a plane of
/// constant x, folded into four vertical pleats 12 cm deep.
fn banner(x: f32, z: f32, width: f32, bottom: f32, top: f32) -> MeshData {
    let mut mesh = MeshData::default();
    let pleats = 4;
    let step = width / pleats as f32;
    for i in 0..pleats {
        let depth = |k: usize| if k.is_multiple_of(2) { 0.0 } else { 0.12 };
        let a = Vec3::new(x + depth(i), bottom, z - width / 2.0 + i as f32 * step);
        let b = Vec3::new(x + depth(i + 1), bottom, a.z + step);
        mesh.append(&quad(a, b - a, Vec3::Y * (top - bottom)));
    }
    mesh
}

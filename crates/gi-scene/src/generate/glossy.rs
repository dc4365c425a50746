//! `glossy`: two rows of spheres from mirror to fully rough, in a small studio.
//!
//! The back row is gold (metallic), raised on a step so the front row does not hide it; the
//! front row is white plastic (dielectric); roughness goes 0, 0.2, 0.4, 0.6, 0.8, 1 from left
//! to right. The spheres stand on a checkered floor in front of a backdrop wall and are lit by three area lights: a large white softbox above the
//! camera, a cool strip on the left and a warm strip on the right, so every sphere shows
//! recognizable highlights, and a dim sky fills the open sides.

use glam::{Vec2, Vec3};

use super::builder::{Parts, SceneBuilder, dielectric, emitter, metal};
use super::shapes::{MeshData, box_between, quad, uv_sphere};
use crate::model::{Material, Scene, Sky};

const ROUGHNESS: [f32; 6] = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0];
const RADIUS: f32 = 0.4;
const SPACING: f32 = 1.0;
/// Floor extent (x, z) and checker tile size.
const FLOOR_HALF: Vec2 = Vec2::new(6.0, 5.0);
const TILE: f32 = 0.5;
/// Rows: the metal row stands on a step behind the dielectric row.
const BACK_Z: f32 = -1.2;
const FRONT_Z: f32 = 0.3;
const STEP: f32 = 0.45;

pub fn build() -> Scene {
    let sky = Sky::Gradient {
        zenith: Vec3::new(0.05, 0.06, 0.08),
        horizon: Vec3::new(0.12, 0.12, 0.12),
        ground: Vec3::new(0.03, 0.03, 0.03),
    };
    let mut builder = SceneBuilder::new("glossy", sky, 1.5);
    let light_tile = builder.material(dielectric("Light tile", Vec3::splat(0.7), 0.6));
    let dark_tile = builder.material(dielectric("Dark tile", Vec3::splat(0.12), 0.6));
    let backdrop = builder.material(dielectric("Backdrop", Vec3::new(0.45, 0.5, 0.55), 0.9));
    let step = builder.material(dielectric("Step", Vec3::splat(0.6), 0.8));
    let housing = Vec3::splat(0.05);
    let softbox = builder.material(emitter("Softbox", housing, Vec3::new(6.0, 6.0, 5.7)));
    let cool = builder.material(emitter("Cool strip", housing, Vec3::new(2.0, 3.5, 6.0)));
    let warm = builder.material(emitter("Warm strip", housing, Vec3::new(6.0, 3.5, 1.6)));

    // Checkered floor of single quads (no texture needed, edges stay sharp at any resolution).
    let mut floor = Parts::default();
    let (nx, nz) = (
        (FLOOR_HALF.x * 2.0 / TILE) as i32,
        (FLOOR_HALF.y * 2.0 / TILE) as i32,
    );
    for i in 0..nx {
        for j in 0..nz {
            let corner = Vec3::new(
                -FLOOR_HALF.x + i as f32 * TILE,
                0.0,
                -FLOOR_HALF.y + j as f32 * TILE,
            );
            let tile = quad(corner, Vec3::Z * TILE, Vec3::X * TILE);
            let material = if (i + j) % 2 == 0 {
                light_tile
            } else {
                dark_tile
            };
            floor.of(material).append(&tile);
        }
    }
    floor.of(backdrop).append(&box_between(
        Vec3::new(-FLOOR_HALF.x, 0.0, -FLOOR_HALF.y - 0.2),
        Vec3::new(FLOOR_HALF.x, 3.5, -FLOOR_HALF.y),
    ));
    // The back row stands on a step so that the front row does not hide it.
    floor.of(step).append(&box_between(
        Vec3::new(-3.3, 0.0, BACK_Z - 0.5),
        Vec3::new(3.3, STEP, BACK_Z + 0.5),
    ));
    builder.mesh_node("Studio", floor, Vec3::ZERO);

    let sphere = uv_sphere(RADIUS, 32, 16);
    let rows = [
        (
            "Gold",
            BACK_Z,
            STEP,
            metal("", Vec3::new(1.0, 0.78, 0.34), 0.0),
        ),
        (
            "Plastic",
            FRONT_Z,
            0.0,
            dielectric("", Vec3::splat(0.8), 0.0),
        ),
    ];
    for (row, z, y, template) in rows {
        for (k, roughness) in ROUGHNESS.into_iter().enumerate() {
            let name = format!("{row} {roughness:.1}");
            let material = builder.material(Material {
                name: name.clone(),
                roughness,
                ..template.clone()
            });
            let x = (k as f32 - (ROUGHNESS.len() - 1) as f32 / 2.0) * SPACING;
            let mut mesh = MeshData::default();
            mesh.add_at(&sphere, Vec3::new(x, y + RADIUS, z));
            builder.single_mesh_node(&name, mesh, material);
        }
    }

    // The softbox hangs above and in front of the spheres, tilted to face them.
    let to_spheres = (Vec3::new(0.0, 0.5, -0.5) - Vec3::new(0.0, 3.2, 2.0)).normalize();
    let width = Vec3::X * 3.0;
    let height = to_spheres.cross(Vec3::X) * 1.2;
    let center = Vec3::new(0.0, 3.2, 2.0);
    let panel = quad(center - width / 2.0 - height / 2.0, width, height);
    builder.single_mesh_node("Softbox", panel, softbox);
    // Vertical strips at the sides, facing inwards.
    let strip = |x: f32, facing: f32| {
        let along = Vec3::Z * 0.3 * -facing;
        quad(Vec3::new(x, 0.3, 0.5 + 0.15 * facing), along, Vec3::Y * 2.2)
    };
    builder.single_mesh_node("Cool strip", strip(-4.5, 1.0), cool);
    builder.single_mesh_node("Warm strip", strip(4.5, -1.0), warm);

    let yfov = 0.7;
    let eye = Vec3::new(0.0, 1.6, 6.0);
    let target = Vec3::new(0.0, 0.55, -0.5);
    builder.camera(eye, target, yfov);
    // A half orbit in front of the rows, low at the end to see the floor reflections.
    builder.camera_path(
        yfov,
        &[
            (0.0, eye, target),
            (2.0, Vec3::new(-3.5, 1.4, 4.5), target),
            (4.0, Vec3::new(3.5, 0.9, 4.5), Vec3::new(-0.5, 0.4, -0.4)),
            (6.0, Vec3::new(0.0, 0.7, 4.0), target),
        ],
    );
    builder.finish()
}

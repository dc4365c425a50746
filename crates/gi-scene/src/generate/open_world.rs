//! `open-world`: 512 x 512 m of terrain, a town, trees and rocks under a low sun.
//!
//! A town of about a hundred buildings (a few glass towers near the center) sits in a flat
//! valley ringed by hills. The world is split into 4 x 4 tiles of 128 m, one node each with its
//! terrain patch and everything standing on it, so streaming and culling can work per tile;
//! tile geometry is stored relative to the tile's center. Terrain is a 128 x 128 cell
//! heightfield from deterministic value noise. The camera path flies a drone from the
//! southwest hills over the town and turns back to look at the skyline; buildings and trees
//! keep clear of its ground track.

use std::f32::consts::TAU;

use glam::{Affine3A, Quat, Vec2, Vec3};

use super::builder::{
    Parts, SUN_COLOR, SUN_IRRADIANCE, SceneBuilder, daylight_sky, dielectric, sun_direction,
};
use super::shapes::{MeshData, box_between, cone, cylinder, heightfield, icosphere};
use crate::model::{LightKind, Scene};

const HALF_SIZE: f32 = 256.0;
const TILES: usize = 4;
const TILE_SIZE: f32 = 2.0 * HALF_SIZE / TILES as f32;
const TILE_CELLS: u32 = 32;

/// A hash of integer coordinates to `[0, 1)` (lowbias32 finalizer; no platform dependence).
fn hash(x: i32, z: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (z as u32).wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Smooth value noise in `[0, 1]` with unit feature size.
fn value_noise(x: f32, z: f32, seed: u32) -> f32 {
    let (x0, z0) = (x.floor(), z.floor());
    let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (u, v) = (fade(x - x0), fade(z - z0));
    let (i, j) = (x0 as i32, z0 as i32);
    let top = hash(i, j, seed) + (hash(i + 1, j, seed) - hash(i, j, seed)) * u;
    let bottom = hash(i, j + 1, seed) + (hash(i + 1, j + 1, seed) - hash(i, j + 1, seed)) * u;
    top + (bottom - top) * v
}

fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Terrain height at (x, z): flat town ground within 90 m of the center, rising through
/// rolling noise into a rim of hills towards the edges.
fn terrain_height(x: f32, z: f32) -> f32 {
    let (mut sum, mut weight, mut frequency) = (0.0, 0.0, 1.0 / 120.0);
    for octave in 0..4 {
        let amplitude = 0.5f32.powi(octave);
        sum += amplitude * value_noise(x * frequency, z * frequency, 11 + octave as u32);
        weight += amplitude;
        frequency *= 2.0;
    }
    let hills = (sum / weight - 0.5) * 50.0;
    let r = x.hypot(z);
    smoothstep(90.0, 210.0, r) * (hills + 28.0 * smoothstep(150.0, 300.0, r))
}

/// Horizontal distance from `p` to the segment `a..b`.
fn distance_to_segment(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-6)).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// World geometry sorted into tiles; each object goes to the tile holding its center.
struct Tiles {
    parts: Vec<Parts>,
}

impl Tiles {
    fn center(index: usize) -> Vec3 {
        let (i, j) = (index % TILES, index / TILES);
        let corner = -HALF_SIZE + TILE_SIZE / 2.0;
        Vec3::new(
            corner + i as f32 * TILE_SIZE,
            0.0,
            corner + j as f32 * TILE_SIZE,
        )
    }

    fn index(position: Vec3) -> usize {
        let cell = |v: f32| (((v + HALF_SIZE) / TILE_SIZE) as usize).min(TILES - 1);
        cell(position.z) * TILES + cell(position.x)
    }

    /// Adds `shape`, placed in the world by `transform`, to the tile under the placement.
    fn add(&mut self, material: usize, shape: &MeshData, transform: Affine3A) {
        let index = Self::index(transform.translation.into());
        let local = Affine3A::from_translation(-Self::center(index)) * transform;
        self.parts[index].of(material).add(shape, local);
    }
}

/// Material indices of the world.
struct Materials {
    grass: usize,
    facades: [usize; 4],
    glass: usize,
    bark: usize,
    foliage: usize,
    rock: usize,
}

impl Materials {
    fn new(builder: &mut SceneBuilder) -> Self {
        let mut material = |name: &str, color: [f32; 3], roughness: f32| {
            builder.material(dielectric(name, Vec3::from_array(color), roughness))
        };
        Self {
            grass: material("Grass", [0.16, 0.26, 0.08], 0.95),
            facades: [
                material("Concrete", [0.55, 0.54, 0.52], 0.85),
                material("Brick", [0.42, 0.20, 0.13], 0.9),
                material("Sandstone", [0.68, 0.58, 0.44], 0.8),
                material("Plaster", [0.74, 0.72, 0.68], 0.9),
            ],
            // Dark, smooth and dielectric: tower glazing reflects the sky at grazing angles.
            glass: material("Glass facade", [0.10, 0.13, 0.16], 0.15),
            bark: material("Bark", [0.25, 0.17, 0.10], 0.9),
            foliage: material("Foliage", [0.07, 0.20, 0.05], 0.9),
            rock: material("Rock", [0.40, 0.38, 0.35], 0.85),
        }
    }
}

/// A point on the terrain.
fn ground(x: f32, z: f32) -> Vec3 {
    Vec3::new(x, terrain_height(x, z), z)
}

/// The drone flight: `(time_s, position, target)`.
fn camera_keys() -> [(f32, Vec3, Vec3); 4] {
    [
        (
            0.0,
            ground(-150.0, 150.0) + Vec3::Y * 20.0,
            Vec3::new(20.0, 15.0, -20.0),
        ),
        (
            3.0,
            Vec3::new(-70.0, 45.0, 70.0),
            Vec3::new(60.0, 20.0, -60.0),
        ),
        (
            6.0,
            Vec3::new(20.0, 70.0, -20.0),
            Vec3::new(150.0, 40.0, -150.0),
        ),
        (
            10.0,
            ground(150.0, -120.0) + Vec3::Y * 35.0,
            Vec3::new(0.0, 40.0, 0.0),
        ),
    ]
}

pub fn build() -> Scene {
    let mut builder = SceneBuilder::new("open-world", daylight_sky(), 0.5);
    let materials = Materials::new(&mut builder);
    let keys = camera_keys();
    // The flight's ground track; objects keep clear of it.
    let track: Vec<Vec2> = keys.iter().map(|k| Vec2::new(k.1.x, k.1.z)).collect();
    let clearance = |p: Vec2| {
        (track.windows(2))
            .map(|w| distance_to_segment(p, w[0], w[1]))
            .fold(f32::MAX, f32::min)
    };

    let mut tiles = Tiles {
        parts: (0..TILES * TILES).map(|_| Parts::default()).collect(),
    };
    for index in 0..TILES * TILES {
        let center = Tiles::center(index);
        let origin = Vec2::new(center.x, center.z) - TILE_SIZE / 2.0;
        let patch = heightfield(origin, Vec2::splat(TILE_SIZE), TILE_CELLS, terrain_height);
        tiles.parts[index]
            .of(materials.grass)
            .add_at(&patch, -center);
    }
    let footprints = add_buildings(&mut tiles, &materials, &clearance);
    add_trees(&mut tiles, &materials, &clearance, &footprints);
    add_boulders(&mut tiles, materials.rock, &clearance);
    for (index, parts) in tiles.parts.into_iter().enumerate() {
        let name = format!("Tile {} {}", index % TILES, index / TILES);
        builder.mesh_node(&name, parts, Tiles::center(index));
    }

    builder.light(
        "Sun",
        LightKind::Directional,
        SUN_COLOR,
        SUN_IRRADIANCE,
        Vec3::new(0.0, 200.0, 0.0),
        -sun_direction(60.0, 28.0),
    );
    let yfov = 0.9;
    builder.camera(keys[0].1, keys[0].2, yfov);
    builder.camera_path(yfov, &keys);
    builder.finish()
}

/// Buildings on a grid of 26 m lots (streets between them), denser and taller at the center,
/// none within 10 m of the camera's track. Returns their footprints as (center, half size).
fn add_buildings(
    tiles: &mut Tiles,
    materials: &Materials,
    clearance: &dyn Fn(Vec2) -> f32,
) -> Vec<(Vec2, Vec2)> {
    let mut footprints = Vec::new();
    for i in -7..=7 {
        for j in -7..=7 {
            let lot = Vec2::new(i as f32, j as f32) * 26.0;
            let r = lot.length();
            let density = 0.95 * (1.0 - smoothstep(70.0, 240.0, r));
            // The central lot stays an open square.
            if (i, j) == (0, 0) || hash(i, j, 1) >= density {
                continue;
            }
            let size = Vec2::new(10.0 + 10.0 * hash(i, j, 2), 10.0 + 10.0 * hash(i, j, 3));
            let slack = (Vec2::splat(20.0) - size).max(Vec2::ZERO) / 2.0;
            let jitter = Vec2::new(hash(i, j, 4), hash(i, j, 5)) * 2.0 - 1.0;
            let center = lot + jitter * slack;
            let half = size / 2.0;
            if clearance(center) < half.max_element() + 10.0 {
                continue;
            }
            // Sunk 1 m below the lowest ground under the footprint, so no slope shows a gap.
            let samples = [
                (-1.0, -1.0),
                (1.0, -1.0),
                (1.0, 1.0),
                (-1.0, 1.0),
                (0.0, 0.0),
            ];
            let heights =
                samples.map(|(u, v)| terrain_height(center.x + u * half.x, center.y + v * half.y));
            let base = heights.iter().copied().fold(f32::MAX, f32::min) - 1.0;
            let grade = heights.iter().copied().fold(f32::MIN, f32::max);
            let tower = hash(i, j, 6) < 0.15 && r < 110.0;
            let height = if tower {
                50.0 + 70.0 * hash(i, j, 7)
            } else {
                6.0 + 28.0 * hash(i, j, 7).powi(2) * (1.0 - 0.6 * smoothstep(50.0, 200.0, r))
            };
            let top = grade + height - base;
            let place = Affine3A::from_translation(Vec3::new(center.x, base, center.y));
            let block = |half: Vec2, y0: f32, y1: f32| {
                box_between(
                    Vec3::new(-half.x, y0, -half.y),
                    Vec3::new(half.x, y1, half.y),
                )
            };
            if tower {
                // Glass, with a narrower crown on the upper fifth.
                let shaft = top - height * 0.2;
                tiles.add(materials.glass, &block(half, 0.0, shaft), place);
                tiles.add(materials.glass, &block(half * 0.7, shaft, top), place);
            } else {
                let facades = &materials.facades;
                let material = facades[(hash(i, j, 8) * facades.len() as f32) as usize];
                tiles.add(material, &block(half, 0.0, top), place);
            }
            footprints.push((center, half));
        }
    }
    footprints
}

/// Conifers on a jittered 18 m grid, growing denser away from the town, clear of buildings
/// and of the camera's track.
fn add_trees(
    tiles: &mut Tiles,
    materials: &Materials,
    clearance: &dyn Fn(Vec2) -> f32,
    footprints: &[(Vec2, Vec2)],
) {
    let trunk = cylinder(0.25, 1.0, 6);
    let crown = cone(1.0, 1.0, 8);
    for i in -14..=14 {
        for j in -14..=14 {
            let jitter = Vec2::new(hash(i, j, 20), hash(i, j, 21)) * 14.0 - 7.0;
            let p = Vec2::new(i as f32, j as f32) * 18.0 + jitter;
            let density = 0.4 * smoothstep(110.0, 170.0, p.length());
            let in_building =
                (footprints.iter()).any(|(c, half)| ((p - *c).abs() - *half).max_element() < 4.0);
            if hash(i, j, 22) >= density
                || in_building
                || p.abs().max_element() > HALF_SIZE - 6.0
                || clearance(p) < 8.0
            {
                continue;
            }
            let height = 6.0 + 5.0 * hash(i, j, 23);
            let foot = ground(p.x, p.y) - Vec3::Y * 0.2;
            let scaled = |scale: Vec3, at: Vec3| {
                Affine3A::from_scale_rotation_translation(scale, Quat::IDENTITY, at)
            };
            let trunk_scale = Vec3::new(1.0, height * 0.3, 1.0);
            tiles.add(materials.bark, &trunk, scaled(trunk_scale, foot));
            let crown_scale = Vec3::new(0.3, 0.75, 0.3) * height;
            let crown_base = foot + Vec3::Y * height * 0.25;
            tiles.add(materials.foliage, &crown, scaled(crown_scale, crown_base));
        }
    }
}

/// Boulders on the hillsides: lumpy, squashed icospheres partly sunk into the ground.
fn add_boulders(tiles: &mut Tiles, rock: usize, clearance: &dyn Fn(Vec2) -> f32) {
    for k in 0..14 {
        let angle = hash(k, 0, 30) * TAU;
        let p = Vec2::new(angle.cos(), angle.sin()) * (160.0 + 80.0 * hash(k, 0, 31));
        if p.abs().max_element() > HALF_SIZE - 10.0 || clearance(p) < 15.0 {
            continue;
        }
        let mut boulder = icosphere(1.0, 1);
        for v in &mut boulder.positions {
            *v *= 0.75 + 0.5 * value_noise(v.x * 1.7 + k as f32 * 7.0, v.z * 1.7 + v.y * 3.1, 40);
        }
        boulder.smooth_normals();
        let scale = Vec3::new(1.3, 0.7, 1.0) * (2.5 + 4.0 * hash(k, 0, 32));
        let spin = Quat::from_rotation_y(hash(k, 0, 33) * TAU);
        let position = ground(p.x, p.y) - Vec3::Y * 0.2 * scale.y;
        tiles.add(
            rock,
            &boulder,
            Affine3A::from_scale_rotation_translation(scale, spin, position),
        );
    }
}

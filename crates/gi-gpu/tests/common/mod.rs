//! Ray sets shared by the BVH tests: a seeded generator and the camera, random, shadow and
//! bounce rays of a frame.

#![allow(dead_code)]

use gi_gpu::bvh::GpuRay;
use gi_scene::{SceneBvh, SceneFrame};
use glam::Vec3;

/// A small seeded generator (SplitMix64) so the rays are the same on every run and machine.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn unit_vector(&mut self) -> Vec3 {
        let z = 2.0 * self.next_f32() - 1.0;
        let phi = std::f32::consts::TAU * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    pub fn in_box(&mut self, min: Vec3, max: Vec3) -> Vec3 {
        let t = Vec3::new(self.next_f32(), self.next_f32(), self.next_f32());
        min + (max - min) * t
    }
}

/// Shorthand of [`GpuRay::new`] for the tests' many rays.
pub fn ray(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> GpuRay {
    GpuRay::new(origin, dir, t_min, t_max)
}

/// Camera rays over a grid, random rays (some of them segments), and for camera hits a shadow ray to each light (or a
/// random point for lights at infinity) and a bounce ray in a random direction.
pub fn test_rays(frame: &SceneFrame, bvh: &SceneBvh, seed: u64) -> Vec<GpuRay> {
    let mut rng = Rng(seed);
    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for tri in &frame.triangles {
        for v in [tri.v0, tri.v1, tri.v2] {
            min = min.min(v.into());
            max = max.max(v.into());
        }
    }
    let margin = (max - min) * 0.1;
    let (min, max) = (min - margin, max + margin);

    let mut rays = Vec::new();
    let camera = frame.camera;
    let grid = 32;
    for y in 0..grid {
        for x in 0..grid {
            let (u, v) = (
                (x as f32 + 0.5) / grid as f32,
                (y as f32 + 0.5) / grid as f32,
            );
            let dir = camera.ray_direction(u, v, 4.0 / 3.0);
            rays.push(ray(camera.position, dir, 0.0, f32::INFINITY));
        }
    }
    for i in 0..1500 {
        let t_max = if i % 2 == 0 {
            f32::INFINITY
        } else {
            rng.next_f32() * (max - min).length()
        };
        // Some segments start past their origin, to test `t_min` too.
        let t_min = if i % 4 == 1 { 0.25 * t_max } else { 0.0 };
        rays.push(ray(rng.in_box(min, max), rng.unit_vector(), t_min, t_max));
    }
    let primary: Vec<GpuRay> = rays[..grid * grid].to_vec();
    for primary in primary {
        let (origin, dir) = (Vec3::from(primary.origin), Vec3::from(primary.dir));
        let Some(hit) = bvh.closest_hit(&frame.triangles, origin, dir, 0.0, f32::INFINITY) else {
            continue;
        };
        let point = origin + dir * hit.t;
        let normal = Vec3::from(frame.triangles[hit.triangle as usize].compute_normal());
        let normal = if normal.dot(dir) > 0.0 {
            -normal
        } else {
            normal
        };
        let surface = point + normal * 1e-3;
        for light in &frame.lights {
            let (wi, distance, _) = light.incident(surface);
            let t_max = if distance.is_finite() {
                distance * 0.999
            } else {
                f32::INFINITY
            };
            rays.push(ray(surface, wi, 0.0, t_max));
        }
        let target = rng.in_box(min, max);
        rays.push(ray(
            surface,
            (target - surface).normalize(),
            0.0,
            (target - surface).length(),
        ));
        let bounce = (normal + rng.unit_vector()).normalize_or(normal);
        rays.push(ray(surface, bounce, 0.0, f32::INFINITY));
    }
    rays
}

//! Helpers of the trace tests: seeded random numbers, rays, slab tests, and a cache built by
//! hand voxel by voxel with a brute-force reference of the traversal's semantics.

#![allow(dead_code)]

use gi_cache::layout::{
    SIDE_COUNT, VOXELS_PER_BRICK, brick_of_voxel, brick_slot, face_index, group_of_brick,
    group_slot, mask_bit, side_seen_by_ray, side_slot, split_mask, voxel_index,
};
use gi_cache::packing::{pack_rgb9e5, pack_unit_vector, pack4x8unorm, unpack_unit_vector};
use gi_cache::{CacheBuffers, CacheConfig, GpuCacheLevel, GpuCacheUniforms, VoxelSurface};
use gi_gpu::GpuContext;
use gi_gpu::bvh::GpuRay;
use gi_scene::SceneFrame;
use glam::{IVec3, UVec3, Vec3, Vec4};

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

/// Where the ray enters the box `[lo, hi]`: `(t_near, axis)` (clamped to 0 from inside), or
/// `None` when it misses it or only leaves it behind the origin.
pub fn slab_entry(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, usize)> {
    let (near, far) = slab(origin, dir, lo, hi)?;
    let (t, axis) = near;
    (far > t.max(0.0)).then_some((t.max(0.0), axis))
}

/// `((t_near, axis of t_near), t_far)` of the ray's line against the box, `None` when a zero
/// direction component lies outside the box's slab.
fn slab(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<((f32, usize), f32)> {
    let mut near = (f32::NEG_INFINITY, 0);
    let mut far = f32::INFINITY;
    for axis in 0..3 {
        if dir[axis] == 0.0 {
            if origin[axis] < lo[axis] || origin[axis] >= hi[axis] {
                return None;
            }
            continue;
        }
        let a = (lo[axis] - origin[axis]) / dir[axis];
        let b = (hi[axis] - origin[axis]) / dir[axis];
        let (a, b) = (a.min(b), a.max(b));
        if a > near.0 {
            near = (a, axis);
        }
        far = far.min(b);
    }
    Some((near, far))
}

/// Finest level whose window holds `p` (as `gi::cache::data::cache_level_of_point`).
pub fn level_of_point(uniforms: &GpuCacheUniforms, p: Vec3) -> Option<u32> {
    (0..uniforms.level_count).find(|&level| {
        let l = &uniforms.levels[level as usize];
        let brick = brick_of_voxel((p / l.voxel_size_m).floor().as_ivec3());
        let local = brick - IVec3::from(l.origin_brick);
        local.cmpge(IVec3::ZERO).all()
            && local
                .cmplt(UVec3::from(uniforms.level_bricks).as_ivec3())
                .all()
    })
}

/// Bounds of a frame's triangles.
pub fn scene_bounds(frame: &SceneFrame) -> (Vec3, Vec3) {
    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for tri in &frame.triangles {
        for v in [tri.v0, tri.v1, tri.v2] {
            min = min.min(v.into());
            max = max.max(v.into());
        }
    }
    (min, max)
}

/// A voxel the reference traversal's ray passes through: entry and exit distances, entered
/// face, `(brick ID, bit)`, stored normal.
type Candidate = (f32, f32, u32, (u32, u32), Vec3);

/// What the reference traversal expects of one ray.
#[derive(Clone, Copy, Debug)]
pub struct ExpectedHit {
    pub t: f32,
    pub level: u32,
    pub voxel: (u32, u32),
    pub face: u32,
    /// Side of the hit surfel the ray sees.
    pub side: u32,
    /// Another voxel is entered within 1e-4 of the same distance, or the ray only grazes the
    /// voxel: either answer is right.
    pub tie: bool,
}

/// A cache of 2 levels of 8^3 bricks (0.25 m and 0.5 m voxels), both windows starting at
/// brick (-4, -4, -4): level 0 covers [-4, 4) m, level 1 [-8, 8) m. Voxels are set one by one.
pub struct HandCache {
    pub config: CacheConfig,
    pub uniforms: GpuCacheUniforms,
    link: Vec<u32>,
    group_masks: Vec<u64>,
    brick_masks: Vec<u64>,
    voxels: Vec<VoxelSurface>,
    direct: Vec<u32>,
    indirect: Vec<u32>,
    next_id: u32,
    /// Every voxel set: level, world voxel, `(brick ID, bit)`, normal.
    set: Vec<(u32, IVec3, (u32, u32), Vec3)>,
}

impl HandCache {
    pub fn new() -> Self {
        let config = CacheConfig {
            voxel_size_m: 0.25,
            levels: 2,
            level_bricks: [8, 8, 8],
            pool_bricks: 1024,
            near_levels: 1,
            ..Default::default()
        };
        config.validate().unwrap();
        let mut uniforms = GpuCacheUniforms {
            level_bricks: config.level_bricks,
            level_count: config.levels,
            bricks_per_level: config.bricks_per_level(),
            groups_per_level: config.groups_per_level(),
            pool_bricks: config.pool_bricks,
            ..Default::default()
        };
        for level in 0..config.levels {
            uniforms.levels[level as usize] = GpuCacheLevel {
                origin_brick: [-4; 3],
                voxel_size_m: config.voxel_size_at(level),
            };
        }
        let voxels = (config.pool_bricks as usize + 1) * VOXELS_PER_BRICK as usize;
        Self {
            link: vec![0; (config.levels * config.bricks_per_level()) as usize],
            group_masks: vec![0; (config.levels * config.groups_per_level()) as usize],
            brick_masks: vec![0; config.pool_bricks as usize + 1],
            voxels: vec![VoxelSurface::default(); voxels],
            direct: vec![0; voxels * SIDE_COUNT as usize],
            indirect: vec![0; voxels * SIDE_COUNT as usize],
            next_id: 1,
            set: Vec::new(),
            config,
            uniforms,
        }
    }

    pub fn voxel_size(&self, level: u32) -> f32 {
        self.config.voxel_size_at(level)
    }

    /// Marks world voxel `voxel` of `level` occupied (grey albedo, normal `normal`) and
    /// returns its `(brick ID, bit)`.
    pub fn set_voxel(&mut self, level: u32, voxel: IVec3, normal: Vec3) -> (u32, u32) {
        let dims = UVec3::from(self.config.level_bricks);
        let brick = brick_of_voxel(voxel);
        assert!(
            {
                let local = brick + 4;
                local.cmpge(IVec3::ZERO).all() && local.cmplt(dims.as_ivec3()).all()
            },
            "voxel {voxel} is outside the window"
        );
        let slot = (level * self.config.bricks_per_level() + brick_slot(brick, dims)) as usize;
        if self.link[slot] == 0 {
            self.link[slot] = self.next_id;
            self.next_id += 1;
            let group = (level * self.config.groups_per_level()
                + group_slot(group_of_brick(brick), dims)) as usize;
            self.group_masks[group] |= 1 << mask_bit((brick & 3).as_uvec3());
        }
        let id = self.link[slot];
        let bit = mask_bit((voxel & 3).as_uvec3());
        self.brick_masks[id as usize] |= 1 << bit;
        self.voxels[voxel_index(id, bit) as usize] = VoxelSurface {
            albedo: pack4x8unorm(Vec4::new(0.5, 0.5, 0.5, 1.0)),
            normal: pack_unit_vector(normal),
            emission: 0,
            state: 1,
        };
        self.set
            .retain(|(l, v, _, _)| !(*l == level && *v == voxel));
        // The shaders see the normal as packed.
        let stored = unpack_unit_vector(pack_unit_vector(normal));
        self.set.push((level, voxel, (id, bit), stored));
        (id, bit)
    }

    /// Sets the direct and indirect irradiance of one side of a voxel.
    pub fn set_side(&mut self, (id, bit): (u32, u32), side: u32, direct: Vec3, indirect: Vec3) {
        let slot = side_slot(id, bit, side) as usize;
        self.direct[slot] = pack_rgb9e5(direct);
        self.indirect[slot] = pack_rgb9e5(indirect);
    }

    pub fn upload(&self, ctx: &GpuContext) -> CacheBuffers {
        let buffers = CacheBuffers::new(ctx, &self.config);
        buffers.write_uniforms(ctx, &self.uniforms);
        let split = |m: &[u64]| m.iter().map(|&m| split_mask(m)).collect::<Vec<_>>();
        let q = &ctx.queue;
        q.write_buffer(&buffers.link, 0, bytemuck::cast_slice(&self.link));
        q.write_buffer(
            &buffers.group_masks,
            0,
            bytemuck::cast_slice(&split(&self.group_masks)),
        );
        q.write_buffer(
            &buffers.brick_masks,
            0,
            bytemuck::cast_slice(&split(&self.brick_masks)),
        );
        q.write_buffer(&buffers.voxels, 0, bytemuck::cast_slice(&self.voxels));
        q.write_buffer(&buffers.direct, 0, bytemuck::cast_slice(&self.direct));
        q.write_buffer(&buffers.indirect, 0, bytemuck::cast_slice(&self.indirect));
        buffers
    }

    /// The window of `level` in meters.
    fn window(&self, level: u32) -> (Vec3, Vec3) {
        let l = &self.uniforms.levels[level as usize];
        let lo = IVec3::from(l.origin_brick).as_vec3() * 4.0 * l.voxel_size_m;
        let hi = lo + UVec3::from(self.uniforms.level_bricks).as_vec3() * 4.0 * l.voxel_size_m;
        (lo, hi)
    }

    /// The traversal's semantics by brute force, for rays starting inside level 0: level `L`
    /// owns the part of the ray between leaving window `L - 1` and leaving window `L`; the
    /// first voxel of that level the part enters (not the origin's voxel) is the hit, at the
    /// distance where the part enters it.
    pub fn reference_trace(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<ExpectedHit> {
        let origin_level = level_of_point(&self.uniforms, origin).expect("origin in a window");
        let mut start = 0.0f32;
        let mut start_face = 0;
        for level in origin_level..self.uniforms.level_count {
            let (lo, hi) = self.window(level);
            let ((_, _), end) = slab(origin, dir, lo, hi).expect("origin inside");
            let s = self.voxel_size(level);
            let origin_voxel = (origin / s).floor().as_ivec3();
            // (entry t, exit t, entered face, (brick ID, bit), stored normal) per voxel.
            let mut candidates: Vec<Candidate> = Vec::new();
            for &(l, voxel, id_bit, normal) in &self.set {
                if l != level || (level == origin_level && voxel == origin_voxel) {
                    continue;
                }
                let Some(((t_near, axis), t_far)) = slab(
                    origin,
                    dir,
                    voxel.as_vec3() * s,
                    (voxel.as_vec3() + 1.0) * s,
                ) else {
                    continue;
                };
                let t = t_near.max(start);
                if t_far <= t || t >= end {
                    continue;
                }
                let face = if t_near >= start {
                    face_index(axis, dir[axis] < 0.0) as u32
                } else {
                    start_face
                };
                candidates.push((t, t_far, face, id_bit, normal));
            }
            candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
            if let Some(&(t, t_far, face, voxel, normal)) = candidates.first() {
                if t > t_max {
                    return None;
                }
                let tie = t_far - t < 1e-4 || candidates.get(1).is_some_and(|c| c.0 - t < 1e-4);
                return Some(ExpectedHit {
                    t,
                    level,
                    voxel,
                    face,
                    side: side_seen_by_ray(normal, dir),
                    tie,
                });
            }
            // Leaving this window: the face the next level's part enters through.
            let exit_axis = (0..3)
                .filter(|&a| dir[a] != 0.0)
                .min_by(|&a, &b| {
                    let ta = ((if dir[a] > 0.0 { hi[a] } else { lo[a] }) - origin[a]) / dir[a];
                    let tb = ((if dir[b] > 0.0 { hi[b] } else { lo[b] }) - origin[b]) / dir[b];
                    ta.total_cmp(&tb)
                })
                .unwrap_or(0);
            start = end;
            start_face = face_index(exit_axis, dir[exit_axis] < 0.0) as u32;
        }
        None
    }
}

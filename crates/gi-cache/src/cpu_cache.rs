//! A complete cache built on the CPU: every level's window around a camera filled by the CPU
//! voxelizer, ready to upload. It lets tests and tools use the cache (trace it, light it,
//! compare against it) without the GPU voxelization pass, and it is the oracle that pass is
//! tested against.
//!
//! ```no_run
//! # fn demo(ctx: &gi_gpu::GpuContext) {
//! use gi_cache::{CacheConfig, CpuCache};
//! let scene = gi_scene::load("cornell-box").unwrap();
//! let frame = scene.evaluate(0.0, None);
//! let cpu = CpuCache::build(&CacheConfig::default(), &scene, &frame, frame.camera.position)
//!     .unwrap();
//! let buffers = cpu.upload(ctx); // bind `buffers.bind_group` at `CacheBuffers::BIND_GROUP`
//! # }
//! ```

use gi_gpu::GpuContext;
use gi_scene::{Scene, SceneFrame};
use glam::{IVec3, Vec3};

use crate::alloc::BrickAllocator;
use crate::binning::{CacheScene, bin_triangles, fill_key};
use crate::buffers::{CacheBuffers, cache_uniforms};
use crate::clipmap::ClipmapWindows;
use crate::config::{CacheConfig, ConfigError};
use crate::cpu_voxelize::voxelize_brick;
use crate::layout::{
    BRICK_VOXELS, GpuCacheUniforms, NO_BRICK, SIDE_COUNT, VOXELS_PER_BRICK, VoxelSurface,
    brick_of_voxel, in_window, mask_bit, side_slot, voxel_index,
};
use crate::packing::pack_rgb9e5;
use crate::structure::CacheStructure;

/// One filled brick of a [`CpuCache`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilledBrick {
    pub level: u32,
    /// World brick coordinate.
    pub brick: IVec3,
    /// Pool ID.
    pub id: u32,
}

/// Every level filled on the CPU: the structure, the pool's surfaces and side irradiances
/// (zero unless a test sets them) and what did not fit.
#[derive(Clone, Debug)]
pub struct CpuCache {
    pub config: CacheConfig,
    pub windows: ClipmapWindows,
    pub structure: CacheStructure,
    pub allocator: BrickAllocator,
    /// Surface per brick ID x 64 + voxel bit (entry 0's bricks unused).
    pub voxels: Vec<VoxelSurface>,
    /// RGB9E5 direct irradiance per voxel x 2 + side.
    pub direct: Vec<u32>,
    /// RGB9E5 indirect irradiance per voxel x 2 + side.
    pub indirect: Vec<u32>,
    /// The filled bricks in fill order (finer levels, then nearer bricks, first).
    pub bricks: Vec<FilledBrick>,
    /// Bricks holding geometry that got no pool ID because the pool was full.
    pub dropped_for_pool: u32,
}

impl CpuCache {
    /// Validates `config` and fills every level's window centered on `camera_position` with
    /// the CPU voxelizer, allocating IDs in fill order until the pool runs out (coarse, far
    /// bricks are the ones left out). Cost: one triangle-brick test per triangle and brick
    /// its bounds touch, then 64 voxel tests per binned triangle.
    pub fn build(
        config: &CacheConfig,
        scene: &Scene,
        frame: &SceneFrame,
        camera_position: Vec3,
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        let cache_scene = CacheScene::new(scene, frame);
        let windows = ClipmapWindows::new(config, camera_position);
        let mut candidates = Vec::new();
        for level in 0..config.levels {
            let bins = bin_triangles(
                config,
                &cache_scene,
                level,
                &windows.window(level),
                0..frame.triangles.len() as u32,
            );
            candidates.extend(bins.into_iter().map(|(brick, tris)| (level, brick, tris)));
        }
        candidates.sort_by_cached_key(|c| fill_key(config, camera_position, (c.0, c.1)));
        let voxels_len = (config.pool_bricks as usize + 1) * VOXELS_PER_BRICK as usize;
        let mut cache = Self {
            config: config.clone(),
            windows,
            structure: CacheStructure::new(config),
            allocator: BrickAllocator::new(config.pool_bricks),
            voxels: vec![VoxelSurface::default(); voxels_len],
            direct: vec![0; voxels_len * SIDE_COUNT as usize],
            indirect: vec![0; voxels_len * SIDE_COUNT as usize],
            bricks: Vec::new(),
            dropped_for_pool: 0,
        };
        for (level, brick, triangles) in candidates {
            let filled =
                voxelize_brick(&cache_scene, config.voxel_size_at(level), brick, &triangles);
            if filled.mask == 0 {
                continue;
            }
            let Some(id) = cache.allocator.alloc() else {
                cache.dropped_for_pool += 1;
                continue;
            };
            cache.structure.set_brick(level, brick, id);
            cache.structure.set_brick_mask(id, filled.mask);
            let start = voxel_index(id, 0) as usize;
            cache.voxels[start..start + VOXELS_PER_BRICK as usize]
                .copy_from_slice(&filled.surfaces);
            cache.bricks.push(FilledBrick { level, brick, id });
        }
        Ok(cache)
    }

    /// The uniforms of this cache (frame index 0).
    pub fn uniforms(&self) -> GpuCacheUniforms {
        cache_uniforms(&self.config, &self.windows, 0)
    }

    /// The occupied voxel at world voxel coordinate `voxel` of `level`: `(brick ID, bit)`, or
    /// `None` when it is empty or outside the window.
    pub fn voxel_at(&self, level: u32, voxel: IVec3) -> Option<(u32, u32)> {
        let brick = brick_of_voxel(voxel);
        let window = self.windows.window(level);
        if !in_window(brick, window.min, self.windows.level_bricks) {
            return None;
        }
        let id = self.structure.brick_id(level, brick);
        let bit = mask_bit((voxel & (BRICK_VOXELS as i32 - 1)).as_uvec3());
        (id != NO_BRICK && self.structure.brick_mask(id) & (1u64 << bit) != 0).then_some((id, bit))
    }

    /// The surface of voxel `bit` of brick `id`.
    pub fn surface(&self, id: u32, bit: u32) -> VoxelSurface {
        self.voxels[voxel_index(id, bit) as usize]
    }

    /// Sets the direct and indirect irradiance of side `side` ([`crate::layout::SIDE_FRONT`]
    /// or [`crate::layout::SIDE_BACK`]) of voxel `bit` of brick `id` (packed to RGB9E5), e.g.
    /// to give a trace test known radiance.
    pub fn set_side_irradiance(
        &mut self,
        id: u32,
        bit: u32,
        side: u32,
        direct: Vec3,
        indirect: Vec3,
    ) {
        let slot = side_slot(id, bit, side) as usize;
        self.direct[slot] = pack_rgb9e5(direct);
        self.indirect[slot] = pack_rgb9e5(indirect);
    }

    /// Creates the GPU buffers (counted under `cache.*`) and uploads everything: uniforms,
    /// link grids, group masks, brick masks, surfaces and side irradiances.
    pub fn upload(&self, ctx: &GpuContext) -> CacheBuffers {
        let buffers = CacheBuffers::new(ctx, &self.config);
        self.write_to(ctx, &buffers);
        buffers
    }

    /// Overwrites `buffers` (made for the same configuration) with this cache.
    pub fn write_to(&self, ctx: &GpuContext, buffers: &CacheBuffers) {
        buffers.write_uniforms(ctx, &self.uniforms());
        let mut structure = self.structure.clone();
        structure.mark_all_dirty();
        buffers.upload_structure(ctx, &mut structure);
        ctx.queue
            .write_buffer(&buffers.voxels, 0, bytemuck::cast_slice(&self.voxels));
        ctx.queue
            .write_buffer(&buffers.direct, 0, bytemuck::cast_slice(&self.direct));
        ctx.queue
            .write_buffer(&buffers.indirect, 0, bytemuck::cast_slice(&self.indirect));
        // No emitter samples: all of the indirect irradiance counts as bounced.
        let emitted = vec![0u32; (buffers.emitted.size() / 4) as usize];
        ctx.queue
            .write_buffer(&buffers.emitted, 0, bytemuck::cast_slice(&emitted));
    }

    /// Filled bricks per level.
    pub fn bricks_per_level(&self) -> Vec<u32> {
        let mut counts = vec![0; self.config.levels as usize];
        for b in &self.bricks {
            counts[b.level as usize] += 1;
        }
        counts
    }
}

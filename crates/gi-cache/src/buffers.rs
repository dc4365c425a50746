//! The cache's GPU buffers: bind group 2 of every cache pass and query
//! (`gi::cache::data`, `shaders/cache/data.wgsl`).
//!
//! | binding | label | contents | bytes |
//! |---|---|---|---|
//! | 0 | `cache.uniforms` | [`GpuCacheUniforms`] | 144 |
//! | 1 | `cache.link` | brick ID per level and brick slot | 4 per slot |
//! | 2 | `cache.group_masks` | `[u32; 2]` per level and group slot | 8 per group |
//! | 3 | `cache.brick_masks` | `[u32; 2]` voxel occupancy per brick ID | 8 per brick |
//! | 4 | `cache.voxels` | [`VoxelSurface`] per brick ID x 64 + voxel bit | 1024 per brick |
//! | 5 | `cache.direct` | RGB9E5 direct irradiance per voxel x 2 + side | 512 per brick |
//! | 6 | `cache.indirect` | RGB9E5 indirect irradiance, same indexing | 512 per brick |
//! | 7 | `cache.emitted` | RGB9E5 emitters' part of the indirect, same indexing | 512 per brick (4 bytes without [`CacheConfig::keep_emitted`]) |
//!
//! Every buffer is created through [`GpuContext`], so it is counted under its label; all are
//! `STORAGE | COPY_DST | COPY_SRC` so they can be uploaded and read back by tests.

use gi_gpu::binding::{storage_entry, uniform_entry};
use gi_gpu::{GpuContext, wgpu};

use crate::clipmap::ClipmapWindows;
use crate::config::CacheConfig;
use crate::layout::{
    GpuCacheLevel, GpuCacheUniforms, SIDE_COUNT, VOXELS_PER_BRICK, VoxelSurface, join_mask,
    split_mask,
};
use crate::structure::CacheStructure;

/// The GPU buffers of the cache and the bind group that binds them at group
/// [`CacheBuffers::BIND_GROUP`].
pub struct CacheBuffers {
    /// `cache.uniforms`: [`GpuCacheUniforms`].
    pub uniforms: wgpu::Buffer,
    /// `cache.link`: brick ID per level and brick slot.
    pub link: wgpu::Buffer,
    /// `cache.group_masks`: occupied-brick mask per level and group slot.
    pub group_masks: wgpu::Buffer,
    /// `cache.brick_masks`: voxel occupancy per brick ID.
    pub brick_masks: wgpu::Buffer,
    /// `cache.voxels`: [`VoxelSurface`] per voxel of every pooled brick.
    pub voxels: wgpu::Buffer,
    /// `cache.direct`: direct irradiance per voxel side.
    pub direct: wgpu::Buffer,
    /// `cache.indirect`: indirect irradiance per voxel side.
    pub indirect: wgpu::Buffer,
    /// `cache.emitted`: per voxel side, the part of `indirect` that emissive triangles give
    /// directly (next-event samples), accumulated alongside it; a 4-byte placeholder unless
    /// [`CacheConfig::keep_emitted`].
    pub emitted: wgpu::Buffer,
    /// The eight buffers bound as `shaders/cache/data.wgsl` declares them.
    pub bind_group: wgpu::BindGroup,
}

/// Usage of every cache storage buffer.
const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_DST)
    .union(wgpu::BufferUsages::COPY_SRC);

impl CacheBuffers {
    /// The bind group index `gi::cache::data` declares.
    pub const BIND_GROUP: u32 = 2;

    /// Storage buffers of the bind group (bindings 1 to 7).
    pub const STORAGE_BUFFERS: u32 = 7;

    /// The layout of bind group 2: a uniform at binding 0 and seven read-write storage buffers,
    /// visible to compute stages.
    pub fn bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        let mut entries = vec![uniform_entry(0)];
        entries.extend((1..=Self::STORAGE_BUFFERS).map(|binding| storage_entry(binding, false)));
        ctx.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cache.bind_group_layout"),
                entries: &entries,
            })
    }

    /// Bytes of each buffer for `config`, in binding order (uniforms first).
    pub fn sizes(config: &CacheConfig) -> [u64; 8] {
        let levels = u64::from(config.levels);
        let ids = u64::from(config.pool_bricks) + 1;
        let voxels = ids * u64::from(VOXELS_PER_BRICK);
        [
            size_of::<GpuCacheUniforms>() as u64,
            levels * u64::from(config.bricks_per_level()) * 4,
            levels * u64::from(config.groups_per_level()) * 8,
            ids * 8,
            voxels * size_of::<VoxelSurface>() as u64,
            voxels * u64::from(SIDE_COUNT) * 4,
            voxels * u64::from(SIDE_COUNT) * 4,
            if config.keep_emitted {
                voxels * u64::from(SIDE_COUNT) * 4
            } else {
                4
            },
        ]
    }

    /// Zero-filled buffers (an empty cache: every link 0) for `config`. The caller has
    /// checked the sizes against the device's limits (`RadianceCache::new` does).
    pub fn new(ctx: &GpuContext, config: &CacheConfig) -> Self {
        let [
            uniform_bytes,
            link,
            group_masks,
            brick_masks,
            voxels,
            direct,
            indirect,
            emitted,
        ] = Self::sizes(config);
        let uniforms = ctx.create_buffer(
            "cache.uniforms",
            uniform_bytes,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let storage = |label, bytes| ctx.create_buffer(label, bytes, STORAGE);
        let link = storage("cache.link", link);
        let group_masks = storage("cache.group_masks", group_masks);
        let brick_masks = storage("cache.brick_masks", brick_masks);
        let voxels = storage("cache.voxels", voxels);
        let direct = storage("cache.direct", direct);
        let indirect = storage("cache.indirect", indirect);
        let emitted = storage("cache.emitted", emitted);
        let layout = Self::bind_group_layout(ctx);
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache.bind_group"),
            layout: &layout,
            entries: &[
                &uniforms,
                &link,
                &group_masks,
                &brick_masks,
                &voxels,
                &direct,
                &indirect,
                &emitted,
            ]
            .iter()
            .zip(0..)
            .map(|(buffer, binding)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect::<Vec<_>>(),
        });
        Self {
            uniforms,
            link,
            group_masks,
            brick_masks,
            voxels,
            direct,
            indirect,
            emitted,
            bind_group,
        }
    }

    /// Writes the uniforms through the queue.
    pub fn write_uniforms(&self, ctx: &GpuContext, uniforms: &GpuCacheUniforms) {
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(uniforms));
    }

    /// Uploads the slots of `structure` changed since the last upload (link grid, group masks
    /// and, when marked, brick masks) and clears its dirty ranges. Returns the bytes written.
    pub fn upload_structure(&self, ctx: &GpuContext, structure: &mut CacheStructure) -> u64 {
        let mut bytes = 0;
        if let Some(range) = structure.dirty_link.take() {
            let data: &[u8] = bytemuck::cast_slice(&structure.link[range.clone()]);
            ctx.queue
                .write_buffer(&self.link, range.start as u64 * 4, data);
            bytes += data.len() as u64;
        }
        for (dirty, masks, buffer) in [
            (
                &mut structure.dirty_group_masks,
                &structure.group_masks,
                &self.group_masks,
            ),
            (
                &mut structure.dirty_brick_masks,
                &structure.brick_masks,
                &self.brick_masks,
            ),
        ] {
            if let Some(range) = dirty.take() {
                let words: Vec<[u32; 2]> = masks[range.clone()]
                    .iter()
                    .map(|&m| split_mask(m))
                    .collect();
                let data: &[u8] = bytemuck::cast_slice(&words);
                ctx.queue.write_buffer(buffer, range.start as u64 * 8, data);
                bytes += data.len() as u64;
            }
        }
        bytes
    }

    /// Bytes of all eight buffers.
    pub fn bytes(&self) -> u64 {
        [
            &self.uniforms,
            &self.link,
            &self.group_masks,
            &self.brick_masks,
            &self.voxels,
            &self.direct,
            &self.indirect,
            &self.emitted,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }

    /// Reads the brick masks back (stalls; for tests and tools).
    pub fn read_brick_masks(&self, ctx: &GpuContext) -> Vec<u64> {
        ctx.read_buffer::<[u32; 2]>(&self.brick_masks)
            .into_iter()
            .map(join_mask)
            .collect()
    }

    /// Reads the voxel surfaces back (stalls; for tests and tools).
    pub fn read_voxels(&self, ctx: &GpuContext) -> Vec<VoxelSurface> {
        ctx.read_buffer(&self.voxels)
    }

    /// Stops counting and destroys every buffer.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.uniforms,
            &self.link,
            &self.group_masks,
            &self.brick_masks,
            &self.voxels,
            &self.direct,
            &self.indirect,
            &self.emitted,
        ] {
            ctx.release_buffer(buffer);
        }
    }
}

/// The uniforms for `config` with the windows `windows` at update `frame_index`.
pub fn cache_uniforms(
    config: &CacheConfig,
    windows: &ClipmapWindows,
    frame_index: u32,
) -> GpuCacheUniforms {
    let mut uniforms = GpuCacheUniforms {
        level_bricks: config.level_bricks,
        level_count: config.levels,
        bricks_per_level: config.bricks_per_level(),
        groups_per_level: config.groups_per_level(),
        pool_bricks: config.pool_bricks,
        frame_index,
        ..Default::default()
    };
    for (level, origin) in windows.origins.iter().enumerate() {
        uniforms.levels[level] = GpuCacheLevel {
            origin_brick: origin.to_array(),
            voxel_size_m: config.voxel_size_at(level as u32),
        };
    }
    uniforms
}

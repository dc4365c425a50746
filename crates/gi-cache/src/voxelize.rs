//! Pass `cache/voxelize` (`shaders/cache/voxelize.wgsl`): fills the pooled bricks the CPU
//! chose with the triangles it binned to them, one 64-thread workgroup per brick.
//!
//! The CPU side ([`crate::RadianceCache`]) decides which bricks to fill, allocates their IDs
//! and links them; this pass writes their surfaces, occupancy masks and zeroed side
//! irradiances. The rules are [`crate::cpu_voxelize`]'s, which the tests hold it to.
//!
//! Group 0: binding 0 the pass uniforms, bindings 1..=7 the scene (`gi::scene`, from
//! [`GpuScene::buffers`]), binding 8 the jobs, binding 9 the binned triangle references.
//! Group 2: the cache ([`CacheBuffers`]). Memory: `cache.voxelize_*`, 32 bytes per job and 4
//! per binned triangle, grown on demand.

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, ShaderLibrary, wgpu};
use glam::IVec3;

use crate::buffers::CacheBuffers;

/// Bricks per dispatch at most (the limit of one dispatch dimension).
const MAX_JOBS_PER_DISPATCH: usize = 65_535;

/// Uniforms of `cache/voxelize` (`VoxelizeUniforms` in WGSL), 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelizeUniforms {
    /// Index of the scene's appended default material.
    pub default_material: u32,
    /// Jobs in this dispatch.
    pub job_count: u32,
    pub pad: [u32; 2],
}

/// One brick to fill (`VoxelizeJob` in WGSL), 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVoxelizeJob {
    /// World brick coordinate.
    pub brick: [i32; 3],
    /// Level of the brick (its voxel size).
    pub level: u32,
    /// Pool ID to write.
    pub brick_id: u32,
    /// First entry of the brick's list in the triangle-reference buffer.
    pub first_triangle: u32,
    /// Entries in the brick's list.
    pub triangle_count: u32,
    pub pad: u32,
}

/// A brick to voxelize, as the CPU hands it over.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelizeJob {
    pub level: u32,
    /// World brick coordinate.
    pub brick: IVec3,
    /// Pool ID the brick is linked to.
    pub id: u32,
    /// Binned triangle references ([`crate::binning`]).
    pub triangles: Vec<u32>,
}

/// The voxelization pass: its pipeline and its growing upload buffers.
pub struct Voxelizer {
    /// Entry point `voxelize` of `cache/voxelize.wgsl`.
    voxelize: wgpu::ComputePipeline,
    frame_layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    jobs: wgpu::Buffer,
    triangles: wgpu::Buffer,
}

impl Voxelizer {
    /// Compiles `cache/voxelize`.
    pub fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "cache/voxelize.wgsl", &[])?;
        // Explicit: the pass uses only some scene bindings, which an automatic layout drops.
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.extend([storage_entry(8, true), storage_entry(9, true)]);
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cache/voxelize.frame_layout"),
                entries: &entries,
            });
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let voxelize = ctx.create_compute_pipeline_with_layouts(
            "cache/voxelize",
            &module,
            "voxelize",
            &[
                Some(&frame_layout),
                None,
                Some(&cache_layout),
                Some(&texture_layout),
            ],
        );
        Ok(Self {
            voxelize,
            frame_layout,
            uniforms: ctx.create_buffer(
                "cache.voxelize_uniforms",
                size_of::<VoxelizeUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            jobs: Self::storage(ctx, "cache.voxelize_jobs", 32),
            triangles: Self::storage(ctx, "cache.voxelize_triangles", 4),
        })
    }

    fn storage(ctx: &GpuContext, label: &str, bytes: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            label,
            bytes.max(4),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    /// Records `cache/voxelize` for `jobs` (at most 65535; the caller's budget keeps it far
    /// below) into `encoder`, timed by `timer`. Uploads through the queue, so record one
    /// voxelization per submission.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut GpuTimer,
        scene: &GpuScene,
        cache: &CacheBuffers,
        jobs: &[VoxelizeJob],
    ) {
        if jobs.is_empty() {
            return;
        }
        assert!(
            jobs.len() <= MAX_JOBS_PER_DISPATCH,
            "too many bricks in one dispatch"
        );
        let mut references = Vec::new();
        let gpu_jobs: Vec<GpuVoxelizeJob> = jobs
            .iter()
            .map(|job| {
                let first_triangle = references.len() as u32;
                references.extend_from_slice(&job.triangles);
                GpuVoxelizeJob {
                    brick: job.brick.to_array(),
                    level: job.level,
                    brick_id: job.id,
                    first_triangle,
                    triangle_count: job.triangles.len() as u32,
                    pad: 0,
                }
            })
            .collect();
        ctx.write_growing(
            &mut self.jobs,
            "cache.voxelize_jobs",
            bytemuck::cast_slice(&gpu_jobs),
        );
        ctx.write_growing(
            &mut self.triangles,
            "cache.voxelize_triangles",
            bytemuck::cast_slice(&references),
        );
        let uniforms = VoxelizeUniforms {
            default_material: scene.default_material,
            job_count: jobs.len() as u32,
            pad: [0; 2],
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));

        let mut entries = buffer_entries(0, [&self.uniforms]);
        entries.extend(scene.bind_group_entries());
        entries.extend(buffer_entries(8, [&self.jobs, &self.triangles]));
        let frame_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache/voxelize.frame"),
            layout: &self.frame_layout,
            entries: &entries,
        });
        timer.compute_pass(ctx, encoder, "cache/voxelize", |pass| {
            pass.set_pipeline(&self.voxelize);
            pass.set_bind_group(0, &frame_group, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, &cache.bind_group, &[]);
            scene.set_texture_bind_group(pass);
            pass.dispatch_workgroups(jobs.len() as u32, 1, 1);
        });
    }

    /// Stops counting and destroys the pass's buffers.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [&self.uniforms, &self.jobs, &self.triangles] {
            ctx.release_buffer(buffer);
        }
    }
}

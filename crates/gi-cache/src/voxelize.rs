//! Pass `cache/voxelize` (`shaders/cache/voxelize.wgsl`): fills the pooled bricks the CPU
//! chose with the triangles it binned to them.
//!
//! The CPU side ([`crate::RadianceCache`]) decides which bricks to fill, allocates their IDs
//! and links them; this pass writes their surfaces, occupancy masks and zeroed side
//! irradiances. The rules are [`crate::cpu_voxelize`]'s, which the tests hold it to.
//!
//! A brick's triangle list is cut into parts of at most
//! [`CacheConfig::voxelize_part_triangles`](crate::CacheConfig::voxelize_part_triangles)
//! entries, each voxelized by its own workgroup, and the parts are merged per brick in list
//! order: a coarse brick that lists a hundred thousand triangles spreads over the whole GPU
//! instead of running on one workgroup (one thread per voxel, which walks the whole list).
//! Four dispatches (`gather`, `resolve`, `project`, `finish`), one 64-thread workgroup per part
//! or per brick.
//!
//! Group 0: binding 0 the pass uniforms, bindings 1..=7 the scene (`gi::scene`, from
//! [`GpuScene::buffers`]), binding 8 the bricks, binding 9 the binned triangle references,
//! binding 10 the parts, binding 11 the records (64 bytes per voxel of every part and brick).
//! Group 2: the cache ([`CacheBuffers`]). Memory: `cache.voxelize_*`, 32 bytes per brick, 16
//! per part, 4 per binned triangle and 4 KiB of records per part and per brick, grown on
//! demand.

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, ShaderLibrary, wgpu};
use glam::IVec3;

use crate::buffers::CacheBuffers;

/// Workgroups per row of a dispatch (`DISPATCH_WIDTH` in WGSL); more take further rows.
const DISPATCH_WIDTH: u32 = 32_768;

/// Bytes of the records of one part or one brick: 64 voxels of 64 bytes (`VoxelPartial`).
const RECORD_BYTES: u64 = 64 * 64;

/// Bytes of a [`GpuVoxelizeJob`] and a [`GpuVoxelizePart`].
const JOB_BYTES: u64 = size_of::<GpuVoxelizeJob>() as u64;
const PART_BYTES: u64 = size_of::<GpuVoxelizePart>() as u64;

/// Most records [`Voxelizer::reserve`] sets aside ahead of use (16 MiB); a batch beyond it grows
/// the buffer when it comes.
const RESERVED_RECORDS_MAX: u64 = 4096;

/// Uniforms of `cache/voxelize` (`VoxelizeUniforms` in WGSL), 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelizeUniforms {
    /// Index of the scene's appended default material.
    pub default_material: u32,
    /// Bricks in this voxelization.
    pub job_count: u32,
    /// Parts of their triangle lists.
    pub part_count: u32,
    pub pad: u32,
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
    /// The brick's first part.
    pub first_part: u32,
    /// Its parts (at least one, also for an empty list).
    pub part_count: u32,
    pub pad: u32,
}

/// A run of a brick's triangle list (`VoxelizePart` in WGSL), 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVoxelizePart {
    /// The brick ([`GpuVoxelizeJob`] index).
    pub job: u32,
    /// First entry of the run in the triangle-reference buffer.
    pub first_triangle: u32,
    /// Entries in the run.
    pub triangle_count: u32,
    pub pad: u32,
}

/// Bricks and parts of one voxelization, as uploaded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VoxelizePlan {
    pub jobs: Vec<GpuVoxelizeJob>,
    pub parts: Vec<GpuVoxelizePart>,
    /// The bricks' lists one after another.
    pub references: Vec<u32>,
    /// Triangles per part this plan used: the configured size, doubled until the records fit
    /// the device's largest storage binding.
    pub part_triangles: u32,
}

impl VoxelizePlan {
    /// Cuts the lists of `jobs` into parts of at most `part_triangles` entries (at least one
    /// part per brick), doubling the size while the records would exceed `max_records` (parts
    /// plus bricks). `jobs` must hold at most `max_records / 2` bricks.
    pub fn new(jobs: &[VoxelizeJob], part_triangles: u32, max_records: u64) -> Self {
        let mut size = u64::from(part_triangles.max(1));
        let parts_at = |size: u64| -> u64 {
            jobs.iter()
                .map(|job| (job.triangles.len() as u64).div_ceil(size).max(1))
                .sum()
        };
        while parts_at(size) + jobs.len() as u64 > max_records && size < u64::from(u32::MAX) {
            size *= 2;
        }
        let size = size.min(u64::from(u32::MAX)) as usize;
        let mut plan = Self {
            part_triangles: size as u32,
            ..Self::default()
        };
        for (index, job) in jobs.iter().enumerate() {
            let first_triangle = plan.references.len() as u32;
            plan.references.extend_from_slice(&job.triangles);
            let first_part = plan.parts.len() as u32;
            let mut start = 0;
            loop {
                let count = (job.triangles.len() - start).min(size);
                plan.parts.push(GpuVoxelizePart {
                    job: index as u32,
                    first_triangle: first_triangle + start as u32,
                    triangle_count: count as u32,
                    pad: 0,
                });
                start += count;
                if start >= job.triangles.len() {
                    break;
                }
            }
            plan.jobs.push(GpuVoxelizeJob {
                brick: job.brick.to_array(),
                level: job.level,
                brick_id: job.id,
                first_part,
                part_count: plan.parts.len() as u32 - first_part,
                pad: 0,
            });
        }
        plan
    }
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

/// The voxelization pass: its pipelines and its growing buffers.
pub struct Voxelizer {
    /// Entry points `gather`, `resolve`, `project`, `finish` of `cache/voxelize.wgsl`.
    stages: [(wgpu::ComputePipeline, Stage); 4],
    frame_layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    jobs: wgpu::Buffer,
    triangles: wgpu::Buffer,
    parts: wgpu::Buffer,
    records: wgpu::Buffer,
    part_triangles: u32,
    /// Records (parts plus bricks) the device's largest storage binding holds.
    max_records: u64,
}

/// What a dispatch of the pass runs over.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    Parts,
    Bricks,
}

impl Voxelizer {
    /// Compiles `cache/voxelize`; lists are cut into parts of `part_triangles` entries
    /// ([`CacheConfig::voxelize_part_triangles`](crate::CacheConfig::voxelize_part_triangles)).
    pub fn new(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        part_triangles: u32,
    ) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "cache/voxelize.wgsl", &[])?;
        // Explicit: the pass uses only some scene bindings, which an automatic layout drops.
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.extend([
            storage_entry(8, true),
            storage_entry(9, true),
            storage_entry(10, true),
            storage_entry(11, false),
        ]);
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cache/voxelize.frame_layout"),
                entries: &entries,
            });
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let stage = |entry: &str, over: Stage| {
            let pipeline = ctx.create_compute_pipeline_with_layouts(
                &format!("cache/voxelize.{entry}"),
                &module,
                entry,
                &[
                    Some(&frame_layout),
                    None,
                    Some(&cache_layout),
                    Some(&texture_layout),
                ],
            );
            (pipeline, over)
        };
        let stages = [
            stage("gather", Stage::Parts),
            stage("resolve", Stage::Bricks),
            stage("project", Stage::Parts),
            stage("finish", Stage::Bricks),
        ];
        let binding = ctx
            .limits
            .max_storage_buffer_binding_size
            .min(ctx.limits.max_buffer_size);
        Ok(Self {
            stages,
            frame_layout,
            uniforms: ctx.create_buffer(
                "cache.voxelize_uniforms",
                size_of::<VoxelizeUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            jobs: Self::storage(ctx, "cache.voxelize_jobs", 32),
            triangles: Self::storage(ctx, "cache.voxelize_triangles", 4),
            parts: Self::storage(ctx, "cache.voxelize_parts", 16),
            records: Self::storage(ctx, "cache.voxelize_records", RECORD_BYTES),
            part_triangles: part_triangles.max(1),
            max_records: binding / RECORD_BYTES,
        })
    }

    /// Bricks one voxelization takes at most: each needs the records of one part and its own
    /// within the device's largest storage binding (16,383 at 128 MiB), and a dispatch's rows.
    pub fn max_jobs(&self) -> usize {
        (self.max_records / 2).min(u64::from(DISPATCH_WIDTH) * 1024) as usize
    }

    /// Grows the buffers to hold a batch of `bricks` bricks with `references` triangle
    /// references in all (at most [`RESERVED_RECORDS_MAX`] records' worth), so that batches
    /// within the cache's per-frame budgets never create a buffer mid-flight: a buffer created
    /// while flying cost a frame 4-6 ms of CPU (H100, 2026-12-07), the worst of the run.
    pub fn reserve(&mut self, ctx: &GpuContext, bricks: u64, references: u64) {
        let size = u64::from(self.part_triangles);
        let references = references.min(RESERVED_RECORDS_MAX * size);
        let bricks = bricks.min(self.max_jobs() as u64).min(RESERVED_RECORDS_MAX);
        // Each brick has at least one part, and a record per part and per brick.
        let parts = references.div_ceil(size) + bricks;
        let records = (parts + bricks)
            .min(RESERVED_RECORDS_MAX)
            .min(self.max_records);
        for (buffer, label, bytes) in [
            (&mut self.jobs, "cache.voxelize_jobs", bricks * JOB_BYTES),
            (
                &mut self.triangles,
                "cache.voxelize_triangles",
                references * 4,
            ),
            (&mut self.parts, "cache.voxelize_parts", parts * PART_BYTES),
            (
                &mut self.records,
                "cache.voxelize_records",
                records * RECORD_BYTES,
            ),
        ] {
            if bytes > buffer.size() {
                let usage = buffer.usage();
                ctx.release_buffer(buffer);
                *buffer = ctx.create_buffer(label, bytes.next_power_of_two(), usage);
            }
        }
    }

    fn storage(ctx: &GpuContext, label: &str, bytes: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            label,
            bytes.max(4),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    /// Records `cache/voxelize` for the first [`Voxelizer::max_jobs`] of `jobs` (the cache
    /// never passes more) into `encoder`, timed by `timer`, and returns the plan it uploaded.
    /// Uploads through the queue, so record one voxelization per submission.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut GpuTimer,
        scene: &GpuScene,
        cache: &CacheBuffers,
        jobs: &[VoxelizeJob],
    ) -> VoxelizePlan {
        let jobs = &jobs[..jobs.len().min(self.max_jobs())];
        if jobs.is_empty() {
            return VoxelizePlan::default();
        }
        let plan = VoxelizePlan::new(jobs, self.part_triangles, self.max_records);
        ctx.write_growing(
            &mut self.jobs,
            "cache.voxelize_jobs",
            bytemuck::cast_slice(&plan.jobs),
        );
        ctx.write_growing(
            &mut self.triangles,
            "cache.voxelize_triangles",
            bytemuck::cast_slice(&plan.references),
        );
        ctx.write_growing(
            &mut self.parts,
            "cache.voxelize_parts",
            bytemuck::cast_slice(&plan.parts),
        );
        let records = (plan.parts.len() + plan.jobs.len()) as u64 * RECORD_BYTES;
        if records > self.records.size() {
            let usage = self.records.usage();
            ctx.release_buffer(&self.records);
            let size = records
                .next_power_of_two()
                .min(self.max_records * RECORD_BYTES);
            self.records = ctx.create_buffer("cache.voxelize_records", size, usage);
        }
        let uniforms = VoxelizeUniforms {
            default_material: scene.default_material,
            job_count: plan.jobs.len() as u32,
            part_count: plan.parts.len() as u32,
            pad: 0,
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));

        let mut entries = buffer_entries(0, [&self.uniforms]);
        entries.extend(scene.bind_group_entries());
        entries.extend(buffer_entries(
            8,
            [&self.jobs, &self.triangles, &self.parts, &self.records],
        ));
        let frame_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache/voxelize.frame"),
            layout: &self.frame_layout,
            entries: &entries,
        });
        timer.compute_pass(ctx, encoder, "cache/voxelize", |pass| {
            pass.set_bind_group(0, &frame_group, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, &cache.bind_group, &[]);
            scene.set_texture_bind_group(pass);
            for (pipeline, over) in &self.stages {
                let count = match over {
                    Stage::Parts => uniforms.part_count,
                    Stage::Bricks => uniforms.job_count,
                };
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(
                    count.min(DISPATCH_WIDTH),
                    count.div_ceil(DISPATCH_WIDTH),
                    1,
                );
            }
        });
        plan
    }

    /// Stops counting and destroys the pass's buffers.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.uniforms,
            &self.jobs,
            &self.triangles,
            &self.parts,
            &self.records,
        ] {
            ctx.release_buffer(buffer);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(id: u32, triangles: u32) -> VoxelizeJob {
        VoxelizeJob {
            level: 0,
            brick: IVec3::new(id as i32, 0, 0),
            id,
            triangles: (0..triangles).map(|t| id * 1000 + t).collect(),
        }
    }

    #[test]
    fn lists_are_cut_into_runs_in_order_and_empty_lists_get_one_part() {
        let jobs = [job(1, 7), job(2, 0), job(3, 3)];
        let plan = VoxelizePlan::new(&jobs, 3, 1 << 20);
        assert_eq!(plan.part_triangles, 3);
        let runs: Vec<(u32, u32, u32)> = plan
            .parts
            .iter()
            .map(|p| (p.job, p.first_triangle, p.triangle_count))
            .collect();
        assert_eq!(
            runs,
            [(0, 0, 3), (0, 3, 3), (0, 6, 1), (1, 7, 0), (2, 7, 3)]
        );
        let spans: Vec<(u32, u32)> = plan
            .jobs
            .iter()
            .map(|j| (j.first_part, j.part_count))
            .collect();
        assert_eq!(spans, [(0, 3), (3, 1), (4, 1)]);
        assert_eq!(plan.references.len(), 10);
        assert_eq!(plan.references[7..], [3000, 3001, 3002]);
    }

    #[test]
    fn parts_grow_until_the_records_fit() {
        // 3 bricks of 100 entries: parts of 10 need 30 + 3 records, of 20 15 + 3, of 40 9 + 3;
        // parts of 80 (2 per brick) fit in 9.
        let jobs = [job(1, 100), job(2, 100), job(3, 100)];
        let plan = VoxelizePlan::new(&jobs, 10, 9);
        assert_eq!(plan.part_triangles, 80);
        assert_eq!(plan.parts.len() + plan.jobs.len(), 9);
        let plan = VoxelizePlan::new(&jobs, 10, 6);
        assert_eq!(plan.part_triangles, 160);
        assert_eq!(plan.parts.len(), 3);
    }
}

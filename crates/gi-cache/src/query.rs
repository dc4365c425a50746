//! Batches of queries through the cache: rays traced with the hierarchical DDA of
//! `shaders/cache/trace.wgsl` (import path `gi::cache::trace`) and irradiance at surface
//! points, one query per invocation of the passes of `shaders/cache/query/` (one file each).
//! Tests compare the hits with the scene's BVH; benchmarks time the rays; `gi debug-cache`
//! renders through the same shaders ([`crate::debug`]).
//!
//! Passes that trace the cache themselves import `gi::cache::trace::{CacheHit, cache_trace,
//! cache_hit_radiance, cache_hit_normal, cache_irradiance}` and bind the cache's
//! [`CacheBuffers::bind_group`] as bind group [`CacheBuffers::BIND_GROUP`].

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{storage_entry, uniform_entry};
use gi_gpu::bvh::GpuRay;
use gi_gpu::wgpu;
use gi_gpu::{GpuContext, GpuError, GpuTimer, PassTimings, ShaderLibrary, TimerMode};
use glam::Vec3;

use crate::buffers::CacheBuffers;

/// Bind group of the cache in every query pipeline.
pub(crate) const CACHE_BIND_GROUP: u32 = CacheBuffers::BIND_GROUP;

/// Invocations per workgroup of the batch entry points (`WORKGROUP_SIZE` in the shader).
const WORKGROUP_SIZE: u32 = 64;

/// Most workgroups along one dispatch dimension (the WebGPU minimum limit); larger batches
/// fold into rows.
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// Invocations per ray of `trace_rays_shared` (`CACHE_LANES` in
/// `shaders/cache/trace_shared.wgsl`).
pub const CACHE_LANES: u32 = 8;

/// One ray's answer as `trace_rays` writes it (`QueryHit` in `shaders/cache/query/shared.wgsl`,
/// 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCacheRayHit {
    /// Normal of the hit voxel on the side the ray sees.
    pub normal: [f32; 3],
    /// Distance along the ray to where it entered the hit voxel (`t_max` on a miss).
    pub t: f32,
    /// Radiance leaving the side the ray sees towards the ray, emission included.
    pub radiance: [f32; 3],
    /// Level of the hit voxel.
    pub level: u32,
    /// Face the ray entered through (0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z).
    pub face: u32,
    /// 1 on a hit, 0 on a miss.
    pub hit: u32,
    /// Pooled brick of the hit voxel (0 on a miss).
    pub brick_id: u32,
    /// Bit of the hit voxel in its brick.
    pub bit: u32,
    /// Side of the hit surfel the ray sees (0 front, 1 back; `gi_cache::layout`).
    pub side: u32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// One irradiance query as `irradiance_at` reads it (`IrradianceQuery`, 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuIrradianceQuery {
    /// World position of the surface point.
    pub position: [f32; 3],
    pub pad_a: f32,
    /// Unit surface normal there.
    pub normal: [f32; 3],
    pub pad_b: f32,
}

impl GpuIrradianceQuery {
    /// The queries of `(position, unit normal)` pairs.
    pub fn batch(points: &[(Vec3, Vec3)]) -> Vec<Self> {
        points
            .iter()
            .map(|(position, normal)| Self {
                position: position.to_array(),
                normal: normal.to_array(),
                ..Default::default()
            })
            .collect()
    }
}

/// What one ray found in the cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheRayHit {
    /// Whether the ray hit an occupied voxel before `t_max` and inside the coarsest window.
    pub hit: bool,
    /// Distance to where the ray entered the hit voxel: the surface lies inside that voxel, so
    /// this is early by at most the voxel's diagonal. `t_max` on a miss.
    pub t: f32,
    /// Level of the hit voxel.
    pub level: u32,
    /// Unit normal of the hit voxel's surface on the ray's side (zero on a miss).
    pub normal: Vec3,
    /// Radiance leaving the side the ray sees towards the ray, emission included (zero on a
    /// miss).
    pub radiance: Vec3,
    /// Axis face the ray entered the voxel through (0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z), for
    /// debugging.
    pub face: u32,
    /// Side of the hit surfel the ray sees: [`crate::layout::SIDE_FRONT`] when it arrives
    /// against the voxel's normal, else [`crate::layout::SIDE_BACK`].
    pub side: u32,
    /// Pooled brick ID and bit of the hit voxel (`(0, _)` on a miss).
    pub voxel: (u32, u32),
}

impl From<GpuCacheRayHit> for CacheRayHit {
    fn from(h: GpuCacheRayHit) -> Self {
        Self {
            hit: h.hit != 0,
            t: h.t,
            level: h.level,
            normal: Vec3::from(h.normal),
            radiance: Vec3::from(h.radiance),
            face: h.face,
            side: h.side,
            voxel: (h.brick_id, h.bit),
        }
    }
}

/// Median GPU time of a ray batch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheTraceTimings {
    /// Scope `cache/trace_rays` (one invocation per ray), milliseconds.
    pub trace_ms: f64,
    /// Scope `cache/trace_rays_shared` (`CACHE_LANES` invocations per ray, as the mobile
    /// tier's probes trace), milliseconds.
    pub shared_ms: f64,
    /// GPU timestamps, or CPU wall-clock time when the adapter has none.
    pub mode: TimerMode,
}

/// The pipelines of `shaders/cache/query/`, one per entry point, each from its own file and
/// with its own batch layout as bind group 0 and the cache as bind group `CACHE_BIND_GROUP`.
pub struct CacheTracer {
    /// Entry point `trace_rays` (timer scope `cache/trace_rays`).
    pub trace_rays: wgpu::ComputePipeline,
    /// Entry point `trace_rays_shared` (timer scope `cache/trace_rays_shared`).
    pub trace_rays_shared: wgpu::ComputePipeline,
    /// Entry point `irradiance_at` (timer scope `cache/irradiance_at`).
    pub irradiance_at: wgpu::ComputePipeline,
    /// Entry point `debug_view` (timer scope `cache/debug_view`).
    pub debug_view: wgpu::ComputePipeline,
    trace_rays_layout: wgpu::BindGroupLayout,
    irradiance_at_layout: wgpu::BindGroupLayout,
    pub(crate) debug_view_layout: wgpu::BindGroupLayout,
}

/// A batch bind group and the buffers it owns, released after use.
pub(crate) struct Batch {
    pub(crate) buffers: Vec<wgpu::Buffer>,
    pub(crate) bind_group: wgpu::BindGroup,
}

impl Batch {
    pub(crate) fn release(self, ctx: &GpuContext) {
        for buffer in &self.buffers {
            ctx.release_buffer(buffer);
        }
    }
}

/// Workgroups `(x, y)` covering `count` items of a one-dimensional batch.
fn batch_groups(count: usize) -> (u32, u32) {
    let groups = (count as u32).div_ceil(WORKGROUP_SIZE).max(1);
    let row = groups.min(MAX_GROUPS_PER_ROW);
    (row, groups.div_ceil(row))
}

impl CacheTracer {
    /// Composes the files of `cache/query/` and builds their four pipelines with explicit
    /// layouts: group 0 the batch, group [`CacheBuffers::BIND_GROUP`] the cache.
    pub fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries,
                })
        };
        let trace_rays_layout = layout(
            "cache.trace_rays_batch",
            &[storage_entry(0, true), storage_entry(1, false)],
        );
        let irradiance_at_layout = layout(
            "cache.irradiance_at_batch",
            &[storage_entry(2, true), storage_entry(3, false)],
        );
        let debug_view_layout = layout(
            "cache.debug_view_batch",
            &[uniform_entry(4), storage_entry(5, false)],
        );
        let pipeline = |entry_point: &str, batch_layout: &wgpu::BindGroupLayout| {
            let module =
                shaders.create_module(ctx, &format!("cache/query/{entry_point}.wgsl"), &[])?;
            let mut groups: Vec<Option<&wgpu::BindGroupLayout>> =
                vec![None; CACHE_BIND_GROUP as usize + 1];
            groups[0] = Some(batch_layout);
            groups[CACHE_BIND_GROUP as usize] = Some(&cache_layout);
            Ok::<_, GpuError>(ctx.create_compute_pipeline_with_layouts(
                &format!("cache/{entry_point}"),
                &module,
                entry_point,
                &groups,
            ))
        };
        Ok(Self {
            trace_rays: pipeline("trace_rays", &trace_rays_layout)?,
            trace_rays_shared: pipeline("trace_rays_shared", &trace_rays_layout)?,
            irradiance_at: pipeline("irradiance_at", &irradiance_at_layout)?,
            debug_view: pipeline("debug_view", &debug_view_layout)?,
            trace_rays_layout,
            irradiance_at_layout,
            debug_view_layout,
        })
    }

    /// Traces every ray through `cache` and reads the hits back, index-aligned with `rays`. Stalls the GPU; for tests and tools.
    pub fn trace(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        rays: &[GpuRay],
    ) -> Vec<CacheRayHit> {
        self.trace_with(ctx, cache, rays, false)
    }

    /// [`Self::trace`] with `CACHE_LANES` invocations per ray (`gi::cache::trace_shared`);
    /// the same hits.
    pub fn trace_shared(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        rays: &[GpuRay],
    ) -> Vec<CacheRayHit> {
        self.trace_with(ctx, cache, rays, true)
    }

    fn trace_with(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        rays: &[GpuRay],
        shared: bool,
    ) -> Vec<CacheRayHit> {
        if rays.is_empty() {
            return Vec::new();
        }
        let batch = self.ray_batch(ctx, rays);
        let mut encoder = ctx.create_encoder("cache.trace_rays");
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cache/trace_rays"),
                timestamp_writes: None,
            });
            self.record_trace(&mut pass, &batch, cache, rays.len(), shared);
        }
        ctx.submit_and_wait(encoder);
        let hits = ctx.read_buffer::<GpuCacheRayHit>(&batch.buffers[1]);
        batch.release(ctx);
        hits.into_iter().map(CacheRayHit::from).collect()
    }

    /// Dispatches `trace_rays` and `trace_rays_shared` over `rays` `repeats` times after one
    /// warm-up and returns their median times. The hits are not read back.
    pub fn time(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        rays: &[GpuRay],
        repeats: usize,
    ) -> CacheTraceTimings {
        let batch = self.ray_batch(ctx, rays);
        let mut timer = GpuTimer::new(ctx, "cache.timer", 2);
        let mut frames = Vec::with_capacity(repeats);
        for _ in 0..=repeats {
            let mut encoder = ctx.create_encoder("cache.time");
            for (scope, shared) in [
                ("cache/trace_rays", false),
                ("cache/trace_rays_shared", true),
            ] {
                timer.compute_pass(ctx, &mut encoder, scope, |pass| {
                    self.record_trace(pass, &batch, cache, rays.len(), shared);
                });
            }
            frames.push(timer.finish(ctx, encoder));
        }
        batch.release(ctx);
        let median = PassTimings::median(&frames[1..]);
        CacheTraceTimings {
            trace_ms: median.get("cache/trace_rays").unwrap_or(0.0),
            shared_ms: median.get("cache/trace_rays_shared").unwrap_or(0.0),
            mode: timer.mode(),
        }
    }

    /// Irradiance at each `(position, unit normal)` from `cache_irradiance`, or `None` where
    /// the cache has no voxel there. Stalls the GPU; for tests and tools.
    pub fn irradiance(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        points: &[(Vec3, Vec3)],
    ) -> Vec<Option<Vec3>> {
        if points.is_empty() {
            return Vec::new();
        }
        let queries = GpuIrradianceQuery::batch(points);
        let input = ctx.create_buffer_init(
            "cache.irradiance_points",
            bytemuck::cast_slice(&queries),
            wgpu::BufferUsages::STORAGE,
        );
        let output = ctx.create_buffer(
            "cache.irradiance",
            points.len() as u64 * 16,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let batch = self.batch(
            ctx,
            "cache.irradiance_at_batch",
            &self.irradiance_at_layout,
            2,
            input,
            output,
        );
        let mut encoder = ctx.create_encoder("cache.irradiance_at");
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cache/irradiance_at"),
                timestamp_writes: None,
            });
            let groups = batch_groups(points.len());
            pass.set_pipeline(&self.irradiance_at);
            pass.set_bind_group(0, &batch.bind_group, &[]);
            pass.set_bind_group(CACHE_BIND_GROUP, &cache.bind_group, &[]);
            pass.dispatch_workgroups(groups.0, groups.1, 1);
        }
        ctx.submit_and_wait(encoder);
        let values = ctx.read_buffer::<[f32; 4]>(&batch.buffers[1]);
        batch.release(ctx);
        values
            .into_iter()
            .map(|[r, g, b, found]| (found > 0.5).then_some(Vec3::new(r, g, b)))
            .collect()
    }

    fn ray_batch(&self, ctx: &GpuContext, rays: &[GpuRay]) -> Batch {
        let input = ctx.create_buffer_init(
            "cache.rays",
            bytemuck::cast_slice(rays),
            wgpu::BufferUsages::STORAGE,
        );
        let output = ctx.create_buffer(
            "cache.hits",
            (rays.len() * size_of::<GpuCacheRayHit>()) as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        self.batch(
            ctx,
            "cache.trace_rays_batch",
            &self.trace_rays_layout,
            0,
            input,
            output,
        )
    }

    /// A bind group of `input` at binding `first` and `output` at `first + 1`.
    fn batch(
        &self,
        ctx: &GpuContext,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        first: u32,
        input: wgpu::Buffer,
        output: wgpu::Buffer,
    ) -> Batch {
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: first,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: first + 1,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        Batch {
            buffers: vec![input, output],
            bind_group,
        }
    }

    fn record_trace(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        batch: &Batch,
        cache: &CacheBuffers,
        count: usize,
        shared: bool,
    ) {
        let (pipeline, invocations) = if shared {
            (&self.trace_rays_shared, count * CACHE_LANES as usize)
        } else {
            (&self.trace_rays, count)
        };
        let groups = batch_groups(invocations);
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &batch.bind_group, &[]);
        pass.set_bind_group(CACHE_BIND_GROUP, &cache.bind_group, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }
}

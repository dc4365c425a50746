//! Batches of rays through the GPU BVH: `shaders/bvh/trace_test.wgsl`, one ray per invocation.
//! Tests compare its hits with the CPU's ray by ray; benchmarks time it.

use crate::binding::storage_entry;
use crate::{GpuContext, GpuError, GpuTimer, PassTimings, ShaderLibrary, TimerMode};

use super::{BVH_BIND_GROUP, GpuBvh, GpuHit, GpuRay};

// The pipeline layout below lists the ray batch, then the BVH.
const _: () = assert!(BVH_BIND_GROUP == 1);

/// Invocations per workgroup of both entry points (`WORKGROUP_SIZE` in the shader).
const WORKGROUP_SIZE: u32 = 64;

/// Most workgroups along one dispatch dimension (the WebGPU minimum limit, so every adapter
/// takes it); larger batches fold into rows.
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// The two ray-batch passes: `closest` (nearest hit per ray, timer scope `bvh/closest`) and
/// `occluded` (any hit per ray, timer scope `bvh/occluded`).
pub struct BvhTracer {
    /// Entry point `closest`: writes one [`GpuHit`] per ray.
    pub closest: wgpu::ComputePipeline,
    /// Entry point `occluded`: writes 1 (blocked) or 0 per ray.
    pub occluded: wgpu::ComputePipeline,
    ray_batch_layout: wgpu::BindGroupLayout,
}

/// Per-ray answers of one batch, index-aligned with the rays.
#[derive(Clone, Debug, Default)]
pub struct TraceResults {
    /// Nearest hit of each ray.
    pub hits: Vec<GpuHit>,
    /// Whether anything blocks each ray.
    pub occluded: Vec<bool>,
}

/// Median milliseconds of the two passes over repeated dispatches of one batch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceTimings {
    /// Scope `bvh/closest`.
    pub closest_ms: f64,
    /// Scope `bvh/occluded`.
    pub occluded_ms: f64,
    /// GPU timestamps, or CPU wall-clock time around each pass when the adapter has none
    /// (which adds submission overhead).
    pub mode: TimerMode,
}

/// The buffers of one batch, made once and reused by every dispatch of that batch.
struct Batch {
    rays: wgpu::Buffer,
    hits: wgpu::Buffer,
    occluded: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    groups: (u32, u32),
}

impl BvhTracer {
    /// Composes `bvh/trace_test.wgsl` and builds both pipelines with an explicit layout: group
    /// 0 the ray batch, group [`BVH_BIND_GROUP`] a [`GpuBvh`].
    pub fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "bvh/trace_test.wgsl", &[])?;
        let ray_batch_layout =
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("bvh.ray_batch_layout"),
                    entries: &[
                        storage_entry(0, true),
                        storage_entry(1, false),
                        storage_entry(2, false),
                    ],
                });
        let bvh_layout = GpuBvh::bind_group_layout(ctx);
        let pipeline = |entry_point: &str| {
            ctx.create_compute_pipeline_with_layouts(
                &format!("bvh/{entry_point}"),
                &module,
                entry_point,
                &[Some(&ray_batch_layout), Some(&bvh_layout)],
            )
        };
        Ok(Self {
            closest: pipeline("closest"),
            occluded: pipeline("occluded"),
            ray_batch_layout,
        })
    }

    /// Traces every ray for its nearest hit and for occlusion, and reads both back. Stalls
    /// the GPU; for tests and tools.
    pub fn trace(&self, ctx: &GpuContext, bvh: &GpuBvh, rays: &[GpuRay]) -> TraceResults {
        if rays.is_empty() {
            return TraceResults::default();
        }
        let batch = self.batch(ctx, rays);
        let mut encoder = ctx.create_encoder("bvh.trace");
        for (name, pipeline) in [
            ("bvh/closest", &self.closest),
            ("bvh/occluded", &self.occluded),
        ] {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(name),
                timestamp_writes: None,
            });
            self.record(&mut pass, pipeline, &batch, bvh);
        }
        ctx.submit_and_wait(encoder);
        let hits = ctx.read_buffer::<GpuHit>(&batch.hits);
        let occluded = ctx
            .read_buffer::<u32>(&batch.occluded)
            .into_iter()
            .map(|flag| flag != 0)
            .collect();
        batch.release(ctx);
        TraceResults { hits, occluded }
    }

    /// Dispatches both passes over `rays` `repeats` times (after one warm-up) and returns the
    /// median time of each. The results are not read back.
    pub fn time(
        &self,
        ctx: &GpuContext,
        bvh: &GpuBvh,
        rays: &[GpuRay],
        repeats: usize,
    ) -> TraceTimings {
        let batch = self.batch(ctx, rays);
        let mut timer = GpuTimer::new(ctx, "bvh.timer", 2);
        let mut frames = Vec::with_capacity(repeats);
        for _ in 0..=repeats {
            let mut encoder = ctx.create_encoder("bvh.time");
            for (name, pipeline) in [
                ("bvh/closest", &self.closest),
                ("bvh/occluded", &self.occluded),
            ] {
                timer.compute_pass(ctx, &mut encoder, name, |pass| {
                    self.record(pass, pipeline, &batch, bvh);
                });
            }
            frames.push(timer.finish(ctx, encoder));
        }
        batch.release(ctx);
        let median = PassTimings::median(&frames[1..]);
        TraceTimings {
            closest_ms: median.get("bvh/closest").unwrap_or(0.0),
            occluded_ms: median.get("bvh/occluded").unwrap_or(0.0),
            mode: timer.mode(),
        }
    }

    fn batch(&self, ctx: &GpuContext, rays: &[GpuRay]) -> Batch {
        let count = rays.len() as u64;
        let rays = ctx.create_buffer_init(
            "bvh.rays",
            bytemuck::cast_slice(rays),
            wgpu::BufferUsages::STORAGE,
        );
        let readable = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let hits = ctx.create_buffer("bvh.hits", count * size_of::<GpuHit>() as u64, readable);
        let occluded = ctx.create_buffer("bvh.occluded_flags", count * 4, readable);
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bvh.ray_batch"),
            layout: &self.ray_batch_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: rays.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: hits.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: occluded.as_entire_binding(),
                },
            ],
        });
        let groups = (count as u32).div_ceil(WORKGROUP_SIZE);
        let row = groups.min(MAX_GROUPS_PER_ROW);
        Batch {
            rays,
            hits,
            occluded,
            bind_group,
            groups: (row, groups.div_ceil(row)),
        }
    }

    fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &wgpu::ComputePipeline,
        batch: &Batch,
        bvh: &GpuBvh,
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &batch.bind_group, &[]);
        pass.set_bind_group(BVH_BIND_GROUP, &bvh.bind_group, &[]);
        pass.dispatch_workgroups(batch.groups.0, batch.groups.1, 1);
    }
}

impl Batch {
    fn release(self, ctx: &GpuContext) {
        ctx.release_buffer(&self.rays);
        ctx.release_buffer(&self.hits);
        ctx.release_buffer(&self.occluded);
    }
}

//! BVH ray tracing on the GPU: an obvhs compressed wide BVH (CWBVH) uploaded as-is and
//! traversed in WGSL (`shaders/bvh/cwbvh.wgsl`, import path `gi::bvh`), standing in for
//! hardware ray tracing.
//!
//! A pass that traces rays imports `gi::bvh::{Ray, Hit, trace_closest, trace_any}` and binds a
//! [`GpuBvh`] as bind group 1 (layout from [`GpuBvh::bind_group_layout`]):
//!
//! | binding | resource | contents |
//! |---|---|---|
//! | 0 | `bvh.nodes`, read-only storage | [`GpuCwBvhNode`], 80 bytes each, root first |
//! | 1 | `bvh.triangles`, read-only storage | [`GpuBvhTriangle`], 48 bytes each, in leaf order |
//!
//! [`BvhTracer`] runs batches of rays through it, for tests and benchmarks.

mod layout;
mod tracer;

pub use layout::{
    BVH_MISS, BVH_STACK_SIZE, BvhError, GpuBvhTriangle, GpuCwBvhNode, GpuHit, GpuRay, PackedBvh,
};
pub use tracer::{BvhTracer, TraceResults, TraceTimings};

use obvhs::{cwbvh::CwBvh, triangle::Triangle};

use crate::GpuContext;

/// Bind group index that `gi::bvh` declares its buffers in.
pub const BVH_BIND_GROUP: u32 = 1;

/// A CWBVH and its triangles in GPU storage buffers, with the bind group that exposes them to
/// `gi::bvh`. Memory: 80 bytes per node plus 48 per primitive (a primitive is a triangle as
/// the BVH leaves reference it; spatial splits may reference one triangle from several leaves).
pub struct GpuBvh {
    /// `bvh.nodes`: the nodes, root at index 0.
    pub nodes: wgpu::Buffer,
    /// `bvh.triangles`: triangle vertices and frame indices in leaf order.
    pub triangles: wgpu::Buffer,
    /// `bvh.bind_group`: both buffers, for [`BVH_BIND_GROUP`].
    pub bind_group: wgpu::BindGroup,
    /// Number of nodes uploaded (1 for an empty BVH, which has a single childless root).
    pub node_count: u32,
    /// Number of primitives uploaded.
    pub primitive_count: u32,
    /// Levels below the root of the deepest node; at most [`BVH_STACK_SIZE`].
    pub depth: u32,
}

impl GpuBvh {
    /// The layout of bind group [`BVH_BIND_GROUP`]: two read-only storage buffers visible to
    /// compute shaders. Layouts with equal entries are interchangeable, so pipelines made with
    /// one from this function accept the bind group of any `GpuBvh`.
    pub fn bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        ctx.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("bvh.bind_group_layout"),
                entries: &[storage(0), storage(1)],
            })
    }

    /// Packs `bvh`, built over `frame_triangles`, and uploads it. Cost: a copy of the nodes
    /// and one of the triangles in leaf order; no GPU work.
    ///
    /// Fails when the BVH is deeper than the traversal stack or larger than the device's
    /// storage binding limit (128 MiB on the software adapter: about 1.6 M nodes or 2.8 M
    /// primitives).
    pub fn upload(
        ctx: &GpuContext,
        bvh: &CwBvh,
        frame_triangles: &[Triangle],
    ) -> Result<Self, BvhError> {
        let packed = PackedBvh::new(bvh, frame_triangles)?;
        Self::upload_packed(ctx, &packed)
    }

    /// Uploads an already packed BVH (see [`GpuBvh::upload`]).
    pub fn upload_packed(ctx: &GpuContext, packed: &PackedBvh) -> Result<Self, BvhError> {
        let limit = ctx.limits.max_storage_buffer_binding_size;
        let node_bytes: &[u8] = bytemuck::cast_slice(&packed.nodes);
        let triangle_bytes: &[u8] = bytemuck::cast_slice(&packed.triangles);
        for (label, bytes) in [("bvh.nodes", node_bytes), ("bvh.triangles", triangle_bytes)] {
            if bytes.len() as u64 > limit {
                return Err(BvhError::TooLarge {
                    label,
                    bytes: bytes.len() as u64,
                    limit,
                });
            }
        }
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let nodes = ctx.create_buffer_init("bvh.nodes", node_bytes, usage);
        let triangles = ctx.create_buffer_init("bvh.triangles", triangle_bytes, usage);
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bvh.bind_group"),
            layout: &Self::bind_group_layout(ctx),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: triangles.as_entire_binding(),
                },
            ],
        });
        Ok(Self {
            nodes,
            triangles,
            bind_group,
            node_count: packed.nodes.len() as u32,
            primitive_count: packed.triangles.len() as u32,
            depth: packed.depth,
        })
    }

    /// Bytes of both buffers.
    pub fn bytes(&self) -> u64 {
        self.nodes.size() + self.triangles.size()
    }

    /// Stops counting and destroys both buffers (for a BVH replaced by a rebuild).
    pub fn release(self, ctx: &GpuContext) {
        ctx.release_buffer(&self.nodes);
        ctx.release_buffer(&self.triangles);
    }
}

//! The GPU refit of the deforming bottom levels (`shaders/bvh/refit.wgsl`): after
//! [`BottomLevels::refit_deforming`] has written a frame's vertices into their primitives, one
//! dispatch per depth, deepest first, gives every node of those levels new boxes.

use std::num::NonZeroU64;

use crate::binding::storage_entry;
use crate::{GpuContext, ShaderLibrary};

use super::layout::BvhError;
use super::levels::{BottomLevels, RefitPlan};

/// Bytes between two dispatches' uniforms: the largest `min_uniform_buffer_offset_alignment`
/// WebGPU allows, so it suits every device.
const STEP_STRIDE: u64 = 256;

/// Invocations per workgroup (`@workgroup_size` in the shader).
const WORKGROUP_SIZE: u32 = 64;

/// The uniforms of one dispatch (`Step` in the shader).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Step {
    first: u32,
    count: u32,
    node_base: u32,
    pad: u32,
}

/// The refit pipeline and the buffers of one [`RefitPlan`]: the node order, a uniform slot per
/// dispatch and two exact box corners per deforming node (32 bytes each).
pub(super) struct DeformRefit {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    steps: wgpu::Buffer,
    order: wgpu::Buffer,
    bounds: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Nodes of each dispatch, deepest first.
    counts: Vec<u32>,
}

impl DeformRefit {
    /// Compiles the refit shader and makes the buffers of `levels`' refit plan, bound to the
    /// BVH's `nodes` and `triangles`. Every size is checked against the device's limits first.
    pub(super) fn new(
        ctx: &GpuContext,
        levels: &BottomLevels,
        nodes: &wgpu::Buffer,
        triangles: &wgpu::Buffer,
    ) -> Result<Self, BvhError> {
        let module = ShaderLibrary::new()
            .create_module(ctx, "bvh/refit.wgsl", &[])
            .map_err(|err| BvhError::Shader {
                message: err.to_string(),
            })?;
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("bvh.refit.layout"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: true,
                            min_binding_size: NonZeroU64::new(size_of::<Step>() as u64),
                        },
                        count: None,
                    },
                    storage_entry(1, false),
                    storage_entry(2, true),
                    storage_entry(3, true),
                    storage_entry(4, false),
                ],
            });
        let pipeline = ctx.create_compute_pipeline_with_layouts(
            "bvh/refit",
            &module,
            "refit",
            &[Some(&layout)],
        );
        let (steps, order, bounds, counts) = Self::plan_buffers(ctx, levels)?;
        let bind_group =
            Self::bind_group(ctx, &layout, [&steps, nodes, triangles, &order, &bounds]);
        Ok(Self {
            pipeline,
            layout,
            steps,
            order,
            bounds,
            bind_group,
            counts,
        })
    }

    /// Takes `levels`' new refit plan (after a rebuild of the deforming levels) and the BVH's
    /// current `nodes` and `triangles` buffers.
    pub(super) fn replan(
        &mut self,
        ctx: &GpuContext,
        levels: &BottomLevels,
        nodes: &wgpu::Buffer,
        triangles: &wgpu::Buffer,
    ) -> Result<(), BvhError> {
        let (steps, order, bounds, counts) = Self::plan_buffers(ctx, levels)?;
        for old in [&self.steps, &self.order, &self.bounds] {
            ctx.release_buffer(old);
        }
        (self.steps, self.order, self.bounds, self.counts) = (steps, order, bounds, counts);
        self.bind_group = Self::bind_group(
            ctx,
            &self.layout,
            [&self.steps, nodes, triangles, &self.order, &self.bounds],
        );
        Ok(())
    }

    /// Records the refit's dispatches into `pass`: one per depth, deepest first (a pass orders
    /// its dispatches' storage writes before the next dispatch's reads).
    pub(super) fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        for (k, &count) in self.counts.iter().enumerate() {
            pass.set_bind_group(0, &self.bind_group, &[(k as u64 * STEP_STRIDE) as u32]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP_SIZE), 1, 1);
        }
    }

    /// Destroys the plan's buffers.
    pub(super) fn release(&self, ctx: &GpuContext) {
        for buffer in [&self.steps, &self.order, &self.bounds] {
            ctx.release_buffer(buffer);
        }
    }

    /// Bytes of the plan's buffers.
    pub(super) fn bytes(&self) -> u64 {
        self.steps.size() + self.order.size() + self.bounds.size()
    }

    #[allow(clippy::type_complexity)]
    fn plan_buffers(
        ctx: &GpuContext,
        levels: &BottomLevels,
    ) -> Result<(wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, Vec<u32>), BvhError> {
        let RefitPlan { order, steps } = levels.refit_plan();
        let (node_base, _) = levels.fixed_len();
        let region_nodes = (levels.nodes.len() - node_base).max(1) as u64;
        let limits = &ctx.limits;
        let checks = [
            ("bvh.refit.order", order.len().max(1) as u64 * 4),
            ("bvh.refit.bounds", region_nodes * 32),
        ];
        for (label, bytes) in checks {
            let limit = limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size);
            if bytes > limit {
                return Err(BvhError::TooLarge {
                    label,
                    bytes,
                    limit,
                });
            }
        }
        // Dispatches past the largest grid would need folding; a depth holds fewer nodes than
        // a level has primitives, so this only bounds absurd inputs.
        let most_groups = u64::from(limits.max_compute_workgroups_per_dimension);
        if let Some(&(_, count)) = steps
            .iter()
            .find(|&&(_, count)| u64::from(count.div_ceil(WORKGROUP_SIZE)) > most_groups)
        {
            return Err(BvhError::TooLarge {
                label: "bvh/refit dispatch (nodes of one depth)",
                bytes: u64::from(count),
                limit: most_groups * u64::from(WORKGROUP_SIZE),
            });
        }
        let mut step_bytes = vec![0u8; steps.len().max(1) * STEP_STRIDE as usize];
        for (k, &(first, count)) in steps.iter().enumerate() {
            let step = Step {
                first,
                count,
                node_base: node_base as u32,
                pad: 0,
            };
            let at = k * STEP_STRIDE as usize;
            step_bytes[at..at + size_of::<Step>()].copy_from_slice(bytemuck::bytes_of(&step));
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let order_bytes: &[u8] = if order.is_empty() {
            &[0; 4]
        } else {
            bytemuck::cast_slice(order)
        };
        Ok((
            ctx.create_buffer_init(
                "bvh.refit.steps",
                &step_bytes,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            ctx.create_buffer_init("bvh.refit.order", order_bytes, storage),
            ctx.create_buffer(
                "bvh.refit.bounds",
                region_nodes * 32,
                wgpu::BufferUsages::STORAGE,
            ),
            steps.iter().map(|&(_, count)| count).collect(),
        ))
    }

    fn bind_group(
        ctx: &GpuContext,
        layout: &wgpu::BindGroupLayout,
        buffers: [&wgpu::Buffer; 5],
    ) -> wgpu::BindGroup {
        let mut entries: Vec<_> = (buffers.iter().zip(0..))
            .map(|(buffer, binding)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        // The uniform slot is one step, at a dynamic offset.
        entries[0].resource = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: buffers[0],
            offset: 0,
            size: NonZeroU64::new(size_of::<Step>() as u64),
        });
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bvh.refit.bind_group"),
            layout,
            entries: &entries,
        })
    }
}

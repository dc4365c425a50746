//! BVH ray tracing on the GPU: a two-level obvhs compressed wide BVH (CWBVH) traversed in
//! WGSL (`shaders/bvh/cwbvh.wgsl`, import path `gi::bvh`), standing in for hardware ray
//! tracing.
//!
//! Bottom levels are built once per scene ([`BottomLevels`]: one world-space level over the
//! static geometry, one object-space level per mesh of a moving node or of many static copies,
//! see [`MeshSharing`]); a small top level over
//! their instances is rebuilt every frame ([`GpuBvh::update`]), so moving objects never force a
//! rebuild of their triangles.
//!
//! Deforming nodes (skinned meshes with animated joints, animated morph weights) are the
//! exception: each has a world-space level in a region at the end of `bvh.nodes` and
//! `bvh.triangles`, after the levels built once, which are not uploaded again. Each update
//! writes the frame's vertices into that region's primitives and refits the region's nodes on
//! the GPU (`bvh/refit`, one dispatch per depth, submitted before the frame's passes); when a
//! level's upper nodes (root, children, grandchildren) outgrow the pose it was built in by
//! [`DEFORMING_REBUILD_GROWTH`] in summed surface area, the levels are built again on the CPU
//! and the region is rewritten. The region has headroom ([`DEFORMING_HEADROOM`]); when a
//! rebuild outgrows it the two buffers are made again, larger, and so is the bind group.
//! Skinning itself runs on the CPU in `Scene::evaluate`.
//!
//! A pass that traces rays imports `gi::bvh::{Ray, Hit, trace_closest, trace_any}` and binds a
//! [`GpuBvh`] as bind group 1 (layout from [`GpuBvh::bind_group_layout`]):
//!
//! | binding | resource | contents |
//! |---|---|---|
//! | 0 | `bvh.nodes`, read-only storage | [`GpuCwBvhNode`] of every bottom level, 80 bytes each |
//! | 1 | `bvh.triangles`, read-only storage | [`GpuBvhTriangle`] of every bottom level, 48 bytes each, in leaf order |
//! | 2 | `bvh.top_nodes`, read-only storage | the top level's [`GpuCwBvhNode`]s, root first |
//! | 3 | `bvh.instances`, read-only storage | a 16-byte [`GpuBvhInstanceHeader`], then [`GpuBvhInstance`], 64 bytes each, in top-level leaf order |
//!
//! A static scene (its only instance the world-space static level) is traced without the top
//! level: the header names the static level's root and rays start there with the world ray
//! ([`GpuBvh::traces_static_directly`]), with the same hits as through the top level.
//!
//! [`BvhTracer`] runs batches of rays through it, for tests and benchmarks.

mod layout;
mod levels;
mod refit;
mod sharing;
mod tracer;

pub use layout::{
    BVH_INSTANCE_IDENTITY, BVH_INSTANCE_MIRRORED, BVH_MISS, BVH_NO_STATIC_ROOT, BVH_STACK_SIZE,
    BVH_TRIANGLE_ALPHA, BvhError, GpuBvhInstance, GpuBvhInstanceHeader, GpuBvhTriangle,
    GpuCwBvhNode, GpuHit, GpuRay, PackedBvh,
};
pub use levels::{BottomLevels, DeformUpdate, RefitPlan, TopLevel};
pub use sharing::MeshSharing;
pub use tracer::{BvhTracer, TraceResults, TraceTimings};

use std::time::Instant;

use gi_scene::{Scene, SceneFrame};
use obvhs::{cwbvh::CwBvh, triangle::Triangle};

use crate::binding::storage_entry;
use crate::{GpuContext, GpuTimer};
use refit::DeformRefit;

/// Bind group index that `gi::bvh` declares its buffers in.
pub const BVH_BIND_GROUP: u32 = 1;

/// Room reserved for the deforming levels, as a multiple of their size at upload (or at the
/// last growth): a rebuild's node count varies with the pose, and more room means fewer
/// reallocations (and bind group rebuilds) at the cost of idle memory in that region only.
pub const DEFORMING_HEADROOM: f64 = 1.5;

/// Growth of a deforming level's upper nodes (their summed surface area over that in the pose
/// it was built in; see [`BottomLevels::refit_deforming`]) past which an update builds the
/// deforming levels again instead of refitting them (see
/// [`GpuBvh::set_deforming_rebuild_growth`]).
pub const DEFORMING_REBUILD_GROWTH: f32 = 1.5;

/// A two-level CWBVH in GPU storage buffers, with the bind group that exposes it to
/// `gi::bvh`. Memory: 80 bytes per bottom-level node plus 48 per primitive (spatial splits may
/// reference one triangle from several leaves), plus 80 per top-level node, 64 per instance and
/// a 16-byte instance header.
pub struct GpuBvh {
    /// `bvh.nodes`: every bottom level's nodes. Written once, at upload, except the deforming
    /// levels' region at its end, rewritten by every update.
    pub nodes: wgpu::Buffer,
    /// `bvh.triangles`: every bottom level's primitives in leaf order. Written once, except
    /// the deforming levels' region.
    pub triangles: wgpu::Buffer,
    /// `bvh.top_nodes`: the top level, root at index 0; rewritten by [`GpuBvh::update`].
    pub top_nodes: wgpu::Buffer,
    /// `bvh.instances`: a [`GpuBvhInstanceHeader`], then the instances in top-level leaf
    /// order; rewritten by every update.
    pub instances: wgpu::Buffer,
    /// `bvh.bind_group`: the four buffers, for [`BVH_BIND_GROUP`]. Made again only when an
    /// update's top level outgrows `bvh.top_nodes` or its instances outgrow `bvh.instances`.
    pub bind_group: wgpu::BindGroup,
    /// Bottom-level nodes uploaded (1 for an empty scene: a single childless root), the
    /// current deforming levels included.
    pub node_count: u32,
    /// Bottom-level primitives uploaded, the current deforming levels included.
    pub primitive_count: u32,
    /// Levels below the root of the deepest bottom level.
    pub depth: u32,
    /// Nodes of the current top level.
    pub top_node_count: u32,
    /// Levels below the root of the current top level.
    pub top_depth: u32,
    /// Instances (the static level is one).
    pub instance_count: u32,
    /// Seconds of the CPU builds of every bottom level and their packing.
    pub build_seconds: f64,
    /// Seconds of the last update: the deforming levels' rebuild and upload (if any), the top
    /// level's build on the CPU, and queueing their uploads.
    pub update_seconds: f64,
    /// CPU seconds of the last update of the deforming levels (0 without them): writing the
    /// frame's vertices and recording the refit, or a rebuild and its upload.
    pub deform_seconds: f64,
    /// Updates that refit the deforming levels on the GPU.
    pub deform_refits: u32,
    /// Updates that built the deforming levels again.
    pub deform_rebuilds: u32,
    /// Times `bvh.nodes` and `bvh.triangles` were made again because the deforming levels
    /// outgrew their region.
    pub bottom_reallocations: u32,
    /// Top levels built so far (the upload's is the first).
    pub update_count: u32,
    levels: BottomLevels,
    /// The header of the last top level written.
    header: GpuBvhInstanceHeader,
    /// Root of the static level when it is the only instance of the last top level written.
    lone_static_root: Option<u32>,
    /// Whether a lone static instance may be traced directly (see
    /// [`GpuBvh::set_static_fast_path`]).
    static_fast_path: bool,
    /// The refit of the deforming levels (`None` without them).
    refit: Option<DeformRefit>,
    /// See [`GpuBvh::set_deforming_rebuild_growth`].
    rebuild_growth: f32,
}

impl GpuBvh {
    /// The layout of bind group [`BVH_BIND_GROUP`]: four read-only storage buffers visible to
    /// compute shaders. Layouts with equal entries are interchangeable, so pipelines made with
    /// one from this function accept the bind group of any `GpuBvh`.
    pub fn bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
        let storage = |binding| storage_entry(binding, true);
        ctx.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("bvh.bind_group_layout"),
                entries: &[storage(0), storage(1), storage(2), storage(3)],
            })
    }

    /// Builds every bottom level of `scene` (static geometry in world space, each moving
    /// node's mesh in object space) and the top level of `frame`, and uploads both. Cost: the
    /// triangle builds, once; later frames call [`GpuBvh::update`].
    pub fn from_scene(
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
    ) -> Result<Self, BvhError> {
        Self::from_scene_with(ctx, scene, frame, MeshSharing::default())
    }

    /// [`GpuBvh::from_scene`] with the given rule for sharing the levels of static meshes.
    pub fn from_scene_with(
        ctx: &GpuContext,
        scene: &Scene,
        frame: &SceneFrame,
        sharing: MeshSharing,
    ) -> Result<Self, BvhError> {
        let levels = BottomLevels::from_scene_with(scene, frame, sharing)?;
        Self::upload_levels(ctx, levels, &frame.world_from_node)
    }

    /// Uploads `bvh`, built over `frame_triangles`, as the only (static, world-space) bottom
    /// level: the plain single-BVH path, for tests and benchmarks. Cost: a copy of the nodes
    /// and one of the triangles in leaf order; no GPU work.
    ///
    /// Fails when the BVH is deeper than the traversal stack allows or larger than the
    /// device's storage binding limit (128 MiB on the software adapter: about 1.6 M nodes or
    /// 2.8 M primitives).
    pub fn upload(
        ctx: &GpuContext,
        bvh: &CwBvh,
        frame_triangles: &[Triangle],
    ) -> Result<Self, BvhError> {
        Self::upload_levels(ctx, BottomLevels::single(bvh, frame_triangles)?, &[])
    }

    /// Uploads built bottom levels and a top level placed with `world_from_node`.
    pub fn upload_levels(
        ctx: &GpuContext,
        levels: BottomLevels,
        world_from_node: &[glam::Mat4],
    ) -> Result<Self, BvhError> {
        let start = Instant::now();
        let top = levels.top_level(world_from_node)?;
        let (nodes, triangles) = Self::bottom_buffers(ctx, &levels)?;
        // A CWBVH has fewer internal nodes than leaves, so one node per instance always fits
        // the top level: the buffer never has to grow for a fixed set of instances.
        let top_capacity = top.nodes.len().max(levels.instance_count()).max(1) as u64;
        let top_nodes = Self::top_nodes_buffer(ctx, top_capacity);
        let instances = Self::instances_buffer(ctx, top.instances.len() as u64);
        let bind_group = Self::bind_group(ctx, [&nodes, &triangles, &top_nodes, &instances]);
        let refit = if levels.has_deforming() {
            Some(DeformRefit::new(ctx, &levels, &nodes, &triangles)?)
        } else {
            None
        };
        let build_seconds = levels.build_time.as_secs_f64() + start.elapsed().as_secs_f64();
        let mut bvh = Self {
            nodes,
            triangles,
            top_nodes,
            instances,
            bind_group,
            node_count: levels.nodes.len() as u32,
            primitive_count: levels.triangles.len() as u32,
            depth: levels.depth,
            top_node_count: 0,
            top_depth: 0,
            instance_count: levels.instance_count() as u32,
            build_seconds,
            update_seconds: 0.0,
            deform_seconds: 0.0,
            deform_refits: 0,
            deform_rebuilds: 0,
            bottom_reallocations: 0,
            update_count: 0,
            levels,
            header: GpuBvhInstanceHeader::default(),
            lone_static_root: None,
            static_fast_path: true,
            refit,
            rebuild_growth: DEFORMING_REBUILD_GROWTH,
        };
        bvh.write_top(ctx, top)?;
        Ok(bvh)
    }

    /// Places the instances at `frame`'s transforms: refits the deforming levels to its
    /// triangles (or builds them again, see [`DEFORMING_REBUILD_GROWTH`]) if the scene has any,
    /// rebuilds the top level, and uploads them with the new instance transforms. The levels
    /// built once are not touched. Cost: a write of 48 bytes per deforming primitive and the
    /// refit's dispatches, submitted here so that they precede the frame's passes (or a CWBVH
    /// build over the deforming triangles and a write of their region), then a CWBVH build
    /// over one box per instance and a write of 80 bytes per top-level node plus 64 per
    /// instance. `frame` must come from the scene the BVH was built for.
    pub fn update(&mut self, ctx: &GpuContext, frame: &SceneFrame) -> Result<(), BvhError> {
        self.update_with_timer(ctx, frame, None)
    }

    /// [`GpuBvh::update`] with the refit timed as pass `bvh/refit` of `timer`'s current frame
    /// (submitted through [`GpuTimer::submit`]; the caller's [`GpuTimer::finish`] reports it).
    pub fn update_timed(
        &mut self,
        ctx: &GpuContext,
        frame: &SceneFrame,
        timer: &mut GpuTimer,
    ) -> Result<(), BvhError> {
        self.update_with_timer(ctx, frame, Some(timer))
    }

    fn update_with_timer(
        &mut self,
        ctx: &GpuContext,
        frame: &SceneFrame,
        timer: Option<&mut GpuTimer>,
    ) -> Result<(), BvhError> {
        let start = Instant::now();
        let mut grown = false;
        if self.levels.has_deforming() {
            match self.levels.refit_deforming(frame, self.rebuild_growth)? {
                DeformUpdate::Refit => {
                    self.write_deformed_triangles(ctx);
                    if let Some(refit) = &self.refit {
                        let mut encoder = ctx.create_encoder("bvh.refit");
                        match timer {
                            Some(timer) => {
                                timer.compute_pass(ctx, &mut encoder, "bvh/refit", |pass| {
                                    refit.record(pass)
                                });
                                timer.submit(ctx, encoder);
                            }
                            None => {
                                let mut pass =
                                    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                                        label: Some("bvh/refit"),
                                        timestamp_writes: None,
                                    });
                                refit.record(&mut pass);
                                drop(pass);
                                ctx.queue.submit([encoder.finish()]);
                            }
                        }
                    }
                    self.deform_refits += 1;
                }
                DeformUpdate::Rebuilt => {
                    grown = self.write_deforming(ctx)?;
                    if let Some(refit) = &mut self.refit {
                        refit.replan(ctx, &self.levels, &self.nodes, &self.triangles)?;
                    }
                    self.deform_rebuilds += 1;
                }
            }
        }
        self.deform_seconds = start.elapsed().as_secs_f64();
        if grown {
            self.rebind(ctx);
        }
        let top = self.levels.top_level(&frame.world_from_node)?;
        self.write_top(ctx, top)?;
        self.update_seconds += self.deform_seconds;
        Ok(())
    }

    /// Sets the growth of a deforming level's upper nodes (summed surface area over that in the
    /// pose it was built in) past which an update builds the deforming levels again rather
    /// than refitting them; [`DEFORMING_REBUILD_GROWTH`] by default. `f32::INFINITY` always refits,
    /// 0 always rebuilds (the cost of a build per frame, the tightest boxes).
    pub fn set_deforming_rebuild_growth(&mut self, growth: f32) {
        self.rebuild_growth = growth;
    }

    /// Writes the deforming levels' primitives (the frame's vertices in their leaf order).
    fn write_deformed_triangles(&self, ctx: &GpuContext) {
        let (_, fixed_triangles) = self.levels.fixed_len();
        let bytes: &[u8] = bytemuck::cast_slice(&self.levels.triangles[fixed_triangles..]);
        let offset = (fixed_triangles * size_of::<GpuBvhTriangle>()) as u64;
        ctx.queue.write_buffer(&self.triangles, offset, bytes);
    }

    /// Creates `bvh.nodes` and `bvh.triangles` holding `levels`, with room for the deforming
    /// levels to grow by [`DEFORMING_HEADROOM`].
    fn bottom_buffers(
        ctx: &GpuContext,
        levels: &BottomLevels,
    ) -> Result<(wgpu::Buffer, wgpu::Buffer), BvhError> {
        let node_bytes: &[u8] = bytemuck::cast_slice(&levels.nodes);
        let triangle_bytes: &[u8] = bytemuck::cast_slice(&levels.triangles);
        let limit = ctx.limits.max_storage_buffer_binding_size;
        // Copyable, so that tests can read back what the refit wrote.
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        if !levels.has_deforming() {
            for (label, bytes) in [("bvh.nodes", node_bytes), ("bvh.triangles", triangle_bytes)] {
                check_size(label, bytes.len() as u64, limit)?;
            }
            return Ok((
                ctx.create_buffer_init("bvh.nodes", node_bytes, usage),
                ctx.create_buffer_init("bvh.triangles", triangle_bytes, usage),
            ));
        }
        let (fixed_nodes, fixed_triangles) = levels.fixed_len();
        let with_room = |label: &'static str, bytes: &[u8], fixed: usize, element: usize| {
            let fixed = (fixed * element) as u64;
            let deforming = bytes.len() as u64 - fixed;
            let size = fixed + (deforming as f64 * DEFORMING_HEADROOM).ceil() as u64;
            let size = size
                .max(bytes.len() as u64)
                .min(limit.max(bytes.len() as u64));
            check_size(label, bytes.len() as u64, limit)?;
            let buffer = ctx.create_buffer(label, size, usage);
            ctx.queue.write_buffer(&buffer, 0, bytes);
            Ok::<_, BvhError>(buffer)
        };
        Ok((
            with_room(
                "bvh.nodes",
                node_bytes,
                fixed_nodes,
                size_of::<GpuCwBvhNode>(),
            )?,
            with_room(
                "bvh.triangles",
                triangle_bytes,
                fixed_triangles,
                size_of::<GpuBvhTriangle>(),
            )?,
        ))
    }

    /// Uploads the rebuilt deforming levels after the fixed ones; when they outgrew their
    /// region, makes both bottom buffers again with fresh headroom and uploads everything.
    /// Returns whether the buffers were replaced (the bind group must be made again).
    fn write_deforming(&mut self, ctx: &GpuContext) -> Result<bool, BvhError> {
        let levels = &self.levels;
        let node_bytes: &[u8] = bytemuck::cast_slice(&levels.nodes);
        let triangle_bytes: &[u8] = bytemuck::cast_slice(&levels.triangles);
        self.node_count = levels.nodes.len() as u32;
        self.primitive_count = levels.triangles.len() as u32;
        self.depth = levels.depth;
        if node_bytes.len() as u64 > self.nodes.size()
            || triangle_bytes.len() as u64 > self.triangles.size()
        {
            let (nodes, triangles) = Self::bottom_buffers(ctx, levels)?;
            ctx.release_buffer(&self.nodes);
            ctx.release_buffer(&self.triangles);
            self.nodes = nodes;
            self.triangles = triangles;
            self.bottom_reallocations += 1;
            return Ok(true);
        }
        let (fixed_nodes, fixed_triangles) = levels.fixed_len();
        let node_offset = fixed_nodes * size_of::<GpuCwBvhNode>();
        let triangle_offset = fixed_triangles * size_of::<GpuBvhTriangle>();
        ctx.queue
            .write_buffer(&self.nodes, node_offset as u64, &node_bytes[node_offset..]);
        ctx.queue.write_buffer(
            &self.triangles,
            triangle_offset as u64,
            &triangle_bytes[triangle_offset..],
        );
        Ok(false)
    }

    /// Whether rays start directly at the static level's root: the scene's only instance is
    /// the world-space static level (and [`GpuBvh::set_static_fast_path`] has not turned this
    /// off). Follows the instance set of the last [`GpuBvh::update`].
    pub fn traces_static_directly(&self) -> bool {
        self.header.static_root != BVH_NO_STATIC_ROOT
    }

    /// Allows (the default) or forbids starting a static scene's rays at its bottom level. Off,
    /// every ray goes through the top level as in a scene with moving objects; the hits are
    /// the same either way, so this exists to compare and time the two paths. Cost: a 16-byte
    /// write.
    pub fn set_static_fast_path(&mut self, ctx: &GpuContext, enabled: bool) {
        self.static_fast_path = enabled;
        self.write_header(ctx, self.header.instance_count);
    }

    /// Makes the bind group again over the current buffers (after one was replaced).
    fn rebind(&mut self, ctx: &GpuContext) {
        self.bind_group = Self::bind_group(
            ctx,
            [
                &self.nodes,
                &self.triangles,
                &self.top_nodes,
                &self.instances,
            ],
        );
    }

    fn write_top(&mut self, ctx: &GpuContext, top: TopLevel) -> Result<(), BvhError> {
        let start = Instant::now();
        let limit = ctx.limits.max_storage_buffer_binding_size;
        let node_bytes: &[u8] = bytemuck::cast_slice(&top.nodes);
        let instance_bytes: &[u8] = bytemuck::cast_slice(&top.instances);
        let header_bytes = size_of::<GpuBvhInstanceHeader>() as u64;
        let mut grown = false;
        if node_bytes.len() as u64 > self.top_nodes.size() {
            check_size("bvh.top_nodes", node_bytes.len() as u64, limit)?;
            ctx.release_buffer(&self.top_nodes);
            self.top_nodes = Self::top_nodes_buffer(ctx, top.nodes.len() as u64);
            grown = true;
        }
        if header_bytes + instance_bytes.len() as u64 > self.instances.size() {
            check_size(
                "bvh.instances",
                header_bytes + instance_bytes.len() as u64,
                limit,
            )?;
            ctx.release_buffer(&self.instances);
            self.instances = Self::instances_buffer(ctx, top.instances.len() as u64);
            grown = true;
        }
        if grown {
            self.rebind(ctx);
        }
        ctx.queue.write_buffer(&self.top_nodes, 0, node_bytes);
        ctx.queue
            .write_buffer(&self.instances, header_bytes, instance_bytes);
        // Decided from this top level's instances, so the fast path follows the instance set.
        self.lone_static_root = match top.instances.as_slice() {
            [only] if only.flags & BVH_INSTANCE_IDENTITY != 0 => Some(only.blas_root),
            _ => None,
        };
        self.write_header(ctx, top.instances.len() as u32);
        self.top_node_count = top.nodes.len() as u32;
        self.top_depth = top.depth;
        self.update_seconds = (top.build_time + start.elapsed()).as_secs_f64();
        self.update_count += 1;
        Ok(())
    }

    fn write_header(&mut self, ctx: &GpuContext, instance_count: u32) {
        let static_root = self
            .lone_static_root
            .filter(|_| self.static_fast_path)
            .unwrap_or(BVH_NO_STATIC_ROOT);
        self.header = GpuBvhInstanceHeader {
            static_root,
            instance_count,
            pad: [0; 2],
        };
        ctx.queue
            .write_buffer(&self.instances, 0, bytemuck::bytes_of(&self.header));
    }

    fn instances_buffer(ctx: &GpuContext, instances: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "bvh.instances",
            size_of::<GpuBvhInstanceHeader>() as u64
                + instances.max(1) * size_of::<GpuBvhInstance>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    fn top_nodes_buffer(ctx: &GpuContext, nodes: u64) -> wgpu::Buffer {
        ctx.create_buffer(
            "bvh.top_nodes",
            nodes.max(1) * size_of::<GpuCwBvhNode>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        )
    }

    fn bind_group(ctx: &GpuContext, buffers: [&wgpu::Buffer; 4]) -> wgpu::BindGroup {
        let entries: Vec<_> = buffers
            .iter()
            .zip(0..)
            .map(|(buffer, binding)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bvh.bind_group"),
            layout: &Self::bind_group_layout(ctx),
            entries: &entries,
        })
    }

    /// The bottom levels on the CPU (node and primitive lists, instance count).
    pub fn bottom_levels(&self) -> &BottomLevels {
        &self.levels
    }

    /// Bytes of the bottom levels (written once).
    pub fn bottom_bytes(&self) -> u64 {
        self.nodes.size() + self.triangles.size()
    }

    /// Bytes of the top level and instances (rewritten every frame).
    pub fn top_bytes(&self) -> u64 {
        self.top_nodes.size() + self.instances.size()
    }

    /// Bytes of all four buffers and of the deforming levels' refit.
    pub fn bytes(&self) -> u64 {
        self.bottom_bytes() + self.top_bytes() + self.refit.as_ref().map_or(0, DeformRefit::bytes)
    }

    /// Stops counting and destroys the buffers (for a BVH replaced by a rebuild).
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.nodes,
            &self.triangles,
            &self.top_nodes,
            &self.instances,
        ] {
            ctx.release_buffer(buffer);
        }
        if let Some(refit) = &self.refit {
            refit.release(ctx);
        }
    }
}

fn check_size(label: &'static str, bytes: u64, limit: u64) -> Result<(), BvhError> {
    if bytes > limit {
        return Err(BvhError::TooLarge {
            label,
            bytes,
            limit,
        });
    }
    Ok(())
}

//! The GPU path tracer, a technique every GPU tier uses: `<tier>/trace` adds samples to
//! per-pixel sums, in dispatches of bounded cost ([`dispatch`]), and `<tier>/resolve` writes
//! the mean image, with the accumulation buffers they share. `<tier>` is `path` (full
//! transport, the `path` tier), or `direct` for the direct-only variant of the same shader:
//! the `direct` tier, and the direct light of the `mobile` and `pc` tiers.

pub mod dispatch;

use std::num::NonZeroU64;

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry};
use gi_gpu::{
    GpuCamera, GpuContext, GpuError, GpuScene, GpuTimer, PassTimings, Recorder, ShaderDefValue,
    ShaderLibrary, Technique, wgpu,
};
use gi_scene::{SceneFrame, Sky};

use dispatch::{DispatchPlan, MAX_DISPATCHES_PER_PASS, TRACE_TILE};

/// Bytes between the uniform slots of `<tier>/trace`'s dispatches: 256 is the largest
/// `min_uniform_buffer_offset_alignment` WebGPU allows, so it suits every device.
const UNIFORM_SLOT_BYTES: u64 = 256;
/// Iterations of the shader's loop check (`loops_ran_to_completion`): two, so a loop that
/// lavapipe ends after its first iteration shows.
const LOOP_CHECK_ITERATIONS: u32 = 2;
/// Invocations per `path/resolve` workgroup.
const RESOLVE_GROUP: u32 = 64;
/// Most workgroups along one dispatch dimension (the WebGPU minimum limit).
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// Rust mirror of `PathUniforms` in `shaders/path/trace.wgsl`, 176 bytes. One per
/// `<tier>/trace` dispatch: `sample_offset`, `spp` and `first_row` say which samples of which
/// rows it adds.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PathUniforms {
    /// The camera that casts the primary rays (`gi::camera`).
    pub camera: GpuCamera,
    /// Gradient sky radiance at the zenith, horizon and nadir (xyz; w unused).
    pub sky_zenith: [f32; 4],
    pub sky_horizon: [f32; 4],
    pub sky_ground: [f32; 4],
    /// Image size in pixels.
    pub size_px: [u32; 2],
    /// Sample index of this dispatch's first sample (samples accumulated before it).
    pub sample_offset: u32,
    /// Samples per pixel this dispatch adds ([`DispatchPlan::samples`] or fewer).
    pub spp: u32,
    /// Render seed, low then high 32 bits.
    pub seed: [u32; 2],
    /// Entries of the emitter table and punctual lights in the scene buffers.
    pub emitter_count: u32,
    pub light_count: u32,
    /// 1 when the sky emits anything (sky sampling is skipped otherwise, as in the reference).
    pub sky_emits: u32,
    /// Index of the default material, used for out-of-range material indices.
    pub default_material: u32,
    /// 0: constant sky (`sky_zenith` is its radiance), 1: gradient.
    pub sky_kind: u32,
    /// Most scatterings per path (the reference's default).
    pub max_depth: u32,
    /// First image row this dispatch covers (it covers [`DispatchPlan::rows`] rows).
    pub first_row: u32,
    /// Iterations the shader's loop check asks for (2): a value the compiler cannot see, so
    /// it cannot unroll the loop.
    pub loop_check: u32,
    /// Up to the WGSL struct's 16-byte alignment.
    pub pad: [u32; 2],
}

impl PathUniforms {
    /// The uniforms of `frame` rendered at `width` x `height`, with the camera values computed
    /// exactly as the reference computes them (so GPU and CPU rays agree bit for bit).
    pub fn new(frame: &SceneFrame, scene: &GpuScene, size: (u32, u32), seed: u64) -> Self {
        let pad = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
        let (sky_kind, zenith, horizon, ground) = match frame.sky {
            Sky::Constant { radiance } => (0, radiance, radiance, radiance),
            Sky::Gradient {
                zenith,
                horizon,
                ground,
            } => (1, zenith, horizon, ground),
        };
        Self {
            camera: GpuCamera::new(&frame.camera, size),
            sky_zenith: pad(zenith),
            sky_horizon: pad(horizon),
            sky_ground: pad(ground),
            size_px: [size.0, size.1],
            sample_offset: 0,
            spp: 0,
            seed: [seed as u32, (seed >> 32) as u32],
            emitter_count: scene.emitter_count,
            light_count: scene.light_count,
            sky_emits: u32::from(!frame.sky.is_black()),
            default_material: scene.default_material,
            sky_kind,
            max_depth: gi_reference::RenderSettings::default().max_depth,
            first_row: 0,
            loop_check: LOOP_CHECK_ITERATIONS,
            pad: [0; 2],
        }
    }
}

/// Rust mirror of `ResolveUniforms` in `shaders/path/resolve.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct ResolveUniforms {
    pixel_count: u32,
    samples: u32,
    pad: [u32; 2],
}

/// The two pipelines; one per entry point, named after it. Cloning shares the compiled
/// pipelines.
#[derive(Clone)]
pub(crate) struct PathPipelines {
    /// Entry point `trace` of `path/trace.wgsl` (with `DIRECT_ONLY` for the direct tier).
    pub(crate) trace: wgpu::ComputePipeline,
    /// Entry point `resolve` of `path/resolve.wgsl`.
    pub(crate) resolve: wgpu::ComputePipeline,
    /// The tier's name, which prefixes every label and timer scope.
    pub(crate) tier: &'static str,
}

impl PathPipelines {
    /// The pipelines of `tier` (`"path"` or `"direct"`, which compiles `DIRECT_ONLY`), labeled
    /// `<tier>/trace` and `<tier>/resolve` like the timer scopes of their passes.
    pub(crate) fn new(ctx: &GpuContext, tier: &'static str) -> Result<Self, GpuError> {
        Self::with_blend_layer(ctx, tier, false)
    }

    /// The direct-light pipelines of the real-time tiers (`"direct"` labels): as the direct
    /// tier's, except that a camera ray meeting an alpha-`BLEND` surface blends the light of
    /// that surface and of the one behind it by its alpha (`BLEND_LAYER`), as their G-buffer
    /// and GI see it, instead of passing it by the hashed rule.
    pub(crate) fn real_time_direct(ctx: &GpuContext) -> Result<Self, GpuError> {
        Self::with_blend_layer(ctx, "direct", true)
    }

    fn with_blend_layer(
        ctx: &GpuContext,
        tier: &'static str,
        blend_layer: bool,
    ) -> Result<Self, GpuError> {
        let direct_only = tier == "direct";
        let shaders = ShaderLibrary::new();
        let mut defs = vec![gi_gpu::ALPHA_TEST];
        if direct_only {
            defs.push(("DIRECT_ONLY", ShaderDefValue::Bool(true)));
        }
        if blend_layer {
            defs.push(("BLEND_LAYER", ShaderDefValue::Bool(true)));
        }
        let defs = defs.as_slice();
        let trace = shaders.create_module(ctx, "path/trace.wgsl", defs)?;
        let resolve = shaders.create_module(ctx, "path/resolve.wgsl", &[])?;
        // An explicit layout: the BVH's bind group is made with `GpuBvh::bind_group_layout`,
        // and the direct variant leaves some scene bindings unused, which an automatic layout
        // would drop. The uniforms take a dynamic offset: one slot per dispatch.
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: NonZeroU64::new(size_of::<PathUniforms>() as u64),
            },
            count: None,
        }];
        entries.extend(GpuScene::layout_entries());
        entries.extend((8..=10).map(|binding| storage_entry(binding, false)));
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&format!("{tier}/trace.frame_layout")),
                entries: &entries,
            });
        let bvh_layout = gi_gpu::bvh::GpuBvh::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let trace = ctx.create_compute_pipeline_with_layouts(
            &format!("{tier}/trace"),
            &trace,
            "trace",
            &[
                Some(&frame_layout),
                Some(&bvh_layout),
                None,
                Some(&texture_layout),
            ],
        );
        Ok(Self {
            trace,
            resolve: ctx.create_compute_pipeline(&format!("{tier}/resolve"), &resolve, "resolve"),
            tier,
        })
    }
}

/// What `<tier>/trace` counted over the dispatches of one [`Accumulation::add_samples`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct TraceStats {
    /// Closest-hit and shadow rays traced.
    pub(crate) rays: u64,
    /// Invocations whose loops the device cut short (lavapipe's loop limit): their pixels'
    /// sums are wrong. Zero unless a dispatch's cost was underestimated.
    pub(crate) cut_invocations: u32,
}

/// Per-pixel running sums of one progressive render (`<tier>.accum_sum`,
/// `<tier>.accum_sum_sq`, 32 bytes per pixel), the mean image (`<tier>.mean`, 16 bytes per
/// pixel), one 256-byte uniform slot per dispatch of the largest pass so far
/// (`<tier>.trace_uniforms`) and the bind groups over them and the scene.
pub(crate) struct Accumulation {
    /// The tier's trace and resolve pipelines (shared with the tier).
    pipelines: PathPipelines,
    pub(crate) size: (u32, u32),
    /// Samples per pixel in the sums.
    pub(crate) samples: u32,
    uniforms: PathUniforms,
    /// Whether the pipelines are the direct tier's (one vertex per path).
    direct_only: bool,
    /// Times the invocation budget has been halved after a dispatch's loops were cut short.
    budget_shift: u32,
    trace_uniforms: wgpu::Buffer,
    /// Uniform slots `trace_uniforms` holds.
    uniform_slots: u32,
    resolve_uniforms: wgpu::Buffer,
    pub(crate) sum: wgpu::Buffer,
    pub(crate) sum_sq: wgpu::Buffer,
    pub(crate) mean: wgpu::Buffer,
    /// `<tier>.trace_stats`, four u32 words: the rays traced (a u64, low word first) and the
    /// invocations cut short by the last [`Accumulation::add_samples`] ([`TraceStats`]).
    trace_stats: wgpu::Buffer,
    trace_group: wgpu::BindGroup,
    resolve_group: wgpu::BindGroup,
}

/// What one frame of the real-time tiers' direct light reads.
pub(crate) struct DirectInputs<'a> {
    /// The scene the accumulation traces (its BVH and textures).
    pub(crate) scene: &'a GpuScene,
    /// Samples per pixel to add this frame, at most as many as one pass holds; 0 records
    /// nothing (the mean is the last frame's).
    pub(crate) samples: u32,
}

/// The real-time tiers' direct light: an accumulation of direct-only samples while the view
/// holds still. Each frame records one `<tier>/trace` pass and a `<tier>/resolve`. Its
/// uniforms are written with `queue.write_buffer`: what `rec` holds must be submitted before
/// the next frame. Nothing reads the trace's counts back here: the tiers add one direct-only
/// sample per frame, a camera ray and a shadow ray per light, far below the budgets.
impl Technique for Accumulation {
    type Inputs<'i> = DirectInputs<'i>;
    /// The frame's result is `<tier>.mean`, the mean of the samples so far, `vec4<f32>` per
    /// pixel: the same buffer every frame of the accumulation.
    type Outputs<'o> = ();

    fn record(&mut self, rec: &mut Recorder<'_>, inputs: &DirectInputs<'_>) {
        if inputs.samples > 0 {
            let (ctx, timer, encoder) = rec.parts();
            encoder.clear_buffer(&self.trace_stats, 0, None);
            self.record_trace(ctx, inputs.scene, timer, encoder, inputs.samples);
            self.record_resolve(ctx, timer, encoder);
        }
    }
}

impl Accumulation {
    pub(crate) fn new(
        ctx: &GpuContext,
        pipelines: &PathPipelines,
        scene: &GpuScene,
        uniforms: PathUniforms,
    ) -> Self {
        let tier = pipelines.tier;
        let size = (uniforms.size_px[0], uniforms.size_px[1]);
        let pixels = u64::from(size.0) * u64::from(size.1);
        // COPY_DST: a restarted accumulation clears its sums.
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let trace_uniforms = ctx.create_buffer(
            &format!("{tier}.trace_uniforms"),
            UNIFORM_SLOT_BYTES,
            uniform,
        );
        let resolve_uniforms = ctx.create_buffer(&format!("{tier}.resolve_uniforms"), 16, uniform);
        // New buffers are zeroed, which is the empty accumulation.
        let sum = ctx.create_buffer(&format!("{tier}.accum_sum"), pixels * 16, storage);
        let sum_sq = ctx.create_buffer(&format!("{tier}.accum_sum_sq"), pixels * 16, storage);
        let mean = ctx.create_buffer(&format!("{tier}.mean"), pixels * 16, storage);
        let trace_stats = ctx.create_buffer(&format!("{tier}.trace_stats"), 16, storage);
        let trace_group = trace_bind_group(
            ctx,
            pipelines,
            scene,
            &trace_uniforms,
            [&sum, &sum_sq, &trace_stats],
        );
        let resolve_group = bind_group(
            ctx,
            &format!("{tier}/resolve"),
            &pipelines.resolve,
            buffer_entries(0, [&resolve_uniforms, &sum, &mean]),
        );
        Self {
            pipelines: pipelines.clone(),
            size,
            samples: 0,
            uniforms,
            direct_only: tier == "direct",
            budget_shift: 0,
            trace_uniforms,
            uniform_slots: 1,
            resolve_uniforms,
            sum,
            sum_sq,
            mean,
            trace_stats,
            trace_group,
            resolve_group,
        }
    }

    /// Empties the sums for a new view or a new frame of the scene, keeping the buffers and
    /// bind groups: the next [`Accumulation::add_samples`] starts from sample 0.
    pub(crate) fn restart(&mut self, uniforms: PathUniforms) {
        self.uniforms = uniforms;
        self.samples = 0;
    }

    /// Empties the sums of the same view: the next [`Accumulation::add_samples`] renders
    /// again from sample 0.
    pub(crate) fn rewind(&mut self) {
        self.samples = 0;
    }

    /// How `<tier>/trace` cuts this accumulation's samples of `scene` into dispatches.
    pub(crate) fn plan(&self, scene: &GpuScene) -> DispatchPlan {
        let per_sample =
            dispatch::loop_iterations_per_sample(self.direct_only, &self.uniforms, &scene.bvh);
        DispatchPlan::new(per_sample, self.size, self.budget_shift)
    }

    /// Halves the invocation budget after a dispatch's loops were cut short, for the next
    /// plan. False when the plan already adds one sample per dispatch: halving cannot help.
    pub(crate) fn halve_budget(&mut self, scene: &GpuScene) -> bool {
        if self.plan(scene).samples <= 1 {
            return false;
        }
        self.budget_shift += 1;
        true
    }

    /// Compute passes [`Accumulation::add_samples`] records to add `spp` samples: its
    /// `<tier>/trace` passes and one `<tier>/resolve`.
    pub(crate) fn passes_for(&self, scene: &GpuScene, spp: u32) -> u32 {
        let per_pass = self.plan(scene).samples_per_pass(self.size.1);
        spp.div_ceil(per_pass).max(1) + 1
    }

    /// Adds `spp` samples per pixel (`<tier>/trace`, as many passes as
    /// [`Accumulation::passes_for`] says, submitted one by one) and resolves the mean
    /// (`<tier>/resolve`), returning every pass's time.
    pub(crate) fn add_samples(
        &mut self,
        ctx: &GpuContext,
        scene: &GpuScene,
        timer: &mut GpuTimer,
        spp: u32,
    ) -> PassTimings {
        let label = format!("{}/frame", self.pipelines.tier);
        let mut encoder = ctx.create_encoder(&label);
        encoder.clear_buffer(&self.trace_stats, 0, None);
        let mut remaining = spp.min(u32::MAX - self.samples);
        loop {
            remaining -= self.record_trace(ctx, scene, timer, &mut encoder, remaining);
            if remaining == 0 {
                break;
            }
            // The next pass rewrites the uniform slots: this one must be submitted first.
            timer.submit(
                ctx,
                std::mem::replace(&mut encoder, ctx.create_encoder(&label)),
            );
        }
        self.record_resolve(ctx, timer, &mut encoder);
        timer.finish(ctx, encoder)
    }

    /// Records one `<tier>/trace` compute pass adding `spp` samples per pixel, or as many as
    /// [`DispatchPlan::samples_per_pass`] allows (at least one when `spp` is): a dispatch per
    /// chunk of [`DispatchPlan::samples`] and band of [`DispatchPlan::rows`], chunk after
    /// chunk, so every pixel adds its samples in order. Returns the samples added.
    fn record_trace(
        &mut self,
        ctx: &GpuContext,
        scene: &GpuScene,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        spp: u32,
    ) -> u32 {
        let plan = self.plan(scene);
        let spp = spp
            .min(u32::MAX - self.samples)
            .min(plan.samples_per_pass(self.size.1));
        if spp == 0 {
            return 0;
        }
        if self.samples == 0 {
            encoder.clear_buffer(&self.sum, 0, None);
            encoder.clear_buffer(&self.sum_sq, 0, None);
        }
        let bands = plan.bands(self.size.1);
        let mut slots = Vec::new();
        let mut added = 0;
        while added < spp {
            let chunk = plan.samples.min(spp - added);
            for band in 0..bands {
                let uniforms = PathUniforms {
                    sample_offset: self.samples + added,
                    spp: chunk,
                    first_row: band * plan.rows,
                    ..self.uniforms
                };
                slots.extend_from_slice(bytemuck::bytes_of(&uniforms));
                slots.resize(slots.len().next_multiple_of(UNIFORM_SLOT_BYTES as usize), 0);
            }
            added += chunk;
        }
        let dispatches = (slots.len() as u64 / UNIFORM_SLOT_BYTES) as u32;
        debug_assert!(dispatches <= MAX_DISPATCHES_PER_PASS);
        self.reserve_slots(ctx, scene, dispatches);
        ctx.queue.write_buffer(&self.trace_uniforms, 0, &slots);
        self.samples += spp;
        let groups_x = self.size.0.div_ceil(TRACE_TILE);
        let groups_y = plan.rows.min(self.size.1.next_multiple_of(TRACE_TILE)) / TRACE_TILE;
        let tier = self.pipelines.tier;
        timer.compute_pass(ctx, encoder, &format!("{tier}/trace"), |pass| {
            pass.set_pipeline(&self.pipelines.trace);
            pass.set_bind_group(gi_gpu::bvh::BVH_BIND_GROUP, &scene.bvh.bind_group, &[]);
            scene.set_texture_bind_group(pass);
            for slot in 0..dispatches {
                let offset = (u64::from(slot) * UNIFORM_SLOT_BYTES) as u32;
                pass.set_bind_group(0, &self.trace_group, &[offset]);
                pass.dispatch_workgroups(groups_x, groups_y, 1);
            }
        });
        spp
    }

    /// Records `<tier>/resolve`: the mean of the samples so far.
    fn record_resolve(
        &self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        let pixel_count = self.size.0 * self.size.1;
        let resolve = ResolveUniforms {
            pixel_count,
            samples: self.samples,
            pad: [0; 2],
        };
        ctx.queue
            .write_buffer(&self.resolve_uniforms, 0, bytemuck::bytes_of(&resolve));
        let groups = pixel_count.div_ceil(RESOLVE_GROUP);
        let rows = groups.div_ceil(MAX_GROUPS_PER_ROW);
        timer.compute_pass(
            ctx,
            encoder,
            &format!("{}/resolve", self.pipelines.tier),
            |pass| {
                pass.set_pipeline(&self.pipelines.resolve);
                pass.set_bind_group(0, &self.resolve_group, &[]);
                pass.dispatch_workgroups(groups.div_ceil(rows), rows, 1);
            },
        );
    }

    /// Grows `<tier>.trace_uniforms` to hold `slots` uniform slots (the bind group over it is
    /// made again). Buffers only grow, so a steady frame rate of samples allocates nothing.
    fn reserve_slots(&mut self, ctx: &GpuContext, scene: &GpuScene, slots: u32) {
        if slots <= self.uniform_slots {
            return;
        }
        let buffer = ctx.create_buffer(
            &format!("{}.trace_uniforms", self.pipelines.tier),
            u64::from(slots) * UNIFORM_SLOT_BYTES,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        ctx.release_buffer(&std::mem::replace(&mut self.trace_uniforms, buffer));
        self.uniform_slots = slots;
        self.trace_group = trace_bind_group(
            ctx,
            &self.pipelines,
            scene,
            &self.trace_uniforms,
            [&self.sum, &self.sum_sq, &self.trace_stats],
        );
    }

    /// What the dispatches of the last [`Accumulation::add_samples`] counted (read back;
    /// stalls the GPU).
    pub(crate) fn trace_stats(&self, ctx: &GpuContext) -> TraceStats {
        let words: Vec<u32> = ctx.read_buffer(&self.trace_stats);
        TraceStats {
            rays: u64::from(words[0]) | (u64::from(words[1]) << 32),
            cut_invocations: words[2],
        }
    }

    /// Stops counting and destroys the buffers.
    pub(crate) fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.trace_uniforms,
            &self.resolve_uniforms,
            &self.sum,
            &self.sum_sq,
            &self.mean,
            &self.trace_stats,
        ] {
            ctx.release_buffer(buffer);
        }
    }
}

/// `<tier>/trace`'s group 0: one uniform slot (at a dynamic offset), the scene and the
/// accumulation buffers.
fn trace_bind_group(
    ctx: &GpuContext,
    pipelines: &PathPipelines,
    scene: &GpuScene,
    uniforms: &wgpu::Buffer,
    accumulation: [&wgpu::Buffer; 3],
) -> wgpu::BindGroup {
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: uniforms,
            offset: 0,
            size: NonZeroU64::new(size_of::<PathUniforms>() as u64),
        }),
    }];
    entries.extend(scene.bind_group_entries());
    entries.extend(buffer_entries(8, accumulation));
    let tier = pipelines.tier;
    bind_group(ctx, &format!("{tier}/trace"), &pipelines.trace, entries)
}

fn bind_group(
    ctx: &GpuContext,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    entries: Vec<wgpu::BindGroupEntry<'_>>,
) -> wgpu::BindGroup {
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

//! The GPU path tracer's passes: `<tier>/trace` (adds samples to per-pixel sums) and
//! `<tier>/resolve` (the mean image), with the accumulation buffers they share. `<tier>` is
//! `path`, or `direct` for the direct-only variant of the same shader.

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{
    GpuCamera, GpuContext, GpuError, GpuScene, GpuTimer, PassTimings, ShaderDefValue,
    ShaderLibrary, wgpu,
};
use gi_scene::{SceneFrame, Sky};

/// Pixels per side of a `path/trace` workgroup (`@workgroup_size(8, 8)`).
const TRACE_TILE: u32 = 8;
/// Invocations per `path/resolve` workgroup.
const RESOLVE_GROUP: u32 = 64;
/// Most workgroups along one dispatch dimension (the WebGPU minimum limit).
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// Rust mirror of `PathUniforms` in `shaders/path/trace.wgsl`, 160 bytes.
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
    /// Samples per pixel this dispatch adds.
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

/// The two pipelines; one per entry point, named after it.
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
        let direct_only = tier == "direct";
        let shaders = ShaderLibrary::new();
        let defs: &[(&str, ShaderDefValue)] = if direct_only {
            &[("DIRECT_ONLY", ShaderDefValue::Bool(true))]
        } else {
            &[]
        };
        let trace = shaders.create_module(ctx, "path/trace.wgsl", defs)?;
        let resolve = shaders.create_module(ctx, "path/resolve.wgsl", &[])?;
        // An explicit layout: the BVH's bind group is made with `GpuBvh::bind_group_layout`,
        // and the direct variant leaves some scene bindings unused, which an automatic layout
        // would drop.
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.extend((8..=10).map(|binding| storage_entry(binding, false)));
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&format!("{tier}/trace.frame_layout")),
                entries: &entries,
            });
        let bvh_layout = gi_gpu::bvh::GpuBvh::bind_group_layout(ctx);
        let trace = ctx.create_compute_pipeline_with_layouts(
            &format!("{tier}/trace"),
            &trace,
            "trace",
            &[Some(&frame_layout), Some(&bvh_layout)],
        );
        Ok(Self {
            trace,
            resolve: ctx.create_compute_pipeline(&format!("{tier}/resolve"), &resolve, "resolve"),
            tier,
        })
    }
}

/// Per-pixel running sums of one progressive render (`<tier>.accum_sum`,
/// `<tier>.accum_sum_sq`, 32 bytes per pixel), the mean image (`<tier>.mean`, 16 bytes per
/// pixel) and the bind groups
/// over them and the scene.
pub(crate) struct Accumulation {
    pub(crate) size: (u32, u32),
    /// Samples per pixel in the sums.
    pub(crate) samples: u32,
    uniforms: PathUniforms,
    trace_uniforms: wgpu::Buffer,
    resolve_uniforms: wgpu::Buffer,
    pub(crate) sum: wgpu::Buffer,
    pub(crate) sum_sq: wgpu::Buffer,
    pub(crate) mean: wgpu::Buffer,
    /// Rays traced by the last `<tier>/trace` dispatch, a u64 as two u32 words.
    ray_count: wgpu::Buffer,
    trace_group: wgpu::BindGroup,
    resolve_group: wgpu::BindGroup,
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
            size_of::<PathUniforms>() as u64,
            uniform,
        );
        let resolve_uniforms = ctx.create_buffer(&format!("{tier}.resolve_uniforms"), 16, uniform);
        // New buffers are zeroed, which is the empty accumulation.
        let sum = ctx.create_buffer(&format!("{tier}.accum_sum"), pixels * 16, storage);
        let sum_sq = ctx.create_buffer(&format!("{tier}.accum_sum_sq"), pixels * 16, storage);
        let mean = ctx.create_buffer(&format!("{tier}.mean"), pixels * 16, storage);
        let ray_count = ctx.create_buffer(&format!("{tier}.ray_count"), 8, storage);
        let mut entries = buffer_entries(0, [&trace_uniforms]);
        entries.extend(scene.bind_group_entries());
        entries.extend(buffer_entries(8, [&sum, &sum_sq, &ray_count]));
        let tier = pipelines.tier;
        let trace_group = bind_group(ctx, &format!("{tier}/trace"), &pipelines.trace, entries);
        let resolve_group = bind_group(
            ctx,
            &format!("{tier}/resolve"),
            &pipelines.resolve,
            buffer_entries(0, [&resolve_uniforms, &sum, &mean]),
        );
        Self {
            size,
            samples: 0,
            uniforms,
            trace_uniforms,
            resolve_uniforms,
            sum,
            sum_sq,
            mean,
            ray_count,
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

    /// Adds `spp` samples per pixel (`path/trace`) and resolves the mean (`path/resolve`),
    /// returning both passes' times.
    pub(crate) fn add_samples(
        &mut self,
        ctx: &GpuContext,
        pipelines: &PathPipelines,
        scene: &GpuScene,
        timer: &mut GpuTimer,
        spp: u32,
    ) -> PassTimings {
        let mut encoder = ctx.create_encoder(&format!("{}/frame", pipelines.tier));
        self.record_samples(ctx, pipelines, scene, timer, &mut encoder, spp);
        timer.finish(ctx, encoder)
    }

    /// Records [`Accumulation::add_samples`]'s passes into `encoder`, timed under `timer`'s
    /// frame. Its uniforms are written with `queue.write_buffer`: `encoder` must be submitted
    /// before the next call.
    pub(crate) fn record_samples(
        &mut self,
        ctx: &GpuContext,
        pipelines: &PathPipelines,
        scene: &GpuScene,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        spp: u32,
    ) {
        let restarting = self.samples == 0;
        let spp = spp.min(u32::MAX - self.samples);
        self.uniforms.sample_offset = self.samples;
        self.uniforms.spp = spp;
        self.samples += spp;
        let pixel_count = self.size.0 * self.size.1;
        ctx.queue
            .write_buffer(&self.trace_uniforms, 0, bytemuck::bytes_of(&self.uniforms));
        let resolve = ResolveUniforms {
            pixel_count,
            samples: self.samples,
            pad: [0; 2],
        };
        ctx.queue
            .write_buffer(&self.resolve_uniforms, 0, bytemuck::bytes_of(&resolve));
        let tier = pipelines.tier;
        encoder.clear_buffer(&self.ray_count, 0, None);
        if restarting {
            encoder.clear_buffer(&self.sum, 0, None);
            encoder.clear_buffer(&self.sum_sq, 0, None);
        }
        timer.compute_pass(ctx, encoder, &format!("{tier}/trace"), |pass| {
            pass.set_pipeline(&pipelines.trace);
            pass.set_bind_group(0, &self.trace_group, &[]);
            pass.set_bind_group(gi_gpu::bvh::BVH_BIND_GROUP, &scene.bvh.bind_group, &[]);
            pass.dispatch_workgroups(
                self.size.0.div_ceil(TRACE_TILE),
                self.size.1.div_ceil(TRACE_TILE),
                1,
            );
        });
        let groups = pixel_count.div_ceil(RESOLVE_GROUP);
        let rows = groups.div_ceil(MAX_GROUPS_PER_ROW);
        timer.compute_pass(ctx, encoder, &format!("{tier}/resolve"), |pass| {
            pass.set_pipeline(&pipelines.resolve);
            pass.set_bind_group(0, &self.resolve_group, &[]);
            pass.dispatch_workgroups(groups.div_ceil(rows), rows, 1);
        });
    }

    /// Rays the last [`Accumulation::add_samples`] traced (read back; stalls the GPU).
    pub(crate) fn rays_traced(&self, ctx: &GpuContext) -> u64 {
        let words: Vec<u32> = ctx.read_buffer(&self.ray_count);
        u64::from(words[0]) | (u64::from(words[1]) << 32)
    }

    /// Stops counting and destroys the buffers.
    pub(crate) fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.trace_uniforms,
            &self.resolve_uniforms,
            &self.sum,
            &self.sum_sq,
            &self.mean,
            &self.ray_count,
        ] {
            ctx.release_buffer(buffer);
        }
    }
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

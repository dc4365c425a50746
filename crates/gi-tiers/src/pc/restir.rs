//! The PC tier's ReSTIR GI and specular tracing (Ouyang et al. 2021; HSGI's specular rays and
//! reuse of the diffuse result), as one technique: its pipelines, its buffers with their
//! `PingPong` histories, the bind groups built from named fields, and the passes it records
//! before and after the denoiser (`shaders/pc/restir/`, one file per pass).

use gi_cache::CacheBuffers;
use gi_gpu::binding::{buffer_entries, uniform_entry};
use gi_gpu::bvh::{BVH_BIND_GROUP, GpuBvh};
use gi_gpu::{
    GBufferOutputs, GpuContext, GpuError, GpuScene, PingPong, Recorder, ShaderLibrary,
    TEXTURE_BIND_GROUP, Technique, wgpu,
};

use super::denoise::{GradientGrid, GradientSource, OUTPUT_PIXEL_BYTES, SCRATCH_PIXEL_BYTES};
use super::{GpuGradientSample, GpuReservoir, GpuSpecularSample, GpuSurface, PcConfig, PcUniforms};

/// Pixels per side of every pass's workgroups (`@workgroup_size(8, 8)`).
const TILE: u32 = 8;
/// Bytes per pixel of `specular_noisy` (`pack_color64`).
const SPECULAR_NOISY_PIXEL_BYTES: u64 = 8;
/// Bytes per pixel of `irradiance` (`pack_color64`).
const IRRADIANCE_PIXEL_BYTES: u64 = 8;
/// Bytes per pixel of `specular_reprojected`: a whole specular history entry (its RGB9E5 value
/// and its byte of length and kind, `pack_specular_history`).
const SPECULAR_REPROJECTED_PIXEL_BYTES: u64 = 8;
/// Bytes of the specular history for `pixels` pixels: the values (RGB9E5), then the bytes of
/// length and kind, four to a word.
fn specular_history_bytes(pixels: u64) -> u64 {
    4 * pixels + 4 * pixels.div_ceil(4)
}

/// The compute pipelines of `shaders/pc/restir/`, each from its pass's file, and their
/// layouts, compiled once per tier; cloning shares them.
#[derive(Clone)]
pub(super) struct RestirPipelines {
    trace_layout: wgpu::BindGroupLayout,
    restir_layout: wgpu::BindGroupLayout,
    trace: wgpu::ComputePipeline,
    shadow: wgpu::ComputePipeline,
    temporal: wgpu::ComputePipeline,
    spatial: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    compose: wgpu::ComputePipeline,
    specular_trace: wgpu::ComputePipeline,
    specular_resolve: wgpu::ComputePipeline,
    specular_reproject: wgpu::ComputePipeline,
    specular_temporal: wgpu::ComputePipeline,
    gradient_filter: wgpu::ComputePipeline,
}

impl RestirPipelines {
    pub(super) fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries,
                })
        };
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.extend(TraceBindings::layout_entries());
        let trace_layout = layout("pc/trace.layout0", &entries);
        let mut entries = vec![uniform_entry(0)];
        entries.extend(RestirBindings::layout_entries());
        let restir_layout = layout("pc/restir.layout0", &entries);
        let bvh_layout = GpuBvh::bind_group_layout(ctx);
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let mut trace_groups: Vec<Option<&wgpu::BindGroupLayout>> =
            vec![None; TEXTURE_BIND_GROUP.max(CacheBuffers::BIND_GROUP) as usize + 1];
        trace_groups[0] = Some(&trace_layout);
        trace_groups[BVH_BIND_GROUP as usize] = Some(&bvh_layout);
        trace_groups[CacheBuffers::BIND_GROUP as usize] = Some(&cache_layout);
        trace_groups[TEXTURE_BIND_GROUP as usize] = Some(&texture_layout);
        // The passes that trace BVH rays, from `pc/restir/{file}.wgsl`, with the alpha test.
        let traced_module = |file: &str| {
            shaders.create_module(
                ctx,
                &format!("pc/restir/{file}.wgsl"),
                &[gi_gpu::ALPHA_TEST],
            )
        };
        let traced_pipeline = |module: &wgpu::ShaderModule, entry: &str| {
            ctx.create_compute_pipeline_with_layouts(
                &format!("pc/{entry}"),
                module,
                entry,
                &trace_groups,
            )
        };
        let traced = |entry: &str| -> Result<_, GpuError> {
            Ok(traced_pipeline(&traced_module(entry)?, entry))
        };
        let gradient = traced_module("gradient")?;
        let mut restir_groups: Vec<Option<&wgpu::BindGroupLayout>> =
            vec![None; CacheBuffers::BIND_GROUP as usize + 1];
        restir_groups[0] = Some(&restir_layout);
        restir_groups[CacheBuffers::BIND_GROUP as usize] = Some(&cache_layout);
        // The passes after the rays, entry `entry` of `pc/restir/{file}.wgsl`.
        let reused_entry = |file: &str, entry: &str| -> Result<_, GpuError> {
            let module = shaders.create_module(ctx, &format!("pc/restir/{file}.wgsl"), &[])?;
            Ok(ctx.create_compute_pipeline_with_layouts(
                &format!("pc/{entry}"),
                &module,
                entry,
                &restir_groups,
            ))
        };
        let reused = |entry: &str| reused_entry(entry, entry);
        Ok(Self {
            trace: traced("trace")?,
            shadow: traced("shadow")?,
            specular_trace: traced("specular_trace")?,
            temporal: reused("temporal")?,
            spatial: reused("spatial")?,
            shade: reused("shade")?,
            compose: reused("compose")?,
            specular_resolve: reused("specular_resolve")?,
            specular_reproject: reused_entry("specular_temporal", "specular_reproject")?,
            specular_temporal: reused("specular_temporal")?,
            gradient_filter: traced_pipeline(&gradient, "gradient_filter"),
            trace_layout,
            restir_layout,
        })
    }
}

gi_gpu::storage_bindings! {
    /// The buffers in group 0 of the passes that trace rays (`trace`, `shadow`,
    /// `specular_trace`), after the uniforms (0) and the scene (1..=7), which they import from
    /// `pc/restir/rays.wgsl`.
    struct TraceBindings from 8 {
        gbuffer_depth: read,
        gbuffer_normal: read,
        /// This frame's receivers' pixels, picked by `trace`.
        receivers: read_write,
        initial: read_write,
        /// The temporal reservoirs the shadow pass falls back to.
        temporal: read,
        resolved: read_write,
        gbuffer_base_color: read,
        gbuffer_metallic_roughness: read,
        specular_samples: read_write,
        /// The ray candidates kept for the next frame's gradient, one per stratum.
        gradient_samples: read_write,
        /// The gradients and their lambda, one per stratum.
        gradients: read_write,
        /// This frame's receivers whole, kept for the next frame's temporal reuse.
        surfaces: read_write,
    }
}

gi_gpu::storage_bindings! {
    /// The buffers in group 0 of the passes after the rays (`temporal`, `spatial`, `shade`,
    /// `compose`, `specular_resolve`, `specular_temporal`), after the uniforms (0), which they
    /// import from `pc/restir/bindings.wgsl`. `*_prev`: the previous frame's side of a
    /// [`PingPong`].
    struct RestirBindings from 8 {
        gbuffer_depth: read,
        gbuffer_normal: read,
        gbuffer_base_color: read,
        gbuffer_metallic_roughness: read,
        gbuffer_motion: read,
        receivers: read,
        surfaces_prev: read,
        /// `initial`, `specular_noisy` and `denoised` are one buffer
        /// ([`RestirBuffers::transient`]).
        initial: read_write,
        temporal_out: read_write,
        temporal_prev: read,
        resolved: read_write,
        irradiance: read_write,
        denoised: read_write,
        direct_mean: read,
        output: read_write,
        /// `specular_samples` and `irradiance` are one buffer ([`RestirBuffers::rays`]).
        specular_samples: read_write,
        specular_noisy: read_write,
        specular_history: read_write,
        /// The specular history each pixel finds in the previous frame, in the buffer of
        /// `resolved` ([`RestirBuffers::resolved`]).
        specular_reprojected: read_write,
        gbuffer_emissive: read,
        gbuffer_blend_layer: read,
        previous_geometry: read,
    }
}

/// What one frame of the PC tier writes and the next reads as its history.
struct FrameBuffers {
    /// Receivers whole (`GpuSurface`), one per trace pixel, kept for the next frame's temporal
    /// reuse. Without it, the only pass that reads them, both sides are one buffer of one
    /// entry, never written.
    surfaces: wgpu::Buffer,
    /// Temporal reservoirs, one per trace pixel (one in all without temporal reuse: never
    /// read then).
    temporal: wgpu::Buffer,
}

impl FrameBuffers {
    fn release(&self, ctx: &GpuContext) {
        for buffer in [&self.surfaces, &self.temporal] {
            ctx.release_buffer(buffer);
        }
    }
}

/// The technique's resolution-dependent buffers (labels `pc.*`).
pub(super) struct RestirBuffers {
    pub(super) trace_size: (u32, u32),
    pub(super) uniforms: wgpu::Buffer,
    /// This frame's and the previous frame's, swapped at the end of a frame.
    frames: PingPong<FrameBuffers>,
    /// Per trace pixel: this frame's receiver's pixel (x | y << 16, `u32::MAX` for none); its
    /// depth and normal are the G-buffer's there, so they are not kept.
    receivers: wgpu::Buffer,
    /// The next three buffers each serve several roles whose lives within a frame do not
    /// overlap, bound under each role's name; every name bound to one of them is `read_write`
    /// (a dispatch may not bind a buffer both read-only and writable). Each is sized for its
    /// largest role.
    ///
    /// `pc.transient`: `initial`, the trace pixels' new reservoirs (from `pc/trace` to the
    /// last pass that reads them, `pc/shadow` at the latest); then `specular_noisy`, per pixel
    /// the specular input (`pack_color64`: rgb and its kind; from `pc/specular_resolve` to
    /// `pc/specular_temporal`); then the denoiser's output (`LentBuffers::output`: from its
    /// first pass until `pc/compose` and the frame's read-back).
    pub(super) transient: wgpu::Buffer,
    /// `pc.rays`: `specular_samples`, this frame's specular ray per trace pixel (from
    /// `pc/specular_trace` to `pc/specular_resolve`); then `irradiance`, per pixel the
    /// multi-sample shading's irradiance (`pack_color64`; from `pc/shade` to the denoiser's
    /// `pc/denoise_temporal` and the frame's read-back).
    pub(super) rays: wgpu::Buffer,
    /// `pc.resolved`: `resolved`, per trace pixel the spatial reuse's result, then the shadow
    /// pass's (in place; until `pc/shade`); then `specular_reprojected`, per pixel the
    /// specular history found in the previous frame (`pc/specular_temporal`'s first dispatch
    /// to its second); then the denoiser's scratch (`LentBuffers::scratch`: from its first
    /// pass to its last).
    pub(super) resolved: wgpu::Buffer,
    /// The specular history, 5 bytes a pixel: per pixel the radiance or ratio (RGB9E5,
    /// rounded stochastically), then a byte per pixel with the length and the kind
    /// (`pack_specular_history`), updated in place: `pc/specular_temporal` first copies what
    /// each pixel reprojects to into `specular_reprojected`.
    pub(super) specular_history: wgpu::Buffer,
    pub(super) output: wgpu::Buffer,
    /// The temporal gradients' strata; `None`: gradients off.
    pub(super) gradient_grid: Option<GradientGrid>,
    /// Per stratum, in two halves by frame parity: the ray candidate `trace` keeps for the next
    /// frame's gradient.
    gradient_samples: wgpu::Buffer,
    /// Per stratum: the gradient and its lambda (`vec4<f32>`).
    pub(super) gradients: wgpu::Buffer,
    /// Whether `frames.history()` holds the previous frame's surfaces and reservoirs.
    pub(super) history: bool,
}

impl RestirBuffers {
    /// Without temporal reuse the temporal reservoirs are never read: they hold one each.
    pub(super) fn new(
        ctx: &GpuContext,
        size: (u32, u32),
        trace_scale: u32,
        temporal: bool,
        gradient_stratum: Option<u32>,
    ) -> Self {
        let trace_size = (size.0.div_ceil(trace_scale), size.1.div_ceil(trace_scale));
        let gradient_grid = gradient_stratum.map(|side| GradientGrid {
            scale: side * trace_scale,
            strata: (trace_size.0.div_ceil(side), trace_size.1.div_ceil(side)),
        });
        let strata = gradient_grid.map_or(1, |g| u64::from(g.strata.0) * u64::from(g.strata.1));
        let traced = u64::from(trace_size.0) * u64::from(trace_size.1);
        let pixels = u64::from(size.0) * u64::from(size.1);
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let buffer = |label: &str, bytes: u64| ctx.create_buffer(label, bytes.max(16), storage);
        let reservoirs = traced * size_of::<GpuReservoir>() as u64;
        // A binding holds at least one element.
        let one = size_of::<GpuReservoir>() as u64;
        let surfaces = traced * size_of::<GpuSurface>() as u64;
        let shared_surfaces = (!temporal).then(|| buffer("pc.surfaces", 0));
        Self {
            trace_size,
            uniforms: ctx.create_buffer(
                "pc.uniforms",
                size_of::<PcUniforms>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            frames: PingPong::from_fn(|_| FrameBuffers {
                surfaces: shared_surfaces
                    .clone()
                    .unwrap_or_else(|| buffer("pc.surfaces", surfaces)),
                temporal: buffer("pc.temporal", if temporal { reservoirs } else { one }),
            }),
            receivers: buffer("pc.receivers", traced * 4),
            transient: buffer(
                "pc.transient",
                reservoirs
                    .max(pixels * SPECULAR_NOISY_PIXEL_BYTES)
                    .max(pixels * OUTPUT_PIXEL_BYTES),
            ),
            resolved: buffer(
                "pc.resolved",
                reservoirs
                    .max(pixels * SPECULAR_REPROJECTED_PIXEL_BYTES)
                    .max(pixels * SCRATCH_PIXEL_BYTES),
            ),
            specular_history: buffer("pc.specular_history", specular_history_bytes(pixels)),
            rays: buffer(
                "pc.rays",
                (traced * size_of::<GpuSpecularSample>() as u64)
                    .max(pixels * IRRADIANCE_PIXEL_BYTES),
            ),
            output: buffer("pc.output", pixels * 16),
            gradient_grid,
            gradient_samples: buffer(
                "pc.gradient_samples",
                2 * strata * size_of::<GpuGradientSample>() as u64,
            ),
            gradients: buffer("pc.gradients", strata * 16),
            history: false,
        }
    }

    /// The temporal gradients for the denoiser; `None` when they are off.
    pub(super) fn gradient_source(&self) -> Option<GradientSource<'_>> {
        self.gradient_grid.map(|grid| GradientSource {
            buffer: &self.gradients,
            grid,
        })
    }

    /// Ends a frame: its receivers and temporal reservoirs become the next frame's history
    /// (the specular history is updated in place).
    pub(super) fn end_frame(&mut self) {
        self.frames.swap();
        self.history = true;
    }

    /// The temporal reservoirs the last ended frame kept for the next one (one entry without
    /// temporal reuse).
    pub(super) fn kept_temporal_reservoirs(&self) -> &wgpu::Buffer {
        &self.frames.history().temporal
    }

    pub(super) fn release(&self, ctx: &GpuContext) {
        for frame in self.frames.both() {
            frame.release(ctx);
        }
        for buffer in [
            &self.uniforms,
            &self.receivers,
            &self.transient,
            &self.resolved,
            &self.specular_history,
            &self.rays,
            &self.output,
            &self.gradient_samples,
            &self.gradients,
        ] {
            ctx.release_buffer(buffer);
        }
    }
}

/// What one frame of the technique reads. The bind groups also name buffers that passes
/// later in the frame write ([`Restir::compose`] reads them): the denoiser's output and the
/// direct light's mean.
pub(super) struct RestirInputs<'a> {
    pub scene: &'a GpuScene,
    /// The brick cache's bind group (group 2), which the hits and the sky read.
    pub cache: &'a wgpu::BindGroup,
    pub gbuffer: GBufferOutputs<'a>,
    /// The denoised irradiance the compose pass reads (the denoiser's output).
    pub denoised: &'a wgpu::Buffer,
    /// The direct light's mean (the compose pass adds the GI to it).
    pub direct: &'a wgpu::Buffer,
    /// The previous frame's G-buffer depth and normal (the denoiser's, valid until the
    /// denoiser records this frame), which the specular history is checked against.
    pub previous_geometry: &'a wgpu::Buffer,
    /// Which passes run.
    pub config: &'a PcConfig,
    /// Image size in pixels.
    pub size: (u32, u32),
}

/// One frame's bind groups: group 0 of the passes that trace rays ([`TraceBindings`]) and the
/// one of the passes after them ([`RestirBindings`]), over this frame's side of the histories.
pub(super) struct RestirGroups {
    trace: wgpu::BindGroup,
    restir: wgpu::BindGroup,
}

impl RestirBuffers {
    /// The frame's bind groups over these buffers and `inputs`.
    pub(super) fn groups(
        &self,
        ctx: &GpuContext,
        pipelines: &RestirPipelines,
        inputs: &RestirInputs<'_>,
    ) -> RestirGroups {
        RestirGroups {
            trace: self.trace_group(ctx, pipelines, inputs),
            restir: self.restir_group(ctx, pipelines, inputs),
        }
    }

    fn trace_group(
        &self,
        ctx: &GpuContext,
        pipelines: &RestirPipelines,
        inputs: &RestirInputs<'_>,
    ) -> wgpu::BindGroup {
        let b = self;
        let frame = b.frames.current();
        let g = &inputs.gbuffer;
        let mut entries = buffer_entries(0, [&b.uniforms]);
        entries.extend(inputs.scene.bind_group_entries());
        entries.extend(
            TraceBindings {
                gbuffer_depth: g.depth,
                gbuffer_normal: g.normal,
                receivers: &b.receivers,
                initial: &b.transient,
                temporal: &frame.temporal,
                resolved: &b.resolved,
                gbuffer_base_color: g.base_color,
                gbuffer_metallic_roughness: g.metallic_roughness,
                specular_samples: &b.rays,
                gradient_samples: &b.gradient_samples,
                gradients: &b.gradients,
                surfaces: &frame.surfaces,
            }
            .entries(),
        );
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pc/trace.group0"),
            layout: &pipelines.trace_layout,
            entries: &entries,
        })
    }

    fn restir_group(
        &self,
        ctx: &GpuContext,
        pipelines: &RestirPipelines,
        inputs: &RestirInputs<'_>,
    ) -> wgpu::BindGroup {
        let b = self;
        let (frame, previous) = (b.frames.current(), b.frames.history());
        let g = &inputs.gbuffer;
        let mut entries = buffer_entries(0, [&b.uniforms]);
        entries.extend(
            RestirBindings {
                gbuffer_depth: g.depth,
                gbuffer_normal: g.normal,
                gbuffer_base_color: g.base_color,
                gbuffer_metallic_roughness: g.metallic_roughness,
                gbuffer_motion: g.motion,
                receivers: &b.receivers,
                surfaces_prev: &previous.surfaces,
                initial: &b.transient,
                temporal_out: &frame.temporal,
                temporal_prev: &previous.temporal,
                resolved: &b.resolved,
                irradiance: &b.rays,
                denoised: inputs.denoised,
                direct_mean: inputs.direct,
                output: &b.output,
                specular_samples: &b.rays,
                specular_noisy: &b.transient,
                specular_history: &b.specular_history,
                specular_reprojected: &b.resolved,
                gbuffer_emissive: g.emissive,
                gbuffer_blend_layer: g.blend_layer,
                previous_geometry: inputs.previous_geometry,
            }
            .entries(),
        );
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pc/restir.group0"),
            layout: &pipelines.restir_layout,
            entries: &entries,
        })
    }
}

/// The technique: the pipelines, the buffers with their histories, and the bind groups of
/// the frame it recorded last, which [`Restir::compose`] binds.
pub(super) struct Restir {
    pipelines: RestirPipelines,
    pub(super) buffers: RestirBuffers,
    recorded: Option<RecordedFrame>,
}

/// What the compose pass binds of the frame recorded last.
struct RecordedFrame {
    groups: RestirGroups,
    cache: wgpu::BindGroup,
    full_workgroups: (u32, u32),
}

impl Restir {
    /// The technique for images of `size`, tracing one pixel in `trace_scale` per axis.
    /// Without temporal reuse the temporal reservoirs are never read: they hold one each.
    pub(super) fn new(
        ctx: &GpuContext,
        pipelines: &RestirPipelines,
        size: (u32, u32),
        trace_scale: u32,
        temporal: bool,
        gradient_stratum: Option<u32>,
    ) -> Self {
        Self {
            pipelines: pipelines.clone(),
            buffers: RestirBuffers::new(ctx, size, trace_scale, temporal, gradient_stratum),
            recorded: None,
        }
    }

    /// Records `pc/compose`: the final image, the direct light plus the denoised diffuse and
    /// the specular GI, weighted by the G-buffer's material, over the bind groups of the frame
    /// recorded last; returns `pc.output`. Nothing is recorded before the first frame.
    pub(super) fn compose(&self, rec: &mut Recorder<'_>) -> &wgpu::Buffer {
        if let Some(frame) = &self.recorded {
            rec.compute_pass("pc/compose", |pass| {
                pass.set_pipeline(&self.pipelines.compose);
                pass.set_bind_group(0, &frame.groups.restir, &[]);
                pass.set_bind_group(CacheBuffers::BIND_GROUP, &frame.cache, &[]);
                let groups = frame.full_workgroups;
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            });
        }
        &self.buffers.output
    }

    /// Ends a frame: its receivers and temporal reservoirs become the next frame's history
    /// (the specular history is updated in place).
    pub(super) fn end_frame(&mut self) {
        self.buffers.end_frame();
    }

    pub(super) fn release(&self, ctx: &GpuContext) {
        self.buffers.release(ctx);
    }
}

impl Technique for Restir {
    type Inputs<'i> = RestirInputs<'i>;
    /// The frame's result is `irradiance` in `pc.rays`, the shaded diffuse irradiance per
    /// pixel before denoising, which the denoiser was made over
    /// ([`super::denoise::DenoiseSources`]).
    type Outputs<'o> = ();

    /// Records the passes before the denoiser, each under its name, in order: `pc/trace`
    /// (a diffuse ray per trace pixel, its hit shaded from the brick cache; with temporal
    /// gradients also last frame's kept ray candidates drawn again), `pc/gradient` (their
    /// lambda),
    /// `pc/specular_trace`, `pc/temporal` and `pc/spatial` (ReSTIR GI reuse), `pc/shadow` (the
    /// chosen samples' visibility), `pc/specular_resolve`, `pc/shade` (multi-sample shading
    /// into `irradiance`) and `pc/specular_temporal`, each as the config switches it on.
    fn record(&mut self, rec: &mut Recorder<'_>, inputs: &RestirInputs<'_>) {
        let groups = self.buffers.groups(rec.ctx, &self.pipelines, inputs);
        let (tw, th) = self.buffers.trace_size;
        let trace_workgroups = (tw.div_ceil(TILE), th.div_ceil(TILE));
        let size = inputs.size;
        let full_workgroups = (size.0.div_ceil(TILE), size.1.div_ceil(TILE));
        let config = inputs.config;
        let p = &self.pipelines;
        // Each pass: name, its pipelines (dispatched in turn over the same workgroups), whether
        // it traces (BVH bound, the trace module's group 0) and whether it runs per trace pixel
        // (else per pixel).
        let specular = config.specular.traced;
        let mut steps = vec![("pc/trace", vec![&p.trace], true, true)];
        if specular {
            steps.push(("pc/specular_trace", vec![&p.specular_trace], true, true));
        }
        // Without temporal reuse the spatial reuse and the shadow pass read the initial
        // reservoirs.
        if config.restir.temporal {
            steps.push(("pc/temporal", vec![&p.temporal], false, true));
        }
        if config.restir.spatial {
            steps.push(("pc/spatial", vec![&p.spatial], false, true));
        }
        steps.push(("pc/shadow", vec![&p.shadow], true, true));
        // The specular rays are resolved before `shade` (each writes the specular input of
        // pixels the other leaves alone), so that `shade`'s irradiance takes their buffer.
        if specular {
            steps.push((
                "pc/specular_resolve",
                vec![&p.specular_resolve],
                false,
                false,
            ));
        }
        steps.push(("pc/shade", vec![&p.shade], false, false));
        if specular || config.specular.reuse_diffuse {
            // Two dispatches: every pixel's history found in the previous frame is copied out
            // before any pixel updates the one history buffer in place.
            let passes = vec![&p.specular_reproject, &p.specular_temporal];
            steps.push(("pc/specular_temporal", passes, false, false));
        }
        let scene = inputs.scene;
        // `trace` also draws last frame's kept rays again, one per gradient stratum, in rows of
        // workgroups below its own: the other rays hide their latency.
        let grid = self.buffers.gradient_grid;
        let gradient_rows = grid.map_or(0, |g| g.strata.1.div_ceil(TILE));
        for (name, pipelines, traces, per_trace_pixel) in steps {
            rec.compute_pass(name, |pass| {
                if traces {
                    pass.set_bind_group(0, &groups.trace, &[]);
                    pass.set_bind_group(BVH_BIND_GROUP, &scene.bvh.bind_group, &[]);
                    scene.set_texture_bind_group(pass);
                } else {
                    pass.set_bind_group(0, &groups.restir, &[]);
                }
                pass.set_bind_group(CacheBuffers::BIND_GROUP, inputs.cache, &[]);
                let groups = match (per_trace_pixel, name) {
                    (true, "pc/trace") => (trace_workgroups.0, trace_workgroups.1 + gradient_rows),
                    (true, _) => trace_workgroups,
                    (false, _) => full_workgroups,
                };
                for pipeline in pipelines {
                    pass.set_pipeline(pipeline);
                    pass.dispatch_workgroups(groups.0, groups.1, 1);
                }
            });
            if name == "pc/trace"
                && let Some(grid) = grid
            {
                rec.compute_pass("pc/gradient", |pass| {
                    pass.set_pipeline(&p.gradient_filter);
                    pass.set_bind_group(0, &groups.trace, &[]);
                    pass.set_bind_group(BVH_BIND_GROUP, &scene.bvh.bind_group, &[]);
                    scene.set_texture_bind_group(pass);
                    pass.set_bind_group(CacheBuffers::BIND_GROUP, inputs.cache, &[]);
                    pass.dispatch_workgroups(
                        grid.strata.0.div_ceil(TILE),
                        grid.strata.1.div_ceil(TILE),
                        1,
                    );
                });
            }
        }
        self.recorded = Some(RecordedFrame {
            groups,
            cache: inputs.cache.clone(),
            full_workgroups,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_gpu::binding::{Access, check_declared, wgsl_storage_bindings};

    /// The passes of `shaders/pc/restir/`, each in its own file.
    const PASSES: [&str; 10] = [
        "gradient",
        "trace",
        "shadow",
        "specular_trace",
        "temporal",
        "spatial",
        "shade",
        "compose",
        "specular_resolve",
        "specular_temporal",
    ];

    #[test]
    fn the_shaders_declare_the_named_buffers_at_their_bindings() {
        let shaders = ShaderLibrary::new();
        let groups = [
            (
                "pc/restir/rays.wgsl",
                TraceBindings::FIRST_BINDING,
                TraceBindings::SLOTS,
            ),
            (
                "pc/restir/bindings.wgsl",
                RestirBindings::FIRST_BINDING,
                RestirBindings::SLOTS,
            ),
        ];
        for (file, first, slots) in groups {
            let source = shaders.source(file).expect("the shader is in the library");
            check_declared(source, 0, first, slots).unwrap_or_else(|e| panic!("{file}: {e}"));
        }
        // The passes declare none of group 0's buffers themselves: they import them from the
        // two files checked above.
        for pass in PASSES {
            let file = format!("pc/restir/{pass}.wgsl");
            let source = shaders.source(&file).expect("the pass is in the library");
            assert_eq!(wgsl_storage_bindings(source, 0), [], "{file}");
        }
        // A swapped pair or a changed access is caught.
        let source = shaders
            .source("pc/restir/bindings.wgsl")
            .expect("the bindings");
        let mut swapped = RestirBindings::SLOTS.to_vec();
        swapped.swap(5, 6);
        assert!(check_declared(source, 0, 8, &swapped).is_err());
        let mut written = RestirBindings::SLOTS.to_vec();
        written[0].1 = Access::ReadWrite;
        assert!(check_declared(source, 0, 8, &written).is_err());
    }
}

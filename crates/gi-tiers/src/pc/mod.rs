//! The PC tier (`pc`): BVH-traced ReSTIR GI over the brick radiance cache, with HSGI's
//! visibility ("shadow") ray, multi-sample shading and an SVGF denoiser (HSGI, GDC 2023, "PC /
//! Console Solution"; ReSTIR GI, Ouyang et al. 2021; SVGF, Schied et al. 2017).
//!
//! A frame: `gbuffer/primary` (ray-cast G-buffer), the cache update (`cache/*`, as the mobile
//! tier's), `pc/trace` (one BVH ray per trace pixel, shaded at the hit with exact direct light,
//! one sample of the emitters included, and the cache's bounced light; the tier's cache keeps
//! its emitted part apart for that, [`gi_cache::CacheConfig::keep_emitted`]),
//! last frame's kept rays drawn again in the same dispatch and `pc/gradient` after it (the
//! temporal gradients that shorten the denoiser's histories where the light changed,
//! [`GradientConfig`]),
//! `pc/specular_trace` (one GGX VNDF ray per trace pixel on surfaces smoother than
//! [`SpecularConfig::max_roughness`]), `pc/temporal` (only with temporal reuse, off by default:
//! [`RestirConfig::temporal`]), `pc/spatial`, `pc/shadow` (the reservoir passes),
//! `pc/specular_resolve` (the specular rays to a per-pixel reflected radiance), `pc/shade`
//! (multi-sample shading to full resolution, and the rough surfaces' lobe ratio),
//! `pc/specular_temporal` (both specular inputs over time), `pc/denoise_*` (temporal
//! supersampling and SVGF: [`denoise`]), `direct/trace` + `direct/resolve` (direct light, accumulated while the view holds
//! still, as the mobile tier does) and `pc/compose`. The GI's cost is the `cache/*` and `pc/*`
//! passes. Pass `pc/<pass>` is the file `shaders/pc/restir/<pass>.wgsl` (the hit shading of
//! `pc/trace` and `pc/specular_trace` is `hit.wgsl` there), pass `pc/denoise_<pass>` the file
//! `shaders/pc/denoise/<pass>.wgsl`.

mod config;
pub mod denoise;
mod restir;

pub use config::{
    GradientConfig, HitLights, PC_OPTIONAL_STAGES, PC_STAGES, PcConfig, RestirConfig,
    SpecularConfig, TraceMode,
};

use bytemuck::{Pod, Zeroable};
use gi_cache::lighting::GpuSky;
use gi_cache::{CacheLighting, RadianceCache, binning::dynamic_triangles};
use gi_gpu::gbuffer::{GBUFFER_MISS, GBuffer};
use gi_gpu::{GpuCamera, GpuContext, GpuError, GpuTimer, Recorder, ShaderLibrary, Technique, wgpu};
use gi_image::Image;
use gi_scene::SceneFrame;

use crate::output::GpuOutput;
use crate::realtime::record_gbuffer_and_cache;
use crate::requirements::{FrameCost, Requirements, image_bytes};
use crate::scene_state::{SceneState, check_frame_settings, read_image, read_packed_image};
use crate::tier::{FrameInput, TierError, TierKind, TierSettings};
use crate::tracer::{DirectInputs, PathPipelines};
use denoise::{DenoiseInputs, DenoisePipelines, DenoiseSources, Denoiser, LentBuffers};
use restir::{Restir, RestirInputs, RestirPipelines};

/// Most timed passes in one frame.
const TIMER_SCOPES: u32 = 56;

/// Mirror of `PcUniforms` in `shaders/pc/restir/common.wgsl`, 304 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PcUniforms {
    pub camera: GpuCamera,
    pub previous_camera: GpuCamera,
    pub sky: GpuSky,
    pub size_px: [u32; 2],
    pub trace_px: [u32; 2],
    pub seed: [u32; 2],
    pub frame_index: u32,
    pub trace_scale: u32,
    /// `FLAG_*` bits of the shader: which stages run, and whether history exists.
    pub flags: u32,
    pub light_count: u32,
    pub default_material: u32,
    pub m_clamp: f32,
    pub jacobian_max: f32,
    pub spatial_radius: f32,
    pub spatial_samples: u32,
    pub shade_radius: u32,
    pub normal_cos: f32,
    pub plane_tolerance: f32,
    pub boil_factor: f32,
    pub shadow_cos: f32,
    pub shadow_distance_ratio: f32,
    /// Emissive triangles in the scene's emitter table.
    pub emitter_count: u32,
    pub specular_max_roughness: f32,
    pub specular_history: f32,
    pub specular_clamp_sigma: f32,
    /// BVH segment length of a diffuse ray (`f32::MAX` unless in trace-probe mode).
    pub probe_ray_m: f32,
    /// Multi-sample shading skips a neighbour whose sample lies nearer its receiver than this
    /// times the two receivers' distance (0: never).
    pub shade_contact_ratio: f32,
    /// Roughness above which the reused rough reflection blends to the irradiance over pi.
    pub specular_diffuse_from: f32,
    /// Trace pixels per side of a temporal-gradient stratum; 0: no gradients.
    pub gradient_stratum: u32,
    pub gradient_strata_x: u32,
    pub gradient_strata_y: u32,
    /// [`GradientConfig::gain`].
    pub gradient_gain: f32,
}

/// Mirror of `GradientSample` in `shaders/pc/restir/common.wgsl`, 32 bytes: the BVH ray
/// candidate one trace pixel of a temporal-gradient stratum drew, kept for the next frame's
/// `pc/gradient` to draw again.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGradientSample {
    /// The receiver's offset ray origin.
    pub origin: [f32; 3],
    /// The receiver's packed normal.
    pub normal: u32,
    /// Luminance of what the ray found outside the brick cache (its hit's emission and
    /// direct light, or the sky).
    pub seen: f32,
    /// The trace pixel (row-major), `u32::MAX`: no sample.
    pub trace_index: u32,
    pub frame_index: u32,
    /// Luminance of all the ray found.
    pub total: f32,
}

/// Mirror of `StoredReservoir` in `shaders/pc/restir/common.wgsl`, 32 bytes: a ReSTIR GI
/// reservoir as the buffers keep it. The initial and temporal reservoirs keep in `m_extra`'s
/// high half and in `extra` what a later frame needs to refresh a surface sample (albedo as
/// unorm 5:6:5, the RGB9E5 emission plus punctual lights' and emitters' direct light); the
/// resolved ones the shadow pass's occluder (f16 distance, packed direction).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuReservoir {
    /// The sample point, or a sky sample's unit direction.
    pub position: [f32; 3],
    /// Unbiased contribution weight W.
    pub w: f32,
    /// RGB9E5 radiance leaving the sample towards the receiver.
    pub radiance: u32,
    /// The sample's packed normal cut to 15 bits a component (bits 0-29) and the flags (bits
    /// 30-31: sky sample; occluded, fell back to the temporal reservoir).
    pub normal_flags: u32,
    /// M as an f16 (bits 0-15), and the albedo or the occluder's distance (bits 16-31).
    pub m_extra: u32,
    /// The fixed radiance, or the occluder's direction.
    pub extra: u32,
}

impl GpuReservoir {
    /// Samples behind the reservoir, M.
    pub fn m(&self) -> f32 {
        gi_cache::packing::half_value(self.m_extra & 0xffff)
    }

    /// Bit 0: sky sample; bit 1: occluded.
    pub fn flags(&self) -> u32 {
        self.normal_flags >> 30
    }
}

/// Mirror of `SpecularSample` in `shaders/pc/restir/common.wgsl`, 32 bytes: one trace pixel's
/// specular ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSpecularSample {
    /// The hit point, or for a miss (flag bit 0) the ray's unit direction.
    pub position: [f32; 3],
    /// Solid-angle pdf of the ray's VNDF sample at its receiver; 0: no sample.
    pub pdf: f32,
    /// Radiance arriving along the ray.
    pub radiance: [f32; 3],
    pub flags: u32,
}

/// Mirror of `StoredSurface` in `shaders/pc/restir/common.wgsl`, 12 bytes: one trace pixel's
/// receiver, kept whole only for the next frame's temporal reuse (this frame's receivers are
/// their pixels alone, `pc.receivers`: their depth and normal are the G-buffer's there). Its
/// position is not kept: the shaders compute it from the pixel and the depth with the camera
/// of the frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSurface {
    /// The full-resolution pixel's column and row, `x | y << 16`.
    pub pixel_xy: u32,
    /// G-buffer depth; 0 when the trace pixel has no surface.
    pub depth: f32,
    /// Packed normal.
    pub normal: u32,
}

/// Shader flag bits (`FLAG_*` in `shaders/pc/restir/common.wgsl`).
mod flags {
    pub const TEMPORAL: u32 = 1;
    pub const SPATIAL: u32 = 2;
    pub const SHADOW: u32 = 4;
    pub const MULTI_SAMPLE: u32 = 8;
    pub const BOILING: u32 = 16;
    pub const HISTORY: u32 = 32;
    pub const SPECULAR: u32 = 64;
    pub const REUSE_SPECULAR: u32 = 128;
    pub const MATERIAL_OCCLUSION: u32 = 256;
    pub const BLEND_LAYER: u32 = 512;
    pub const HIT_LIGHTS_CACHE: u32 = 1024;
}

/// GPU memory of the PC tier by what it scales with.
pub type PcMemory = crate::realtime::GiMemory;

/// One frame's intermediate images, for tests and metrics.
#[derive(Clone, Debug)]
pub struct PcFrameData {
    /// The GI term the tier added to the direct light.
    pub gi: Image,
    /// The multi-sample shading's irradiance, before denoising.
    pub noisy_irradiance: Image,
    /// The denoised irradiance.
    pub irradiance: Image,
    /// With temporal reuse, the trace pixels' temporal reservoirs (row-major, `trace_size`):
    /// what the next frame reuses. (The resolved reservoirs' buffer holds the denoiser's
    /// scratch by the frame's end.)
    pub temporal_reservoirs: Option<Vec<GpuReservoir>>,
    pub trace_size: (u32, u32),
    /// The temporal gradients' strata per row and column, and each one's lambda (row-major):
    /// the share of history the denoiser dropped there this frame. `None` without gradients.
    pub gradient_lambda: Option<((u32, u32), Vec<f32>)>,
    /// Per pixel, from the G-buffer: distance along the pixel's unit ray, `+inf` for sky.
    pub depth: Vec<f32>,
    /// Per pixel, from the G-buffer: previous pixel position minus this pixel's center, in
    /// pixels.
    pub motion: Vec<[f32; 2]>,
    /// Per pixel: it shows a triangle that an animation moves.
    pub dynamic: Vec<bool>,
}

/// What the PC tier with `config` needs of an adapter at `settings`' resolution. The passes
/// after the rays bind the most storage buffers: 22 of their own and the brick cache's 7 (the
/// trace passes as many: the scene's 7, 11 of their own, the BVH's 4 and the cache's 7; the
/// denoiser 12); the cache passes as for mobile. The largest binding is an image buffer or
/// the reservoirs, surfaces or specular samples of every trace pixel.
pub fn requirements(settings: &TierSettings, config: &PcConfig) -> Requirements {
    let scale = config.trace_scale.max(1);
    let traced =
        u64::from(settings.width.div_ceil(scale)) * u64::from(settings.height.div_ceil(scale));
    let per_trace_pixel = [
        size_of::<GpuReservoir>(),
        size_of::<GpuSurface>(),
        size_of::<GpuSpecularSample>(),
    ]
    .into_iter()
    .max()
    .unwrap_or(0) as u64;
    Requirements::compute(29, image_bytes(settings).max(traced * per_trace_pixel))
}

/// The PC tier's measured cost per frame on an H100, for [`crate::select`].
pub const H100_COST: FrameCost = FrameCost {
    kind: TierKind::Pc,
    points: &[(2.0736, 4.42)],
    source: "benchmarks/results/h100-2026-11-27-atrous-kernel/bundled/pc-1.md, `gi-bench pc \
             --scenes dynamic --size 1920x1080 --frames 64`, variant atrous-3x3-5 (the default \
             since): GI 3.255 + gbuffer/primary 0.346 + direct 0.814 ms",
};

/// The PC tier. See the module docs.
pub struct PcTier {
    settings: TierSettings,
    config: PcConfig,
    ctx: GpuContext,
    shaders: ShaderLibrary,
    timer: GpuTimer,
    direct_pipelines: PathPipelines,
    pipelines: RestirPipelines,
    denoise_pipelines: DenoisePipelines,
    gbuffer: GBuffer,
    cache: RadianceCache,
    prepared: Option<Prepared>,
    frame_index: u32,
}

/// What the tier uploaded for its scene.
struct Prepared {
    state: SceneState,
    restir: Restir,
    denoiser: Denoiser,
    /// Per triangle of the uploaded frame: moved by an animation (for [`PcFrameData`]).
    dynamic_triangles: Vec<bool>,
}

impl Prepared {
    fn release(self, ctx: &GpuContext) {
        self.restir.release(ctx);
        self.denoiser.release(ctx);
        self.state.release(ctx);
    }
}

impl PcTier {
    /// A PC tier on `ctx`. Fails when the configuration or the image size is unusable or the
    /// shaders do not compile on the device.
    pub fn new(
        settings: TierSettings,
        config: PcConfig,
        ctx: GpuContext,
    ) -> Result<Self, TierError> {
        let unavailable = |reason: String| TierError::Unavailable { tier: "pc", reason };
        check_frame_settings(
            TierKind::Pc,
            &settings,
            &requirements(&settings, &config),
            &ctx,
        )?;
        config.validate().map_err(unavailable)?;
        let shaders = ShaderLibrary::new();
        let gpu = |e: GpuError| unavailable(e.to_string());
        let direct_pipelines = PathPipelines::real_time_direct(&ctx).map_err(gpu)?;
        let gbuffer = GBuffer::new(&ctx, &shaders, settings.width, settings.height).map_err(gpu)?;
        let mut cache =
            RadianceCache::new(&ctx, &config.cache).map_err(|e| unavailable(e.to_string()))?;
        CacheLighting::attach(&ctx, &shaders, &mut cache).map_err(gpu)?;
        let pipelines = RestirPipelines::new(&ctx, &shaders).map_err(gpu)?;
        let denoise_pipelines = DenoisePipelines::new(&ctx, &shaders).map_err(gpu)?;
        let timer = GpuTimer::new(&ctx, "pc", TIMER_SCOPES);
        Ok(Self {
            settings,
            config,
            ctx,
            shaders,
            timer,
            direct_pipelines,
            pipelines,
            denoise_pipelines,
            gbuffer,
            cache,
            prepared: None,
            frame_index: 0,
        })
    }

    /// The last frame's GI term and intermediate images, read back from the GPU (stalls);
    /// `None` before the first frame. For tests and metrics.
    pub fn frame_data(&self) -> Option<PcFrameData> {
        let prepared = self.prepared.as_ref()?;
        let ctx = &self.ctx;
        let (width, height) = (self.settings.width, self.settings.height);
        let read = |buffer: &wgpu::Buffer| read_image(ctx, buffer, (width, height));
        let buffers = &prepared.restir.buffers;
        let output = read(&buffers.output);
        let direct = read(&prepared.state.direct.mean);
        let gi = Image {
            width,
            height,
            pixels: output
                .pixels
                .iter()
                .zip(&direct.pixels)
                .map(|(o, d)| *o - *d)
                .collect(),
        };
        let gbuffer = self.gbuffer.read(ctx);
        let dynamic = gbuffer
            .triangle
            .iter()
            .map(|&t| {
                let moved = prepared.dynamic_triangles.get(t as usize);
                t != GBUFFER_MISS && moved.copied().unwrap_or(false)
            })
            .collect();
        Some(PcFrameData {
            gi,
            noisy_irradiance: read_packed_image(ctx, &buffers.rays, (width, height)),
            irradiance: read_packed_image(ctx, prepared.denoiser.output(), (width, height)),
            temporal_reservoirs: (self.config.restir.temporal)
                .then(|| ctx.read_buffer(buffers.kept_temporal_reservoirs())),
            trace_size: buffers.trace_size,
            gradient_lambda: buffers.gradient_grid.map(|grid| {
                let entries: Vec<[f32; 4]> = ctx.read_buffer(&buffers.gradients);
                (grid.strata, entries.iter().map(|g| g[2]).collect())
            }),
            depth: gbuffer.depth,
            motion: gbuffer.motion,
            dynamic,
        })
    }

    fn uniforms(&self, frame: &SceneFrame, previous: &SceneFrame, history: bool) -> PcUniforms {
        let size = (self.settings.width, self.settings.height);
        let r = &self.config.restir;
        let prepared = self.prepared.as_ref().expect("prepared before uniforms");
        let trace_size = prepared.restir.buffers.trace_size;
        let gradient_grid = prepared.restir.buffers.gradient_grid;
        let mut bits = 0;
        for (on, bit) in [
            (r.temporal, flags::TEMPORAL),
            (r.spatial, flags::SPATIAL),
            (r.shadow_ray, flags::SHADOW),
            (r.multi_sample, flags::MULTI_SAMPLE),
            (r.boiling_filter, flags::BOILING),
            (history, flags::HISTORY),
            (self.config.specular.traced, flags::SPECULAR),
            (self.config.specular.reuse_diffuse, flags::REUSE_SPECULAR),
            (self.config.material_occlusion, flags::MATERIAL_OCCLUSION),
            (self.gbuffer.has_blend_layer(), flags::BLEND_LAYER),
            (
                self.config.hit_lights == HitLights::Cache,
                flags::HIT_LIGHTS_CACHE,
            ),
        ] {
            if on {
                bits |= bit;
            }
        }
        let seed = self.settings.seed;
        PcUniforms {
            camera: GpuCamera::new(&frame.camera, size),
            previous_camera: GpuCamera::new(&previous.camera, size),
            sky: GpuSky::new(&frame.sky),
            size_px: [size.0, size.1],
            trace_px: [trace_size.0, trace_size.1],
            seed: [seed as u32, (seed >> 32) as u32],
            frame_index: self.frame_index,
            trace_scale: self.config.trace_scale,
            flags: bits,
            light_count: frame.lights.len() as u32,
            default_material: prepared.state.scene.default_material,
            m_clamp: r.m_clamp,
            jacobian_max: r.jacobian_max,
            spatial_radius: r.spatial_radius,
            spatial_samples: r.spatial_samples,
            shade_radius: r.shade_radius,
            normal_cos: r.normal_cos,
            plane_tolerance: r.plane_tolerance,
            boil_factor: r.boil_factor,
            shadow_cos: r.shadow_cos,
            shadow_distance_ratio: r.shadow_distance_ratio,
            emitter_count: prepared.state.scene.emitter_count,
            specular_max_roughness: self.config.specular.max_roughness,
            specular_history: self.config.specular.history,
            specular_clamp_sigma: self.config.specular.clamp_sigma,
            probe_ray_m: match self.config.trace_mode {
                TraceMode::Rays => f32::MAX,
                TraceMode::Probes => self.config.probe_ray_m,
            },
            shade_contact_ratio: r.shade_contact_ratio,
            specular_diffuse_from: self.config.specular.diffuse_from,
            gradient_stratum: gradient_grid.map_or(0, |_| self.config.gradients.stratum),
            gradient_strata_x: gradient_grid.map_or(0, |g| g.strata.0),
            gradient_strata_y: gradient_grid.map_or(0, |g| g.strata.1),
            gradient_gain: self.config.gradients.gain,
        }
    }

    /// Makes the GPU state match `input` ([`SceneState`]): the scene is uploaded once and
    /// follows animation, light edits and camera moves. The bind groups naming the direct
    /// light are made per frame, so a replaced accumulation needs nothing more.
    fn prepare(&mut self, input: &FrameInput) -> Result<(), TierError> {
        let size = (self.settings.width, self.settings.height);
        let seed = self.settings.seed;
        if let Some(prepared) = self.prepared.as_mut()
            && prepared.state.holds(input.frame)
        {
            prepared
                .state
                .follow(&self.ctx, "pc", input, &self.direct_pipelines, size, seed)?;
            return Ok(());
        }
        if let Some(old) = self.prepared.take() {
            old.release(&self.ctx);
        }
        let state = SceneState::upload(
            &self.ctx,
            "pc",
            input,
            &self.direct_pipelines,
            size,
            seed,
            &self.settings.textures,
        )?;
        self.gbuffer.prepare_layers(&self.ctx, &state.scene);
        let restir = Restir::new(
            &self.ctx,
            &self.pipelines,
            size,
            self.config.trace_scale,
            self.config.restir.temporal,
            self.config
                .gradients
                .enabled
                .then_some(self.config.gradients.stratum),
        );
        let gbuffer = self.gbuffer.outputs();
        let denoiser = Denoiser::with_lent_buffers(
            &self.ctx,
            &self.denoise_pipelines,
            size,
            &DenoiseSources {
                noisy: &restir.buffers.rays,
                depth: gbuffer.depth,
                normal: gbuffer.normal,
                motion: gbuffer.motion,
                gradients: restir.buffers.gradient_source(),
            },
            LentBuffers {
                output: &restir.buffers.transient,
                scratch: &restir.buffers.resolved,
            },
        );
        self.prepared = Some(Prepared {
            state,
            restir,
            denoiser,
            dynamic_triangles: dynamic_triangles(input.scene, input.frame),
        });
        Ok(())
    }
}

crate::realtime::real_time_tier!(PcTier, TierKind::Pc, PcConfig, &[]);

impl PcTier {
    /// Where the last frame's image and direct light lie; `None` before the first frame.
    fn output(&self) -> Option<GpuOutput<'_>> {
        let prepared = self.prepared.as_ref()?;
        Some(GpuOutput {
            ctx: &self.ctx,
            image: &prepared.restir.buffers.output,
            direct: Some(&prepared.state.direct.mean),
            size: (self.settings.width, self.settings.height),
        })
    }

    /// Records and submits the frame but for its last encoder, which it returns for the
    /// caller to end the timer's frame with (waiting for it or not).
    fn record_frame(&mut self, input: &FrameInput) -> Result<wgpu::CommandEncoder, TierError> {
        let frame = input.frame;
        self.prepare(input)?;
        let mut uniforms = {
            let prepared = self.prepared.as_ref().expect("prepared above");
            let history = prepared.restir.buffers.history;
            self.uniforms(frame, &prepared.state.previous, history)
        };
        let size = (self.settings.width, self.settings.height);
        let PcTier {
            ctx,
            timer,
            gbuffer,
            cache,
            prepared,
            config,
            settings,
            frame_index,
            ..
        } = self;
        let Prepared {
            state,
            restir,
            denoiser,
            ..
        } = prepared.as_mut().expect("prepared above");
        let scene = &state.scene;
        let mut rec = Recorder::new(ctx, timer, "pc/frame");

        let (gbuffer, cache) = record_gbuffer_and_cache(&mut rec, gbuffer, cache, input, state);
        // A cache fill (a first view, a jump) lights through missing walls: reservoirs and
        // history gathered from it must not be kept.
        if cache.stats.filling {
            restir.buffers.history = false;
            uniforms.flags &= !flags::HISTORY;
            denoiser.reset_history();
        }
        ctx.queue
            .write_buffer(&restir.buffers.uniforms, 0, bytemuck::bytes_of(&uniforms));
        restir.record(
            &mut rec,
            &RestirInputs {
                scene,
                cache: &cache.buffers.bind_group,
                gbuffer,
                denoised: denoiser.output(),
                direct: &state.direct.mean,
                previous_geometry: denoiser.previous_geometry(),
                config,
                size,
            },
        );
        // While the cache's light converges (after a fill, a jump or a change of the lights)
        // the long history would average its darker, staler frames: it keeps the short
        // history's length until the cache has settled, then grows back a frame at a time.
        let mut denoise = config.denoise.clone();
        if cache.stats.converging {
            denoise.long_history = denoise.short_history;
        }
        denoiser.record(&mut rec, &DenoiseInputs { config: &denoise });
        rec.submit("pc/compose");

        let samples = u32::from(state.direct.samples < settings.spp);
        state
            .direct
            .record(&mut rec, &DirectInputs { scene, samples });
        restir.compose(&mut rec);

        state.finish_frame(frame);
        restir.end_frame();
        *frame_index = frame_index.wrapping_add(1);
        if let Some(progress) = input.progress {
            progress(state.direct.samples);
        }
        Ok(rec.into_encoder())
    }
}

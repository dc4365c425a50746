//! The screen-space passes of the mobile tier (`shaders/mobile/screen.wgsl`): lite G-buffer,
//! screen probe placement and tracing, the half-resolution gather with its temporal filter,
//! and the upsample that composes the final image. See the shader for what each pass does.

use bytemuck::{Pod, Zeroable};
use gi_cache::lighting::GpuSky;
use gi_cache::{CACHE_LANES, CacheBuffers};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::{GpuCamera, GpuContext, GpuError, GpuTimer, ShaderLibrary, wgpu};

use super::config::{PROBE_TEXELS, ScreenConfig, ScreenProbeMode};

/// Probe slots per tile: the regular probe and the extra probe of marked tiles.
pub const SLOTS_PER_TILE: u32 = 2;
/// Pixels per side of the 2D passes' workgroups (`@workgroup_size(8, 8)`).
const TILE_GROUP: u32 = 8;
/// Invocations of the 1D passes' workgroups (`@workgroup_size(64)`).
const LINEAR_GROUP: u32 = 64;
/// Most workgroups of one dispatch row.
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// Mirror of `ScreenUniforms` in `shaders/mobile/screen.wgsl`, 256 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ScreenUniforms {
    pub camera: GpuCamera,
    pub previous_camera: GpuCamera,
    pub sky: GpuSky,
    pub size_px: [u32; 2],
    pub half_px: [u32; 2],
    pub tiles: [u32; 2],
    pub tile_px: u32,
    pub frame_index: u32,
    pub seed: [u32; 2],
    pub max_age: u32,
    /// 1 when `history_in` holds the previous frame's gather.
    pub history_valid: u32,
    pub plane_tolerance: f32,
    pub normal_cos: f32,
    pub ray_offset_voxels: f32,
    /// Bit 0: SmartGI, else HSGI ([`ScreenProbeMode`]); bit 1: the material's occlusion map
    /// darkens the gathered diffuse light ([`ScreenConfig::material_occlusion`]); bit 2
    /// (`FLAG_BLEND_LAYER`): `gbuffer.blend_layer` holds a blended layer per pixel.
    pub flags: u32,
}

/// [`ScreenUniforms::flags`] bit: the G-buffer found blended layers (the scene has alpha-`BLEND`
/// materials), which compose blends over the GI behind them.
pub const FLAG_BLEND_LAYER: u32 = 4;

/// Mirror of `ScreenProbe` in the shader, 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuScreenProbe {
    pub position: [f32; 3],
    /// Distance to the camera; 0 when the slot holds no probe.
    pub depth: f32,
    pub normal: [f32; 3],
    /// Bit 0: the probe sits on a dynamic object; bit 1: reprojected from the previous frame's
    /// slot `flags >> 8`.
    pub flags: u32,
}

/// Sizes that follow from the image size and the tile size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenLayout {
    pub size: (u32, u32),
    pub half: (u32, u32),
    pub tiles: (u32, u32),
}

impl ScreenLayout {
    pub fn new(width: u32, height: u32, tile_px: u32) -> Self {
        Self {
            size: (width, height),
            half: (width.div_ceil(2), height.div_ceil(2)),
            tiles: (width.div_ceil(tile_px), height.div_ceil(tile_px)),
        }
    }

    pub fn pixels(&self) -> u64 {
        u64::from(self.size.0) * u64::from(self.size.1)
    }

    pub fn half_pixels(&self) -> u64 {
        u64::from(self.half.0) * u64::from(self.half.1)
    }

    pub fn tile_count(&self) -> u32 {
        self.tiles.0 * self.tiles.1
    }

    pub fn slots(&self) -> u32 {
        self.tile_count() * SLOTS_PER_TILE
    }
}

/// The six pipelines, sharing one layout: group 0 the screen buffers, 1 the probe volume,
/// 2 the cache.
pub struct ScreenPipelines {
    layout0: wgpu::BindGroupLayout,
    lite: wgpu::ComputePipeline,
    reproject: wgpu::ComputePipeline,
    place: wgpu::ComputePipeline,
    trace: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    compose: wgpu::ComputePipeline,
}

impl ScreenPipelines {
    pub fn new(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        volume_layout: &wgpu::BindGroupLayout,
    ) -> Result<Self, GpuError> {
        let module = shaders.create_module(ctx, "mobile/screen.wgsl", &[])?;
        // G-buffer, dynamic bits, history_in, direct, the previous frame's probes.
        let read_only = [1u32, 2, 3, 4, 5, 6, 7, 12, 14, 16, 17, 19, 20];
        let mut entries = vec![uniform_entry(0)];
        entries
            .extend((1..=20).map(|binding| storage_entry(binding, read_only.contains(&binding))));
        let layout0 = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("mobile/screen.layout0"),
                entries: &entries,
            });
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let pipeline = |entry: &str| {
            ctx.create_compute_pipeline_with_layouts(
                &format!("mobile/{entry}"),
                &module,
                entry,
                &[Some(&layout0), Some(volume_layout), Some(&cache_layout)],
            )
        };
        Ok(Self {
            lite: pipeline("lite_pack"),
            reproject: pipeline("reproject"),
            place: pipeline("place"),
            trace: pipeline("trace"),
            gather: pipeline("gather"),
            compose: pipeline("compose"),
            layout0,
        })
    }
}

/// The screen passes in frame order, as [`ScreenBuffers::record`] records them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScreenStep {
    /// `mobile/lite`: the lite G-buffer.
    Lite,
    /// `mobile/probe_reproject` (SmartGI mode), `mobile/probe_place`, `mobile/probe_trace`.
    Probes,
    /// `mobile/gather`: half-resolution irradiance and its temporal filter.
    Gather,
    /// `mobile/compose`: upsample and final image.
    Compose,
}

/// The G-buffer outputs and the direct image the screen passes read, by binding.
pub struct ScreenSources<'a> {
    pub depth: &'a wgpu::Buffer,
    pub normal: &'a wgpu::Buffer,
    pub base_color: &'a wgpu::Buffer,
    pub metallic_roughness: &'a wgpu::Buffer,
    pub triangle: &'a wgpu::Buffer,
    pub motion: &'a wgpu::Buffer,
    /// `gbuffer.emissive`, for the material's occlusion factor in its w.
    pub emissive: &'a wgpu::Buffer,
    /// `gbuffer.blend_layer`, the blended layers in front of the pixels.
    pub blend_layer: &'a wgpu::Buffer,
    pub dynamic_triangles: &'a wgpu::Buffer,
    pub direct_mean: &'a wgpu::Buffer,
}

/// The screen buffers of one image size (labels `mobile.*`), with the two bind groups of the
/// history ping-pong.
pub struct ScreenBuffers {
    pub layout: ScreenLayout,
    uniforms: wgpu::Buffer,
    pub lite: wgpu::Buffer,
    /// Probes and their texels, ping-pong like the history: frame `i` writes `[i % 2]` and
    /// reads the previous frame's from the other.
    pub probes: [wgpu::Buffer; 2],
    pub probe_radiance: [wgpu::Buffer; 2],
    pub tile_marks: wgpu::Buffer,
    pub tile_claims: wgpu::Buffer,
    mode: ScreenProbeMode,
    /// Half-resolution irradiance, ping-pong: frame `i` writes `history[i % 2]`.
    pub history: [wgpu::Buffer; 2],
    /// The final image, 16 bytes per pixel (`mobile.output`).
    pub output: wgpu::Buffer,
    groups: [wgpu::BindGroup; 2],
    /// Which history buffer the last gather wrote.
    pub current: usize,
    frames: u32,
}

impl ScreenBuffers {
    pub fn new(
        ctx: &GpuContext,
        pipelines: &ScreenPipelines,
        layout: ScreenLayout,
        mode: ScreenProbeMode,
        sources: &ScreenSources<'_>,
    ) -> Self {
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let uniforms = ctx.create_buffer(
            "mobile.screen_uniforms",
            size_of::<ScreenUniforms>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let lite = ctx.create_buffer("mobile.lite", layout.pixels() * 4, storage);
        let slots = u64::from(layout.slots());
        let probe_bytes = slots * size_of::<GpuScreenProbe>() as u64;
        let texel_bytes = slots * u64::from(PROBE_TEXELS * PROBE_TEXELS) * 8;
        let probes = [0, 1].map(|_| ctx.create_buffer("mobile.probes", probe_bytes, storage));
        let probe_radiance =
            [0, 1].map(|_| ctx.create_buffer("mobile.probe_radiance", texel_bytes, storage));
        let tile_bytes = u64::from(layout.tile_count()) * 4;
        let tile_marks = ctx.create_buffer("mobile.tile_marks", tile_bytes, storage);
        let tile_claims = ctx.create_buffer("mobile.tile_claims", tile_bytes, storage);
        let history = [
            ctx.create_buffer("mobile.history", layout.half_pixels() * 8, storage),
            ctx.create_buffer("mobile.history", layout.half_pixels() * 8, storage),
        ];
        let output = ctx.create_buffer("mobile.output", layout.pixels() * 16, storage);
        let group = |write: usize| {
            let mut entries = buffer_entries(
                0,
                [
                    &uniforms,
                    sources.depth,
                    sources.normal,
                    sources.base_color,
                    sources.metallic_roughness,
                    sources.triangle,
                    sources.motion,
                    sources.dynamic_triangles,
                    &lite,
                    &probes[write],
                    &probe_radiance[write],
                    &tile_marks,
                    &history[1 - write],
                    &history[write],
                    sources.direct_mean,
                ],
            );
            entries.extend(buffer_entries(
                15,
                [
                    &output,
                    &probes[1 - write],
                    &probe_radiance[1 - write],
                    &tile_claims,
                    sources.emissive,
                    sources.blend_layer,
                ],
            ));
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mobile/screen.group"),
                layout: &pipelines.layout0,
                entries: &entries,
            })
        };
        let groups = [group(0), group(1)];
        Self {
            layout,
            uniforms,
            lite,
            probes,
            probe_radiance,
            tile_marks,
            tile_claims,
            mode,
            history,
            output,
            groups,
            current: 1,
            frames: 0,
        }
    }

    /// Forgets the history: the next gather starts every pixel at age 1.
    pub fn reset_history(&mut self) {
        self.frames = 0;
    }

    /// Writes this frame's uniforms (history validity and the ping-pong side included) and
    /// makes the next gather write the other history buffer.
    pub fn begin_frame(&mut self, ctx: &GpuContext, mut uniforms: ScreenUniforms) {
        self.current = 1 - self.current;
        uniforms.history_valid = u32::from(self.frames > 0);
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        self.frames += 1;
    }

    fn group(&self) -> &wgpu::BindGroup {
        &self.groups[self.current]
    }

    /// Records the passes of `step` (see [`ScreenStep`]), each timed under its name.
    pub fn record(
        &self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &ScreenPipelines,
        groups: (&wgpu::BindGroup, &wgpu::BindGroup),
        step: ScreenStep,
    ) {
        let (w, h) = self.layout.size;
        let full = [w.div_ceil(TILE_GROUP), h.div_ceil(TILE_GROUP)];
        let slots = self.layout.slots();
        let per_slot = [slots.div_ceil(LINEAR_GROUP), 1];
        let texels = slots * PROBE_TEXELS * PROBE_TEXELS;
        let passes: Vec<(&str, &wgpu::ComputePipeline, [u32; 2])> = match step {
            ScreenStep::Lite => vec![("mobile/lite", &pipelines.lite, full)],
            ScreenStep::Probes => {
                let mut passes = Vec::new();
                if self.mode == ScreenProbeMode::SmartGi {
                    passes.push(("mobile/probe_reproject", &pipelines.reproject, per_slot));
                }
                passes.push(("mobile/probe_place", &pipelines.place, per_slot));
                // CACHE_LANES invocations per ray, in rows of at most 65535 workgroups.
                let groups = (texels * CACHE_LANES).div_ceil(LINEAR_GROUP);
                let row = groups.min(MAX_GROUPS_PER_ROW);
                passes.push((
                    "mobile/probe_trace",
                    &pipelines.trace,
                    [row, groups.div_ceil(row)],
                ));
                passes
            }
            ScreenStep::Gather => {
                let (w, h) = self.layout.half;
                let half = [w.div_ceil(TILE_GROUP), h.div_ceil(TILE_GROUP)];
                vec![("mobile/gather", &pipelines.gather, half)]
            }
            ScreenStep::Compose => vec![("mobile/compose", &pipelines.compose, full)],
        };
        for (name, pipeline, workgroups) in passes {
            self.dispatch(ctx, timer, encoder, name, pipeline, groups, workgroups);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn dispatch(
        &self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        name: &str,
        pipeline: &wgpu::ComputePipeline,
        (volume, cache): (&wgpu::BindGroup, &wgpu::BindGroup),
        groups: [u32; 2],
    ) {
        timer.compute_pass(ctx, encoder, name, |pass| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, self.group(), &[]);
            pass.set_bind_group(1, volume, &[]);
            pass.set_bind_group(CacheBuffers::BIND_GROUP, cache, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], 1);
        });
    }

    /// Stops counting and destroys the buffers.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.uniforms,
            &self.lite,
            &self.probes[0],
            &self.probes[1],
            &self.probe_radiance[0],
            &self.probe_radiance[1],
            &self.tile_marks,
            &self.tile_claims,
            &self.history[0],
            &self.history[1],
            &self.output,
        ] {
            ctx.release_buffer(buffer);
        }
    }
}

/// The screen uniforms of a frame (history validity is set by [`ScreenBuffers::begin_frame`]).
pub fn screen_uniforms(
    config: &ScreenConfig,
    layout: ScreenLayout,
    camera: GpuCamera,
    previous_camera: GpuCamera,
    sky: GpuSky,
    frame_index: u32,
    seed: u64,
) -> ScreenUniforms {
    ScreenUniforms {
        camera,
        previous_camera,
        sky,
        size_px: [layout.size.0, layout.size.1],
        half_px: [layout.half.0, layout.half.1],
        tiles: [layout.tiles.0, layout.tiles.1],
        tile_px: config.tile_px,
        frame_index,
        seed: [seed as u32, (seed >> 32) as u32],
        max_age: config.max_age,
        history_valid: 0,
        plane_tolerance: config.plane_tolerance,
        normal_cos: config.normal_cos,
        ray_offset_voxels: config.ray_offset_voxels,
        flags: match config.mode {
            ScreenProbeMode::Hsgi => 0,
            ScreenProbeMode::SmartGi => 1,
        } | if config.material_occlusion { 2 } else { 0 },
    }
}

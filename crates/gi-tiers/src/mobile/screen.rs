//! The screen-space passes of the mobile tier (`shaders/mobile/screen/`, one file per pass):
//! lite G-buffer, screen probe placement and tracing, the half-resolution gather with its
//! temporal filter, and the upsample that composes the final image. See the shaders for what
//! each pass does.

use bytemuck::{Pod, Zeroable};
use gi_cache::lighting::GpuSky;
use gi_cache::{CACHE_LANES, CacheBuffers};
use gi_gpu::binding::{buffer_entries, uniform_entry};
use gi_gpu::{
    GBufferOutputs, GpuCamera, GpuContext, GpuError, PingPong, Recorder, ShaderLibrary, Technique,
    wgpu,
};

use super::config::{PROBE_TEXELS, ScreenConfig, ScreenProbeMode};

/// Probe slots per tile: the regular probe and the extra probe of marked tiles.
pub const SLOTS_PER_TILE: u32 = 2;
/// Pixels per side of the 2D passes' workgroups (`@workgroup_size(8, 8)`).
const TILE_GROUP: u32 = 8;
/// Invocations of the 1D passes' workgroups (`@workgroup_size(64)`).
const LINEAR_GROUP: u32 = 64;
/// Most workgroups of one dispatch row.
const MAX_GROUPS_PER_ROW: u32 = 65_535;

/// Mirror of `ScreenUniforms` in `shaders/mobile/screen/shared.wgsl`, 256 bytes.
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
    /// The brick cache's `CacheConfig::change_gain`: how strongly the change the cache measured
    /// at a pixel's surface shortens the gather's temporal history; 0: not at all.
    pub change_gain: f32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// [`ScreenUniforms::flags`] bit: the G-buffer found blended layers (the scene has alpha-`BLEND`
/// materials), which compose blends over the GI behind them.
pub const FLAG_BLEND_LAYER: u32 = 4;
/// `FLAG_VOLUME_STALE`: the lights changed lately and the probe volume still holds their old
/// light, so the gather reads the cache where it would read the volume.
pub const FLAG_VOLUME_STALE: u32 = 8;

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

/// The six pipelines, each from its pass's file of `shaders/mobile/screen/`, sharing one
/// layout: group 0 the screen buffers, 1 the probe volume, 2 the cache.
#[derive(Clone)]
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
        let mut entries = vec![uniform_entry(0)];
        entries.extend(ScreenGroup::layout_entries());
        let layout0 = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("mobile/screen.layout0"),
                entries: &entries,
            });
        let cache_layout = CacheBuffers::bind_group_layout(ctx);
        let pipeline = |entry: &str| -> Result<_, GpuError> {
            let module = shaders.create_module(ctx, &format!("mobile/screen/{entry}.wgsl"), &[])?;
            Ok(ctx.create_compute_pipeline_with_layouts(
                &format!("mobile/{entry}"),
                &module,
                entry,
                &[Some(&layout0), Some(volume_layout), Some(&cache_layout)],
            ))
        };
        Ok(Self {
            lite: pipeline("lite_pack")?,
            reproject: pipeline("reproject")?,
            place: pipeline("place")?,
            trace: pipeline("trace")?,
            gather: pipeline("gather")?,
            compose: pipeline("compose")?,
            layout0,
        })
    }
}

/// The screen passes in frame order, as [`Technique::record`] records them.
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

/// What the screen passes read from the rest of the frame: the G-buffer, which triangles move,
/// and the direct light.
pub struct ScreenSources<'a> {
    pub gbuffer: GBufferOutputs<'a>,
    /// One bit per frame triangle: moved by an animation.
    pub dynamic_triangles: &'a wgpu::Buffer,
    /// The direct light's mean, which the compose pass adds the GI to.
    pub direct_mean: &'a wgpu::Buffer,
}

gi_gpu::storage_bindings! {
    /// The screen passes' buffers in group 0, after the uniforms (0), which they import from
    /// `mobile/screen/shared.wgsl`. `*_prev` and `history_in`: the previous frame's side of a
    /// [`PingPong`].
    struct ScreenGroup from 1 {
        gbuffer_depth: read,
        gbuffer_normal: read,
        gbuffer_base_color: read,
        gbuffer_metallic_roughness: read,
        gbuffer_triangle: read,
        gbuffer_motion: read,
        dynamic_triangles: read,
        lite: read_write,
        probes: read_write,
        probe_radiance: read_write,
        tile_marks: read_write,
        history_in: read,
        history_out: read_write,
        direct_mean: read,
        output: read_write,
        probes_prev: read,
        probe_radiance_prev: read,
        tile_claims: read_write,
        gbuffer_emissive: read,
        gbuffer_blend_layer: read,
    }
}

/// What one frame of the screen probes writes and the next reads as its history.
pub struct ScreenFrame {
    /// The probes placed this frame.
    pub probes: wgpu::Buffer,
    /// Their texels.
    pub probe_radiance: wgpu::Buffer,
    /// Half-resolution irradiance the gather wrote.
    pub history: wgpu::Buffer,
}

/// The screen buffers of one image size (labels `mobile.*`), with the bind groups of both
/// sides of the frames' ping-pong.
pub struct ScreenProbes {
    /// The six pipelines (shared with the tier).
    pipelines: ScreenPipelines,
    pub layout: ScreenLayout,
    uniforms: wgpu::Buffer,
    pub lite: wgpu::Buffer,
    /// This frame's probes, texels and irradiance, and the previous frame's.
    pub frames: PingPong<ScreenFrame>,
    pub tile_marks: wgpu::Buffer,
    pub tile_claims: wgpu::Buffer,
    mode: ScreenProbeMode,
    /// The final image, 16 bytes per pixel (`mobile.output`).
    pub output: wgpu::Buffer,
    /// The bind group of each side of `frames`, swapped with it.
    groups: PingPong<wgpu::BindGroup>,
    frames_rendered: u32,
}

/// What one step of the screen probes reads.
pub struct ProbeStep<'a> {
    /// Which passes to record.
    pub step: ScreenStep,
    /// The probe volume's bind group (group 1).
    pub volume: &'a wgpu::BindGroup,
    /// The brick cache's bind group.
    pub cache: &'a wgpu::BindGroup,
}

/// The screen probes: recorded in steps around the probe volume's update and the direct
/// light (see [`ScreenStep`]).
impl Technique for ScreenProbes {
    type Inputs<'i> = ProbeStep<'i>;
    /// The steps write the technique's own buffers; [`ScreenStep::Compose`] writes the final
    /// image, `mobile.output` ([`ScreenProbes`]'s `output`).
    type Outputs<'o> = ();

    /// Records the passes of the step (see [`ScreenStep`]), each timed under its name.
    fn record(&mut self, rec: &mut Recorder<'_>, inputs: &ProbeStep<'_>) {
        let pipelines = &self.pipelines;
        let (w, h) = self.layout.size;
        let full = [w.div_ceil(TILE_GROUP), h.div_ceil(TILE_GROUP)];
        let slots = self.layout.slots();
        let per_slot = [slots.div_ceil(LINEAR_GROUP), 1];
        let texels = slots * PROBE_TEXELS * PROBE_TEXELS;
        let passes: Vec<(&str, &wgpu::ComputePipeline, [u32; 2])> = match inputs.step {
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
        for (name, pipeline, groups) in passes {
            rec.compute_pass(name, |pass| {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, self.groups.current(), &[]);
                pass.set_bind_group(1, inputs.volume, &[]);
                pass.set_bind_group(CacheBuffers::BIND_GROUP, inputs.cache, &[]);
                pass.dispatch_workgroups(groups[0], groups[1], 1);
            });
        }
    }
}

impl ScreenProbes {
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
        let frames = PingPong::from_fn(|_| ScreenFrame {
            probes: ctx.create_buffer("mobile.probes", probe_bytes, storage),
            probe_radiance: ctx.create_buffer("mobile.probe_radiance", texel_bytes, storage),
            history: ctx.create_buffer("mobile.history", layout.half_pixels() * 8, storage),
        });
        let tile_bytes = u64::from(layout.tile_count()) * 4;
        let tile_marks = ctx.create_buffer("mobile.tile_marks", tile_bytes, storage);
        let tile_claims = ctx.create_buffer("mobile.tile_claims", tile_bytes, storage);
        let output = ctx.create_buffer("mobile.output", layout.pixels() * 16, storage);
        let group = |write: usize| {
            let (previous, frame) = frames.read_write(write);
            let mut entries = buffer_entries(0, [&uniforms]);
            entries.extend(
                ScreenGroup {
                    gbuffer_depth: sources.gbuffer.depth,
                    gbuffer_normal: sources.gbuffer.normal,
                    gbuffer_base_color: sources.gbuffer.base_color,
                    gbuffer_metallic_roughness: sources.gbuffer.metallic_roughness,
                    gbuffer_triangle: sources.gbuffer.triangle,
                    gbuffer_motion: sources.gbuffer.motion,
                    dynamic_triangles: sources.dynamic_triangles,
                    lite: &lite,
                    probes: &frame.probes,
                    probe_radiance: &frame.probe_radiance,
                    tile_marks: &tile_marks,
                    history_in: &previous.history,
                    history_out: &frame.history,
                    direct_mean: sources.direct_mean,
                    output: &output,
                    probes_prev: &previous.probes,
                    probe_radiance_prev: &previous.probe_radiance,
                    tile_claims: &tile_claims,
                    gbuffer_emissive: sources.gbuffer.emissive,
                    gbuffer_blend_layer: sources.gbuffer.blend_layer,
                }
                .entries(),
            );
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mobile/screen.group"),
                layout: &pipelines.layout0,
                entries: &entries,
            })
        };
        let groups = PingPong::from_fn(group);
        Self {
            pipelines: pipelines.clone(),
            layout,
            uniforms,
            lite,
            frames,
            tile_marks,
            tile_claims,
            mode,
            output,
            groups,
            frames_rendered: 0,
        }
    }

    /// Forgets the history: the next gather starts every pixel at age 1.
    pub fn reset_history(&mut self) {
        self.frames_rendered = 0;
    }

    /// Writes this frame's uniforms (history validity and the ping-pong side included) and
    /// makes the next gather write the other history buffer.
    pub fn begin_frame(&mut self, ctx: &GpuContext, mut uniforms: ScreenUniforms) {
        self.frames.swap();
        self.groups.swap();
        uniforms.history_valid = u32::from(self.frames_rendered > 0);
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        self.frames_rendered += 1;
    }

    /// Stops counting and destroys the buffers.
    pub fn release(self, ctx: &GpuContext) {
        for buffer in [
            &self.uniforms,
            &self.lite,
            &self.tile_marks,
            &self.tile_claims,
            &self.output,
        ] {
            ctx.release_buffer(buffer);
        }
        for frame in self.frames.both() {
            for buffer in [&frame.probes, &frame.probe_radiance, &frame.history] {
                ctx.release_buffer(buffer);
            }
        }
    }
}

/// The screen uniforms of a frame (history validity is set by [`ScreenProbes::begin_frame`]).
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
        change_gain: 0.0,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use gi_gpu::binding::{Access, check_declared, wgsl_storage_bindings};

    #[test]
    fn the_shader_declares_the_named_buffers_at_their_bindings() {
        let shaders = ShaderLibrary::new();
        let source = shaders
            .source("mobile/screen/shared.wgsl")
            .expect("the shader is in the library");
        check_declared(source, 0, ScreenGroup::FIRST_BINDING, ScreenGroup::SLOTS)
            .unwrap_or_else(|e| panic!("mobile/screen/shared.wgsl: {e}"));
        // The passes declare none of group 0's buffers themselves: they import them.
        for pass in [
            "lite_pack",
            "reproject",
            "place",
            "trace",
            "gather",
            "compose",
        ] {
            let file = format!("mobile/screen/{pass}.wgsl");
            let source = shaders.source(&file).expect("the pass is in the library");
            assert_eq!(wgsl_storage_bindings(source, 0), [], "{file}");
        }
        // A swapped pair or a changed access is caught.
        let mut swapped = ScreenGroup::SLOTS.to_vec();
        swapped.swap(0, 1);
        assert!(check_declared(source, 0, ScreenGroup::FIRST_BINDING, &swapped).is_err());
        let mut written = ScreenGroup::SLOTS.to_vec();
        written[0].1 = Access::ReadWrite;
        assert!(check_declared(source, 0, ScreenGroup::FIRST_BINDING, &written).is_err());
    }
}

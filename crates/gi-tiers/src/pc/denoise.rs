//! The PC tier's denoiser (`shaders/pc/denoise/`): HSGI's final processing (GDC 2023, "PC /
//! Console Solution": temporal supersampling with a long and a short history, variance
//! clamping with the short history's 5 x 5 neighbourhood) followed by SVGF (Schied et al. 2017,
//! "Spatiotemporal Variance-Guided Filtering", HPG).
//!
//! Each frame [`Technique::record`] records, on full-resolution storage buffers:
//!
//! 1. `pc/denoise_temporal`, two dispatches. `temporal_short` reprojects the histories
//!    through the motion vectors (bilinear 2 x 2 taps, each kept only if its previous depth and
//!    normal agree with the pixel's), blends the noisy input into the short one with
//!    `alpha = max(1 / (age + 1), 1 / short_history)` and leaves it and the reprojected long
//!    history (color, luminance variance, age) in the output and scratch buffers, so that every
//!    history is updated in place. `temporal` clamps the long
//!    history's color into `mean +- clamp_sigma sigma` of this frame's short history over the
//!    5 x 5 neighbourhood, and blends with `alpha = max(1 / (age + 1), 1 / long_history)`.
//!    Why the short history and not the noisy input for the clamp box: its neighbourhood is
//!    about `sqrt(short_history)` times less noisy, so the box is tight enough to catch stale
//!    history, yet it follows a change within about `short_history` frames.
//! 2. `pc/denoise_variance`: SVGF's luminance variance, from the temporal moments once the
//!    history is [`VARIANCE_MIN_AGE`] frames old, else from a 7 x 7 bilateral (depth, normal)
//!    estimate of the moments.
//! 3. `pc/denoise_atrous` x [`DenoiseConfig::atrous_iterations`]: SVGF's a-trous wavelet
//!    filter, 5 x 5 B3-spline taps (or 3 x 3 linear ones, [`DenoiseConfig::atrous_kernel`])
//!    `2^i` pixels apart with normal, depth and luminance
//!    edge-stopping weights; the variance is filtered with the squared weights. With
//!    [`DenoiseConfig::feedback`] (SVGF's choice, off by default) the first iteration's
//!    output is the color history of the next frame.
//!
//! Sky pixels (depth `+inf`) pass their input through, keep no history and never mix into
//! their neighbours. Depths are compared without the camera's motion (the denoiser sees no
//! camera): a camera closing in on a surface faster than
//! [`DenoiseConfig::reprojection_depth_tolerance`] of its distance per frame loses the history.
//!
//! Memory: 32 bytes per pixel (about 66 MB at 1920 x 1080; 120 before packing), 16 of them
//! its own when the caller lends the output and the scratch:
//!
//! - the previous frame's depth and normal in one word (4): the depth as an f16 (at most
//!   `2^-11` of itself off, against a reprojection tolerance of
//!   [`DenoiseConfig::reprojection_depth_tolerance`] of it; depths beyond 65504 clamped to
//!   it) and the normal as two 8-bit octahedral coordinates (under a degree off, against the
//!   26 degrees of [`DenoiseConfig::reprojection_normal_cos`]); `temporal` writes this
//!   frame's once `temporal_short` has read them;
//! - the short history (4), RGB9E5: it only places the clamp box, which is widened by
//!   its rounding (at most `2^-9` of the largest channel);
//! - the long history with its luminance moments (8, `gi::packing::pack_history64`): color as
//!   three 14-bit mantissas sharing a 5-bit exponent (at most `2^-14` of the largest channel
//!   off), the luminance variance as a 10-bit float (at most `2^-6` of itself off: it only
//!   scales the a-trous luminance weight's sigma, by its square root) and the age as a 7-bit
//!   integer (so `long_history` is at most [`MAX_LONG_HISTORY`]). The first moment is the
//!   color's luminance and the second the variance about it, as NRD's ReLAX keeps a second
//!   moment beside its history's color: blended with the color's alpha (the variance by the
//!   exponentially weighted update, Finch 2009), they are SVGF's two moments exactly wherever
//!   the clamp leaves the history's color alone, in four bytes less; a clamped color pulls
//!   the mean with it, so the variance is then measured about the color the history keeps;
//! - the output and the scratch (8 each) in the long history's 64-bit format (the luminance
//!   variance in place of the age: an 11-bit float, at most `2^-7` of itself off), both its
//!   own, or lent by the PC tier ([`Denoiser::with_lent_buffers`]: buffers its passes before
//!   the denoiser use).
//!
//! Nothing else is allocated: reprojecting every history once in `temporal_short` lets the
//! histories be updated in place (no ping-pong): the output and the scratch hold the
//! reprojected long history (color and age; variance) and this frame's short history (in the
//! scratch, read around each pixel by `temporal`, which copies it back) until `temporal`
//! writes its result to the output. The filter passes then alternate between the two:
//! `variance` reads only its own pixel, so it writes the output again or the scratch, by the
//! parity of the a-trous iterations, so that the last pass writes the output. Packed colors are non-negative and clamped to 65535 (RGB9E5: 65408), f16 values to
//! 65504.

use std::num::NonZeroU64;

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::uniform_entry;
use gi_gpu::{GpuContext, GpuError, Recorder, ShaderLibrary, Technique, wgpu};

/// Most a-trous iterations (the last one's taps are 256 pixels apart).
pub const MAX_ATROUS_ITERATIONS: u32 = 8;
/// Most frames [`DenoiseConfig::long_history`] may ask for: the long history stores its age in
/// 7 bits.
pub const MAX_LONG_HISTORY: u32 = 127;
/// Frames of history from which the variance comes from the temporal moments rather than the
/// spatial estimate (SVGF: 4).
pub const VARIANCE_MIN_AGE: u32 = 4;
/// Pixels per side of the passes' workgroups (`@workgroup_size(8, 8)`).
const TILE_GROUP: u32 = 8;
/// Bytes between the uniform slots: slot 0 serves the temporal and variance passes, slot
/// `1 + i` a-trous iteration `i`. 256 is the largest `min_uniform_buffer_offset_alignment`
/// WebGPU allows, so it suits every device.
const UNIFORM_SLOT_BYTES: u64 = 256;

/// The a-trous filter's kernel per iteration (`shaders/pc/denoise/atrous.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtrousKernel {
    /// SVGF's 5 x 5 taps of the B3-spline (1/16, 1/4, 3/8, 1/4, 1/16).
    B3,
    /// 3 x 3 taps of the linear B-spline (1/4, 1/2, 1/4).
    Linear,
}

impl AtrousKernel {
    /// The names [`AtrousKernel::from_str`](std::str::FromStr) takes.
    pub const NAMES: [&str; 2] = ["5x5", "3x3"];

    /// `5x5` or `3x3`.
    pub fn name(self) -> &'static str {
        match self {
            Self::B3 => "5x5",
            Self::Linear => "3x3",
        }
    }
}

impl std::str::FromStr for AtrousKernel {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "5x5" => Ok(Self::B3),
            "3x3" => Ok(Self::Linear),
            other => Err(format!(
                "unknown a-trous kernel '{other}' (expected {})",
                Self::NAMES.join(" or ")
            )),
        }
    }
}

/// The denoiser's settings. The defaults are HSGI's history lengths and SVGF's weights, with
/// a 3 x 3 a-trous kernel ([`DenoiseConfig::atrous_kernel`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DenoiseConfig {
    /// Temporal accumulation (reprojection, depth and normal rejection, variance clamping).
    /// Off, every frame is filtered alone: more noise, no ghosting.
    pub temporal: bool,
    /// SVGF a-trous iterations (taps 1, 2, 4, ... pixels apart), 0 = no spatial filter, at most
    /// [`MAX_ATROUS_ITERATIONS`]. More iterations blur wider (the footprint is about
    /// `4 * 2^iterations` pixels with the 5 x 5 kernel, `2 * 2^iterations` with the 3 x 3)
    /// at about the same cost each.
    pub atrous_iterations: u32,
    /// The a-trous kernel: SVGF's 5 x 5 B3-spline, or a 3 x 3 linear B-spline (9 taps
    /// instead of 25, half the reach per iteration). The default is the 3 x 3 kernel with 5
    /// iterations, which reaches as far as SVGF's four 5 x 5 ones (31 against 30 pixels) for
    /// 45 taps a pixel instead of 100. Measured on the H100 at 1920 x 1080 (2026-11-27,
    /// `benchmarks/results/h100-2026-11-27-atrous-kernel/`): `pc/denoise_atrous` 0.55-0.76
    /// ms against 0.85-1.18 ms on the bundled scenes and GasStation, rmse_srgb8 equal or lower
    /// on every one (thin-wall 17.99 against 18.11, atrium 5.20 against 5.21; four 3 x 3
    /// iterations were cheaper still, 0.37-0.60 ms, and blurred less: atrium 5.23, thin-wall
    /// 18.17).
    pub atrous_kernel: AtrousKernel,
    /// Most frames the long history averages (HSGI: 50), from 1 to [`MAX_LONG_HISTORY`]: higher
    /// is smoother in static views and slower to follow changes the clamp does not catch.
    pub long_history: u32,
    /// Frames of the short history whose neighbourhood clamps the long one (HSGI: 10): lower
    /// follows lighting changes faster and clamps more noise into the result.
    pub short_history: u32,
    /// Half-width of the clamp box in standard deviations of the short history's 5 x 5
    /// neighbourhood: lower rejects stale history sooner and lets less of its smoothing through.
    pub clamp_sigma: f32,
    /// Half-width, in standard deviations of this frame's noisy input over the 3 x 3
    /// neighbourhood, of the box the reprojected short history is clamped into before the
    /// blend (0: no clamp). The short history otherwise follows a lighting change at its
    /// blend rate only (`1 / short_history` a frame: two thirds of a switched-off light's
    /// bounce still shows after 4 frames), and the long history follows the short one. Off by
    /// default: on the H100 at 1080p (2026-11-27, `benchmarks/results/h100-2026-11-27-short-clamp/`)
    /// 2 left 46% of a switched-off sun's bounce after 4 frames on atrium instead of 77%, but
    /// raised every scene's error (thin-wall rmse_srgb8 24.82 against 17.99, Sponza 7.65
    /// against 6.36) and the still-camera flicker (1.24% against 0.95%).
    pub short_clamp_sigma: f32,
    /// Relative depth difference a reprojected tap may have (plus the depth's change across a
    /// pixel): higher keeps history on sloped surfaces and in motion, and ghosts more at edges.
    pub reprojection_depth_tolerance: f32,
    /// Least cosine between a reprojected tap's normal and the pixel's.
    pub reprojection_normal_cos: f32,
    /// Exponent of the a-trous normal weight `max(0, n . m)^p` (SVGF: 128): higher keeps
    /// creases sharper and smooths curved surfaces less.
    pub normal_power: f32,
    /// Scale of the depth weight `exp(-|dz| / (depth_sigma |grad z| |offset|))` (SVGF: 1):
    /// higher blurs across small depth steps.
    pub depth_sigma: f32,
    /// Scale of the luminance weight `exp(-|dl| / (luminance_sigma sigma_l))` (SVGF: 4):
    /// higher blurs more noise and more detail.
    pub luminance_sigma: f32,
    /// SVGF's feedback: the first a-trous iteration's color, not the temporal blend's, becomes
    /// the long history. Off by default: each frame's history is then blurred again, so over
    /// a history of `long_history` frames the first iteration's kernel compounds about that
    /// many times, and surfaces whose light varies across them lose it to their darker parts
    /// (measured: a 7.6% darker red wall on cornell-box at 128 x 96, 2.5% without feedback;
    /// on the H100 at 1280 x 720, rmse_srgb8 3.88 with it and 3.74 without on cornell-box,
    /// 9.34 and 9.08 on glossy, 7.51 and 7.61 on atrium, 20.09 and 20.16 on thin-wall).
    pub feedback: bool,
}

impl Default for DenoiseConfig {
    fn default() -> Self {
        Self {
            temporal: true,
            atrous_iterations: 5,
            atrous_kernel: AtrousKernel::Linear,
            long_history: 50,
            short_history: 10,
            clamp_sigma: 1.5,
            short_clamp_sigma: 0.0,
            reprojection_depth_tolerance: 0.05,
            reprojection_normal_cos: 0.9,
            normal_power: 128.0,
            depth_sigma: 1.0,
            luminance_sigma: 4.0,
            feedback: false,
        }
    }
}

impl DenoiseConfig {
    /// Checks every setting; the error names the first bad field.
    pub fn validate(&self) -> Result<(), String> {
        if self.atrous_iterations > MAX_ATROUS_ITERATIONS {
            return Err(format!(
                "atrous_iterations = {}: at most {MAX_ATROUS_ITERATIONS}",
                self.atrous_iterations
            ));
        }
        if self.long_history == 0 || self.long_history > MAX_LONG_HISTORY {
            return Err(format!(
                "long_history = {}: from 1 to {MAX_LONG_HISTORY} frames",
                self.long_history
            ));
        }
        if self.short_history == 0 || self.short_history > self.long_history {
            return Err(format!(
                "short_history = {}: from 1 to long_history ({})",
                self.short_history, self.long_history
            ));
        }
        let positive = [
            ("clamp_sigma", self.clamp_sigma),
            (
                "reprojection_depth_tolerance",
                self.reprojection_depth_tolerance,
            ),
            ("depth_sigma", self.depth_sigma),
            ("luminance_sigma", self.luminance_sigma),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("{name} = {value}: must be finite and positive"));
            }
        }
        if !(self.short_clamp_sigma.is_finite() && self.short_clamp_sigma >= 0.0) {
            return Err(format!(
                "short_clamp_sigma = {}: must be finite and non-negative",
                self.short_clamp_sigma
            ));
        }
        if !(self.normal_power.is_finite() && self.normal_power >= 0.0) {
            return Err(format!(
                "normal_power = {}: must be finite and non-negative",
                self.normal_power
            ));
        }
        if !(-1.0..=1.0).contains(&self.reprojection_normal_cos) {
            return Err(format!(
                "reprojection_normal_cos = {}: must lie in [-1, 1]",
                self.reprojection_normal_cos
            ));
        }
        Ok(())
    }
}

/// Mirror of `DenoiseUniforms` in `shaders/pc/denoise/shared.wgsl`, 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DenoiseUniforms {
    pub size_px: [u32; 2],
    /// Pixels between a-trous taps (`2^iteration`).
    pub step_px: u32,
    /// A-trous iterations this frame: with a pass's place in the filter chain, whether it
    /// writes the output or the packed filter buffer.
    pub atrous_iterations: u32,
    /// 0 when there is no usable history (first frame, reset, temporal accumulation off).
    pub history_valid: u32,
    pub long_history: u32,
    pub short_history: u32,
    pub variance_min_age: u32,
    pub clamp_sigma: f32,
    pub reprojection_depth_tolerance: f32,
    pub reprojection_normal_cos: f32,
    pub normal_power: f32,
    pub depth_sigma: f32,
    pub luminance_sigma: f32,
    /// 1: the first a-trous iteration's color becomes the long history
    /// ([`DenoiseConfig::feedback`]).
    pub feedback: u32,
    /// [`DenoiseConfig::short_clamp_sigma`]; 0: off.
    pub short_clamp_sigma: f32,
    /// Full-resolution pixels per side of a temporal-gradient stratum ([`GradientGrid`]); 0:
    /// no gradients.
    pub gradient_scale: u32,
    pub gradient_strata_x: u32,
    pub gradient_strata_y: u32,
    pub pad: u32,
}

impl DenoiseUniforms {
    /// The uniforms of `config` for an image of `size` pixels, with no a-trous step yet.
    pub fn new(config: &DenoiseConfig, size: (u32, u32), history_valid: bool) -> Self {
        Self {
            gradient_scale: 0,
            gradient_strata_x: 0,
            gradient_strata_y: 0,
            pad: 0,
            size_px: [size.0, size.1],
            step_px: 1,
            atrous_iterations: config.atrous_iterations.min(MAX_ATROUS_ITERATIONS),
            history_valid: u32::from(history_valid),
            long_history: config.long_history,
            short_history: config.short_history,
            variance_min_age: VARIANCE_MIN_AGE,
            clamp_sigma: config.clamp_sigma,
            reprojection_depth_tolerance: config.reprojection_depth_tolerance,
            reprojection_normal_cos: config.reprojection_normal_cos,
            normal_power: config.normal_power,
            depth_sigma: config.depth_sigma,
            luminance_sigma: config.luminance_sigma,
            feedback: u32::from(config.feedback),
            short_clamp_sigma: config.short_clamp_sigma,
        }
    }
}

/// The five pipelines, one per entry point, sharing two bind group layouts: group 0 the
/// frame's inputs, the histories and the filter buffers, group 1 the dispatch's uniforms. Each
/// pass's file of `shaders/pc/denoise/` holds its entry points (`temporal.wgsl` both of
/// `pc/denoise_temporal`).
#[derive(Clone)]
pub struct DenoisePipelines {
    frame_layout: wgpu::BindGroupLayout,
    uniform_layout: wgpu::BindGroupLayout,
    temporal_short: wgpu::ComputePipeline,
    temporal: wgpu::ComputePipeline,
    variance: wgpu::ComputePipeline,
    atrous: wgpu::ComputePipeline,
    atrous_3x3: wgpu::ComputePipeline,
}

impl DenoisePipelines {
    pub fn new(ctx: &GpuContext, shaders: &ShaderLibrary) -> Result<Self, GpuError> {
        let frame_entries = DenoiseBindings::layout_entries();
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("pc/denoise.frame_layout"),
                entries: &frame_entries,
            });
        let uniform_layout =
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("pc/denoise.uniform_layout"),
                    entries: &[uniform_entry(0)],
                });
        let module =
            |pass: &str| shaders.create_module(ctx, &format!("pc/denoise/{pass}.wgsl"), &[]);
        let pipeline = |module: &wgpu::ShaderModule, entry: &str| {
            ctx.create_compute_pipeline_with_layouts(
                &format!("pc/denoise_{entry}"),
                module,
                entry,
                &[Some(&frame_layout), Some(&uniform_layout)],
            )
        };
        let temporal = module("temporal")?;
        let atrous = module("atrous")?;
        Ok(Self {
            temporal_short: pipeline(&temporal, "temporal_short"),
            temporal: pipeline(&temporal, "temporal"),
            variance: pipeline(&module("variance")?, "variance"),
            atrous: pipeline(&atrous, "atrous"),
            atrous_3x3: pipeline(&atrous, "atrous_3x3"),
            frame_layout,
            uniform_layout,
        })
    }
}

/// The G-buffer and the noisy image the denoiser reads, one entry per pixel, row-major.
/// The denoiser keeps `depth` and `normal`, packed, for the next frame's reprojection.
pub struct DenoiseSources<'a> {
    /// `array<vec2<u32>>`: noisy demodulated diffuse irradiance (rgb), non-negative, in
    /// `gi::packing::pack_color64` (`gi_cache::packing::pack_color64`; the value unused).
    pub noisy: &'a wgpu::Buffer,
    /// `array<f32>`: distance along the unit camera ray, `+inf` for sky (`gbuffer.depth`).
    pub depth: &'a wgpu::Buffer,
    /// `array<u32>`: octahedral world shading normal, `gi::packing` (`gbuffer.normal`).
    pub normal: &'a wgpu::Buffer,
    /// `array<vec2<f32>>`: previous pixel position minus this pixel's center, pixels
    /// (`gbuffer.motion`).
    pub motion: &'a wgpu::Buffer,
    /// Temporal gradients that shorten the histories where the light changed; `None`: the
    /// histories keep their lengths.
    pub gradients: Option<GradientSource<'a>>,
}

/// Buffers the PC tier lends the denoiser ([`Denoiser::with_lent_buffers`]), each free for it
/// from its first pass of a frame until what it names is no longer needed, and sized with
/// [`OUTPUT_PIXEL_BYTES`] and [`SCRATCH_PIXEL_BYTES`].
pub(crate) struct LentBuffers<'a> {
    /// The output ([`Denoiser::output`]), at least 8 bytes per pixel: free until the output
    /// has been read.
    pub output: &'a wgpu::Buffer,
    /// At least 8 bytes per pixel, free until the last denoise pass has run: the reprojected
    /// variance and this frame's short history, then the filter buffer the output alternates
    /// with.
    pub scratch: &'a wgpu::Buffer,
}

/// Bytes per pixel of [`LentBuffers::output`].
pub(crate) const OUTPUT_PIXEL_BYTES: u64 = 8;
/// Bytes per pixel of [`LentBuffers::scratch`].
pub(crate) const SCRATCH_PIXEL_BYTES: u64 = 8;

gi_gpu::storage_bindings! {
    /// The buffers of the denoise passes' group 0 (`shaders/pc/denoise/shared.wgsl`). The
    /// sources are read-only.
    struct DenoiseBindings from 0 {
        noisy: read,
        depth: read,
        normal: read,
        motion: read,
        previous_geometry: read_write,
        short_history: read_write,
        history: read_write,
        output: read_write,
        gradients: read,
        scratch: read_write,
    }
}

/// Where the denoiser reads the temporal gradients (`pc/restir/gradient.wgsl`).
pub struct GradientSource<'a> {
    /// `array<vec4<f32>>`, one entry per stratum, row-major, lambda in z: 0 where the light
    /// did not change since the last frame, up to 1 where all of it did.
    pub buffer: &'a wgpu::Buffer,
    pub grid: GradientGrid,
}

/// The strata of the temporal gradients over the image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GradientGrid {
    /// Full-resolution pixels per side of a stratum.
    pub scale: u32,
    /// Strata per row and per column.
    pub strata: (u32, u32),
}

/// The denoiser of one image size: its histories and output (labels `pc.denoise.*`) and the
/// bind groups over them and the sources it was made with.
pub struct Denoiser {
    /// The pipelines (shared with whoever compiled them).
    pipelines: DenoisePipelines,
    size: (u32, u32),
    /// Uniform slots: 0 for the temporal and variance passes, `1 + i` for a-trous iteration `i`.
    uniforms: wgpu::Buffer,
    /// The previous frame's G-buffer depth (f16) and normal (8-bit octahedral) in one word,
    /// written by `temporal` once `temporal_short` has read the previous one.
    previous_geometry: wgpu::Buffer,
    /// RGB9E5 short history, updated in place: `temporal_short` leaves this frame's in the
    /// scratch, `temporal` copies it back.
    short_history: wgpu::Buffer,
    /// Long history color, luminance variance and age (`pack_history64` in the shader): the
    /// color of the previous frame's temporal blend (with feedback, its first a-trous output).
    history: wgpu::Buffer,
    /// The reprojected long history's color and age, then a filter buffer, then the result.
    output: wgpu::Buffer,
    /// The reprojected long history's variance and this frame's short history, then the other
    /// filter buffer.
    scratch: wgpu::Buffer,
    /// Whether `output` and `scratch` are the denoiser's own, else lent
    /// ([`Denoiser::with_lent_buffers`]).
    owns_lent: bool,
    /// The stand-in for the gradients when there are none.
    no_gradients: Option<wgpu::Buffer>,
    gradient_grid: Option<GradientGrid>,
    /// Group 0.
    frame_group: wgpu::BindGroup,
    /// Group 1 of each uniform slot.
    uniform_groups: Vec<wgpu::BindGroup>,
    has_history: bool,
}

/// What one frame of the denoiser reads besides the sources it was made with.
pub struct DenoiseInputs<'a> {
    /// The filter's settings this frame.
    pub config: &'a DenoiseConfig,
}

/// What one frame of the denoiser produced.
pub struct DenoiseOutputs<'a> {
    /// The denoised irradiance ([`Denoiser::output`]).
    pub irradiance: &'a wgpu::Buffer,
}

impl Technique for Denoiser {
    type Inputs<'i> = DenoiseInputs<'i>;
    type Outputs<'o> = DenoiseOutputs<'o>;

    /// Records this frame's denoise passes (timer scopes `pc/denoise_temporal`,
    /// `pc/denoise_variance`, `pc/denoise_atrous`); `temporal` also keeps this frame's depth,
    /// normal and short history for the next frame, in place. The uniforms are
    /// written through the queue: record at most one frame per submission. `config` should be
    /// valid ([`DenoiseConfig::validate`]); more a-trous iterations than
    /// [`MAX_ATROUS_ITERATIONS`] are cut to that.
    fn record<'o>(
        &'o mut self,
        rec: &mut Recorder<'_>,
        inputs: &DenoiseInputs<'_>,
    ) -> DenoiseOutputs<'o> {
        let config = inputs.config;
        let ctx = rec.ctx;
        debug_assert_eq!(config.validate(), Ok(()));
        let iterations = config.atrous_iterations.min(MAX_ATROUS_ITERATIONS);
        self.write_uniforms(ctx, config);
        let workgroups = [
            self.size.0.div_ceil(TILE_GROUP),
            self.size.1.div_ceil(TILE_GROUP),
        ];
        let frame_group = &self.frame_group;
        let dispatch =
            |pass: &mut wgpu::ComputePass<'_>, pipeline: &wgpu::ComputePipeline, slot: u32| {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, frame_group, &[]);
                pass.set_bind_group(1, &self.uniform_groups[slot as usize], &[]);
                pass.dispatch_workgroups(workgroups[0], workgroups[1], 1);
            };
        // One scope for both dispatches: wgpu orders dispatches of a pass with barriers, and
        // `temporal` reads the short history `temporal_short` wrote around each pixel.
        rec.compute_pass("pc/denoise_temporal", |pass| {
            dispatch(pass, &self.pipelines.temporal_short, 0);
            dispatch(pass, &self.pipelines.temporal, 0);
        });
        // Without a-trous iterations the temporal pass wrote the output and the history.
        if iterations > 0 {
            rec.compute_pass("pc/denoise_variance", |pass| {
                dispatch(pass, &self.pipelines.variance, 0);
            });
            let atrous = match config.atrous_kernel {
                AtrousKernel::B3 => &self.pipelines.atrous,
                AtrousKernel::Linear => &self.pipelines.atrous_3x3,
            };
            for i in 0..iterations {
                rec.compute_pass("pc/denoise_atrous", |pass| {
                    dispatch(pass, atrous, 1 + i);
                });
            }
        }
        self.has_history = config.temporal;
        DenoiseOutputs {
            irradiance: &self.output,
        }
    }
}

impl Denoiser {
    /// The denoiser for images of `size` over `sources`, with buffers of its own.
    pub fn new(
        ctx: &GpuContext,
        pipelines: &DenoisePipelines,
        size: (u32, u32),
        sources: &DenoiseSources<'_>,
    ) -> Self {
        Self::build(ctx, pipelines, size, sources, None)
    }

    /// As [`Denoiser::new`], its output and scratch in buffers the caller lends.
    pub(crate) fn with_lent_buffers(
        ctx: &GpuContext,
        pipelines: &DenoisePipelines,
        size: (u32, u32),
        sources: &DenoiseSources<'_>,
        lent: LentBuffers<'_>,
    ) -> Self {
        Self::build(ctx, pipelines, size, sources, Some(lent))
    }

    fn build(
        ctx: &GpuContext,
        pipelines: &DenoisePipelines,
        size: (u32, u32),
        sources: &DenoiseSources<'_>,
        lent: Option<LentBuffers<'_>>,
    ) -> Self {
        let pixels = u64::from(size.0) * u64::from(size.1);
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let buffer = |label: &str, bytes_per_pixel: u64| {
            ctx.create_buffer(label, pixels * bytes_per_pixel, storage)
        };
        let uniforms = ctx.create_buffer(
            "pc.denoise.uniforms",
            UNIFORM_SLOT_BYTES * u64::from(1 + MAX_ATROUS_ITERATIONS),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let previous_geometry = buffer("pc.denoise.previous_geometry", 4);
        let short_history = buffer("pc.denoise.short_history", 4);
        let history = buffer("pc.denoise.history", 8);
        let owns_lent = lent.is_none();
        let (output, scratch) = match lent {
            Some(lent) => {
                debug_assert!(lent.output.size() >= pixels * OUTPUT_PIXEL_BYTES);
                debug_assert!(lent.scratch.size() >= pixels * SCRATCH_PIXEL_BYTES);
                (lent.output.clone(), lent.scratch.clone())
            }
            None => (
                buffer("pc.denoise.output", OUTPUT_PIXEL_BYTES),
                buffer("pc.denoise.scratch", SCRATCH_PIXEL_BYTES),
            ),
        };
        // Without gradients lambda is never read: a binding's least size stands in.
        let no_gradients = sources
            .gradients
            .is_none()
            .then(|| ctx.create_buffer("pc.denoise.no_gradients", 16, wgpu::BufferUsages::STORAGE));
        let gradients = sources
            .gradients
            .as_ref()
            .map(|g| g.buffer)
            .or(no_gradients.as_ref())
            .expect("one of the two");
        let gradient_grid = sources.gradients.as_ref().map(|g| g.grid);

        let frame_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pc/denoise.frame_group"),
            layout: &pipelines.frame_layout,
            entries: &DenoiseBindings {
                noisy: sources.noisy,
                depth: sources.depth,
                normal: sources.normal,
                motion: sources.motion,
                previous_geometry: &previous_geometry,
                short_history: &short_history,
                history: &history,
                output: &output,
                gradients,
                scratch: &scratch,
            }
            .entries(),
        });
        let uniform_groups = (0..=MAX_ATROUS_ITERATIONS)
            .map(|slot| {
                let binding = wgpu::BufferBinding {
                    buffer: &uniforms,
                    offset: UNIFORM_SLOT_BYTES * u64::from(slot),
                    size: NonZeroU64::new(size_of::<DenoiseUniforms>() as u64),
                };
                ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("pc/denoise.uniform_group"),
                    layout: &pipelines.uniform_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(binding),
                    }],
                })
            })
            .collect();
        Self {
            pipelines: pipelines.clone(),
            size,
            uniforms,
            previous_geometry,
            short_history,
            history,
            output,
            scratch,
            owns_lent,
            no_gradients,
            gradient_grid,
            frame_group,
            uniform_groups,
            has_history: false,
        }
    }

    /// Writes slot 0 (temporal, variance) and one slot per a-trous iteration.
    fn write_uniforms(&self, ctx: &GpuContext, config: &DenoiseConfig) {
        let mut base = DenoiseUniforms::new(config, self.size, config.temporal && self.has_history);
        if let Some(grid) = self.gradient_grid {
            base.gradient_scale = grid.scale;
            (base.gradient_strata_x, base.gradient_strata_y) = grid.strata;
        }
        let mut slots = vec![0u8; self.uniforms.size() as usize];
        for slot in 0..=MAX_ATROUS_ITERATIONS {
            let uniforms = match slot {
                0 => base,
                _ => DenoiseUniforms {
                    step_px: 1 << (slot - 1),
                    ..base
                },
            };
            let offset = (UNIFORM_SLOT_BYTES * u64::from(slot)) as usize;
            let bytes = bytemuck::bytes_of(&uniforms);
            slots[offset..offset + bytes.len()].copy_from_slice(bytes);
        }
        ctx.queue.write_buffer(&self.uniforms, 0, &slots);
    }

    /// The denoised irradiance, `array<vec2<u32>>` in `pack_color64` (rgb; the value holds the
    /// filter's luminance variance estimate), valid once the recorded passes ran and until the
    /// next [`Technique::record`], which uses it as scratch (a lent output, until its lender
    /// uses it again).
    pub fn output(&self) -> &wgpu::Buffer {
        &self.output
    }

    /// The previous frame's G-buffer depth and normal, `array<u32>` of
    /// `gi::packing::pack_depth_normal` (f16 depth, +inf for sky; 8-bit octahedral normal):
    /// valid from the end of one recorded frame until the next frame's `pc/denoise_temporal`.
    pub fn previous_geometry(&self) -> &wgpu::Buffer {
        &self.previous_geometry
    }

    /// The image size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Forgets the history (the next frame starts fresh), e.g. after a scene change.
    pub fn reset_history(&mut self) {
        self.has_history = false;
    }

    /// The buffers it owns.
    fn buffers(&self) -> impl Iterator<Item = &wgpu::Buffer> {
        [
            &self.uniforms,
            &self.previous_geometry,
            &self.short_history,
            &self.history,
        ]
        .into_iter()
        .chain(
            [&self.output, &self.scratch]
                .into_iter()
                .filter(|_| self.owns_lent),
        )
        .chain(self.no_gradients.as_ref())
    }

    /// Stops counting and destroys the buffers it owns (not the sources).
    pub fn release(self, ctx: &GpuContext) {
        for buffer in self.buffers() {
            ctx.release_buffer(buffer);
        }
    }

    /// Bytes of the buffers it owns.
    pub fn memory_bytes(&self) -> u64 {
        self.buffers().map(wgpu::Buffer::size).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_gpu::binding::{check_declared, wgsl_storage_bindings};

    #[test]
    fn the_shaders_declare_the_named_buffers_at_their_bindings() {
        let shaders = ShaderLibrary::new();
        let file = "pc/denoise/shared.wgsl";
        let source = shaders.source(file).expect("the shader is in the library");
        check_declared(
            source,
            0,
            DenoiseBindings::FIRST_BINDING,
            DenoiseBindings::SLOTS,
        )
        .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(
            wgsl_storage_bindings(source, 0).len(),
            DenoiseBindings::SLOTS.len(),
            "{file} declares every binding"
        );
        // The passes import group 0's buffers from the shared file.
        for pass in ["temporal", "variance", "atrous"] {
            let file = format!("pc/denoise/{pass}.wgsl");
            let source = shaders.source(&file).expect("the pass is in the library");
            assert_eq!(wgsl_storage_bindings(source, 0), [], "{file}");
        }
    }
}

//! The PC tier's denoiser (`gi_tiers::pc::denoise`) on synthetic 64 x 64 frames built directly
//! as G-buffer buffers: its uniforms' layout, its settings' validation, exactness on constant
//! input under every configuration, noise reduction with the mean kept, edges, and history
//! rejection and clamping.

use gi_cache::packing::{pack_color64, pack_unit_vector, unpack_color64};
use gi_gpu::{
    GpuContext, GpuTimer, Recorder, ShaderLibrary, Technique, rust_field_offsets, wgpu,
    wgsl_struct_layout,
};
use gi_tiers::pc::denoise::{
    AtrousKernel, DenoiseConfig, DenoiseInputs, DenoisePipelines, DenoiseSources, DenoiseUniforms,
    Denoiser, GradientGrid, GradientSource,
};
use glam::Vec3;
use rand::RngExt as _;
use rand_pcg::Pcg32;

const SIZE: (u32, u32) = (64, 64);
const PIXELS: usize = (SIZE.0 * SIZE.1) as usize;
/// Most error of one store of a color in 64 bits (16-bit mantissas sharing an exponent),
/// relative to the largest channel: half a step of 2^-16 of the exponent's power of two. The
/// long history, its reprojection and the filter buffers (the output among them) are stored
/// so.
const COLOR64_ERROR: f32 = 1.0 / 131072.0;
/// The long history's color (`pack_history64`: 14-bit mantissas sharing an exponent): half a
/// step of 2^-13 of the largest channel's power of two, at most 2^-14 of the channel.
const HISTORY64_ERROR: f32 = 1.0 / 16384.0;
/// The same for RGB9E5 (9-bit mantissas): the short history, which places the clamp box.
const RGB9E5_ERROR: f32 = 1.0 / 512.0;
/// f32 arithmetic of the passes, relative.
const ARITHMETIC_ERROR: f32 = 1e-6;

/// One frame's inputs, one entry per pixel, row-major.
#[derive(Clone)]
struct Frame {
    noisy: Vec<[f32; 4]>,
    depth: Vec<f32>,
    normal: Vec<u32>,
    motion: Vec<[f32; 2]>,
}

impl Frame {
    /// A flat surface: every pixel at `depth` with normal `normal`, no motion, input `value`.
    fn flat(value: [f32; 3], depth: f32, normal: Vec3) -> Self {
        Self {
            noisy: vec![[value[0], value[1], value[2], 0.0]; PIXELS],
            depth: vec![depth; PIXELS],
            normal: vec![pack_unit_vector(normal); PIXELS],
            motion: vec![[0.0; 2]; PIXELS],
        }
    }

    /// Marks `pixel` as sky with input `value`.
    fn set_sky(&mut self, pixel: usize, value: f32) {
        self.depth[pixel] = f32::INFINITY;
        self.normal[pixel] = 0;
        self.noisy[pixel] = [value, value, value, 0.0];
    }

    /// The noisy input as the denoiser reads it: each pixel stored in `pack_color64`.
    fn stored_noisy(&self) -> Vec<[f32; 4]> {
        (self.noisy.iter())
            .map(|&c| unpack_color64(pack_color64(Vec3::from_slice(&c), 0.0)).to_array())
            .collect()
    }

    /// Multiplies every channel of every non-sky pixel by `1 + amplitude * U(-1, 1)`: i.i.d.
    /// noise, symmetric, so an unbiased filter keeps the mean, and non-negative for
    /// `amplitude <= 1`.
    fn add_noise(&mut self, rng: &mut Pcg32, amplitude: f32) {
        for (color, depth) in self.noisy.iter_mut().zip(&self.depth) {
            if depth.is_finite() {
                for channel in &mut color[..3] {
                    *channel *= 1.0 + amplitude * rng.random_range(-1.0..1.0f32);
                }
            }
        }
    }
}

fn column(pixel: usize) -> u32 {
    pixel as u32 % SIZE.0
}

/// A denoiser over its own source buffers, which each frame overwrites.
struct Harness {
    ctx: GpuContext,
    noisy: wgpu::Buffer,
    depth: wgpu::Buffer,
    normal: wgpu::Buffer,
    motion: wgpu::Buffer,
    denoiser: Denoiser,
    timer: GpuTimer,
    /// The temporal gradients' lambda per stratum (z), with [`Harness::with_gradients`].
    gradients: Option<wgpu::Buffer>,
}

impl Harness {
    fn new(ctx: GpuContext) -> Self {
        Self::with_gradients(ctx, None)
    }

    /// A denoiser that reads temporal gradients over `grid` ([`Harness::set_lambda`]).
    fn with_gradients(ctx: GpuContext, grid: Option<GradientGrid>) -> Self {
        let pipelines = DenoisePipelines::new(&ctx, &ShaderLibrary::new()).unwrap();
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let buffer = |label: &str, bytes_per_pixel: u64| {
            ctx.create_buffer(label, PIXELS as u64 * bytes_per_pixel, usage)
        };
        let noisy = buffer("test.noisy", 8);
        let depth = buffer("test.depth", 4);
        let normal = buffer("test.normal", 4);
        let motion = buffer("test.motion", 8);
        let gradients = grid.map(|grid| {
            let strata = u64::from(grid.strata.0 * grid.strata.1);
            ctx.create_buffer("test.gradients", strata * 16, usage)
        });
        let sources = DenoiseSources {
            noisy: &noisy,
            depth: &depth,
            normal: &normal,
            motion: &motion,
            gradients: grid
                .zip(gradients.as_ref())
                .map(|(grid, buffer)| GradientSource { buffer, grid }),
        };
        let denoiser = Denoiser::new(&ctx, &pipelines, SIZE, &sources);
        let timer = GpuTimer::new(&ctx, "test.denoise", 16);
        Self {
            ctx,
            noisy,
            depth,
            normal,
            motion,
            denoiser,
            timer,
            gradients,
        }
    }

    /// Sets the gradients' lambda of every stratum, row-major.
    fn set_lambda(&self, lambda: &[f32]) {
        let entries: Vec<[f32; 4]> = lambda.iter().map(|&l| [0.0, 0.0, l, 0.0]).collect();
        let buffer = self.gradients.as_ref().expect("made with gradients");
        self.ctx
            .queue
            .write_buffer(buffer, 0, bytemuck::cast_slice(&entries));
    }

    /// Denoises `frame` and returns the output.
    fn run(&mut self, frame: &Frame, config: &DenoiseConfig) -> Vec<[f32; 4]> {
        let queue = &self.ctx.queue;
        let noisy: Vec<[u32; 2]> = (frame.noisy.iter())
            .map(|&c| pack_color64(Vec3::from_slice(&c), 0.0))
            .collect();
        queue.write_buffer(&self.noisy, 0, bytemuck::cast_slice(&noisy));
        queue.write_buffer(&self.depth, 0, bytemuck::cast_slice(&frame.depth));
        queue.write_buffer(&self.normal, 0, bytemuck::cast_slice(&frame.normal));
        queue.write_buffer(&self.motion, 0, bytemuck::cast_slice(&frame.motion));
        let mut rec = Recorder::new(&self.ctx, &mut self.timer, "test.denoise");
        self.denoiser.record(&mut rec, &DenoiseInputs { config });
        let encoder = rec.into_encoder();
        let timings = self.timer.finish(&self.ctx, encoder);
        let expected = 1 + u32::from(config.atrous_iterations > 0) + config.atrous_iterations;
        assert_eq!(timings.0.len() as u32, expected, "{timings:?}");
        let packed: Vec<[u32; 2]> = self.ctx.read_buffer(self.denoiser.output());
        packed
            .iter()
            .map(|&p| unpack_color64(p).to_array())
            .collect()
    }
}

/// Mean and standard deviation of channel `channel` over the pixels `keep` selects.
fn stats(image: &[[f32; 4]], channel: usize, keep: impl Fn(usize) -> bool) -> (f64, f64) {
    let values: Vec<f64> = (0..image.len())
        .filter(|&pixel| keep(pixel))
        .map(|pixel| f64::from(image[pixel][channel]))
        .collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, variance.sqrt())
}

fn configs() -> Vec<(String, DenoiseConfig)> {
    let mut configs = Vec::new();
    for temporal in [true, false] {
        for atrous_iterations in [0, 1, 4, 8] {
            configs.push((
                format!("temporal {temporal}, atrous {atrous_iterations}"),
                DenoiseConfig {
                    temporal,
                    atrous_iterations,
                    ..DenoiseConfig::default()
                },
            ));
        }
    }
    for atrous_iterations in [1, 4] {
        configs.push((
            format!("5 x 5 kernel, atrous {atrous_iterations}"),
            DenoiseConfig {
                atrous_kernel: AtrousKernel::B3,
                atrous_iterations,
                ..DenoiseConfig::default()
            },
        ));
    }
    configs.push((
        "short history clamp".to_owned(),
        DenoiseConfig {
            short_clamp_sigma: 2.0,
            ..DenoiseConfig::default()
        },
    ));
    configs.push((
        "SVGF's feedback".to_owned(),
        DenoiseConfig {
            feedback: true,
            ..DenoiseConfig::default()
        },
    ));
    configs
}

#[test]
fn uniforms_match_their_wgsl_layout() {
    let module = ShaderLibrary::new()
        .compose("pc/denoise/shared.wgsl", &[])
        .unwrap();
    let wgsl = wgsl_struct_layout(&module, "DenoiseUniforms").unwrap();
    let rust = rust_field_offsets!(DenoiseUniforms {
        size_px,
        step_px,
        atrous_iterations,
        history_valid,
        long_history,
        short_history,
        variance_min_age,
        clamp_sigma,
        reprojection_depth_tolerance,
        reprojection_normal_cos,
        normal_power,
        depth_sigma,
        luminance_sigma,
        feedback,
        short_clamp_sigma,
        gradient_scale,
        gradient_strata_x,
        gradient_strata_y,
        pad,
    });
    assert_eq!(wgsl.members, rust);
    assert_eq!(wgsl.size as usize, size_of::<DenoiseUniforms>());
}

/// Makes one setting of a valid config invalid.
type Spoil = fn(&mut DenoiseConfig);

#[test]
fn validation_names_the_bad_field() {
    assert_eq!(DenoiseConfig::default().validate(), Ok(()));
    let bad: [(&str, Spoil); 10] = [
        ("atrous_iterations", |c| c.atrous_iterations = 9),
        ("long_history", |c| c.long_history = 0),
        ("long_history", |c| c.long_history = 128),
        ("short_history", |c| c.short_history = 0),
        ("short_history", |c| c.short_history = 51),
        ("clamp_sigma", |c| c.clamp_sigma = 0.0),
        ("reprojection_depth_tolerance", |c| {
            c.reprojection_depth_tolerance = f32::NAN
        }),
        ("reprojection_normal_cos", |c| {
            c.reprojection_normal_cos = 1.5
        }),
        ("normal_power", |c| c.normal_power = -1.0),
        ("luminance_sigma", |c| c.luminance_sigma = f32::INFINITY),
    ];
    for (field, spoil) in bad {
        let mut config = DenoiseConfig::default();
        spoil(&mut config);
        let err = config.validate().unwrap_err();
        assert!(err.starts_with(field), "{field}: {err}");
    }
}

#[test]
fn constant_input_stays_constant_under_every_config() {
    let Some(ctx) = GpuContext::new_or_skip("constant_input_stays_constant_under_every_config")
    else {
        return;
    };
    let mut harness = Harness::new(ctx);
    // A plane sloping away to the right, seen moving (sub-pixel motion exercises the bilinear
    // reprojection and its partial taps at the borders), with a block of sky whose input must
    // come out as is and must not leak into the constant.
    let value = [0.3, 0.6, 0.9];
    let mut frame = Frame::flat(value, 2.0, Vec3::Z);
    for pixel in 0..PIXELS {
        frame.depth[pixel] = 2.0 + 0.01 * column(pixel) as f32;
        frame.motion[pixel] = [0.25, -0.5];
        if column(pixel) < 16 && pixel < 8 * SIZE.0 as usize {
            frame.set_sky(pixel, 7.0);
        }
    }
    for (name, config) in configs() {
        // Errors relative to the pixel's largest channel. The input is rounded once (stored
        // in 64 bits). Without history only the filter buffers (the output among them) round
        // (once: a constant stays what it was rounded to). With history the long history is
        // also rounded when stored (`pack_history64`) and when reprojected; the clamp box is
        // widened by the short history's RGB9E5 rounding, which therefore does not show.
        let bound = if config.temporal {
            3.0 * COLOR64_ERROR + HISTORY64_ERROR
        } else {
            2.0 * COLOR64_ERROR
        } + ARITHMETIC_ERROR;
        harness.denoiser.reset_history();
        let mut worst = 0.0f32;
        for index in 0..6 {
            let output = harness.run(&frame, &config);
            for (pixel, out) in output.iter().enumerate() {
                let expected = if frame.depth[pixel].is_finite() {
                    value
                } else {
                    [7.0; 3]
                };
                let largest = expected.into_iter().fold(0.0f32, f32::max);
                for c in 0..3 {
                    worst = worst.max((out[c] - expected[c]).abs() / largest);
                }
            }
            assert!(
                worst <= bound,
                "{name}, frame {index}: relative error {worst} > {bound}"
            );
        }
        eprintln!("{name}: worst relative error {worst:e} (bound {bound:e})");
    }
}

#[test]
fn noise_falls_and_the_mean_stays() {
    let Some(ctx) = GpuContext::new_or_skip("noise_falls_and_the_mean_stays") else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let mean = [0.5f32, 1.0, 2.0];
    let frames = 16;
    // Upper bounds on output / input standard deviation per config: temporal accumulation
    // alone averages 16 frames (1/4), the a-trous filter alone a wide neighbourhood.
    let cases = [
        ("default", DenoiseConfig::default(), 0.03),
        (
            "temporal only",
            DenoiseConfig {
                atrous_iterations: 0,
                ..DenoiseConfig::default()
            },
            0.3,
        ),
        (
            "spatial only",
            DenoiseConfig {
                temporal: false,
                ..DenoiseConfig::default()
            },
            0.15,
        ),
        // Four 5 x 5 iterations reach as far as the default's five 3 x 3 ones.
        (
            "spatial only, 5 x 5 kernel",
            DenoiseConfig {
                temporal: false,
                atrous_kernel: AtrousKernel::B3,
                atrous_iterations: 4,
                ..DenoiseConfig::default()
            },
            0.15,
        ),
    ];
    for (name, config, bound) in cases {
        let mut rng = Pcg32::new(17, 0x0a02_bdbf_7bb3_c0a7);
        harness.denoiser.reset_history();
        let mut output = Vec::new();
        let mut input = Frame::flat(mean, 3.0, Vec3::Z);
        for _ in 0..frames {
            input = Frame::flat(mean, 3.0, Vec3::Z);
            input.add_noise(&mut rng, 0.9);
            output = harness.run(&input, &config);
        }
        for (c, &expected_mean) in mean.iter().enumerate() {
            let (_, sigma_in) = stats(&input.noisy, c, |_| true);
            let (mean_out, sigma_out) = stats(&output, c, |_| true);
            // One frame's standard error of the image mean; the output averages more samples.
            let standard_error = sigma_in / (PIXELS as f64).sqrt();
            let ratio = sigma_out / sigma_in;
            let mean_error = (mean_out - f64::from(expected_mean)) / standard_error;
            eprintln!(
                "{name}, channel {c}: sigma in {sigma_in:.4}, out {sigma_out:.4} \
                 (ratio {ratio:.4}); mean error {mean_error:.2} standard errors"
            );
            assert!(ratio < bound, "{name}, channel {c}: sigma ratio {ratio}");
            assert!(
                mean_error.abs() < 4.0,
                "{name}, channel {c}: mean {mean_out}"
            );
        }
    }
}

/// Worst relative difference between two images' rgb over the pixels `keep` selects.
fn worst_relative_error(
    image: &[[f32; 4]],
    expected: &[[f32; 4]],
    keep: impl Fn(usize) -> bool,
) -> f32 {
    let mut worst = 0.0f32;
    for pixel in (0..image.len()).filter(|&pixel| keep(pixel)) {
        for c in 0..3 {
            let scale = expected[pixel][c].abs().max(1e-6);
            worst = worst.max((image[pixel][c] - expected[pixel][c]).abs() / scale);
        }
    }
    worst
}

#[test]
fn atrous_does_not_bleed_across_normal_or_depth_edges() {
    let Some(ctx) = GpuContext::new_or_skip("atrous_does_not_bleed_across_normal_or_depth_edges")
    else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let edge = SIZE.0 / 2;
    let (left, right) = (1.0f32, 4.0f32);
    // (name, right half's depth, right half's normal, whether the edge must hold)
    let cases = [
        ("normal edge", 2.0, Vec3::X, true),
        ("depth edge", 10.0, Vec3::Z, true),
        ("no geometric edge (control)", 2.0, Vec3::Z, false),
    ];
    // With SVGF's feedback every frame's filter compounds, so a leak would grow frame after
    // frame and the control bleeds far: the stricter test. The default (no feedback) must
    // hold the edges too.
    let default = DenoiseConfig::default();
    let feedback = DenoiseConfig {
        feedback: true,
        ..DenoiseConfig::default()
    };
    let b3 = DenoiseConfig {
        atrous_kernel: AtrousKernel::B3,
        atrous_iterations: 4,
        ..DenoiseConfig::default()
    };
    let b3_feedback = DenoiseConfig {
        feedback: true,
        ..b3.clone()
    };
    let runs = cases
        .iter()
        .map(|case| (case, &feedback))
        .chain(cases.iter().skip(2).map(|case| (case, &b3_feedback)))
        .chain(cases.iter().take(2).map(|case| (case, &default)))
        .chain(cases.iter().take(2).map(|case| (case, &b3)));
    for (&(name, right_depth, right_normal, holds), config) in runs {
        let name = format!(
            "{name}, feedback {}, kernel {}",
            config.feedback,
            config.atrous_kernel.name()
        );
        let mut rng = Pcg32::new(5, 0x0a02_bdbf_7bb3_c0a7);
        harness.denoiser.reset_history();
        let mut output = Vec::new();
        for _ in 0..8 {
            let mut frame = Frame::flat([left; 3], 2.0, Vec3::Z);
            for pixel in (0..PIXELS).filter(|&pixel| column(pixel) >= edge) {
                frame.noisy[pixel] = [right, right, right, 0.0];
                frame.depth[pixel] = right_depth;
                frame.normal[pixel] = pack_unit_vector(right_normal);
            }
            // Noise loosens the luminance weight, so that only geometry can stop the blur.
            frame.add_noise(&mut rng, 0.5);
            output = harness.run(&frame, config);
        }
        // The worst relative deviation of a column's mean (over the rows) from its half's
        // value, among the columns two or more pixels from the edge.
        let mut worst = 0.0f64;
        let mut worst_column = 0;
        for x in (0..SIZE.0).filter(|&x| x + 2 < edge || x >= edge + 2) {
            let expected = f64::from(if x < edge { left } else { right });
            let (mean, _) = stats(&output, 0, |pixel| column(pixel) == x);
            let deviation = (mean - expected).abs() / expected;
            if deviation > worst {
                (worst, worst_column) = (deviation, x);
            }
        }
        eprintln!("{name}: worst column mean deviation {worst:.4} (column {worst_column})");
        // An edge holds within 2%; the control must bleed at least twice that, so that the
        // measure would see a leak.
        let bound = 0.02;
        if holds {
            assert!(
                worst < bound,
                "{name}: column {worst_column} is off by {worst}"
            );
        } else {
            assert!(
                worst > 2.0 * bound,
                "{name}: the control shows no bleeding ({worst})"
            );
        }
    }
}

#[test]
fn disocclusion_drops_the_history_and_a_static_surface_keeps_it() {
    let Some(ctx) =
        GpuContext::new_or_skip("disocclusion_drops_the_history_and_a_static_surface_keeps_it")
    else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let temporal_only = DenoiseConfig {
        atrous_iterations: 0,
        ..DenoiseConfig::default()
    };
    let mut rng = Pcg32::new(23, 0x0a02_bdbf_7bb3_c0a7);
    let noisy_frame = |rng: &mut Pcg32, value: f32, depth: f32| {
        let mut frame = Frame::flat([value; 3], depth, Vec3::Z);
        frame.add_noise(rng, 0.9);
        frame
    };
    // Output / input standard deviation, green channel.
    let sigma_ratio = |output: &[[f32; 4]], frame: &Frame| {
        stats(output, 1, |_| true).1 / stats(&frame.noisy, 1, |_| true).1
    };

    // A static surface: the history grows and the noise keeps falling.
    let mut ratios = Vec::new();
    for index in 1..=16 {
        let frame = noisy_frame(&mut rng, 1.0, 2.0);
        let output = harness.run(&frame, &temporal_only);
        if [1, 4, 16].contains(&index) {
            ratios.push(sigma_ratio(&output, &frame));
        }
    }
    eprintln!("static surface: sigma ratio after 1, 4, 16 frames {ratios:.4?}");
    assert!(
        ratios[0] > 0.999,
        "the first frame has no history: {ratios:?}"
    );
    assert!(ratios[1] < 0.75 * ratios[0] && ratios[2] < 0.75 * ratios[1]);

    // The depth changes everywhere by 25 %: no history survives, the output is the input.
    let frame = noisy_frame(&mut rng, 3.0, 2.5);
    let output = harness.run(&frame, &temporal_only);
    let error = worst_relative_error(&output, &frame.stored_noisy(), |_| true);
    eprintln!("disocclusion frame: output vs input relative error {error:e}");
    assert!(error <= 1e-6, "history survived the disocclusion: {error}");
    let frame = noisy_frame(&mut rng, 3.0, 2.5);
    let output = harness.run(&frame, &temporal_only);
    let ratio = sigma_ratio(&output, &frame);
    eprintln!("the frame after: sigma ratio {ratio:.4}");
    assert!(ratio < 0.8, "the new history is not kept: {ratio}");

    // The same with the whole filter on a noise-free input: the new value at once.
    harness.denoiser.reset_history();
    for _ in 0..10 {
        harness.run(
            &Frame::flat([1.0; 3], 2.0, Vec3::Z),
            &DenoiseConfig::default(),
        );
    }
    let frame = Frame::flat([3.0; 3], 2.5, Vec3::Z);
    let output = harness.run(&frame, &DenoiseConfig::default());
    let error = worst_relative_error(&output, &frame.stored_noisy(), |_| true);
    assert!(
        error <= 1e-5,
        "default config after the disocclusion: {error}"
    );
}

#[test]
fn a_lighting_change_is_followed_as_fast_as_the_short_history() {
    let Some(ctx) =
        GpuContext::new_or_skip("a_lighting_change_is_followed_as_fast_as_the_short_history")
    else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let config = DenoiseConfig::default();
    let (before, after) = (1.0f32, 2.0f32);
    for _ in 0..60 {
        harness.run(&Frame::flat([before; 3], 2.0, Vec3::Z), &config);
    }
    // Same geometry, new irradiance: depth and normal keep the history, and only the clamp
    // into the short history's box removes the old value. The short history moves by
    // 1 / short_history of the remaining difference per frame; the long history alone would
    // move by 1 / long_history.
    let frame = Frame::flat([after; 3], 2.0, Vec3::Z);
    let keep = 1.0 - 1.0 / config.short_history as f32;
    for k in 1..=20 {
        let output = harness.run(&frame, &config);
        let left = output
            .iter()
            .map(|o| (o[1] - after).abs())
            .fold(0.0f32, f32::max);
        // Plus the short history's RGB9E5 rounding (it stops moving within a rounding of the
        // new value) and the clamp box's widening by that rounding.
        let allowed = (after - before) * keep.powi(k) + 2.0 * RGB9E5_ERROR * after;
        if k % 5 == 0 {
            eprintln!("frame {k} after the change: {left:.5} left, clamping allows {allowed:.5}");
        }
        assert!(
            left <= allowed + 1e-3,
            "frame {k}: {left} of the old value left"
        );
    }
}

/// A light switched off under noise (multiplicative, +-50% uniform): the image mean falls from
/// 1 to 0.1. Without the short history's clamp the history follows at its blend rate (after 4
/// frames about 0.9^4 = 66% of the change is left); with it, the reprojected short history
/// lands in the noisy neighbourhood's box at once, so within 4 frames at most a tenth of the
/// change is left. Then, held still for 60 frames, the clamped history must still smooth: the
/// output's noise stays within twice the unclamped one's. (The mean then still lies a few
/// percent above the new value in both: the long history, clamped into the short one's box,
/// leaves it from its edge at `1 / long_history` a frame.)
#[test]
fn the_short_history_clamp_follows_a_light_switched_off() {
    let Some(ctx) = GpuContext::new_or_skip("the_short_history_clamp_follows_a_light_switched_off")
    else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let (before, after) = (1.0f32, 0.1f32);
    let mut left_after_4 = Vec::new();
    let mut sigma_still = Vec::new();
    for short_clamp_sigma in [0.0, 2.0] {
        let config = DenoiseConfig {
            short_clamp_sigma,
            ..DenoiseConfig::default()
        };
        let mut rng = Pcg32::new(41, 0x0a02_bdbf_7bb3_c0a7);
        harness.denoiser.reset_history();
        let noisy = |rng: &mut Pcg32, value: f32| {
            let mut frame = Frame::flat([value; 3], 2.0, Vec3::Z);
            frame.add_noise(rng, 0.5);
            frame
        };
        for _ in 0..60 {
            harness.run(&noisy(&mut rng, before), &config);
        }
        let mut output = Vec::new();
        for _ in 0..4 {
            output = harness.run(&noisy(&mut rng, after), &config);
        }
        let (mean, _) = stats(&output, 1, |_| true);
        left_after_4.push((mean - f64::from(after)) / f64::from(before - after));
        for _ in 0..60 {
            output = harness.run(&noisy(&mut rng, after), &config);
        }
        let (mean, sigma) = stats(&output, 1, |_| true);
        sigma_still.push(sigma);
        eprintln!(
            "short_clamp_sigma {short_clamp_sigma}: {:.3} of the change left after 4 frames; \
             still: mean {mean:.4}, sigma {sigma:.5}",
            left_after_4.last().unwrap()
        );
    }
    assert!(
        left_after_4[0] > 0.5,
        "without the clamp: {}",
        left_after_4[0]
    );
    assert!(left_after_4[1] < 0.1, "with the clamp: {}", left_after_4[1]);
    assert!(
        sigma_still[1] < 2.0 * sigma_still[0],
        "the clamp's noise {} against {}",
        sigma_still[1],
        sigma_still[0]
    );
}

#[test]
fn history_follows_the_motion_vectors() {
    let Some(ctx) = GpuContext::new_or_skip("history_follows_the_motion_vectors") else {
        return;
    };
    let mut harness = Harness::new(ctx);
    let config = DenoiseConfig {
        atrous_iterations: 0,
        ..DenoiseConfig::default()
    };
    // A noise-free stripe pattern moving right one pixel per frame: every pixel's previous
    // position is one pixel to its left. Reprojected correctly, the history holds this frame's
    // values and the output equals the input; the wrong pixels' history would differ by up to
    // the stripes' contrast.
    let pattern = |x: i64| 1.0 + 0.5 * (0.7 * x as f32).sin();
    let mut worst = 0.0f32;
    for index in 0..8i64 {
        let mut frame = Frame::flat([0.0; 3], 2.0, Vec3::Z);
        for pixel in 0..PIXELS {
            let value = pattern(i64::from(column(pixel)) - index);
            frame.noisy[pixel] = [value, value, value, 0.0];
            frame.motion[pixel] = [-1.0, 0.0];
        }
        let output = harness.run(&frame, &config);
        worst = worst.max(worst_relative_error(&output, &frame.stored_noisy(), |_| {
            true
        }));
    }
    // The history is rounded when stored (`pack_history64`) and when reprojected, the output
    // when stored (the only filter write without a-trous iterations).
    let bound = HISTORY64_ERROR + 2.0 * COLOR64_ERROR + ARITHMETIC_ERROR;
    eprintln!("moving stripes: worst relative error {worst:e} (bound {bound:e})");
    assert!(worst <= bound, "moving stripes: {worst}");
}

#[test]
fn memory_is_counted_and_released() {
    let Some(ctx) = GpuContext::new_or_skip("memory_is_counted_and_released") else {
        return;
    };
    let harness = Harness::new(ctx);
    let bytes = harness.denoiser.memory_bytes();
    // 32 bytes per pixel with its own output and scratch (see the module docs),
    // nine 256-byte uniform slots and, without temporal gradients, the 16-byte buffer bound in
    // their place.
    assert_eq!(bytes, 32 * PIXELS as u64 + 9 * 256 + 16);
    assert_eq!(harness.ctx.memory().bytes_with_prefix("pc.denoise."), bytes);
    harness.denoiser.release(&harness.ctx);
    assert_eq!(harness.ctx.memory().bytes_with_prefix("pc.denoise."), 0);
}

/// SVGF's feedback re-filters the history every frame, so over a long history the first
/// a-trous kernel compounds into a wide blur: a bright stripe across a flat surface loses its
/// peak to its darker surroundings. Without feedback (the default) the history is the plain
/// temporal mean and only this frame's filter blurs it. The stripe is 5 pixels wide (Gaussian
/// of 4 px), three times brighter at its peak than the surface, with 50% noise; the loss at
/// the peak is measured per row over the last 16 of 80 frames, and the difference between
/// the two configurations must exceed four standard errors of its mean over the rows.
#[test]
fn feedback_compounds_the_blur_and_is_off_by_default() {
    let Some(ctx) = GpuContext::new_or_skip("feedback_compounds_the_blur_and_is_off_by_default")
    else {
        return;
    };
    assert!(!DenoiseConfig::default().feedback);
    let profile = |x: u32| 1.0 + 2.0 * (-((x as f32 - 32.0) / 4.0).powi(2)).exp();
    let mut harness = Harness::new(ctx);
    let mut peak_loss = |config: &DenoiseConfig| {
        harness.denoiser.reset_history();
        let mut rng = Pcg32::new(31, 0x0a02_bdbf_7bb3_c0a7);
        let mut per_row = vec![0.0f64; SIZE.1 as usize];
        for index in 0..80 {
            let mut frame = Frame::flat([1.0; 3], 2.0, Vec3::Z);
            for (pixel, color) in frame.noisy.iter_mut().enumerate() {
                let v = profile(column(pixel));
                *color = [v, v, v, 0.0];
            }
            frame.add_noise(&mut rng, 0.5);
            let output = harness.run(&frame, config);
            if index >= 64 {
                for (pixel, color) in output.iter().enumerate() {
                    if column(pixel) == 32 {
                        let row = pixel / SIZE.0 as usize;
                        per_row[row] += f64::from(1.0 - color[1] / profile(32)) / 16.0;
                    }
                }
            }
        }
        per_row
    };
    let without = peak_loss(&DenoiseConfig::default());
    let with = peak_loss(&DenoiseConfig {
        feedback: true,
        ..DenoiseConfig::default()
    });
    let differences: Vec<f64> = with.iter().zip(&without).map(|(a, b)| a - b).collect();
    let n = differences.len() as f64;
    let mean = differences.iter().sum::<f64>() / n;
    let sd = (differences.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let (loss_without, loss_with) = (
        without.iter().sum::<f64>() / n,
        with.iter().sum::<f64>() / n,
    );
    eprintln!(
        "peak loss: {loss_without:.4} without feedback, {loss_with:.4} with; difference {mean:.4} \
         (standard error {:.4})",
        sd / n.sqrt()
    );
    assert!(
        mean > 4.0 * sd / n.sqrt(),
        "feedback did not blur more: {mean} vs {sd}"
    );
}

/// The temporal gradients' lambda drops the history where the light changed and keeps it
/// elsewhere: after 24 frames of a lit surface the light goes out; where lambda is 1 the
/// very next frame shows the dark input, where it is 0 the histories fall at their own rate
/// (the short one by 1 / short_history a frame, the long one clamped into its box).
#[test]
fn lambda_drops_the_history_where_the_light_changed() {
    let Some(ctx) = GpuContext::new_or_skip("lambda_drops_the_history_where_the_light_changed")
    else {
        return;
    };
    let grid = GradientGrid {
        scale: 4,
        strata: (SIZE.0 / 4, SIZE.1 / 4),
    };
    let mut harness = Harness::with_gradients(ctx, Some(grid));
    let config = DenoiseConfig {
        atrous_iterations: 0,
        ..DenoiseConfig::default()
    };
    let strata = (grid.strata.0 * grid.strata.1) as usize;
    harness.set_lambda(&vec![0.0; strata]);
    let lit = Frame::flat([1.0; 3], 4.0, Vec3::Z);
    for _ in 0..24 {
        harness.run(&lit, &config);
    }
    // The left half's strata changed, the right half's did not.
    let lambda: Vec<f32> = (0..strata)
        .map(|s| f32::from(u8::from((s as u32 % grid.strata.0) < grid.strata.0 / 2)))
        .collect();
    harness.set_lambda(&lambda);
    let dark = Frame::flat([0.0; 3], 4.0, Vec3::Z);
    let output = harness.run(&dark, &config);
    // Away from the middle, where lambda is interpolated between the halves.
    let (left, _) = stats(&output, 1, |p| column(p) < SIZE.0 / 2 - grid.scale);
    let (right, _) = stats(&output, 1, |p| column(p) >= SIZE.0 / 2 + grid.scale);
    eprintln!("after the light went out: left (lambda 1) {left}, right (lambda 0) {right}");
    assert!(left.abs() < 1e-6, "the changed half kept history: {left}");
    let short = 1.0 - 1.0 / config.short_history as f64;
    assert!(
        right > 0.9 * short,
        "the unchanged half lost its history: {right}"
    );
}

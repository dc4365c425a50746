//! Tests of the GPU context, read-back, timers and memory accounting on a real adapter
//! (lavapipe in CI). Without an adapter they skip loudly, or fail when `GI_REQUIRE_GPU` is set.

use gi_gpu::{
    DeviceSharing, FRAMES_IN_FLIGHT, GpuContext, GpuError, GpuOptions, GpuTimer, ShaderLibrary,
    TimerMode,
};

/// An odd count, so the last workgroup is partial and the shader's bounds check matters.
const COUNT: usize = 1000;
const WORKGROUP_SIZE: usize = 64;

/// The `test/double` kernel bound to a fresh buffer of `0, 1, 2, ...`.
struct Doubler {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    values: wgpu::Buffer,
}

impl Doubler {
    fn new(ctx: &GpuContext) -> Self {
        let module = ShaderLibrary::new()
            .create_module(ctx, "test/double.wgsl", &[])
            .unwrap();
        let pipeline = ctx.create_compute_pipeline("test/double", &module, "double_values");
        let initial: Vec<f32> = (0..COUNT).map(|i| i as f32).collect();
        let values = ctx.create_buffer_init(
            "test.values",
            bytemuck::cast_slice(&initial),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("test/double"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: values.as_entire_binding(),
            }],
        });
        Self {
            pipeline,
            bind_group,
            values,
        }
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(COUNT.div_ceil(WORKGROUP_SIZE) as u32, 1, 1);
    }

    fn expected(factor: f32) -> Vec<f32> {
        (0..COUNT).map(|i| factor * i as f32).collect()
    }
}

/// Doubles `ctx`'s fresh buffer once and checks the result: the context's device works.
fn assert_doubles(ctx: &GpuContext) {
    let doubler = Doubler::new(ctx);
    let mut encoder = ctx.create_encoder("test/double");
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("test/double"),
            timestamp_writes: None,
        });
        doubler.record(&mut pass);
    }
    ctx.submit_and_wait(encoder);
    assert_eq!(
        ctx.read_buffer::<f32>(&doubler.values),
        Doubler::expected(2.0)
    );
}

#[test]
fn a_compute_shader_doubles_a_buffer() {
    let Some(ctx) = GpuContext::new_or_skip("a_compute_shader_doubles_a_buffer") else {
        return;
    };
    eprintln!(
        "adapter: {} ({:?})",
        ctx.adapter_info.name, ctx.adapter_info.device_type
    );
    assert_doubles(&ctx);
}

#[test]
fn the_timer_reports_each_named_pass() {
    let Some(ctx) = GpuContext::new_or_skip("the_timer_reports_each_named_pass") else {
        return;
    };
    for mode in [TimerMode::Gpu, TimerMode::Cpu] {
        let doubler = Doubler::new(&ctx);
        let mut timer = GpuTimer::with_mode(&ctx, "test.timer", 4, mode);
        if mode == TimerMode::Gpu {
            assert_eq!(
                timer.mode(),
                TimerMode::Gpu,
                "lavapipe and real GPUs have timestamps"
            );
        }
        let mut encoder = ctx.create_encoder("test/frame");
        timer.compute_pass(&ctx, &mut encoder, "test/double", |pass| {
            doubler.record(pass)
        });
        timer.compute_pass(&ctx, &mut encoder, "test/double_again", |pass| {
            doubler.record(pass)
        });
        let timings = timer.finish(&ctx, encoder);
        eprintln!("{mode:?} timings:\n{timings}");

        let names: Vec<&str> = timings.0.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["test/double", "test/double_again"], "{mode:?}");
        for (name, ms) in &timings.0 {
            assert!(ms.is_finite() && *ms >= 0.0, "{mode:?} {name}: {ms} ms");
        }
        assert!(timings.to_string().contains("test/double_again"));
        // Both passes ran, in order, in either mode.
        assert_eq!(
            ctx.read_buffer::<f32>(&doubler.values),
            Doubler::expected(4.0)
        );

        // The timer is reusable: the next frame starts empty.
        let empty = timer.finish(&ctx, ctx.create_encoder("test/frame"));
        assert!(empty.0.is_empty());
    }
}

/// Frames ended with `finish_async` are reported later, each under its own tag with its own
/// passes and times, never more than `FRAMES_IN_FLIGHT` at a time in flight; `drain` reports
/// the rest.
#[test]
fn the_timer_reports_frames_in_flight_in_order_with_their_own_times() {
    let Some(ctx) = GpuContext::new_or_skip("the_timer_reports_frames_in_flight") else {
        return;
    };
    // Even frames run one dispatch, odd ones 256 in their first pass: if a frame were
    // reported with another's timestamps, a light frame would read as long as a heavy one.
    const HEAVY: usize = 256;
    for mode in [TimerMode::Gpu, TimerMode::Cpu] {
        let doubler = Doubler::new(&ctx);
        let mut timer = GpuTimer::with_mode(&ctx, "test.timer", 4, mode);
        let frames = 9u32;
        let mut reported = Vec::new();
        for frame in 0..frames {
            let mut encoder = ctx.create_encoder("test/frame");
            let name = if frame % 2 == 0 {
                "test/light"
            } else {
                "test/heavy"
            };
            // Frame 4 records nothing; frame 6 is recorded in two submissions.
            if frame != 4 {
                timer.compute_pass(&ctx, &mut encoder, name, |pass| {
                    let dispatches = if frame % 2 == 0 { 1 } else { HEAVY };
                    for _ in 0..dispatches {
                        doubler.record(pass);
                    }
                });
            }
            if frame == 6 {
                timer.submit(&ctx, encoder);
                encoder = ctx.create_encoder("test/frame");
                timer.compute_pass(&ctx, &mut encoder, "test/second", |pass| {
                    doubler.record(pass)
                });
            }
            reported.extend(timer.finish_async(&ctx, encoder, frame));
            let in_flight = timer.frames_in_flight();
            match mode {
                TimerMode::Gpu => assert!(in_flight <= FRAMES_IN_FLIGHT, "{in_flight} in flight"),
                TimerMode::Cpu => assert_eq!(in_flight, 0, "CPU timing waits for every pass"),
            }
            assert_eq!(reported.len() + in_flight, frame as usize + 1, "{mode:?}");
        }
        reported.extend(timer.drain(&ctx));
        assert_eq!(timer.frames_in_flight(), 0);
        let tags: Vec<u32> = reported.iter().map(|(tag, _)| *tag).collect();
        assert_eq!(tags, (0..frames).collect::<Vec<_>>(), "{mode:?}");
        let mut light = Vec::new();
        let mut heavy = Vec::new();
        for (frame, timings) in &reported {
            let names: Vec<&str> = timings.0.iter().map(|(n, _)| n.as_str()).collect();
            let expected: &[&str] = match frame {
                4 => &[],
                6 => &["test/light", "test/second"],
                f if f % 2 == 0 => &["test/light"],
                _ => &["test/heavy"],
            };
            assert_eq!(names, expected, "{mode:?} frame {frame}");
            for (name, ms) in &timings.0 {
                assert!(ms.is_finite() && *ms >= 0.0, "{mode:?} {name}: {ms} ms");
            }
            light.extend(timings.get("test/light"));
            heavy.extend(timings.get("test/heavy"));
        }
        eprintln!("{mode:?}: light frames {light:?} ms, heavy frames {heavy:?} ms");
        // Medians: one frame may pay a first use or a busy machine's pause, but a time
        // reported for the wrong frame would swap the two kinds, which alternate.
        let (light, heavy) = (median(&light), median(&heavy));
        assert!(
            heavy > light,
            "{mode:?}: frames of {HEAVY} dispatches read a median of {heavy} ms, those of a \
             single dispatch {light} ms"
        );
    }
}

#[test]
fn the_memory_report_counts_bytes_by_label() {
    let Some(ctx) = GpuContext::new_or_skip("the_memory_report_counts_bytes_by_label") else {
        return;
    };
    let usage = wgpu::BufferUsages::STORAGE;
    let a = ctx.create_buffer("test.a", 1024, usage);
    let _b1 = ctx.create_buffer("test.b", 256, usage);
    let _b2 = ctx.create_buffer_init("test.b", &[7u8; 256], usage);
    let _texture = ctx.create_texture(&wgpu::TextureDescriptor {
        label: Some("test.texture"),
        size: wgpu::Extent3d {
            width: 16,
            height: 16,
            depth_or_array_layers: 1,
        },
        mip_level_count: 2,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::STORAGE_BINDING,
        view_formats: &[],
    });
    let report = ctx.memory();
    eprintln!("{report}");
    assert_eq!(report.bytes("test.a"), 1024);
    assert_eq!(report.bytes("test.b"), 512);
    // 16x16 + 8x8 texels of 8 bytes.
    assert_eq!(report.bytes("test.texture"), (256 + 64) * 8);
    assert_eq!(report.total_bytes(), 1024 + 512 + 2560);
    assert_eq!(report.bytes_with_prefix("test.b"), 512);

    assert!(ctx.release_buffer(&a));
    assert!(
        !ctx.release_buffer(&a),
        "a released buffer is no longer tracked"
    );
    assert_eq!(ctx.memory().bytes("test.a"), 0);

    {
        let _timer = GpuTimer::new(&ctx, "test.timer", 8);
        let with_timer = ctx.memory().bytes("test.timer.timestamps");
        assert!(ctx.supports_timestamps() == (with_timer == 8 * 2 * 8));
        let readback = ctx.memory().bytes("test.timer.timestamps_readback");
        assert!(
            ctx.supports_timestamps() == (readback == FRAMES_IN_FLIGHT as u64 * 8 * 2 * 8),
            "{readback} bytes of readback"
        );
    }
    assert_eq!(
        ctx.memory().bytes_with_prefix("test.timer.timestamps"),
        0,
        "the timer releases its own"
    );

    assert_eq!(ctx.release_labeled("test."), 3);
    assert_eq!(ctx.memory().total_bytes(), 0);
}

#[test]
fn reading_a_buffer_without_copy_src_is_an_error() {
    let Some(ctx) = GpuContext::new_or_skip("reading_a_buffer_without_copy_src_is_an_error") else {
        return;
    };
    let buffer = ctx.create_buffer("test.no_copy", 64, wgpu::BufferUsages::STORAGE);
    let err = ctx.try_read_buffer::<u32>(&buffer).unwrap_err();
    assert!(matches!(err, GpuError::Readback(_)), "{err}");
}

#[test]
fn options_reject_unknown_adapters_and_unmet_limits() {
    let err = GpuContext::with_options(&GpuOptions {
        adapter_name: Some("no such adapter".into()),
        ..GpuOptions::default()
    })
    .err()
    .expect("no adapter is called that");
    assert!(matches!(err, GpuError::NoAdapter { .. }), "{err}");
    assert!(err.to_string().contains("mesa-vulkan-drivers"), "{err}");

    if GpuContext::new_or_skip("options_reject_unknown_adapters_and_unmet_limits").is_none() {
        return;
    }
    let err = GpuContext::with_options(&GpuOptions {
        required_limits: wgpu::Limits {
            max_storage_buffer_binding_size: u64::MAX,
            ..wgpu::Limits::default()
        },
        ..GpuOptions::default()
    })
    .err()
    .expect("no adapter binds 16 EiB");
    assert!(
        matches!(
            err,
            GpuError::LimitTooSmall {
                limit: "max_storage_buffer_binding_size",
                needed: u64::MAX,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn contexts_share_one_device_and_keep_their_own_memory_accounts() {
    let Some(auto) =
        GpuContext::new_or_skip("contexts_share_one_device_and_keep_their_own_memory_accounts")
    else {
        return;
    };
    // By default hardware adapters share a device and software ones (lavapipe) do not.
    let hardware = auto.adapter_info.device_type != wgpu::DeviceType::Cpu;
    assert_eq!(
        auto.shares_device_with(&GpuContext::new().unwrap()),
        hardware
    );

    let shared = GpuOptions {
        sharing: DeviceSharing::Shared,
        ..GpuOptions::from_env()
    };
    let first = GpuContext::with_options(&shared).unwrap();
    let second = GpuContext::with_options(&shared).unwrap();
    let options = shared.clone();
    let from_thread = std::thread::spawn(move || GpuContext::with_options(&options))
        .join()
        .unwrap()
        .unwrap();
    assert!(first.shares_device_with(&second));
    assert!(first.shares_device_with(&from_thread));
    assert_eq!(auto.shares_device_with(&first), hardware);

    let buffer = first.create_buffer("test.own", 4096, wgpu::BufferUsages::STORAGE);
    assert_eq!(first.memory().bytes_with_prefix("test.own"), 4096);
    assert_eq!(second.memory().total_bytes(), 0, "another context's buffer");
    assert!(
        !second.release_buffer(&buffer),
        "not the second context's to release"
    );
    assert!(first.release_buffer(&buffer));

    // Options that change the device get a device of their own; `Dedicated` always does.
    let without_timestamps = GpuContext::with_options(&GpuOptions {
        optional_features: wgpu::Features::empty(),
        ..shared.clone()
    })
    .unwrap();
    assert!(!without_timestamps.shares_device_with(&first));
    assert!(!without_timestamps.supports_timestamps());
    let dedicated = GpuContext::with_options(&GpuOptions {
        sharing: DeviceSharing::Dedicated,
        ..shared
    })
    .unwrap();
    assert!(!dedicated.shares_device_with(&first));
    assert_doubles(&dedicated);
    assert_doubles(&second);
}

#[test]
fn a_destroyed_shared_device_is_replaced_by_the_next_context() {
    if GpuContext::new_or_skip("a_destroyed_shared_device_is_replaced_by_the_next_context")
        .is_none()
    {
        return;
    }
    // Options no other test uses, so destroying their device disturbs no other test.
    let options = GpuOptions {
        optional_features: wgpu::Features::TIMESTAMP_QUERY,
        sharing: DeviceSharing::Shared,
        ..GpuOptions::from_env()
    };
    let lost = GpuContext::with_options(&options).unwrap();
    assert!(
        GpuContext::with_options(&options)
            .unwrap()
            .shares_device_with(&lost)
    );
    lost.device.destroy();
    // The device-lost callback runs when the device is polled.
    let _ = lost.device.poll(wgpu::PollType::wait_indefinitely());
    let next = GpuContext::with_options(&options).unwrap();
    assert!(!next.shares_device_with(&lost));
    assert_doubles(&next);
    assert!(
        GpuContext::with_options(&options)
            .unwrap()
            .shares_device_with(&next)
    );
}

#[test]
fn a_context_renders_on_a_device_the_caller_opened() {
    if GpuContext::new_or_skip("a_context_renders_on_a_device_the_caller_opened").is_none() {
        return;
    }
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
    });
    let adapter =
        pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .unwrap();
    let (device, queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default())).unwrap();
    let ctx = GpuContext::from_device(&adapter, device.clone(), queue);
    assert!(!ctx.shares_device_with(&GpuContext::new().unwrap()));
    assert_eq!(ctx.limits, device.limits());
    assert_eq!(ctx.adapter_info.name, adapter.get_info().name);
    assert_doubles(&ctx);
}

#[test]
fn shared_packing_and_basis_functions_are_accurate() {
    let Some(ctx) = GpuContext::new_or_skip("shared_packing_and_basis_functions_are_accurate")
    else {
        return;
    };
    // A fixed pseudo-random batch: unit vectors in every octant (and the poles), colors over
    // nine orders of magnitude, depths (the colors' w) over seven and the sky's +inf.
    let mut state = 0x2545_f491_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32
    };
    let mut inputs: Vec<[f32; 4]> = vec![
        [0.0, 0.0, 1.0, 0.0],
        [1.0, 1.0, 1.0, f32::INFINITY],
        [0.0, 0.0, -1.0, 0.0],
        [0.5; 4],
    ];
    for i in 0..254 {
        let v = [2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0];
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
        inputs.push([v[0] / length, v[1] / length, v[2] / length, 0.0]);
        let scale = 10f32.powi(i % 9 - 4);
        let depth = (0.1 + next()) * 10f32.powi(i % 7 - 2);
        inputs.push([next() * scale, next() * scale, next() * scale, depth]);
    }
    let count = inputs.len() / 2;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input_buffer = ctx.create_buffer_init("test.inputs", bytemuck::cast_slice(&inputs), usage);
    let output_buffer = ctx.create_buffer("test.outputs", (count * 6 * 16) as u64, usage);
    let module = ShaderLibrary::new()
        .create_module(&ctx, "test/common_functions.wgsl", &[])
        .unwrap();
    let pipeline =
        ctx.create_compute_pipeline("test/common_functions", &module, "common_functions");
    let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("test/common_functions"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input_buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output_buffer.as_entire_binding(),
            },
        ],
    });
    let mut encoder = ctx.create_encoder("test/common_functions");
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("test/common_functions"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(count.div_ceil(64) as u32, 1, 1);
    }
    ctx.submit_and_wait(encoder);
    let outputs: Vec<[f32; 4]> = ctx.read_buffer(&output_buffer);

    let mut worst_normal = 0f32;
    let mut worst_color = 0f32;
    let mut worst_normal8 = 0f32;
    let mut worst_depth = 0f32;
    let mut worst_history = 0f32;
    let mut worst_variance = 0f32;
    let mut worst_dither = 0f32;
    let distance =
        |a: [f32; 4], b: [f32; 4]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f32>().sqrt();
    for i in 0..count {
        let (n, color) = (inputs[2 * i], inputs[2 * i + 1]);
        let [n_out, color_out, basis, geometry, history, age] =
            [0, 1, 2, 3, 4, 5].map(|k| outputs[6 * i + k]);
        worst_normal = worst_normal.max(distance(n, n_out));
        worst_normal8 = worst_normal8.max(distance(n, geometry));
        let depth = color[3];
        if depth.is_finite() {
            worst_depth = worst_depth.max((geometry[3] - depth).abs() / depth);
        } else {
            assert_eq!(geometry[3], f32::INFINITY, "input {i}: the sky's depth");
        }
        let max_channel = color[0].max(color[1]).max(color[2]);
        for k in 0..3 {
            // Nine mantissa bits relative to the largest channel, after rounding.
            let relative = (color[k] - color_out[k]).abs() / max_channel;
            worst_color = worst_color.max(relative);
            // Fourteen for the long history.
            worst_history = worst_history.max((color[k] - history[k]).abs() / max_channel);
            // Dithered RGB9E5 is the value on average: over 64 evenly spaced offsets within
            // 1/128 of a step (a step is at most 2^-8 of the largest channel).
            worst_dither = worst_dither.max((color[k] - age[1 + k]).abs() / max_channel);
        }
        // The variance (here the depth, +inf clamped to the largest f16) to 2^-6 of itself,
        // the age exact (clamped to 127).
        let variance = depth.min(65504.0);
        worst_variance = worst_variance.max((history[3] - variance).abs() / variance);
        assert_eq!(
            age[0],
            (i % 131).min(127) as f32,
            "input {i}: the history's age"
        );
        for (k, value) in basis[..3].iter().enumerate() {
            assert!(value.abs() < 1e-5, "input {i}: basis dot {k} = {value}");
        }
        assert!(
            (basis[3] - 1.0).abs() < 1e-5,
            "input {i}: basis determinant {}",
            basis[3]
        );
    }
    eprintln!(
        "worst unit-vector error {worst_normal:e}, worst relative color error {worst_color:e}, \
         worst 8-bit normal error {worst_normal8:e}, worst relative depth error {worst_depth:e}, \
         worst relative history color error {worst_history:e}, worst relative variance error \
         {worst_variance:e}, worst relative error of the dithered RGB9E5 mean {worst_dither:e}"
    );
    assert!(worst_normal < 1e-4, "unit vectors: {worst_normal}");
    assert!(worst_color <= 1.0 / 512.0, "colors: {worst_color}");
    // Under a degree (a chord of 2 sin(0.5 degree)); an f16 rounds to 2^-11 of itself.
    assert!(
        worst_normal8 < 2.0 * 0.5f32.to_radians().sin(),
        "8-bit normals: {worst_normal8}"
    );
    assert!(worst_depth <= 1.0 / 2048.0, "depths: {worst_depth}");
    assert!(
        worst_history <= 1.0 / 16384.0,
        "history colors: {worst_history}"
    );
    assert!(
        worst_variance <= 1.0 / 64.0,
        "history variances: {worst_variance}"
    );
    assert!(
        worst_dither <= 1.0 / (256.0 * 128.0) + 1e-6,
        "dithered RGB9E5 means: {worst_dither}"
    );
}

/// The median of `values` (the mean of the middle two for an even count).
fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    assert!(n > 0, "no values");
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

//! The mobile tier: its shared structs, the lite G-buffer encoding, and whole frames on small
//! scenes (irradiance under a known sky, dynamic history, probe scheduling, quality against
//! the reference).

mod common;

use common::{
    add_sun, check_glass_blends, check_occlusion_scaling, ground_behind_glass, open_ground,
    settings, sunlit_wall, with_occlusion,
};
use gi_gpu::{GpuContext, ShaderLibrary, rust_field_offsets, wgpu, wgsl_struct_layout};
use gi_image::Image;
use gi_reference::{Mode, Reference, RenderSettings};
use gi_scene::{CameraView, Scene};
use gi_tiers::mobile::{
    GpuScreenProbe, MobileConfig, MobileFrameData, ScreenConfig, ScreenUniforms,
};
use gi_tiers::{FrameInput, MobileTier, Tier, TierError};
use glam::Vec3;
use rand::Rng as _;
use rand_pcg::Pcg32;

/// Renders `frames` frames of `scene` at time `time(i)` through `camera` and returns the tier.
fn run(
    ctx: GpuContext,
    scene: &Scene,
    config: MobileConfig,
    size: (u32, u32),
    frames: u32,
    camera: Option<CameraView>,
) -> (MobileTier, gi_tiers::FrameOutput) {
    let mut tier = MobileTier::new(settings(size.0, size.1), config, ctx).unwrap();
    let mut last = None;
    for index in 0..frames {
        let frame = scene.evaluate(scene.frame_time(index), camera);
        last = Some(
            tier.render(&FrameInput {
                scene,
                frame: &frame,
                index,
                progress: None,
            })
            .unwrap(),
        );
    }
    (tier, last.expect("at least one frame"))
}

/// Frame data of the frames after a still warm-up: `warmup` frames of `scene` seen by `camera`,
/// then one frame of each of `then`, in order; `None` without an adapter.
fn frames_after_warmup(
    name: &str,
    scene: &Scene,
    then: &[&Scene],
    config: MobileConfig,
    size: (u32, u32),
    warmup: u32,
    camera: CameraView,
) -> Option<Vec<MobileFrameData>> {
    let ctx = GpuContext::new_or_skip(name)?;
    let (mut tier, _) = run(ctx, scene, config, size, warmup, Some(camera));
    let mut data = Vec::with_capacity(then.len());
    for (index, scene) in (warmup..).zip(then) {
        let frame = scene.evaluate(0.0, Some(camera));
        tier.render(&FrameInput {
            scene,
            frame: &frame,
            index,
            progress: None,
        })
        .unwrap();
        data.push(tier.frame_data().unwrap());
    }
    Some(data)
}

/// The default configuration with the brick cache's lighting cut to a trickle, for tests whose
/// checks do not depend on the cache's light: an open ground under the sky (the probe rays
/// meet the sky, not the cache), probe scheduling, history rejection, finite output and
/// memory. Settling would relight 1536 young bricks more per frame for the first frames, and
/// the round-robin 512 a frame, most of the software adapter's time; 16 bricks a frame keep
/// every lighting pass running. Measured with the default budgets and with these: mean
/// irradiance 3.1115 and 3.1107 in `open_ground_gathers_pi_times_the_sky` (bound 0.04; the
/// ground's bounced light in the volume is all that changes), the same 311
/// revealed samples and 8677 of 8677 static samples keeping their history in
/// `history_of_dynamic_pixels_is_discarded`.
fn idle_cache() -> MobileConfig {
    let mut config = MobileConfig::default();
    config.cache.settle_bricks_per_frame = 0;
    config.cache.light_bricks_per_frame = 16;
    config
}

#[test]
fn shared_structs_match_their_wgsl_layout() {
    let module = ShaderLibrary::new()
        .compose("mobile/screen/shared.wgsl", &[])
        .unwrap();
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(wgsl.members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "ScreenUniforms",
        rust_field_offsets!(ScreenUniforms {
            camera,
            previous_camera,
            sky,
            size_px,
            half_px,
            tiles,
            tile_px,
            frame_index,
            seed,
            max_age,
            history_valid,
            plane_tolerance,
            normal_cos,
            ray_offset_voxels,
            flags,
            change_gain,
            pad_a,
            pad_b,
            pad_c,
        }),
        size_of::<ScreenUniforms>(),
    );
    check(
        "ScreenProbe",
        rust_field_offsets!(GpuScreenProbe {
            position,
            depth,
            normal,
            flags
        }),
        size_of::<GpuScreenProbe>(),
    );
}

// ---------------------------------------------------------------------------------------------
// The lite G-buffer encoding.
// ---------------------------------------------------------------------------------------------

/// A compute shader that encodes case `i` (normal, ray, albedo, dynamic) with each of the
/// 16 x 16 stratified dithers and writes every decoded normal, and the decoded albedo and mask
/// of the first.
const LITE_TEST: &str = r#"
#import gi::camera::Camera
#import gi::mobile::lite::{lite_encode, lite_diffuse, lite_is_dynamic, lite_normal}

struct Case {
    normal: vec4<f32>,
    ray: vec4<f32>,
    albedo: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> camera: Camera;
@group(0) @binding(1) var<storage, read> cases: array<Case>;
@group(0) @binding(2) var<storage, read_write> decoded: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> albedo: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let case_index = id.x / 256u;
    if case_index >= arrayLength(&cases) {
        return;
    }
    let d = id.x % 256u;
    let dither = (vec2<f32>(f32(d % 16u), f32(d / 16u)) + 0.5) / 16.0 - 0.5;
    let c = cases[case_index];
    let bits = lite_encode(c.albedo.xyz, c.albedo.w > 0.5, c.normal.xyz, camera, c.ray.xyz, dither);
    decoded[id.x] = vec4(lite_normal(bits, camera, c.ray.xyz), 0.0);
    if d == 0u {
        albedo[case_index] = vec4(lite_diffuse(bits), select(0.0, 1.0, lite_is_dynamic(bits)));
    }
}
"#;

/// Seeded random numbers for test inputs.
struct Rng(Pcg32);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(Pcg32::new(seed, 0x0a02_bdbf_7bb3_c0a7))
    }

    fn next_f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next_f32(), self.next_f32(), self.next_f32()) * 2.0 - 1.0;
            if (0.01..1.0).contains(&v.length_squared()) {
                return v.normalize();
            }
        }
    }
}

#[test]
fn lite_gbuffer_keeps_albedo_mask_and_an_unbiased_normal() {
    let Some(ctx) =
        GpuContext::new_or_skip("lite_gbuffer_keeps_albedo_mask_and_an_unbiased_normal")
    else {
        return;
    };
    let view = CameraView::look_at(Vec3::new(0.3, 1.2, 4.0), Vec3::ZERO, 1.0);
    let camera = gi_gpu::GpuCamera::new(&view, (64, 48));
    let mut rng = Rng::new(11);
    // Cases: a ray through a random point of the image, a normal facing back along it at least
    // 0.3 away from the horizon (|the hemisphere map's coordinates| <= 0.83, more than a cell
    // from the square's border, where clamping would bias the dither).
    let mut cases = Vec::new();
    let mut expected = Vec::new();
    while cases.len() < 400 {
        let ray = { view.ray_direction(rng.next_f32(), rng.next_f32(), 64.0 / 48.0) };
        let n = rng.unit();
        if n.dot(-ray) < 0.3 {
            continue;
        }
        let albedo = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let dynamic = cases.len() % 3 == 0;
        cases.push([
            n.extend(0.0).to_array(),
            ray.extend(0.0).to_array(),
            albedo.extend(if dynamic { 1.0 } else { 0.0 }).to_array(),
        ]);
        expected.push((n, albedo, dynamic));
    }
    let shaders = ShaderLibrary::new().with_source("test/lite.wgsl", LITE_TEST);
    let module = shaders.create_module(&ctx, "test/lite.wgsl", &[]).unwrap();
    let pipeline = ctx.create_compute_pipeline("test/lite", &module, "main");
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let camera_buffer = ctx.create_buffer_init("test.camera", bytemuck::bytes_of(&camera), storage);
    let case_buffer = ctx.create_buffer_init("test.cases", bytemuck::cast_slice(&cases), storage);
    let decoded = ctx.create_buffer("test.decoded", cases.len() as u64 * 256 * 16, storage);
    let albedo = ctx.create_buffer("test.albedo", cases.len() as u64 * 16, storage);
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &gi_gpu::binding::buffer_entries(
            0,
            [&camera_buffer, &case_buffer, &decoded, &albedo],
        ),
    });
    let mut encoder = ctx.create_encoder("test.lite");
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((cases.len() as u32 * 256).div_ceil(64), 1, 1);
    }
    ctx.submit_and_wait(encoder);
    let decoded: Vec<[f32; 4]> = ctx.read_buffer(&decoded);
    let albedo: Vec<[f32; 4]> = ctx.read_buffer(&albedo);

    // One decode: the center of the dithered cell lies less than one cell (2/16 of the square)
    // from the exact point along each axis, so within 0.125 of it in the diamond (the square's
    // axes are the diamond's diagonals). The map P = (x, y, 1 - |x| - |y|) -> P / |P| stretches
    // lengths by at most |dP| / |P| <= sqrt(3) / (1 / sqrt(3)) = 3 (at the octant's center,
    // where dP = (a, b, -a - b) is tangent): at most 0.375 rad.
    let single_bound = 0.125f32 * 3.0;
    // The mean over the 16 x 16 stratified dithers: the dither is unbiased up to its 1/16-cell
    // strata (single_bound / 16) and the decode's curvature adds a second-order term of at
    // most single_bound^2 / 2.
    let mean_bound = single_bound / 16.0 + single_bound * single_bound / 2.0;
    let (mut worst_single, mut worst_mean) = (0f32, 0f32);
    for (i, &(n, a, dynamic)) in expected.iter().enumerate() {
        let mut sum = Vec3::ZERO;
        for d in &decoded[i * 256..(i + 1) * 256] {
            let v = Vec3::from_slice(d);
            worst_single = worst_single.max(v.angle_between(n));
            sum += v;
        }
        worst_mean = worst_mean.max(sum.normalize().angle_between(n));
        // Albedo: sqrt-encoded with 8 (7 for blue) bits: |error| <= (2 sqrt(a) + 1/255) / 255.
        let got = Vec3::from_slice(&albedo[i]);
        for (c, (g, e)) in got.to_array().into_iter().zip(a.to_array()).enumerate() {
            let steps = if c == 2 { 127.0 } else { 255.0 };
            let bound = (e.sqrt() + 0.5 / steps) / steps + 1e-6;
            assert!((g - e).abs() <= bound, "case {i} channel {c}: {g} vs {e}");
        }
        assert_eq!(albedo[i][3] > 0.5, dynamic, "case {i}: dynamic mask");
    }
    println!(
        "lite normals: worst single decode {:.2} deg (bound {:.2}), worst dithered mean {:.2} deg \
         (bound {:.2})",
        worst_single.to_degrees(),
        single_bound.to_degrees(),
        worst_mean.to_degrees(),
        mean_bound.to_degrees()
    );
    assert!(worst_single <= single_bound, "{worst_single}");
    assert!(worst_mean <= mean_bound, "{worst_mean}");
}

// ---------------------------------------------------------------------------------------------
// Whole frames.
// ---------------------------------------------------------------------------------------------

/// A scene of one grey ground quad (`half_m` on each side of the origin) under a constant sky
/// of radiance 1, with no light: every point of the ground receives exactly pi.

#[test]
fn open_ground_gathers_pi_times_the_sky() {
    let Some(ctx) = GpuContext::new_or_skip("open_ground_gathers_pi_times_the_sky") else {
        return;
    };
    let scene = open_ground("mobile-open-ground", 20.0, 0.5);
    let camera = CameraView::look_at(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, 0.9);
    let config = MobileConfig {
        screen: ScreenConfig {
            tile_px: 8,
            ..ScreenConfig::default()
        },
        ..idle_cache()
    };
    let (tier, _) = run(ctx, &scene, config, (64, 48), 24, Some(camera));
    let data = tier.frame_data().unwrap();
    // Every probe ray sees the sky (the only surface is the ground the probes sit on), so the
    // exact irradiance is pi. (The estimate runs about 1% low here, 3.5 of its standard errors
    // in the measured run: a probe's hemisphere follows its own lite-decoded normal, and where
    // that differs from the pixel's decoded normal by theta the pixel misses (1 - cos theta) / 2
    // of a uniform sky.) The estimate's noise: the per-tile means of the 8 x 8-pixel tiles
    // (each tile's probes are independent of the others'), their spread over sqrt(tiles).
    let mut tile_means = Vec::new();
    for ty in 0..6 {
        for tx in 0..8 {
            let mut sum = 0.0;
            let mut count = 0;
            for y in ty * 8..ty * 8 + 8 {
                for x in tx * 8..tx * 8 + 8 {
                    let i = y * 64 + x;
                    if data.depth[i].is_finite() {
                        sum += f64::from(data.irradiance.pixels[i].y);
                        count += 1;
                    }
                }
            }
            if count == 64 {
                tile_means.push(sum / 64.0);
            }
        }
    }
    let n = tile_means.len() as f64;
    assert!(n >= 24.0, "only {n} tiles see the ground");
    let mean = tile_means.iter().sum::<f64>() / n;
    let spread = (tile_means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let standard_error = spread / n.sqrt();
    // The noise bound: four standard errors; RGB9E5 rounds the stored irradiance to 9 mantissa
    // bits on top. The bias is bounded apart, and only downwards: a probe's hemisphere tilted
    // from the pixel's loses sky and gains ground, which is darker, so the estimate can only
    // fall short, here by at most 1.5% of pi (it measured 1.0%).
    let pi = std::f64::consts::PI;
    let noise = 4.0 * standard_error + pi * 2f64.powi(-9);
    let bias = 0.015 * pi;
    println!(
        "open ground: mean irradiance {mean:.4} (pi = {pi:.4}, {:.2}% low), tile spread \
         {spread:.4}, noise bound {noise:.4}, bias bound {bias:.4}",
        100.0 * (1.0 - mean / pi)
    );
    assert!(mean <= pi + noise, "{mean}: above pi beyond the noise");
    assert!(
        mean >= pi - bias - noise,
        "{mean}: below pi beyond the bias and the noise"
    );
}

#[test]
fn the_occlusion_map_darkens_the_gathered_diffuse_light_only_when_asked() {
    let Some(ctx) = GpuContext::new_or_skip(
        "the_occlusion_map_darkens_the_gathered_diffuse_light_only_when_asked",
    ) else {
        return;
    };
    drop(ctx);
    let camera = CameraView::look_at(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, 0.9);
    // The same seed draws the same probe rays, so the frames differ only in the occlusion
    // factor compose applies.
    let gi = |scene: &Scene, material_occlusion: bool| {
        let mut config = idle_cache();
        config.screen.material_occlusion = material_occlusion;
        let (tier, _) = run(
            GpuContext::new().unwrap(),
            scene,
            config,
            (64, 48),
            4,
            Some(camera),
        );
        tier.frame_data().unwrap().gi
    };
    let ground = open_ground("mobile-occluded-ground", 20.0, 0.5);
    let plain = gi(&ground, true);
    let plain_again = gi(&ground, true);
    let quarter = gi(&with_occlusion(ground.clone(), 0.0, 0.75), true);
    // Off (the default), the map changes nothing.
    assert_eq!(
        gi(&with_occlusion(ground.clone(), 0.0, 0.75), false).pixels,
        plain.pixels
    );
    let half = gi(&with_occlusion(ground, 0.0, 0.5), true);
    let lit = check_occlusion_scaling(&plain, &plain_again, [(&quarter, 0.25), (&half, 0.5)]);
    assert!(lit > 64 * 48 / 3, "only {lit} pixels see the ground");
}

#[test]
fn blended_glass_is_composited_over_the_gi_behind_it() {
    let Some(ctx) = GpuContext::new_or_skip("blended_glass_is_composited_over_the_gi_behind_it")
    else {
        return;
    };
    drop(ctx);
    let camera = CameraView::look_at(Vec3::new(0.0, 3.0, 3.0), Vec3::ZERO, 0.9);
    // The GI term and the direct light (the image less the GI) of the last frame.
    let render = |alpha: f32| {
        let (scene, first) = ground_behind_glass(&camera, alpha);
        let (tier, last) = run(
            GpuContext::new().unwrap(),
            &scene,
            idle_cache(),
            (64, 48),
            4,
            Some(camera),
        );
        let gi = tier.frame_data().unwrap().gi;
        let direct = Image {
            width: gi.width,
            height: gi.height,
            pixels: last
                .image
                .pixels
                .iter()
                .zip(&gi.pixels)
                .map(|(o, g)| *o - *g)
                .collect(),
        };
        (scene, first, gi, direct)
    };
    let (_, _, clear_gi, clear_direct) = render(0.0);
    let (scene, first, gi, direct) = render(0.5);
    check_glass_blends(&scene, first, &camera, ("GI", &gi, &clear_gi));
    check_glass_blends(
        &scene,
        first,
        &camera,
        ("direct light", &direct, &clear_direct),
    );
}

/// Pixels of the half-resolution samples (even coordinates) of a `width` x `height` image.
fn half_samples(width: usize, height: usize) -> impl Iterator<Item = usize> {
    (0..height)
        .step_by(2)
        .flat_map(move |y| (0..width).step_by(2).map(move |x| y * width + x))
}

#[test]
fn history_of_dynamic_pixels_is_discarded() {
    let Some(ctx) = GpuContext::new_or_skip("history_of_dynamic_pixels_is_discarded") else {
        return;
    };
    let scene = gi_scene::load("dynamic").unwrap();
    let (width, height) = (96usize, 64usize);
    let mut tier =
        MobileTier::new(settings(width as u32, height as u32), idle_cache(), ctx).unwrap();
    let mut previous: Option<MobileFrameData> = None;
    let (mut revealed, mut static_kept, mut static_total) = (0, 0, 0);
    // Frames 0.2 s apart: the objects move several pixels per frame.
    for index in 0..16u32 {
        let frame = scene.evaluate(index as f32 * 0.2, None);
        tier.render(&FrameInput {
            scene: &scene,
            frame: &frame,
            index,
            progress: None,
        })
        .unwrap();
        let data = tier.frame_data().unwrap();
        if let Some(before) = &previous {
            for i in half_samples(width, height) {
                if !data.depth[i].is_finite() || data.dynamic[i] {
                    continue;
                }
                // The camera holds still: a pixel's history is its own previous sample.
                if before.dynamic[i] {
                    revealed += 1;
                    assert_eq!(
                        data.history_age[i], 1,
                        "frame {index}: pixel {i} kept the history of the object that left it"
                    );
                } else if index >= 10 {
                    static_total += 1;
                    if data.history_age[i] > 1 {
                        static_kept += 1;
                    }
                }
            }
        }
        previous = Some(data);
    }
    println!(
        "revealed samples {revealed}; static samples keeping history {static_kept}/{static_total}"
    );
    assert!(
        revealed > 0,
        "no object moved off a pixel: the test saw nothing"
    );
    // Static pixels keep their history once the cache's first fill (which resets it) is over.
    assert!(
        static_kept * 10 >= static_total * 9,
        "{static_kept}/{static_total}"
    );
}

/// The gather's temporal history follows the brick cache's measured change: in a still view no
/// sample's history shortens, and when the sun of a [`sunlit_wall`] goes out the samples whose
/// surface's voxels measured the change restart it, where with the cache's change gain at 0
/// they keep it (and the cache's lag with it). The wall's voxels measure it in the change's
/// frame (`cache/inject_all`); the ground's only when their brick is relit, which for the
/// far ground's many level-0 bricks takes longer than the budget of that frame: a quarter of
/// the long histories at least restart (measured 648 of 1460).
#[test]
fn the_gather_restarts_its_history_where_the_cache_measured_a_change() {
    let (width, height) = (48usize, 36usize);
    let camera = CameraView::look_at(Vec3::new(-2.0, 2.0, 0.0), Vec3::new(1.0, 0.5, 0.0), 1.0);
    let scene = sunlit_wall("mobile-measured-change");
    let mut dark = scene.clone();
    dark.lights[0].intensity = 0.0;
    let mut restarted = Vec::new();
    for gain in [3.0, 0.0] {
        let mut config = MobileConfig::default();
        config.cache.change_gain = gain;
        let max_age = config.screen.max_age;
        let Some(data) = frames_after_warmup(
            "the_gather_restarts_its_history",
            &scene,
            &[&scene, &scene, &dark],
            config,
            (width as u32, height as u32),
            40,
            camera,
        ) else {
            return;
        };
        let [before, still, after] = &data[..] else {
            unreachable!("three frames asked for")
        };
        let (mut old, mut restart) = (0, 0);
        for i in 0..width * height {
            // Age 0: the half-resolution sample nearest the pixel shows the sky.
            if before.history_age[i] == 0 {
                continue;
            }
            let grown = (before.history_age[i] + 1).min(max_age as u8);
            assert!(
                still.history_age[i] >= grown,
                "gain {gain}: pixel {i}'s history shortened in a still view: {} -> {}",
                before.history_age[i],
                still.history_age[i]
            );
            if still.history_age[i] >= 16 {
                old += 1;
                restart += usize::from(after.history_age[i] <= 2);
            }
        }
        println!("gain {gain}: {restart} of {old} samples with a long history restarted");
        assert!(
            old * 4 >= width * height,
            "{old} samples with a long history"
        );
        restarted.push(restart as f32 / old as f32);
    }
    assert!(restarted[0] >= 0.25, "{restarted:?}");
    assert_eq!(restarted[1], 0.0, "{restarted:?}");
}

/// The gather's history also restarts where the light its probes find changed while the
/// surface's own light did not: a ground lit from straight above by a strong sun, which sees a
/// wall lit by a second sun off screen. When the wall's sun goes out the ground's own
/// irradiance, which the cache measures, changes by under 4% (the wall's bounce against the
/// overhead sun's 30), below the cache's smallest step of change, so only the probes' rays,
/// which meet the darkened wall, see it.
#[test]
fn the_gather_restarts_its_history_where_the_light_its_probes_find_changed() {
    let (width, height) = (48usize, 36usize);
    // Looking down at the ground beside the wall, which is out of view.
    let camera = CameraView::look_at(Vec3::new(-0.5, 3.0, 0.0), Vec3::ZERO, 0.6);
    let mut scene = sunlit_wall("mobile-probe-change");
    add_sun(
        &mut scene,
        glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
    );
    scene.lights[1].intensity = 30.0;
    let mut dark = scene.clone();
    dark.lights[0].intensity = 0.0;
    let mut restarted = Vec::new();
    for gain in [3.0, 0.0] {
        let mut config = MobileConfig::default();
        config.cache.change_gain = gain;
        // 3 x 3 tiles: every pixel has probes around it.
        config.screen.tile_px = 16;
        let Some(data) = frames_after_warmup(
            "the_gather_restarts_its_history_where_the_light",
            &scene,
            &[&scene, &dark],
            config,
            (width as u32, height as u32),
            40,
            camera,
        ) else {
            return;
        };
        let [before, after] = &data[..] else {
            unreachable!("two frames asked for")
        };
        // The pixels the wall lights: a tenth of the brightest irradiance or more.
        let lum = |i: usize| before.irradiance.pixels[i].dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let brightest = (0..width * height).map(lum).fold(0.0f32, f32::max);
        let (mut lit, mut restart) = (0, 0);
        for i in 0..width * height {
            if before.history_age[i] >= 16 && lum(i) >= 0.1 * brightest {
                lit += 1;
                restart += usize::from(after.history_age[i] <= 2);
            }
        }
        println!("gain {gain}: {restart} of {lit} lit samples with a long history restarted");
        assert!(
            lit * 4 >= width * height,
            "{lit} lit samples with a long history"
        );
        restarted.push(restart as f32 / lit as f32);
    }
    // Every lit sample's probes meet the wall and nothing else that emits or reflects.
    assert!(restarted[0] >= 0.9, "{restarted:?}");
    assert_eq!(restarted[1], 0.0, "{restarted:?}");
}

#[test]
fn smartgi_mode_traces_one_probe_per_group_and_reprojects_the_rest() {
    let Some(ctx) =
        GpuContext::new_or_skip("smartgi_mode_traces_one_probe_per_group_and_reprojects_the_rest")
    else {
        return;
    };
    // The camera sees nothing but ground, so every fresh probe finds a surface.
    let scene = open_ground("mobile-open-ground", 20.0, 0.5);
    let camera = Some(CameraView::look_at(
        Vec3::new(0.0, 3.0, 1.0),
        Vec3::ZERO,
        0.9,
    ));
    // 64 x 48 pixels in 16-pixel tiles: 4 x 3 tiles in 2 x 2 groups (2 x 2 groups, the lower
    // ones half full).
    let config = MobileConfig {
        screen: ScreenConfig::smartgi(),
        ..idle_cache()
    };
    let (tier, _) = run(ctx, &scene, config, (64, 48), 16, camera);
    let counts = tier.frame_data().unwrap().probes;
    println!("smartgi probe slots: {counts:?}");
    assert_eq!(counts.fresh + counts.reprojected + counts.empty, 12);
    assert_eq!(counts.fresh, 4, "one fresh probe per group");
    // Still camera, after the cache's first fill (which drops history): every history probe
    // lands back in its own tile and claims it.
    assert_eq!((counts.reprojected, counts.empty), (8, 0), "{counts:?}");

    let config = MobileConfig {
        screen: ScreenConfig {
            tile_px: 16,
            ..ScreenConfig::default()
        },
        ..idle_cache()
    };
    let (tier, _) = run(
        GpuContext::new().unwrap(),
        &scene,
        config,
        (64, 48),
        3,
        camera,
    );
    let counts = tier.frame_data().unwrap().probes;
    assert_eq!((counts.fresh, counts.reprojected), (12, 0), "{counts:?}");
}

#[test]
fn every_bundled_scene_renders_finite_and_accounts_its_memory() {
    let Some(ctx) =
        GpuContext::new_or_skip("every_bundled_scene_renders_finite_and_accounts_its_memory")
    else {
        return;
    };
    drop(ctx);
    // The bundled scenes, and a skinned arm (the GPU skinning's buffers).
    let scenes = (gi_scene::BUNDLED_SCENES.iter())
        .map(|(name, _)| (*name, gi_scene::load(name).unwrap()))
        .chain([("skinned-arm", gi_scene::generate::skinned_arm())]);
    for (name, scene) in scenes {
        let ctx = GpuContext::new().unwrap();
        let (tier, output) = run(ctx, &scene, idle_cache(), (40, 30), 3, None);
        assert!(
            output
                .image
                .pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0),
            "{name}: non-finite or negative radiance"
        );
        let data = tier.frame_data().unwrap();
        assert!(
            data.gi.pixels.iter().all(|g| g.min_element() >= -1e-6),
            "{name}: negative GI"
        );
        for pass in [
            "gbuffer/primary",
            "mobile/lite",
            "mobile/volume",
            "mobile/probe_place",
            "mobile/probe_trace",
            "mobile/gather",
            "mobile/compose",
        ] {
            assert!(
                output.passes.iter().any(|(p, _)| p == pass),
                "{name}: no {pass} pass"
            );
        }
        // The parts are summed from the buffers' labels: every byte the tier owns is in one
        // of them (a buffer under a label none names would leave a gap).
        let memory = tier.memory();
        assert_eq!(
            memory.coverage_bytes + memory.screen_bytes + memory.frame_bytes,
            tier.memory_bytes(),
            "{name}: {:?}",
            tier.context().memory().by_label
        );
        assert!(
            memory.coverage_bytes > 20 << 20 && memory.screen_bytes > 0,
            "{memory:?}"
        );
    }
}

/// `Tier::advance` renders the frame `Tier::render` renders, only without reading the image
/// back: a tier advanced twice and then rendered shows the image of a tier rendered three
/// times, with the same passes.
#[test]
fn advancing_renders_the_same_frames_without_the_image() {
    let Some(ctx) = GpuContext::new_or_skip("advancing_renders_the_same_frames_without_the_image")
    else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let (_, rendered) = run(ctx, &scene, MobileConfig::default(), (40, 30), 3, None);
    let mut tier = MobileTier::new(
        settings(40, 30),
        MobileConfig::default(),
        GpuContext::new().unwrap(),
    )
    .unwrap();
    let frame = scene.evaluate(0.0, None);
    let input = |index| FrameInput {
        scene: &scene,
        frame: &frame,
        index,
        progress: None,
    };
    let mut advanced = Vec::new();
    for index in 0..2 {
        advanced.push(tier.advance(&input(index)).unwrap());
    }
    let last = tier.render(&input(2)).unwrap();
    let names =
        |passes: &[(String, f64)]| passes.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&advanced[1]), names(&last.passes));
    let worst = last
        .image
        .pixels
        .iter()
        .zip(&rendered.image.pixels)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(worst == 0.0, "images differ by up to {worst}");
}

#[test]
fn unusable_settings_are_refused_with_the_reason() {
    let Some(ctx) = GpuContext::new_or_skip("unusable_settings_are_refused_with_the_reason") else {
        return;
    };
    let bad_tile = MobileConfig {
        screen: ScreenConfig {
            tile_px: 4,
            ..ScreenConfig::default()
        },
        ..MobileConfig::default()
    };
    let message = match MobileTier::new(settings(64, 48), bad_tile, ctx) {
        Err(TierError::Unavailable { reason, .. }) => reason,
        Err(other) => panic!("{other}"),
        Ok(_) => panic!("a 4-pixel tile was accepted"),
    };
    assert!(message.contains("tile_px"), "{message}");
    let ctx = GpuContext::new().unwrap();
    assert!(MobileTier::new(settings(0, 48), MobileConfig::default(), ctx).is_err());
}

/// The issue's quality bar, at a size the software adapter renders in seconds: on the Cornell
/// box after a still warm-up of 63 frames, the mobile tier's error is at most 0.55 of the
/// direct-only image's, both against the CPU reference.
#[test]
fn cornell_box_meets_the_quality_bar() {
    let Some(ctx) = GpuContext::new_or_skip("cornell_box_meets_the_quality_bar") else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let (width, height) = (80, 60);
    let (_, output) = run(
        ctx,
        &scene,
        MobileConfig::default(),
        (width, height),
        64,
        None,
    );
    let frame = scene.evaluate(0.0, None);
    let reference = Reference::new(&scene, frame);
    let render = |mode: Mode, spp: u32, seed: u64| -> Image {
        let settings = RenderSettings {
            width,
            height,
            spp,
            seed,
            mode,
            ..RenderSettings::default()
        };
        reference.render(&settings, &|_| {}).unwrap().image
    };
    let truth = render(Mode::Full, 256, 1);
    let direct = render(Mode::Direct, 16, 2);
    let rmse = |image: &Image| gi_image::rmse_srgb8(image, &truth, scene.exposure).unwrap();
    let (mobile, baseline) = (rmse(&output.image), rmse(&direct));
    println!(
        "cornell-box {width}x{height}: mobile {mobile:.2}, direct {baseline:.2}, gain {:.3}",
        mobile / baseline
    );
    assert!(mobile <= 0.55 * baseline);
}

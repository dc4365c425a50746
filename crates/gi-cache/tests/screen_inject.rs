//! `cache/screen_inject`: voxels seen through are cleared, static visible surfaces never are,
//! and visible voxels take the G-buffer's materials.

use gi_cache::layout::{STATE_DYNAMIC, VoxelSurface, mask_cell};
use gi_cache::packing::unpack4x8unorm;
use gi_cache::{
    CacheConfig, CacheInputs, CacheUpdateStats, CpuCache, RadianceCache, ScreenInjectCounts,
    ScreenInputs,
};
use gi_gpu::{
    GBuffer, GBufferInputs, GpuContext, GpuScene, GpuTimer, Recorder, ShaderLibrary, Technique,
};
use gi_reference::brdf::Brdf;
use gi_scene::{Scene, SceneFrame};
use glam::{IVec3, Vec3};

const WIDTH: u32 = 80;
const HEIGHT: u32 = 60;

fn config() -> CacheConfig {
    CacheConfig {
        levels: 3,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    }
}

/// One cache update of `scene` at `frame` around `camera`, with the G-buffer of
/// `gbuffer_scene` at `gbuffer_frame` when given.
fn update(
    ctx: &GpuContext,
    cache: &mut RadianceCache,
    (scene, frame): (&Scene, &SceneFrame),
    camera: Vec3,
    gbuffer_of: Option<(&Scene, &SceneFrame)>,
) -> (CacheUpdateStats, ScreenInjectCounts) {
    let gpu_scene = GpuScene::upload(ctx, scene, frame).unwrap();
    let mut timer = GpuTimer::new(ctx, "screen inject test", 8);
    let mut rec = Recorder::new(ctx, &mut timer, "screen inject test");
    let mut gbuffer = None;
    let mut gbuffer_scene = None;
    if let Some((g_scene, g_frame)) = gbuffer_of {
        let uploaded = GpuScene::upload(ctx, g_scene, g_frame).unwrap();
        let mut g = GBuffer::new(ctx, &ShaderLibrary::new(), WIDTH, HEIGHT).unwrap();
        g.record(
            &mut rec,
            &GBufferInputs {
                frame: g_frame,
                scene: &uploaded,
                previous: g_frame,
            },
        );
        gbuffer = Some((g, g_frame.camera));
        gbuffer_scene = Some(uploaded);
    }
    let stats = cache
        .record(
            &mut rec,
            &CacheInputs {
                scene,
                frame,
                gpu_scene: &gpu_scene,
                camera_position: camera,
                gbuffer: gbuffer
                    .as_ref()
                    .map(|(g, view): &(GBuffer, _)| ScreenInputs::new(&g.outputs(), view)),
            },
        )
        .stats;
    let encoder = rec.into_encoder();
    let timings = timer.finish(ctx, encoder);
    if gbuffer.is_some() {
        assert!(timings.get("cache/screen_inject").is_some(), "{timings}");
    }
    eprintln!("{stats:?} {timings}");
    let counts = cache.screen_inject_counts(ctx);
    if let Some((g, _)) = gbuffer {
        g.release(ctx);
    }
    if let Some(s) = gbuffer_scene {
        s.release(ctx);
    }
    gpu_scene.release(ctx);
    (stats, counts)
}

/// Voxels occupied before and not after, split by the dynamic bit they had before:
/// `(static, dynamic, cleared voxels as (level, world voxel))`.
fn cleared(
    cache: &RadianceCache,
    masks_before: &[u64],
    masks_after: &[u64],
    voxels_before: &[VoxelSurface],
) -> (u32, u32, Vec<(u32, IVec3)>) {
    let (mut static_cleared, mut dynamic_cleared, mut list) = (0, 0, Vec::new());
    for b in cache.resident_bricks() {
        let id = b.brick_id as usize;
        let gone = masks_before[id] & !masks_after[id];
        for bit in (0..64).filter(|bit| gone >> bit & 1 == 1) {
            if voxels_before[id * 64 + bit].state & STATE_DYNAMIC != 0 {
                dynamic_cleared += 1;
            } else {
                static_cleared += 1;
            }
            list.push((b.level, b.brick * 4 + mask_cell(bit as u32).as_ivec3()));
        }
    }
    (static_cleared, dynamic_cleared, list)
}

#[test]
fn screen_inject_structs_match_their_wgsl_layout() {
    use gi_cache::screen_inject::{GpuScreenJob, ScreenInjectUniforms};
    use gi_gpu::{rust_field_offsets, wgsl_struct_layout};
    let module = ShaderLibrary::new()
        .compose("cache/screen_inject.wgsl", &[])
        .expect("cache/screen_inject.wgsl composes");
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(wgsl.members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "ScreenInjectUniforms",
        rust_field_offsets!(ScreenInjectUniforms {
            camera,
            size_px,
            job_count,
            pad
        }),
        size_of::<ScreenInjectUniforms>(),
    );
    check(
        "ScreenJob",
        rust_field_offsets!(GpuScreenJob {
            brick,
            level,
            brick_id,
            pad_a,
            pad_b,
            pad_c
        }),
        size_of::<GpuScreenJob>(),
    );
    assert_eq!(size_of::<ScreenInjectUniforms>(), 80);
    assert_eq!(size_of::<GpuScreenJob>(), 32);
}

#[test]
fn static_visible_surfaces_are_never_cleared() {
    let Some(ctx) = GpuContext::new_or_skip("static_visible_surfaces_are_never_cleared") else {
        return;
    };
    for name in ["cornell-box", "thin-wall"] {
        let scene = gi_scene::load(name).unwrap();
        let frame = scene.evaluate(0.0, None);
        let camera = frame.camera.position;
        let mut cache = RadianceCache::new(&ctx, &config()).unwrap();
        update(&ctx, &mut cache, (&scene, &frame), camera, None);
        let masks = cache.buffers().read_brick_masks(&ctx);
        let voxels = cache.buffers().read_voxels(&ctx);
        // Nothing is queued any more, so every visible brick is checked.
        let (stats, counts) = update(
            &ctx,
            &mut cache,
            (&scene, &frame),
            camera,
            Some((&scene, &frame)),
        );
        let after = cache.buffers().read_brick_masks(&ctx);
        let (static_cleared, dynamic_cleared, _) = cleared(&cache, &masks, &after, &voxels);
        eprintln!(
            "{name}: {} bricks checked, {} voxels cleared ({static_cleared} static), {} updated",
            stats.screen_injected, counts.cleared_voxels, counts.updated_voxels
        );
        assert!(stats.screen_injected > 0);
        assert_eq!(stats.voxelized, 0);
        assert_eq!(static_cleared + dynamic_cleared, 0, "{name}");
        assert_eq!(counts.cleared_voxels, 0, "{name}");
        assert!(counts.updated_voxels > 0, "{name}");
        cache.release_buffers(&ctx);
    }
}

#[test]
fn voxels_a_moving_object_left_are_cleared() {
    let Some(ctx) = GpuContext::new_or_skip("voxels_a_moving_object_left_are_cleared") else {
        return;
    };
    let scene = gi_scene::load("dynamic").unwrap();
    let config = config();
    let frame0 = scene.evaluate(0.0, None);
    let camera = frame0.camera.position;
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    update(&ctx, &mut cache, (&scene, &frame0), camera, None);
    let masks = cache.buffers().read_brick_masks(&ctx);
    let voxels = cache.buffers().read_voxels(&ctx);
    let dynamic_voxels = voxels
        .iter()
        .filter(|v| v.state & STATE_DYNAMIC != 0)
        .count();

    // The cache keeps t = 0 (its scene input stays frame 0, so nothing is re-voxelized);
    // the G-buffer shows the object elsewhere.
    let later = scene.evaluate(2.0, Some(frame0.camera));
    let (stats, counts) = update(
        &ctx,
        &mut cache,
        (&scene, &frame0),
        camera,
        Some((&scene, &later)),
    );
    assert_eq!(stats.voxelized, 0);
    let after = cache.buffers().read_brick_masks(&ctx);
    let (static_cleared, dynamic_cleared, list) = cleared(&cache, &masks, &after, &voxels);
    // No cleared voxel holds geometry at the later time.
    let fresh = CpuCache::build(&config, &scene, &later, camera).unwrap();
    let wrongly_cleared = list
        .iter()
        .filter(|(level, voxel)| fresh.voxel_at(*level, *voxel).is_some())
        .count();
    eprintln!(
        "dynamic: {} bricks checked; of {dynamic_voxels} dynamic voxels {dynamic_cleared} cleared; \
         {static_cleared} static cleared; {wrongly_cleared} cleared voxels hold geometry at t = 2 s; \
         {} updated, {} bricks left empty",
        stats.screen_injected, counts.updated_voxels, counts.emptied_bricks
    );
    assert!(dynamic_cleared > 0);
    assert_eq!(static_cleared, 0);
    assert_eq!(wrongly_cleared, 0);
    assert_eq!(counts.cleared_voxels, static_cleared + dynamic_cleared);
}

#[test]
fn visible_voxels_take_the_gbuffer_albedo() {
    let Some(ctx) = GpuContext::new_or_skip("visible_voxels_take_the_gbuffer_albedo") else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let frame = scene.evaluate(0.0, None);
    let camera = frame.camera.position;
    let mut cache = RadianceCache::new(&ctx, &config()).unwrap();
    update(&ctx, &mut cache, (&scene, &frame), camera, None);
    let before = cache.buffers().read_voxels(&ctx);

    // The red wall turns blue in the G-buffer only.
    let mut repainted = scene.clone();
    let red = repainted
        .materials
        .iter()
        .position(|m| m.name == "Red")
        .expect("cornell-box has a red material");
    let material = repainted.materials[red].clone();
    // A voxel's albedo is the Lambert lobe's at the mean view cosine (`cache/voxelize`).
    let albedo = |base: Vec3| {
        Brdf::new(base, material.metallic, material.roughness)
            .diffuse_albedo(gi_cache::cpu_voxelize::MEAN_VIEW_COSINE)
    };
    let old = albedo(material.base_color.truncate());
    let new_base = Vec3::new(0.1, 0.2, 0.9);
    let new = albedo(new_base);
    repainted.materials[red].base_color = new_base.extend(1.0);
    let repainted_frame = repainted.evaluate(0.0, None);
    let (_, counts) = update(
        &ctx,
        &mut cache,
        (&scene, &frame),
        camera,
        Some((&repainted, &repainted_frame)),
    );
    let after = cache.buffers().read_voxels(&ctx);
    let near =
        |packed: u32, c: Vec3| (unpack4x8unorm(packed).truncate() - c).abs().max_element() < 0.01;
    let mut red_voxels = 0;
    let mut turned_blue = 0;
    let mut other_turned_blue = 0;
    for (b, a) in before.iter().zip(&after) {
        let was_red = b.albedo != 0 && near(b.albedo, old);
        red_voxels += u32::from(was_red);
        if near(a.albedo, new) {
            if was_red {
                turned_blue += 1;
            } else if !near(b.albedo, new) {
                other_turned_blue += 1;
            }
        }
        assert_eq!(b.emission, a.emission);
        assert_eq!(b.state, a.state);
        assert_eq!(b.albedo >> 24, a.albedo >> 24, "coverage is kept");
    }
    eprintln!(
        "refresh: {} voxels updated; {turned_blue} of {red_voxels} red voxels took the new color, \
         {other_turned_blue} voxels of other materials did",
        counts.updated_voxels
    );
    // Red voxels hidden from the camera, seen at grazing angles or coarser than the red wall's
    // neighborhood keep their color; no voxel of another material takes the new one.
    assert!(turned_blue >= 100, "{turned_blue} of {red_voxels}");
    assert_eq!(other_turned_blue, 0);
    assert_eq!(counts.cleared_voxels, 0);
}

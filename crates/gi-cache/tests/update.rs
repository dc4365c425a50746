//! The cache update (`Technique::record` of `RadianceCache`) on the GPU: window moves keep staying bricks in place, the pool
//! degrades gracefully, and moved or reshaped dynamic objects are re-voxelized locally and
//! exactly.

use std::collections::HashMap;

use gi_cache::binning::{CacheScene, bin_triangles};
use gi_cache::layout::{NO_BRICK, SIDE_COUNT, VOXELS_PER_BRICK, VoxelSurface, join_mask};
use gi_cache::{CacheConfig, CacheInputs, CacheUpdateStats, CpuCache, RadianceCache};
use gi_gpu::{GpuContext, GpuScene, GpuTimer, Recorder, Technique};
use gi_scene::{Animation, Channel, ChannelValues, Interpolation, MorphTarget, Scene, SceneFrame};
use glam::{IVec3, Vec3};

fn update(
    ctx: &GpuContext,
    cache: &mut RadianceCache,
    scene: &Scene,
    frame: &SceneFrame,
    camera: Vec3,
) -> CacheUpdateStats {
    let gpu_scene = GpuScene::upload(ctx, scene, frame).unwrap();
    let mut timer = GpuTimer::new(ctx, "cache test", 12);
    let mut rec = Recorder::new(ctx, &mut timer, "cache test");
    let stats = cache
        .record(
            &mut rec,
            &CacheInputs {
                scene,
                frame,
                gpu_scene: &gpu_scene,
                camera_position: camera,
                gbuffer: None,
            },
        )
        .stats;
    let encoder = rec.into_encoder();
    let timings = timer.finish(ctx, encoder);
    eprintln!("{stats:?} {timings}");
    gpu_scene.release(ctx);
    stats
}

/// Three levels, every queued brick voxelized in the update that queued it.
fn three_levels_at_once() -> CacheConfig {
    CacheConfig {
        levels: 3,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    }
}

/// `(level, brick) -> id` of every allocated brick.
fn residents(cache: &RadianceCache) -> HashMap<(u32, IVec3), u32> {
    cache
        .resident_bricks()
        .into_iter()
        .map(|b| ((b.level, b.brick), b.brick_id))
        .collect()
}

#[test]
fn camera_move_keeps_staying_bricks_in_place() {
    let Some(ctx) = GpuContext::new_or_skip("camera_move_keeps_staying_bricks_in_place") else {
        return;
    };
    let scene = gi_scene::load("thin-wall").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        levels: 2,
        near_levels: 1,
        level_bricks: [16, 8, 16],
        pool_bricks: 4096,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    };
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let camera = frame.camera.position;
    let first = update(&ctx, &mut cache, &scene, &frame, camera);
    assert_eq!(first.queued_remaining, 0);
    assert_eq!(first.dropped_for_pool, 0);
    let before = residents(&cache);
    assert_eq!(before.len() as u32, first.voxelized);

    // Known side values, so a later read shows whether anything touched them.
    let sides = (cache.buffers().direct.size() / 4) as u32;
    let known: Vec<u32> = (0..sides).map(|i| i.wrapping_mul(2_654_435_761)).collect();
    ctx.queue
        .write_buffer(&cache.buffers().direct, 0, bytemuck::cast_slice(&known));
    ctx.queue
        .write_buffer(&cache.buffers().indirect, 0, bytemuck::cast_slice(&known));
    let voxels_before: Vec<VoxelSurface> = cache.buffers().read_voxels(&ctx);
    let windows_before = cache.windows().unwrap().clone();

    // Three level-0 groups (3 m) along x and one down z: past the hysteresis band of both
    // levels (1.25 groups: 1.25 m at level 0, 2.5 m at level 1), so both move.
    let moved = camera + Vec3::new(3.0, 0.0, -1.0);
    let stats = update(&ctx, &mut cache, &scene, &frame, moved);
    let windows = cache.windows().unwrap().clone();
    assert_eq!(stats.levels_moved, 2);

    let after = residents(&cache);
    let voxels_after: Vec<VoxelSurface> = cache.buffers().read_voxels(&ctx);
    let direct: Vec<u32> = ctx.read_buffer(&cache.buffers().direct);
    let indirect: Vec<u32> = ctx.read_buffer(&cache.buffers().indirect);
    let mut stayed = 0;
    let mut left = 0;
    for (&(level, brick), &id) in &before {
        if !windows.window(level).contains(brick) {
            left += 1;
            assert!(!after.contains_key(&(level, brick)));
            continue;
        }
        stayed += 1;
        assert_eq!(
            after.get(&(level, brick)),
            Some(&id),
            "level {level} brick {brick}"
        );
        let voxels = id as usize * 64..(id as usize + 1) * 64;
        assert_eq!(voxels_after[voxels.clone()], voxels_before[voxels]);
        let per_brick = (VOXELS_PER_BRICK * SIDE_COUNT) as usize;
        let sides = id as usize * per_brick..(id as usize + 1) * per_brick;
        assert_eq!(direct[sides.clone()], known[sides.clone()]);
        assert_eq!(indirect[sides.clone()], known[sides]);
    }
    assert!(stayed > 100 && left > 10, "stayed {stayed}, left {left}");
    assert_eq!(stats.released_leaving, left);

    // Exactly the entering slabs' bricks with geometry were queued, and all were filled.
    let cache_scene = CacheScene::new(&scene, &frame);
    let mut entering = 0;
    for level in 0..config.levels {
        let (old, new) = (windows_before.window(level), windows.window(level));
        for slab in new.difference(&old) {
            let bins = bin_triangles(
                &config,
                &cache_scene,
                level,
                &slab,
                0..frame.triangles.len() as u32,
            );
            entering += bins.len() as u32;
            for brick in bins.keys() {
                assert!(
                    after.contains_key(&(level, *brick)),
                    "entering brick {brick} not filled"
                );
            }
        }
    }
    assert_eq!(stats.queued_entering, entering);
    assert_eq!(stats.voxelized, entering);

    // The GPU link grid and group masks are the CPU mirror's, and consistent.
    cache.structure().check_group_masks().unwrap();
    let link: Vec<u32> = ctx.read_buffer(&cache.buffers().link);
    assert_eq!(link, cache.structure().link);
    let groups: Vec<[u32; 2]> = ctx.read_buffer(&cache.buffers().group_masks);
    let groups: Vec<u64> = groups.into_iter().map(join_mask).collect();
    assert_eq!(groups, cache.structure().group_masks);
    eprintln!("cache memory: {} bytes", cache.memory_bytes(&ctx));
}

/// The same scene and camera path give every brick the same pool ID in any cache: the pool ID
/// decides when the lighting schedule's round-robin reaches a brick, so IDs handed out in the
/// hash order the bricks were found in (which differs from one cache to the next) made the
/// same frames render differently. The Cornell box's symmetry puts many bricks at the same
/// distance from the camera; the fill runs over several frames and runs out of pool, and a
/// camera move then frees IDs for bricks dropped before: both paths that hand out IDs.
#[test]
fn two_caches_give_every_brick_the_same_pool_id() {
    let Some(ctx) = GpuContext::new_or_skip("two_caches_give_every_brick_the_same_pool_id") else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        levels: 3,
        pool_bricks: 250,
        voxelize_bricks_per_frame: 64,
        ..Default::default()
    };
    let camera = frame.camera.position;
    let path = [camera; 6]
        .into_iter()
        .chain([camera + Vec3::new(1.5, 0.5, 3.0); 6]);
    let (mut a, mut b) = (
        RadianceCache::new(&ctx, &config).unwrap(),
        RadianceCache::new(&ctx, &config).unwrap(),
    );
    let (mut dropped, mut requeued) = (0, 0);
    for (i, position) in path.enumerate() {
        let stats = update(&ctx, &mut a, &scene, &frame, position);
        update(&ctx, &mut b, &scene, &frame, position);
        (dropped, requeued) = (
            dropped + stats.dropped_for_pool,
            requeued + stats.requeued_dropped,
        );
        let (ids_a, ids_b) = (a.resident_bricks(), b.resident_bricks());
        let differing = ids_a.iter().zip(&ids_b).filter(|(x, y)| x != y).count();
        assert_eq!(
            (ids_a.len(), differing),
            (ids_b.len(), 0),
            "update {i}: {differing} of {} bricks differ in place or pool ID",
            ids_a.len()
        );
    }
    assert!(
        dropped > 0 && requeued > 0,
        "the fill must run out of pool and refill: {dropped} dropped, {requeued} requeued"
    );
}

#[test]
fn pool_exhaustion_keeps_the_finest_levels() {
    let Some(ctx) = GpuContext::new_or_skip("pool_exhaustion_keeps_the_finest_levels") else {
        return;
    };
    let scene = gi_scene::load("thin-wall").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        levels: 3,
        level_bricks: [16, 8, 16],
        pool_bricks: 300,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    };
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let camera = frame.camera.position;
    let stats = update(&ctx, &mut cache, &scene, &frame, camera);
    let state = cache.stats();
    assert_eq!(state.allocated_bricks, 300);
    assert_eq!(state.free_bricks, 0);
    assert!(stats.dropped_for_pool > 0);
    // Level by level: a level may lose bricks only when every finer level is complete.
    let cache_scene = CacheScene::new(&scene, &frame);
    let windows = cache.windows().unwrap();
    let mut incomplete = false;
    for level in 0..config.levels {
        let candidates = bin_triangles(
            &config,
            &cache_scene,
            level,
            &windows.window(level),
            0..frame.triangles.len() as u32,
        )
        .len() as u32;
        let held = state.bricks_per_level[level as usize];
        assert!(
            !incomplete || held == 0,
            "level {level} holds {held} while a finer level is incomplete"
        );
        incomplete |= held < candidates;
    }
    // Moving the camera releases bricks and refills with finer levels first, without panics.
    let stats = update(
        &ctx,
        &mut cache,
        &scene,
        &frame,
        camera + Vec3::new(3.0, 0.0, 0.0),
    );
    assert_eq!(cache.stats().allocated_bricks, 300);
    assert!(stats.released_leaving > 0);
    cache.structure().check_group_masks().unwrap();
}

#[test]
fn bricks_dropped_for_pool_are_filled_when_a_shift_frees_space() {
    let Some(ctx) =
        GpuContext::new_or_skip("bricks_dropped_for_pool_are_filled_when_a_shift_frees_space")
    else {
        return;
    };
    let scene = gi_scene::load("thin-wall").unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        levels: 3,
        level_bricks: [16, 8, 16],
        pool_bricks: 300,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    };
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let camera = frame.camera.position;
    let first = update(&ctx, &mut cache, &scene, &frame, camera);
    assert!(first.dropped_for_pool > 0);
    // Up, away from the ground: the leaving slabs below free many bricks, the entering slabs
    // above (open sky) need none, so the freed IDs go to bricks dropped at the first update.
    let raised = camera + Vec3::new(0.0, 3.0, 0.0);
    let stats = update(&ctx, &mut cache, &scene, &frame, raised);
    eprintln!(
        "requeue: first update dropped {}, the shift released {}, requeued {}, now {} allocated",
        first.dropped_for_pool,
        stats.released_leaving,
        stats.requeued_dropped,
        cache.stats().allocated_bricks
    );
    assert!(stats.released_leaving > 0);
    assert!(stats.requeued_dropped > 0);
    // The freed space is used again, finest levels first.
    assert_eq!(cache.stats().allocated_bricks, config.pool_bricks);
    let cache_scene = CacheScene::new(&scene, &frame);
    let windows = cache.windows().unwrap();
    let held = residents(&cache);
    let mut incomplete = false;
    for level in 0..config.levels {
        let bins = bin_triangles(
            &config,
            &cache_scene,
            level,
            &windows.window(level),
            0..frame.triangles.len() as u32,
        );
        let missing = bins
            .keys()
            .filter(|b| !held.contains_key(&(level, **b)))
            .count();
        let count = cache.stats().bricks_per_level[level as usize];
        assert!(
            !incomplete || count == 0,
            "level {level} holds {count} while a finer level is incomplete"
        );
        incomplete |= missing > 0;
    }
    cache.structure().check_group_masks().unwrap();
}

#[test]
fn dynamic_object_is_revoxelized_locally_and_exactly() {
    let Some(ctx) = GpuContext::new_or_skip("dynamic_object_is_revoxelized_locally_and_exactly")
    else {
        return;
    };
    let scene = gi_scene::load("dynamic").unwrap();
    let config = three_levels_at_once();
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let frame0 = scene.evaluate(0.0, None);
    let camera = frame0.camera.position;
    let first = update(&ctx, &mut cache, &scene, &frame0, camera);
    assert_eq!(first.dropped_for_pool, 0);

    let frame1 = scene.evaluate(0.25, None);
    let stats = update(&ctx, &mut cache, &scene, &frame1, camera);
    assert_eq!(stats.levels_moved, 0);
    // Only bricks inside the moving nodes' old and new bounds were touched.
    let cache_scene = CacheScene::new(&scene, &frame1);
    let (bounds0, bounds1) = (
        CacheScene::new(&scene, &frame0).node_bounds(),
        cache_scene.node_bounds(),
    );
    let windows = cache.windows().unwrap();
    let mut near = 0u64;
    for node in 0..scene.nodes.len() {
        if !cache_scene.dynamic_node[node]
            || frame0.world_from_node[node] == frame1.world_from_node[node]
        {
            continue;
        }
        for (lo, hi) in [bounds0[node], bounds1[node]].into_iter().flatten() {
            for level in 0..config.levels {
                let region = gi_cache::BrickBox::from_world(lo, hi, config.brick_size_at(level));
                near += region.intersection(&windows.window(level)).volume();
            }
        }
    }
    eprintln!(
        "dynamic: {} of {} bricks re-voxelized ({} bricks in the moving bounds), {} released",
        stats.voxelized, first.voxelized, near, stats.released_empty
    );
    assert!(stats.voxelized > 0);
    assert!(u64::from(stats.voxelized + stats.released_empty) <= near);
    assert!(stats.voxelized * 4 < first.voxelized);

    // Occupancy equals a fresh CPU voxelization at the new time.
    let cpu = CpuCache::build(&config, &scene, &frame1, camera).unwrap();
    let masks = cache.buffers().read_brick_masks(&ctx);
    let gpu = residents(&cache);
    assert_eq!(gpu.len(), cpu.bricks.len());
    for b in &cpu.bricks {
        let id = gpu.get(&(b.level, b.brick)).copied().unwrap_or(NO_BRICK);
        assert_ne!(id, NO_BRICK, "level {} brick {} missing", b.level, b.brick);
        assert_eq!(
            masks[id as usize],
            cpu.structure.brick_mask(b.id),
            "level {} brick {}",
            b.level,
            b.brick
        );
    }
}

#[test]
fn a_pool_beyond_the_storage_binding_limit_is_refused() {
    let Some(ctx) = GpuContext::new_or_skip("a_pool_beyond_the_storage_binding_limit_is_refused")
    else {
        return;
    };
    let config = CacheConfig {
        pool_bricks: 1 << 22,
        ..Default::default()
    };
    let err = RadianceCache::new(&ctx, &config).err().expect("refused");
    assert!(
        matches!(err, gi_cache::CacheError::BufferTooLarge { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("pool_bricks"), "{err}");
    let bad = CacheConfig {
        levels: 0,
        ..Default::default()
    };
    let err = RadianceCache::new(&ctx, &bad).err().expect("refused");
    assert!(err.to_string().contains("levels"), "{err}");
}

/// `scene`'s arm deforms between 0 and 0.5 s while its node's own transform stays: the
/// update at 0.5 s queues it as a dynamic node that moved, the occupancy then equals a fresh
/// CPU voxelization at the new time, and the same frame again queues nothing. Returns the
/// stats of the update at 0.5 s.
fn check_deforming_arm(ctx: &GpuContext, scene: &Scene, arm: usize) -> CacheUpdateStats {
    let config = CacheConfig {
        levels: 3,
        voxelize_bricks_per_frame: 100_000,
        voxelize_scan_per_frame: u32::MAX,
        ..Default::default()
    };
    let mut cache = RadianceCache::new(ctx, &config).unwrap();
    let camera = Vec3::new(0.0, 1.0, 4.0);
    let frame0 = scene.evaluate(0.0, None);
    let first = update(ctx, &mut cache, scene, &frame0, camera);
    assert_eq!(first.dropped_for_pool, 0);
    assert!(first.voxelized > 0);

    let frame1 = scene.evaluate(0.5, None);
    assert_eq!(
        frame0.world_from_node[arm], frame1.world_from_node[arm],
        "the arm's own transform stays"
    );
    assert!(
        CacheScene::new(scene, &frame1).dynamic_node[arm],
        "a deforming node is dynamic"
    );
    let stats = update(ctx, &mut cache, scene, &frame1, camera);
    assert!(
        stats.queued_dynamic > 0,
        "the arm counts as moved: {stats:?}"
    );

    let cpu = CpuCache::build(&config, scene, &frame1, camera).unwrap();
    let masks = cache.buffers().read_brick_masks(ctx);
    let gpu = residents(&cache);
    assert_eq!(gpu.len(), cpu.bricks.len());
    for b in &cpu.bricks {
        let id = gpu.get(&(b.level, b.brick)).copied().unwrap_or(NO_BRICK);
        assert_ne!(id, NO_BRICK, "level {} brick {} missing", b.level, b.brick);
        assert_eq!(
            masks[id as usize],
            cpu.structure.brick_mask(b.id),
            "level {} brick {}",
            b.level,
            b.brick
        );
    }

    let again = update(ctx, &mut cache, scene, &frame1, camera);
    assert_eq!(again.queued_dynamic, 0, "{again:?}");
    cache.release_buffers(ctx);
    stats
}

/// A skinned arm whose elbow bends: its node's own transform never changes, yet its joints
/// move it, so it is a dynamic node that moved; only its triangles are dynamic, no window
/// moves, and the bricks around its old and new shapes are voxelized again exactly.
#[test]
fn skinned_object_is_revoxelized_when_its_joints_move() {
    let Some(ctx) = GpuContext::new_or_skip("skinned_object_is_revoxelized_when_its_joints_move")
    else {
        return;
    };
    let scene = gi_scene::generate::skinned_arm();
    let arm = scene.nodes.iter().position(|n| n.name == "arm").unwrap();
    let frame1 = scene.evaluate(0.5, None);
    let dynamic = gi_cache::binning::dynamic_triangles(&scene, &frame1);
    for (flag, attributes) in dynamic.iter().zip(&frame1.attributes) {
        assert_eq!(*flag, attributes.node == arm as u32);
    }
    let stats = check_deforming_arm(&ctx, &scene, arm);
    assert_eq!(stats.levels_moved, 0);
    assert!(stats.voxelized > 0);
}

/// The skinned arm without its skin, morphed instead: one target shifts it 1 m along +X and an
/// animation ramps its weight from 0 to 1. Its node's transform never changes, yet its
/// triangles move, so it is a dynamic node that moved, voxelized again exactly.
#[test]
fn morphed_object_is_revoxelized_when_its_weights_change() {
    let Some(ctx) =
        GpuContext::new_or_skip("morphed_object_is_revoxelized_when_its_weights_change")
    else {
        return;
    };
    let mut scene = gi_scene::generate::skinned_arm();
    let arm = scene.nodes.iter().position(|n| n.name == "arm").unwrap();
    scene.nodes[arm].skin = None;
    let mesh = scene.nodes[arm].mesh.unwrap();
    let primitive = &mut scene.meshes[mesh].primitives[0];
    primitive.targets = vec![MorphTarget {
        positions: vec![Vec3::X; primitive.positions.len()],
        ..MorphTarget::default()
    }];
    scene.animations = vec![Animation {
        name: "shift".into(),
        channels: vec![Channel {
            node: arm,
            times: vec![0.0, 1.0],
            values: ChannelValues::Weights(vec![vec![0.0], vec![1.0]]),
            interpolation: Interpolation::Linear,
        }],
    }];
    let frame0 = scene.evaluate(0.0, None);
    let frame1 = scene.evaluate(0.5, None);
    assert_eq!(frame0.world_from_node, frame1.world_from_node);
    check_deforming_arm(&ctx, &scene, arm);
}

/// Switching cornell-box's light panel off (its material's emission to 0) voxelizes again the
/// bricks its triangles touch, and those only: afterwards no voxel emits, while a frame of a
/// new revision with the same materials queues nothing.
#[test]
fn an_edited_material_is_voxelized_again_where_its_triangles_are() {
    let Some(ctx) =
        GpuContext::new_or_skip("an_edited_material_is_voxelized_again_where_its_triangles_are")
    else {
        return;
    };
    let mut scene = gi_scene::load("cornell-box").unwrap();
    let config = three_levels_at_once();
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let mut frame = scene.evaluate(0.0, None);
    let camera = frame.camera.position;
    let first = update(&ctx, &mut cache, &scene, &frame, camera);
    assert_eq!(first.queued_edited, 0);
    let emitting = |cache: &RadianceCache| {
        (cache.buffers().read_voxels(&ctx).iter())
            .filter(|v| gi_cache::packing::unpack_rgb9e5(v.emission) != Vec3::ZERO)
            .count()
    };
    let lit = emitting(&cache);
    assert!(lit > 0, "the panel's voxels emit");

    // A new revision whose materials are the same: nothing to voxelize again.
    frame.material_revision = 1;
    let same = update(&ctx, &mut cache, &scene, &frame, camera);
    assert_eq!((same.queued_edited, same.voxelized), (0, 0));

    let light = (scene.materials.iter())
        .position(|m| m.emissive != Vec3::ZERO)
        .expect("cornell-box has an emitter");
    scene.materials[light].emissive = Vec3::ZERO;
    frame.material_revision = 2;
    let edited = update(&ctx, &mut cache, &scene, &frame, camera);
    // The bricks the panel's triangles (padded by half a voxel) touch, at every level.
    let windows = cache.windows().unwrap();
    let mut near = std::collections::HashSet::new();
    for (index, attributes) in frame.attributes.iter().enumerate() {
        if attributes.material as usize != light {
            continue;
        }
        let t = &frame.triangles[index];
        let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
        for level in 0..config.levels {
            let size = config.brick_size_at(level);
            let pad = Vec3::splat(size / 8.0);
            let region =
                gi_cache::BrickBox::from_world(a.min(b).min(c) - pad, a.max(b).max(c) + pad, size)
                    .intersection(&windows.window(level));
            near.extend(region.bricks().map(|brick| (level, brick)));
        }
    }
    eprintln!(
        "{lit} voxels emitted; {} bricks queued, {} voxelized of {} ({} near the panel)",
        edited.queued_edited,
        edited.voxelized,
        first.voxelized,
        near.len()
    );
    assert!(edited.queued_edited > 0 && edited.voxelized == edited.queued_edited);
    assert!(edited.voxelized as usize <= near.len());
    assert!(edited.voxelized * 2 < first.voxelized);
    assert_eq!(emitting(&cache), 0, "voxels still emit after the edit");
}

/// With the default per-frame budgets, a fill that leaves bricks queued grows the
/// voxelization's buffers to a full batch at once, so flying through the scene afterwards creates
/// no buffer mid-flight (a buffer created then cost a frame milliseconds of CPU); a scene that
/// fills at once keeps them small.
#[test]
fn batches_within_the_budgets_create_no_buffer() {
    let Some(ctx) = GpuContext::new_or_skip("batches_within_the_budgets_create_no_buffer") else {
        return;
    };
    let labels = [
        "cache.voxelize_jobs",
        "cache.voxelize_triangles",
        "cache.voxelize_parts",
        "cache.voxelize_records",
    ];
    let sizes = |ctx: &GpuContext| labels.map(|label| ctx.memory().bytes(label));
    let config = CacheConfig::default();

    let scene = gi_scene::load("open-world").unwrap();
    let frame = scene.evaluate(0.0, None);
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let fill = update(&ctx, &mut cache, &scene, &frame, frame.camera.position);
    assert!(fill.queued_remaining > 0, "{fill:?}");
    let reserved = sizes(&ctx);
    // A full batch: the default 512 bricks and 32,768 references in 512 parts of 64, at least
    // one part per brick (1,024 parts), and a record per part and per brick (1,536), in
    // buffers of powers of two.
    assert_eq!(
        (
            config.voxelize_bricks_per_frame,
            config.voxelize_scan_per_frame,
            config.voxelize_part_triangles
        ),
        (512, 32_768, 64)
    );
    assert_eq!(
        reserved,
        [512 * 32, 32_768 * 4, 1024 * 16, 2048 * 4096],
        "{reserved:?}"
    );
    let mut voxelized = 0;
    let mut triangles = 0;
    for step in 1..6 {
        let camera = frame.camera.position + Vec3::new(6.0 * step as f32, 0.0, 0.0);
        let stats = update(&ctx, &mut cache, &scene, &frame, camera);
        voxelized += stats.voxelized;
        triangles = triangles.max(stats.voxelized_triangles);
        assert_eq!(sizes(&ctx), reserved, "update {step}");
    }
    // The updates did voxelize full batches.
    assert!(voxelized >= 5 * 256, "{voxelized}");
    assert!(triangles > 2048, "{triangles}");
    cache.release_buffers(&ctx);

    let scene = gi_scene::load("cornell-box").unwrap();
    let frame = scene.evaluate(0.0, None);
    let mut cache = RadianceCache::new(&ctx, &config).unwrap();
    let fill = update(&ctx, &mut cache, &scene, &frame, frame.camera.position);
    assert_eq!(fill.queued_remaining, 0);
    let records = ctx.memory().bytes("cache.voxelize_records");
    assert!(records < reserved[3], "{records}");
}

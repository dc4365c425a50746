//! The cache's CPU structure: allocator, windows, link grid and masks, the CPU-filled cache.

use gi_cache::binning::CacheScene;
use gi_cache::layout::{
    GROUP_BRICKS, NO_BRICK, STATE_DYNAMIC, box_cross_section, join_mask, side_slot,
};
use gi_cache::packing::{unpack_rgb9e5, unpack_unit_vector};
use gi_cache::{BrickAllocator, CacheBuffers, CacheConfig, ClipmapWindows, CpuCache, FreeError};
use gi_gpu::GpuContext;
use glam::{IVec3, Vec3};
use rand::{RngExt, SeedableRng};

#[test]
fn allocator_stays_consistent_under_random_alloc_and_free() {
    let pool = 97;
    let mut allocator = BrickAllocator::new(pool);
    let mut held: Vec<u32> = Vec::new();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    for _ in 0..20_000 {
        if rng.random_bool(0.55) {
            match allocator.alloc() {
                Some(id) => {
                    assert!((1..=pool).contains(&id));
                    assert!(!held.contains(&id), "ID {id} handed out twice");
                    held.push(id);
                }
                None => assert_eq!(held.len() as u32, pool),
            }
        } else if !held.is_empty() {
            let id = held.swap_remove(rng.random_range(0..held.len()));
            assert_eq!(allocator.free(id), Ok(()));
            assert_eq!(allocator.free(id), Err(FreeError::NotAllocated { id }));
        }
        assert_eq!(allocator.allocated_count(), held.len() as u32);
        assert_eq!(allocator.free_count(), pool - held.len() as u32);
    }
    for id in [0, pool + 1, u32::MAX] {
        assert!(matches!(
            allocator.free(id),
            Err(FreeError::OutOfRange { .. })
        ));
    }
}

#[test]
fn windows_are_centered_on_the_camera_and_snapped_to_groups() {
    let config = CacheConfig::default();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
    for _ in 0..200 {
        let camera = Vec3::new(
            rng.random_range(-300.0..300.0),
            rng.random_range(-50.0..50.0),
            rng.random_range(-300.0..300.0),
        );
        let windows = ClipmapWindows::new(&config, camera);
        for level in 0..config.levels {
            let window = windows.window(level);
            assert_eq!(window.min % GROUP_BRICKS as i32, IVec3::ZERO);
            let center = (window.min + window.max).as_vec3() * 0.5;
            let camera_brick = camera / config.brick_size_at(level);
            let offset = (camera_brick - center).abs().max_element();
            assert!(
                offset <= GROUP_BRICKS as f32 / 2.0 + 1e-3,
                "level {level}: {offset}"
            );
        }
    }
}

fn load(name: &str) -> gi_scene::Scene {
    gi_scene::load(name).unwrap_or_else(|e| panic!("scene {name}: {e}"))
}

#[test]
fn cpu_cache_of_the_cornell_box_holds_its_surfaces() {
    let scene = load("cornell-box");
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig::default();
    let start = std::time::Instant::now();
    let cache = CpuCache::build(&config, &scene, &frame, frame.camera.position).unwrap();
    eprintln!(
        "cornell-box: {} bricks {:?} in {:.1} ms",
        cache.bricks.len(),
        cache.bricks_per_level(),
        start.elapsed().as_secs_f64() * 1e3
    );
    assert_eq!(cache.dropped_for_pool, 0);
    assert_eq!(
        cache.allocator.allocated_count() as usize,
        cache.bricks.len()
    );
    cache.structure.check_group_masks().unwrap();
    // Every level holds the whole box (2 m fits the finest 8 x 4 x 8 m window).
    for level in 0..config.levels {
        assert!(cache.bricks_per_level()[level as usize] > 0);
    }
    // A point on the floor's top face, away from the blocks: an occupied voxel whose normal
    // points up and whose albedo is the white floor's.
    let mut found = 0;
    for b in &cache.bricks {
        let mask = cache.structure.brick_mask(b.id);
        assert_ne!(mask, 0);
        assert_eq!(cache.structure.brick_id(b.level, b.brick), b.id);
        for bit in 0..64 {
            if mask & (1 << bit) == 0 {
                continue;
            }
            let s = cache.surface(b.id, bit);
            assert_eq!(s.state & STATE_DYNAMIC, 0);
            let n = unpack_unit_vector(s.normal);
            assert!((n.length() - 1.0).abs() < 1e-3);
            found += 1;
        }
    }
    assert!(found > 1000);
}

/// The ceiling panel of cornell-box (0.18 m², 5 mm below the ceiling) covers only part of
/// its voxels. Each level's voxels together emit the panel's power: emission times the
/// cross-section of the voxel's box along its normal, summed, equals the panel's radiance
/// times its area, within RGB9E5 rounding, where the voxels face the way the panel does. Under
/// the earlier rule (every voxel nearest the panel shone with its full radiance) the 0.5 m
/// level emitted several times as much.
#[test]
fn cached_emitters_keep_their_power_at_every_level() {
    let scene = load("cornell-box");
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig::default();
    // Windows centered in the room, so that every level holds the whole panel.
    let cache = CpuCache::build(&config, &scene, &frame, Vec3::new(0.0, 1.0, 0.0)).unwrap();
    let cache_scene = CacheScene::new(&scene, &frame);
    let mut radiance = Vec3::ZERO;
    let mut area = 0.0f32;
    for (index, attributes) in frame.attributes.iter().enumerate() {
        let emissive = scene.materials[attributes.material as usize].emissive;
        if emissive != Vec3::ZERO {
            let [a, b, c] = cache_scene.vertices(index as u32);
            area += 0.5 * (b - a).cross(c - a).length();
            radiance = emissive;
        }
    }
    assert!(area > 0.1 && radiance.max_element() > 1.0);
    let power = radiance * area;
    for level in 0..config.levels {
        let s = config.voxel_size_at(level);
        let mut cached = Vec3::ZERO;
        let mut voxels = 0;
        for b in cache.bricks.iter().filter(|b| b.level == level) {
            let mask = cache.structure.brick_mask(b.id);
            for bit in (0..64).filter(|bit| mask & (1 << bit) != 0) {
                let v = cache.surface(b.id, bit);
                let e = unpack_rgb9e5(v.emission);
                if e != Vec3::ZERO {
                    let n = unpack_unit_vector(v.normal);
                    cached += e * box_cross_section(v.state, n, s);
                    voxels += 1;
                    // No voxel shines brighter than the panel.
                    assert!(e.cmple(radiance * 1.01).all(), "level {level}: {e}");
                }
            }
        }
        eprintln!(
            "level {level} ({s} m voxels): {voxels} emitting voxels, power {cached} of {power}"
        );
        // Up to 0.5 m voxels, the panel's voxels face down with it. Coarser voxels hold the
        // walls' corners too (the 2 m level the whole room), and their normals lean away from
        // the panel's: what they emit along their normals is its power times the cosine
        // between the two, down to nothing where the room's faces cancel.
        let (low, high) = if s <= 0.5 { (0.99, 1.01) } else { (0.0, 1.01) };
        assert!(
            cached.cmpge(power * low).all() && cached.cmple(power * high).all(),
            "level {level}: {cached} emitted, the panel {power}"
        );
    }
}

#[test]
fn cpu_cache_uploads_to_the_bind_group_buffers() {
    let Some(ctx) = GpuContext::new_or_skip("cpu_cache_uploads_to_the_bind_group_buffers") else {
        return;
    };
    let scene = load("thin-wall");
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig {
        pool_bricks: 2048,
        ..Default::default()
    };
    let mut cache = CpuCache::build(&config, &scene, &frame, frame.camera.position).unwrap();
    let first = cache.bricks[0];
    cache.set_side_irradiance(first.id, 5, 1, Vec3::new(1.0, 2.0, 3.0), Vec3::splat(0.5));
    let buffers = cache.upload(&ctx);
    let masks = buffers.read_brick_masks(&ctx);
    assert_eq!(masks, cache.structure.brick_masks);
    let link: Vec<u32> = ctx.read_buffer(&buffers.link);
    assert_eq!(link, cache.structure.link);
    let groups: Vec<[u32; 2]> = ctx.read_buffer(&buffers.group_masks);
    let groups: Vec<u64> = groups.into_iter().map(join_mask).collect();
    assert_eq!(groups, cache.structure.group_masks);
    assert_eq!(buffers.read_voxels(&ctx), cache.voxels);
    let direct: Vec<u32> = ctx.read_buffer(&buffers.direct);
    assert_eq!(direct, cache.direct);
    let indirect: Vec<u32> = ctx.read_buffer(&buffers.indirect);
    assert_eq!(indirect, cache.indirect);
    // The side set above, at its slot: voxel index x 2 + side.
    let slot = side_slot(first.id, 5, 1) as usize;
    assert_eq!(slot, (first.id as usize * 64 + 5) * 2 + 1);
    assert_eq!(
        (unpack_rgb9e5(direct[slot]), unpack_rgb9e5(indirect[slot])),
        (Vec3::new(1.0, 2.0, 3.0), Vec3::splat(0.5))
    );
    let report = ctx.memory();
    eprintln!("{report}");
    assert_eq!(
        buffers.bytes(),
        CacheBuffers::sizes(&config).iter().sum::<u64>()
    );
    let link_slots = link.iter().filter(|&&id| id != NO_BRICK).count();
    assert_eq!(link_slots, cache.bricks.len());
}

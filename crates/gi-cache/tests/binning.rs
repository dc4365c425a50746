//! The grid-indexed binning ([`TriangleIndex`]) against a scan of every triangle
//! ([`bin_triangles`]): the same bricks with the same triangle lists.

use gi_cache::binning::{Bins, CacheScene, TriangleIndex, bin_triangles};
use gi_cache::{BrickBox, CacheConfig, ClipmapWindows};
use glam::{IVec3, UVec3, Vec3};

fn brute_force(
    config: &CacheConfig,
    scene: &CacheScene<'_>,
    level: u32,
    region: &BrickBox,
) -> Bins {
    bin_triangles(
        config,
        scene,
        level,
        region,
        0..scene.frame.triangles.len() as u32,
    )
}

/// Every level's window, a slab entering it as the camera moves, a region straddling the
/// window's edge and a scattered set of single bricks, binned both ways.
fn compare(name: &str, time: f32) {
    let scene = gi_scene::load(name).unwrap();
    let frame = scene.evaluate(time, None);
    let config = CacheConfig::default();
    let cache_scene = CacheScene::new(&scene, &frame);
    let index = TriangleIndex::new(&config, &cache_scene);
    let camera = frame.camera.position;
    let windows = ClipmapWindows::new(&config, camera);
    let mut moved = windows.clone();
    let step = Vec3::new(3.0, 0.5, -2.0) * config.group_size_at(config.levels - 1);
    let shifts = moved.recenter(&config, camera + step);
    assert!(
        !shifts.is_empty(),
        "{name}: the camera step moves no window"
    );
    let mut nonempty = 0;
    for level in 0..config.levels {
        let window = windows.window(level);
        let bins = index.bin_region(level, &window);
        assert_eq!(
            bins,
            brute_force(&config, &cache_scene, level, &window),
            "{name} at {time}: level {level} window"
        );
        nonempty += bins.len();
        // The occupancy masks give the same bricks without binning.
        let mut candidates = index.candidate_bricks(level, &window);
        candidates.sort_by_key(|b| (b.z, b.y, b.x));
        let mut keys: Vec<IVec3> = bins.keys().copied().collect();
        keys.sort_by_key(|b| (b.z, b.y, b.x));
        assert_eq!(
            candidates, keys,
            "{name} at {time}: level {level}: occupied bricks"
        );

        let straddling = BrickBox::new(window.min - IVec3::new(3, 2, 5), UVec3::new(9, 7, 11));
        assert_eq!(
            index.bin_region(level, &straddling),
            brute_force(&config, &cache_scene, level, &straddling),
            "{name} at {time}: level {level} region across the window edge"
        );

        let bricks: Vec<IVec3> = bins
            .keys()
            .copied()
            .step_by(7)
            .chain([window.min])
            .collect();
        // One list per brick asked, in the order asked; empty for a brick without geometry.
        let expected: Vec<Vec<u32>> = bricks
            .iter()
            .map(|&brick| {
                let single = BrickBox::new(brick, UVec3::ONE);
                brute_force(&config, &cache_scene, level, &single)
                    .remove(&brick)
                    .unwrap_or_default()
            })
            .collect();
        assert_eq!(
            index.bin_bricks(level, &bricks),
            expected,
            "{name} at {time}: level {level} single bricks"
        );
    }
    assert!(
        nonempty > 100,
        "{name}: only {nonempty} bricks hold geometry"
    );
    for shift in shifts {
        for slab in &shift.entering {
            assert_eq!(
                index.bin_region(shift.level, slab),
                brute_force(&config, &cache_scene, shift.level, slab),
                "{name} at {time}: level {} entering slab {slab:?}",
                shift.level
            );
        }
    }
}

#[test]
fn indexed_binning_matches_a_scan_of_every_triangle_on_open_world() {
    compare("open-world", 0.0);
}

#[test]
fn indexed_binning_matches_a_scan_of_every_triangle_on_the_dynamic_scene() {
    compare("dynamic", 0.0);
    compare("dynamic", 0.25);
}

/// `TriangleIndex::update` keeps the index for an unchanged frame and rebuilds it when a
/// triangle moved: after each update the bins are the scan's for the frame given.
#[test]
fn update_follows_a_moved_triangle() {
    let scene = gi_scene::load("cornell-box").unwrap();
    let config = CacheConfig::default();
    let level = 0;
    let mut frame = scene.evaluate(0.0, None);
    let window = ClipmapWindows::new(&config, frame.camera.position).window(level);
    let mut index = TriangleIndex::new(&config, &CacheScene::new(&scene, &frame));
    let before = index.bin_region(level, &window);
    // The same frame again: the same bins.
    index.update(&config, &CacheScene::new(&scene, &frame));
    assert_eq!(index.bin_region(level, &window), before);
    // Move the first triangle by a metre: the bins follow it.
    let offset = glam::Vec3A::new(0.0, 1.0, 0.0);
    let t = &mut frame.triangles[0];
    (t.v0, t.v1, t.v2) = (t.v0 + offset, t.v1 + offset, t.v2 + offset);
    frame.geometry_changed();
    let moved = CacheScene::new(&scene, &frame);
    index.update(&config, &moved);
    let after = index.bin_region(level, &window);
    assert_ne!(after, before, "the moved triangle's bins did not change");
    assert_eq!(after, brute_force(&config, &moved, level, &window));
}

/// Triangles too large for the grid cells (a 20 km ground triangle under the scene, a long
/// thin one crossing it) are binned from their level's separate list: the bins and their order
/// are still the scan's.
#[test]
fn large_triangles_bin_like_a_scan() {
    let scene = gi_scene::load("open-world").unwrap();
    let mut frame = scene.evaluate(0.0, None);
    let attributes = frame.attributes[0];
    let tri = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| obvhs::triangle::Triangle {
        v0: a.into(),
        v1: b.into(),
        v2: c.into(),
    };
    // Inserted in the middle, so frame order puts them between gridded triangles.
    let middle = frame.triangles.len() / 2;
    // Through the finest window, about the camera.
    let c = frame.camera.position;
    let (y, z) = (c.y - 0.5, c.z + 0.3);
    for (offset, t) in [
        tri([-1e4, y, -1e4], [1e4, y, -1e4], [0.0, y, 1e4]),
        tri(
            [-3e3, y + 1.0, z],
            [3e3, y + 1.2, z],
            [3e3, y + 1.3, z + 0.05],
        ),
        // Listed per block of cells at the finest level (too wide for its cells), in the
        // cells at coarser ones.
        tri(
            [c.x - 30.0, y + 0.7, c.z - 30.0],
            [c.x + 30.0, y + 0.8, c.z - 29.0],
            [c.x + 1.0, y + 0.75, c.z + 30.0],
        ),
        // Wide: listed in its cells at every level.
        tri(
            [c.x - 9.0, y + 1.7, c.z - 9.0],
            [c.x + 9.0, y + 1.4, c.z - 8.0],
            [c.x + 2.0, y + 1.6, c.z + 9.0],
        ),
    ]
    .into_iter()
    .enumerate()
    {
        frame.triangles.insert(middle + offset, t);
        frame.attributes.insert(middle + offset, attributes);
    }
    frame.geometry_changed();
    let config = CacheConfig::default();
    let cache_scene = CacheScene::new(&scene, &frame);
    let index = TriangleIndex::new(&config, &cache_scene);
    let windows = ClipmapWindows::new(&config, frame.camera.position);
    for level in 0..config.levels {
        let window = windows.window(level);
        let bins = index.bin_region(level, &window);
        let middle = middle as u32;
        assert!(
            bins.values().any(|list| list.contains(&middle)),
            "level {level}: the ground triangle is in no bin"
        );
        assert_eq!(
            bins,
            brute_force(&config, &cache_scene, level, &window),
            "level {level}"
        );
        // The bricks an entering slab queues are the bins' bricks.
        let mut candidates = index.candidate_bricks(level, &window);
        candidates.sort_by_key(|b| (b.z, b.y, b.x));
        let mut keys: Vec<IVec3> = bins.keys().copied().collect();
        keys.sort_by_key(|b| (b.z, b.y, b.x));
        assert_eq!(candidates, keys, "level {level}: occupied bricks");
        // Binning chosen bricks, as the cache's fill does, reads the same lists.
        let bricks: Vec<IVec3> = bins.keys().copied().step_by(3).collect();
        let expected: Vec<Vec<u32>> = bricks.iter().map(|brick| bins[brick].clone()).collect();
        assert_eq!(
            index.bin_bricks(level, &bricks),
            expected,
            "level {level}: chosen bricks"
        );
    }
}

/// A new evaluation of the same geometry (another revision, the same triangles) keeps the
/// index's bins.
#[test]
fn a_new_revision_of_the_same_geometry_keeps_the_bins() {
    let scene = gi_scene::load("cornell-box").unwrap();
    let config = CacheConfig::default();
    let first = scene.evaluate(0.0, None);
    let second = scene.evaluate(0.0, None);
    assert_ne!(first.geometry_revision, second.geometry_revision);
    let window = ClipmapWindows::new(&config, first.camera.position).window(0);
    let mut index = TriangleIndex::new(&config, &CacheScene::new(&scene, &first));
    let before = index.bin_region(0, &window);
    index.update(&config, &CacheScene::new(&scene, &second));
    assert_eq!(index.bin_region(0, &window), before);
    assert!(!before.is_empty());
}

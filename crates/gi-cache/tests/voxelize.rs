//! The GPU voxelizer (`cache/voxelize`) against the CPU voxelizer on bundled scenes.

use gi_cache::binning::{CacheScene, bin_triangles};
use gi_cache::cpu_voxelize::triangle_box_overlap;
use gi_cache::layout::{VoxelSurface, mask_cell, voxel_index};
use gi_cache::packing::{unpack_rgb9e5, unpack_unit_vector, unpack4x8unorm};
use gi_cache::voxelize::{VoxelizeJob, Voxelizer};
use gi_cache::{CacheBuffers, CacheConfig, CpuCache};
use gi_gpu::{GpuContext, GpuScene, GpuTimer, ShaderLibrary};
use glam::IVec3;

/// True when voxel `bit` of `brick` is a boundary tie: some triangle of the brick overlaps the
/// voxel box grown by a relative 1e-4 but not the box shrunk by as much, so f32 rounding of
/// the same test may decide either way.
fn is_boundary_tie(
    scene: &CacheScene<'_>,
    voxel_size: f32,
    brick: IVec3,
    bit: u32,
    triangles: &[u32],
) -> bool {
    let voxel = brick * 4 + mask_cell(bit).as_ivec3();
    let center = (voxel.as_vec3() + 0.5) * voxel_size;
    let half = 0.5 * voxel_size;
    triangles.iter().any(|&r| {
        let v = scene.vertices(r & 0x7fff_ffff);
        triangle_box_overlap(v, center, half * (1.0 + 1e-4))
            != triangle_box_overlap(v, center, half * (1.0 - 1e-4))
    })
}

/// Voxelizes every brick of `name`'s CPU cache on the GPU with lists cut into parts of
/// `part_triangles` entries and compares each voxel with the CPU's.
fn compare(name: &str, part_triangles: u32) {
    let Some(ctx) = GpuContext::new_or_skip(&format!("gpu_voxelizer_matches_cpu ({name})")) else {
        return;
    };
    let scene = gi_scene::load(name).unwrap();
    let frame = scene.evaluate(0.0, None);
    let config = CacheConfig::default();
    let cpu = CpuCache::build(&config, &scene, &frame, frame.camera.position).unwrap();
    let cache_scene = CacheScene::new(&scene, &frame);
    let mut jobs = Vec::new();
    for level in 0..config.levels {
        let bins = bin_triangles(
            &config,
            &cache_scene,
            level,
            &cpu.windows.window(level),
            0..frame.triangles.len() as u32,
        );
        for b in cpu.bricks.iter().filter(|b| b.level == level) {
            jobs.push(VoxelizeJob {
                level,
                brick: b.brick,
                id: b.id,
                triangles: bins[&b.brick].clone(),
            });
        }
    }
    let gpu_scene = GpuScene::upload(&ctx, &scene, &frame).unwrap();
    let buffers = CacheBuffers::new(&ctx, &config);
    buffers.write_uniforms(&ctx, &cpu.uniforms());
    let mut voxelizer = Voxelizer::new(&ctx, &ShaderLibrary::new(), part_triangles).unwrap();
    let mut timer = GpuTimer::new(&ctx, "test", 4);
    let mut encoder = ctx.create_encoder("test");
    let plan = voxelizer.record(&ctx, &mut encoder, &mut timer, &gpu_scene, &buffers, &jobs);
    assert_eq!(
        plan.jobs.len(),
        jobs.len(),
        "every brick in one voxelization"
    );
    let longest = jobs
        .iter()
        .map(|job| job.triangles.len())
        .max()
        .unwrap_or(0);
    if longest > part_triangles as usize {
        assert!(plan.parts.len() > jobs.len(), "some brick cut into parts");
    }
    let timings = timer.finish(&ctx, encoder);
    eprintln!(
        "{name}: {} bricks (lists up to {longest}) in {} parts of {part_triangles} voxelized on \
         the GPU in {:.1} ms",
        jobs.len(),
        plan.parts.len(),
        timings.get("cache/voxelize").unwrap_or(f64::NAN)
    );
    let masks = buffers.read_brick_masks(&ctx);
    let voxels: Vec<VoxelSurface> = buffers.read_voxels(&ctx);
    let (mut ties, mut compared) = (0, 0);
    for job in &jobs {
        let voxel_size = config.voxel_size_at(job.level);
        let (gpu_mask, cpu_mask) = (masks[job.id as usize], cpu.structure.brick_mask(job.id));
        for bit in 0..64 {
            let (g, c) = (gpu_mask >> bit & 1, cpu_mask >> bit & 1);
            if g != c {
                assert!(
                    is_boundary_tie(&cache_scene, voxel_size, job.brick, bit, &job.triangles),
                    "{name}: level {} brick {} voxel {bit}: GPU {g} CPU {c}",
                    job.level,
                    job.brick
                );
                ties += 1;
                continue;
            }
            if c == 0 {
                continue;
            }
            compared += 1;
            let i = voxel_index(job.id, bit) as usize;
            let (gs, cs) = (voxels[i], cpu.voxels[i]);
            let where_ = format!(
                "{name}: level {} brick {} voxel {bit}",
                job.level, job.brick
            );
            let albedo = (unpack4x8unorm(gs.albedo) - unpack4x8unorm(cs.albedo))
                .abs()
                .max_element();
            assert!(albedo <= 1.5 / 255.0, "{where_}: albedo {gs:?} vs {cs:?}");
            let angle = unpack_unit_vector(gs.normal).angle_between(unpack_unit_vector(cs.normal));
            assert!(angle < 1e-2, "{where_}: normal off by {angle} rad");
            let (ge, ce) = (unpack_rgb9e5(gs.emission), unpack_rgb9e5(cs.emission));
            assert!(
                (ge - ce).abs().max_element() <= 0.01 * ce.max_element() + 1e-6,
                "{where_}: emission {ge} vs {ce}"
            );
            assert_eq!(gs.state, cs.state, "{where_}");
        }
    }
    eprintln!("{name}: {compared} voxels equal, {ties} boundary ties");
    assert!(compared > 1000);
    assert!(ties * 1000 <= compared, "{name}: {ties} ties of {compared}");
}

#[test]
fn gpu_voxelizer_matches_cpu_on_cornell_box() {
    compare(
        "cornell-box",
        CacheConfig::default().voxelize_part_triangles,
    );
}

#[test]
fn gpu_voxelizer_matches_cpu_on_thin_wall() {
    compare("thin-wall", CacheConfig::default().voxelize_part_triangles);
}

/// Lists cut into parts of 3 triangles: most bricks are merged from several parts, so the
/// merge's order (the first of the nearest triangles gives the albedo), its sums and its boxes
/// are held to the CPU's single walk of each list.
#[test]
fn gpu_voxelizer_merging_parts_matches_cpu() {
    compare("cornell-box", 3);
}

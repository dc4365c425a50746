//! The cache's Rust mirrors against naga's layout of `shaders/cache/data.wgsl`.

use gi_cache::{GpuCacheLevel, GpuCacheUniforms, VoxelSurface};
use gi_gpu::{ShaderLibrary, rust_field_offsets, wgsl_struct_layout};

/// A tiny entry file that uses every shared struct, so composition keeps them.
const PROBE: &str = r#"
#import gi::cache::data::{cache, cache_voxels, cache_side_radiance, cache_voxel_at, cache_level_of_point}

@group(0) @binding(0) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(1)
fn probe() {
    let level = cache_level_of_point(vec3(0.0));
    let v = cache_voxel_at(level, vec3(0));
    out[0] = vec4(cache_side_radiance(v, 0u, true), cache.levels[0].voxel_size_m)
        + vec4(f32(cache_voxels[0].state));
}
"#;

#[test]
fn shared_structs_match_their_wgsl_layout() {
    let module = ShaderLibrary::new()
        .with_source("test/cache_layout.wgsl", PROBE)
        .compose("test/cache_layout.wgsl", &[])
        .unwrap();
    let check = |name: &str, rust: Vec<(String, u32)>, size: usize| {
        let wgsl = wgsl_struct_layout(&module, name).unwrap_or_else(|| panic!("{name}"));
        assert_eq!(wgsl.members, rust, "{name}");
        assert_eq!(wgsl.size as usize, size, "{name}");
    };
    check(
        "CacheLevel",
        rust_field_offsets!(GpuCacheLevel {
            origin_brick,
            voxel_size_m
        }),
        size_of::<GpuCacheLevel>(),
    );
    check(
        "CacheUniforms",
        rust_field_offsets!(GpuCacheUniforms {
            levels,
            level_bricks,
            level_count,
            bricks_per_level,
            groups_per_level,
            pool_bricks,
            frame_index,
        }),
        size_of::<GpuCacheUniforms>(),
    );
    check(
        "VoxelSurface",
        rust_field_offsets!(VoxelSurface {
            albedo,
            normal,
            emission,
            state
        }),
        size_of::<VoxelSurface>(),
    );
}

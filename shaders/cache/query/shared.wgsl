// Batch queries of the brick radiance cache and its debug views, for tests, benchmarks and
// the `gi debug-cache` command (`gi_cache::CacheTracer`), one pass per file of
// `shaders/cache/query/`: `trace_rays.wgsl` (one ray per invocation through `cache_trace`),
// `trace_rays_shared.wgsl` (the same rays, CACHE_LANES invocations per ray through
// `cache_trace_shared`), `irradiance_at.wgsl` (one surface point per invocation through
// `cache_irradiance`) and `debug_view.wgsl` (one pixel per invocation through a pinhole
// camera). This module holds what they share: the rays and hits of the two ray passes (bind
// group 0, bindings 0 and 1) and the batches' workgroup size. Bind group 2 of every pass is
// the cache (`gi::cache::data`).
#define_import_path gi::cache::query

#import gi::cache::trace::{CacheHit, cache_hit_radiance, cache_hit_normal}

// Mirror of `gi_gpu::bvh::GpuRay`: `origin + t * dir`, `t` in `[t_min, t_max]`, `dir` unit.
struct QueryRay {
    origin: vec3<f32>,
    t_min: f32,
    dir: vec3<f32>,
    t_max: f32,
}

// Mirror of `gi_cache::GpuCacheRayHit`.
struct QueryHit {
    // Normal of the hit voxel, on the side the ray sees.
    normal: vec3<f32>,
    // Distance to the entry into the hit voxel (t_max on a miss).
    t: f32,
    // Radiance leaving the side the ray sees, emission included.
    radiance: vec3<f32>,
    level: u32,
    face: u32,
    // 1 on a hit, 0 on a miss.
    hit: u32,
    brick_id: u32,
    bit: u32,
    // Side of the hit surfel the ray sees (0 front, 1 back).
    side: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

@group(0) @binding(0) var<storage, read> rays: array<QueryRay>;
@group(0) @binding(1) var<storage, read_write> hits: array<QueryHit>;

// Threads per workgroup of every entry point; batches fold into rows of at most 65535
// workgroups.
const WORKGROUP_SIZE: u32 = 64u;

fn item_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}

fn query_hit(hit: CacheHit, t_min: f32) -> QueryHit {
    return QueryHit(
        cache_hit_normal(hit),
        hit.t + t_min,
        cache_hit_radiance(hit, true),
        hit.level,
        hit.face,
        select(0u, 1u, hit.hit),
        hit.voxel.brick_id,
        hit.voxel.bit,
        hit.side,
        0u,
        0u,
        0u,
    );
}

// Batch queries of the brick radiance cache and its debug views, for tests, benchmarks and
// the `gi debug-cache` command: `trace_rays` (one ray per invocation through `cache_trace`),
// `trace_rays_shared` (the same rays, CACHE_LANES invocations per ray through
// `cache_trace_shared`),
// `irradiance_at` (one surface point per invocation through `cache_irradiance`) and
// `debug_view` (one pixel per invocation through a pinhole camera).
//
// Bind group 0 (`gi_cache::CacheTracer`), its own bindings per entry point so one module
// holds all three (each pipeline's layout lists only its own):
//   trace_rays, trace_rays_shared: binding 0 `rays` (read), binding 1 `hits` (written)
//   irradiance_at: binding 2 `points` (read), binding 3 `irradiance` (written)
//   debug_view:    binding 4 `view` (uniform), binding 5 `pixels` (written, linear rgb + 1)
// Bind group 2 is the cache (`gi::cache::data`).

#import gi::cache::data::{
    cache, cache_voxels, cache_voxel_index, cache_voxel_albedo, cache_side_irradiance,
    cache_face_direction, CACHE_SIDE_FRONT
}
#import gi::cache::trace::{
    CacheHit, cache_trace, cache_hit_radiance, cache_hit_normal, cache_irradiance
}
#import gi::cache::trace_shared::{cache_trace_shared, CACHE_LANES}

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

// Mirror of `gi_cache::GpuIrradianceQuery`.
struct IrradianceQuery {
    position: vec3<f32>,
    pad_a: f32,
    normal: vec3<f32>,
    pad_b: f32,
}

// Mirror of `gi_cache::GpuDebugView`: a pinhole camera and the view to render.
struct DebugViewUniforms {
    position: vec3<f32>,
    tan_half_fov_y: f32,
    right: vec3<f32>,
    aspect: f32,
    up: vec3<f32>,
    width: u32,
    forward: vec3<f32>,
    height: u32,
    // `gi_cache::DebugView` discriminant (DEBUG_* below).
    view: u32,
    t_max: f32,
    pad_a: u32,
    pad_b: u32,
}

const DEBUG_ALBEDO: u32 = 0u;
const DEBUG_NORMAL: u32 = 1u;
const DEBUG_RADIANCE: u32 = 2u;
const DEBUG_IRRADIANCE: u32 = 3u;
const DEBUG_OCCUPANCY: u32 = 4u;
const DEBUG_FACE: u32 = 5u;
const DEBUG_DISTANCE: u32 = 6u;

@group(0) @binding(0) var<storage, read> rays: array<QueryRay>;
@group(0) @binding(1) var<storage, read_write> hits: array<QueryHit>;
@group(0) @binding(2) var<storage, read> points: array<IrradianceQuery>;
@group(0) @binding(3) var<storage, read_write> irradiance: array<vec4<f32>>;
@group(0) @binding(4) var<uniform> view: DebugViewUniforms;
@group(0) @binding(5) var<storage, read_write> pixels: array<vec4<f32>>;

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

@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = item_index(id, groups);
    if i >= arrayLength(&rays) {
        return;
    }
    let ray = rays[i];
    hits[i] = query_hit(cache_trace(ray.origin + ray.dir * ray.t_min, ray.dir, ray.t_max - ray.t_min), ray.t_min);
}

// `trace_rays` with CACHE_LANES invocations per ray (`gi::cache::trace_shared`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays_shared(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = item_index(id, groups) / CACHE_LANES;
    let traced = i < arrayLength(&rays);
    var ray = QueryRay(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0.0);
    if traced {
        ray = rays[i];
    }
    let shared_hit = cache_trace_shared(ray.origin + ray.dir * ray.t_min, ray.dir, ray.t_max - ray.t_min, traced, local_index);
    if traced && shared_hit.owner {
        hits[i] = query_hit(shared_hit.hit, ray.t_min);
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn irradiance_at(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = item_index(id, groups);
    if i >= arrayLength(&points) {
        return;
    }
    irradiance[i] = cache_irradiance(points[i].position, points[i].normal);
}

// A distinct color per level (finest red, then orange, yellow, green, cyan, blue, purple, pink).
fn level_color(level: u32) -> vec3<f32> {
    var colors = array<vec3<f32>, 8>(
        vec3(0.9, 0.2, 0.2), vec3(0.9, 0.55, 0.15), vec3(0.85, 0.85, 0.2), vec3(0.3, 0.8, 0.3),
        vec3(0.2, 0.8, 0.8), vec3(0.25, 0.4, 0.9), vec3(0.6, 0.3, 0.85), vec3(0.9, 0.45, 0.7),
    );
    return colors[min(level, 7u)];
}

// What a pixel shows of a hit. Misses are black in every view.
fn debug_color(hit: CacheHit) -> vec3<f32> {
    let s = cache_voxels[cache_voxel_index(hit.voxel)];
    // Shading by the entered face's orientation makes voxel shapes readable.
    let face_shade = 0.55 + 0.45 * abs(dot(cache_face_direction(hit.face), vec3(0.35, 0.85, 0.4)));
    switch view.view {
        case DEBUG_ALBEDO: {
            return cache_voxel_albedo(s);
        }
        case DEBUG_NORMAL: {
            return cache_hit_normal(hit) * 0.5 + 0.5;
        }
        case DEBUG_RADIANCE: {
            return cache_hit_radiance(hit, true);
        }
        case DEBUG_IRRADIANCE: {
            return cache_side_irradiance(hit.voxel, hit.side);
        }
        case DEBUG_OCCUPANCY: {
            return level_color(hit.level) * face_shade;
        }
        case DEBUG_FACE: {
            // The axis of the entered face in hue, the side seen in brightness.
            return abs(cache_face_direction(hit.face)) * select(0.4, 1.0, hit.side == CACHE_SIDE_FRONT);
        }
        case DEBUG_DISTANCE: {
            return vec3(1.0 / (1.0 + 0.25 * hit.t));
        }
        default: {
            return vec3(1.0, 0.0, 1.0);
        }
    }
}

@compute @workgroup_size(8, 8)
fn debug_view(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= view.width || id.y >= view.height {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(f32(view.width), f32(view.height));
    let x = (2.0 * uv.x - 1.0) * view.tan_half_fov_y * view.aspect;
    let y = (1.0 - 2.0 * uv.y) * view.tan_half_fov_y;
    let dir = normalize(view.forward + x * view.right + y * view.up);
    let hit = cache_trace(view.position, dir, view.t_max);
    var color = vec3(0.0);
    if hit.hit {
        color = debug_color(hit);
    }
    pixels[id.x + id.y * view.width] = vec4(color, 1.0);
}

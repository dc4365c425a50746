// Pass `cache/debug_view` of the cache's batch queries (`gi::cache::query`), for
// `gi debug-cache` (`gi_cache::debug`): one pixel per invocation through a pinhole camera,
// showing what the cache holds along the pixel's ray.
//
// Bind group 0: binding 4 `view` (uniform), binding 5 `pixels` (written, linear rgb + 1).
// Group 2: the cache (`gi::cache::data`).

#import gi::cache::data::{
    cache_voxels, cache_voxel_index, cache_voxel_albedo, cache_side_irradiance,
    cache_face_direction, CACHE_SIDE_FRONT
}
#import gi::cache::trace::{CacheHit, cache_trace, cache_hit_radiance, cache_hit_normal}

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

@group(0) @binding(4) var<uniform> view: DebugViewUniforms;
@group(0) @binding(5) var<storage, read_write> pixels: array<vec4<f32>>;

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

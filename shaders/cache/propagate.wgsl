// Multi-bounce propagation in the brick radiance cache (pass `cache/propagate`): HSGI, GDC 2023,
// "Light Propagation - Indirect Lighting" (hemisphere gather, temporal accumulation) and "Origin
// Geometry" (rays start about one voxel off the surface); SmartGI, SIGGRAPH 2024, "Lighting
// Injection" (multi bounce: each visible face gathers the previous frame's voxel lighting).
//
// One 64-thread workgroup per scheduled brick, one thread per voxel. For every visible face,
// `rays_per_face` cosine-distributed directions about the face normal (the voxel normal flipped
// towards the face) are traced through the cache from the center of the empty neighbour across
// the face. A hit contributes the hit face's radiance (albedo / pi x its direct + indirect
// irradiance, plus the voxel's emission: `cache/inject` adds only punctual lights, so nothing is
// counted twice); a miss contributes the sky. E = pi mean(L) estimates the face's indirect
// irradiance, accumulated over updates with weight 1 / age (age = min(age + 1, max_age)).
//
// Reads of other bricks see what this frame's passes have written so far or last frame's
// values: each update is one more bounce, the order does not bias the fixed point.
//
// Bind group 0: `gi::cache::lighting`; 2: the cache (`gi::cache::data`).

#import gi::math::PI
#import gi::sampling::{Sampler, sampler_new, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::lights::sky_radiance
#import gi::packing::{pack_rgb9e5, unpack_rgb9e5}
#import gi::cache::data::{
    cache, cache_brick_masks, cache_voxels, cache_indirect, VoxelRef, cache_mask_cell,
    cache_mask_test, cache_voxel_index, cache_face_slot, cache_voxel_normal, cache_voxel_age,
    cache_face_direction
}
#import gi::cache::trace::{cache_trace, cache_hit_radiance}
#import gi::cache::lighting::{lighting, scheduled_bricks, face_is_visible, face_normal}

const FAR: f32 = 3.0e38;

// Incoming radiance along `dir` from `origin`: the cache's face radiance with emission, or the
// sky where the ray leaves the cache.
fn incoming_radiance(origin: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let hit = cache_trace(origin, dir, FAR);
    if hit.hit {
        return cache_hit_radiance(hit, true);
    }
    return sky_radiance(lighting.sky, dir);
}

@compute @workgroup_size(64)
fn propagate(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) bit: u32,
) {
    if group.x >= lighting.brick_count {
        return;
    }
    let scheduled = scheduled_bricks[group.x];
    if !cache_mask_test(cache_brick_masks[scheduled.brick_id], bit) {
        return;
    }
    let v = VoxelRef(scheduled.brick_id, bit);
    let size = cache.levels[scheduled.level].voxel_size_m;
    let voxel = scheduled.brick * 4 + vec3<i32>(cache_mask_cell(bit));
    let center = (vec3<f32>(voxel) + 0.5) * size;
    let surface = cache_voxels[cache_voxel_index(v)];
    let n = cache_voxel_normal(surface);
    let age = min(cache_voxel_age(surface) + 1u, lighting.max_age);
    let weight = 1.0 / f32(age);
    let rays = max(lighting.rays_per_face, 1u);
    for (var face = 0u; face < 6u; face++) {
        let slot = cache_face_slot(v, face);
        if !face_is_visible(scheduled.level, voxel, face) {
            cache_indirect[slot] = 0u;
            continue;
        }
        let frame = frame_from_normal(face_normal(n, face));
        let origin = center + cache_face_direction(face) * size;
        var sampler = sampler_new(vec2<u32>(lighting.seed, 0u), slot, lighting.frame_index);
        var sum = vec3<f32>(0.0);
        for (var i = 0u; i < rays; i++) {
            let dir = frame_to_world(frame, cosine_hemisphere(sampler_next_2d(&sampler)));
            sum += incoming_radiance(origin, dir);
        }
        let irradiance = sum * (PI / f32(rays));
        let history = unpack_rgb9e5(cache_indirect[slot]);
        cache_indirect[slot] = pack_rgb9e5(mix(history, irradiance, weight));
    }
    cache_voxels[cache_voxel_index(v)].state = (surface.state & ~0xffu) | age;
}

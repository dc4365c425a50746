// Pass `mobile/probe_trace` of the mobile tier's screen-space passes (`gi::mobile::screen`):
// each fresh probe's 4 x 4-texel hemisphere map: one ray per texel, jittered inside the texel,
// traced through the brick cache (visibility rays instead of VSM); a reprojected probe copies
// its history texels. Each texel keeps the change the cache just measured at its ray's hit
// (the gather's temporal gradient).
//
// Bind group 0: `gi::mobile::screen`'s; 2: the brick cache (`gi::cache::data`).

#import gi::lights::sky_radiance
#import gi::packing::pack_rgb9e5
#import gi::sampling::{sampler_new, sampler_next_2d, frame_from_normal, frame_to_world}
#import gi::cache::data::{cache, cache_level_of_point}
#import gi::cache::trace::{cache_hit_radiance, cache_hit_change}
#import gi::cache::trace_shared::{cache_trace_shared, CACHE_LANES}
#import gi::mobile::screen::{
    uniforms, ScreenProbe, probes, probe_radiance, probe_radiance_prev, PROBE_TEXELS,
    SLOTS_PER_TILE, FAR, PROBE_REPROJECTED, PROBE_SOURCE_SHIFT, pack_probe_ray, probe_ray_unchanged
}

// The direction of hemisphere-map point `s` in [-1, 1]^2 in the probe's local frame (z up),
// unnormalized: the point P of the octahedron face whose density is |P|^3 / 2.
fn hemisphere_point(s: vec2<f32>) -> vec3<f32> {
    let p = vec2(s.x + s.y, s.x - s.y) * 0.5;
    return vec3(p, 1.0 - abs(p.x) - abs(p.y));
}

// One probe texel's ray per CACHE_LANES invocations (`gi::cache::trace_shared`): the pass
// traces a few thousand rays, too few to hide the cache's memory latency one ray per thread.
@compute @workgroup_size(64)
fn trace(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    // Workgroups come in rows of at most 65535.
    let out = (id.x + id.y * groups.x * 64u) / CACHE_LANES;
    let slot = out / PROBE_TEXELS;
    let texel = out % PROBE_TEXELS;
    let valid = slot < uniforms.tiles.x * uniforms.tiles.y * SLOTS_PER_TILE;
    var probe = ScreenProbe(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0u);
    if valid {
        probe = probes[slot];
    }
    let traced = valid && probe.depth > 0.0 && (probe.flags & PROBE_REPROJECTED) == 0u;
    var sampler = sampler_new(uniforms.seed ^ vec2(0x85ebca6bu, 0u), out, uniforms.frame_index);
    let cell = vec2<f32>(vec2(texel % 4u, texel / 4u));
    let s = (cell + sampler_next_2d(&sampler)) * 0.5 - 1.0;
    let point = hemisphere_point(s);
    let length_p = length(point);
    let pdf = 0.5 * length_p * length_p * length_p;
    let frame = frame_from_normal(probe.normal);
    let dir = frame_to_world(frame, point / length_p);
    let level = min(cache_level_of_point(probe.position), cache.level_count - 1u);
    let offset = uniforms.ray_offset_voxels * cache.levels[level].voxel_size_m;
    let shared_hit = cache_trace_shared(probe.position + probe.normal * offset, dir, FAR, traced, local_index);
    if !valid || !shared_hit.owner {
        return;
    }
    if probe.depth <= 0.0 {
        probe_radiance[out] = vec2(0u);
    } else if (probe.flags & PROBE_REPROJECTED) != 0u {
        let source = probe.flags >> PROBE_SOURCE_SHIFT;
        let copied = probe_radiance_prev[source * PROBE_TEXELS + texel];
        probe_radiance[out] = vec2(copied.x, probe_ray_unchanged(copied.y));
    } else {
        var radiance: vec3<f32>;
        if shared_hit.hit.hit {
            radiance = cache_hit_radiance(shared_hit.hit, true);
        } else {
            radiance = sky_radiance(uniforms.sky, dir);
        }
        let change = cache_hit_change(shared_hit.hit);
        probe_radiance[out] = vec2(pack_rgb9e5(radiance / pdf), pack_probe_ray(dir, change));
    }
}

// The BVH ray candidate of a trace pixel, which `trace` draws and `gradient` draws again a
// frame later with the same random numbers: what a cosine-distributed ray from a receiver
// finds (a surface shaded by `gi::pc::restir::hit`, the sky, or in trace-probe mode the brick
// cache beyond the ray's BVH segment).
#define_import_path gi::pc::restir::candidate

#import gi::math::luminance
#import gi::sampling::{Sampler, sampler_new, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::bvh::{Ray, trace_closest, BVH_MISS}
#import gi::lights::{sky_radiance, emitter_pdf}
#import gi::packing::{pack_unit_vector, unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5}
#import gi::cache::data::cache
#import gi::cache::trace::{CacheHit, cache_miss, cache_trace_from, cache_hit_radiance, cache_hit_normal, cache_change}
#import gi::pc::restir::common::{
    uniforms, Reservoir, empty_reservoir, SAMPLE_SKY, FAR, FLAG_HISTORY, GRADIENT_NONE,
    gradient_pick, gradient_seen
}
#import gi::pc::restir::rays::{gradient_samples, gradients, kept_sample_slot}
#import gi::pc::restir::hit::shade_hit
#import gi::pc::restir::hit_cache::hit_lights_from_cache

// Most cache voxels of the receiver's own surface a far-field trace steps over.
const FAR_FIELD_SELF_SKIPS: u32 = 4u;

// Trace-probe mode's far field: the cache traced from the end of the ray's BVH segment (open
// space, so nothing is skipped there). A grazing ray runs inside the coarse voxels of the
// surface it left for a while; hits on voxels of that surface (within two voxels of its
// tangent plane, normal within 45 degrees) are stepped over, or the surface would shade
// itself.
fn trace_far_field(origin: vec3<f32>, dir: vec3<f32>, n: vec3<f32>) -> CacheHit {
    var start = uniforms.probe_ray_m;
    for (var k = 0u; k < FAR_FIELD_SELF_SKIPS; k++) {
        var far = cache_trace_from(origin + dir * start, dir, FAR, false);
        if !far.hit {
            return far;
        }
        far.t += start;
        let size = cache.levels[far.level].voxel_size_m;
        let own_surface = abs(dot(dir * far.t, n)) < 2.0 * size
            && abs(dot(cache_hit_normal(far), n)) > 0.7;
        if !own_surface {
            return far;
        }
        start = far.t + 1.8 * size;
    }
    return cache_miss(FAR);
}

// What the ray along unit `dir` from `origin` (a receiver with normal `n`, offset) finds, as a
// reservoir sample (W and M unset), and the pdf with which the emitter candidate would have
// drawn the same point (0 without emitters, or where the ray found no emitter). A surface
// hit's emitter sample draws from `sampler`.
struct RayCandidate {
    sample: Reservoir,
    pdf_emit: f32,
}

fn ray_candidate(origin: vec3<f32>, dir: vec3<f32>, n: vec3<f32>, sampler: ptr<function, Sampler>) -> RayCandidate {
    var r = empty_reservoir();
    var pdf_emit = 0.0;
    let emitters_on = uniforms.emitter_count > 0u;
    let hit = trace_closest(Ray(origin, 0.0, dir, uniforms.probe_ray_m));
    var far = cache_miss(0.0);
    if hit.triangle == BVH_MISS && uniforms.probe_ray_m < FAR {
        far = trace_far_field(origin, dir, n);
    }
    if far.hit {
        // The cache's emission stays out when emitter samples cover the emitters.
        r.position = origin + dir * far.t;
        r.radiance = pack_rgb9e5(cache_hit_radiance(far, !emitters_on));
        r.normal = pack_unit_vector(cache_hit_normal(far));
        r.fixed_radiance = r.radiance;
    } else if hit.triangle == BVH_MISS {
        r.position = dir;
        r.radiance = pack_rgb9e5(sky_radiance(uniforms.sky, dir));
        r.flags = SAMPLE_SKY;
    } else {
        let shaded = shade_hit(dir, hit.t, hit.triangle, hit.barycentrics, sampler, hit_lights_from_cache());
        r.position = shaded.position;
        r.radiance = pack_rgb9e5(shaded.radiance);
        r.normal = pack_unit_vector(shaded.normal);
        r.fixed_radiance = pack_rgb9e5(shaded.fixed_radiance);
        r.albedo = pack4x8unorm(vec4(shaded.albedo, 0.0));
        if emitters_on {
            pdf_emit = emitter_pdf(hit.triangle, hit.t, dir);
        }
    }
    return RayCandidate(r, pdf_emit);
}

// The temporal gradient of `stratum` (`pc/restir/gradient.wgsl` explains them): draws again
// the ray candidate one of its trace pixels kept last frame, with that frame's random numbers
// (the same direction, emitter sample and shadow rays), and stores the change of what it
// finds (x) and the larger of the two luminances of all it finds (y). The change counts what it
// finds outside the brick cache (`gradient_seen`), and the cache's light only where the cache
// measured a change at the hit in this lighting update or the last (`cache_change`): the
// cache's light changes every frame by its updates' noise, which must not cut history in a
// still scene, where every measured change is exactly 0. `trace` runs it in extra workgroups
// of its own dispatch, where the other rays hide its latency.
fn draw_gradient(stratum: vec2<u32>) {
    if any(stratum >= vec2(uniforms.gradient_strata_x, uniforms.gradient_strata_y)) {
        return;
    }
    let s = stratum.y * uniforms.gradient_strata_x + stratum.x;
    var change = vec4(0.0);
    let previous = uniforms.frame_index - 1u;
    let kept = gradient_samples[kept_sample_slot(stratum, previous)];
    // The sample must be last frame's pick of this stratum (a stratum whose pick fell outside
    // the image, or showed the sky, kept none).
    let t = gradient_pick(stratum, previous);
    let picked = all(t < uniforms.trace_px) && kept.trace_index == t.y * uniforms.trace_px.x + t.x;
    if (uniforms.flags & FLAG_HISTORY) != 0u && kept.trace_index != GRADIENT_NONE
        && kept.frame_index == previous && picked {
        // `trace`'s random numbers of that frame and trace pixel, in its order.
        var sampler = sampler_new(uniforms.seed, kept.trace_index, previous);
        let n = unpack_unit_vector(kept.normal);
        let local = cosine_hemisphere(sampler_next_2d(&sampler));
        let dir = frame_to_world(frame_from_normal(n), local);
        let candidate = ray_candidate(kept.origin, dir, n, &sampler);
        let found = candidate.sample;
        let total = luminance(unpack_rgb9e5(found.radiance));
        let seen = gradient_seen(found);
        // The cache's light the ray found, new minus old, where the cache measured a change at
        // the hit in this update or the last. A shaded hit's is all but `gradient_seen`; a
        // far-field hit (no albedo) is all cache, and `gradient_seen` already compares it.
        var cached = 0.0;
        let shaded_hit = (found.flags & SAMPLE_SKY) == 0u && found.albedo != 0u;
        if shaded_hit && cache_change(found.position, unpack_unit_vector(found.normal)) > 0.0 {
            cached = (total - seen) - (kept.total - kept.seen);
        }
        change = vec4(seen - kept.seen + cached, max(total, kept.total), 0.0, 0.0);
    }
    gradients[s] = change;
}

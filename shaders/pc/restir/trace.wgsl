// Pass `pc/trace`, the PC tier's diffuse rays (HSGI, GDC 2023, "PC / Console Solution":
// hardware ray tracing, here the software CWBVH of `gi::bvh` standing in for it), one
// invocation per trace pixel: picks one full-resolution pixel of its block (jittered per frame:
// HSGI's "canonical sample coverage, 2x2 jitter") as the receiver, traces one
// cosine-distributed ray from it through the BVH and shades the hit (`gi::pc::restir::hit`); a
// miss sees the sky. With emissive triangles in the scene a second candidate is a point drawn
// on them (next-event estimation); the two are combined by RIS into the pixel's initial
// reservoir (M = 1).
// In trace-probe mode (HSGI's "trace probe": a short ray, then radiance from probes) the BVH
// ray stops after `probe_ray_m`; past that the brick cache is traced from the segment's end and
// its radiance taken where it hits, the cache's voxels standing in for HSGI's probes.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), bindings 1-7 the scene
// (`gi::scene`), then the buffers of `gi::pc::restir::rays`. Group 1: the BVH (`gi::bvh`).
// Group 2: the cache (`gi::cache::data`).

#import gi::math::{INV_PI, luminance}
#import gi::sampling::{sampler_new, sampler_next_f32, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::bvh::{Ray, trace_closest, BVH_MISS}
#import gi::lights::{sky_radiance, emitter_pdf}
#import gi::packing::{pack_unit_vector, unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5}
#import gi::cache::data::cache
#import gi::cache::trace::{CacheHit, cache_miss, cache_trace_from, cache_hit_radiance, cache_hit_normal}
#import gi::pc::restir::common::{
    uniforms, Surface, empty_reservoir, is_sky_depth, has_surface, pixel_point, store_reservoir,
    SAMPLE_SKY, FAR
}
#import gi::pc::restir::rays::{gbuffer_depth, gbuffer_normal, store_surface, initial, offset_origin}
#import gi::pc::restir::hit::{shade_hit, visible_emitter_sample}
#import gi::pc::restir::hit_cache::hit_lights_from_cache

// The receiver of trace pixel `t`: the first pixel of its block, starting at a per-frame
// jittered one, that shows a surface.
fn pick_receiver(t: vec2<u32>, index: u32) -> Surface {
    let scale = uniforms.trace_scale;
    let count = scale * scale;
    var sampler = sampler_new(uniforms.seed ^ vec2(0x2545f491u, 0u), index, uniforms.frame_index);
    let start = min(u32(sampler_next_2d(&sampler).x * f32(count)), count - 1u);
    for (var k = 0u; k < count; k++) {
        let o = (start + k) % count;
        let p = t * scale + vec2(o % scale, o / scale);
        if any(p >= uniforms.size_px) {
            continue;
        }
        let pixel = p.y * uniforms.size_px.x + p.x;
        let depth = gbuffer_depth[pixel];
        if is_sky_depth(depth) {
            continue;
        }
        return Surface(pixel_point(uniforms.camera, p, depth), gbuffer_normal[pixel], pixel, depth);
    }
    return Surface(vec3(0.0), 0u, 0u, 0.0);
}

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

// Initial candidates, two strategies combined by resampled importance sampling (Talbot et al.
// 2005; Bitterli et al. 2020 use it for ReSTIR's initial candidates) with balance-heuristic
// MIS weights: one cosine-distributed BVH ray (what ReSTIR GI traces), and one point drawn on
// the scene's emitters by their power with a shadow ray (next-event estimation: a small bright
// emitter that lights the receiver directly is found by every pixel instead of by the rare ray
// that hits it). Candidate y_i gets the weight p(y_i) / (p_cos(y_i) + p_emit(y_i)); the kept
// one has W = (sum of weights) / p(kept).
@compute @workgroup_size(8, 8)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.trace_px) {
        return;
    }
    let index = id.y * uniforms.trace_px.x + id.x;
    let s = pick_receiver(id.xy, index);
    store_surface(index, s);
    if !has_surface(s) {
        initial[index] = store_reservoir(empty_reservoir());
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let origin = offset_origin(s.position, n);
    let emitters_on = uniforms.emitter_count > 0u;
    var sampler = sampler_new(uniforms.seed, index, uniforms.frame_index);
    var weight_sum = 0.0;
    var chosen = empty_reservoir();
    var chosen_pdf = 0.0;

    // The BVH ray.
    let local = cosine_hemisphere(sampler_next_2d(&sampler));
    let dir = frame_to_world(frame_from_normal(n), local);
    let pdf_cos = local.z * INV_PI;
    if pdf_cos > 0.0 {
        var r = empty_reservoir();
        var pdf_emit = 0.0;
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
            let shaded = shade_hit(dir, hit.t, hit.triangle, hit.barycentrics, &sampler, hit_lights_from_cache());
            r.position = shaded.position;
            r.radiance = pack_rgb9e5(shaded.radiance);
            r.normal = pack_unit_vector(shaded.normal);
            r.fixed_radiance = pack_rgb9e5(shaded.fixed_radiance);
            r.albedo = pack4x8unorm(vec4(shaded.albedo, 0.0));
            if emitters_on {
                pdf_emit = emitter_pdf(hit.triangle, hit.t, dir);
            }
        }
        let p = luminance(unpack_rgb9e5(r.radiance)) * local.z;
        let w = p / (pdf_cos + pdf_emit);
        if w > 0.0 && w < FAR {
            weight_sum += w;
            chosen = r;
            chosen_pdf = p;
        }
    }

    // The emitter sample.
    if emitters_on {
        let light = visible_emitter_sample(s.position, n, origin, &sampler);
        if light.pdf > 0.0 {
            let cos_x = dot(light.wi, n);
            var r = empty_reservoir();
            r.position = s.position + light.wi * light.distance;
            r.radiance = pack_rgb9e5(light.radiance);
            r.normal = pack_unit_vector(light.normal);
            r.fixed_radiance = pack_rgb9e5(light.radiance);
            let p = luminance(unpack_rgb9e5(r.radiance)) * cos_x;
            // The BVH ray reaches emitters within its segment only.
            let pdf_ray = select(0.0, cos_x * INV_PI, light.distance <= uniforms.probe_ray_m);
            let w = p / (pdf_ray + light.pdf);
            if w > 0.0 && w < FAR {
                weight_sum += w;
                if sampler_next_f32(&sampler) * weight_sum < w {
                    chosen = r;
                    chosen_pdf = p;
                }
            }
        }
    }
    if chosen_pdf > 0.0 {
        chosen.w = weight_sum / chosen_pdf;
        chosen.m = 1.0;
    } else {
        chosen = empty_reservoir();
        chosen.m = 1.0;
    }
    initial[index] = store_reservoir(chosen);
}

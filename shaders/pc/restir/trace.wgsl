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
#import gi::packing::{pack_unit_vector, unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5}
#import gi::pc::restir::common::{
    uniforms, Surface, empty_reservoir, is_sky_depth, has_surface, pixel_point, store_reservoir, FAR,
    gradient_seen
}
#import gi::pc::restir::rays::{
    gbuffer_depth, gbuffer_normal, store_surface, initial, offset_origin, store_gradient_sample,
    clear_gradient_sample
}
#import gi::pc::restir::hit::visible_emitter_sample
#import gi::pc::restir::candidate::{ray_candidate, draw_gradient}

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

// Initial candidates, two strategies combined by resampled importance sampling (Talbot et al.
// 2005; Bitterli et al. 2020 use it for ReSTIR's initial candidates) with balance-heuristic
// MIS weights: one cosine-distributed BVH ray (what ReSTIR GI traces), and one point drawn on
// the scene's emitters by their power with a shadow ray (next-event estimation: a small bright
// emitter that lights the receiver directly is found by every pixel instead of by the rare ray
// that hits it). Candidate y_i gets the weight p(y_i) / (p_cos(y_i) + p_emit(y_i)); the kept
// one has W = (sum of weights) / p(kept). The BVH ray's candidate of one trace pixel per
// temporal-gradient stratum is kept to be drawn again next frame (`draw_gradient`, in the
// dispatch's extra rows of workgroups).
@compute @workgroup_size(8, 8)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    // The workgroup rows below the trace pixels' draw last frame's kept rays again, one per
    // temporal-gradient stratum.
    let trace_rows = (uniforms.trace_px.y + 7u) / 8u * 8u;
    if id.y >= trace_rows {
        draw_gradient(vec2(id.x, id.y - trace_rows));
        return;
    }
    if any(id.xy >= uniforms.trace_px) {
        return;
    }
    let index = id.y * uniforms.trace_px.x + id.x;
    let s = pick_receiver(id.xy, index);
    store_surface(index, s);
    if !has_surface(s) {
        clear_gradient_sample(id.xy);
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
        let candidate = ray_candidate(origin, dir, n, &sampler);
        let r = candidate.sample;
        let seen = gradient_seen(r);
        store_gradient_sample(id.xy, index, origin, s.normal, seen, luminance(unpack_rgb9e5(r.radiance)));
        let p = luminance(unpack_rgb9e5(r.radiance)) * local.z;
        let w = p / (pdf_cos + candidate.pdf_emit);
        if w > 0.0 && w < FAR {
            weight_sum += w;
            chosen = r;
            chosen_pdf = p;
        }
    } else {
        clear_gradient_sample(id.xy);
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

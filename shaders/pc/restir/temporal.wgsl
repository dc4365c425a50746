// Pass `pc/temporal`, ReSTIR GI's temporal reuse (Ouyang et al. 2021, with HSGI's changes,
// GDC 2023, "PC / Console Solution"), only with temporal reuse (off by default:
// `gi_tiers::pc::RestirConfig::temporal` says why), per trace pixel: the initial reservoir
// combined with the previous frame's temporal reservoir of the same surface (found by the
// G-buffer's motion vector, checked by normal and tangent-plane distance), its M clamped to
// `m_clamp` (5) and its sample moved to this receiver with the reconnection shift's bounded
// Jacobian; then the boiling filter (a reservoir whose weight exceeds `boil_factor` times its
// workgroup's mean restarts from its initial sample). Its result is next frame's history.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`. Group 2: the cache (`gi::cache::data`), read to refresh reused
// samples.

#import gi::math::INV_PI
#import gi::sampling::{sampler_new, sampler_next_f32}
#import gi::packing::{unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5}
#import gi::pc::restir::hit_cache::{hit_cache_irradiance, hit_lights_from_cache}
#import gi::pc::restir::bindings::{gbuffer_motion, load_surface, load_surface_prev, initial, temporal_out, temporal_prev, trace_index}
#import gi::pc::restir::common::{
    uniforms, Surface, Reservoir, empty_reservoir, has_surface, target_pdf, reconnection_jacobian,
    combiner_new, combiner_add, combiner_finish, similar_surfaces, SAMPLE_SKY, FLAG_TEMPORAL,
    FLAG_BOILING, FLAG_HISTORY, load_reservoir, store_reservoir
}

// Trace pixel of the previous frame that held receiver `s`, or -1: the G-buffer's motion
// vector of `s`'s pixel gives where the surface was; of the 3 x 3 trace pixels around that
// point, the nearest whose previous receiver lies on the same surface.
fn previous_trace_pixel(s: Surface) -> i32 {
    let p = vec2(s.pixel % uniforms.size_px.x, s.pixel / uniforms.size_px.x);
    let before = vec2<f32>(p) + 0.5 + gbuffer_motion[s.pixel];
    let t = before / f32(uniforms.trace_scale);
    let center = vec2<i32>(floor(t));
    var best = -1;
    var best_d = 1e30;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = center + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(uniforms.trace_px)) {
                continue;
            }
            let i = trace_index(vec2<u32>(q));
            if !similar_surfaces(s, load_surface_prev(i), uniforms.normal_cos, uniforms.plane_tolerance) {
                continue;
            }
            let d = length(vec2<f32>(q) + 0.5 - t);
            if d < best_d {
                best_d = d;
                best = i32(i);
            }
        }
    }
    return best;
}

// `r` with its surface sample's indirect part read again from the cache: the radiance a
// reservoir stored frames ago lags the cache while the cache converges (from below, after a
// fill or a light change), and reusing it would darken the image by that lag.
fn refreshed(r: Reservoir) -> Reservoir {
    if (r.flags & SAMPLE_SKY) != 0u || r.albedo == 0u || r.w <= 0.0 {
        return r;
    }
    var out = r;
    let albedo = unpack4x8unorm(r.albedo).xyz;
    let indirect = hit_cache_irradiance(r.position, unpack_unit_vector(r.normal), hit_lights_from_cache());
    out.radiance = pack_rgb9e5(unpack_rgb9e5(r.fixed_radiance) + albedo * INV_PI * indirect);
    return out;
}

var<workgroup> boil_weight: array<f32, 64>;

@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let inside = all(id.xy < uniforms.trace_px);
    var index = 0u;
    var first = empty_reservoir();
    var r = empty_reservoir();
    var weight = -1.0;
    if inside {
        index = trace_index(id.xy);
        let s = load_surface(index);
        first = load_reservoir(initial[index]);
        if has_surface(s) {
            let n = unpack_unit_vector(s.normal);
            var sampler = sampler_new(uniforms.seed ^ vec2(0x9e3779b9u, 0u), index, uniforms.frame_index);
            var c = combiner_new();
            combiner_add(&c, first, 1.0, target_pdf(first, s.position, n), 1.0, sampler_next_f32(&sampler));
            let history = FLAG_TEMPORAL | FLAG_HISTORY;
            if (uniforms.flags & history) == history {
                let prev = previous_trace_pixel(s);
                if prev >= 0 {
                    let rp = refreshed(load_reservoir(temporal_prev[prev]));
                    let source = load_surface_prev(u32(prev)).position;
                    let j = reconnection_jacobian(rp, source, s.position, uniforms.jacobian_max);
                    combiner_add(&c, rp, min(rp.m, uniforms.m_clamp), target_pdf(rp, s.position, n), j, sampler_next_f32(&sampler));
                }
            }
            r = combiner_finish(c);
            weight = c.chosen_pdf * r.w;
        }
    }
    // Boiling filter (Ouyang et al. 2021, 5.4): a reservoir far brighter than its
    // neighbourhood's mean is a firefly about to spread through reuse; it restarts.
    if (uniforms.flags & FLAG_BOILING) != 0u {
        boil_weight[local] = weight;
        workgroupBarrier();
        var sum = 0.0;
        var count = 0.0;
        for (var i = 0u; i < 64u; i++) {
            let w = boil_weight[i];
            if w >= 0.0 {
                sum += w;
                count += 1.0;
            }
        }
        if weight > 0.0 && weight > uniforms.boil_factor * sum / max(count, 1.0) {
            r = first;
        }
    }
    if inside {
        temporal_out[index] = store_reservoir(r);
    }
}

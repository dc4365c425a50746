// The PC tier's reservoir passes and shading (ReSTIR GI, Ouyang et al. 2021, with HSGI's
// changes, GDC 2023, "PC / Console Solution"):
//   - `temporal` (pass `pc/temporal`, only with temporal reuse, off by default:
//     `gi_tiers::pc::RestirConfig::temporal` says why), per trace pixel: the initial
//     reservoir combined with the previous frame's temporal reservoir of the same surface (found by the G-buffer's motion
//     vector, checked by normal and tangent-plane distance), its M clamped to `m_clamp` (5)
//     and its sample moved to this receiver with the reconnection shift's bounded Jacobian; then
//     the boiling filter (a reservoir whose weight exceeds `boil_factor` times its workgroup's
//     mean restarts from its initial sample). Its result is next frame's history.
//   - `spatial` (pass `pc/spatial`), per trace pixel, from the temporal reservoirs or without
//     temporal reuse the initial ones: `spatial_samples` neighbours within
//     `spatial_radius` trace pixels, kept when they lie on the same surface (heuristic
//     selection by normal and plane distance), combined with the Jacobian and no visibility
//     (the biased reuse; the shadow pass restores visibility).
//   - `shade` (pass `pc/shade`), per full-resolution pixel, HSGI's multi-sample shading: the
//     pixel is shaded from the reservoirs of the trace pixels whose centers lie within
//     `shade_radius` trace pixels (per axis) of its own center (at trace scale 2, the 2 x 2
//     nearest it, each pixel of a 2 x 2 block its own), whose receiver lies on its surface
//     and that pass the shadow test (HSGI's "post spatial reuse" neighbour rule, applied here
//     at shading time) and whose sample lies at least `shade_contact_ratio` times the two
//     receivers' distance from its own receiver (near contacts a neighbour's short ray sees
//     another scene), each an estimate of its irradiance through the reconnection shift;
//     their mean is the noisy, demodulated irradiance the denoiser filters. It also upsamples
//     the trace resolution to full. On a rough pixel (from `specular_max_roughness` up) the
//     estimates of the wider (2 shade_radius + 1)^2 trace pixels around its own, weighted by
//     the pixel's specular lobe, give HSGI's reuse of the diffuse result for the reflection:
//     the ratio of the lobe-weighted light to the light, per channel, which
//     `pc/specular.wgsl` accumulates over time. (A ratio of two sums over the same samples:
//     more samples make it less biased, and their shared noise cancels in it. The irradiance
//     from all of the 3 x 3 shared most of its reservoirs between neighbouring pixels, noise
//     the denoiser's spatial filter barely removes: on cornell-box its error was 1.5% higher.)
//   - `compose` (pass `pc/compose`): direct light plus the diffuse albedo times the denoised
//     irradiance over pi, plus the split-sum specular albedo times the reflected radiance: the
//     traced specular (`pc/specular.wgsl`) on smooth surfaces, blended to the irradiance over
//     pi between 0.75 and 1 times `specular_max_roughness`; on rough ones the irradiance over
//     pi times the accumulated lobe ratio, blended to 1 from `specular_diffuse_from` to
//     roughness 1.
//
// Bind group 0: binding 0 `u` (`gi::pc::common::PcUniforms`), then the buffers of
// `gi::pc::restir_bindings` (each described there). Group 2: the cache (`gi::cache::data`),
// read by `temporal` to refresh reused samples.

#import gi::math::{PI, INV_PI}
#import gi::brdf::{brdf_new, specular_albedo, ggx_lobe, gbuffer_brdf, brdf_split_sum_albedos}
#import gi::sampling::{sampler_new, sampler_next_f32, sampler_next_2d, concentric_disk, Frame, frame_from_normal, frame_to_local}
#import gi::camera::camera_ray
#import gi::packing::{unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5, pack_color64, unpack_color64}
#import gi::cache::trace::{cache_bounced_irradiance, cache_blend_layer_gi}
#import gi::pc::restir_bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_base_color, gbuffer_metallic_roughness,
    gbuffer_motion, surfaces, surfaces_prev, initial, temporal_out, temporal_prev, resolved,
    irradiance, denoised, direct_mean, output, specular_noisy, specular_history,
    gbuffer_emissive, gbuffer_blend_layer
}
#import gi::pc::common::{
    PcUniforms, Surface, Reservoir, Combiner, empty_reservoir, is_sky_depth, has_surface,
    target_pdf, reconnection_jacobian, combiner_new, combiner_add, combiner_finish,
    reservoir_irradiance, similar_surfaces, sample_direction, specular_kind, SAMPLE_OCCLUDED, SAMPLE_SKY,
    FLAG_TEMPORAL, FLAG_SPATIAL, FLAG_SHADOW, FLAG_MULTI_SAMPLE, FLAG_BOILING, FLAG_HISTORY, FLAG_MATERIAL_OCCLUSION, FLAG_BLEND_LAYER,
    SPECULAR_NONE, SPECULAR_TRACED, SPECULAR_REUSED
}

@group(0) @binding(0) var<uniform> u: PcUniforms;

fn trace_index(t: vec2<u32>) -> u32 {
    return t.y * u.trace_px.x + t.x;
}

// ---------------------------------------------------------------------------------------------
// temporal
// ---------------------------------------------------------------------------------------------

// Trace pixel of the previous frame that held receiver `s`, or -1: the G-buffer's motion
// vector of `s`'s pixel gives where the surface was; of the 3 x 3 trace pixels around that
// point, the nearest whose previous receiver lies on the same surface.
fn previous_trace_pixel(s: Surface) -> i32 {
    let p = vec2(s.pixel % u.size_px.x, s.pixel / u.size_px.x);
    let before = vec2<f32>(p) + 0.5 + gbuffer_motion[s.pixel];
    let t = before / f32(u.trace_scale);
    let center = vec2<i32>(floor(t));
    var best = -1;
    var best_d = 1e30;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = center + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(u.trace_px)) {
                continue;
            }
            let i = trace_index(vec2<u32>(q));
            if !similar_surfaces(s, surfaces_prev[i], u.normal_cos, u.plane_tolerance) {
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
    let indirect = cache_bounced_irradiance(r.position, unpack_unit_vector(r.normal)).xyz;
    out.radiance = pack_rgb9e5(unpack_rgb9e5(r.fixed_radiance) + albedo * INV_PI * indirect);
    return out;
}

var<workgroup> boil_weight: array<f32, 64>;

@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let inside = all(id.xy < u.trace_px);
    var index = 0u;
    var first = empty_reservoir();
    var r = empty_reservoir();
    var weight = -1.0;
    if inside {
        index = trace_index(id.xy);
        let s = surfaces[index];
        first = initial[index];
        if has_surface(s) {
            let n = unpack_unit_vector(s.normal);
            var sampler = sampler_new(u.seed ^ vec2(0x9e3779b9u, 0u), index, u.frame_index);
            var c = combiner_new();
            combiner_add(&c, first, 1.0, target_pdf(first, s.position, n), 1.0, sampler_next_f32(&sampler));
            let history = FLAG_TEMPORAL | FLAG_HISTORY;
            if (u.flags & history) == history {
                let prev = previous_trace_pixel(s);
                if prev >= 0 {
                    let rp = refreshed(temporal_prev[prev]);
                    let source = surfaces_prev[prev].position;
                    let j = reconnection_jacobian(rp, source, s.position, u.jacobian_max);
                    combiner_add(&c, rp, min(rp.m, u.m_clamp), target_pdf(rp, s.position, n), j, sampler_next_f32(&sampler));
                }
            }
            r = combiner_finish(c);
            weight = c.chosen_pdf * r.w;
        }
    }
    // Boiling filter (Ouyang et al. 2021, 5.4): a reservoir far brighter than its
    // neighbourhood's mean is a firefly about to spread through reuse; it restarts.
    if (u.flags & FLAG_BOILING) != 0u {
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
        if weight > 0.0 && weight > u.boil_factor * sum / max(count, 1.0) {
            r = first;
        }
    }
    if inside {
        temporal_out[index] = r;
    }
}

// ---------------------------------------------------------------------------------------------
// spatial
// ---------------------------------------------------------------------------------------------

// The reservoir the spatial reuse starts from at trace pixel `i`.
fn reuse_source(i: u32) -> Reservoir {
    if (u.flags & FLAG_TEMPORAL) != 0u {
        return temporal_out[i];
    }
    return initial[i];
}

@compute @workgroup_size(8, 8)
fn spatial(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.trace_px) {
        return;
    }
    let index = trace_index(id.xy);
    let s = surfaces[index];
    if !has_surface(s) {
        resolved[index] = empty_reservoir();
        return;
    }
    let n = unpack_unit_vector(s.normal);
    var sampler = sampler_new(u.seed ^ vec2(0x7f4a7c15u, 0u), index, u.frame_index);
    var c = combiner_new();
    let own = reuse_source(index);
    combiner_add(&c, own, own.m, target_pdf(own, s.position, n), 1.0, sampler_next_f32(&sampler));
    for (var k = 0u; k < u.spatial_samples; k++) {
        let offset = concentric_disk(sampler_next_2d(&sampler)) * u.spatial_radius;
        let u_select = sampler_next_f32(&sampler);
        let q = vec2<i32>(id.xy) + vec2<i32>(round(offset));
        if any(q < vec2(0)) || any(q >= vec2<i32>(u.trace_px)) || all(q == vec2<i32>(id.xy)) {
            continue;
        }
        let qi = trace_index(vec2<u32>(q));
        let sq = surfaces[qi];
        if !similar_surfaces(s, sq, u.normal_cos, u.plane_tolerance) {
            continue;
        }
        let rq = reuse_source(qi);
        let j = reconnection_jacobian(rq, sq.position, s.position, u.jacobian_max);
        combiner_add(&c, rq, rq.m, target_pdf(rq, s.position, n), j, u_select);
    }
    resolved[index] = combiner_finish(c);
}

// ---------------------------------------------------------------------------------------------
// shade
// ---------------------------------------------------------------------------------------------

// HSGI's shadow condition for reusing neighbour reservoir `nb` at a pixel whose own trace
// pixel's reservoir is `center`, at receiver `x`: both visible, accept; one occluded and the
// other not, reject; both occluded, reject when the neighbour's sample lies within the cone
// (`shadow_cos`) of the centre's occluded direction and beyond `shadow_distance_ratio` times the
// centre's occluder distance (behind the occluder), accept otherwise.
fn shadow_compatible(center: Reservoir, nb: Reservoir, x: vec3<f32>) -> bool {
    let center_occluded = (center.flags & SAMPLE_OCCLUDED) != 0u;
    let nb_occluded = (nb.flags & SAMPLE_OCCLUDED) != 0u;
    if center_occluded != nb_occluded {
        return false;
    }
    if !center_occluded {
        return true;
    }
    let d = sample_direction(nb, x);
    let toward = dot(unpack_unit_vector(center.occluder_direction), d.xyz) > u.shadow_cos;
    return !(toward && d.w > u.shadow_distance_ratio * center.occluder_distance);
}

// A rough pixel's specular lobe for the reused reflection (HSGI's "reuse diffuse tracing
// result"): the lobe without Fresnel times the cosine, `D G2 / (4 n.v)`, in the frame of the
// normal, and `pi` over its albedo, so that light arriving alike from every direction gives
// a ratio of 1.
struct Lobe {
    frame: Frame,
    wo: vec3<f32>,
    a2: f32,
    scale: f32,
}

fn lobe_new(n: vec3<f32>, v: vec3<f32>, roughness: f32) -> Lobe {
    let frame = frame_from_normal(n);
    let alpha = brdf_new(vec3(0.0), 0.0, roughness).alpha;
    let n_dot_v = dot(n, v);
    let albedo = specular_albedo(vec3(1.0), 1.0, roughness, n_dot_v).x;
    return Lobe(frame, frame_to_local(frame, v), alpha * alpha, PI / max(albedo, 1e-4));
}

// The lobe's weight of a sample arriving from `d`, relative to the cosine's.
fn lobe_weight(l: Lobe, d: vec3<f32>) -> f32 {
    let wi = frame_to_local(l.frame, d);
    if wi.z <= 0.0 || l.wo.z <= 0.0 {
        return 0.0;
    }
    return ggx_lobe(normalize(l.wo + wi), l.wo.z, wi.z, l.a2) * l.scale;
}

@compute @workgroup_size(8, 8)
fn shade(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    if is_sky_depth(depth) {
        irradiance[pixel] = vec4(0.0);
        specular_noisy[pixel] = vec2(0u);
        return;
    }
    let kind = specular_kind(u.flags, u.specular_max_roughness, depth, gbuffer_metallic_roughness[pixel].y);
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(u.size_px);
    let ray = camera_ray(u.camera, uv);
    let x = u.camera.position + ray * depth;
    let me = Surface(x, gbuffer_normal[pixel], pixel, depth, 0u, 0u);
    let n = unpack_unit_vector(me.normal);
    let t = vec2<i32>(id.xy / u.trace_scale);
    let center_index = trace_index(vec2<u32>(t));
    let center = resolved[center_index];
    var radius = 0;
    if (u.flags & FLAG_MULTI_SAMPLE) != 0u {
        radius = i32(u.shade_radius);
    }
    let shadow_test = (u.flags & FLAG_SHADOW) != 0u;
    let reused = kind == SPECULAR_REUSED;
    var lobe: Lobe;
    if reused {
        lobe = lobe_new(n, -ray, gbuffer_metallic_roughness[pixel].y);
    }
    // This pixel's center in trace pixels: the irradiance's reservoirs lie within `radius`
    // of it (per axis), a subset of the (2 radius + 1)^2 around its own trace pixel.
    let c = (vec2<f32>(id.xy) + 0.5) / f32(u.trace_scale) - 0.5;
    var sum = vec3(0.0);
    var count = 0.0;
    var lobe_sum = vec3(0.0);
    var lobe_light = vec3(0.0);
    for (var dy = -radius; dy <= radius; dy++) {
        for (var dx = -radius; dx <= radius; dx++) {
            let q = t + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(u.trace_px)) {
                continue;
            }
            // Only a rough pixel's reflection ratio reads the trace pixels beyond the nearest.
            let near = radius == 0 || all(abs(vec2<f32>(q) - c) <= vec2(f32(radius) + 1e-3));
            if !near && !reused {
                continue;
            }
            let qi = trace_index(vec2<u32>(q));
            let sq = surfaces[qi];
            if !similar_surfaces(me, sq, u.normal_cos, u.plane_tolerance) {
                continue;
            }
            let rq = resolved[qi];
            if qi != center_index {
                if shadow_test && !shadow_compatible(center, rq, x) {
                    continue;
                }
                let reach = sample_direction(rq, sq.position).w;
                if reach < u.shade_contact_ratio * distance(sq.position, x) {
                    continue;
                }
            }
            let e = reservoir_irradiance(rq, sq.position, x, n, u.jacobian_max);
            if near {
                sum += e;
                count += 1.0;
            }
            if reused {
                lobe_light += e;
                lobe_sum += e * lobe_weight(lobe, sample_direction(rq, x).xyz);
            }
        }
    }
    if count == 0.0 {
        // No trace pixel nearby lies on this surface (a thin or small feature): the own one's
        // sample, whatever surface it was drawn for.
        let s = surfaces[center_index];
        if has_surface(s) {
            sum = reservoir_irradiance(center, s.position, x, n, u.jacobian_max);
            if reused {
                lobe_light = sum;
                lobe_sum = sum * lobe_weight(lobe, sample_direction(center, x).xyz);
            }
        }
        count = 1.0;
    }
    irradiance[pixel] = vec4(sum / count, 1.0);
    // The reused reflection's ratio, per channel: the lobe-weighted light over the light
    // (1 where no light arrived, or where the shading normal faces away from the view, as at
    // a smooth-shaded silhouette: nothing to reshape, no lobe to reshape it by).
    if reused {
        let lit = sum > vec3(0.0) & vec3(dot(n, -ray) > 0.0);
        let ratio = select(vec3(1.0), lobe_sum / max(lobe_light, vec3(1e-30)), lit);
        specular_noisy[pixel] = pack_color64(ratio, f32(SPECULAR_REUSED));
    } else if kind == SPECULAR_NONE {
        specular_noisy[pixel] = vec2(0u);
    }
}

// ---------------------------------------------------------------------------------------------
// compose
// ---------------------------------------------------------------------------------------------

@compute @workgroup_size(8, 8)
fn compose(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    let direct = direct_mean[pixel].xyz;
    let depth = gbuffer_depth[pixel];
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(u.size_px);
    let v = -camera_ray(u.camera, uv);
    if is_sky_depth(depth) {
        var gi = vec3(0.0);
        if (u.flags & FLAG_BLEND_LAYER) != 0u {
            gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], u.camera.position, -v, gi);
        }
        output[pixel] = vec4(direct + gi, 1.0);
        return;
    }
    let n = unpack_unit_vector(gbuffer_normal[pixel]);
    let mr = gbuffer_metallic_roughness[pixel];
    let albedos = brdf_split_sum_albedos(gbuffer_brdf(gbuffer_base_color[pixel], mr), max(dot(n, v), 0.0));
    let diffuse = albedos.diffuse;
    let specular = albedos.specular;
    let e = max(denoised[pixel].xyz, vec3(0.0));
    var reflected = e * INV_PI;
    let max_roughness = u.specular_max_roughness;
    let kind = specular_kind(u.flags, max_roughness, depth, mr.y);
    if kind != SPECULAR_NONE {
        let h = unpack_color64(specular_history[pixel].xy);
        if h.w > 0.0 && kind == SPECULAR_TRACED {
            let t = 1.0 - smoothstep(0.75 * max_roughness, max_roughness, mr.y);
            reflected = mix(reflected, h.xyz, t);
        } else if h.w > 0.0 {
            let start = u.specular_diffuse_from;
            let t = select(0.0, clamp((mr.y - start) / (1.0 - start), 0.0, 1.0), start < 1.0);
            reflected *= mix(h.xyz, vec3(1.0), t);
        }
    }
    // The material's occlusion map darkens the gathered diffuse light only.
    var occlusion = 1.0;
    if (u.flags & FLAG_MATERIAL_OCCLUSION) != 0u {
        occlusion = gbuffer_emissive[pixel].w;
    }
    var gi = diffuse * e * (occlusion * INV_PI) + specular * reflected;
    // A blended surface in front (glass) shows its own GI over the GI behind it, by its alpha.
    if (u.flags & FLAG_BLEND_LAYER) != 0u {
        gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], u.camera.position, -v, gi);
    }
    output[pixel] = vec4(direct + gi, 1.0);
}

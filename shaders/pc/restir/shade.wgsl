// Pass `pc/shade`, per full-resolution pixel, HSGI's multi-sample shading (GDC 2023, "PC /
// Console Solution"): the pixel is shaded from the reservoirs of the trace pixels whose centers
// lie within `shade_radius` trace pixels (per axis) of its own center (at trace scale 2, the
// 2 x 2 nearest it, each pixel of a 2 x 2 block its own), whose receiver lies on its surface
// and that pass the shadow test (HSGI's "post spatial reuse" neighbour rule, applied here at
// shading time) and whose sample lies at least `shade_contact_ratio` times the two receivers'
// distance from its own receiver (near contacts a neighbour's short ray sees another scene),
// each an estimate of its irradiance through the reconnection shift; their mean is the noisy,
// demodulated irradiance the denoiser filters. It also upsamples the trace resolution to full.
// On a rough pixel (from `specular_max_roughness` up) the estimates of the wider
// (2 shade_radius + 1)^2 trace pixels around its own, weighted by the pixel's specular lobe,
// give HSGI's reuse of the diffuse result for the reflection: the ratio of the lobe-weighted
// light to the light, per channel, which `specular_temporal` accumulates over time. (A ratio
// of two sums over the same samples: more samples make it less biased, and their shared noise
// cancels in it. The irradiance from all of the 3 x 3 shared most of its reservoirs between
// neighbouring pixels, noise the denoiser's spatial filter barely removes: on cornell-box its
// error was 1.5% higher.)
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`.

#import gi::math::PI
#import gi::brdf::{brdf_new, specular_albedo, ggx_lobe}
#import gi::sampling::{Frame, frame_from_normal, frame_to_local}
#import gi::camera::camera_ray
#import gi::packing::{unpack_unit_vector, pack_color64}
#import gi::pc::restir::bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_metallic_roughness, load_surface, resolved, irradiance,
    specular_noisy, trace_index
}
#import gi::pc::restir::common::{
    uniforms, Surface, Reservoir, is_sky_depth, has_surface, reservoir_irradiance,
    similar_surfaces, sample_direction, specular_kind, SAMPLE_OCCLUDED, FLAG_SHADOW,
    FLAG_MULTI_SAMPLE, SPECULAR_NONE, SPECULAR_REUSED, load_resolved
}

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
    let toward = dot(unpack_unit_vector(center.occluder_direction), d.xyz) > uniforms.shadow_cos;
    return !(toward && d.w > uniforms.shadow_distance_ratio * center.occluder_distance);
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
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    if is_sky_depth(depth) {
        irradiance[pixel] = vec2(0u);
        specular_noisy[pixel] = vec2(0u);
        return;
    }
    let kind = specular_kind(uniforms.flags, uniforms.specular_max_roughness, depth, gbuffer_metallic_roughness[pixel].y);
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(uniforms.size_px);
    let ray = camera_ray(uniforms.camera, uv);
    let x = uniforms.camera.position + ray * depth;
    let me = Surface(x, gbuffer_normal[pixel], pixel, depth);
    let n = unpack_unit_vector(me.normal);
    let t = vec2<i32>(id.xy / uniforms.trace_scale);
    let center_index = trace_index(vec2<u32>(t));
    let center = load_resolved(resolved[center_index]);
    var radius = 0;
    if (uniforms.flags & FLAG_MULTI_SAMPLE) != 0u {
        radius = i32(uniforms.shade_radius);
    }
    let shadow_test = (uniforms.flags & FLAG_SHADOW) != 0u;
    let reused = kind == SPECULAR_REUSED;
    var lobe: Lobe;
    if reused {
        lobe = lobe_new(n, -ray, gbuffer_metallic_roughness[pixel].y);
    }
    // This pixel's center in trace pixels: the irradiance's reservoirs lie within `radius`
    // of it (per axis), a subset of the (2 radius + 1)^2 around its own trace pixel.
    let c = (vec2<f32>(id.xy) + 0.5) / f32(uniforms.trace_scale) - 0.5;
    var sum = vec3(0.0);
    var count = 0.0;
    var lobe_sum = vec3(0.0);
    var lobe_light = vec3(0.0);
    for (var dy = -radius; dy <= radius; dy++) {
        for (var dx = -radius; dx <= radius; dx++) {
            let q = t + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(uniforms.trace_px)) {
                continue;
            }
            // Only a rough pixel's reflection ratio reads the trace pixels beyond the nearest.
            let near = radius == 0 || all(abs(vec2<f32>(q) - c) <= vec2(f32(radius) + 1e-3));
            if !near && !reused {
                continue;
            }
            let qi = trace_index(vec2<u32>(q));
            let sq = load_surface(qi);
            if !similar_surfaces(me, sq, uniforms.normal_cos, uniforms.plane_tolerance) {
                continue;
            }
            let rq = load_resolved(resolved[qi]);
            if qi != center_index {
                if shadow_test && !shadow_compatible(center, rq, x) {
                    continue;
                }
                let reach = sample_direction(rq, sq.position).w;
                if reach < uniforms.shade_contact_ratio * distance(sq.position, x) {
                    continue;
                }
            }
            let e = reservoir_irradiance(rq, sq.position, x, n, uniforms.jacobian_max);
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
        let s = load_surface(center_index);
        if has_surface(s) {
            sum = reservoir_irradiance(center, s.position, x, n, uniforms.jacobian_max);
            if reused {
                lobe_light = sum;
                lobe_sum = sum * lobe_weight(lobe, sample_direction(center, x).xyz);
            }
        }
        count = 1.0;
    }
    irradiance[pixel] = pack_color64(sum / count, 0.0);
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

// The PC tier's traced specular reflections after HSGI (GDC 2023, "PC / Console Solution",
// "Specular Reflection"): `specular_trace` in `pc/trace.wgsl` traces one GGX VNDF ray per trace
// pixel on surfaces smoother than `specular_max_roughness`; here they become a per-pixel
// reflected radiance:
//   - `specular_resolve` (pass `pc/specular_resolve`), per pixel: the rays of the 3 x 3 trace
//     pixels around it whose receivers lie on its surface, each reconnected from this pixel to
//     its hit and weighted by this pixel's specular lobe over the pdf it was drawn with, the
//     ratio estimator of Stachowiak 2015 ("Stochastic Screen-Space Reflections"); the result
//     is the lobe's mean incident radiance, demodulated from the lobe's albedo.
//   - `specular_temporal` (pass `pc/specular_temporal`), per pixel: the resolved radiance
//     averaged with the history found by the surface's motion vector (depth and normal
//     checked), over up to `specular_history` frames, the history first clamped to the
//     resolved neighbourhood's mean plus or minus `specular_clamp_sigma` standard deviations.
//     Rough pixels go through it too: their input is the lobe ratio of the reused diffuse
//     samples (`shade` in `pc/restir.wgsl`), and neither the clamp's neighbourhood nor the
//     history mixes the two kinds (a ratio's history stores its distance negated).
// `compose` in `pc/restir.wgsl` multiplies the radiance by the split-sum specular albedo, and
// the irradiance over pi by the ratio.
//
// Bind group 0: the layout of `pc/restir.wgsl`; this file uses binding 0 `u`
// (`gi::pc::common::PcUniforms`) and the buffers it imports from `gi::pc::restir_bindings`.

#import gi::brdf::{brdf_new, ggx_lobe}
#import gi::sampling::{frame_from_normal, frame_to_local}
#import gi::camera::camera_ray
#import gi::packing::{pack_unit_vector, unpack_unit_vector, pack_color64, unpack_color64}
#import gi::pc::restir_bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_base_color, gbuffer_metallic_roughness,
    gbuffer_motion, surfaces, specular_samples, specular_noisy, specular_history,
    specular_history_prev
}
#import gi::pc::common::{
    PcUniforms, Surface, SpecularSample, has_surface, similar_surfaces, specular_kind, SAMPLE_SKY,
    FLAG_MULTI_SAMPLE, FLAG_HISTORY, SPECULAR_NONE, SPECULAR_TRACED, SPECULAR_REUSED
}

@group(0) @binding(0) var<uniform> u: PcUniforms;

const FAR: f32 = 3.40282347e38;

// Where the specular reflection of pixel `pixel` (with G-buffer depth `depth`) comes from.
fn kind_of(pixel: u32, depth: f32) -> u32 {
    return specular_kind(u.flags, u.specular_max_roughness, depth, gbuffer_metallic_roughness[pixel].y);
}

fn world_position(p: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(p) + 0.5) / vec2<f32>(u.size_px);
    return u.camera.position + camera_ray(u.camera, uv) * depth;
}

@compute @workgroup_size(8, 8)
fn specular_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    // `shade` wrote the other pixels' input.
    if kind_of(pixel, depth) != SPECULAR_TRACED {
        return;
    }
    let x = world_position(id.xy, depth);
    let me = Surface(x, gbuffer_normal[pixel], pixel, depth, 0u, 0u);
    let frame = frame_from_normal(unpack_unit_vector(me.normal));
    let wo = frame_to_local(frame, normalize(u.camera.position - x));
    if wo.z <= 0.0 {
        specular_noisy[pixel] = vec2(0u);
        return;
    }
    let mr = gbuffer_metallic_roughness[pixel];
    let alpha = brdf_new(gbuffer_base_color[pixel].xyz, mr.x, mr.y).alpha;
    let a2 = alpha * alpha;
    let t = vec2<i32>(id.xy / u.trace_scale);
    var radius = 0;
    if (u.flags & FLAG_MULTI_SAMPLE) != 0u {
        radius = 1;
    }
    var weighted = vec3(0.0);
    var weight_sum = 0.0;
    // Every usable ray's radiance, unweighted: the fallback of a lobe so narrow that no ray
    // lands in it this frame (a mirror between its trace pixels' receivers).
    var plain = vec3(0.0);
    var count = 0.0;
    for (var dy = -radius; dy <= radius; dy++) {
        for (var dx = -radius; dx <= radius; dx++) {
            let q = t + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(u.trace_px)) {
                continue;
            }
            let qi = u32(q.y) * u.trace_px.x + u32(q.x);
            let sample = specular_samples[qi];
            if !(sample.pdf > 0.0) || !similar_surfaces(me, surfaces[qi], u.normal_cos, u.plane_tolerance) {
                continue;
            }
            var wi_world = sample.position;
            if (sample.flags & SAMPLE_SKY) == 0u {
                wi_world = normalize(sample.position - x);
            }
            let wi = frame_to_local(frame, wi_world);
            if wi.z <= 0.0 {
                continue;
            }
            plain += sample.radiance;
            count += 1.0;
            // This pixel's lobe without Fresnel (the albedo carries it) times the cosine,
            // over the pdf the ray was drawn with.
            let h = normalize(wo + wi);
            let w = ggx_lobe(h, wo.z, wi.z, a2) * wi.z / sample.pdf;
            if w > 0.0 && w < FAR {
                weighted += sample.radiance * w;
                weight_sum += w;
            }
        }
    }
    var radiance = vec3(0.0);
    var valid = 0.0;
    if weight_sum > 0.0 {
        radiance = weighted / weight_sum;
        valid = 1.0;
    } else if count > 0.0 {
        radiance = plain / count;
        valid = 1.0;
    }
    specular_noisy[pixel] = pack_color64(radiance, valid * f32(SPECULAR_TRACED));
}

@compute @workgroup_size(8, 8)
fn specular_temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    let kind = kind_of(pixel, depth);
    if kind == SPECULAR_NONE {
        specular_history[pixel] = vec4(0u);
        return;
    }
    let x = world_position(id.xy, depth);
    let n = unpack_unit_vector(gbuffer_normal[pixel]);
    let current = unpack_color64(specular_noisy[pixel]);

    // The resolved neighbourhood's mean and standard deviation.
    var m1 = vec3(0.0);
    var m2 = vec3(0.0);
    var count = 0.0;
    let p = vec2<i32>(id.xy);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = p + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(u.size_px)) {
                continue;
            }
            // The input's value is its kind (0: none).
            let v = unpack_color64(specular_noisy[u32(q.y) * u.size_px.x + u32(q.x)]);
            if v.w == f32(kind) {
                m1 += v.xyz;
                m2 += v.xyz * v.xyz;
                count += 1.0;
            }
        }
    }

    // The previous frame's history of this surface.
    var history = vec3(0.0);
    var length = 0.0;
    let before = vec2<f32>(id.xy) + 0.5 + gbuffer_motion[pixel];
    let q = vec2<i32>(floor(before));
    if (u.flags & FLAG_HISTORY) != 0u && all(q >= vec2(0)) && all(q < vec2<i32>(u.size_px)) {
        let h = specular_history_prev[u32(q.y) * u.size_px.x + u32(q.x)];
        let stored = unpack_color64(h.xy);
        let expected = distance(x, u.previous_camera.position);
        // A reused ratio's history stores its distance negated: never mixed with radiance.
        let signed = select(expected, -expected, kind == SPECULAR_REUSED);
        let same_depth = abs(bitcast<f32>(h.z) - signed) <= 0.05 * expected;
        let same_normal = dot(unpack_unit_vector(h.w), n) > 0.9;
        if stored.w > 0.0 && same_depth && same_normal {
            history = stored.xyz;
            length = stored.w;
            if count > 0.0 {
                let mean = m1 / count;
                let sigma = sqrt(max(m2 / count - mean * mean, vec3(0.0)));
                let k = u.specular_clamp_sigma;
                history = clamp(history, mean - k * sigma, mean + k * sigma);
            }
        }
    }
    var radiance = history;
    if current.w > 0.0 {
        length = min(length + 1.0, u.specular_history);
        radiance = mix(history, current.xyz, 1.0 / length);
    }
    let packed = pack_color64(radiance, length);
    let d = distance(x, u.camera.position);
    let signed = select(d, -d, kind == SPECULAR_REUSED);
    specular_history[pixel] = vec4(packed, bitcast<u32>(signed), pack_unit_vector(n));
}

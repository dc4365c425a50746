// Pass `pc/specular_resolve`, the first half of the PC tier's traced specular reflections
// after HSGI (GDC 2023, "PC / Console Solution", "Specular Reflection"), per pixel smoother
// than `specular_max_roughness`: the rays `specular_trace` traced from the 3 x 3 trace pixels
// around it whose receivers lie on its surface, each reconnected from this pixel to its hit and
// weighted by this pixel's specular lobe over the pdf it was drawn with, the ratio estimator
// of Stachowiak 2015 ("Stochastic Screen-Space Reflections"); the result is the lobe's mean
// incident radiance, demodulated from the lobe's albedo. `compose` multiplies it by the
// split-sum specular albedo.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`.

#import gi::brdf::{brdf_new, ggx_lobe}
#import gi::sampling::{frame_from_normal, frame_to_local}
#import gi::packing::{unpack_unit_vector, pack_color64}
#import gi::pc::restir::bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_base_color, gbuffer_metallic_roughness, load_surface,
    specular_samples, specular_noisy, kind_of, world_position
}
#import gi::pc::restir::common::{
    uniforms, Surface, similar_surfaces, SAMPLE_SKY, FLAG_MULTI_SAMPLE, SPECULAR_TRACED, FAR
}

@compute @workgroup_size(8, 8)
fn specular_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    // `shade`, the next pass, writes the other pixels' input.
    if kind_of(pixel, depth) != SPECULAR_TRACED {
        return;
    }
    let x = world_position(id.xy, depth);
    let me = Surface(x, gbuffer_normal[pixel], pixel, depth);
    let frame = frame_from_normal(unpack_unit_vector(me.normal));
    let wo = frame_to_local(frame, normalize(uniforms.camera.position - x));
    if wo.z <= 0.0 {
        specular_noisy[pixel] = vec2(0u);
        return;
    }
    let mr = gbuffer_metallic_roughness[pixel];
    let alpha = brdf_new(gbuffer_base_color[pixel].xyz, mr.x, mr.y).alpha;
    let a2 = alpha * alpha;
    let t = vec2<i32>(id.xy / uniforms.trace_scale);
    var radius = 0;
    if (uniforms.flags & FLAG_MULTI_SAMPLE) != 0u {
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
            if any(q < vec2(0)) || any(q >= vec2<i32>(uniforms.trace_px)) {
                continue;
            }
            let qi = u32(q.y) * uniforms.trace_px.x + u32(q.x);
            let sample = specular_samples[qi];
            if !(sample.pdf > 0.0) || !similar_surfaces(me, load_surface(qi), uniforms.normal_cos, uniforms.plane_tolerance) {
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

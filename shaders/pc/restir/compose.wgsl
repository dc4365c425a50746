// Pass `pc/compose`, the PC tier's final image: direct light plus the diffuse albedo times the
// denoised irradiance over pi, plus the split-sum specular albedo times the reflected
// radiance: the traced specular (`specular_resolve`, `specular_temporal`) on smooth surfaces,
// blended to the irradiance over pi between 0.75 and 1 times `specular_max_roughness`; on
// rough ones the irradiance over pi times the accumulated lobe ratio, blended to 1 from
// `specular_diffuse_from` to roughness 1.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`. Group 2: the cache (`gi::cache::data`), for the GI of a blended
// layer.

#import gi::math::INV_PI
#import gi::brdf::{gbuffer_brdf, brdf_split_sum_albedos}
#import gi::camera::camera_ray
#import gi::packing::{unpack_unit_vector, unpack_color64}
#import gi::cache::trace::cache_blend_layer_gi
#import gi::pc::restir::bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_base_color, gbuffer_metallic_roughness, denoised,
    direct_mean, output, load_specular_history, gbuffer_emissive, gbuffer_blend_layer
}
#import gi::pc::restir::common::{
    uniforms, is_sky_depth, specular_kind, FLAG_MATERIAL_OCCLUSION, FLAG_BLEND_LAYER,
    SPECULAR_NONE, SPECULAR_TRACED, unpack_specular_history
}

@compute @workgroup_size(8, 8)
fn compose(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let direct = direct_mean[pixel].xyz;
    let depth = gbuffer_depth[pixel];
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(uniforms.size_px);
    let v = -camera_ray(uniforms.camera, uv);
    if is_sky_depth(depth) {
        var gi = vec3(0.0);
        if (uniforms.flags & FLAG_BLEND_LAYER) != 0u {
            gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], uniforms.camera.position, -v, gi);
        }
        output[pixel] = vec4(direct + gi, 1.0);
        return;
    }
    let n = unpack_unit_vector(gbuffer_normal[pixel]);
    let mr = gbuffer_metallic_roughness[pixel];
    let albedos = brdf_split_sum_albedos(gbuffer_brdf(gbuffer_base_color[pixel], mr), max(dot(n, v), 0.0));
    let diffuse = albedos.diffuse;
    let specular = albedos.specular;
    let e = unpack_color64(denoised[pixel]).rgb;
    var reflected = e * INV_PI;
    let max_roughness = uniforms.specular_max_roughness;
    let kind = specular_kind(uniforms.flags, max_roughness, depth, mr.y);
    if kind != SPECULAR_NONE {
        let h = unpack_specular_history(load_specular_history(pixel));
        if h.length > 0.0 && kind == SPECULAR_TRACED {
            let t = 1.0 - smoothstep(0.75 * max_roughness, max_roughness, mr.y);
            reflected = mix(reflected, h.value, t);
        } else if h.length > 0.0 {
            let start = uniforms.specular_diffuse_from;
            let t = select(0.0, clamp((mr.y - start) / (1.0 - start), 0.0, 1.0), start < 1.0);
            reflected *= mix(h.value, vec3(1.0), t);
        }
    }
    // The material's occlusion map darkens the gathered diffuse light only.
    var occlusion = 1.0;
    if (uniforms.flags & FLAG_MATERIAL_OCCLUSION) != 0u {
        occlusion = gbuffer_emissive[pixel].w;
    }
    var gi = diffuse * e * (occlusion * INV_PI) + specular * reflected;
    // A blended surface in front (glass) shows its own GI over the GI behind it, by its alpha.
    if (uniforms.flags & FLAG_BLEND_LAYER) != 0u {
        gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], uniforms.camera.position, -v, gi);
    }
    output[pixel] = vec4(direct + gi, 1.0);
}

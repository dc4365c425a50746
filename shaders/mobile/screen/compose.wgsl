// Pass `mobile/compose` of the mobile tier's screen-space passes (`gi::mobile::screen`), at
// full resolution: bilateral upsample of the half-resolution irradiance (depth and normal
// weights) and the final image: direct light + (diffuse albedo + a split-sum specular albedo)
// x irradiance / pi.
//
// Bind group 0: `gi::mobile::screen`'s; 2: the brick cache (`gi::cache::data`), for the GI of a
// blended layer.

#import gi::packing::unpack_rgb9e5
#import gi::math::INV_PI
#import gi::brdf::{gbuffer_brdf, brdf_split_sum_albedos}
#import gi::mobile::lite::{lite_diffuse, lite_normal}
#import gi::cache::trace::cache_blend_layer_gi
#import gi::mobile::screen::{
    uniforms, gbuffer_depth, gbuffer_base_color, gbuffer_metallic_roughness, gbuffer_emissive,
    gbuffer_blend_layer, lite, history_out, direct_mean, output, is_sky, pixel_ray,
    history_age_depth, half_source, FLAG_MATERIAL_OCCLUSION, FLAG_BLEND_LAYER
}

// Sharpness of the upsample's normal weight (cos^k) and width of its depth weight, relative
// to the pixel's depth.
const UPSAMPLE_NORMAL_POWER: f32 = 8.0;
const UPSAMPLE_DEPTH_WIDTH: f32 = 0.02;

@compute @workgroup_size(8, 8)
fn compose(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= uniforms.size_px.x || id.y >= uniforms.size_px.y {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let direct = direct_mean[pixel].xyz;
    let depth = gbuffer_depth[pixel];
    let dir = pixel_ray(uniforms.camera, id.xy);
    if is_sky(depth) {
        var gi = vec3(0.0);
        if (uniforms.flags & FLAG_BLEND_LAYER) != 0u {
            gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], uniforms.camera.position, dir, gi);
        }
        output[pixel] = vec4(direct + gi, 1.0);
        return;
    }
    let bits = lite[pixel];
    let n = lite_normal(bits, uniforms.camera, dir);

    // Bilateral upsample from the four half-resolution samples around the pixel.
    let q = vec2<f32>(id.xy) * 0.5;
    let base = vec2<i32>(floor(q));
    let f = q - floor(q);
    var sum = vec3(0.0);
    var weight = 0.0;
    var plain_sum = vec3(0.0);
    var plain_weight = 0.0;
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let h = vec2<u32>(clamp(base + vec2<i32>(c), vec2(0), vec2<i32>(uniforms.half_px) - 1));
        let entry = history_out[h.y * uniforms.half_px.x + h.x];
        let age_depth = history_age_depth(entry);
        if age_depth.x <= 0.0 {
            continue;
        }
        let w2 = select(1.0 - f, f, c == vec2(1u));
        let bilinear = max(w2.x * w2.y, 1e-3);
        let e = unpack_rgb9e5(entry.x);
        let source = half_source(h);
        let source_n = lite_normal(lite[source.y * uniforms.size_px.x + source.x], uniforms.camera, pixel_ray(uniforms.camera, source));
        let depth_w = exp(-abs(abs(age_depth.y) - depth) / (UPSAMPLE_DEPTH_WIDTH * depth));
        let normal_w = pow(max(dot(n, source_n), 0.0), UPSAMPLE_NORMAL_POWER);
        let w = bilinear * depth_w * normal_w;
        sum += w * e;
        weight += w;
        plain_sum += bilinear * e;
        plain_weight += bilinear;
    }
    var irradiance = vec3(0.0);
    if weight > 1e-4 {
        irradiance = sum / weight;
    } else if plain_weight > 0.0 {
        irradiance = plain_sum / plain_weight;
    }

    let mr = gbuffer_metallic_roughness[pixel];
    let brdf = gbuffer_brdf(gbuffer_base_color[pixel], mr);
    let specular = brdf_split_sum_albedos(brdf, max(dot(n, -dir), 0.0)).specular;
    // The material's occlusion map darkens the gathered diffuse light only.
    var occlusion = 1.0;
    if (uniforms.flags & FLAG_MATERIAL_OCCLUSION) != 0u {
        occlusion = gbuffer_emissive[pixel].w;
    }
    var gi = (lite_diffuse(bits) * occlusion + specular) * irradiance * INV_PI;
    // A blended surface in front (glass) shows its own GI over the GI behind it, by its alpha.
    if (uniforms.flags & FLAG_BLEND_LAYER) != 0u {
        gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], uniforms.camera.position, dir, gi);
    }
    output[pixel] = vec4(direct + gi, 1.0);
}

// Pass `mobile/lite` of the mobile tier's screen-space passes (`gi::mobile::screen`): packs
// the G-buffer into the lite deferred G-buffer (`gi::mobile::lite`): diffuse color, dynamic
// mask and an 8-bit dithered normal, one u32 per pixel.
//
// Bind group 0: `gi::mobile::screen`'s.

#import gi::packing::unpack_unit_vector
#import gi::sampling::{sampler_new, sampler_next_2d}
#import gi::brdf::{gbuffer_brdf, brdf_diffuse_albedo}
#import gi::mobile::lite::lite_encode
#import gi::mobile::screen::{
    uniforms, gbuffer_depth, gbuffer_normal, gbuffer_base_color, gbuffer_metallic_roughness,
    gbuffer_triangle, dynamic_triangles, lite, is_sky, pixel_ray
}

@compute @workgroup_size(8, 8)
fn lite_pack(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= uniforms.size_px.x || id.y >= uniforms.size_px.y {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    if is_sky(gbuffer_depth[pixel]) {
        lite[pixel] = 0u;
        return;
    }
    let triangle = gbuffer_triangle[pixel];
    let dynamic = ((dynamic_triangles[triangle >> 5u] >> (triangle & 31u)) & 1u) != 0u;
    let brdf = gbuffer_brdf(gbuffer_base_color[pixel], gbuffer_metallic_roughness[pixel]);
    let n = unpack_unit_vector(gbuffer_normal[pixel]);
    let ray = pixel_ray(uniforms.camera, id.xy);
    let diffuse = brdf_diffuse_albedo(brdf, max(dot(n, -ray), 0.0));
    var sampler = sampler_new(uniforms.seed, pixel, uniforms.frame_index);
    let dither = sampler_next_2d(&sampler) - 0.5;
    lite[pixel] = lite_encode(diffuse, dynamic, n, uniforms.camera, ray, dither);
}

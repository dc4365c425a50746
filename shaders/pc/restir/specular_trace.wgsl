// Pass `pc/specular_trace`, HSGI's specular ray (GDC 2023, "PC / Console Solution",
// "Specular Reflection"), one invocation per trace pixel: at the receiver `trace` picked, when
// its roughness is below `specular_max_roughness`, one ray along the mirror direction of a GGX
// visible normal (Heitz 2018), shaded at its hit as `trace` shades (`gi::pc::restir::hit`; the
// sky on a miss). `specular_resolve` and `specular_temporal` turn them into a per-pixel
// reflected radiance.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), bindings 1-7 the scene
// (`gi::scene`), then the buffers of `gi::pc::restir::rays`. Group 1: the BVH (`gi::bvh`).
// Group 2: the cache (`gi::cache::data`).

#import gi::sampling::{sampler_new, sampler_next_2d, frame_from_normal, frame_to_world, frame_to_local}
#import gi::brdf::{brdf_new, sample_ggx_vndf, brdf_specular_pdf}
#import gi::bvh::{Ray, trace_closest, BVH_MISS}
#import gi::lights::sky_radiance
#import gi::packing::unpack_unit_vector
#import gi::pc::restir::common::{uniforms, SpecularSample, has_surface, SAMPLE_SKY, FAR}
#import gi::pc::restir::rays::{load_surface, gbuffer_base_color, gbuffer_metallic_roughness, specular_samples, offset_origin}
#import gi::pc::restir::hit::shade_hit

@compute @workgroup_size(8, 8)
fn specular_trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.trace_px) {
        return;
    }
    let index = id.y * uniforms.trace_px.x + id.x;
    var sample = SpecularSample(vec3(0.0), 0.0, vec3(0.0), 0u);
    let s = load_surface(index);
    let mr = gbuffer_metallic_roughness[s.pixel];
    if !has_surface(s) || !(mr.y < uniforms.specular_max_roughness) {
        specular_samples[index] = sample;
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let frame = frame_from_normal(n);
    let wo = frame_to_local(frame, normalize(uniforms.camera.position - s.position));
    let brdf = brdf_new(gbuffer_base_color[s.pixel].xyz, mr.x, mr.y);
    // A stream of its own (the temporal pass draws from `0x9e3779b9`).
    var sampler = sampler_new(uniforms.seed ^ vec2(0x6a09e667u, 0u), index, uniforms.frame_index);
    let h = sample_ggx_vndf(wo, brdf.alpha, sampler_next_2d(&sampler));
    let wi = 2.0 * dot(wo, h) * h - wo;
    if wo.z <= 0.0 || wi.z <= 0.0 {
        specular_samples[index] = sample;
        return;
    }
    let pdf = brdf_specular_pdf(brdf, wo, wi);
    if !(pdf > 0.0 && pdf < FAR) {
        specular_samples[index] = sample;
        return;
    }
    let dir = frame_to_world(frame, wi);
    let hit = trace_closest(Ray(offset_origin(s.position, n), 0.0, dir, FAR));
    if hit.triangle == BVH_MISS {
        sample.position = dir;
        sample.radiance = sky_radiance(uniforms.sky, dir);
        sample.flags = SAMPLE_SKY;
    } else {
        let shaded = shade_hit(dir, hit.t, hit.triangle, hit.barycentrics, &sampler, false);
        sample.position = shaded.position;
        sample.radiance = shaded.radiance;
    }
    sample.pdf = pdf;
    specular_samples[index] = sample;
}

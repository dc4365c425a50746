// The shading of a BVH ray's hit, which `trace` and `specular_trace` share: the hit's
// emission, exact direct light from every punctual light (one shadow ray each) and from the
// emissive triangles (one point drawn on them by their power, one shadow ray), and the brick
// cache's irradiance at the hit less those two (HSGI, GDC 2023: "indirect lighting always
// from the cache system"), reflected by its diffuse and split-sum specular albedo. With
// `FLAG_HIT_LIGHTS_CACHE` the diffuse rays' hits take the punctual lights' direct light from
// the cache too (`cache_lit_irradiance`: no shadow rays, shadows as sharp as a voxel);
// the specular rays' hits, which a mirror shows sharply, always trace their shadow rays.
#define_import_path gi::pc::restir::hit

#import gi::math::INV_PI
#import gi::sampling::{Sampler, sampler_next_f32, sampler_next_2d}
#import gi::brdf::brdf_split_sum_albedos
#import gi::bvh::{Ray, trace_any}
#import gi::scene::{triangles, lights, emission, geometric_normal, material_of, tex_coords, cone_footprint, material_brdf, mapped_normal, normalize_or, orient_shading_normal}
#import gi::lights::{LIGHT_DIRECTIONAL, EmitterSample, light_incident, sample_emitter}
#import gi::pc::restir::hit_cache::hit_cache_irradiance
#import gi::pc::restir::common::{uniforms, FAR}
#import gi::pc::restir::rays::{SHADOW_MARGIN, offset_origin}

// Spread angle (radians) of the ray cone of a GI ray: the width of its footprint at distance t
// is t times this. Diffuse-like bounces gather over wide cones, so their hits read
// prefiltered texture levels.
const TRACE_CONE_SPREAD: f32 = 0.05;

// One point drawn on the emitters by their power (`sample_emitter`) for a surface at `p` with
// normal `n`, its shadow ray leaving from `origin`; pdf 0 when it cannot light the surface:
// behind it, black, or occluded.
fn visible_emitter_sample(
    p: vec3<f32>,
    n: vec3<f32>,
    origin: vec3<f32>,
    sampler: ptr<function, Sampler>,
) -> EmitterSample {
    let u_select = sampler_next_f32(sampler);
    var light = sample_emitter(p, u_select, sampler_next_2d(sampler), uniforms.emitter_count, uniforms.default_material);
    if !(light.pdf > 0.0 && dot(light.wi, n) > 0.0 && any(light.radiance > vec3(0.0)))
        || trace_any(Ray(origin, 0.0, light.wi, light.distance * (1.0 - SHADOW_MARGIN))) {
        light.pdf = 0.0;
    }
    return light;
}

// Radiance leaving the point a ray along `dir` hit, towards the ray: emission, the direct light
// of the punctual lights (shadow rays) and of the emitters (one next-event sample with a shadow
// ray, drawn from `sampler`), and the cache's bounced light (`cache_bounced_irradiance`: the
// cache's emitted part would count the emitters twice), reflected by the diffuse albedo plus the
// split-sum specular albedo towards the ray, all weighed with the hit's shading normal (vertex
// normals and normal map). Also returns the hit's geometric normal facing the ray. The cache's estimate of the emitters' light is taken over a voxel side and interpolated,
// so at a hit near an edge or a contact shadow it is wrong by the voxel's extent; the sample is
// exact in expectation wherever the ray lands.
struct HitShading {
    radiance: vec3<f32>,
    position: vec3<f32>,
    normal: vec3<f32>,
    // Emission plus the punctual lights' and emitters' direct light, and the albedo (diffuse
    // plus specular towards the ray).
    fixed_radiance: vec3<f32>,
    albedo: vec3<f32>,
}

// `lights_from_cache`: leave the punctual lights to the cache (no shadow rays).
fn shade_hit(dir: vec3<f32>, t: f32, triangle: u32, b: vec2<f32>, sampler: ptr<function, Sampler>, lights_from_cache: bool) -> HitShading {
    let tri = triangles[triangle];
    let b0 = 1.0 - b.x - b.y;
    let p = tri.pa.xyz + (tri.pb.xyz - tri.pa.xyz) * b.x + (tri.pc.xyz - tri.pa.xyz) * b.y;
    var ng = geometric_normal(tri);
    if all(ng == vec3(0.0)) {
        ng = -dir;
    }
    let front_facing = dot(ng, dir) <= 0.0;
    ng = select(-ng, ng, front_facing);
    let material = material_of(triangle, uniforms.default_material);
    // Textures prefiltered over the footprint of the bounce's ray cone.
    let footprint = cone_footprint(tri, t * TRACE_CONE_SPREAD, dot(ng, dir));
    let tc = tex_coords(triangle, vec3(b0, b.x, b.y), footprint);
    let brdf = material_brdf(material, tc);
    // The shading normal as the G-buffer and the path tracer take it: the interpolated vertex
    // normal, bent by the normal map, on the ray's side. It weighs the light the hit receives
    // and reflects; the geometric normal still decides which side light can arrive from and
    // which side of the cache's voxels the hit reads.
    let n_vertex = tri.na.xyz * b0 + tri.nb.xyz * b.x + tri.nc.xyz * b.y;
    let ns = orient_shading_normal(ng, mapped_normal(material, normalize_or(n_vertex, ng), tc), -dir);
    // The hit reflects towards the ray its diffuse lobe and, by the split-sum approximation,
    // its specular lobe: metals (no diffuse lobe) would otherwise reflect nothing.
    let albedos = brdf_split_sum_albedos(brdf, max(dot(ns, -dir), 0.0));
    let albedo = albedos.diffuse + albedos.specular;
    var radiance = vec3(0.0);
    if front_facing || material.double_sided != 0u {
        radiance = emission(material, tc);
    }
    let origin = offset_origin(p, ng);
    var irradiance = vec3(0.0);
    let light_count = select(uniforms.light_count, 0u, lights_from_cache);
    for (var i = 0u; i < light_count; i++) {
        let light = lights[i];
        let incident = light_incident(light, p);
        let cos_l = dot(incident.wi, ns);
        if cos_l <= 0.0 || dot(incident.wi, ng) <= 0.0 || all(incident.irradiance == vec3(0.0)) {
            continue;
        }
        var t_max = FAR;
        if light.kind != LIGHT_DIRECTIONAL {
            t_max = incident.distance * (1.0 - SHADOW_MARGIN);
        }
        if !trace_any(Ray(origin, 0.0, incident.wi, t_max)) {
            irradiance += incident.irradiance * cos_l;
        }
    }
    if uniforms.emitter_count > 0u {
        let light = visible_emitter_sample(p, ng, origin, sampler);
        if light.pdf > 0.0 {
            irradiance += light.radiance * (max(dot(light.wi, ns), 0.0) / light.pdf);
        }
    }
    radiance += albedo * INV_PI * irradiance;
    let fixed_radiance = radiance;
    radiance += albedo * INV_PI * hit_cache_irradiance(p, ng, lights_from_cache);
    return HitShading(radiance, p, ng, fixed_radiance, albedo);
}

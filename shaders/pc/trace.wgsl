// The PC tier's BVH rays (HSGI, GDC 2023, "PC / Console Solution": hardware ray tracing, here
// the software CWBVH of `gi::bvh` standing in for it):
//   - `trace` (pass `pc/trace`), one invocation per trace pixel: picks one full-resolution
//     pixel of its block (jittered per frame: HSGI's "canonical sample coverage, 2x2 jitter")
//     as the receiver, traces one cosine-distributed ray from it through the BVH and shades the
//     hit: its emission, exact direct light from every punctual light (one shadow ray each)
//     and from the emissive triangles (one point drawn on them by their power, one shadow ray),
//     and the brick cache's irradiance at the hit less those two ("indirect lighting always from
//     the cache system"), reflected by its diffuse and split-sum specular albedo; a miss sees the
//     sky. With emissive triangles in the scene a second candidate is a point drawn on them
//     (next-event estimation); the two are combined by RIS into the pixel's initial reservoir
//     (M = 1).
//     In trace-probe mode (HSGI's "trace probe": a short ray, then radiance from probes) the
//     BVH ray stops after `probe_ray_m`; past that the brick cache is traced from the
//     segment's end and its radiance taken where it hits, the cache's voxels standing in for
//     HSGI's probes.
//   - `shadow` (pass `pc/shadow`), HSGI's "ReSTIR GI shadow": one visibility ray from the
//     receiver to the sample the spatial reuse chose. Visible: kept. Occluded: the pixel falls
//     back to its temporal reservoir (reused from its own rays, so with little visibility bias)
//     and remembers the occluder's distance and the occluded direction for the multi-sample
//     shading's neighbour test.
//   - `specular_trace` (pass `pc/specular_trace`), HSGI's specular ray: at the same receiver,
//     when its roughness is below `specular_max_roughness`, one ray along the mirror direction
//     of a GGX visible normal (Heitz 2018), shaded at its hit as `trace` shades (the sky on a
//     miss); `shaders/pc/specular.wgsl` resolves and accumulates them.
//
// Bind group 0: binding 0 `u` (`gi::pc::common::PcUniforms`), bindings 1-7 the scene
// (`gi::scene`), then the buffers below. Group 1: the BVH (`gi::bvh`). Group 2: the cache
// (`gi::cache::data`).

#import gi::math::{INV_PI, luminance}
#import gi::sampling::{Sampler, sampler_new, sampler_next_f32, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world, frame_to_local}
#import gi::brdf::{brdf_new, brdf_split_sum_albedos, sample_ggx_vndf, brdf_specular_pdf}
#import gi::bvh::{Ray, trace_closest, trace_any, BVH_MISS}
#import gi::camera::camera_ray
#import gi::scene::{triangles, lights, selection, emission, geometric_normal, material_of, tex_coords, cone_footprint, material_brdf, mapped_normal, normalize_or, orient_shading_normal}
#import gi::lights::{LIGHT_DIRECTIONAL, EmitterSample, light_incident, sky_radiance, sample_emitter, emitter_pdf}
#import gi::packing::{pack_unit_vector, unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5}
#import gi::cache::data::cache
#import gi::cache::trace::{CacheHit, cache_bounced_irradiance, cache_miss, cache_trace_from, cache_hit_radiance, cache_hit_normal}
#import gi::pc::common::{
    PcUniforms, Surface, Reservoir, SpecularSample, empty_reservoir, is_sky_depth, has_surface,
    SAMPLE_SKY, SAMPLE_OCCLUDED, FLAG_SPATIAL, FLAG_SHADOW, FLAG_TEMPORAL
}

// Spread angle (radians) of the ray cone of a GI ray: the width of its footprint at distance t
// is t times this. Diffuse-like bounces gather over wide cones, so their hits read
// prefiltered texture levels.
const TRACE_CONE_SPREAD: f32 = 0.05;
const FAR: f32 = 3.40282347e38;
// Shadow rays stop short of their target by this share of the distance.
const SHADOW_MARGIN: f32 = 1e-3;

@group(0) @binding(0) var<uniform> u: PcUniforms;
@group(0) @binding(8) var<storage, read> gbuffer_depth: array<f32>;
@group(0) @binding(9) var<storage, read> gbuffer_normal: array<u32>;
// Per trace pixel: this frame's receiver (written by `trace`).
@group(0) @binding(10) var<storage, read_write> surfaces: array<Surface>;
// Per trace pixel: the initial reservoir (written by `trace`).
@group(0) @binding(11) var<storage, read_write> initial: array<Reservoir>;
// Per trace pixel: the temporal reuse's result (read by `shadow`).
@group(0) @binding(12) var<storage, read> temporal: array<Reservoir>;
// Per trace pixel: the reservoir the shading reads. With spatial reuse, `pc/spatial` wrote
// its result here and `shadow` updates it in place (each invocation reads and writes only its
// own element); without, `shadow` writes it.
@group(0) @binding(13) var<storage, read_write> resolved: array<Reservoir>;
@group(0) @binding(14) var<storage, read> gbuffer_base_color: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> gbuffer_metallic_roughness: array<vec2<f32>>;
// Per trace pixel: the specular ray (written by `specular_trace`).
@group(0) @binding(16) var<storage, read_write> specular_samples: array<SpecularSample>;

// `p` pushed off its surface along `n` by a margin relative to its magnitude (the reference's
// `offset_origin`).
fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    return p + n * (1e-4 * (1.0 + max(max(a.x, a.y), a.z)));
}

// The receiver of trace pixel `t`: the first pixel of its block, starting at a per-frame
// jittered one, that shows a surface.
fn pick_receiver(t: vec2<u32>, index: u32) -> Surface {
    let scale = u.trace_scale;
    let count = scale * scale;
    var sampler = sampler_new(u.seed ^ vec2(0x2545f491u, 0u), index, u.frame_index);
    let start = min(u32(sampler_next_2d(&sampler).x * f32(count)), count - 1u);
    for (var k = 0u; k < count; k++) {
        let o = (start + k) % count;
        let p = t * scale + vec2(o % scale, o / scale);
        if any(p >= u.size_px) {
            continue;
        }
        let pixel = p.y * u.size_px.x + p.x;
        let depth = gbuffer_depth[pixel];
        if is_sky_depth(depth) {
            continue;
        }
        let uv = (vec2<f32>(p) + 0.5) / vec2<f32>(u.size_px);
        let x = u.camera.position + camera_ray(u.camera, uv) * depth;
        return Surface(x, gbuffer_normal[pixel], pixel, depth, 0u, 0u);
    }
    return Surface(vec3(0.0), 0u, 0u, 0.0, 0u, 0u);
}

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
    var light = sample_emitter(p, u_select, sampler_next_2d(sampler), u.emitter_count, u.default_material);
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

fn shade_hit(dir: vec3<f32>, t: f32, triangle: u32, b: vec2<f32>, sampler: ptr<function, Sampler>) -> HitShading {
    let tri = triangles[triangle];
    let b0 = 1.0 - b.x - b.y;
    let p = tri.pa.xyz + (tri.pb.xyz - tri.pa.xyz) * b.x + (tri.pc.xyz - tri.pa.xyz) * b.y;
    var ng = geometric_normal(tri);
    if all(ng == vec3(0.0)) {
        ng = -dir;
    }
    let front_facing = dot(ng, dir) <= 0.0;
    ng = select(-ng, ng, front_facing);
    let material = material_of(triangle, u.default_material);
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
    for (var i = 0u; i < u.light_count; i++) {
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
    if u.emitter_count > 0u {
        let light = visible_emitter_sample(p, ng, origin, sampler);
        if light.pdf > 0.0 {
            irradiance += light.radiance * (max(dot(light.wi, ns), 0.0) / light.pdf);
        }
    }
    radiance += albedo * INV_PI * irradiance;
    let fixed_radiance = radiance;
    radiance += albedo * INV_PI * cache_bounced_irradiance(p, ng).xyz;
    return HitShading(radiance, p, ng, fixed_radiance, albedo);
}

// Most cache voxels of the receiver's own surface a far-field trace steps over.
const FAR_FIELD_SELF_SKIPS: u32 = 4u;

// Trace-probe mode's far field: the cache traced from the end of the ray's BVH segment (open
// space, so nothing is skipped there). A grazing ray runs inside the coarse voxels of the
// surface it left for a while; hits on voxels of that surface (within two voxels of its
// tangent plane, normal within 45 degrees) are stepped over, or the surface would shade
// itself.
fn trace_far_field(origin: vec3<f32>, dir: vec3<f32>, n: vec3<f32>) -> CacheHit {
    var start = u.probe_ray_m;
    for (var k = 0u; k < FAR_FIELD_SELF_SKIPS; k++) {
        var far = cache_trace_from(origin + dir * start, dir, FAR, false);
        if !far.hit {
            return far;
        }
        far.t += start;
        let size = cache.levels[far.level].voxel_size_m;
        let own_surface = abs(dot(dir * far.t, n)) < 2.0 * size
            && abs(dot(cache_hit_normal(far), n)) > 0.7;
        if !own_surface {
            return far;
        }
        start = far.t + 1.8 * size;
    }
    return cache_miss(FAR);
}

// Initial candidates, two strategies combined by resampled importance sampling (Talbot et al.
// 2005; Bitterli et al. 2020 use it for ReSTIR's initial candidates) with balance-heuristic
// MIS weights: one cosine-distributed BVH ray (what ReSTIR GI traces), and one point drawn on
// the scene's emitters by their power with a shadow ray (next-event estimation: a small bright
// emitter that lights the receiver directly is found by every pixel instead of by the rare ray
// that hits it). Candidate y_i gets the weight p(y_i) / (p_cos(y_i) + p_emit(y_i)); the kept
// one has W = (sum of weights) / p(kept).
@compute @workgroup_size(8, 8)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.trace_px) {
        return;
    }
    let index = id.y * u.trace_px.x + id.x;
    let s = pick_receiver(id.xy, index);
    surfaces[index] = s;
    if !has_surface(s) {
        initial[index] = empty_reservoir();
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let origin = offset_origin(s.position, n);
    let emitters_on = u.emitter_count > 0u;
    var sampler = sampler_new(u.seed, index, u.frame_index);
    var weight_sum = 0.0;
    var chosen = empty_reservoir();
    var chosen_pdf = 0.0;

    // The BVH ray.
    let local = cosine_hemisphere(sampler_next_2d(&sampler));
    let dir = frame_to_world(frame_from_normal(n), local);
    let pdf_cos = local.z * INV_PI;
    if pdf_cos > 0.0 {
        var r = empty_reservoir();
        var pdf_emit = 0.0;
        let hit = trace_closest(Ray(origin, 0.0, dir, u.probe_ray_m));
        var far = cache_miss(0.0);
        if hit.triangle == BVH_MISS && u.probe_ray_m < FAR {
            far = trace_far_field(origin, dir, n);
        }
        if far.hit {
            // The cache's emission stays out when emitter samples cover the emitters.
            r.position = origin + dir * far.t;
            r.radiance = pack_rgb9e5(cache_hit_radiance(far, !emitters_on));
            r.normal = pack_unit_vector(cache_hit_normal(far));
            r.fixed_radiance = r.radiance;
        } else if hit.triangle == BVH_MISS {
            r.position = dir;
            r.radiance = pack_rgb9e5(sky_radiance(u.sky, dir));
            r.flags = SAMPLE_SKY;
        } else {
            let shaded = shade_hit(dir, hit.t, hit.triangle, hit.barycentrics, &sampler);
            r.position = shaded.position;
            r.radiance = pack_rgb9e5(shaded.radiance);
            r.normal = pack_unit_vector(shaded.normal);
            r.fixed_radiance = pack_rgb9e5(shaded.fixed_radiance);
            r.albedo = pack4x8unorm(vec4(shaded.albedo, 0.0));
            if emitters_on {
                pdf_emit = emitter_pdf(hit.triangle, hit.t, dir);
            }
        }
        let p = luminance(unpack_rgb9e5(r.radiance)) * local.z;
        let w = p / (pdf_cos + pdf_emit);
        if w > 0.0 && w < FAR {
            weight_sum += w;
            chosen = r;
            chosen_pdf = p;
        }
    }

    // The emitter sample.
    if emitters_on {
        let light = visible_emitter_sample(s.position, n, origin, &sampler);
        if light.pdf > 0.0 {
            let cos_x = dot(light.wi, n);
            var r = empty_reservoir();
            r.position = s.position + light.wi * light.distance;
            r.radiance = pack_rgb9e5(light.radiance);
            r.normal = pack_unit_vector(light.normal);
            r.fixed_radiance = pack_rgb9e5(light.radiance);
            let p = luminance(unpack_rgb9e5(r.radiance)) * cos_x;
            // The BVH ray reaches emitters within its segment only.
            let pdf_ray = select(0.0, cos_x * INV_PI, light.distance <= u.probe_ray_m);
            let w = p / (pdf_ray + light.pdf);
            if w > 0.0 && w < FAR {
                weight_sum += w;
                if sampler_next_f32(&sampler) * weight_sum < w {
                    chosen = r;
                    chosen_pdf = p;
                }
            }
        }
    }
    if chosen_pdf > 0.0 {
        chosen.w = weight_sum / chosen_pdf;
        chosen.m = 1.0;
    } else {
        chosen = empty_reservoir();
        chosen.m = 1.0;
    }
    initial[index] = chosen;
}

@compute @workgroup_size(8, 8)
fn shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.trace_px) {
        return;
    }
    let index = id.y * u.trace_px.x + id.x;
    var r = temporal[index];
    if (u.flags & FLAG_TEMPORAL) == 0u {
        r = initial[index];
    }
    let fallback = r;
    if (u.flags & FLAG_SPATIAL) != 0u {
        r = resolved[index];
    }
    let s = surfaces[index];
    if (u.flags & FLAG_SHADOW) == 0u || !has_surface(s) || r.w <= 0.0 {
        resolved[index] = r;
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let origin = offset_origin(s.position, n);
    var dir: vec3<f32>;
    var t_max = FAR;
    if (r.flags & SAMPLE_SKY) != 0u {
        dir = r.position;
    } else {
        let d = r.position - origin;
        let len = length(d);
        dir = d / max(len, 1e-12);
        t_max = len * (1.0 - SHADOW_MARGIN);
    }
    let hit = trace_closest(Ray(origin, 0.0, dir, t_max));
    if hit.triangle == BVH_MISS {
        resolved[index] = r;
        return;
    }
    var back = fallback;
    back.flags |= SAMPLE_OCCLUDED;
    back.occluder_distance = hit.t;
    back.occluder_direction = pack_unit_vector(dir);
    resolved[index] = back;
}

@compute @workgroup_size(8, 8)
fn specular_trace(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.trace_px) {
        return;
    }
    let index = id.y * u.trace_px.x + id.x;
    var sample = SpecularSample(vec3(0.0), 0.0, vec3(0.0), 0u);
    let s = surfaces[index];
    let mr = gbuffer_metallic_roughness[s.pixel];
    if !has_surface(s) || !(mr.y < u.specular_max_roughness) {
        specular_samples[index] = sample;
        return;
    }
    let n = unpack_unit_vector(s.normal);
    let frame = frame_from_normal(n);
    let wo = frame_to_local(frame, normalize(u.camera.position - s.position));
    let brdf = brdf_new(gbuffer_base_color[s.pixel].xyz, mr.x, mr.y);
    // A stream of its own (the temporal pass draws from `0x9e3779b9`).
    var sampler = sampler_new(u.seed ^ vec2(0x6a09e667u, 0u), index, u.frame_index);
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
        sample.radiance = sky_radiance(u.sky, dir);
        sample.flags = SAMPLE_SKY;
    } else {
        let shaded = shade_hit(dir, hit.t, hit.triangle, hit.barycentrics, &sampler);
        sample.position = shaded.position;
        sample.radiance = shaded.radiance;
    }
    sample.pdf = pdf;
    specular_samples[index] = sample;
}

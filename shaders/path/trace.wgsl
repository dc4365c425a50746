// The GPU path tracer: implements gi-reference's light transport contract (the crate docs of
// gi-reference, "The light transport contract") operation for operation, and draws its random
// numbers in the reference's order from the same per-path PCG32, so a GPU sample equals the
// CPU's sample up to f32 rounding.
//
// - Unidirectional path tracing with next-event estimation and multiple importance sampling
//   (Veach 1997, ch. 9, power heuristic), Russian roulette after RUSSIAN_ROULETTE_START
//   scatterings.
// - With the shader def DIRECT_ONLY: the reference's Mode::Direct (camera-ray emission or sky
//   plus every punctual light at the first hit).
//
// Each invocation adds `spp` samples to one pixel's running sums, starting at sample index
// `sample_offset`, so progressive frames, and the dispatches a frame is cut into, add up to
// exactly one long render. A dispatch covers the image rows from `first_row` on; its samples
// and rows are chosen so that its loops stay within budget (`gi_tiers::path::dispatch`), and
// the loop check at the end tells the tier when they did not.
//
// Bind group 0: uniforms, the scene (`gi_gpu::GpuScene`, declared in `path/scene.wgsl`), the
// accumulation buffers.
// Bind group 1: the BVH (`gi_gpu::bvh::GpuBvh`).
//
// What a light delivers (punctual lights, the sky, a point drawn on the emitters) comes from
// `gi::lights`, the statement of those rules the brick cache's lighting uses too.

#import gi::math::PI
#import gi::sampling::{Sampler, sampler_new, sampler_next_f32, sampler_next_2d, cosine_hemisphere, power_heuristic, Frame, frame_from_normal, frame_to_local, frame_to_world}
#import gi::brdf::{ViewedBrdf, brdf_seen_from, viewed_eval, viewed_pdf, viewed_sample, is_finite}
#import gi::bvh::{Ray, Hit, trace_closest, trace_any, BVH_MISS}
#import gi::camera::{Camera, camera_ray}
#import gi::scene::{triangles, selection, lights, emission, geometric_normal, material_of, tex_coords, mapped_normal, material_brdf, normalize_or, orient_shading_normal, material_alpha, set_blend_policy, BLEND_HASHED, BLEND_PASS, BLEND_OPAQUE, ALPHA_BLEND}
#import gi::sky::Sky
#import gi::lights::{LIGHT_DIRECTIONAL, light_incident, sky_radiance, sample_emitter, emitter_pdf}

const RUSSIAN_ROULETTE_START: u32 = 3u;
const RUSSIAN_ROULETTE_MAX_SURVIVAL: f32 = 0.95;
// Shadow rays stop short of a light at distance d by this relative margin (the reference's
// `shadow_distance`).
const SHADOW_MARGIN: f32 = 1e-4;
const FAR: f32 = 3.40282347e38;

// Mirror of `gi_tiers::path::PathUniforms`. The sky's fields are those of `gi::sky::Sky`,
// which `sky()` assembles from them.
struct PathUniforms {
    camera: Camera,
    sky_zenith: vec4<f32>,
    sky_horizon: vec4<f32>,
    sky_ground: vec4<f32>,
    size_px: vec2<u32>,
    sample_offset: u32,
    spp: u32,
    // Render seed, low then high 32 bits.
    seed: vec2<u32>,
    emitter_count: u32,
    light_count: u32,
    // 1 when the sky emits anything.
    sky_emits: u32,
    default_material: u32,
    // 0 constant sky (`sky_zenith` is its radiance), 1 gradient.
    sky_kind: u32,
    max_depth: u32,
    // First image row of this dispatch.
    first_row: u32,
    // Iterations of the loop check (2), unknown to the compiler.
    loop_check: u32,
    pad_a: u32,
    pad_b: u32,
}

@group(0) @binding(0) var<uniform> uniforms: PathUniforms;
// Per pixel: sum of samples (rgb) and count of non-finite samples (w).
@group(0) @binding(8) var<storage, read_write> accum_sum: array<vec4<f32>>;
// Per pixel: sum of squared samples, per channel.
@group(0) @binding(9) var<storage, read_write> accum_sum_sq: array<vec4<f32>>;
// What the dispatches of a frame counted: rays traced (closest-hit and shadow rays), a u64 as
// (low, high) words at STATS_RAYS_LOW and STATS_RAYS_HIGH; invocations whose loops were cut
// short at STATS_CUT_INVOCATIONS.
@group(0) @binding(10) var<storage, read_write> trace_stats: array<atomic<u32>, 4>;
const STATS_RAYS_LOW: u32 = 0u;
const STATS_RAYS_HIGH: u32 = 1u;
const STATS_CUT_INVOCATIONS: u32 = 2u;

// Rays this invocation traced, added to `trace_stats` once at its end.
var<private> rays_traced: u32;

// What a path sees at a surface hit (the reference's `Surface`).
struct Surface {
    p: vec3<f32>,
    ng: vec3<f32>,
    frame: Frame,
    wo: vec3<f32>,
    // The BRDF seen from `wo`.
    brdf: ViewedBrdf,
    emitted: vec3<f32>,
}

// The uniforms' sky as `gi::lights` reads it.
fn sky() -> Sky {
    return Sky(uniforms.sky_zenith, uniforms.sky_horizon, uniforms.sky_ground, uniforms.sky_kind, 0u, 0u, 0u);
}

// The reference's `Reference::surface` for a hit with barycentrics `b` of v1 and v2.
fn surface_at(dir: vec3<f32>, triangle: u32, b: vec2<f32>) -> Surface {
    let tri = triangles[triangle];
    let b1 = b.x;
    let b2 = b.y;
    let b0 = 1.0 - b1 - b2;
    var s: Surface;
    s.p = tri.pa.xyz + (tri.pb.xyz - tri.pa.xyz) * b1 + (tri.pc.xyz - tri.pa.xyz) * b2;
    let wo = -dir;
    var ng_front = geometric_normal(tri);
    if all(ng_front == vec3<f32>(0.0)) {
        ng_front = wo;
    }
    let front_facing = dot(ng_front, wo) >= 0.0;
    s.ng = select(-ng_front, ng_front, front_facing);
    let material = material_of(triangle, uniforms.default_material);
    // Level 0, exactly as the reference samples.
    let tc = tex_coords(triangle, vec3(b0, b1, b2), 0.0);
    let n = tri.na.xyz * b0 + tri.nb.xyz * b1 + tri.nc.xyz * b2;
    let ns = orient_shading_normal(s.ng, mapped_normal(material, normalize_or(n, s.ng), tc), wo);
    s.frame = frame_from_normal(ns);
    let brdf = material_brdf(material, tc);
    s.emitted = vec3<f32>(0.0);
    if front_facing || material.double_sided != 0u {
        s.emitted = emission(material, tc);
    }
    s.wo = frame_to_local(s.frame, wo);
    s.brdf = brdf_seen_from(brdf, s.wo);
    return s;
}

// The reference's `offset_origin`: `p` pushed off its surface along `n`.
fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    return p + n * (1e-4 * (1.0 + max(max(a.x, a.y), a.z)));
}

fn occluded(origin: vec3<f32>, dir: vec3<f32>, t_max: f32) -> bool {
    rays_traced += 1u;
    return trace_any(Ray(origin, 0.0, dir, t_max));
}

fn closest(origin: vec3<f32>, dir: vec3<f32>) -> Hit {
    rays_traced += 1u;
    return trace_closest(Ray(origin, 0.0, dir, FAR));
}

// Every punctual light through `WorldLight::incident`, with one shadow ray each.
fn punctual_lights(s: Surface, x: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < uniforms.light_count; i++) {
        let light = lights[i];
        let incident = light_incident(light, s.p);
        if dot(incident.wi, s.ng) <= 0.0 {
            continue;
        }
        let wi_local = frame_to_local(s.frame, incident.wi);
        let contribution = viewed_eval(s.brdf, wi_local) * wi_local.z * incident.irradiance;
        if all(contribution == vec3<f32>(0.0)) {
            continue;
        }
        var t_max = FAR;
        if light.kind != LIGHT_DIRECTIONAL {
            t_max = incident.distance * (1.0 - SHADOW_MARGIN);
        }
        if !occluded(x, incident.wi, t_max) {
            sum += contribution;
        }
    }
    return sum;
}

// One next-event sample of the emissive triangles, MIS-weighted against BRDF sampling.
fn sample_emitters(s: Surface, x: vec3<f32>, sampler: ptr<function, Sampler>) -> vec3<f32> {
    let u_select = sampler_next_f32(sampler);
    let u_point = sampler_next_2d(sampler);
    let light = sample_emitter(x, u_select, u_point, uniforms.emitter_count, uniforms.default_material);
    if light.pdf <= 0.0 || dot(light.wi, s.ng) <= 0.0 {
        return vec3<f32>(0.0);
    }
    let wi_local = frame_to_local(s.frame, light.wi);
    let contribution = viewed_eval(s.brdf, wi_local) * wi_local.z * light.radiance;
    if all(contribution == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let w = power_heuristic(light.pdf, viewed_pdf(s.brdf, wi_local));
    if occluded(x, light.wi, light.distance * (1.0 - SHADOW_MARGIN)) {
        return vec3<f32>(0.0);
    }
    return contribution * (w / light.pdf);
}

// One cosine-weighted next-event sample of the sky, MIS-weighted against BRDF sampling.
fn sample_sky(s: Surface, x: vec3<f32>, sampler: ptr<function, Sampler>) -> vec3<f32> {
    let wi = cosine_hemisphere(sampler_next_2d(sampler));
    let pdf = wi.z / PI;
    if pdf <= 0.0 {
        return vec3<f32>(0.0);
    }
    let wi_world = frame_to_world(s.frame, wi);
    if dot(wi_world, s.ng) <= 0.0 {
        return vec3<f32>(0.0);
    }
    let contribution = viewed_eval(s.brdf, wi) * wi.z * sky_radiance(sky(), wi_world);
    if all(contribution == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let w = power_heuristic(pdf, viewed_pdf(s.brdf, wi));
    if occluded(x, wi_world, FAR) {
        return vec3<f32>(0.0);
    }
    return contribution * (w / pdf);
}

// Radiance along one camera ray, as the reference's `direct_radiance` or `path_radiance`.
fn radiance(camera_origin: vec3<f32>, camera_dir: vec3<f32>, sampler: ptr<function, Sampler>) -> vec3<f32> {
#ifdef DIRECT_ONLY
#ifdef BLEND_LAYER
    // The real-time tiers' direct light sees the nearest alpha-`BLEND` surface as their G-buffer
    // does: a layer over the surface behind it, blended by its alpha (the hashed rule would
    // leave the binomial noise of the few samples a pixel gets). Blended surfaces stop the first
    // ray; when it stops at another surface, nothing blended lies in front, and that is the hit
    // the hashed rule gives too.
    set_blend_policy(BLEND_OPAQUE);
    let front = closest(camera_origin, camera_dir);
    set_blend_policy(BLEND_HASHED);
    if front.triangle == BVH_MISS {
        return sky_radiance(sky(), camera_dir);
    }
    let s = surface_at(camera_dir, front.triangle, front.barycentrics);
    let lit = s.emitted + punctual_lights(s, offset_origin(s.p, s.ng));
    let material = material_of(front.triangle, uniforms.default_material);
    if material.alpha_mode != ALPHA_BLEND {
        return lit;
    }
    let b = front.barycentrics;
    let alpha = clamp(material_alpha(material, tex_coords(front.triangle, vec3(1.0 - b.x - b.y, b.x, b.y), 0.0)), 0.0, 1.0);
    // Behind it, every blended surface is passed: one layer, as in the G-buffer.
    set_blend_policy(BLEND_PASS);
    let hit = closest(camera_origin, camera_dir);
    set_blend_policy(BLEND_HASHED);
    var behind = sky_radiance(sky(), camera_dir);
    if hit.triangle != BVH_MISS {
        let t = surface_at(camera_dir, hit.triangle, hit.barycentrics);
        behind = t.emitted + punctual_lights(t, offset_origin(t.p, t.ng));
    }
    return mix(behind, lit, alpha);
#else
    let hit = closest(camera_origin, camera_dir);
    if hit.triangle == BVH_MISS {
        return sky_radiance(sky(), camera_dir);
    }
    let s = surface_at(camera_dir, hit.triangle, hit.barycentrics);
    return s.emitted + punctual_lights(s, offset_origin(s.p, s.ng));
#endif
#else
    let sky_emits = uniforms.sky_emits != 0u;
    var origin = camera_origin;
    var dir = camera_dir;
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    // The BRDF-sampled pdf of the current ray and the sky's next-event pdf for it; camera rays
    // (depth 0) weigh emission with 1.
    var last_brdf_pdf = 0.0;
    var last_sky_pdf = 0.0;
    var depth = 0u;
    loop {
        let hit = closest(origin, dir);
        if hit.triangle == BVH_MISS {
            if sky_emits {
                var w = 1.0;
                if depth > 0u {
                    w = power_heuristic(last_brdf_pdf, last_sky_pdf);
                }
                l += beta * sky_radiance(sky(), dir) * w;
            }
            break;
        }
        let s = surface_at(dir, hit.triangle, hit.barycentrics);
        if any(s.emitted != vec3<f32>(0.0)) {
            var w = 1.0;
            if depth > 0u {
                w = power_heuristic(last_brdf_pdf, emitter_pdf(hit.triangle, hit.t, dir));
            }
            l += beta * s.emitted * w;
        }
        if depth == uniforms.max_depth {
            break;
        }
        depth += 1u;

        let x = offset_origin(s.p, s.ng);
        var direct = punctual_lights(s, x);
        if uniforms.emitter_count > 0u {
            direct += sample_emitters(s, x, sampler);
        }
        if sky_emits {
            direct += sample_sky(s, x, sampler);
        }
        l += beta * direct;

        let u_lobe = sampler_next_f32(sampler);
        let bs = viewed_sample(s.brdf, u_lobe, sampler_next_2d(sampler));
        if !bs.valid {
            break;
        }
        let wi = frame_to_world(s.frame, bs.wi);
        // Directions below the geometric surface would leak through it.
        if dot(wi, s.ng) <= 0.0 {
            break;
        }
        beta *= bs.f * (bs.wi.z / bs.pdf);
        last_brdf_pdf = bs.pdf;
        last_sky_pdf = bs.wi.z / PI;
        origin = x;
        dir = wi;

        if depth >= RUSSIAN_ROULETTE_START {
            let survival = min(max(max(beta.x, beta.y), beta.z), RUSSIAN_ROULETTE_MAX_SURVIVAL);
            if sampler_next_f32(sampler) >= survival {
                break;
            }
            beta /= survival;
        }
    }
    return l;
#endif
}

// Whether every loop of this invocation ran to its end. Lavapipe (Mesa's llvmpipe) ends all of
// an invocation's loops for good once they have run 65,535 iterations together; from then on
// a loop stops after its first iteration. This loop asks for `loop_check` (2) iterations, a
// count the compiler cannot see and so cannot unroll; on any other device it runs both.
fn loops_ran_to_completion() -> bool {
    var iterations = 0u;
    loop {
        iterations += 1u;
        if iterations >= uniforms.loop_check {
            break;
        }
    }
    return iterations >= uniforms.loop_check;
}

@compute @workgroup_size(8, 8)
fn trace(@builtin(global_invocation_id) invocation: vec3<u32>) {
    let size = uniforms.size_px;
    let id = vec2(invocation.x, invocation.y + uniforms.first_row);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let pixel = id.y * size.x + id.x;
    // Sums continue from the buffer sample by sample, so splitting samples into frames and
    // dispatches changes neither the values nor the order in which they are added.
    var sum = accum_sum[pixel];
    var sum_sq = accum_sum_sq[pixel];
    let width = f32(size.x);
    let height = f32(size.y);
    for (var i = 0u; i < uniforms.spp; i++) {
        var sampler = sampler_new(uniforms.seed, pixel, uniforms.sample_offset + i);
        let jitter = sampler_next_2d(&sampler);
        let u = (f32(id.x) + jitter.x) / width;
        let v = (f32(id.y) + jitter.y) / height;
        let dir = camera_ray(uniforms.camera, vec2<f32>(u, v));
        let value = radiance(uniforms.camera.position, dir, &sampler);
        if is_finite(value.x) && is_finite(value.y) && is_finite(value.z) {
            sum += vec4<f32>(value, 0.0);
            sum_sq += vec4<f32>(value * value, 0.0);
        } else {
            sum.w += 1.0;
        }
    }
    accum_sum[pixel] = sum;
    accum_sum_sq[pixel] = sum_sq;
    // A carry out of the low word (the old value plus ours wrapped) goes to the high word.
    let before = atomicAdd(&trace_stats[STATS_RAYS_LOW], rays_traced);
    if before + rays_traced < before {
        atomicAdd(&trace_stats[STATS_RAYS_HIGH], 1u);
    }
    if !loops_ran_to_completion() {
        atomicAdd(&trace_stats[STATS_CUT_INVOCATIONS], 1u);
    }
}

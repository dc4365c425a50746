// Direct injection into the brick radiance cache (pass `cache/inject`): HSGI, GDC 2023, "Light
// Propagation - Direct Lighting" (analytic lights with ray-traced visibility) and SmartGI,
// SIGGRAPH 2024, "Lighting Injection" (the first bounce from the light sources with shadow
// rays, per visible voxel face; here per surfel side, HSGI's surfel being "voxel + normal").
//
// One 64-thread workgroup per scheduled brick, one thread per voxel. For both sides of every
// occupied voxel (normals +n and -n), the irradiance from every punctual light arriving at the
// point just outside the surfel on that side (`gi::cache::lighting::side_point`), on a surface
// of the side's normal, with one exact shadow ray through the BVH each: `WorldLight::incident`
// times the cosine, as the reference evaluates punctual lights. Emissive surfaces and the sky
// reach voxels through `cache/propagate`. Both sides are always lit: a side facing into solid
// geometry finds it with its shadow rays. A side whose direct light changed by more than
// LIGHT_CHANGE (a light moved or switched) pulls its voxel's age down to CHANGED_AGE, so its
// indirect light follows quickly.
//
// Bind group 0: `gi::cache::lighting`; 1: the BVH (`gi::bvh`); 2: the cache (`gi::cache::data`).

#import gi::bvh::{Ray, trace_any}
#import gi::scene::lights
#import gi::lights::{LIGHT_DIRECTIONAL, light_incident}
#import gi::packing::{pack_rgb9e5, unpack_rgb9e5}
#import gi::math::luminance
#import gi::cache::data::{
    cache_voxels, cache_direct, cache_voxel_index, cache_side_slot, cache_side_normal,
    cache_voxel_age, CACHE_SIDE_COUNT
}
#import gi::cache::lighting::{lighting, scheduled_voxel, scheduled_voxel_occupied, side_point}

// Shadow rays towards a point or spot light stop short of it by this relative margin (the
// reference's `shadow_distance`).
const SHADOW_MARGIN: f32 = 1e-4;
const FAR: f32 = 3.40282347e38;
// Relative change of a side's direct luminance that counts as "the lighting changed".
const LIGHT_CHANGE: f32 = 0.25;
// Age a changed voxel is pulled down to: its next indirect updates weigh 1/3, 1/4, ...
const CHANGED_AGE: u32 = 2u;

// Irradiance from every punctual light at `x` on a surface of normal `n`, shadow rays from `x`.
fn punctual_irradiance(x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var irradiance = vec3<f32>(0.0);
    for (var i = 0u; i < lighting.light_count; i++) {
        let light = lights[i];
        let incident = light_incident(light, x);
        let cos_theta = dot(incident.wi, n);
        if cos_theta <= 0.0 || all(incident.irradiance == vec3<f32>(0.0)) {
            continue;
        }
        var t_max = FAR;
        if light.kind != LIGHT_DIRECTIONAL {
            t_max = incident.distance * (1.0 - SHADOW_MARGIN);
        }
        if !trace_any(Ray(x, 0.0, incident.wi, t_max)) {
            irradiance += incident.irradiance * cos_theta;
        }
    }
    return irradiance;
}

@compute @workgroup_size(64)
fn inject(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) bit: u32,
) {
    if !scheduled_voxel_occupied(group.x, bit) {
        return;
    }
    let lit = scheduled_voxel(group.x, bit);
    var changed = false;
    for (var side = 0u; side < CACHE_SIDE_COUNT; side++) {
        let slot = cache_side_slot(lit.v, side);
        let n_side = cache_side_normal(lit.n, side);
        let irradiance = punctual_irradiance(side_point(lit.center, lit.size_m, n_side), n_side);
        let new_luminance = luminance(irradiance);
        let old_luminance = luminance(unpack_rgb9e5(cache_direct[slot]));
        let scale = max(new_luminance, old_luminance);
        if abs(new_luminance - old_luminance) > LIGHT_CHANGE * scale && scale > 1e-6 {
            changed = true;
        }
        cache_direct[slot] = pack_rgb9e5(irradiance);
    }
    if changed && cache_voxel_age(lit.surface) > CHANGED_AGE {
        cache_voxels[cache_voxel_index(lit.v)].state = (lit.surface.state & ~0xffu) | CHANGED_AGE;
    }
}

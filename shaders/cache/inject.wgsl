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
// geometry finds it with its shadow rays. Where a side's direct light changed (a light moved,
// turned or was switched), the share of the side's reflected light that changed is measured
// against the light it had: the voxel's change (`cache_voxel_change`) is raised to it, and
// `cache/propagate` weighs the voxel's next update, and those of its neighbours that see it,
// by that measured change rather than by the voxel's age. The shadow rays are exact, so in a
// still scene the direct light is the same to the bit and the change stays 0.
//
// Bind group 0: `gi::cache::lighting`; 1: the BVH (`gi::bvh`); 2: the cache (`gi::cache::data`).

#import gi::bvh::{Ray, trace_any}
#import gi::scene::lights
#import gi::lights::{LIGHT_DIRECTIONAL, light_incident}
#import gi::packing::{pack_rgb9e5, unpack_rgb9e5}
#import gi::math::luminance
#import gi::cache::data::{
    cache_voxels, cache_direct, cache_indirect, cache_voxel_index, cache_side_slot,
    cache_side_normal, cache_voxel_age, cache_voxel_change, cache_state_with_change, CACHE_SIDE_COUNT
}
#import gi::cache::lighting::{lighting, scheduled_voxel, scheduled_voxel_occupied, side_point}

// Shadow rays towards a point or spot light stop short of it by this relative margin (the
// reference's `shadow_distance`).
const SHADOW_MARGIN: f32 = 1e-4;
const FAR: f32 = 3.40282347e38;

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
    // The largest share of a side's reflected light (direct + indirect irradiance) that the
    // new direct light changed.
    var change = 0.0;
    for (var side = 0u; side < CACHE_SIDE_COUNT; side++) {
        let slot = cache_side_slot(lit.v, side);
        let n_side = cache_side_normal(lit.n, side);
        let packed = pack_rgb9e5(punctual_irradiance(side_point(lit.center, lit.size_m, n_side), n_side));
        // Compared as stored, so that the same light gives exactly no change.
        let new_luminance = luminance(unpack_rgb9e5(packed));
        let old_luminance = luminance(unpack_rgb9e5(cache_direct[slot]));
        let indirect = luminance(unpack_rgb9e5(cache_indirect[slot]));
        let scale = max(new_luminance, old_luminance) + indirect;
        if scale > 0.0 {
            change = max(change, abs(new_luminance - old_luminance) / scale);
        }
        cache_direct[slot] = packed;
    }
    // Kept until `cache/propagate` has followed it (this frame's, when the brick is scheduled;
    // a later one after `cache/inject_all`): the larger of the two where it was not yet. A voxel
    // never lit before (age 0: new, or lit during a fill) had no light to change.
    let measured = lighting.change_gain > 0.0 && cache_voxel_age(lit.surface) > 0u;
    if measured && change > cache_voxel_change(lit.surface) {
        cache_voxels[cache_voxel_index(lit.v)].state = cache_state_with_change(lit.surface.state, change);
    }
}

// Multi-bounce propagation in the brick radiance cache (pass `cache/propagate`): HSGI, GDC 2023,
// "Light Propagation - Indirect Lighting" (hemisphere gather, temporal accumulation) and "Origin
// Geometry" (rays start about one voxel off the surface); SmartGI, SIGGRAPH 2024, "Lighting
// Injection" (multi bounce: each visible face gathers the previous frame's voxel lighting; here
// each surfel side, HSGI's surfel being "voxel + normal").
//
// One 64-thread workgroup per 16 occupied voxel sides of the scheduled bricks (the list
// `cache/propagate_list` made), four threads per side sharing its rays; the workgroups past the
// listed sides end at once. For each side of every
// occupied voxel (normals +n and -n),
// `rays_per_side` cosine-distributed directions about the side's normal are traced through the
// cache from the point just outside the surfel on that side (`gi::cache::lighting::side_point`,
// half a voxel diagonal off the center). A hit contributes the reflected radiance of the side it
// sees (albedo / pi x its direct + indirect irradiance), a miss the sky: E = pi mean(L). Light
// emitted by emissive triangles is not taken from the hit voxels' emission but sampled directly
// (next-event estimation through the scene's emitter table, `rays_per_side` samples taken at the
// side's surface, half a voxel out from its center, with BVH shadow rays from the side point, E =
// mean(Le cos / pdf)): a small bright emitter is then found by every sample instead of by the rare
// ray that hits its voxel, and nothing is counted twice (`cache/inject` adds only punctual
// lights). The sum is the side's indirect irradiance, accumulated over updates with weight 1 / age
// (age = min(age + 1, max_age)). When the cache keeps it, the emitters' samples alone are
// accumulated the same way into `cache_emitted`: a caller that samples the emitters itself at a
// surface point (the PC tier at its rays' hits) takes `cache_indirect - cache_emitted`, the
// light that arrives after a bounce.
//
// Measured change (temporal gradients for the cache, after A-SVGF, Schied et al. 2018): each ray
// also brings the change of the voxel it hits (`cache_voxel_change`: raised by `cache/inject`
// where the direct light changed, set by this pass from what a voxel's own rays found), and the
// side's gathered change g is the changed share of its new irradiance. The update weighs
// max(1 / age, min(change_gain max(g, own change), 1)) instead of 1 / age alone, the voxel's
// age is lowered to match (so the updates after it weigh more too, and the smoothing grows
// back), and the voxel's new change is half the larger of its own and g times the indirect
// share of its light: a change passes on through the bounces it travels and fades by half at
// each, and in a still scene every change is exactly 0, so nothing is weighed differently.
//
// A gather from last frame's lighting (HSGI's and SmartGI's "previous frame" bounce): this pass
// writes nothing the cache's rays read. The accumulated value goes to `propagate_scratch` and
// the voxel's age stays as it was; `cache/propagate_resolve`, the next pass, copies both into
// the cache. Every ray therefore sees `cache_indirect` and the ages as the previous update left
// them, whatever order the workgroups run in, and the result is the same on every run. The
// direct light it reflects (`cache_direct`) is this frame's: `cache/inject` is recorded before
// this pass, so it has finished when this pass starts.
//
// Bind group 0: `gi::cache::lighting`; 1: the BVH (`gi::bvh`); 2: the cache (`gi::cache::data`).

#import gi::math::PI
#import gi::sampling::{Sampler, sampler_new, sampler_next_f32, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::lights::{sky_radiance, sample_emitter}
#import gi::bvh::{Ray, trace_any}
#import gi::packing::{pack_rgb9e5, unpack_rgb9e5}
#import gi::math::luminance
#import gi::cache::data::{
    cache_voxels, cache_direct, cache_indirect, cache_emitted, cache_keeps_emitted,
    cache_side_slot, cache_side_normal, cache_voxel_index, cache_voxel_change,
    cache_state_with_change, CACHE_SIDE_COUNT
}
#import gi::cache::trace::{cache_trace, cache_hit_radiance}
#import gi::cache::lighting::{
    lighting, scheduled_voxel, propagate_scratch, propagate_scratch_slot, propagated_age,
    side_point, propagate_entries, PROPAGATE_NO_ENTRY
}

const FAR: f32 = 3.0e38;
// Shadow rays stop short of the emitter point by this relative margin (the reference's
// `shadow_distance`).
const SHADOW_MARGIN: f32 = 1e-4;

// Radiance arriving along `dir` at `origin` after at least one bounce (rgb): the cache's
// reflected side radiance (emission is sampled directly), or the sky where the ray leaves the
// cache; and the hit voxel's measured change (w; 0 for the sky). During a fill (`max_age` 0,
// `gi_cache::lighting::FILL_FRACTION`) a ray that finds nothing may have passed where a wall is
// still queued, so it brings nothing: the fill's lighting starts dark and the updates after it
// add the sky, rather than leaking it indoors.
fn bounced_radiance(origin: vec3<f32>, dir: vec3<f32>) -> vec4<f32> {
    let hit = cache_trace(origin, dir, FAR);
    if hit.hit {
        let change = cache_voxel_change(cache_voxels[cache_voxel_index(hit.voxel)]);
        return vec4(cache_hit_radiance(hit, false), change);
    }
    if lighting.max_age == 0u {
        return vec4(0.0);
    }
    return vec4(sky_radiance(lighting.sky, dir), 0.0);
}

// One next-event sample of the emissive triangles for a surface of normal `n` at `surface`:
// the irradiance estimate Le cos / pdf there, 0 when the sample is behind the surface or the
// shadow ray from `origin` (the side point, off the surface's own voxels) to it is blocked.
// A sample in front of the surface but below the side point's plane (a neighbouring wall's
// strip next to the edge) counts: rejecting those lost 1.3% of the light in the furnace test.
// The estimate is taken at the surface, not at the side point: the side point lies most of a
// voxel towards the light, and an emitter a few voxels away would read that much nearer (the
// cornell-box's ceiling light lit its floor 6% too brightly so).
fn emitter_irradiance(
    surface: vec3<f32>,
    origin: vec3<f32>,
    n: vec3<f32>,
    sampler: ptr<function, Sampler>,
) -> vec3<f32> {
    let u_select = sampler_next_f32(sampler);
    let u_point = sampler_next_2d(sampler);
    let light = sample_emitter(surface, u_select, u_point, lighting.emitter_count, lighting.default_material);
    let cos_theta = dot(light.wi, n);
    if light.pdf <= 0.0 || cos_theta <= 0.0 || all(light.radiance == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let to_light = surface + light.wi * light.distance - origin;
    let distance = length(to_light);
    if trace_any(Ray(origin, 0.0, to_light / distance, distance * (1.0 - SHADOW_MARGIN))) {
        return vec3<f32>(0.0);
    }
    return light.radiance * (cos_theta / light.pdf);
}

// Threads per voxel side: each takes every RAY_LANES-th of the side's rays (and emitter
// samples), and the workgroup sums them. Spreading a side's rays over threads shortens each
// invocation's serial chain of cache traces and shadow rays: the pass has too few voxels per
// frame (512 bricks x about 20 occupied voxels x 2 sides) to hide that latency otherwise.
const RAY_LANES: u32 = 4u;
// Voxel sides per workgroup (`propagate_list.wgsl`'s `GROUP_SIDES`), and workgroups per
// scheduled brick: a brick lists at most 64 x 2 sides.
const GROUP_SIDES: u32 = 16u;
const PROPAGATE_ROWS: u32 = 8u;

// Each thread's share of its side's irradiance sum (bounced x pi + emitted, rgb; in w the
// luminance of its changed part), and of its emitted part, by thread index.
var<workgroup> lane_sums: array<vec4<f32>, 64>;
var<workgroup> lane_emitted: array<vec3<f32>, 64>;

// The random sequence of lane `lane` of side `side` of world voxel `voxel` at `level` for this
// update. Keyed by the side's place in the world rather than its pool slot, so the result does
// not depend on the brick IDs the allocator handed out (which follow the order bricks were
// filled in).
fn side_sampler(level: u32, voxel: vec3<i32>, side: u32, lane: u32) -> Sampler {
    let key = vec2<u32>(bitcast<u32>(voxel.x) ^ lighting.seed, bitcast<u32>(voxel.y));
    let place = bitcast<u32>(voxel.z) * 16u + level * CACHE_SIDE_COUNT + side;
    return sampler_new(key, place, lighting.frame_index * RAY_LANES + lane);
}

// The first entry of this workgroup, for the whole workgroup.
var<workgroup> first_entry: u32;

// Workgroups: GROUP_SIDES entries of `propagate_entries` each, (x, y) covering entries
// (x * PROPAGATE_ROWS + y) * GROUP_SIDES onwards, as many as the scheduled bricks could list
// (`gi_cache::lighting` dispatches one x per brick); those past the entries listed this frame
// stop at once. Threads: RAY_LANES per entry (thread t serves entry t % GROUP_SIDES, lane
// t / GROUP_SIDES).
@compute @workgroup_size(64)
fn propagate(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) thread: u32,
) {
    let slot_in_group = thread % GROUP_SIDES;
    let lane = thread / GROUP_SIDES;
    let first = (group.x * PROPAGATE_ROWS + group.y) * GROUP_SIDES;
    if thread == 0u {
        first_entry = propagate_entries[first];
    }
    // Entries are listed from the start, so a workgroup whose first entry is none has none.
    if workgroupUniformLoad(&first_entry) == PROPAGATE_NO_ENTRY {
        return;
    }
    var entry = propagate_entries[first + slot_in_group];
    // The last workgroup's tail: the list is cleared before `cache/propagate_list`.
    let listed = entry != PROPAGATE_NO_ENTRY;
    entry -= 1u;
    let scheduled = entry >> 7u;
    let bit = (entry >> 1u) & 63u;
    let side = entry & 1u;
    let rays = max(lighting.rays_per_side, 1u);
    var sum = vec3<f32>(0.0);
    var changed = 0.0;
    var emitted = vec3<f32>(0.0);
    if listed {
        let lit = scheduled_voxel(scheduled, bit);
        let n_side = cache_side_normal(lit.n, side);
        let frame = frame_from_normal(n_side);
        // Gather rays and emitter samples leave from the same point. It lies in a neighbouring
        // voxel, which the trace skips: where the surface lies on a voxel boundary that
        // neighbour holds the same surface.
        let x = side_point(lit.center, lit.size_m, n_side);
        // Where the side's surface lies for a lookup: `cache_irradiance` reads the voxel whose
        // center is half a voxel behind the point it is asked for.
        let surface = lit.center + n_side * (0.5 * lit.size_m);
        var sampler = side_sampler(lit.level, lit.voxel, side, lane);
        for (var i = lane; i < rays; i += RAY_LANES) {
            let dir = frame_to_world(frame, cosine_hemisphere(sampler_next_2d(&sampler)));
            let bounced = bounced_radiance(x, dir);
            sum += bounced.rgb * PI;
            changed += bounced.w * luminance(bounced.rgb) * PI;
            if lighting.emitter_count > 0u {
                emitted += emitter_irradiance(surface, x, n_side, &sampler);
            }
        }
    }
    lane_sums[thread] = vec4(sum + emitted, changed);
    lane_emitted[thread] = emitted;
    workgroupBarrier();
    if !listed || lane != 0u {
        return;
    }
    var total = vec4<f32>(0.0);
    var total_emitted = vec3<f32>(0.0);
    for (var l = 0u; l < RAY_LANES; l++) {
        total += lane_sums[slot_in_group + GROUP_SIDES * l];
        total_emitted += lane_emitted[slot_in_group + GROUP_SIDES * l];
    }
    let lit = scheduled_voxel(scheduled, bit);
    let age = propagated_age(lit);
    // The changed share of what the rays found, and the weight it asks for.
    let found = luminance(total.rgb);
    let gathered = select(0.0, min(total.w / found, 1.0), found > 0.0);
    let own = cache_voxel_change(lit.surface);
    let lambda = min(lighting.change_gain * max(gathered, own), 1.0);
    // Age 0 (max_age 0, during a fill) replaces without keeping history.
    let weight = max(1.0 / f32(max(age, 1u)), lambda);
    // The age whose weight this was (so the next update weighs 1 / (that + 1)); a fill's 0 stays.
    let new_age = min(age, max(u32(round(1.0 / weight)), 1u));
    let slot = cache_side_slot(lit.v, side);
    let irradiance = total.rgb / f32(rays);
    let history = unpack_rgb9e5(cache_indirect[slot]);
    let indirect = mix(history, irradiance, weight);
    let scratch = propagate_scratch_slot(scheduled, bit, side);
    propagate_scratch[scratch] = pack_rgb9e5(indirect);
    // The share of the side's reflected light that changed through its gather.
    let light = luminance(unpack_rgb9e5(cache_direct[slot]) + indirect);
    let passed_on = select(0.0, gathered * luminance(indirect) / light, light > 0.0);
    propagate_scratch[scratch + 1u] = cache_state_with_change(new_age, 0.5 * max(own, passed_on));
    if cache_keeps_emitted() {
        let emitted_history = unpack_rgb9e5(cache_emitted[slot]);
        propagate_scratch[scratch + 2u] =
            pack_rgb9e5(mix(emitted_history, total_emitted / f32(rays), weight));
    }
}

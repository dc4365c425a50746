// The second half of multi-bounce propagation in the brick radiance cache (pass
// `cache/propagate_resolve`): HSGI, GDC 2023, "Light Propagation - Indirect Lighting" and
// SmartGI, SIGGRAPH 2024, "Lighting Injection" gather from the previous frame's lighting, so
// `cache/propagate` leaves the cache untouched and writes its results to `propagate_scratch`;
// this pass stores them. Kept apart so that no ray of `cache/propagate` reads a value another
// workgroup of the same dispatch has already replaced (a side's light, a voxel's change), which
// would make the result depend on the order the workgroups run in.
//
// One 64-thread workgroup per scheduled brick, one thread per voxel: for every occupied voxel,
// both sides' new indirect irradiance (and its emitted part, when the cache keeps it) are copied
// into `cache_indirect` (and `cache_emitted`), and the voxel's age and measured change set as
// `cache/propagate` left them: the lower of its two sides' ages, the larger change.
//
// Bind group 0: `gi::cache::lighting`; 2: the cache (`gi::cache::data`).

#import gi::cache::data::{
    cache_voxels, cache_indirect, cache_emitted, cache_keeps_emitted, cache_voxel_index,
    cache_side_slot, CACHE_SIDE_COUNT, CACHE_STATE_CHANGE_SHIFT
}
#import gi::cache::lighting::{
    scheduled_voxel, scheduled_voxel_occupied, propagate_scratch, propagate_scratch_slot
}

@compute @workgroup_size(64)
fn propagate_resolve(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) bit: u32,
) {
    if !scheduled_voxel_occupied(group.x, bit) {
        return;
    }
    let lit = scheduled_voxel(group.x, bit);
    // The voxel's age is the lower of its sides' new ones, its change the larger.
    var age = 0xffu;
    var change = 0u;
    for (var side = 0u; side < CACHE_SIDE_COUNT; side++) {
        let slot = cache_side_slot(lit.v, side);
        let scratch = propagate_scratch_slot(group.x, bit, side);
        cache_indirect[slot] = propagate_scratch[scratch];
        let state = propagate_scratch[scratch + 1u];
        age = min(age, state & 0xffu);
        change = max(change, state & ~0xffu);
        if cache_keeps_emitted() {
            cache_emitted[slot] = propagate_scratch[scratch + 2u];
        }
    }
    let keep = ~0xffu & ((1u << CACHE_STATE_CHANGE_SHIFT) - 1u);
    cache_voxels[cache_voxel_index(lit.v)].state = (lit.surface.state & keep) | change | age;
}

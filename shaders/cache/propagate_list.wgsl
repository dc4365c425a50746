// The work list of `cache/propagate` (first dispatch of the pass, into `propagate_entries`):
// every occupied voxel side of this frame's scheduled bricks. A brick is mostly empty (a wall
// through a 4 x 4 x 4 brick occupies a quarter to a half of its voxels), so `cache/propagate`
// spends its rays on the listed sides only instead of on a thread per voxel of every brick, most
// of which would idle beside the rays of the occupied ones.
//
// One 64-thread workgroup per scheduled brick, one thread per voxel: the brick reserves two
// entries per occupied voxel with one atomic add and writes them at the voxel's rank among the
// brick's occupied voxels. The bricks' order in the list depends on the order the workgroups
// run in; `cache/propagate`'s results do not (each side's samples and scratch slot follow from
// the side itself).
//
// Bind group 0: `gi::cache::lighting`; 1: the count of entries; 2: the cache
// (`gi::cache::data`).

#import gi::cache::data::{cache_brick_masks, CACHE_SIDE_COUNT}
#import gi::cache::lighting::{
    lighting, scheduled_bricks, scheduled_voxel_occupied, propagate_entries, propagate_entry
}

// The number of entries listed so far, set to 0 before the pass.
@group(1) @binding(0) var<storage, read_write> propagate_count: atomic<u32>;

var<workgroup> brick_base: u32;

@compute @workgroup_size(64)
fn propagate_list(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) bit: u32,
) {
    var mask = vec2(0u);
    if group.x < lighting.brick_count {
        mask = cache_brick_masks[scheduled_bricks[group.x].brick_id];
    }
    if bit == 0u {
        let entries = (countOneBits(mask.x) + countOneBits(mask.y)) * CACHE_SIDE_COUNT;
        brick_base = atomicAdd(&propagate_count, entries);
    }
    let base = workgroupUniformLoad(&brick_base);
    if !scheduled_voxel_occupied(group.x, bit) {
        return;
    }
    // Occupied voxels of the brick below this one.
    let below = select(
        countOneBits(mask.x & ((1u << bit) - 1u)),
        countOneBits(mask.x) + countOneBits(mask.y & ((1u << (bit - 32u)) - 1u)),
        bit >= 32u
    );
    for (var side = 0u; side < CACHE_SIDE_COUNT; side++) {
        propagate_entries[base + below * CACHE_SIDE_COUNT + side] = propagate_entry(group.x, bit, side);
    }
}

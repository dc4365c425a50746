// Pass `cache/change_age`: counts the frames since each voxel's measured change
// (`gi::cache::data::cache_voxel_change`) was measured, up to CACHE_CHANGE_FRAMES_MAX. The
// cache's lighting weighs a change at the voxel's next update, however late; the passes that
// read the cache's light on screen count it only in the frame it was measured and the next
// (`cache_voxel_recent_change`), since their own histories see the cache's light as it is
// every frame. Recorded first in every lighting update, before `cache/inject` and
// `cache/propagate_resolve` measure this frame's (frame count 0).
//
// One 64-thread workgroup per pool brick ID (ids 1..=pool_bricks, in rows of 65535 workgroups),
// one thread per voxel; only voxels with a change whose count is below the maximum are written.
//
// Bind group 2: the cache (`gi::cache::data`).

#import gi::cache::data::{
    cache, cache_voxels, cache_brick_masks, cache_mask_test, CACHE_STATE_CHANGE_SHIFT,
    CACHE_CHANGE_LEVELS, CACHE_STATE_CHANGE_FRAMES_SHIFT, CACHE_CHANGE_FRAMES_MAX
}

const ROW_WORKGROUPS: u32 = 65535u;

@compute @workgroup_size(64)
fn change_age(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(local_invocation_index) bit: u32,
) {
    let brick_id = group.y * ROW_WORKGROUPS + group.x + 1u;
    if brick_id > cache.pool_bricks || !cache_mask_test(cache_brick_masks[brick_id], bit) {
        return;
    }
    let index = brick_id * 64u + bit;
    let state = cache_voxels[index].state;
    let change = (state >> CACHE_STATE_CHANGE_SHIFT) & CACHE_CHANGE_LEVELS;
    let frames = state >> CACHE_STATE_CHANGE_FRAMES_SHIFT;
    if change != 0u && frames < CACHE_CHANGE_FRAMES_MAX {
        cache_voxels[index].state = state + (1u << CACHE_STATE_CHANGE_FRAMES_SHIFT);
    }
}

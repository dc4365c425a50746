// Pass `cache/trace_rays` of the cache's batch queries (`gi::cache::query`): one ray per
// invocation through `cache_trace`.
//
// Bind group 0: binding 0 `rays` (read), binding 1 `hits` (written), both declared by
// `gi::cache::query`. Group 2: the cache (`gi::cache::data`).

#import gi::cache::trace::cache_trace
#import gi::cache::query::{rays, hits, item_index, query_hit, WORKGROUP_SIZE}

@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = item_index(id, groups);
    if i >= arrayLength(&rays) {
        return;
    }
    let ray = rays[i];
    hits[i] = query_hit(cache_trace(ray.origin + ray.dir * ray.t_min, ray.dir, ray.t_max - ray.t_min), ray.t_min);
}

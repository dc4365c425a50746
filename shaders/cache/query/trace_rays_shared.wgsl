// Pass `cache/trace_rays_shared` of the cache's batch queries (`gi::cache::query`): the rays
// of `trace_rays`, CACHE_LANES invocations per ray through `cache_trace_shared`.
//
// Bind group 0: binding 0 `rays` (read), binding 1 `hits` (written), both declared by
// `gi::cache::query`. Group 2: the cache (`gi::cache::data`).

#import gi::cache::trace_shared::{cache_trace_shared, CACHE_LANES}
#import gi::cache::query::{QueryRay, rays, hits, item_index, query_hit, WORKGROUP_SIZE}

// `trace_rays` with CACHE_LANES invocations per ray (`gi::cache::trace_shared`).
@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays_shared(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    let i = item_index(id, groups) / CACHE_LANES;
    let traced = i < arrayLength(&rays);
    var ray = QueryRay(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0.0);
    if traced {
        ray = rays[i];
    }
    let shared_hit = cache_trace_shared(ray.origin + ray.dir * ray.t_min, ray.dir, ray.t_max - ray.t_min, traced, local_index);
    if traced && shared_hit.owner {
        hits[i] = query_hit(shared_hit.hit, ray.t_min);
    }
}

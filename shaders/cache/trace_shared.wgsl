// Rays through the brick cache traced by CACHE_LANES invocations each (`cache_trace_lane`
// splits a ray by clipmap level; this module runs the lanes and picks the first hit).
//
// A ray's lanes are consecutive invocations of one workgroup: ray `local_index / CACHE_LANES`
// of the workgroup, lane `local_index % CACHE_LANES`; the workgroup size must be a multiple of
// CACHE_LANES and at most CACHE_LANES * CACHE_SHARED_RAYS. Every invocation of the workgroup
// must call `cache_trace_shared` the same number of times (it holds workgroup barriers):
// invocations without a ray pass `traced = false` instead of returning early.
#define_import_path gi::cache::trace_shared

#import gi::cache::trace::{CacheHit, cache_miss, cache_trace_lane}

// Invocations per ray. The default clipmap has 7 levels: 8 lanes give each level its own.
const CACHE_LANES: u32 = 8u;
// Most rays of one workgroup.
const CACHE_SHARED_RAYS: u32 = 64u;

// Per ray of the workgroup: the lowest lane with a hit (CACHE_LANES for none).
var<workgroup> cache_first_lane: array<atomic<u32>, CACHE_SHARED_RAYS>;

// One invocation's part of a shared ray.
struct SharedHit {
    // This lane's hit: the ray's first hit in the lane that `owner` marks; on the owner of a
    // ray that nothing hit, a miss.
    hit: CacheHit,
    // True in exactly one lane of each ray (also of rays not traced): the lane whose hit is
    // the ray's, or lane 0 when no lane hit.
    owner: bool,
}

// Traces `origin + t * dir` (as `cache_trace` does) with the ray's CACHE_LANES invocations;
// every lane of a ray passes the same ray.
fn cache_trace_shared(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, traced: bool, local_index: u32) -> SharedHit {
    let ray = local_index / CACHE_LANES;
    let lane = local_index % CACHE_LANES;
    if lane == 0u {
        atomicStore(&cache_first_lane[ray], CACHE_LANES);
    }
    workgroupBarrier();
    var hit = cache_miss(t_max);
    if traced {
        hit = cache_trace_lane(origin, dir, t_max, lane, CACHE_LANES);
        if hit.hit {
            atomicMin(&cache_first_lane[ray], lane);
        }
    }
    workgroupBarrier();
    let first = atomicLoad(&cache_first_lane[ray]);
    // The next call's reset must not overtake this call's reads.
    workgroupBarrier();
    return SharedHit(hit, first == lane || (first == CACHE_LANES && lane == 0u));
}

// Ray batches through the compressed wide BVH traversal of `gi::bvh` (Ylitie et al. 2017,
// "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs"): one ray per
// invocation, so tests can compare GPU and CPU hits ray by ray and benchmarks can time
// traversal alone.
//
// Bind group 0 (`BvhTracer`): binding 0 `rays` (read), binding 1 `hits` (written by
// `closest`), binding 2 `occluded` (1 or 0 per ray, written by `occluded`). Bind group 1 is the
// BVH (`GpuBvh`).

#import gi::bvh::{Ray, Hit, trace_closest, trace_any}

@group(0) @binding(0) var<storage, read> rays: array<Ray>;
@group(0) @binding(1) var<storage, read_write> hits: array<Hit>;
@group(0) @binding(2) var<storage, read_write> occluded_flags: array<u32>;

/// Threads per workgroup of both entry points. `BvhTracer` dispatches `ceil(rays / 64)`
/// workgroups, folded into rows of at most 65535 so large batches fit the dispatch limit.
const WORKGROUP_SIZE: u32 = 64u;

fn ray_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WORKGROUP_SIZE;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn closest(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = ray_index(id, groups);
    if i >= arrayLength(&rays) {
        return;
    }
    hits[i] = trace_closest(rays[i]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn occluded(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = ray_index(id, groups);
    if i >= arrayLength(&rays) {
        return;
    }
    occluded_flags[i] = select(0u, 1u, trace_any(rays[i]));
}

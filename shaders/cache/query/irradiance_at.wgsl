// Pass `cache/irradiance_at` of the cache's batch queries (`gi::cache::query`): one surface
// point per invocation through `cache_irradiance`.
//
// Bind group 0: binding 2 `points` (read), binding 3 `irradiance` (written). Group 2: the
// cache (`gi::cache::data`).

#import gi::cache::trace::cache_irradiance
#import gi::cache::query::{item_index, WORKGROUP_SIZE}

// Mirror of `gi_cache::GpuIrradianceQuery`.
struct IrradianceQuery {
    position: vec3<f32>,
    pad_a: f32,
    normal: vec3<f32>,
    pad_b: f32,
}

@group(0) @binding(2) var<storage, read> points: array<IrradianceQuery>;
@group(0) @binding(3) var<storage, read_write> irradiance: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn irradiance_at(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = item_index(id, groups);
    if i >= arrayLength(&points) {
        return;
    }
    irradiance[i] = cache_irradiance(points[i].position, points[i].normal);
}

// Pass `mobile/volume_irradiance_at` (tests and tools): `irradiance_at` evaluates
// `volume_irradiance` for a batch of queries, one per invocation.
//
// Bind group 0:
//   binding 11: `queries` array<IrradianceQuery>
//   binding 12: `results` array<vec4<f32>>
// Group 1 is the volume (`gi::mobile::volume`).

#import gi::mobile::volume::{volume_irradiance, WORKGROUP_SIZE}

// Mirror of `gi_cache::query::GpuIrradianceQuery` (32 bytes).
struct IrradianceQuery {
    position: vec3<f32>,
    pad_a: f32,
    normal: vec3<f32>,
    pad_b: f32,
}

@group(0) @binding(11) var<storage, read_write> queries: array<IrradianceQuery>;
@group(0) @binding(12) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn irradiance_at(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&queries) {
        return;
    }
    let q = queries[i];
    results[i] = volume_irradiance(q.position, q.normal);
}

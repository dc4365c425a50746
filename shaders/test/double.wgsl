// Test kernel of the GPU context and timer tests: doubles every element of a storage buffer
// in place, so a read-back has one exact expected answer.

@group(0) @binding(0) var<storage, read_write> values: array<f32>;

@compute @workgroup_size(64)
fn double_values(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i < arrayLength(&values) {
        values[i] = 2.0 * values[i];
    }
}

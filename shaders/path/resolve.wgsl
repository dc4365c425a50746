// Resolve of the GPU path tracer (`path/trace.wgsl`, gi-reference's transport contract): the
// mean radiance per pixel from the accumulated sums, which is what the reference's
// accumulator image is.

struct ResolveUniforms {
    pixel_count: u32,
    // Samples per pixel accumulated so far.
    samples: u32,
    pad_a: u32,
    pad_b: u32,
}

@group(0) @binding(0) var<uniform> uniforms: ResolveUniforms;
@group(0) @binding(1) var<storage, read> accum_sum: array<vec4<f32>>;
// Mean radiance (rgb) and count of non-finite samples so far (w).
@group(0) @binding(2) var<storage, read_write> mean: array<vec4<f32>>;

@compute @workgroup_size(64)
fn resolve(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // Large images fold their workgroups into rows (at most 65535 per dispatch dimension).
    let pixel = id.y * groups.x * 64u + id.x;
    if pixel >= uniforms.pixel_count {
        return;
    }
    let n = f32(max(uniforms.samples, 1u));
    let sum = accum_sum[pixel];
    // w carries the pixel's count of non-finite samples through to the read-back.
    mean[pixel] = vec4<f32>(sum.xyz / n, sum.w);
}

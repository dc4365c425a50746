// Test kernel of the shared-module tests: runs `gi::packing` round trips and the
// `gi::math` orthonormal basis on a batch of inputs so the CPU can check every result.
// For input i (a unit vector n and a color c packed in two vec4s, a depth in c's w), writes
// six vec4s: the unit-vector round trip, the RGB9E5 round trip of c, basis checks (x.y, x.n,
// y.n, det(basis)), the depth-and-normal round trip (normal, depth), and the long-history
// round trip of c with the depth as its variance and i % 131 as its age (rgb and variance,
// then the age, then in yzw the mean of c's dithered RGB9E5 round trips over 64 evenly spaced
// offsets).

#import gi::math::world_from_tangent
#import gi::packing::{
    pack_unit_vector, unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5, pack_depth_normal, unpack_depth,
    unpack_normal8, pack_history64, unpack_history64,
    pack_rgb9e5_dithered
}

@group(0) @binding(0) var<storage, read> inputs: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read_write> outputs: array<vec4<f32>>;

@compute @workgroup_size(64)
fn common_functions(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&inputs) / 2u {
        return;
    }
    let n = inputs[2u * i].xyz;
    let color = inputs[2u * i + 1u].xyz;
    let depth = inputs[2u * i + 1u].w;
    outputs[6u * i] = vec4<f32>(unpack_unit_vector(pack_unit_vector(n)), 0.0);
    outputs[6u * i + 1u] = vec4<f32>(unpack_rgb9e5(pack_rgb9e5(color)), 0.0);
    let geometry = pack_depth_normal(depth, n);
    outputs[6u * i + 3u] = vec4<f32>(unpack_normal8(geometry), unpack_depth(geometry));
    let history = unpack_history64(pack_history64(color, depth, f32(i % 131u)));
    outputs[6u * i + 4u] = vec4<f32>(history.rgb, history.variance);
    var dithered = vec3(0.0);
    for (var k = 0u; k < 64u; k++) {
        dithered += unpack_rgb9e5(pack_rgb9e5_dithered(color, (f32(k) + 0.5) / 64.0));
    }
    outputs[6u * i + 5u] = vec4<f32>(history.age, dithered / 64.0);
    let basis = world_from_tangent(n);
    outputs[6u * i + 2u] = vec4<f32>(
        dot(basis[0], basis[1]),
        dot(basis[0], n),
        dot(basis[1], n),
        determinant(basis),
    );
}

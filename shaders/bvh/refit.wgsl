// Refit of the deforming bottom levels of the GPU BVH (`gi_gpu::bvh`, module `refit`): their
// primitives hold a new frame's vertices in the leaf order of the level built earlier, and this
// pass gives every node new boxes over them, keeping the tree's shape.
//
// One dispatch per depth, deepest first: a node at depth d reads the exact boxes of its leaf
// children from their triangles and those of its internal children from `bounds`, written by
// the dispatch of depth d + 1. It then encodes its children's boxes as obvhs's CWBVH builder
// does (`bvh2_to_cwbvh.rs`): origin `p` the node box's minimum, per axis the smallest power of
// two `e` with 255 e at least the extent (from the float's bits, so no `log2` rounding), child
// planes floored and ceiled to that grid, which keeps every decoded box around its child.

#import gi::bvh::{CwBvhNode, BvhTriangle, byte_of}

// One dispatch: `count` node indices from `order[first]`; `bounds` is indexed by node index
// minus `node_base` (the first node of the deforming levels).
struct Step {
    first: u32,
    count: u32,
    node_base: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> step: Step;
@group(0) @binding(1) var<storage, read_write> nodes: array<CwBvhNode>;
@group(0) @binding(2) var<storage, read> triangles: array<BvhTriangle>;
@group(0) @binding(3) var<storage, read> order: array<u32>;
// Two entries per node: its exact minimum, then its exact maximum (w unused).
@group(0) @binding(4) var<storage, read_write> bounds: array<vec4<f32>>;

const WORKGROUP_SIZE: u32 = 64u;
// obvhs's DENOM: 1 / 255, the grid steps across a node.
const DENOM: f32 = 1.0 / 255.0;

fn with_byte(words: vec2<u32>, slot: u32, value: u32) -> vec2<u32> {
    var out = words;
    let shift = (slot & 3u) * 8u;
    out[slot >> 2u] = (out[slot >> 2u] & ~(0xffu << shift)) | (value << shift);
    return out;
}

// Biased exponent of the smallest power of two at least `x` (x > 0, normal).
fn ceil_exponent(x: f32) -> u32 {
    let bits = bitcast<u32>(x);
    return (bits >> 23u) + select(0u, 1u, (bits & 0x7fffffu) != 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn refit(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= step.count {
        return;
    }
    let index = order[step.first + id.x];
    var node = nodes[index];
    var child_lo: array<vec3<f32>, 8>;
    var child_hi: array<vec3<f32>, 8>;
    var lo = vec3(bitcast<f32>(0x7f800000u));
    var hi = -lo;
    for (var slot = 0u; slot < 8u; slot++) {
        let info = byte_of(node.child_meta, slot);
        if info == 0u {
            continue;
        }
        var box_lo = vec3(bitcast<f32>(0x7f800000u));
        var box_hi = -box_lo;
        if ((node.e_imask >> (24u + slot)) & 1u) != 0u {
            // Internal: the child's rank among the internal children before this slot.
            let rank = countOneBits((node.e_imask >> 24u) & ((1u << slot) - 1u));
            let child = node.child_base_idx + rank - step.node_base;
            box_lo = bounds[2u * child].xyz;
            box_hi = bounds[2u * child + 1u].xyz;
        } else {
            let first = node.primitive_base_idx + (info & 0x1fu);
            let count = countOneBits(info & 0xe0u);
            for (var k = 0u; k < count; k++) {
                let tri = triangles[first + k];
                box_lo = min(box_lo, min(tri.a, min(tri.b, tri.c)));
                box_hi = max(box_hi, max(tri.a, max(tri.b, tri.c)));
            }
        }
        child_lo[slot] = box_lo;
        child_hi[slot] = box_hi;
        lo = min(lo, box_lo);
        hi = max(hi, box_hi);
    }
    let local = index - step.node_base;
    bounds[2u * local] = vec4(lo, 0.0);
    bounds[2u * local + 1u] = vec4(hi, 0.0);

    let exponent = vec3(
        ceil_exponent(max(hi.x - lo.x, 1e-20) * DENOM),
        ceil_exponent(max(hi.y - lo.y, 1e-20) * DENOM),
        ceil_exponent(max(hi.z - lo.z, 1e-20) * DENOM),
    );
    // 1 / 2^(exponent - 127), exactly.
    let inverse_step = bitcast<vec3<f32>>((vec3(254u) - exponent) << vec3(23u));
    node.p = lo;
    node.e_imask = (node.e_imask & 0xff000000u) | exponent.x | (exponent.y << 8u)
        | (exponent.z << 16u);
    for (var slot = 0u; slot < 8u; slot++) {
        if byte_of(node.child_meta, slot) == 0u {
            continue;
        }
        let q_lo = vec3<u32>(clamp(floor((child_lo[slot] - lo) * inverse_step), vec3(0.0),
            vec3(255.0)));
        let q_hi = vec3<u32>(clamp(ceil((child_hi[slot] - lo) * inverse_step), vec3(0.0),
            vec3(255.0)));
        node.child_min_x = with_byte(node.child_min_x, slot, q_lo.x);
        node.child_min_y = with_byte(node.child_min_y, slot, q_lo.y);
        node.child_min_z = with_byte(node.child_min_z, slot, q_lo.z);
        node.child_max_x = with_byte(node.child_max_x, slot, q_hi.x);
        node.child_max_y = with_byte(node.child_max_y, slot, q_hi.y);
        node.child_max_z = with_byte(node.child_max_z, slot, q_hi.z);
    }
    nodes[index] = node;
}

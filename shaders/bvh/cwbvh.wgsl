// Closest-hit and any-hit ray traversal of a two-level compressed wide BVH (8-wide, quantized
// child boxes).
//
// Ylitie, Karras, Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
// BVHs", HPG 2017: node groups (a node's child base index plus a hit mask) on a short per-thread
// stack, children ordered by the ray octant through the node's per-child meta bytes, and the
// ray transformed into each node's quantized grid instead of decoding the child boxes. Two
// levels share the one stack as in their instancing scheme (and obvhs's
// `ray_traverse_tlas_blas`): a top-level leaf names an instance; entering it pushes the rest of
// the top-level work, transforms the ray into the instance's object space and continues at its
// bottom level's root; when the stack drops back to where it was, the world ray is restored.
//
// Nodes are obvhs `CwBvhNode`s uploaded byte for byte, and the node and triangle tests follow
// obvhs's CPU traversal operation for operation, so a GPU hit and a CPU hit of the same ray
// agree on the triangle and on `t` up to rounding (exactly, for the world-space static level).
//
// Bind group 1 (`GpuBvh::bind_group_layout`), read-only storage, any stage that traces:
//   binding 0: `bvh_nodes`      array<CwBvhNode>, every bottom level, 80 bytes each
//   binding 1: `bvh_triangles`  array<BvhTriangle>, every bottom level's primitives, 48 bytes
//   binding 2: `bvh_top_nodes`  array<CwBvhNode>, the top level, root at index 0
//   binding 3: `bvh_instances`  BvhInstances: a 16-byte header, then 64 bytes per instance in
//                               top-level leaf order
//
// When the only instance is the static level, the header names its root and rays start there
// with the world ray: a static scene pays neither the top-level node, nor the instance load,
// nor the level switch. It visits the same bottom-level nodes in the same order with the same
// ray as through the top level (whose one box encloses the level's), so its hits are identical.

#define_import_path gi::bvh

#ifdef ALPHA_TEST
#import gi::scene::alpha_covers
#endif

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`. `dir` need not be unit length; `t`
/// is measured in units of `dir`.
struct Ray {
    origin: vec3<f32>,
    t_min: f32,
    dir: vec3<f32>,
    t_max: f32,
}

/// Result of `trace_closest`. `triangle` indexes the frame's triangle list, `BVH_MISS` when
/// nothing was hit. `barycentrics` are the weights of v1 and v2 (v0's is `1 - x - y`).
struct Hit {
    t: f32,
    triangle: u32,
    barycentrics: vec2<f32>,
}

/// obvhs `CwBvhNode`, 80 bytes. Byte arrays are read as little-endian words: `e_imask` holds
/// the three extent exponents in bytes 0..2 and the internal-child mask in byte 3; each
/// `vec2<u32>` holds the eight per-child bytes of one field, child `i` in byte `i % 4` of
/// component `i / 4`.
struct CwBvhNode {
    p: vec3<f32>,
    e_imask: u32,
    child_base_idx: u32,
    primitive_base_idx: u32,
    child_meta: vec2<u32>,
    child_min_x: vec2<u32>,
    child_max_x: vec2<u32>,
    child_min_y: vec2<u32>,
    child_max_y: vec2<u32>,
    child_min_z: vec2<u32>,
    child_max_z: vec2<u32>,
}

/// A bottom-level triangle in leaf order, with its index: the frame triangle index in the
/// world-space static level, the index within its node's triangle range in an object-space one
/// (the instance adds its `triangle_base`). `a`, `b`, `c` are its v0, v1, v2 (names of
/// an import module cannot end in a digit). Vertices rather than edges, so the GPU test
/// performs the same operations as the CPU one.
struct BvhTriangle {
    a: vec3<f32>,
    triangle: u32,
    b: vec3<f32>,
    flags: u32,
    c: vec3<f32>,
    pad_c: u32,
}

/// A bottom level placed in the world (`gi_gpu::bvh::GpuBvhInstance`). The object-space ray is
/// `vec4(origin, 1) * object_from_world` and `vec4(dir, 0) * object_from_world`, unnormalized,
/// so `t` along it is `t` along the world ray.
struct BvhInstance {
    object_from_world: mat3x4<f32>,
    blas_root: u32,
    triangle_base: u32,
    flags: u32,
    pad: u32,
}

/// Head of `bvh_instances` (`gi_gpu::bvh::GpuBvhInstanceHeader`).
struct BvhInstanceHeader {
    /// Root of the static level when it is the only instance, else `BVH_NO_STATIC_ROOT`.
    static_root: u32,
    instance_count: u32,
    pad: vec2<u32>,
}

struct BvhInstances {
    header: BvhInstanceHeader,
    instances: array<BvhInstance>,
}

/// `BvhInstanceHeader::static_root` when rays start at the top level.
const BVH_NO_STATIC_ROOT: u32 = 0xffffffffu;

/// `BvhInstance::flags`: trace the world ray unchanged (the static level).
const BVH_INSTANCE_IDENTITY: u32 = 1u;
/// `BvhInstance::flags`: the transform mirrors; the frame triangle has v1 and v2 swapped.
const BVH_INSTANCE_MIRRORED: u32 = 2u;

/// `BvhTriangle::flags` bit: the triangle's material is alpha-tested; shaders composed with
/// `ALPHA_TEST` (which bind the scene, `gi::scene`) count its hits only where
/// `alpha_covers` says the surface exists, others treat it as solid.
const BVH_TRIANGLE_ALPHA: u32 = 1u;

/// `Hit::triangle` of a ray that hit nothing.
const BVH_MISS: u32 = 0xffffffffu;

/// Entries of the per-thread traversal stack. One group is pushed per level descended, plus two
/// on entering an instance, so the stack holds at most top depth + 2 + bottom depth; `GpuBvh`
/// refuses a deeper pair of levels, so the stack can never overflow.
const BVH_STACK_SIZE: u32 = 32u;

/// Boxes are entered no closer than this, as obvhs does; it keeps CPU and GPU traversal equal.
const BVH_NODE_EPSILON: f32 = 0.0001;

@group(1) @binding(0) var<storage, read> bvh_nodes: array<CwBvhNode>;
@group(1) @binding(1) var<storage, read> bvh_triangles: array<BvhTriangle>;
@group(1) @binding(2) var<storage, read> bvh_top_nodes: array<CwBvhNode>;
@group(1) @binding(3) var<storage, read> bvh_instances: BvhInstances;

/// `traverse`'s marker for "in the top level" (no instance entered).
const BVH_IN_TOP: u32 = 0xffffffffu;

/// Per-ray values reused by every node test.
struct RayState {
    origin: vec3<f32>,
    dir: vec3<f32>,
    inv_dir: vec3<f32>,
    /// 1 per axis where the direction is negative (then a child's max plane is its entry).
    negative: vec3<bool>,
    /// Inverse ray octant (bit 2: x >= 0, bit 1: y >= 0, bit 0: z >= 0), XORed into the slot
    /// index of internal children so the nearest-first order falls out of a find-MSB.
    oct_inv: u32,
}

/// Reciprocal that stays finite for (near-)zero components, as obvhs's `safe_inverse`.
fn safe_inverse(x: f32) -> f32 {
    if abs(x) <= 1.1920929e-7 {
        let sign = select(1.0, -1.0, (bitcast<u32>(x) & 0x80000000u) != 0u);
        return sign / 1.1920929e-7;
    }
    return 1.0 / x;
}

fn ray_state(origin: vec3<f32>, ray_dir: vec3<f32>) -> RayState {
    // Negative zeros become +0.0 (the CPU side, gi_scene::SceneBvh, does the same): the sign
    // of a zero component must agree between `inv_dir` (sign bit) and `negative` (`< 0.0`),
    // or the slab test picks the wrong planes and the ray misses.
    let dir = select(ray_dir, vec3(0.0), ray_dir == vec3(0.0));
    var state: RayState;
    state.origin = origin;
    state.dir = dir;
    state.inv_dir = vec3(safe_inverse(dir.x), safe_inverse(dir.y), safe_inverse(dir.z));
    state.negative = dir < vec3(0.0);
    state.oct_inv = select(4u, 0u, state.negative.x) | select(2u, 0u, state.negative.y)
        | select(1u, 0u, state.negative.z);
    return state;
}

/// Byte `child` of the eight in a per-child field.
fn byte_of(word: vec2<u32>, child: u32) -> u32 {
    return (word[child >> 2u] >> ((child & 3u) * 8u)) & 0xffu;
}

/// The four bytes of `word`, lowest first, as floats.
fn bytes_f32(word: u32) -> vec4<f32> {
    return vec4<f32>(unpack4xU8(word));
}

/// Tests the ray against the eight quantized child boxes of `node` over `[ε, t_max]` and
/// returns the hit mask: internal children as bit `24 + (slot ^ oct_inv)` (so the highest set
/// bit is the nearest in octant order), leaf children as their unary primitive count shifted to
/// their first primitive's offset from `primitive_base_idx` (bits 0..23).
///
/// Four children at a time, one per byte of a field's word, with no branch: a ray enters a
/// child by its min plane along an axis where it travels forward and by its max plane where it
/// travels backward, so the two words of a field are swapped once per node, not per child; an
/// empty slot (meta byte 0) adds no bit.
fn intersect_node(node: CwBvhNode, ray: RayState, t_max: f32) -> u32 {
    let e = vec3(node.e_imask & 0xffu, (node.e_imask >> 8u) & 0xffu, (node.e_imask >> 16u) & 0xffu);
    let extent = bitcast<vec3<f32>>(e << vec3(23u));
    let adjusted_dir_inv = extent * ray.inv_dir;
    let adjusted_origin = (node.p - ray.origin) * ray.inv_dir;
    let near_x = select(node.child_min_x, node.child_max_x, ray.negative.x);
    let far_x = select(node.child_max_x, node.child_min_x, ray.negative.x);
    let near_y = select(node.child_min_y, node.child_max_y, ray.negative.y);
    let far_y = select(node.child_max_y, node.child_min_y, ray.negative.y);
    let near_z = select(node.child_min_z, node.child_max_z, ray.negative.z);
    let far_z = select(node.child_max_z, node.child_min_z, ray.negative.z);
    var hit_mask = 0u;
    for (var half = 0u; half < 2u; half++) {
        let t_enter = max(max(max(
            bytes_f32(near_x[half]) * adjusted_dir_inv.x + adjusted_origin.x,
            bytes_f32(near_y[half]) * adjusted_dir_inv.y + adjusted_origin.y),
            bytes_f32(near_z[half]) * adjusted_dir_inv.z + adjusted_origin.z),
            vec4(BVH_NODE_EPSILON));
        let t_exit = min(min(min(
            bytes_f32(far_x[half]) * adjusted_dir_inv.x + adjusted_origin.x,
            bytes_f32(far_y[half]) * adjusted_dir_inv.y + adjusted_origin.y),
            bytes_f32(far_z[half]) * adjusted_dir_inv.z + adjusted_origin.z),
            vec4(t_max));
        let info = unpack4xU8(node.child_meta[half]);
        // Internal children have meta 24 + slot (bits 3 and 4 both set); leaves never do.
        let inner = (info & (info << vec4(1u)) & vec4(0x10u)) != vec4(0u);
        let bit_index = (info ^ select(vec4(0u), vec4(ray.oct_inv), inner)) & vec4(0x1fu);
        let bits = select(vec4(0u), (info >> vec4(5u)) << bit_index, t_enter <= t_exit);
        hit_mask |= bits.x | bits.y | bits.z | bits.w;
    }
    return hit_mask;
}

/// Möller-Trumbore in the form obvhs uses (same edges, same sign-bit inside test, so rays
/// through shared edges resolve as on the CPU). Returns `(t, u, v)` with `t` infinite on a miss.
fn intersect_triangle(tri: BvhTriangle, ray: RayState, t_min: f32, t_max: f32) -> vec3<f32> {
    let e1 = tri.a - tri.b;
    let e2 = tri.c - tri.a;
    let n = cross(e1, e2);
    let c = tri.a - ray.origin;
    let r = cross(ray.dir, c);
    let inv_det = 1.0 / dot(n, ray.dir);
    let u = dot(r, e2) * inv_det;
    let v = dot(r, e1) * inv_det;
    let w = 1.0 - u - v;
    // A sign bit on any weight, -0.0 included, is outside: the same rule as the CPU.
    let outside = ((bitcast<u32>(u) | bitcast<u32>(v) | bitcast<u32>(w)) & 0x80000000u) != 0u;
    if !outside && inv_det != 0.0 {
        let t = dot(n, c) * inv_det;
        if t >= t_min && t <= t_max {
            return vec3(t, u, v);
        }
    }
    return vec3(bitcast<f32>(0x7f800000u), 0.0, 0.0);
}

/// Child node index of the highest set bit of the group's hit mask: the group's base plus the
/// number of internal children in lower slots.
fn group_child(group: vec2<u32>, bit: u32, oct_inv: u32) -> u32 {
    let slot = (bit - 24u) ^ oct_inv;
    let lower_slots = ~(0xffffffffu << slot);
    return group.x + countOneBits(group.y & lower_slots);
}

/// Both queries: the nearest hit in `[ray.t_min, ray.t_max]`, or with `any_hit` the first hit
/// found. Cost: one 80-byte node load and eight box tests (two branch-free fours) per visited
/// node, one 48-byte load per tested triangle, and a 64-byte load plus a ray transform per
/// entered instance; a static scene (one identity instance) starts at its bottom level and pays
/// none of the top level's share.
fn traverse(ray: Ray, any_hit: bool) -> Hit {
    let world = ray_state(ray.origin, ray.dir);
    var state = world;
    var hit = Hit(ray.t_max, BVH_MISS, vec2(0.0));
    var t_max = ray.t_max;
    var stack: array<vec2<u32>, BVH_STACK_SIZE>;
    var stack_len = 0u;
    // Stack length when the current instance was entered; BVH_IN_TOP in the top level.
    var instance_stack_len = BVH_IN_TOP;
    var triangle_base = 0u;
    var mirrored = false;
    // (child_base_idx, hit bits << 24 | imask) of internal children still to visit; the root
    // is the single child of a virtual group.
    var node_group = vec2(0u, 0x80000000u);
    // (primitive_base_idx, hit bits of leaf primitives still to test): triangles in a bottom
    // level, instances in the top level.
    var leaf_group = vec2(0u, 0u);
    let static_root = bvh_instances.header.static_root;
    if static_root != BVH_NO_STATIC_ROOT {
        // The static level entered from an empty stack, as the top level would enter it: the
        // world ray, no triangle base, not mirrored; emptying the stack ends the traversal.
        instance_stack_len = 0u;
        node_group = vec2(static_root, 0x80000000u);
    }
    loop {
        if instance_stack_len == BVH_IN_TOP {
            if leaf_group.y != 0u {
                let bit = firstLeadingBit(leaf_group.y);
                leaf_group.y &= ~(1u << bit);
                let instance = bvh_instances.instances[leaf_group.x + bit];
                // The rest of this top-level node's work resumes when the instance is done.
                // Leaf groups have no bits in 24..31, which tells them apart when popped.
                if leaf_group.y != 0u {
                    stack[stack_len] = leaf_group;
                    stack_len += 1u;
                }
                if (node_group.y & 0xff000000u) != 0u {
                    stack[stack_len] = node_group;
                    stack_len += 1u;
                }
                instance_stack_len = stack_len;
                triangle_base = instance.triangle_base;
                mirrored = (instance.flags & BVH_INSTANCE_MIRRORED) != 0u;
                if (instance.flags & BVH_INSTANCE_IDENTITY) == 0u {
                    let m = instance.object_from_world;
                    state = ray_state(vec4(world.origin, 1.0) * m, vec4(world.dir, 0.0) * m);
                }
                node_group = vec2(instance.blas_root, 0x80000000u);
                leaf_group = vec2(0u, 0u);
            }
        } else {
            while leaf_group.y != 0u {
                let bit = firstLeadingBit(leaf_group.y);
                leaf_group.y &= ~(1u << bit);
                let tri = bvh_triangles[leaf_group.x + bit];
                let tuv = intersect_triangle(tri, state, ray.t_min, t_max);
                if tuv.x < t_max {
                    let triangle = triangle_base + tri.triangle;
                    let b = select(tuv.yz, tuv.zy, mirrored);
#ifdef ALPHA_TEST
                    if (tri.flags & BVH_TRIANGLE_ALPHA) != 0u && !alpha_covers(triangle, b) {
                        continue;
                    }
#endif
                    t_max = tuv.x;
                    hit = Hit(tuv.x, triangle, b);
                    if any_hit {
                        return hit;
                    }
                }
            }
        }
        if (node_group.y & 0xff000000u) != 0u {
            let bit = firstLeadingBit(node_group.y);
            let child = group_child(node_group, bit, state.oct_inv);
            node_group.y &= ~(1u << bit);
            var node: CwBvhNode;
            if instance_stack_len == BVH_IN_TOP {
                node = bvh_top_nodes[child];
            } else {
                node = bvh_nodes[child];
            }
            let hit_mask = intersect_node(node, state, t_max);
            let imask = node.e_imask >> 24u;
            leaf_group = vec2(node.primitive_base_idx, hit_mask & 0x00ffffffu);
            // The rest of this group is pushed only when the child has internal children to
            // descend into (Ylitie et al.): a child with leaves alone, most nodes near the
            // bottom, leaves it current, so no push is popped right back.
            if (hit_mask & 0xff000000u) != 0u {
                if (node_group.y & 0xff000000u) != 0u {
                    stack[stack_len] = node_group;
                    stack_len += 1u;
                }
                node_group = vec2(node.child_base_idx, (hit_mask & 0xff000000u) | imask);
            }
        }
        if leaf_group.y == 0u && (node_group.y & 0xff000000u) == 0u {
            if stack_len == instance_stack_len {
                // The instance is done: back to the world ray in the top level.
                instance_stack_len = BVH_IN_TOP;
                state = world;
            }
            if stack_len == 0u {
                break;
            }
            stack_len -= 1u;
            let group = stack[stack_len];
            if (group.y & 0xff000000u) != 0u {
                node_group = group;
            } else {
                leaf_group = group;
            }
        }
    }
    return hit;
}

/// Nearest hit in `[ray.t_min, ray.t_max]`.
fn trace_closest(ray: Ray) -> Hit {
    return traverse(ray, false);
}

/// True when any triangle blocks the ray in `[ray.t_min, ray.t_max)`: a shadow ray. Stops at
/// the first blocker found, in the same order as `trace_closest`.
fn trace_any(ray: Ray) -> bool {
    return traverse(ray, true).triangle != BVH_MISS;
}

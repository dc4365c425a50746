//! Rust mirrors of the structures `shaders/bvh/cwbvh.wgsl` reads and writes, and the packing
//! of an obvhs CWBVH into them.
//!
//! Each mirror is `#[repr(C)]` + bytemuck and has a test that its size and field offsets equal
//! the WGSL layout naga computes (and, for the node, obvhs's own `CwBvhNode`).

use bytemuck::{Pod, Zeroable};
use obvhs::{
    cwbvh::{CwBvh, node::CwBvhNode},
    triangle::Triangle,
};

/// `Hit::triangle` (and [`GpuHit::triangle`]) of a ray that hit nothing.
pub const BVH_MISS: u32 = u32::MAX;

/// Entries of the per-thread traversal stack in `cwbvh.wgsl` (`BVH_STACK_SIZE`). A BVH whose
/// depth exceeds it is refused at packing time, so traversal never overflows the stack.
pub const BVH_STACK_SIZE: u32 = 32;

/// obvhs [`CwBvhNode`] as the shader reads it: 80 bytes, byte for byte the same. Holds the
/// node's grid origin `p`, the per-axis power-of-two grid scales `e`, the internal-child mask
/// and, per child slot, a meta byte (leaf: primitive offset and unary count; internal: 24 +
/// slot) and the quantized box planes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCwBvhNode {
    pub p: [f32; 3],
    pub e: [u8; 3],
    pub imask: u8,
    pub child_base_idx: u32,
    pub primitive_base_idx: u32,
    pub child_meta: [u8; 8],
    pub child_min_x: [u8; 8],
    pub child_max_x: [u8; 8],
    pub child_min_y: [u8; 8],
    pub child_max_y: [u8; 8],
    pub child_min_z: [u8; 8],
    pub child_max_z: [u8; 8],
}

impl From<&CwBvhNode> for GpuCwBvhNode {
    fn from(node: &CwBvhNode) -> Self {
        Self {
            p: node.p.to_array(),
            e: node.e,
            imask: node.imask,
            child_base_idx: node.child_base_idx,
            primitive_base_idx: node.primitive_base_idx,
            child_meta: node.child_meta,
            child_min_x: node.child_min_x,
            child_max_x: node.child_max_x,
            child_min_y: node.child_min_y,
            child_max_y: node.child_max_y,
            child_min_z: node.child_min_z,
            child_max_z: node.child_max_z,
        }
    }
}

/// One BVH primitive in leaf order (48 bytes): the three vertices of a world-space triangle
/// and the index of that triangle in the frame's list, so a hit needs no indirection. Vertices
/// rather than precomputed edges keep the GPU triangle test the same operations as obvhs's.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBvhTriangle {
    /// Vertex v0. (WGSL names cannot end in a digit in an import module.)
    pub a: [f32; 3],
    /// Index into the frame's `triangles` (and `attributes`).
    pub triangle: u32,
    /// Vertex v1.
    pub b: [f32; 3],
    /// [`BVH_TRIANGLE_ALPHA`] when the triangle's material is alpha-tested.
    pub flags: u32,
    /// Vertex v2.
    pub c: [f32; 3],
    pub pad_c: u32,
}

/// [`GpuBvhTriangle::flags`] bit: the triangle's material is alpha-tested, so a hit counts
/// only where `gi::scene::alpha_covers` says the surface exists (in shaders composed with
/// `ALPHA_TEST`).
pub const BVH_TRIANGLE_ALPHA: u32 = 1;

/// [`GpuBvhInstance::flags`] bit: the instance is the world-space static level, and the
/// shader traces the world ray unchanged (no transform, so no rounding).
pub const BVH_INSTANCE_IDENTITY: u32 = 1;

/// [`GpuBvhInstance::flags`] bit: the instance's transform mirrors (negative determinant).
/// `Scene::evaluate` then swaps v1 and v2 of its world triangles to keep the winding, so the
/// shader swaps the object-space barycentrics to name the frame triangle's vertices.
pub const BVH_INSTANCE_MIRRORED: u32 = 2;

/// One top-level primitive (64 bytes, `BvhInstance` in WGSL): a bottom level placed in the
/// world. The shader transforms the world ray into object space as
/// `vec4(p, 1) * object_from_world` (rows of the affine inverse), keeping the direction
/// unnormalized so distances `t` stay those of the world ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBvhInstance {
    /// The three rows of the affine map from world to object space.
    pub object_from_world: [[f32; 4]; 3],
    /// Index of the bottom level's root in `bvh.nodes`.
    pub blas_root: u32,
    /// Added to the bottom level's primitive index to give the frame triangle index.
    pub triangle_base: u32,
    /// [`BVH_INSTANCE_IDENTITY`] | [`BVH_INSTANCE_MIRRORED`].
    pub flags: u32,
    pub pad: u32,
}

/// [`GpuBvhInstanceHeader::static_root`] when rays must start at the top level.
pub const BVH_NO_STATIC_ROOT: u32 = u32::MAX;

/// The first 16 bytes of `bvh.instances` (`BvhInstanceHeader` in WGSL), followed by the
/// [`GpuBvhInstance`]s. Every ray reads it once, before traversal.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBvhInstanceHeader {
    /// Root in `bvh.nodes` of the static level when it is the only instance, so rays start
    /// there with the world ray and skip the top-level node, the instance load and the level
    /// switch; [`BVH_NO_STATIC_ROOT`] otherwise. Both paths visit the same bottom-level nodes
    /// in the same order with the same ray, so their hits are identical.
    pub static_root: u32,
    /// Instances that follow the header (the top level's primitives).
    pub instance_count: u32,
    pub pad: [u32; 2],
}

/// WGSL `Ray` (32 bytes): `origin + t * dir` for `t` in `[t_min, t_max]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    pub origin: [f32; 3],
    pub t_min: f32,
    pub dir: [f32; 3],
    pub t_max: f32,
}

impl GpuRay {
    /// The ray `origin + t * dir`, `t` in `[t_min, t_max]` (`t_max` may be infinite).
    pub fn new(origin: glam::Vec3, dir: glam::Vec3, t_min: f32, t_max: f32) -> Self {
        Self {
            origin: origin.to_array(),
            t_min,
            dir: dir.to_array(),
            t_max,
        }
    }
}

/// WGSL `Hit` (16 bytes): distance, frame triangle index ([`BVH_MISS`] on a miss) and the
/// barycentric weights of v1 and v2.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHit {
    pub t: f32,
    pub triangle: u32,
    pub barycentrics: [f32; 2],
}

impl GpuHit {
    /// The frame triangle that was hit, `None` on a miss.
    pub fn triangle(&self) -> Option<u32> {
        (self.triangle != BVH_MISS).then_some(self.triangle)
    }
}

/// Why a BVH cannot be traced on the GPU.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum BvhError {
    /// Traversal would overflow the fixed per-thread stack (a degenerate build).
    #[error("BVH depth {depth} exceeds the GPU traversal stack of {BVH_STACK_SIZE} entries")]
    TooDeep { depth: u32 },
    /// A leaf names a primitive that `primitive_indices` or the triangle list lacks.
    #[error("BVH primitive {primitive} has no triangle (the list has {triangles})")]
    MissingTriangle { primitive: u32, triangles: usize },
    /// A buffer would exceed the device's largest storage binding.
    #[error("{label} needs {bytes} bytes, over the device's storage binding limit of {limit}")]
    TooLarge {
        label: &'static str,
        bytes: u64,
        limit: u64,
    },
    /// The refit shader of the deforming levels failed to compile (a shader folder named by
    /// `GI_SHADER_DIR` with an error in it).
    #[error("the BVH refit shader does not compile: {message}")]
    Shader { message: String },
}

/// A CWBVH in the shader's layout, ready to upload.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedBvh {
    /// Root first. An empty BVH packs as one node with no children, so buffers are never empty.
    pub nodes: Vec<GpuCwBvhNode>,
    /// `triangles[i]` is the BVH's primitive `i`: `frame_triangles[primitive_indices[i]]`.
    pub triangles: Vec<GpuBvhTriangle>,
    /// Levels below the root of the deepest node (0 for a root-only BVH).
    pub depth: u32,
}

impl PackedBvh {
    /// Packs `bvh`, built over `frame_triangles`, for the GPU. Cost: one pass over nodes and
    /// primitives; the result is 80 bytes per node plus 48 per primitive.
    pub fn new(bvh: &CwBvh, frame_triangles: &[Triangle]) -> Result<Self, BvhError> {
        if bvh.nodes.is_empty() {
            return Ok(Self {
                nodes: vec![GpuCwBvhNode::default()],
                triangles: vec![GpuBvhTriangle::default()],
                depth: 0,
            });
        }
        let depth = gi_scene::cwbvh_depth(bvh);
        if depth > BVH_STACK_SIZE {
            return Err(BvhError::TooDeep { depth });
        }
        let triangles =
            bvh.primitive_indices
                .iter()
                .map(|&primitive| {
                    let tri = frame_triangles.get(primitive as usize).ok_or(
                        BvhError::MissingTriangle {
                            primitive,
                            triangles: frame_triangles.len(),
                        },
                    )?;
                    Ok(GpuBvhTriangle {
                        a: tri.v0.to_array(),
                        triangle: primitive,
                        b: tri.v1.to_array(),
                        flags: 0,
                        c: tri.v2.to_array(),
                        pad_c: 0,
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
        let nodes = bvh.nodes.iter().map(GpuCwBvhNode::from).collect();
        Ok(Self {
            nodes,
            triangles,
            depth,
        })
    }
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris};

    use super::*;

    /// `(size, [(member, offset)])` of the WGSL struct `name` of `gi::bvh`, as naga lays it
    /// out in the composed module.
    fn wgsl_layout(name: &str) -> (u32, Vec<(String, u32)>) {
        let module = crate::ShaderLibrary::new()
            .compose("bvh/cwbvh.wgsl", &[])
            .expect("cwbvh.wgsl composes");
        let layout = crate::wgsl_struct_layout(&module, name)
            .unwrap_or_else(|| panic!("struct {name} in cwbvh.wgsl"));
        (layout.size, layout.members)
    }

    fn offset(layout: &[(String, u32)], member: &str) -> usize {
        layout
            .iter()
            .find(|(name, _)| name == member)
            .unwrap_or_else(|| panic!("member {member}"))
            .1 as usize
    }

    #[test]
    fn node_matches_obvhs_and_wgsl() {
        assert_eq!(size_of::<GpuCwBvhNode>(), 80);
        assert_eq!(size_of::<GpuCwBvhNode>(), size_of::<CwBvhNode>());
        macro_rules! same_offset {
            ($($field:ident),*) => {$(
                assert_eq!(
                    offset_of!(GpuCwBvhNode, $field),
                    offset_of!(CwBvhNode, $field),
                    stringify!($field)
                );
            )*};
        }
        same_offset!(
            p,
            e,
            imask,
            child_base_idx,
            primitive_base_idx,
            child_meta,
            child_min_x,
            child_max_x,
            child_min_y,
            child_max_y,
            child_min_z,
            child_max_z
        );

        let (size, wgsl) = wgsl_layout("CwBvhNode");
        assert_eq!(size as usize, size_of::<GpuCwBvhNode>());
        // WGSL reads the three exponent bytes and the mask as one little-endian word.
        assert_eq!(offset(&wgsl, "e_imask"), offset_of!(GpuCwBvhNode, e));
        assert_eq!(
            offset_of!(GpuCwBvhNode, imask),
            offset_of!(GpuCwBvhNode, e) + 3
        );
        macro_rules! same_wgsl_offset {
            ($($field:ident),*) => {$(
                assert_eq!(
                    offset(&wgsl, stringify!($field)),
                    offset_of!(GpuCwBvhNode, $field),
                    stringify!($field)
                );
            )*};
        }
        same_wgsl_offset!(
            p,
            child_base_idx,
            primitive_base_idx,
            child_meta,
            child_min_x,
            child_max_x,
            child_min_y,
            child_max_y,
            child_min_z,
            child_max_z
        );
    }

    #[test]
    fn instance_header_matches_wgsl() {
        let (size, wgsl) = wgsl_layout("BvhInstanceHeader");
        assert_eq!(size as usize, size_of::<GpuBvhInstanceHeader>());
        assert_eq!(size, 16);
        for (member, rust) in [
            ("static_root", offset_of!(GpuBvhInstanceHeader, static_root)),
            (
                "instance_count",
                offset_of!(GpuBvhInstanceHeader, instance_count),
            ),
        ] {
            assert_eq!(offset(&wgsl, member), rust, "{member}");
        }
        // The instances follow the header directly.
        let (_, instances) = wgsl_layout("BvhInstances");
        assert_eq!(offset(&instances, "header"), 0);
        assert_eq!(
            offset(&instances, "instances"),
            size_of::<GpuBvhInstanceHeader>()
        );
    }

    #[test]
    fn instance_matches_wgsl() {
        let (size, wgsl) = wgsl_layout("BvhInstance");
        assert_eq!(size as usize, size_of::<GpuBvhInstance>());
        assert_eq!(size, 64);
        for (member, rust) in [
            (
                "object_from_world",
                offset_of!(GpuBvhInstance, object_from_world),
            ),
            ("blas_root", offset_of!(GpuBvhInstance, blas_root)),
            ("triangle_base", offset_of!(GpuBvhInstance, triangle_base)),
            ("flags", offset_of!(GpuBvhInstance, flags)),
        ] {
            assert_eq!(offset(&wgsl, member), rust, "{member}");
        }
    }

    #[test]
    fn triangle_ray_and_hit_match_wgsl() {
        let (size, wgsl) = wgsl_layout("BvhTriangle");
        assert_eq!(size as usize, size_of::<GpuBvhTriangle>());
        assert_eq!(offset(&wgsl, "a"), offset_of!(GpuBvhTriangle, a));
        assert_eq!(
            offset(&wgsl, "triangle"),
            offset_of!(GpuBvhTriangle, triangle)
        );
        assert_eq!(offset(&wgsl, "b"), offset_of!(GpuBvhTriangle, b));
        assert_eq!(offset(&wgsl, "c"), offset_of!(GpuBvhTriangle, c));

        let (size, wgsl) = wgsl_layout("Ray");
        assert_eq!(size as usize, size_of::<GpuRay>());
        assert_eq!(offset(&wgsl, "origin"), offset_of!(GpuRay, origin));
        assert_eq!(offset(&wgsl, "t_min"), offset_of!(GpuRay, t_min));
        assert_eq!(offset(&wgsl, "dir"), offset_of!(GpuRay, dir));
        assert_eq!(offset(&wgsl, "t_max"), offset_of!(GpuRay, t_max));

        let (size, wgsl) = wgsl_layout("Hit");
        assert_eq!(size as usize, size_of::<GpuHit>());
        assert_eq!(offset(&wgsl, "t"), offset_of!(GpuHit, t));
        assert_eq!(offset(&wgsl, "triangle"), offset_of!(GpuHit, triangle));
        assert_eq!(
            offset(&wgsl, "barycentrics"),
            offset_of!(GpuHit, barycentrics)
        );
    }

    /// A strip of quads: leaves index the reordered triangles directly and carry the frame
    /// index of the triangle they came from.
    #[test]
    fn packing_reorders_triangles_into_leaf_order() {
        let triangles: Vec<Triangle> = (0..200)
            .map(|i| {
                let x = (i * 7 % 200) as f32;
                Triangle {
                    v0: glam::Vec3A::new(x, 0.0, 0.0),
                    v1: glam::Vec3A::new(x + 1.0, 0.0, 0.0),
                    v2: glam::Vec3A::new(x, 1.0, (i % 3) as f32),
                }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &triangles,
            BvhBuildParams::medium_build(),
            &mut Default::default(),
        );
        let packed = PackedBvh::new(&bvh, &triangles).expect("packs");
        assert_eq!(packed.nodes.len(), bvh.nodes.len());
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(&packed.nodes),
            bytemuck::cast_slice::<_, u8>(&bvh.nodes)
        );
        assert_eq!(packed.triangles.len(), bvh.primitive_indices.len());
        for (packed_tri, &index) in packed.triangles.iter().zip(&bvh.primitive_indices) {
            assert_eq!(packed_tri.triangle, index);
            assert_eq!(packed_tri.c, triangles[index as usize].v2.to_array());
        }
        assert!(packed.depth >= 1 && packed.depth <= BVH_STACK_SIZE);

        let short = &triangles[..10];
        assert!(matches!(
            PackedBvh::new(&bvh, short),
            Err(BvhError::MissingTriangle { triangles: 10, .. })
        ));
    }

    /// A chain of single-child nodes deeper than the stack is refused rather than traversed
    /// with an overflowing stack.
    #[test]
    fn deeper_than_stack_is_refused() {
        let levels = BVH_STACK_SIZE + 2;
        let nodes = (0..levels)
            .map(|i| {
                let mut node = CwBvhNode::default();
                if i + 1 < levels {
                    node.imask = 1;
                    node.child_meta[0] = 24;
                    node.child_base_idx = i + 1;
                }
                node
            })
            .collect();
        let bvh = CwBvh {
            nodes,
            ..Default::default()
        };
        assert_eq!(
            PackedBvh::new(&bvh, &[]),
            Err(BvhError::TooDeep { depth: levels - 1 })
        );
    }

    #[test]
    fn empty_bvh_packs_one_childless_node() {
        let packed = PackedBvh::new(&CwBvh::default(), &[]).expect("packs");
        assert_eq!(packed.nodes, vec![GpuCwBvhNode::default()]);
        assert_eq!(packed.triangles.len(), 1);
    }
}

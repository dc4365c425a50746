//! The cache's GPU data layout and its addressing, mirrored by `shaders/cache/data.wgsl`
//! (import path `gi::cache::data`). Tests check every mirrored struct against naga's layout
//! and every addressing function against the WGSL one.
//!
//! ## Structure
//!
//! - A **voxel** is a cube of `voxel_size_at(level)` meters. A **brick** is 4 x 4 x 4 voxels
//!   (HSGI's brick), so its occupancy is one 64-bit mask. A **group** is 4 x 4 x 4 bricks, so
//!   which of its bricks hold anything is one 64-bit mask too: the two levels of SmartGI's
//!   hierarchical DDA, with HSGI's brick size. (SmartGI's 8^3 bricks need a 2^3 "voxel group"
//!   indirection to fit a 64-bit mask; 4^3 bricks fit directly.)
//! - Each **level** is a window of `level_bricks` bricks in world brick coordinates starting at
//!   its `origin_brick`, always a multiple of 4 (a group boundary) so that groups move as
//!   units. Brick `b` of a level lives in the level's **link grid** slot `b mod level_bricks`
//!   (toroidal addressing): when the window moves, bricks that stay keep their slot and only
//!   the newly exposed slab is cleared and refilled.
//! - The **link grid** holds, per slot, the ID of the pooled brick there, 0 when the brick is
//!   empty (HSGI's "hierarchy link"). The **group masks** hold one 64-bit mask per group slot
//!   (bit `x + 4y + 16z` for the brick at `(x, y, z)` inside the group), kept equal to "link
//!   is non-zero".
//! - The **pool** is indexed by brick ID (1-based; entry 0 exists and stays empty): a 64-bit
//!   voxel occupancy mask per brick (bit `x + 4y + 16z` for voxel `(x, y, z)` inside it), a
//!   [`VoxelSurface`] per voxel, and two irradiances (direct, indirect) per voxel **side**.
//!
//! ## Sides
//!
//! A voxel's surface is a surfel, "voxel + normal" (HSGI): it has two sides, the **front**
//! (side 0, [`SIDE_FRONT`]) along its normal `n` and the **back** (side 1, [`SIDE_BACK`]) along
//! `-n`, and its lighting is stored per side. A ray sees the side facing it: the front when
//! `dot(dir, n) < 0`, else the back ([`side_seen_by_ray`]; a ray exactly in the surfel's plane
//! sees the back, an arbitrary but fixed choice for a case of measure zero). The irradiance of
//! a side is what a surface of normal `+-n` receives just outside the voxel on that side.
//!
//! Two sides are what SmartGI's visible faces are for: a wall thinner than a voxel, lit on
//! one side and dark on the other, is exactly a front and a back, and a voxel whose normal is
//! averaged over an edge or a corner is lit with that averaged normal from outside the corner,
//! where axis faces would be hidden by the neighbouring voxels and read as black. It also
//! costs a third of six faces: 16 bytes of surface + 2 sides x (direct + indirect) x 4 bytes =
//! 32 bytes per voxel instead of 64, so the same ~25 MiB holds twice the bricks.
//!
//! The tracer still reports the axis face a ray entered a voxel through ([`FACE_DIRECTIONS`],
//! [`face_index`]), for debugging and for the traversal's own tests.

use bytemuck::{Pod, Zeroable};
use glam::{IVec3, UVec3, Vec3};

/// Voxels along each edge of a brick.
pub const BRICK_VOXELS: u32 = 4;
/// Voxels in a brick (bits of its occupancy mask).
pub const VOXELS_PER_BRICK: u32 = 64;
/// Bricks along each edge of a group.
pub const GROUP_BRICKS: u32 = 4;
/// Lighting sides per voxel: front (along the normal) and back.
pub const SIDE_COUNT: u32 = 2;
/// The side along the voxel's normal.
pub const SIDE_FRONT: u32 = 0;
/// The side along the opposite of the voxel's normal.
pub const SIDE_BACK: u32 = 1;
/// Axis faces of a voxel (the tracer reports the one a ray entered through).
pub const FACE_COUNT: u32 = 6;
/// Most levels a cache can have (the size of the uniform level table).
pub const MAX_LEVELS: u32 = 8;
/// Link-grid value of a slot without a brick.
pub const NO_BRICK: u32 = 0;

/// Outward normal of each face, in face-index order.
pub const FACE_DIRECTIONS: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

/// Face index of the side with outward normal along `axis` (0, 1, 2) in direction `positive`.
pub fn face_index(axis: usize, positive: bool) -> u32 {
    axis as u32 * 2 + u32::from(!positive)
}

/// One level's window, as the shaders read it (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCacheLevel {
    /// World brick coordinate of the window's lowest corner (a multiple of 4 per axis).
    pub origin_brick: [i32; 3],
    /// Edge of one of this level's voxels in meters.
    pub voxel_size_m: f32,
}

/// Uniforms of every cache pass and query (`gi::cache::data::CacheUniforms`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCacheUniforms {
    /// Level windows, finest first; entries at and after `level_count` are unused.
    pub levels: [GpuCacheLevel; MAX_LEVELS as usize],
    /// Bricks per level along x, y, z.
    pub level_bricks: [u32; 3],
    /// Number of levels in use.
    pub level_count: u32,
    /// `level_bricks.x * y * z`: link-grid slots per level.
    pub bricks_per_level: u32,
    /// Groups per level.
    pub groups_per_level: u32,
    /// Brick IDs in the pool are `1..=pool_bricks`.
    pub pool_bricks: u32,
    /// Frames the cache has been updated (drives random sequences of the update passes).
    pub frame_index: u32,
}

/// What the cache knows about the surface inside one voxel (16 bytes, `gi::cache::data::VoxelSurface`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelSurface {
    /// Diffuse albedo (rgb) and coverage (a: the fraction of the voxel's samples that found
    /// surface), `pack4x8unorm`.
    pub albedo: u32,
    /// Unit surface normal, octahedral in two 16-bit snorms (`gi::packing::pack_unit_vector`).
    pub normal: u32,
    /// Emitted radiance (W/(sr m^2)), RGB9E5 (`gi::packing::pack_rgb9e5`).
    pub emission: u32,
    /// Bits 0-7: age (lighting updates accumulated, saturating at `max_age`); bit 8: the voxel
    /// holds a dynamic (moving) object's surface; bits 9-26: the box around the voxel's
    /// geometry ([`geometry_box_bits`]; all zero is the whole voxel); bits 27-29: the share of
    /// its reflected light that changed lately, in steps of `1 / CHANGE_LEVELS`
    /// ([`STATE_CHANGE_SHIFT`], set by the lighting passes; 0 for a new voxel); bits 30-31: the
    /// frames since that change was measured, up to 3 ([`STATE_CHANGE_FRAMES_SHIFT`]).
    pub state: u32,
}

/// First `VoxelSurface::state` bit of the geometry box.
pub const STATE_BOX_SHIFT: u32 = 9;
/// Steps per voxel edge of the geometry box's bounds.
pub const BOX_STEPS: u32 = 8;

/// `VoxelSurface::state` bits (already shifted) of the box `[lo, hi]` around the geometry in a
/// voxel of half edge `half`, `lo` and `hi` relative to its center: per axis (x, y, z, 6 bits
/// each from [`STATE_BOX_SHIFT`]) 3 bits of the lower bound in eighths of the voxel edge,
/// rounded down, and 3 bits of `8 -` the upper bound, rounded up, so the stored box holds the
/// geometry and all zero bits are the whole voxel. A box is at least an eighth thick.
///
/// A ray through an occupied voxel hits it only where it meets this box
/// (`gi::cache::trace::cache_ray_meets_box`). Every ray that meets the geometry inside the
/// voxel meets its box, so no ray passes a surface it hits; a ray passing beside the surface
/// (through a door's opening next to its jamb, whose voxels reach up to a voxel into the
/// opening) goes on.
pub fn geometry_box_bits(lo: glam::Vec3, hi: glam::Vec3, half: f32) -> u32 {
    let steps = BOX_STEPS as f32;
    let mut bits = 0u32;
    for axis in 0..3u32 {
        let to_steps = |x: f32| (x + half) / (2.0 * half) * steps;
        // Rounded outwards, with a margin for the rounding of the clipped vertices.
        let (lo, hi) = (lo[axis as usize], hi[axis as usize]);
        let a = (to_steps(lo) - 1e-3).floor().clamp(0.0, steps - 1.0) as u32;
        let b = ((to_steps(hi) + 1e-3).ceil().clamp(1.0, steps) as u32).max(a + 1);
        bits |= (a | ((BOX_STEPS - b) << 3)) << (STATE_BOX_SHIFT + 6 * axis);
    }
    bits
}

/// The box (`(lo, hi)` in eighths of the voxel edge from its lowest corner) that
/// `VoxelSurface::state` holds: the inverse of [`geometry_box_bits`] up to its rounding.
pub fn geometry_box(state: u32) -> (glam::UVec3, glam::UVec3) {
    let bits = state >> STATE_BOX_SHIFT;
    let field = |axis: u32, shift: u32| (bits >> (6 * axis + shift)) & 7;
    (
        glam::UVec3::new(field(0, 0), field(1, 0), field(2, 0)),
        glam::UVec3::new(
            BOX_STEPS - field(0, 3),
            BOX_STEPS - field(1, 3),
            BOX_STEPS - field(2, 3),
        ),
    )
}

/// The area that the box stored in `state` ([`geometry_box`]; the whole voxel when its bits
/// are 0) of a voxel of edge `s` shows along unit direction `n`: the sum over the box's faces
/// of their area times `|n|` along their axis.
pub fn box_cross_section(state: u32, n: glam::Vec3, s: f32) -> f32 {
    let (lo, hi) = geometry_box(state);
    let e = (hi - lo).as_vec3() * (s / BOX_STEPS as f32);
    let a = n.abs();
    a.x * e.y * e.z + a.y * e.x * e.z + a.z * e.x * e.y
}

/// First `VoxelSurface::state` bit of the voxel's measured change (`cache_voxel_change` in
/// `shaders/cache/data.wgsl`).
pub const STATE_CHANGE_SHIFT: u32 = 27;
/// Steps of the measured change (also the mask of its bits): `CHANGE_LEVELS` is all of the
/// voxel's light.
pub const CHANGE_LEVELS: u32 = 7;
/// First `VoxelSurface::state` bit of the frames since the change was measured.
pub const STATE_CHANGE_FRAMES_SHIFT: u32 = 30;

/// The measured change (0 to 1) that `state` holds.
pub fn state_change(state: u32) -> f32 {
    ((state >> STATE_CHANGE_SHIFT) & CHANGE_LEVELS) as f32 / CHANGE_LEVELS as f32
}

/// The frames since the change `state` holds was measured (0 to 3, 3 meaning 3 or more).
pub fn state_change_frames(state: u32) -> u32 {
    state >> STATE_CHANGE_FRAMES_SHIFT
}

/// `VoxelSurface::state` bit of voxels that hold part of a moving object.
pub const STATE_DYNAMIC: u32 = 1 << 8;
/// `VoxelSurface::state` mask of the age.
pub const STATE_AGE_MASK: u32 = 0xff;

/// Bit of a cell `(x, y, z)` (each 0..4) in a 64-bit brick or group mask.
pub fn mask_bit(cell: UVec3) -> u32 {
    cell.x + 4 * cell.y + 16 * cell.z
}

/// The cell `(x, y, z)` of bit `bit` of a 64-bit mask.
pub fn mask_cell(bit: u32) -> UVec3 {
    UVec3::new(bit & 3, (bit >> 2) & 3, bit >> 4)
}

/// World voxel coordinate of `point` at a level with voxels of `voxel_size_m`.
pub fn voxel_of_point(point: Vec3, voxel_size_m: f32) -> IVec3 {
    (point / voxel_size_m).floor().as_ivec3()
}

/// World brick coordinate of a world voxel coordinate.
pub fn brick_of_voxel(voxel: IVec3) -> IVec3 {
    voxel >> 2
}

/// World group coordinate of a world brick coordinate.
pub fn group_of_brick(brick: IVec3) -> IVec3 {
    brick >> 2
}

/// True when world brick `brick` lies inside the window starting at `origin_brick`.
pub fn in_window(brick: IVec3, origin_brick: IVec3, level_bricks: UVec3) -> bool {
    let local = brick - origin_brick;
    local.cmpge(IVec3::ZERO).all() && local.cmplt(level_bricks.as_ivec3()).all()
}

/// Link-grid slot (within its level) of world brick `brick`: toroidal, so it does not depend
/// on where the window is.
pub fn brick_slot(brick: IVec3, level_bricks: UVec3) -> u32 {
    let dims = level_bricks.as_ivec3();
    let p = brick.rem_euclid(dims).as_uvec3();
    p.x + level_bricks.x * (p.y + level_bricks.y * p.z)
}

/// Group-mask slot (within its level) of world group `group`.
pub fn group_slot(group: IVec3, level_bricks: UVec3) -> u32 {
    let dims = level_bricks / GROUP_BRICKS;
    let p = group.rem_euclid(dims.as_ivec3()).as_uvec3();
    p.x + dims.x * (p.y + dims.y * p.z)
}

/// Index of a voxel in the pool's per-voxel arrays.
pub fn voxel_index(brick_id: u32, bit: u32) -> u32 {
    brick_id * VOXELS_PER_BRICK + bit
}

/// Index of a voxel side in the pool's per-side arrays (`cache_direct`, `cache_indirect`).
pub fn side_slot(brick_id: u32, bit: u32, side: u32) -> u32 {
    voxel_index(brick_id, bit) * SIDE_COUNT + side
}

/// The side of a surfel of normal `normal` that a ray along `dir` sees: [`SIDE_FRONT`] when it
/// arrives against the normal (`dot(dir, normal) < 0`), else [`SIDE_BACK`] (a ray in the plane
/// included).
pub fn side_seen_by_ray(normal: Vec3, dir: Vec3) -> u32 {
    if dir.dot(normal) < 0.0 {
        SIDE_FRONT
    } else {
        SIDE_BACK
    }
}

/// Outward normal of side `side` of a surfel of normal `normal`.
pub fn side_normal(normal: Vec3, side: u32) -> Vec3 {
    if side == SIDE_FRONT { normal } else { -normal }
}

/// A 64-bit mask as the shaders store it: `[low word, high word]`.
pub fn split_mask(mask: u64) -> [u32; 2] {
    [mask as u32, (mask >> 32) as u32]
}

/// Inverse of [`split_mask`].
pub fn join_mask(words: [u32; 2]) -> u64 {
    u64::from(words[0]) | (u64::from(words[1]) << 32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toroidal_slots_stay_put_when_the_window_moves() {
        let dims = UVec3::new(8, 4, 8);
        let brick = IVec3::new(-3, 5, 17);
        let slot = brick_slot(brick, dims);
        // Any window containing the brick addresses it at the same slot, and two bricks of
        // one window never share a slot.
        for origin in [IVec3::new(-8, 4, 12), IVec3::new(-4, 4, 16)] {
            assert!(in_window(brick, origin, dims));
            let mut seen = std::collections::HashSet::new();
            for z in 0..8 {
                for y in 0..4 {
                    for x in 0..8 {
                        let b = origin + IVec3::new(x, y, z);
                        assert!(seen.insert(brick_slot(b, dims)));
                    }
                }
            }
            assert_eq!(brick_slot(brick, dims), slot);
        }
    }

    #[test]
    fn coordinates_floor_towards_negative_infinity() {
        assert_eq!(
            voxel_of_point(Vec3::new(-0.01, 0.0, 0.99), 0.5),
            IVec3::new(-1, 0, 1)
        );
        assert_eq!(brick_of_voxel(IVec3::new(-1, 3, 4)), IVec3::new(-1, 0, 1));
        assert_eq!(group_of_brick(IVec3::new(-5, 0, 15)), IVec3::new(-2, 0, 3));
        for bit in 0..64 {
            assert_eq!(mask_bit(mask_cell(bit)), bit);
        }
        assert_eq!(
            join_mask(split_mask(0x8000_0001_0000_0002)),
            0x8000_0001_0000_0002
        );
        assert_eq!(face_index(1, false), 3);
        assert_eq!(FACE_DIRECTIONS[face_index(2, true) as usize], Vec3::Z);
        assert_eq!(side_slot(3, 5, SIDE_BACK), (3 * 64 + 5) * 2 + 1);
        assert_eq!(side_seen_by_ray(Vec3::Y, Vec3::NEG_Y), SIDE_FRONT);
        assert_eq!(side_seen_by_ray(Vec3::Y, Vec3::Y), SIDE_BACK);
        assert_eq!(side_seen_by_ray(Vec3::Y, Vec3::X), SIDE_BACK);
        assert_eq!(side_normal(Vec3::X, SIDE_BACK), Vec3::NEG_X);
    }
}

// What the cache's lighting passes (`cache/inject.wgsl`, `cache/propagate.wgsl`,
// `cache/propagate_resolve.wgsl`) share: their uniforms, the list of bricks scheduled this frame
// and the voxel each thread updates, the propagation's scratch and the point a voxel side is lit
// at. Mirrors `gi_cache::lighting`; a test checks the struct layouts. Finding a thread's voxel
// reads the cache (`gi::cache::data`, group 2), which every lighting pass binds.
//
// Bind group 0 of all three passes (`gi_cache::CacheLighting`):
//   binding 0: `lighting` uniform LightingUniforms
//   bindings 1-7: the scene (`gi::scene`, `gi_gpu::GpuScene::buffers`): triangles, materials,
//              texture references, tangents and TEXCOORD_1, the emitter table, selection
//              probabilities, punctual lights (the texture arrays are bind group 3)
//   binding 8: `scheduled_bricks` array<ScheduledBrick>, one workgroup each
//   binding 9: `propagate_scratch` array<u32>, per scheduled brick * 128 + voxel bit * 2 + side:
//              the side's new RGB9E5 indirect irradiance, its new age and measured change (in
//              the state's bits), then its emitted part when the cache keeps it
//              (`propagate_scratch_slot`), written by `cache/propagate` and stored into
//              `cache_indirect`, the voxel's state (and `cache_emitted`) by
//              `cache/propagate_resolve`
#define_import_path gi::cache::lighting

#import gi::sky::Sky
#import gi::cache::data::{
    cache, cache_brick_masks, cache_voxels, VoxelRef, VoxelSurface, cache_mask_cell,
    cache_mask_test, cache_voxel_index, cache_voxel_normal, cache_voxel_age, cache_keeps_emitted
}

// Distance from a voxel's center to the point its sides are lit at, in voxel edges: half the
// voxel's diagonal, so the point lies beyond the voxel's surface (a plane of normal n crossing
// the voxel is at most sqrt(3) / 2 edges from its center) whatever the normal's direction.
const SIDE_OFFSET_VOXELS: f32 = 0.8660254;

// Mirror of `gi_cache::lighting::GpuLightingUniforms`.
struct LightingUniforms {
    sky: Sky,
    // Entries of `scheduled_bricks` this frame (= workgroups dispatched).
    brick_count: u32,
    // Punctual lights in `lights`.
    light_count: u32,
    // `CacheConfig::gather_rays_per_side`.
    rays_per_side: u32,
    // `CacheConfig::max_age`.
    max_age: u32,
    // Lighting updates so far: the sample index of every side's random sequence.
    frame_index: u32,
    // Seed of the gather's random sequences.
    seed: u32,
    // Entries of the scene's emitter table (`gi::scene::emitters`).
    emitter_count: u32,
    // Index of the default material in `gi::scene::materials`.
    default_material: u32,
    // `CacheConfig::change_gain`: how strongly a measured change of the light a voxel side
    // sees raises its update's weight above 1 / age; 0 weighs by age alone.
    change_gain: f32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

// Mirror of `gi_cache::lighting::GpuScheduledBrick`: a brick whose lighting is updated.
struct ScheduledBrick {
    // World brick coordinate at `level`.
    brick: vec3<i32>,
    level: u32,
    // Pool ID.
    brick_id: u32,
    // Cap of its voxels' ages in this update (`gi_cache::lighting::GpuScheduledBrick`): the
    // uniforms' `max_age`, lower while the brick settles, 0 during a fill.
    max_age: u32,
    pad_b: u32,
    pad_c: u32,
}

@group(0) @binding(0) var<uniform> lighting: LightingUniforms;
@group(0) @binding(8) var<storage, read> scheduled_bricks: array<ScheduledBrick>;
@group(0) @binding(9) var<storage, read_write> propagate_scratch: array<u32>;
// The occupied voxel sides of this frame's bricks, one entry each (`propagate_entry`), written
// by `cache/propagate_list` in no fixed order and read by `cache/propagate`.
@group(0) @binding(10) var<storage, read_write> propagate_entries: array<u32>;

// An entry of `propagate_entries`: side `side` of voxel `bit` of the `scheduled`-th brick, plus one
// (a cleared entry, 0, is none: `PROPAGATE_NO_ENTRY`).
fn propagate_entry(scheduled: u32, bit: u32, side: u32) -> u32 {
    return ((scheduled << 7u) | (bit << 1u) | side) + 1u;
}

const PROPAGATE_NO_ENTRY: u32 = 0u;

// A voxel of a brick scheduled this frame: thread `bit` of workgroup `i` of each lighting pass
// updates voxel `bit` of `scheduled_bricks[i]`.
struct ScheduledVoxel {
    // The voxel in the pool.
    v: VoxelRef,
    // Its world voxel coordinate at `level`.
    voxel: vec3<i32>,
    // Its cache level.
    level: u32,
    // Its world-space center.
    center: vec3<f32>,
    // Its edge length in metres.
    size_m: f32,
    // Its stored surface, as the pass found it, and that surface's normal.
    surface: VoxelSurface,
    n: vec3<f32>,
    // Its brick's age cap in this update (`ScheduledBrick::max_age`).
    max_age: u32,
}

// Whether thread `bit` of workgroup `scheduled` of a lighting pass has a voxel to update: the
// workgroup has a scheduled brick and the brick's voxel `bit` is occupied.
fn scheduled_voxel_occupied(scheduled: u32, bit: u32) -> bool {
    return scheduled < lighting.brick_count
        && cache_mask_test(cache_brick_masks[scheduled_bricks[scheduled].brick_id], bit);
}

// Voxel `bit` of the `scheduled`-th brick of `scheduled_bricks`, an occupied one
// (`scheduled_voxel_occupied`).
fn scheduled_voxel(scheduled: u32, bit: u32) -> ScheduledVoxel {
    let brick = scheduled_bricks[scheduled];
    let v = VoxelRef(brick.brick_id, bit);
    let size_m = cache.levels[brick.level].voxel_size_m;
    let voxel = brick.brick * 4 + vec3<i32>(cache_mask_cell(bit));
    let center = (vec3<f32>(voxel) + 0.5) * size_m;
    let surface = cache_voxels[cache_voxel_index(v)];
    return ScheduledVoxel(
        v, voxel, brick.level, center, size_m, surface, cache_voxel_normal(surface), brick.max_age
    );
}

// Index in `propagate_scratch` of side `side` of voxel `bit` of the `scheduled`-th brick: its
// indirect irradiance; at the next index its new age and change (`VoxelSurface::state`'s bits
// 0-7 and 27-31, the rest 0), then its emitted part when the cache keeps that.
fn propagate_scratch_slot(scheduled: u32, bit: u32, side: u32) -> u32 {
    let stride = select(2u, 3u, cache_keeps_emitted());
    return ((scheduled * 64u + bit) * 2u + side) * stride;
}

// Age of voxel `lit` after this frame's propagation by age alone: one update older, at most its
// brick's cap (`cache/propagate` lowers it where it measured a change).
fn propagated_age(lit: ScheduledVoxel) -> u32 {
    return min(cache_voxel_age(lit.surface) + 1u, lit.max_age);
}

// The point side `side_n` (the side's outward normal, the voxel normal or its opposite) of a
// voxel of edge `size` centered at `center` is lit at: along `side_n` by half the voxel's
// diagonal plus a margin that escapes f32 rounding, so just outside the surfel on that side
// (HSGI's offset origin). Clamped to the voxel's 3 x 3 x 3 neighbourhood, which a unit normal
// never leaves: the clamp only guards against a degenerate stored normal. A side facing into
// solid geometry (a wall's back resting against another surface) simply sees that geometry
// from there.
fn side_point(center: vec3<f32>, size: f32, side_n: vec3<f32>) -> vec3<f32> {
    let a = abs(center);
    let margin = max(1e-3 * size, 1e-4 * (1.0 + max(max(a.x, a.y), a.z)));
    let p = center + side_n * (SIDE_OFFSET_VOXELS * size + margin);
    return clamp(p, center - vec3(size), center + vec3(size));
}

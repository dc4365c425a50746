// The surfel brick radiance cache's data and addressing (HSGI, GDC 2023, "Radiance Cache":
// bricks of 4^3 surfel voxels, a brick-ID pool, a dense hierarchy link, clipmap levels with
// toroidal addressing; SmartGI, SIGGRAPH 2024, "Bricklizer": 64-bit brick and group masks for
// a two-level HDDA, lighting per visible voxel face). Lighting is stored per surfel side: HSGI's
// surfel is "voxel + normal", so a voxel has a front side (0, along its normal) and a back side
// (1, against it), the two faces of a thin wall that SmartGI's visible faces keep apart;
// `gi_cache::layout` explains why two sides rather than six axis faces.
//
// Mirrors `gi_cache::layout` (the Rust side documents the structure in full); tests check the
// struct layouts and the addressing functions against it.
//
// Bind group 2 (`gi_cache::CacheBuffers::bind_group_layout`), compute stages:
//   binding 0: `cache` uniform CacheUniforms
//   binding 1: `cache_link` array<u32>, per level then per brick slot: brick ID, 0 = empty
//   binding 2: `cache_group_masks` array<vec2<u32>>, per level then per group slot
//   binding 3: `cache_brick_masks` array<vec2<u32>>, per brick ID: voxel occupancy
//   binding 4: `cache_voxels` array<VoxelSurface>, per brick ID * 64 + voxel bit
//   binding 5: `cache_direct` array<u32>, per voxel index * 2 + side: RGB9E5 direct irradiance
//   binding 6: `cache_indirect` array<u32>, same indexing: RGB9E5 indirect irradiance
//   binding 7: `cache_emitted` array<u32>, same indexing: RGB9E5, the part of the indirect
//              irradiance that emissive triangles give directly (accumulated alongside it);
//              one placeholder element unless `gi_cache::CacheConfig::keep_emitted`
// The storage buffers are read_write so update passes and queries share one module and one
// layout; queries only read them.
#define_import_path gi::cache::data

#import gi::packing::{unpack_rgb9e5, unpack_unit_vector}

const CACHE_MAX_LEVELS: u32 = 8u;
const CACHE_NO_BRICK: u32 = 0u;
const CACHE_SIDE_COUNT: u32 = 2u;
// The side along the voxel's normal, and the one against it.
const CACHE_SIDE_FRONT: u32 = 0u;
const CACHE_SIDE_BACK: u32 = 1u;
const CACHE_STATE_DYNAMIC: u32 = 256u;
// `gi_cache::layout::STATE_BOX_SHIFT` and `BOX_STEPS`: where the state holds the box around
// the voxel's geometry, and its steps per voxel edge.
const CACHE_STATE_BOX_SHIFT: u32 = 9u;
const CACHE_BOX_STEPS: u32 = 8u;
// `gi_cache::layout::STATE_CHANGE_SHIFT`, `CHANGE_LEVELS` and `STATE_CHANGE_FRAMES_SHIFT`:
// where the state holds the share of the voxel's reflected light that changed lately
// (`cache_voxel_change`), in steps of 1 / CACHE_CHANGE_LEVELS, and the frames since that change
// was measured (`cache/change_age` counts them, up to CACHE_CHANGE_FRAMES_MAX).
const CACHE_STATE_CHANGE_SHIFT: u32 = 27u;
const CACHE_CHANGE_LEVELS: u32 = 7u;
const CACHE_STATE_CHANGE_FRAMES_SHIFT: u32 = 30u;
const CACHE_CHANGE_FRAMES_MAX: u32 = 3u;
const CACHE_INV_PI: f32 = 0.3183098861837907;

// One level's window: world brick coordinate of its lowest corner and its voxel edge.
struct CacheLevel {
    origin_brick: vec3<i32>,
    voxel_size_m: f32,
}

// Mirror of `gi_cache::GpuCacheUniforms`.
struct CacheUniforms {
    levels: array<CacheLevel, 8>,
    level_bricks: vec3<u32>,
    level_count: u32,
    bricks_per_level: u32,
    groups_per_level: u32,
    pool_bricks: u32,
    frame_index: u32,
}

// Mirror of `gi_cache::VoxelSurface`: albedo rgb + coverage a (unorm8), packed unit normal,
// RGB9E5 emission, state (bits 0-7 age, bit 8 dynamic, bits 9-26 the geometry box, bits 27-29
// the measured change of its light, bits 30-31 the frames since it was measured).
struct VoxelSurface {
    albedo: u32,
    normal: u32,
    emission: u32,
    state: u32,
}

// A voxel found in the cache: the pooled brick holding it (0: none) and its bit in the brick.
struct VoxelRef {
    brick_id: u32,
    bit: u32,
}

@group(2) @binding(0) var<uniform> cache: CacheUniforms;
@group(2) @binding(1) var<storage, read_write> cache_link: array<u32>;
@group(2) @binding(2) var<storage, read_write> cache_group_masks: array<vec2<u32>>;
@group(2) @binding(3) var<storage, read_write> cache_brick_masks: array<vec2<u32>>;
@group(2) @binding(4) var<storage, read_write> cache_voxels: array<VoxelSurface>;
@group(2) @binding(5) var<storage, read_write> cache_direct: array<u32>;
@group(2) @binding(6) var<storage, read_write> cache_indirect: array<u32>;
@group(2) @binding(7) var<storage, read_write> cache_emitted: array<u32>;

// Whether the cache keeps the emitted part of its sides' indirect irradiance (`cache_emitted`
// holds every side rather than a placeholder).
fn cache_keeps_emitted() -> bool {
    return arrayLength(&cache_emitted) > 1u;
}

// Bit of cell `c` (each component 0..3) in a 64-bit brick or group mask.
fn cache_mask_bit(c: vec3<u32>) -> u32 {
    return c.x + 4u * c.y + 16u * c.z;
}

// Cell of bit `bit` of a 64-bit mask.
fn cache_mask_cell(bit: u32) -> vec3<u32> {
    return vec3(bit & 3u, (bit >> 2u) & 3u, bit >> 4u);
}

// True when bit `bit` (0..63) of the 64-bit mask `m` ([low, high]) is set.
fn cache_mask_test(m: vec2<u32>, bit: u32) -> bool {
    return ((m[bit >> 5u] >> (bit & 31u)) & 1u) != 0u;
}

// Index of the axis face with outward normal along `axis` in direction `positive`
// (0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z): the face a ray entered a voxel through, for debugging.
fn cache_face_index(axis: u32, positive: bool) -> u32 {
    return axis * 2u + select(1u, 0u, positive);
}

// Outward normal of face `face`.
fn cache_face_direction(face: u32) -> vec3<f32> {
    var d = vec3(0.0);
    d[face >> 1u] = select(1.0, -1.0, (face & 1u) != 0u);
    return d;
}

// World voxel coordinate of `p` at `level`.
fn cache_voxel_of_point(p: vec3<f32>, level: u32) -> vec3<i32> {
    return vec3<i32>(floor(p / cache.levels[level].voxel_size_m));
}

// True when world brick `brick` is inside `level`'s window.
fn cache_in_window(level: u32, brick: vec3<i32>) -> bool {
    let local = brick - cache.levels[level].origin_brick;
    return all(local >= vec3(0)) && all(local < vec3<i32>(cache.level_bricks));
}

// Finest level whose window holds `p`, or `cache.level_count` when none does.
fn cache_level_of_point(p: vec3<f32>) -> u32 {
    for (var level = 0u; level < cache.level_count; level++) {
        if cache_in_window(level, cache_voxel_of_point(p, level) >> vec3(2u)) {
            return level;
        }
    }
    return cache.level_count;
}

// Toroidal link-grid index (level-major) of world brick `brick`.
fn cache_link_index(level: u32, brick: vec3<i32>) -> u32 {
    let dims = vec3<i32>(cache.level_bricks);
    let p = vec3<u32>(((brick % dims) + dims) % dims);
    return level * cache.bricks_per_level + p.x + cache.level_bricks.x * (p.y + cache.level_bricks.y * p.z);
}

// Toroidal group-mask index (level-major) of world group `group`.
fn cache_group_index(level: u32, group: vec3<i32>) -> u32 {
    let dims_u = cache.level_bricks / 4u;
    let dims = vec3<i32>(dims_u);
    let p = vec3<u32>(((group % dims) + dims) % dims);
    return level * cache.groups_per_level + p.x + dims_u.x * (p.y + dims_u.y * p.z);
}

// Pooled brick ID of world brick `brick` at `level`; CACHE_NO_BRICK outside the window or
// where the brick is empty.
fn cache_brick_id(level: u32, brick: vec3<i32>) -> u32 {
    if !cache_in_window(level, brick) {
        return CACHE_NO_BRICK;
    }
    return cache_link[cache_link_index(level, brick)];
}

// The occupied voxel at world voxel coordinate `voxel` of `level`; brick_id 0 when the voxel
// is empty or outside the window.
fn cache_voxel_at(level: u32, voxel: vec3<i32>) -> VoxelRef {
    let brick_id = cache_brick_id(level, voxel >> vec3(2u));
    let bit = cache_mask_bit(vec3<u32>(voxel & vec3(3)));
    if brick_id == CACHE_NO_BRICK || !cache_mask_test(cache_brick_masks[brick_id], bit) {
        return VoxelRef(CACHE_NO_BRICK, bit);
    }
    return VoxelRef(brick_id, bit);
}

// Index of a voxel in `cache_voxels`.
fn cache_voxel_index(v: VoxelRef) -> u32 {
    return v.brick_id * 64u + v.bit;
}

// Index of side `side` of voxel `v` in `cache_direct`, `cache_indirect` and `cache_emitted`.
fn cache_side_slot(v: VoxelRef, side: u32) -> u32 {
    return cache_voxel_index(v) * CACHE_SIDE_COUNT + side;
}

// The side of a surfel of normal `n` that a ray along `dir` sees: the front when the ray arrives
// against the normal (dot(dir, n) < 0), else the back. A ray exactly in the surfel's plane
// (dot = 0) sees the back: an arbitrary but fixed choice, for a case of measure zero that the
// traversal's exact axis-parallel rays against axis-aligned normals do meet.
fn cache_side_seen_by_ray(n: vec3<f32>, dir: vec3<f32>) -> u32 {
    return select(CACHE_SIDE_BACK, CACHE_SIDE_FRONT, dot(dir, n) < 0.0);
}

// Outward normal of side `side` of a surfel of normal `n`.
fn cache_side_normal(n: vec3<f32>, side: u32) -> vec3<f32> {
    return select(-n, n, side == CACHE_SIDE_FRONT);
}

// The box around a voxel's geometry that its state holds (`gi_cache::layout::geometry_box`):
// bounds in steps of 1 / CACHE_BOX_STEPS of the voxel edge from its lowest corner; all-zero
// bits are the whole voxel.
struct CacheGeometryBox {
    lo: vec3<u32>,
    hi: vec3<u32>,
}

fn cache_geometry_box(state: u32) -> CacheGeometryBox {
    let bits = state >> CACHE_STATE_BOX_SHIFT;
    let lo = vec3<u32>(bits & 7u, (bits >> 6u) & 7u, (bits >> 12u) & 7u);
    let hi = CACHE_BOX_STEPS - vec3<u32>((bits >> 3u) & 7u, (bits >> 9u) & 7u, (bits >> 15u) & 7u);
    return CacheGeometryBox(lo, hi);
}

fn cache_voxel_albedo(s: VoxelSurface) -> vec3<f32> {
    return unpack4x8unorm(s.albedo).rgb;
}

fn cache_voxel_normal(s: VoxelSurface) -> vec3<f32> {
    return unpack_unit_vector(s.normal);
}

fn cache_voxel_emission(s: VoxelSurface) -> vec3<f32> {
    return unpack_rgb9e5(s.emission);
}

fn cache_voxel_age(s: VoxelSurface) -> u32 {
    return s.state & 0xffu;
}

// The share (0 to 1) of the voxel's reflected light that changed lately, as the lighting
// measured it (`gi_cache::lighting`'s "measured change"): `cache/inject` raises it where a
// side's direct light changed, `cache/propagate` sets it from the change its rays found. Exactly
// 0 while nothing in the scene changes. It lasts until the voxel's next update, which weighs
// it: the cache's own passes read it.
fn cache_voxel_change(s: VoxelSurface) -> f32 {
    return f32((s.state >> CACHE_STATE_CHANGE_SHIFT) & CACHE_CHANGE_LEVELS) / f32(CACHE_CHANGE_LEVELS);
}

// `cache_voxel_change` where it was measured in this frame's lighting update or the last one,
// else 0: what has just changed in the voxel's light. The passes that read the cache's light on
// screen read this: a change measured frames ago (a voxel waits for its next update) has long
// reached them.
fn cache_voxel_recent_change(s: VoxelSurface) -> f32 {
    if (s.state >> CACHE_STATE_CHANGE_FRAMES_SHIFT) > 1u {
        return 0.0;
    }
    return cache_voxel_change(s);
}

// `state` with its change set to `change` (0 to 1, rounded down to a step: a change below one
// step, such as the tail of one passed on through several bounces, ends), measured this frame.
fn cache_state_with_change(state: u32, change: f32) -> u32 {
    let steps = u32(floor(clamp(change, 0.0, 1.0) * f32(CACHE_CHANGE_LEVELS)));
    let keep = (1u << CACHE_STATE_CHANGE_SHIFT) - 1u;
    return (state & keep) | (steps << CACHE_STATE_CHANGE_SHIFT);
}

// Irradiance (direct + indirect) that side `side` of voxel `v` receives.
fn cache_side_irradiance(v: VoxelRef, side: u32) -> vec3<f32> {
    let slot = cache_side_slot(v, side);
    return unpack_rgb9e5(cache_direct[slot]) + unpack_rgb9e5(cache_indirect[slot]);
}

// Outgoing radiance of side `side` of voxel `v` (a Lambertian surface of the voxel's diffuse
// albedo), plus the voxel's emission when `with_emission`.
fn cache_side_radiance(v: VoxelRef, side: u32, with_emission: bool) -> vec3<f32> {
    let s = cache_voxels[cache_voxel_index(v)];
    var radiance = cache_voxel_albedo(s) * CACHE_INV_PI * cache_side_irradiance(v, side);
    if with_emission {
        radiance += cache_voxel_emission(s);
    }
    return radiance;
}

// What the cache's lighting passes (`cache/inject.wgsl`, `cache/propagate.wgsl`,
// `cache/propagate_resolve.wgsl`) share: their uniforms, the list of bricks scheduled this frame,
// the propagation's scratch and the point a voxel side is lit at. Mirrors `gi_cache::lighting`;
// a test checks the struct layouts.
//
// Bind group 0 of all three passes (`gi_cache::CacheLighting`):
//   binding 0: `lighting` uniform LightingUniforms
//   bindings 1-7: the scene (`gi::scene`, `gi_gpu::GpuScene::buffers`): triangles, materials,
//              textures, texels, the emitter table, selection probabilities, punctual lights
//   binding 8: `scheduled_bricks` array<ScheduledBrick>, one workgroup each
//   binding 9: `propagate_scratch` array<u32>, per scheduled brick * 128 + voxel bit * 2 + side:
//              the side's new RGB9E5 indirect irradiance, written by `cache/propagate` and
//              copied into `cache_indirect` by `cache/propagate_resolve`
#define_import_path gi::cache::lighting

#import gi::lights::Sky

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
}

// Mirror of `gi_cache::lighting::GpuScheduledBrick`: a brick whose lighting is updated.
struct ScheduledBrick {
    // World brick coordinate at `level`.
    brick: vec3<i32>,
    level: u32,
    // Pool ID.
    brick_id: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

@group(0) @binding(0) var<uniform> lighting: LightingUniforms;
@group(0) @binding(8) var<storage, read> scheduled_bricks: array<ScheduledBrick>;
@group(0) @binding(9) var<storage, read_write> propagate_scratch: array<u32>;

// Index in `propagate_scratch` of side `side` of voxel `bit` of the `scheduled`-th brick.
fn propagate_scratch_slot(scheduled: u32, bit: u32, side: u32) -> u32 {
    return (scheduled * 64u + bit) * 2u + side;
}

// Age of a voxel after this frame's propagation: one update older, at most `max_age`. Both
// `cache/propagate` (for the accumulation weight) and `cache/propagate_resolve` (to store it)
// compute it from the same unchanged state.
fn propagated_age(age: u32) -> u32 {
    return min(age + 1u, lighting.max_age);
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

// What the cache's lighting passes (`cache/inject.wgsl`, `cache/propagate.wgsl`) share: their
// uniforms, the list of bricks scheduled this frame and the geometry of a visible voxel face.
// Mirrors `gi_cache::lighting`; a test checks the struct layouts.
//
// Bind group 0 of both passes (`gi_cache::CacheLighting`):
//   binding 0: `lighting` uniform LightingUniforms
//   bindings 1-7: the scene (`gi::scene`, `gi_gpu::GpuScene::buffers`): triangles, materials,
//              textures, texels, the emitter table, selection probabilities, punctual lights
//   binding 8: `scheduled_bricks` array<ScheduledBrick>, one workgroup each
#define_import_path gi::cache::lighting

#import gi::lights::Sky
#import gi::cache::data::{CACHE_NO_BRICK, cache_face_direction, cache_voxel_at}

// A visible face's normal keeps the voxel normal's sign unless the normal points away from the
// face by more than this cosine: a normal perpendicular to the face (a floor's side faces) keeps
// its own side, so packing noise in the normal cannot flip a floor's edge into a ceiling.
const FACE_PERPENDICULAR_COS: f32 = 1e-3;

// Mirror of `gi_cache::lighting::GpuLightingUniforms`.
struct LightingUniforms {
    sky: Sky,
    // Entries of `scheduled_bricks` this frame (= workgroups dispatched).
    brick_count: u32,
    // Punctual lights in `lights`.
    light_count: u32,
    // `CacheConfig::gather_rays_per_face`.
    rays_per_face: u32,
    // `CacheConfig::max_age`.
    max_age: u32,
    // Lighting updates so far: the sample index of every face's random sequence.
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

// True when face `face` of world voxel `voxel` at `level` can be seen: its neighbour across the
// face is empty (or outside the level's window). A face between two occupied voxels is never
// seen and is not lit.
fn face_is_visible(level: u32, voxel: vec3<i32>, face: u32) -> bool {
    let neighbour = voxel + vec3<i32>(cache_face_direction(face));
    return cache_voxel_at(level, neighbour).brick_id == CACHE_NO_BRICK;
}

// The normal of the surface a face's irradiance is for: the voxel normal `n` flipped towards the
// face's side (the contract of `cache_direct` / `cache_indirect`).
fn face_normal(n: vec3<f32>, face: u32) -> vec3<f32> {
    return select(n, -n, dot(n, cache_face_direction(face)) < -FACE_PERPENDICULAR_COS);
}

// The point just outside the center of face `face` of a voxel of edge `size` centered at
// `center`: beyond the voxel's surface on the face's side, by a margin that escapes f32 rounding.
fn face_point(center: vec3<f32>, size: f32, face: u32) -> vec3<f32> {
    let a = abs(center);
    let margin = max(1e-3 * size, 1e-4 * (1.0 + max(max(a.x, a.y), a.z)));
    return center + cache_face_direction(face) * (0.5 * size + margin);
}

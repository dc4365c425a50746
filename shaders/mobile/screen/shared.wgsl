// What the mobile tier's screen-space passes (HSGI, GDC 2023, "Mobile Solution"; SmartGI,
// SIGGRAPH 2024, "Screen Probes") share: their uniforms, the screen probes and the storage
// buffers of their bind group 0, declared once, and the helpers that several of them call. One
// pass per file of `shaders/mobile/screen/`, in frame order: `lite_pack.wgsl` (the lite
// G-buffer, `gi::mobile::lite`), `reproject.wgsl` (SmartGI mode), `place.wgsl`, `trace.wgsl`,
// `gather.wgsl`, `compose.wgsl`.
//
// Hemisphere map of a probe: texel (i, j) of the 4 x 4 map covers [i, i+1] x [j, j+1] / 4 of
// the unit square, which the hemisphere octahedral map takes to the probe's hemisphere (the
// square rotated 45 degrees onto the diamond |x| + |y| <= 1, lifted to z = 1 - |x| - |y| and
// normalized). A ray drawn uniformly in its texel has the solid-angle density
// pdf = |P|^3 / 2 at the unnormalized point P = (x, y, z) (the plane x + y + z = 1 seen from
// the origin: dOmega = dx dy / |P|^3; the diamond has area 2), so each texel stores
// L / pdf and the irradiance of any normal n in the probe's hemisphere is the unbiased
// stratified estimate E(n) = 1/16 sum_k L_k max(0, n . w_k) / pdf_k.
//
// Bind group 0: `uniforms` at binding 0, then the buffers of `ScreenGroup`
// (crates/gi-tiers/src/mobile/screen.rs) from binding 1, each pass importing the ones it uses;
// a unit test checks the names and accesses against the Rust list. 1: the probe volume
// (`gi::mobile::volume`); 2: the brick cache (`gi::cache::data`).
#define_import_path gi::mobile::screen

#import gi::camera::{Camera, camera_ray}
#import gi::sky::Sky
#import gi::packing::{oct_encode, oct_decode}

const PROBE_TEXELS: u32 = 16u;
const SLOTS_PER_TILE: u32 = 2u;
const FAR: f32 = 3.0e38;
const INFINITY_BITS: u32 = 0x7f800000u;

// Mirror of `gi_tiers::mobile::screen::ScreenUniforms`, 256 bytes.
struct ScreenUniforms {
    camera: Camera,
    previous_camera: Camera,
    sky: Sky,
    size_px: vec2<u32>,
    half_px: vec2<u32>,
    tiles: vec2<u32>,
    tile_px: u32,
    frame_index: u32,
    seed: vec2<u32>,
    max_age: u32,
    // 0: no usable history (first frame, new size); 1: history_in holds the previous frame.
    history_valid: u32,
    plane_tolerance: f32,
    normal_cos: f32,
    ray_offset_voxels: f32,
    // FLAG_SMARTGI: SmartGI (2 x 2 groups, reprojection), else HSGI (every tile traced every
    // frame); FLAG_MATERIAL_OCCLUSION: the occlusion map darkens the gathered diffuse light.
    flags: u32,
    // The brick cache's `CacheConfig::change_gain`: how strongly the change the cache measured
    // at a pixel's surface shortens its temporal history (`mobile/gather`); 0: not at all.
    change_gain: f32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

const FLAG_SMARTGI: u32 = 1u;
const FLAG_MATERIAL_OCCLUSION: u32 = 2u;
// `gbuffer_blend_layer` holds the blended layer in front of each pixel.
const FLAG_BLEND_LAYER: u32 = 4u;
// The lights changed lately and the probe volume still holds their old light: the gather reads
// the cache's surfels where it would read the volume.
const FLAG_VOLUME_STALE: u32 = 8u;
// `ScreenProbe.flags`: bit 0 the probe sits on a dynamic object; bit 1 it was reprojected from
// the previous frame, whose slot is in bits 8 and up.
const PROBE_DYNAMIC: u32 = 1u;
const PROBE_REPROJECTED: u32 = 2u;
const PROBE_SOURCE_SHIFT: u32 = 8u;
// Bits of a claim's key that hold the history slot (the rest rank the claim).
const CLAIM_SLOT_BITS: u32 = 20u;

// A screen probe: where it sits and which way its hemisphere faces; `depth` is its distance
// to the camera, 0 when the slot holds no probe this frame. 32 bytes.
struct ScreenProbe {
    position: vec3<f32>,
    depth: f32,
    normal: vec3<f32>,
    flags: u32,
}

// Named `uniforms`, not `u`: the passes import it, and naga_oil would rewrite the `u` suffix
// of integer literals into an imported `u`.
@group(0) @binding(0) var<uniform> uniforms: ScreenUniforms;
// The G-buffer (`gi_gpu::GBuffer`), read only.
@group(0) @binding(1) var<storage, read> gbuffer_depth: array<f32>;
@group(0) @binding(2) var<storage, read> gbuffer_normal: array<u32>;
@group(0) @binding(3) var<storage, read> gbuffer_base_color: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> gbuffer_metallic_roughness: array<vec2<f32>>;
@group(0) @binding(5) var<storage, read> gbuffer_triangle: array<u32>;
@group(0) @binding(6) var<storage, read> gbuffer_motion: array<vec2<f32>>;
// One bit per frame triangle: set when the triangle's node is moved by an animation.
@group(0) @binding(7) var<storage, read> dynamic_triangles: array<u32>;
// The lite G-buffer, one u32 per pixel (`gi::mobile::lite`).
@group(0) @binding(8) var<storage, read_write> lite: array<u32>;
// SLOTS_PER_TILE probes per tile: the regular probe, then the extra one of marked tiles.
@group(0) @binding(9) var<storage, read_write> probes: array<ScreenProbe>;
// PROBE_TEXELS texels per probe slot: x = RGB9E5 of L / pdf, y = the ray's direction and the
// change the cache measured at its hit (`pack_probe_ray`).
@group(0) @binding(10) var<storage, read_write> probe_radiance: array<vec2<u32>>;
// The previous frame's probes and texels (ping-pong with the two above).
@group(0) @binding(16) var<storage, read> probes_prev: array<ScreenProbe>;
@group(0) @binding(17) var<storage, read> probe_radiance_prev: array<vec2<u32>>;
// Per tile, the best claim of a reprojected history probe this frame (0: none): the bitwise
// complement of (rank << CLAIM_SLOT_BITS | slot), so atomicMax keeps the lowest rank.
@group(0) @binding(18) var<storage, read_write> tile_claims: array<atomic<u32>>;
// Per tile, 1 when a gather pixel of the tile found no usable probe this frame.
@group(0) @binding(11) var<storage, read_write> tile_marks: array<atomic<u32>>;
// Half-resolution irradiance of the previous and this frame: x = RGB9E5 irradiance,
// y = the signed depth's f32 bits with the age (0-255) in the low 8 bits: depth is the
// distance to that frame's camera (relative precision 2^-15), negative for dynamic pixels;
// age 0 marks sky and empty entries.
@group(0) @binding(12) var<storage, read> history_in: array<vec2<u32>>;
@group(0) @binding(13) var<storage, read_write> history_out: array<vec2<u32>>;
// The direct light of this frame (`direct.mean` of the direct-light accumulation).
@group(0) @binding(14) var<storage, read> direct_mean: array<vec4<f32>>;
// The final image.
@group(0) @binding(15) var<storage, read_write> output: array<vec4<f32>>;
// The G-buffer's emission and, in w, the material's occlusion factor.
@group(0) @binding(19) var<storage, read> gbuffer_emissive: array<vec4<f32>>;
// With FLAG_BLEND_LAYER: the nearest blended surface in front of each pixel (`gbuffer.blend_layer`).
@group(0) @binding(20) var<storage, read> gbuffer_blend_layer: array<vec4<f32>>;

fn is_sky(depth: f32) -> bool {
    return bitcast<u32>(depth) == INFINITY_BITS || !(depth < FAR);
}

fn pixel_ray(camera: Camera, pixel: vec2<u32>) -> vec3<f32> {
    return camera_ray(camera, (vec2<f32>(pixel) + 0.5) / vec2<f32>(uniforms.size_px));
}

// The tile of 2 x 2 group `group` that gets a freshly traced probe this frame: each tile of the
// group in turn, the turn offset by a hash of the group so neighbouring groups differ.
fn fresh_tile(group: vec2<u32>) -> vec2<u32> {
    let k = (uniforms.frame_index + group.x * 7u + group.y * 13u) & 3u;
    return min(group * 2u + vec2(k & 1u, k >> 1u), uniforms.tiles - 1u);
}

fn is_fresh(tile_xy: vec2<u32>) -> bool {
    return (uniforms.flags & FLAG_SMARTGI) == 0u || all(fresh_tile(tile_xy / 2u) == tile_xy);
}

// Steps of a probe texel's direction coordinates (12 bits each; an angular step below 0.05
// degrees) and of its hit's change (8 bits).
const PROBE_RAY_DIR_STEPS: f32 = 4095.0;
const PROBE_RAY_CHANGE_STEPS: f32 = 255.0;

// A probe texel's unit ray direction (octahedral, two 12-bit unorms in bits 8 and up) and the
// change the brick cache just measured in the light the ray found (`cache_voxel_recent_change`
// of the hit voxel, 0 to 1; 0 for the sky and for copied texels) in bits 0 to 7.
fn pack_probe_ray(dir: vec3<f32>, change: f32) -> u32 {
    let e = vec2<u32>(round((oct_encode(dir) * 0.5 + 0.5) * PROBE_RAY_DIR_STEPS));
    let c = u32(round(clamp(change, 0.0, 1.0) * PROBE_RAY_CHANGE_STEPS));
    return (e.x << 20u) | (e.y << 8u) | c;
}

fn probe_ray_dir(bits: u32) -> vec3<f32> {
    let e = vec2<f32>(vec2(bits >> 20u, (bits >> 8u) & 0xfffu)) / PROBE_RAY_DIR_STEPS;
    return oct_decode(e * 2.0 - 1.0);
}

fn probe_ray_change(bits: u32) -> f32 {
    return f32(bits & 0xffu) / PROBE_RAY_CHANGE_STEPS;
}

// `bits` with its change cleared: a texel copied into a later frame brings no new change.
fn probe_ray_unchanged(bits: u32) -> u32 {
    return bits & ~0xffu;
}

// (age, signed depth) of a history entry.
fn history_age_depth(entry: vec2<u32>) -> vec2<f32> {
    return vec2(f32(entry.y & 0xffu), bitcast<f32>(entry.y & 0xffffff00u));
}

// The full-resolution pixel a half-resolution pixel samples.
fn half_source(half: vec2<u32>) -> vec2<u32> {
    return min(half * 2u, uniforms.size_px - 1u);
}

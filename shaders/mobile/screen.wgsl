// The mobile tier's screen-space passes (HSGI, GDC 2023, "Mobile Solution"; SmartGI,
// SIGGRAPH 2024, "Screen Probes"), one entry point each, in frame order:
//
//   lite     pack the G-buffer into the lite deferred G-buffer (`gi::mobile::lite`): diffuse
//            color, dynamic mask and an 8-bit dithered normal, one u32 per pixel;
//   reproject (SmartGI mode) every probe of the previous frame is projected into this frame;
//            where it is still visible (depth and normal agree with the G-buffer) it claims the
//            tile it lands in, and the geometrically closest claim (nearest the tile's center
//            on screen) wins;
//   place    one probe per screen tile (plus one more in tiles the previous gather marked):
//            HSGI mode places every tile's probe afresh at a jittered pixel of the tile; SmartGI
//            mode does so for one tile of each 2 x 2 group per frame (rotating) and gives the
//            other three the history probe that won their claim, or nothing (a hole);
//   trace    each fresh probe's 4 x 4-texel hemisphere map: one ray per texel, jittered inside
//            the texel, traced through the brick cache (visibility rays instead of VSM); a
//            reprojected probe copies its history texels;
//   gather   half resolution: irradiance from the probes of the four nearest tiles with depth
//            (tangent plane) and normal tests; in SmartGI mode holes fall back to the next
//            "mip", the fresh probes of the four nearest 2 x 2 groups; the probe volume serves
//            dynamic pixels and pixels where every probe fails (which marks the tile for an
//            extra probe next frame); then a
//            temporal filter: reprojection through the motion vectors, a depth test, history
//            of dynamic pixels discarded, age-based convergence;
//   compose  full resolution: bilateral upsample of the half-resolution irradiance (depth and
//            normal weights) and the final image: direct light + (diffuse albedo + a split-sum
//            specular albedo) x irradiance / pi.
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
// Bind group 0: this file's buffers; 1: the probe volume (`gi::mobile::volume`); 2: the brick
// cache (`gi::cache::data`).

#import gi::camera::{Camera, camera_ray, camera_project}
#import gi::lights::{Sky, sky_radiance}
#import gi::packing::{pack_rgb9e5, unpack_rgb9e5, pack_unit_vector, unpack_unit_vector}
#import gi::sampling::{Sampler, sampler_new, sampler_next_2d, frame_from_normal, frame_to_world}
#import gi::math::INV_PI
#import gi::brdf::{gbuffer_brdf, brdf_diffuse_albedo, brdf_split_sum_albedos}
#import gi::mobile::lite::{lite_encode, lite_diffuse, lite_is_dynamic, lite_normal}
#import gi::mobile::volume::volume_irradiance
#import gi::cache::data::{cache, cache_level_of_point}
#import gi::cache::trace::{cache_hit_radiance, cache_irradiance, cache_blend_layer_gi}
#import gi::cache::trace_shared::{cache_trace_shared, CACHE_LANES}

const PROBE_TEXELS: u32 = 16u;
const SLOTS_PER_TILE: u32 = 2u;
const FAR: f32 = 3.0e38;
const INFINITY_BITS: u32 = 0x7f800000u;
// Relative depth difference a reprojected history sample may have from the distance of the
// current surface point to the previous camera (nearest-pixel reprojection on a sloped
// surface differs by the slope times one half-resolution pixel).
const HISTORY_DEPTH_TOLERANCE: f32 = 0.1;
// Sharpness of the upsample's normal weight (cos^k) and width of its depth weight, relative
// to the pixel's depth.
const UPSAMPLE_NORMAL_POWER: f32 = 8.0;
const UPSAMPLE_DEPTH_WIDTH: f32 = 0.02;
// Jittered pixels a probe tries before its tile counts as sky.
const PLACE_TRIES: u32 = 4u;

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
}

const FLAG_SMARTGI: u32 = 1u;
const FLAG_MATERIAL_OCCLUSION: u32 = 2u;
// `gbuffer_blend_layer` holds the blended layer in front of each pixel.
const FLAG_BLEND_LAYER: u32 = 4u;
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

@group(0) @binding(0) var<uniform> u: ScreenUniforms;
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
// PROBE_TEXELS texels per probe slot: x = RGB9E5 of L / pdf, y = the packed ray direction.
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
    return camera_ray(camera, (vec2<f32>(pixel) + 0.5) / vec2<f32>(u.size_px));
}

// ---------------------------------------------------------------------------------------------
// lite
// ---------------------------------------------------------------------------------------------

@compute @workgroup_size(8, 8)
fn lite_pack(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= u.size_px.x || id.y >= u.size_px.y {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    if is_sky(gbuffer_depth[pixel]) {
        lite[pixel] = 0u;
        return;
    }
    let triangle = gbuffer_triangle[pixel];
    let dynamic = ((dynamic_triangles[triangle >> 5u] >> (triangle & 31u)) & 1u) != 0u;
    let brdf = gbuffer_brdf(gbuffer_base_color[pixel], gbuffer_metallic_roughness[pixel]);
    let n = unpack_unit_vector(gbuffer_normal[pixel]);
    let ray = pixel_ray(u.camera, id.xy);
    let diffuse = brdf_diffuse_albedo(brdf, max(dot(n, -ray), 0.0));
    var sampler = sampler_new(u.seed, pixel, u.frame_index);
    let dither = sampler_next_2d(&sampler) - 0.5;
    lite[pixel] = lite_encode(diffuse, dynamic, n, u.camera, ray, dither);
}

// ---------------------------------------------------------------------------------------------
// place
// ---------------------------------------------------------------------------------------------

// The tile of 2 x 2 group `group` that gets a freshly traced probe this frame: each tile of the
// group in turn, the turn offset by a hash of the group so neighbouring groups differ.
fn fresh_tile(group: vec2<u32>) -> vec2<u32> {
    let k = (u.frame_index + group.x * 7u + group.y * 13u) & 3u;
    return min(group * 2u + vec2(k & 1u, k >> 1u), u.tiles - 1u);
}

fn is_fresh(tile_xy: vec2<u32>) -> bool {
    return (u.flags & FLAG_SMARTGI) == 0u || all(fresh_tile(tile_xy / 2u) == tile_xy);
}

@compute @workgroup_size(64)
fn reproject(@builtin(global_invocation_id) id: vec3<u32>) {
    let slot = id.x;
    if slot >= u.tiles.x * u.tiles.y * SLOTS_PER_TILE || u.history_valid == 0u {
        return;
    }
    let probe = probes_prev[slot];
    if probe.depth <= 0.0 || (probe.flags & PROBE_DYNAMIC) != 0u {
        return;
    }
    let screen = camera_project(u.camera, probe.position - u.camera.position, u.size_px);
    if screen.z == 0.0 || any(screen.xy < vec2(0.0)) || any(screen.xy >= vec2<f32>(u.size_px)) {
        return;
    }
    let pixel_xy = vec2<u32>(screen.xy);
    let pixel = pixel_xy.y * u.size_px.x + pixel_xy.x;
    let depth = gbuffer_depth[pixel];
    let distance_now = distance(probe.position, u.camera.position);
    if is_sky(depth) || abs(depth - distance_now) > u.plane_tolerance * depth {
        return;
    }
    let dir = pixel_ray(u.camera, pixel_xy);
    if dot(lite_normal(lite[pixel], u.camera, dir), probe.normal) < u.normal_cos {
        return;
    }
    let tile_xy = min(pixel_xy / u.tile_px, u.tiles - 1u);
    if is_fresh(tile_xy) {
        return;
    }
    let center = (vec2<f32>(tile_xy) + 0.5) * f32(u.tile_px);
    let rank = u32(clamp(length(screen.xy - center) / f32(u.tile_px), 0.0, 1.0) * 4095.0);
    let key = (rank << CLAIM_SLOT_BITS) | slot;
    atomicMax(&tile_claims[tile_xy.y * u.tiles.x + tile_xy.x], ~key);
}

@compute @workgroup_size(64)
fn place(@builtin(global_invocation_id) id: vec3<u32>) {
    let tile_count = u.tiles.x * u.tiles.y;
    let slot = id.x;
    if slot >= tile_count * SLOTS_PER_TILE {
        return;
    }
    let tile = slot / SLOTS_PER_TILE;
    let tile_xy = vec2(tile % u.tiles.x, tile / u.tiles.x);
    var probe = ScreenProbe(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0u);
    if slot % SLOTS_PER_TILE == 1u {
        // The extra probe: only for tiles the previous gather marked; the mark is consumed.
        if atomicExchange(&tile_marks[tile], 0u) == 0u {
            probes[slot] = probe;
            return;
        }
    } else {
        // The claim is consumed whatever happens, so the next frame starts with none.
        let claim = atomicExchange(&tile_claims[tile], 0u);
        if !is_fresh(tile_xy) {
            if claim != 0u {
                let source = (~claim) & ((1u << CLAIM_SLOT_BITS) - 1u);
                probe = probes_prev[source];
                probe.depth = distance(probe.position, u.camera.position);
                probe.flags = PROBE_REPROJECTED | (source << PROBE_SOURCE_SHIFT);
            }
            probes[slot] = probe;
            return;
        }
    }
    let origin = tile_xy * u.tile_px;
    let extent = min(origin + vec2(u.tile_px), u.size_px) - origin;
    var sampler = sampler_new(u.seed ^ vec2(0x9e3779b9u, 0u), slot, u.frame_index);
    for (var attempt = 0u; attempt < PLACE_TRIES; attempt++) {
        let jitter = sampler_next_2d(&sampler);
        let pixel_xy = origin + min(vec2<u32>(jitter * vec2<f32>(extent)), extent - 1u);
        let pixel = pixel_xy.y * u.size_px.x + pixel_xy.x;
        let depth = gbuffer_depth[pixel];
        if is_sky(depth) {
            continue;
        }
        let dir = pixel_ray(u.camera, pixel_xy);
        probe.position = u.camera.position + depth * dir;
        probe.normal = lite_normal(lite[pixel], u.camera, dir);
        probe.depth = depth;
        probe.flags = select(0u, PROBE_DYNAMIC, lite_is_dynamic(lite[pixel]));
        break;
    }
    probes[slot] = probe;
}

// ---------------------------------------------------------------------------------------------
// trace
// ---------------------------------------------------------------------------------------------

// The direction of hemisphere-map point `s` in [-1, 1]^2 in the probe's local frame (z up),
// unnormalized: the point P of the octahedron face whose density is |P|^3 / 2.
fn hemisphere_point(s: vec2<f32>) -> vec3<f32> {
    let p = vec2(s.x + s.y, s.x - s.y) * 0.5;
    return vec3(p, 1.0 - abs(p.x) - abs(p.y));
}

// One probe texel's ray per CACHE_LANES invocations (`gi::cache::trace_shared`): the pass
// traces a few thousand rays, too few to hide the cache's memory latency one ray per thread.
@compute @workgroup_size(64)
fn trace(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
) {
    // Workgroups come in rows of at most 65535.
    let out = (id.x + id.y * groups.x * 64u) / CACHE_LANES;
    let slot = out / PROBE_TEXELS;
    let texel = out % PROBE_TEXELS;
    let valid = slot < u.tiles.x * u.tiles.y * SLOTS_PER_TILE;
    var probe = ScreenProbe(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0u);
    if valid {
        probe = probes[slot];
    }
    let traced = valid && probe.depth > 0.0 && (probe.flags & PROBE_REPROJECTED) == 0u;
    var sampler = sampler_new(u.seed ^ vec2(0x85ebca6bu, 0u), out, u.frame_index);
    let cell = vec2<f32>(vec2(texel % 4u, texel / 4u));
    let s = (cell + sampler_next_2d(&sampler)) * 0.5 - 1.0;
    let point = hemisphere_point(s);
    let length_p = length(point);
    let pdf = 0.5 * length_p * length_p * length_p;
    let frame = frame_from_normal(probe.normal);
    let dir = frame_to_world(frame, point / length_p);
    let level = min(cache_level_of_point(probe.position), cache.level_count - 1u);
    let offset = u.ray_offset_voxels * cache.levels[level].voxel_size_m;
    let shared_hit = cache_trace_shared(probe.position + probe.normal * offset, dir, FAR, traced, local_index);
    if !valid || !shared_hit.owner {
        return;
    }
    if probe.depth <= 0.0 {
        probe_radiance[out] = vec2(0u);
    } else if (probe.flags & PROBE_REPROJECTED) != 0u {
        let source = probe.flags >> PROBE_SOURCE_SHIFT;
        probe_radiance[out] = probe_radiance_prev[source * PROBE_TEXELS + texel];
    } else {
        var radiance: vec3<f32>;
        if shared_hit.hit.hit {
            radiance = cache_hit_radiance(shared_hit.hit, true);
        } else {
            radiance = sky_radiance(u.sky, dir);
        }
        probe_radiance[out] = vec2(pack_rgb9e5(radiance / pdf), pack_unit_vector(dir));
    }
}

// ---------------------------------------------------------------------------------------------
// gather
// ---------------------------------------------------------------------------------------------

// Irradiance of normal `n` from the hemisphere map of probe slot `slot`.
fn probe_irradiance(slot: u32, n: vec3<f32>) -> vec3<f32> {
    var sum = vec3(0.0);
    for (var texel = 0u; texel < PROBE_TEXELS; texel++) {
        let t = probe_radiance[slot * PROBE_TEXELS + texel];
        sum += unpack_rgb9e5(t.x) * max(dot(n, unpack_unit_vector(t.y)), 0.0);
    }
    return sum * (1.0 / f32(PROBE_TEXELS));
}

// Whether probe slot `slot` may light the pixel at `p` (normal `n`, depth `depth`): it holds a
// probe whose tangent plane passes near `p` (depth test) and whose normal agrees (normal test).
fn probe_accepts(slot: u32, p: vec3<f32>, n: vec3<f32>, depth: f32) -> bool {
    let probe = probes[slot];
    if probe.depth <= 0.0 {
        return false;
    }
    let plane = abs(dot(p - probe.position, probe.normal));
    return plane <= u.plane_tolerance * depth && dot(n, probe.normal) >= u.normal_cos;
}

// Irradiance of the pixel `source` (at `p`, normal `n`) interpolated bilinearly from the probes
// of the four cells of `cell` x `cell` tiles around it that pass the tests, with the weight
// found in w (0: none passed). Cell 1 reads every slot of the four tiles; cell 2 (SmartGI's
// mip) reads the regular probe of each group's fresh tile.
fn interpolate_probes(p: vec3<f32>, n: vec3<f32>, depth: f32, source: vec2<u32>, cell: u32) -> vec4<f32> {
    let cells = (u.tiles + cell - 1u) / cell;
    let q = (vec2<f32>(source) + 0.5) / f32(u.tile_px * cell) - 0.5;
    let base = vec2<i32>(floor(q));
    let f = q - floor(q);
    var sum = vec3(0.0);
    var weight = 0.0;
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let cell_xy = vec2<u32>(clamp(base + vec2<i32>(c), vec2(0), vec2<i32>(cells) - 1));
        let w2 = select(1.0 - f, f, c == vec2(1u));
        let bilinear = max(w2.x * w2.y, 1e-3);
        var tile_xy = cell_xy;
        var slots = SLOTS_PER_TILE;
        if cell > 1u {
            tile_xy = fresh_tile(cell_xy);
            slots = 1u;
        }
        let tile = tile_xy.y * u.tiles.x + tile_xy.x;
        for (var s = 0u; s < slots; s++) {
            let slot = tile * SLOTS_PER_TILE + s;
            if probe_accepts(slot, p, n, depth) {
                sum += bilinear * probe_irradiance(slot, n);
                weight += bilinear;
            }
        }
    }
    if weight > 0.0 {
        return vec4(sum / weight, weight);
    }
    return vec4(0.0);
}

// Irradiance from the world-space structures: the probe volume, or the cache's own surfels
// where no probe covers the point.
fn world_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let volume = volume_irradiance(p, n);
    if volume.w > 0.0 {
        return volume.xyz;
    }
    return cache_irradiance(p, n).xyz;
}

fn history_entry(irradiance: vec3<f32>, age: f32, signed_depth: f32) -> vec2<u32> {
    return vec2(pack_rgb9e5(irradiance), (bitcast<u32>(signed_depth) & 0xffffff00u) | u32(age));
}

// (age, signed depth) of a history entry.
fn history_age_depth(entry: vec2<u32>) -> vec2<f32> {
    return vec2(f32(entry.y & 0xffu), bitcast<f32>(entry.y & 0xffffff00u));
}

// The full-resolution pixel a half-resolution pixel samples.
fn half_source(half: vec2<u32>) -> vec2<u32> {
    return min(half * 2u, u.size_px - 1u);
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= u.half_px.x || id.y >= u.half_px.y {
        return;
    }
    let half_index = id.y * u.half_px.x + id.x;
    let source = half_source(id.xy);
    let pixel = source.y * u.size_px.x + source.x;
    let depth = gbuffer_depth[pixel];
    if is_sky(depth) {
        history_out[half_index] = vec2(0u);
        return;
    }
    let dir = pixel_ray(u.camera, source);
    let p = u.camera.position + depth * dir;
    let bits = lite[pixel];
    let n = lite_normal(bits, u.camera, dir);
    if lite_is_dynamic(bits) {
        // Dynamic pixels read the probe volume directly and keep no history of their own.
        history_out[half_index] = history_entry(world_irradiance(p, n), 1.0, -depth);
        return;
    }

    // Screen probes of the four tiles whose centers surround the pixel; in SmartGI mode, where
    // they all fail, the fresh probes of the four nearest groups (the next mip).
    var found = interpolate_probes(p, n, depth, source, 1u);
    if found.w <= 0.0 && (u.flags & FLAG_SMARTGI) != 0u {
        found = interpolate_probes(p, n, depth, source, 2u);
    }
    var current: vec3<f32>;
    if found.w > 0.0 {
        current = found.xyz;
    } else {
        let own_tile = min(source / u.tile_px, u.tiles - 1u);
        atomicStore(&tile_marks[own_tile.y * u.tiles.x + own_tile.x], 1u);
        current = world_irradiance(p, n);
    }

    // Temporal filter.
    var age = 1.0;
    var irradiance = current;
    if u.history_valid != 0u {
        let previous = vec2<f32>(source) + 0.5 + gbuffer_motion[pixel];
        let h = vec2<i32>(round((previous - 0.5) * 0.5));
        if all(h >= vec2(0)) && all(h < vec2<i32>(u.half_px)) {
            let entry = history_in[u32(h.y) * u.half_px.x + u32(h.x)];
            let age_depth = history_age_depth(entry);
            let expected = distance(p, u.previous_camera.position);
            // Sky (age 0) and dynamic (negative depth) history is discarded.
            if age_depth.x > 0.0 && age_depth.y > 0.0
                && abs(age_depth.y - expected) < HISTORY_DEPTH_TOLERANCE * expected {
                age = min(age_depth.x + 1.0, f32(u.max_age));
                irradiance = mix(unpack_rgb9e5(entry.x), current, 1.0 / age);
            }
        }
    }
    history_out[half_index] = history_entry(irradiance, age, depth);
}

// ---------------------------------------------------------------------------------------------
// compose
// ---------------------------------------------------------------------------------------------

@compute @workgroup_size(8, 8)
fn compose(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= u.size_px.x || id.y >= u.size_px.y {
        return;
    }
    let pixel = id.y * u.size_px.x + id.x;
    let direct = direct_mean[pixel].xyz;
    let depth = gbuffer_depth[pixel];
    let dir = pixel_ray(u.camera, id.xy);
    if is_sky(depth) {
        var gi = vec3(0.0);
        if (u.flags & FLAG_BLEND_LAYER) != 0u {
            gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], u.camera.position, dir, gi);
        }
        output[pixel] = vec4(direct + gi, 1.0);
        return;
    }
    let bits = lite[pixel];
    let n = lite_normal(bits, u.camera, dir);

    // Bilateral upsample from the four half-resolution samples around the pixel.
    let q = vec2<f32>(id.xy) * 0.5;
    let base = vec2<i32>(floor(q));
    let f = q - floor(q);
    var sum = vec3(0.0);
    var weight = 0.0;
    var plain_sum = vec3(0.0);
    var plain_weight = 0.0;
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let h = vec2<u32>(clamp(base + vec2<i32>(c), vec2(0), vec2<i32>(u.half_px) - 1));
        let entry = history_out[h.y * u.half_px.x + h.x];
        let age_depth = history_age_depth(entry);
        if age_depth.x <= 0.0 {
            continue;
        }
        let w2 = select(1.0 - f, f, c == vec2(1u));
        let bilinear = max(w2.x * w2.y, 1e-3);
        let e = unpack_rgb9e5(entry.x);
        let source = half_source(h);
        let source_n = lite_normal(lite[source.y * u.size_px.x + source.x], u.camera, pixel_ray(u.camera, source));
        let depth_w = exp(-abs(abs(age_depth.y) - depth) / (UPSAMPLE_DEPTH_WIDTH * depth));
        let normal_w = pow(max(dot(n, source_n), 0.0), UPSAMPLE_NORMAL_POWER);
        let w = bilinear * depth_w * normal_w;
        sum += w * e;
        weight += w;
        plain_sum += bilinear * e;
        plain_weight += bilinear;
    }
    var irradiance = vec3(0.0);
    if weight > 1e-4 {
        irradiance = sum / weight;
    } else if plain_weight > 0.0 {
        irradiance = plain_sum / plain_weight;
    }

    let mr = gbuffer_metallic_roughness[pixel];
    let brdf = gbuffer_brdf(gbuffer_base_color[pixel], mr);
    let specular = brdf_split_sum_albedos(brdf, max(dot(n, -dir), 0.0)).specular;
    // The material's occlusion map darkens the gathered diffuse light only.
    var occlusion = 1.0;
    if (u.flags & FLAG_MATERIAL_OCCLUSION) != 0u {
        occlusion = gbuffer_emissive[pixel].w;
    }
    var gi = (lite_diffuse(bits) * occlusion + specular) * irradiance * INV_PI;
    // A blended surface in front (glass) shows its own GI over the GI behind it, by its alpha.
    if (u.flags & FLAG_BLEND_LAYER) != 0u {
        gi = cache_blend_layer_gi(gbuffer_blend_layer[pixel], u.camera.position, dir, gi);
    }
    output[pixel] = vec4(direct + gi, 1.0);
}

// Pass `mobile/probe_place` of the mobile tier's screen-space passes (`gi::mobile::screen`):
// one probe per screen tile (plus one more in tiles the previous gather marked): HSGI mode
// places every tile's probe afresh at a jittered pixel of the tile; SmartGI mode does so for
// one tile of each 2 x 2 group per frame (rotating) and gives the other three the history
// probe that won their claim (`reproject`), or nothing (a hole).
//
// Bind group 0: `gi::mobile::screen`'s.

#import gi::sampling::{sampler_new, sampler_next_2d}
#import gi::mobile::lite::{lite_is_dynamic, lite_normal}
#import gi::mobile::screen::{
    uniforms, ScreenProbe, gbuffer_depth, lite, probes, probes_prev, tile_marks, tile_claims,
    is_sky, pixel_ray, is_fresh, SLOTS_PER_TILE, PROBE_DYNAMIC, PROBE_REPROJECTED,
    PROBE_SOURCE_SHIFT, CLAIM_SLOT_BITS
}

// Jittered pixels a probe tries before its tile counts as sky.
const PLACE_TRIES: u32 = 4u;

@compute @workgroup_size(64)
fn place(@builtin(global_invocation_id) id: vec3<u32>) {
    let tile_count = uniforms.tiles.x * uniforms.tiles.y;
    let slot = id.x;
    if slot >= tile_count * SLOTS_PER_TILE {
        return;
    }
    let tile = slot / SLOTS_PER_TILE;
    let tile_xy = vec2(tile % uniforms.tiles.x, tile / uniforms.tiles.x);
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
                probe.depth = distance(probe.position, uniforms.camera.position);
                probe.flags = PROBE_REPROJECTED | (source << PROBE_SOURCE_SHIFT);
            }
            probes[slot] = probe;
            return;
        }
    }
    let origin = tile_xy * uniforms.tile_px;
    let extent = min(origin + vec2(uniforms.tile_px), uniforms.size_px) - origin;
    var sampler = sampler_new(uniforms.seed ^ vec2(0x9e3779b9u, 0u), slot, uniforms.frame_index);
    for (var attempt = 0u; attempt < PLACE_TRIES; attempt++) {
        let jitter = sampler_next_2d(&sampler);
        let pixel_xy = origin + min(vec2<u32>(jitter * vec2<f32>(extent)), extent - 1u);
        let pixel = pixel_xy.y * uniforms.size_px.x + pixel_xy.x;
        let depth = gbuffer_depth[pixel];
        if is_sky(depth) {
            continue;
        }
        let dir = pixel_ray(uniforms.camera, pixel_xy);
        probe.position = uniforms.camera.position + depth * dir;
        probe.normal = lite_normal(lite[pixel], uniforms.camera, dir);
        probe.depth = depth;
        probe.flags = select(0u, PROBE_DYNAMIC, lite_is_dynamic(lite[pixel]));
        break;
    }
    probes[slot] = probe;
}

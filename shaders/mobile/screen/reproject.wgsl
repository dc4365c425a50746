// Pass `mobile/probe_reproject` (SmartGI mode) of the mobile tier's screen-space passes
// (`gi::mobile::screen`): every probe of the previous frame is projected into this frame;
// where it is still visible (depth and normal agree with the G-buffer) it claims the tile it
// lands in, and the geometrically closest claim (nearest the tile's center on screen) wins.
//
// Bind group 0: `gi::mobile::screen`'s.

#import gi::camera::camera_project
#import gi::mobile::lite::lite_normal
#import gi::mobile::screen::{
    uniforms, gbuffer_depth, lite, probes_prev, tile_claims, is_sky, pixel_ray, is_fresh,
    SLOTS_PER_TILE, PROBE_DYNAMIC, CLAIM_SLOT_BITS
}

@compute @workgroup_size(64)
fn reproject(@builtin(global_invocation_id) id: vec3<u32>) {
    let slot = id.x;
    if slot >= uniforms.tiles.x * uniforms.tiles.y * SLOTS_PER_TILE || uniforms.history_valid == 0u {
        return;
    }
    let probe = probes_prev[slot];
    if probe.depth <= 0.0 || (probe.flags & PROBE_DYNAMIC) != 0u {
        return;
    }
    let screen = camera_project(uniforms.camera, probe.position - uniforms.camera.position, uniforms.size_px);
    if screen.z == 0.0 || any(screen.xy < vec2(0.0)) || any(screen.xy >= vec2<f32>(uniforms.size_px)) {
        return;
    }
    let pixel_xy = vec2<u32>(screen.xy);
    let pixel = pixel_xy.y * uniforms.size_px.x + pixel_xy.x;
    let depth = gbuffer_depth[pixel];
    let distance_now = distance(probe.position, uniforms.camera.position);
    if is_sky(depth) || abs(depth - distance_now) > uniforms.plane_tolerance * depth {
        return;
    }
    let dir = pixel_ray(uniforms.camera, pixel_xy);
    if dot(lite_normal(lite[pixel], uniforms.camera, dir), probe.normal) < uniforms.normal_cos {
        return;
    }
    let tile_xy = min(pixel_xy / uniforms.tile_px, uniforms.tiles - 1u);
    if is_fresh(tile_xy) {
        return;
    }
    let center = (vec2<f32>(tile_xy) + 0.5) * f32(uniforms.tile_px);
    let rank = u32(clamp(length(screen.xy - center) / f32(uniforms.tile_px), 0.0, 1.0) * 4095.0);
    let key = (rank << CLAIM_SLOT_BITS) | slot;
    atomicMax(&tile_claims[tile_xy.y * uniforms.tiles.x + tile_xy.x], ~key);
}

// Pass `mobile/gather` of the mobile tier's screen-space passes (`gi::mobile::screen`), at
// half resolution: irradiance from the probes of the four nearest tiles with depth (tangent
// plane) and normal tests; in SmartGI mode holes fall back to the next "mip", the fresh probes
// of the four nearest 2 x 2 groups; the probe volume serves dynamic pixels and pixels where
// every probe fails (which marks the tile for an extra probe next frame); then a temporal
// filter: reprojection through the motion vectors, a depth test, history of dynamic pixels
// discarded, age-based convergence, shortened where the light the pixel gathers changed
// (A-SVGF's rule, Schied et al. 2018, with the brick cache's measured change as the gradient:
// `alpha = max(1 / age, min(change_gain * change, 1))`, the age lowered to match). The change is
// the larger of the one the cache measured at the pixel's surface and the changed share of the
// probes' directions: each probe texel carries the change the cache measured at its ray's hit,
// so a floor whose own light stays while the wall it sees goes dark drops its history too. In a
// still scene both are exactly 0.
//
// Bind group 0: `gi::mobile::screen`'s; 1: the probe volume (`gi::mobile::volume`); 2: the
// brick cache (`gi::cache::data`).

#import gi::packing::{pack_rgb9e5, unpack_rgb9e5}
#import gi::mobile::lite::{lite_is_dynamic, lite_normal}
#import gi::mobile::volume::volume_irradiance
#import gi::cache::trace::{cache_irradiance, cache_surface_change}
#import gi::mobile::screen::{
    uniforms, gbuffer_depth, gbuffer_motion, lite, probes, probe_radiance, tile_marks,
    history_in, history_out, is_sky, pixel_ray, fresh_tile, history_age_depth, half_source,
    PROBE_TEXELS, SLOTS_PER_TILE, FLAG_SMARTGI, FLAG_VOLUME_STALE, probe_ray_dir, probe_ray_change
}

// Relative depth difference a reprojected history sample may have from the distance of the
// current surface point to the previous camera (nearest-pixel reprojection on a sloped
// surface differs by the slope times one half-resolution pixel).
const HISTORY_DEPTH_TOLERANCE: f32 = 0.1;

// Irradiance of normal `n` from the hemisphere map of probe slot `slot` (rgb), and in w the
// changed share of its lit directions: the texels' hit changes averaged with their cosine
// weights over the texels that bring light or whose light changed (a black sky or wall that
// stayed black is no part of the light). A share of directions rather than of light, since a
// hit's change is relative to the larger of its old and new light and only the new one is at
// hand: a wall switched off sends none.
fn probe_irradiance(slot: u32, n: vec3<f32>) -> vec4<f32> {
    var sum = vec3(0.0);
    var changed = 0.0;
    var weight = 0.0;
    for (var texel = 0u; texel < PROBE_TEXELS; texel++) {
        let t = probe_radiance[slot * PROBE_TEXELS + texel];
        let cosine = max(dot(n, probe_ray_dir(t.y)), 0.0);
        let radiance = unpack_rgb9e5(t.x);
        let change = probe_ray_change(t.y);
        sum += radiance * cosine;
        if any(radiance > vec3(0.0)) || change > 0.0 {
            changed += cosine * change;
            weight += cosine;
        }
    }
    return vec4(sum * (1.0 / f32(PROBE_TEXELS)), select(0.0, changed / weight, weight > 0.0));
}

// What the gather takes from the probes around a pixel: their interpolated irradiance, the sum
// of their weights (0: no probe passed the tests), and their interpolated changed share.
struct ProbeGather {
    irradiance: vec3<f32>,
    weight: f32,
    change: f32,
}

// Whether probe slot `slot` may light the pixel at `p` (normal `n`, depth `depth`): it holds a
// probe whose tangent plane passes near `p` (depth test) and whose normal agrees (normal test).
fn probe_accepts(slot: u32, p: vec3<f32>, n: vec3<f32>, depth: f32) -> bool {
    let probe = probes[slot];
    if probe.depth <= 0.0 {
        return false;
    }
    let plane = abs(dot(p - probe.position, probe.normal));
    return plane <= uniforms.plane_tolerance * depth && dot(n, probe.normal) >= uniforms.normal_cos;
}

// Irradiance of the pixel `source` (at `p`, normal `n`) interpolated bilinearly from the probes
// of the four cells of `cell` x `cell` tiles around it that pass the tests. Cell 1 reads every
// slot of the four tiles; cell 2 (SmartGI's mip) reads the regular probe of each group's fresh
// tile.
fn interpolate_probes(p: vec3<f32>, n: vec3<f32>, depth: f32, source: vec2<u32>, cell: u32) -> ProbeGather {
    let cells = (uniforms.tiles + cell - 1u) / cell;
    let q = (vec2<f32>(source) + 0.5) / f32(uniforms.tile_px * cell) - 0.5;
    let base = vec2<i32>(floor(q));
    let f = q - floor(q);
    var sum = vec4(0.0);
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
        let tile = tile_xy.y * uniforms.tiles.x + tile_xy.x;
        for (var s = 0u; s < slots; s++) {
            let slot = tile * SLOTS_PER_TILE + s;
            if probe_accepts(slot, p, n, depth) {
                sum += bilinear * probe_irradiance(slot, n);
                weight += bilinear;
            }
        }
    }
    if weight > 0.0 {
        return ProbeGather(sum.xyz / weight, weight, sum.w / weight);
    }
    return ProbeGather(vec3(0.0), 0.0, 0.0);
}

// Irradiance from the world-space structures: the probe volume, or the cache's own surfels
// where no probe covers the point or the volume is stale (FLAG_VOLUME_STALE).
fn world_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let volume = volume_irradiance(p, n);
    if volume.w > 0.0 && (uniforms.flags & FLAG_VOLUME_STALE) == 0u {
        return volume.xyz;
    }
    return cache_irradiance(p, n).xyz;
}

fn history_entry(irradiance: vec3<f32>, age: f32, signed_depth: f32) -> vec2<u32> {
    return vec2(pack_rgb9e5(irradiance), (bitcast<u32>(signed_depth) & 0xffffff00u) | u32(age));
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= uniforms.half_px.x || id.y >= uniforms.half_px.y {
        return;
    }
    let half_index = id.y * uniforms.half_px.x + id.x;
    let source = half_source(id.xy);
    let pixel = source.y * uniforms.size_px.x + source.x;
    let depth = gbuffer_depth[pixel];
    if is_sky(depth) {
        history_out[half_index] = vec2(0u);
        return;
    }
    let dir = pixel_ray(uniforms.camera, source);
    let p = uniforms.camera.position + depth * dir;
    let bits = lite[pixel];
    let n = lite_normal(bits, uniforms.camera, dir);
    if lite_is_dynamic(bits) {
        // Dynamic pixels read the probe volume directly and keep no history of their own.
        history_out[half_index] = history_entry(world_irradiance(p, n), 1.0, -depth);
        return;
    }

    // Screen probes of the four tiles whose centers surround the pixel; in SmartGI mode, where
    // they all fail, the fresh probes of the four nearest groups (the next mip).
    var found = interpolate_probes(p, n, depth, source, 1u);
    if found.weight <= 0.0 && (uniforms.flags & FLAG_SMARTGI) != 0u {
        found = interpolate_probes(p, n, depth, source, 2u);
    }
    var current: vec3<f32>;
    if found.weight > 0.0 {
        current = found.irradiance;
    } else {
        let own_tile = min(source / uniforms.tile_px, uniforms.tiles - 1u);
        atomicStore(&tile_marks[own_tile.y * uniforms.tiles.x + own_tile.x], 1u);
        current = world_irradiance(p, n);
    }

    // Temporal filter.
    var age = 1.0;
    var irradiance = current;
    if uniforms.history_valid != 0u {
        let previous = vec2<f32>(source) + 0.5 + gbuffer_motion[pixel];
        let h = vec2<i32>(round((previous - 0.5) * 0.5));
        if all(h >= vec2(0)) && all(h < vec2<i32>(uniforms.half_px)) {
            let entry = history_in[u32(h.y) * uniforms.half_px.x + u32(h.x)];
            let age_depth = history_age_depth(entry);
            let expected = distance(p, uniforms.previous_camera.position);
            // Sky (age 0) and dynamic (negative depth) history is discarded.
            if age_depth.x > 0.0 && age_depth.y > 0.0
                && abs(age_depth.y - expected) < HISTORY_DEPTH_TOLERANCE * expected {
                age = min(age_depth.x + 1.0, f32(uniforms.max_age));
                var alpha = 1.0 / age;
                if uniforms.change_gain > 0.0 {
                    let change = max(cache_surface_change(p, n), found.change);
                    let lambda = min(uniforms.change_gain * change, 1.0);
                    alpha = max(alpha, lambda);
                    age = min(age, max(round(1.0 / alpha), 1.0));
                }
                irradiance = mix(unpack_rgb9e5(entry.x), current, alpha);
            }
        }
    }
    history_out[half_index] = history_entry(irradiance, age, depth);
}

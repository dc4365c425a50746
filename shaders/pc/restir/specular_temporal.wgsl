// Pass `pc/specular_temporal`, the second half of the PC tier's specular reflections after
// HSGI (GDC 2023, "PC / Console Solution", "Specular Reflection"), per pixel: the resolved
// radiance averaged with the history found by the surface's motion vector (depth and normal
// checked), over up to `specular_history` frames, the history first clamped to the resolved
// neighbourhood's mean plus or minus `specular_clamp_sigma` standard deviations. Rough pixels
// go through it too: their input is the lobe ratio of the reused diffuse samples (`shade`), and
// neither the clamp's neighbourhood nor the history mixes the two kinds (a ratio's history
// keeps its kind, `pack_specular_history`). The history's surface is checked against the
// previous frame's G-buffer depth and normal (the denoiser's), so an entry is 5 bytes: the
// value in RGB9E5, rounded stochastically, and a byte with the length and the kind. `compose` multiplies the radiance by the split-sum specular albedo, and the
// irradiance over pi by the ratio.
//
// Two dispatches, so that one history buffer serves both frames: `specular_reproject` copies
// the history each pixel finds in the previous frame (checked, or none) into
// `specular_reprojected`; then `specular_temporal` updates each pixel's history in place
// from its own copy.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), then the buffers of
// `gi::pc::restir::bindings`.

#import gi::packing::{unpack_unit_vector, unpack_color64, unpack_depth, unpack_normal8}
#import gi::pc::restir::bindings::{
    gbuffer_depth, gbuffer_normal, gbuffer_motion, specular_noisy, load_specular_history,
    store_specular_history, specular_reprojected, previous_geometry, kind_of, world_position
}
#import gi::pc::restir::common::{
    uniforms, FLAG_HISTORY, SPECULAR_NONE, SPECULAR_REUSED, pack_specular_history,
    unpack_specular_history
}

// The history pixel `id` finds at its position in the previous frame (the surface's motion
// vector; depth, normal and kind checked), copied into `specular_reprojected`; none (length 0)
// where there is none. Pixels without a specular input are left alone.
@compute @workgroup_size(8, 8)
fn specular_reproject(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    let kind = kind_of(pixel, depth);
    if kind == SPECULAR_NONE {
        return;
    }
    var found = vec2(0u);
    let before = vec2<f32>(id.xy) + 0.5 + gbuffer_motion[pixel];
    let q = vec2<i32>(floor(before));
    if (uniforms.flags & FLAG_HISTORY) != 0u && all(q >= vec2(0)) && all(q < vec2<i32>(uniforms.size_px)) {
        let qi = u32(q.y) * uniforms.size_px.x + u32(q.x);
        let entry = load_specular_history(qi);
        let stored = unpack_specular_history(entry);
        let x = world_position(id.xy, depth);
        let n = unpack_unit_vector(gbuffer_normal[pixel]);
        let expected = distance(x, uniforms.previous_camera.position);
        // Sky's depth is infinite: never the same.
        let previous = previous_geometry[qi];
        let same_depth = abs(unpack_depth(previous) - expected) <= 0.05 * expected;
        let same_normal = dot(unpack_normal8(previous), n) > 0.9;
        // A reused ratio's history is never mixed with radiance, nor the other way round.
        let same_kind = stored.reused == (kind == SPECULAR_REUSED);
        if same_kind && same_depth && same_normal {
            found = entry;
        }
    }
    specular_reprojected[pixel] = found;
}

// The PCG hash (Jarzynski and Olano 2020, "Hash Functions for GPU Rendering", JCGT): 32
// well-mixed bits of `v`.
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

@compute @workgroup_size(8, 8)
fn specular_temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = id.y * uniforms.size_px.x + id.x;
    let depth = gbuffer_depth[pixel];
    let kind = kind_of(pixel, depth);
    if kind == SPECULAR_NONE {
        store_specular_history(pixel, vec2(0u));
        return;
    }
    let current = unpack_color64(specular_noisy[pixel]);

    // The resolved neighbourhood's mean and standard deviation.
    var m1 = vec3(0.0);
    var m2 = vec3(0.0);
    var count = 0.0;
    let p = vec2<i32>(id.xy);
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = p + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(uniforms.size_px)) {
                continue;
            }
            // The input's value is its kind (0: none).
            let v = unpack_color64(specular_noisy[u32(q.y) * uniforms.size_px.x + u32(q.x)]);
            if v.w == f32(kind) {
                m1 += v.xyz;
                m2 += v.xyz * v.xyz;
                count += 1.0;
            }
        }
    }

    // The previous frame's history of this surface, as `specular_reproject` found it.
    var history = vec3(0.0);
    var length = 0.0;
    let stored = unpack_specular_history(specular_reprojected[pixel]);
    if stored.length > 0.0 {
        history = stored.value;
        length = stored.length;
        if count > 0.0 {
            let mean = m1 / count;
            let sigma = sqrt(max(m2 / count - mean * mean, vec3(0.0)));
            let k = uniforms.specular_clamp_sigma;
            history = clamp(history, mean - k * sigma, mean + k * sigma);
        }
    }
    var radiance = history;
    if current.w > 0.0 {
        length = min(length + 1.0, uniforms.specular_history);
        radiance = mix(history, current.xyz, 1.0 / length);
    }
    // The stochastic rounding's offset, new each frame and pixel.
    let u = f32(pcg_hash(pixel ^ pcg_hash(uniforms.frame_index ^ uniforms.seed.x)) >> 8u) / 16777216.0;
    store_specular_history(pixel, pack_specular_history(radiance, length, kind == SPECULAR_REUSED, u));
}

// Pass `pc/gradient`, the PC tier's temporal gradients (Schied, Peters and Dachsbacher 2018,
// "Gradient Estimation for Real-Time Adaptive Temporal Filtering", A-SVGF), two dispatches
// over the strata of `gradient_stratum` x `gradient_stratum` trace pixels, before `trace`:
//
//   gradient         draws again the BVH ray candidate that one trace pixel of the stratum drew
//                    last frame (`trace` kept it, `store_gradient_sample`): the same receiver,
//                    direction and random numbers, so what differs is the scene's light and
//                    geometry, not the noise; stores the change of the luminance it finds
//                    outside the brick cache (`gradient_seen`: the cache's light changes by
//                    its updates' noise every frame) and the larger of the two luminances of
//                    all it finds;
//   gradient_filter  lambda = min(gain * |sum of changes| / sum of the larger luminances, 1)
//                    over the 3 x 3 strata around each: signed changes of noise cancel in the
//                    sum, a change of the light adds up.
//
// The denoiser and the specular history weigh their history by 1 - lambda more than they
// would (`alpha' = mix(alpha, 1, lambda)`, A-SVGF's rule): where the light changed, the image
// follows it within a frame or two; where it did not, the histories keep their length.
//
// Bind group 0: binding 0 `uniforms` (`gi::pc::restir::common`), bindings 1-7 the scene
// (`gi::scene`), then the buffers of `gi::pc::restir::rays`. Group 1: the BVH (`gi::bvh`).
// Group 2: the cache (`gi::cache::data`).

#import gi::math::luminance
#import gi::sampling::{sampler_new, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::packing::{unpack_unit_vector, unpack_rgb9e5}
#import gi::pc::restir::common::{uniforms, FLAG_HISTORY, GRADIENT_NONE, gradient_pick, gradient_seen}
#import gi::pc::restir::rays::{gradient_samples, gradients}
#import gi::pc::restir::candidate::ray_candidate

@compute @workgroup_size(8, 8)
fn gradient(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= uniforms.gradient_strata_x || id.y >= uniforms.gradient_strata_y {
        return;
    }
    let s = id.y * uniforms.gradient_strata_x + id.x;
    var change = vec4(0.0);
    let kept = gradient_samples[s];
    let previous = uniforms.frame_index - 1u;
    // The sample must be last frame's pick of this stratum (a stratum whose pick fell outside
    // the image, or showed the sky, kept none).
    let t = gradient_pick(id.xy, previous);
    let picked = all(t < uniforms.trace_px) && kept.trace_index == t.y * uniforms.trace_px.x + t.x;
    if (uniforms.flags & FLAG_HISTORY) != 0u && kept.trace_index != GRADIENT_NONE
        && kept.frame_index == previous && picked {
        // `trace`'s random numbers of that frame and trace pixel, in its order.
        var sampler = sampler_new(uniforms.seed, kept.trace_index, previous);
        let n = unpack_unit_vector(kept.normal);
        let local = cosine_hemisphere(sampler_next_2d(&sampler));
        let dir = frame_to_world(frame_from_normal(n), local);
        let candidate = ray_candidate(kept.origin, dir, n, &sampler);
        let total = luminance(unpack_rgb9e5(candidate.sample.radiance));
        change = vec4(gradient_seen(candidate.sample) - kept.seen, max(total, kept.total), 0.0, 0.0);
    }
    gradients[s] = change;
}

@compute @workgroup_size(8, 8)
fn gradient_filter(@builtin(global_invocation_id) id: vec3<u32>) {
    let strata = vec2(uniforms.gradient_strata_x, uniforms.gradient_strata_y);
    if any(id.xy >= strata) {
        return;
    }
    var delta = 0.0;
    var total = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = vec2<i32>(id.xy) + vec2(dx, dy);
            if any(q < vec2(0)) || any(q >= vec2<i32>(strata)) {
                continue;
            }
            let g = gradients[u32(q.y) * strata.x + u32(q.x)];
            delta += g.x;
            total += g.y;
        }
    }
    var lambda = 0.0;
    if total > 0.0 {
        lambda = min(uniforms.gradient_gain * abs(delta) / total, 1.0);
    }
    // Only this invocation writes z; its neighbours read x and y.
    gradients[id.y * strata.x + id.x].z = lambda;
}

// Pass `pc/gradient`, the PC tier's temporal gradients (Schied, Peters and Dachsbacher 2018,
// "Gradient Estimation for Real-Time Adaptive Temporal Filtering", A-SVGF), over the strata of
// `gradient_stratum` x `gradient_stratum` trace pixels, in two steps:
//
//   draw_gradient    (`gi::pc::restir::candidate`, in extra workgroups of `trace`'s dispatch)
//                    draws again the BVH ray candidate that one trace pixel of the stratum drew
//                    last frame (`trace` kept it, `store_gradient_sample`): the same receiver,
//                    direction and random numbers, so what differs is the scene's light and
//                    geometry, not the noise; stores the change of the luminance it finds
//                    outside the brick cache (`gradient_seen`: the cache's light changes by
//                    its updates' noise every frame) plus the change of the cache's light
//                    where the cache measured one at the hit (`gi_cache::lighting`'s measured
//                    change: the cache follows a change over a few of its updates, and tells
//                    where it just did), and the larger of the two luminances of all it finds;
//   gradient_filter  (this pass, after `trace`) lambda = min(gain * |sum of changes| / sum of the larger luminances, 1)
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

#import gi::pc::restir::common::uniforms
#import gi::pc::restir::rays::gradients

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

// Pass `pc/denoise_variance` of the PC tier's denoiser (`gi::pc::denoise`):
//
//   variance        SVGF's luminance variance: from the temporal moments once the history is
//                   variance_min_age frames old, else from a 7 x 7 bilateral (depth, normal)
//                   estimate of the moments around the pixel (each history's: its color's
//                   luminance, and the variance it keeps about it plus that squared).
//
// Bind group 0: the frame's inputs, the histories and the filter buffers; group 1: this
// dispatch's uniforms (`gi::pc::denoise`).

#import gi::packing::unpack_unit_vector
#import gi::math::luminance
#import gi::pc::denoise::{
    depth, normal, uniforms, load_history, load_filter, store_filter, is_sky,
    pixel_index, depth_at, depth_derivative, normal_weight, VARIANCE_WRITE
}

@compute @workgroup_size(8, 8)
fn variance(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let center = load_filter(VARIANCE_WRITE - 1u, index);
    let z = depth[index];
    if is_sky(z) {
        store_filter(VARIANCE_WRITE, index, vec4(center.rgb, 0.0));
        return;
    }
    if load_history(index).age >= f32(uniforms.variance_min_age) {
        store_filter(VARIANCE_WRITE, index, center);
        return;
    }
    // Young history: the moments of the 7 x 7 neighbourhood on the same surface.
    let n = unpack_unit_vector(normal[index]);
    let phi_depth = uniforms.depth_sigma * depth_derivative(pixel, z);
    var sum = vec2(0.0);
    var weight_sum = 0.0;
    for (var dy = -3; dy <= 3; dy++) {
        for (var dx = -3; dx <= 3; dx++) {
            let q = pixel + vec2(dx, dy);
            let q_depth = depth_at(q);
            if is_sky(q_depth) {
                continue;
            }
            let qi = pixel_index(q);
            let distance_px = length(vec2<f32>(vec2(dx, dy)));
            let w_depth = abs(q_depth - z) / (phi_depth * max(distance_px, 1.0));
            let w = normal_weight(n, unpack_unit_vector(normal[qi]), uniforms.normal_power) * exp(-w_depth);
            let h = load_history(qi);
            let mean = luminance(h.rgb);
            sum += w * vec2(mean, h.variance + mean * mean);
            weight_sum += w;
        }
    }
    // The center has weight 1, so weight_sum >= 1.
    let m = sum / weight_sum;
    store_filter(VARIANCE_WRITE, index, vec4(center.rgb, max(m.y - m.x * m.x, 0.0)));
}

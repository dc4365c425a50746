// Pass `pc/denoise_atrous` of the PC tier's denoiser (`gi::pc::denoise`), once per iteration:
//
//   atrous          one a-trous iteration (5 x 5 B3-spline taps `step_px` apart) with SVGF's
//                   normal, depth and luminance edge-stopping weights; the variance is
//                   filtered with the squared weights. With `feedback` the first iteration
//                   also writes the color of the next frame's long history.
//   atrous_3x3      the same with 3 x 3 taps of the linear B-spline (1/4, 1/2, 1/4): 9 taps
//                   instead of 25, each iteration reaching half as far
//                   (`DenoiseConfig::atrous_kernel`).
// Both weigh luminance by the center's variance prefiltered over its 3 x 3 neighbours (SVGF),
// read from a tile of the workgroup's variances in workgroup memory.
//
// Bind group 0: the frame's inputs, the histories and the filter buffers; group 1: this
// dispatch's uniforms (`gi::pc::denoise`).

#import gi::packing::unpack_unit_vector
#import gi::math::luminance
#import gi::pc::denoise::{
    depth, normal, uniforms, load_history, store_history, load_filter, store_filter, is_sky,
    pixel_index, depth_at, depth_derivative, normal_weight, FIRST_ATROUS_WRITE
}

// Keeps the luminance weight defined where the variance is 0 (a noise-free input).
const LUMINANCE_EPSILON: f32 = 1e-10;
// B3-spline taps of the 5 x 5 a-trous kernel, by distance 0, 1, 2.
const B3_KERNEL: array<f32, 3> = array<f32, 3>(0.375, 0.25, 0.0625);
// Linear B-spline taps of the 3 x 3 kernel, by distance 0, 1.
const LINEAR_KERNEL: array<f32, 2> = array<f32, 2>(0.5, 0.25);

// The 1-D kernel's tap at distance `d` (0..=radius) for a kernel of radius 2 (B3) or 1.
fn kernel_tap(radius: i32, d: i32) -> f32 {
    if radius == 2 {
        return B3_KERNEL[d];
    }
    return LINEAR_KERNEL[d];
}
// Taps of the 3 x 3 Gaussian that prefilters the center variance, by distance 0, 1.
const GAUSSIAN_3X3: array<f32, 2> = array<f32, 2>(0.5, 0.25);
// The workgroup's pixels and a one-pixel border, row-major: the prefilter's taps.
const TILE_SIDE: u32 = 10u;
const WORKGROUP_SIDE: u32 = 8u;
// The input's luminance variance over the workgroup's tile, -1 for sky and outside the image:
// each pixel's 3 x 3 prefilter reads its nine taps here, loaded once per workgroup.
var<workgroup> tile_variance: array<f32, 100>;

// Fills `tile_variance` from filter write `input` for the workgroup at `group`; every
// invocation of the workgroup calls it.
fn load_variance_tile(input: u32, group: vec2<u32>, local_index: u32) {
    let corner = vec2<i32>(group * WORKGROUP_SIDE) - 1;
    for (var i = local_index; i < TILE_SIDE * TILE_SIDE; i += WORKGROUP_SIDE * WORKGROUP_SIDE) {
        let q = corner + vec2(i32(i % TILE_SIDE), i32(i / TILE_SIDE));
        var variance = -1.0;
        if !is_sky(depth_at(q)) {
            variance = load_filter(input, pixel_index(q)).w;
        }
        tile_variance[i] = variance;
    }
    workgroupBarrier();
}

// The center variance prefiltered with a 3 x 3 Gaussian over the non-sky pixels (SVGF: it
// steadies the luminance weight against a noisy variance estimate), from `tile_variance`
// around the pixel at `local` in its workgroup.
fn prefiltered_variance(local: vec2<u32>) -> f32 {
    var sum = 0.0;
    var weight_sum = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let t = vec2<i32>(local) + 1 + vec2(dx, dy);
            let variance = tile_variance[u32(t.y) * TILE_SIDE + u32(t.x)];
            if variance < 0.0 {
                continue;
            }
            let w = GAUSSIAN_3X3[abs(dx)] * GAUSSIAN_3X3[abs(dy)];
            sum += w * variance;
            weight_sum += w;
        }
    }
    return sum / weight_sum;
}

@compute @workgroup_size(8, 8)
fn atrous(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    filter_pixel(id.xy, local.xy, local_index, group.xy, 2);
}

@compute @workgroup_size(8, 8)
fn atrous_3x3(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) local_index: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    filter_pixel(id.xy, local.xy, local_index, group.xy, 1);
}

// One a-trous iteration at pixel `id` (`local` in workgroup `group`) with taps out to `radius`
// (2: 5 x 5, 1: 3 x 3) steps.
fn filter_pixel(id: vec2<u32>, local: vec2<u32>, local_index: u32, group: vec2<u32>, radius: i32) {
    // Iteration i has step 2^i.
    let place = FIRST_ATROUS_WRITE + firstTrailingBit(uniforms.step_px);
    let input = place - 1u;
    // Before any invocation leaves: the whole workgroup loads the tile.
    load_variance_tile(input, group, local_index);
    if any(id >= uniforms.size_px) {
        return;
    }
    let pixel = vec2<i32>(id);
    let index = pixel_index(pixel);
    let center = load_filter(input, index);
    let z = depth[index];
    var result = center;
    if !is_sky(z) {
        let n = unpack_unit_vector(normal[index]);
        let l = luminance(center.rgb);
        let phi_luminance = uniforms.luminance_sigma * sqrt(prefiltered_variance(local)) + LUMINANCE_EPSILON;
        let phi_depth = uniforms.depth_sigma * depth_derivative(pixel, z) * f32(uniforms.step_px);
        let step = i32(uniforms.step_px);
        // The center tap: every edge-stopping weight is 1.
        let center_weight = kernel_tap(radius, 0) * kernel_tap(radius, 0);
        var color_sum = center_weight * center.rgb;
        var variance_sum = center_weight * center_weight * center.w;
        var weight_sum = center_weight;
        for (var dy = -radius; dy <= radius; dy++) {
            for (var dx = -radius; dx <= radius; dx++) {
                if dx == 0 && dy == 0 {
                    continue;
                }
                let q = pixel + vec2(dx, dy) * step;
                let q_depth = depth_at(q);
                if is_sky(q_depth) {
                    continue;
                }
                let qi = pixel_index(q);
                let sample = load_filter(input, qi);
                let w_depth = abs(q_depth - z) / (phi_depth * length(vec2<f32>(vec2(dx, dy))));
                let w_luminance = abs(luminance(sample.rgb) - l) / phi_luminance;
                let w = kernel_tap(radius, abs(dx)) * kernel_tap(radius, abs(dy))
                    * normal_weight(n, unpack_unit_vector(normal[qi]), uniforms.normal_power)
                    * exp(-w_depth - w_luminance);
                color_sum += w * sample.rgb;
                variance_sum += w * w * sample.w;
                weight_sum += w;
            }
        }
        result = vec4(color_sum / weight_sum, variance_sum / (weight_sum * weight_sum));
    }
    store_filter(place, index, result);
    if place == FIRST_ATROUS_WRITE && uniforms.feedback != 0u {
        // SVGF feeds the first iteration back as the long history's color; `temporal` wrote
        // the variance and the age.
        let kept = load_history(index);
        store_history(index, result.rgb, kept.variance, kept.age);
    }
}

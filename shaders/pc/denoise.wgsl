// The PC tier's denoiser: HSGI's final processing (GDC 2023, "PC / Console Solution":
// temporal supersampling with a long and a short history, variance clamping with the short
// history's 5 x 5 neighbourhood) followed by SVGF's variance estimate and edge-avoiding
// a-trous wavelet filter (Schied et al. 2017, "Spatiotemporal Variance-Guided Filtering:
// Real-Time Reconstruction for Path-Traced Global Illumination", HPG). One entry point per
// dispatch, in frame order:
//
//   temporal_short  reproject the short history (bilinear 2 x 2 taps through the motion
//                   vector, each tap kept only if its previous depth and normal agree with
//                   this pixel's) and blend this frame's noisy irradiance into it with
//                   alpha = max(1 / (age + 1), 1 / short_history); store the history's age;
//   temporal        reproject the long history (color from the previous frame's first a-trous
//                   iteration, as SVGF feeds back, and the luminance moments) with the same
//                   taps, clamp its color into mean +- clamp_sigma sigma of this frame's short
//                   history over the 5 x 5 neighbourhood, and blend with
//                   alpha = max(1 / (age + 1), 1 / long_history);
//   variance        SVGF's luminance variance: from the temporal moments once the history is
//                   variance_min_age frames old, else from a 7 x 7 bilateral (depth, normal)
//                   estimate of the moments around the pixel;
//   atrous          one a-trous iteration (5 x 5 B3-spline taps `step_px` apart) with SVGF's
//                   normal, depth and luminance edge-stopping weights; the variance is
//                   filtered with the squared weights. The first iteration also writes the
//                   color history of the next frame.
//
// Pixels are one storage-buffer entry each, row-major. Sky pixels (depth +inf) pass their
// input through every pass, keep no history and never mix into their neighbours.
//
// Bind group 0: the frame's inputs and the histories (`gi_tiers::pc::denoise::Denoiser`);
// group 1: this dispatch's uniforms, filter input and filter output.

#import gi::packing::unpack_unit_vector
#import gi::math::luminance

const INFINITY_BITS: u32 = 0x7f800000u;
// Least total bilinear weight of the kept reprojection taps for the history to be used (SVGF's
// reference implementation's threshold).
const MIN_REPROJECTION_WEIGHT: f32 = 0.01;
// Least depth derivative of the depth weights, relative to the depth: a surface facing the
// camera has no derivative, and its depths still differ by rounding.
const DEPTH_DERIVATIVE_FLOOR: f32 = 1e-4;
// Keeps the luminance weight defined where the variance is 0 (a noise-free input).
const LUMINANCE_EPSILON: f32 = 1e-10;
// B3-spline taps of the a-trous kernel, by distance 0, 1, 2.
const ATROUS_KERNEL: array<f32, 3> = array<f32, 3>(0.375, 0.25, 0.0625);
// Taps of the 3 x 3 Gaussian that prefilters the center variance, by distance 0, 1.
const GAUSSIAN_3X3: array<f32, 2> = array<f32, 2>(0.5, 0.25);

// Mirror of `gi_tiers::pc::denoise::DenoiseUniforms`, 56 bytes.
struct DenoiseUniforms {
    size_px: vec2<u32>,
    // Pixels between a-trous taps (2^iteration).
    step_px: u32,
    // 1 on the first a-trous iteration: its output is the next frame's color history.
    write_history: u32,
    // 0: no usable history (first frame, reset, temporal accumulation off).
    history_valid: u32,
    long_history: u32,
    short_history: u32,
    variance_min_age: u32,
    clamp_sigma: f32,
    reprojection_depth_tolerance: f32,
    reprojection_normal_cos: f32,
    normal_power: f32,
    depth_sigma: f32,
    luminance_sigma: f32,
}

// Group 0.
@group(0) @binding(0) var<storage, read> noisy: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> depth: array<f32>;
@group(0) @binding(2) var<storage, read> normal: array<u32>;
@group(0) @binding(3) var<storage, read> motion: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> previous_depth: array<f32>;
@group(0) @binding(5) var<storage, read> previous_normal: array<u32>;
// rgb: the previous frame's first a-trous output; w: its variance (unused here).
@group(0) @binding(6) var<storage, read_write> history_color: array<vec4<f32>>;
// rgb: short history; w: age, frames accumulated including this one (0 for sky).
@group(0) @binding(7) var<storage, read> short_in: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> short_out: array<vec4<f32>>;
// Mean luminance and mean squared luminance of the long history.
@group(0) @binding(9) var<storage, read> moments_in: array<vec2<f32>>;
@group(0) @binding(10) var<storage, read_write> moments_out: array<vec2<f32>>;

// Group 1. Filter buffers hold rgb irradiance and, in w, its luminance variance.
@group(1) @binding(0) var<uniform> u: DenoiseUniforms;
@group(1) @binding(1) var<storage, read> filter_in: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> filter_out: array<vec4<f32>>;

fn is_sky(z: f32) -> bool {
    return bitcast<u32>(z) == INFINITY_BITS;
}

fn pixel_index(pixel: vec2<i32>) -> u32 {
    return u32(pixel.y) * u.size_px.x + u32(pixel.x);
}

fn inside(pixel: vec2<i32>) -> bool {
    return all(pixel >= vec2(0)) && all(pixel < vec2<i32>(u.size_px));
}

// Depth of a pixel, +inf outside the image (so it counts as sky).
fn depth_at(pixel: vec2<i32>) -> f32 {
    if !inside(pixel) {
        return bitcast<f32>(INFINITY_BITS);
    }
    return depth[pixel_index(pixel)];
}

// How much the depth changes per pixel at `pixel` (depth `z`): per axis the smaller of the two
// one-sided differences (the side on the same surface), the larger axis of the two; never
// below DEPTH_DERIVATIVE_FLOOR z. It plays the part of SVGF's screen-space depth gradient
// `fwidth(z)`, which a compute pass over a ray-cast G-buffer does not have.
fn depth_derivative(pixel: vec2<i32>, z: f32) -> f32 {
    var derivative = 0.0;
    for (var axis = 0; axis < 2; axis++) {
        var offset = vec2(0);
        offset[axis] = 1;
        let after = depth_at(pixel + offset);
        let before = depth_at(pixel - offset);
        var smaller = 3.0e38;
        if !is_sky(after) {
            smaller = abs(after - z);
        }
        if !is_sky(before) {
            smaller = min(smaller, abs(before - z));
        }
        if smaller < 3.0e38 {
            derivative = max(derivative, smaller);
        }
    }
    // The absolute floor keeps a zero depth from dividing by zero.
    return max(derivative, DEPTH_DERIVATIVE_FLOOR * z + 1e-30);
}

// SVGF's normal edge-stopping weight max(0, n . m)^power.
fn normal_weight(n: vec3<f32>, m: vec3<f32>, power: f32) -> f32 {
    let cos_angle = dot(n, m);
    if cos_angle <= 0.0 {
        return 0.0;
    }
    return pow(cos_angle, power);
}

// ---------------------------------------------------------------------------------------------
// temporal_short, temporal
// ---------------------------------------------------------------------------------------------

// The bilinear taps of the previous frame that a pixel reprojects to; a tap whose previous
// depth or normal disagrees with the pixel's has weight 0.
struct Reprojection {
    pixels: vec4<u32>,
    weights: vec4<f32>,
}

// The taps around the previous position of `pixel` (index `index`, depth `z`, normal `n`).
// Depths are compared without the camera's motion (the denoiser has no camera), with a
// tolerance relative to the depth plus the depth change across the one-pixel tap footprint.
fn reproject(pixel: vec2<i32>, index: u32, z: f32, n: vec3<f32>) -> Reprojection {
    var taps = Reprojection(vec4(0u), vec4(0.0));
    if u.history_valid == 0u {
        return taps;
    }
    // Tap space: previous pixel centers sit at integer coordinates.
    let previous = vec2<f32>(pixel) + motion[index];
    let base = floor(previous);
    let f = previous - base;
    let tolerance = u.reprojection_depth_tolerance * z + 2.0 * depth_derivative(pixel, z);
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let tap = vec2<i32>(base) + vec2<i32>(c);
        let w2 = select(1.0 - f, f, c == vec2(1u));
        let bilinear = w2.x * w2.y;
        if bilinear <= 0.0 || !inside(tap) {
            continue;
        }
        let t = pixel_index(tap);
        let tap_depth = previous_depth[t];
        if is_sky(tap_depth) || abs(tap_depth - z) > tolerance {
            continue;
        }
        if dot(unpack_unit_vector(previous_normal[t]), n) < u.reprojection_normal_cos {
            continue;
        }
        taps.pixels[corner] = t;
        taps.weights[corner] = bilinear;
    }
    return taps;
}

fn total_weight(taps: Reprojection) -> f32 {
    return dot(taps.weights, vec4(1.0));
}

@compute @workgroup_size(8, 8)
fn temporal_short(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let x = noisy[index].rgb;
    let z = depth[index];
    if is_sky(z) {
        short_out[index] = vec4(x, 0.0);
        return;
    }
    let taps = reproject(pixel, index, z, unpack_unit_vector(normal[index]));
    let total = total_weight(taps);
    var short_color = x;
    var previous_age = 0.0;
    if total >= MIN_REPROJECTION_WEIGHT {
        var previous = vec4(0.0);
        for (var k = 0u; k < 4u; k++) {
            previous += taps.weights[k] * short_in[taps.pixels[k]];
        }
        previous /= total;
        previous_age = previous.w;
        let alpha = max(1.0 / (previous_age + 1.0), 1.0 / f32(u.short_history));
        short_color = mix(previous.rgb, x, alpha);
    }
    short_out[index] = vec4(short_color, min(previous_age + 1.0, f32(u.long_history)));
}

// Per-channel statistics of a neighbourhood.
struct ColorBox {
    mean: vec3<f32>,
    sigma: vec3<f32>,
}

// Mean and standard deviation, per channel, of this frame's short history over the 5 x 5
// neighbourhood of `pixel` (sky left out).
fn short_neighbourhood(pixel: vec2<i32>) -> ColorBox {
    var sum = vec3(0.0);
    var sum_sq = vec3(0.0);
    var count = 0.0;
    for (var dy = -2; dy <= 2; dy++) {
        for (var dx = -2; dx <= 2; dx++) {
            let q = pixel + vec2(dx, dy);
            if is_sky(depth_at(q)) {
                continue;
            }
            let s = short_out[pixel_index(q)].rgb;
            sum += s;
            sum_sq += s * s;
            count += 1.0;
        }
    }
    let mean = sum / count;
    let sigma = sqrt(max(sum_sq / count - mean * mean, vec3(0.0)));
    return ColorBox(mean, sigma);
}

@compute @workgroup_size(8, 8)
fn temporal(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let x = noisy[index].rgb;
    let z = depth[index];
    let l = luminance(x);
    var color = x;
    var moments = vec2(l, l * l);
    if !is_sky(z) {
        let taps = reproject(pixel, index, z, unpack_unit_vector(normal[index]));
        let total = total_weight(taps);
        if total >= MIN_REPROJECTION_WEIGHT {
            var previous_color = vec3(0.0);
            var previous_moments = vec2(0.0);
            for (var k = 0u; k < 4u; k++) {
                previous_color += taps.weights[k] * history_color[taps.pixels[k]].rgb;
                previous_moments += taps.weights[k] * moments_in[taps.pixels[k]];
            }
            let box = short_neighbourhood(pixel);
            let half_width = u.clamp_sigma * box.sigma;
            let clamped = clamp(previous_color / total, box.mean - half_width, box.mean + half_width);
            // `temporal_short` stored the age including this frame: alpha = 1 / (previous + 1).
            let age = short_out[index].w;
            let alpha = max(1.0 / age, 1.0 / f32(u.long_history));
            color = mix(clamped, x, alpha);
            moments = mix(previous_moments / total, moments, alpha);
        }
    }
    moments_out[index] = moments;
    filter_out[index] = vec4(color, max(moments.y - moments.x * moments.x, 0.0));
}

// ---------------------------------------------------------------------------------------------
// variance
// ---------------------------------------------------------------------------------------------

@compute @workgroup_size(8, 8)
fn variance(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let center = filter_in[index];
    let z = depth[index];
    if is_sky(z) {
        filter_out[index] = vec4(center.rgb, 0.0);
        return;
    }
    if short_out[index].w >= f32(u.variance_min_age) {
        filter_out[index] = center;
        return;
    }
    // Young history: the moments of the 7 x 7 neighbourhood on the same surface.
    let n = unpack_unit_vector(normal[index]);
    let phi_depth = u.depth_sigma * depth_derivative(pixel, z);
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
            let w = normal_weight(n, unpack_unit_vector(normal[qi]), u.normal_power) * exp(-w_depth);
            sum += w * moments_out[qi];
            weight_sum += w;
        }
    }
    // The center has weight 1, so weight_sum >= 1.
    let m = sum / weight_sum;
    filter_out[index] = vec4(center.rgb, max(m.y - m.x * m.x, 0.0));
}

// ---------------------------------------------------------------------------------------------
// atrous
// ---------------------------------------------------------------------------------------------

// The center variance prefiltered with a 3 x 3 Gaussian over the non-sky pixels (SVGF: it
// steadies the luminance weight against a noisy variance estimate).
fn prefiltered_variance(pixel: vec2<i32>) -> f32 {
    var sum = 0.0;
    var weight_sum = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = pixel + vec2(dx, dy);
            if is_sky(depth_at(q)) {
                continue;
            }
            let w = GAUSSIAN_3X3[abs(dx)] * GAUSSIAN_3X3[abs(dy)];
            sum += w * filter_in[pixel_index(q)].w;
            weight_sum += w;
        }
    }
    return sum / weight_sum;
}

@compute @workgroup_size(8, 8)
fn atrous(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= u.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let center = filter_in[index];
    let z = depth[index];
    var result = center;
    if !is_sky(z) {
        let n = unpack_unit_vector(normal[index]);
        let l = luminance(center.rgb);
        let phi_luminance = u.luminance_sigma * sqrt(prefiltered_variance(pixel)) + LUMINANCE_EPSILON;
        let phi_depth = u.depth_sigma * depth_derivative(pixel, z) * f32(u.step_px);
        let step = i32(u.step_px);
        // The center tap: every edge-stopping weight is 1.
        let center_weight = ATROUS_KERNEL[0] * ATROUS_KERNEL[0];
        var color_sum = center_weight * center.rgb;
        var variance_sum = center_weight * center_weight * center.w;
        var weight_sum = center_weight;
        for (var dy = -2; dy <= 2; dy++) {
            for (var dx = -2; dx <= 2; dx++) {
                if dx == 0 && dy == 0 {
                    continue;
                }
                let q = pixel + vec2(dx, dy) * step;
                let q_depth = depth_at(q);
                if is_sky(q_depth) {
                    continue;
                }
                let qi = pixel_index(q);
                let sample = filter_in[qi];
                let w_depth = abs(q_depth - z) / (phi_depth * length(vec2<f32>(vec2(dx, dy))));
                let w_luminance = abs(luminance(sample.rgb) - l) / phi_luminance;
                let w = ATROUS_KERNEL[abs(dx)] * ATROUS_KERNEL[abs(dy)]
                    * normal_weight(n, unpack_unit_vector(normal[qi]), u.normal_power)
                    * exp(-w_depth - w_luminance);
                color_sum += w * sample.rgb;
                variance_sum += w * w * sample.w;
                weight_sum += w;
            }
        }
        result = vec4(color_sum / weight_sum, variance_sum / (weight_sum * weight_sum));
    }
    filter_out[index] = result;
    if u.write_history != 0u {
        history_color[index] = result;
    }
}

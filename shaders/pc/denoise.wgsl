// The PC tier's denoiser: HSGI's final processing (GDC 2023, "PC / Console Solution":
// temporal supersampling with a long and a short history, variance clamping with the short
// history's 5 x 5 neighbourhood) followed by SVGF's variance estimate and edge-avoiding
// a-trous wavelet filter (Schied et al. 2017, "Spatiotemporal Variance-Guided Filtering:
// Real-Time Reconstruction for Path-Traced Global Illumination", HPG). One entry point per
// dispatch, in frame order:
//
//   temporal_short  reproject the histories once (bilinear 2 x 2 taps through the motion
//                   vector, each tap kept only if its previous depth and normal agree with
//                   this pixel's): blend this frame's noisy irradiance into the short history
//                   with alpha = max(1 / (age + 1), 1 / short_history), and leave the
//                   reprojected long history (color, luminance moments, age) in `output`;
//   temporal        clamp the reprojected long color into mean +- clamp_sigma sigma of this
//                   frame's short history over the 5 x 5 neighbourhood and blend with
//                   alpha = max(1 / (age + 1), 1 / long_history); store the long history
//                   (with `feedback`, as SVGF does, the first a-trous iteration replaces its
//                   color);
//   variance        SVGF's luminance variance: from the temporal moments once the history is
//                   variance_min_age frames old, else from a 7 x 7 bilateral (depth, normal)
//                   estimate of the moments around the pixel;
//   atrous          one a-trous iteration (5 x 5 B3-spline taps `step_px` apart) with SVGF's
//                   normal, depth and luminance edge-stopping weights; the variance is
//                   filtered with the squared weights. With `feedback` the first iteration
//                   also writes the color of the next frame's long history.
//
// Pixels are one storage-buffer entry each, row-major. Sky pixels (depth +inf) pass their
// input through every pass, keep no history and never mix into their neighbours.
//
// Memory, 44 bytes per pixel (`gi_tiers::pc::denoise` explains the choice): the histories are
// packed (short color RGB9E5; long color and age `pack_color64`; moments f16), and the filter
// passes ping-pong between `output` (f32) and a `pack_color64` pair of buffers that are dead by
// then: the previous short history (reprojected by `temporal_short`) and the previous normals
// (read only by `temporal_short`, copied anew after the last pass). Which one a pass writes
// follows from the parity of its place in the chain (`writes_full`), so that the last pass
// writes `output`.
//
// Bind group 0: the frame's inputs, the histories and the filter buffers
// (`gi_tiers::pc::denoise::Denoiser`); group 1: this dispatch's uniforms.

#import gi::packing::{
    unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5, pack_half2, unpack_half2, pack_color64, unpack_color64
}
#import gi::math::{image_contains, image_index, luminance}

const INFINITY_BITS: u32 = 0x7f800000u;
// Most error of an RGB9E5 channel relative to the largest channel (half a mantissa step).
const RGB9E5_ERROR: f32 = 1.0 / 512.0;
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
// Places of the filter chain's writes (`writes_full`): `temporal` is write 0, `variance`
// write 1, a-trous iteration i write 2 + i.
const TEMPORAL_WRITE: u32 = 0u;
const VARIANCE_WRITE: u32 = 1u;
const FIRST_ATROUS_WRITE: u32 = 2u;

// Mirror of `gi_tiers::pc::denoise::DenoiseUniforms`, 64 bytes.
struct DenoiseUniforms {
    size_px: vec2<u32>,
    // Pixels between a-trous taps (2^iteration).
    step_px: u32,
    // A-trous iterations this frame: with the pass's place, where it reads and writes.
    atrous_iterations: u32,
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
    // 1: the first a-trous iteration's color becomes the long history (SVGF's feedback).
    feedback: u32,
    pad: u32,
}

// Group 0.
@group(0) @binding(0) var<storage, read> noisy: array<vec4<f32>>;
@group(0) @binding(1) var<storage, read> depth: array<f32>;
@group(0) @binding(2) var<storage, read> normal: array<u32>;
@group(0) @binding(3) var<storage, read> motion: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read> previous_depth: array<f32>;
// Octahedral normals of the previous frame until `temporal_short` has run; then the second
// word of the packed filter buffer (`store_filter`).
@group(0) @binding(5) var<storage, read_write> previous_normal: array<u32>;
// The previous frame's short history (RGB9E5) until `temporal_short` has run; then the first
// word of the packed filter buffer.
@group(0) @binding(6) var<storage, read_write> short_in: array<u32>;
// This frame's short history, RGB9E5.
@group(0) @binding(7) var<storage, read_write> short_out: array<u32>;
// The long history, `pack_color64` (rgb, age); age = frames accumulated including the current
// one (0 for sky). Read through the taps only by `temporal_short`.
@group(0) @binding(8) var<storage, read_write> history: array<vec2<u32>>;
// f16 (mean luminance, luminance variance) of the long history.
@group(0) @binding(9) var<storage, read_write> moments: array<u32>;
// `array<vec4<f32>>` for the caller (rgb irradiance, w its variance), kept as raw bits here:
// the reprojected long history between `temporal_short` and `temporal` (`Reprojected`), then
// the full-precision filter buffer, and the result after the last pass.
@group(0) @binding(10) var<storage, read_write> output: array<vec4<u32>>;

// Group 1.
@group(1) @binding(0) var<uniform> u: DenoiseUniforms;

// ---------------------------------------------------------------------------------------------
// Packed histories and filter buffers
// ---------------------------------------------------------------------------------------------

// Long history of pixel `index`: rgb and age.
fn load_history(index: u32) -> vec4<f32> {
    return unpack_color64(history[index]);
}

fn store_history(index: u32, color: vec3<f32>, age: f32) {
    history[index] = pack_color64(color, age);
}

// Mean luminance and mean squared luminance of pixel `index`'s long history (stored as mean
// and variance: the variance keeps its precision in f16, the squared mean would not).
fn load_moments(index: u32) -> vec2<f32> {
    let m = unpack_half2(moments[index]);
    return vec2(m.x, m.y + m.x * m.x);
}

// Stores mean and mean squared luminance, returns the variance.
fn store_moments(index: u32, m: vec2<f32>) -> f32 {
    let variance = max(m.y - m.x * m.x, 0.0);
    moments[index] = pack_half2(vec2(m.x, variance));
    return variance;
}

// The long history reprojected by `temporal_short` for `temporal`, in `output`.
struct Reprojected {
    // Whether enough taps were kept (else the history is dropped).
    valid: bool,
    color: vec3<f32>,
    // Frames accumulated including this one.
    age: f32,
    // Mean luminance and mean squared luminance.
    moments: vec2<f32>,
}

fn store_reprojected(index: u32, r: Reprojected) {
    let variance = max(r.moments.y - r.moments.x * r.moments.x, 0.0);
    let color = pack_color64(r.color, r.age);
    output[index] = vec4(color, pack_half2(vec2(r.moments.x, variance)), u32(r.valid));
}

fn load_reprojected(index: u32) -> Reprojected {
    let packed = output[index];
    let color = unpack_color64(packed.xy);
    let m = unpack_half2(packed.z);
    return Reprojected(packed.w != 0u, color.rgb, color.w, vec2(m.x, m.y + m.x * m.x));
}

// Index of this frame's last filter write: the last a-trous iteration, or `temporal` without.
fn last_write() -> u32 {
    return select(FIRST_ATROUS_WRITE + u.atrous_iterations - 1u, TEMPORAL_WRITE, u.atrous_iterations == 0u);
}

// Whether filter write `place` goes to `output` (full precision), else to the packed pair.
// They alternate so that each pass reads the other one, and the last write is `output`.
fn writes_full(place: u32) -> bool {
    return ((last_write() - place) & 1u) == 0u;
}

// Filter data (rgb, luminance variance) of pixel `index` as written by filter write `place`.
fn load_filter(place: u32, index: u32) -> vec4<f32> {
    if writes_full(place) {
        return bitcast<vec4<f32>>(output[index]);
    }
    return unpack_color64(vec2(short_in[index], previous_normal[index]));
}

fn store_filter(place: u32, index: u32, value: vec4<f32>) {
    if writes_full(place) {
        output[index] = bitcast<vec4<u32>>(value);
    } else {
        let packed = pack_color64(value.rgb, value.w);
        short_in[index] = packed.x;
        previous_normal[index] = packed.y;
    }
}

fn is_sky(z: f32) -> bool {
    return bitcast<u32>(z) == INFINITY_BITS;
}

fn pixel_index(pixel: vec2<i32>) -> u32 {
    return image_index(pixel, u.size_px);
}

fn inside(pixel: vec2<i32>) -> bool {
    return image_contains(pixel, u.size_px);
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
    var long = Reprojected(false, vec3(0.0), 0.0, vec2(0.0));
    if is_sky(z) {
        short_out[index] = pack_rgb9e5(x);
        store_reprojected(index, long);
        return;
    }
    let taps = reproject(pixel, index, z, unpack_unit_vector(normal[index]));
    let total = total_weight(taps);
    var short_color = x;
    var previous_age = 0.0;
    if total >= MIN_REPROJECTION_WEIGHT {
        var previous_short = vec3(0.0);
        var previous_long = vec4(0.0);
        var previous_moments = vec2(0.0);
        for (var k = 0u; k < 4u; k++) {
            let t = taps.pixels[k];
            let w = taps.weights[k];
            previous_short += w * unpack_rgb9e5(short_in[t]);
            previous_long += w * load_history(t);
            previous_moments += w * load_moments(t);
        }
        previous_age = previous_long.w / total;
        let alpha = max(1.0 / (previous_age + 1.0), 1.0 / f32(u.short_history));
        short_color = mix(previous_short / total, x, alpha);
        long.valid = true;
        long.color = previous_long.rgb / total;
        long.moments = previous_moments / total;
    }
    short_out[index] = pack_rgb9e5(short_color);
    long.age = min(previous_age + 1.0, f32(u.long_history));
    store_reprojected(index, long);
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
            let s = unpack_rgb9e5(short_out[pixel_index(q)]);
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
    // Only this pixel reads its reprojection, so its filter data may replace it.
    let previous = load_reprojected(index);
    var color = x;
    var m = vec2(l, l * l);
    if !is_sky(z) && previous.valid {
        let box = short_neighbourhood(pixel);
        // Widened by the short history's RGB9E5 rounding, so that a noise-free history is not
        // pulled off by it.
        let rounding = RGB9E5_ERROR * max(max(box.mean.r, box.mean.g), box.mean.b);
        let half_width = u.clamp_sigma * box.sigma + rounding;
        let clamped = clamp(previous.color, box.mean - half_width, box.mean + half_width);
        // `temporal_short` stored the age including this frame: alpha = 1 / (previous + 1).
        let alpha = max(1.0 / previous.age, 1.0 / f32(u.long_history));
        color = mix(clamped, x, alpha);
        m = mix(previous.moments, m, alpha);
    }
    let variance = store_moments(index, m);
    // The first a-trous iteration, if any, replaces the color.
    store_history(index, color, previous.age);
    store_filter(TEMPORAL_WRITE, index, vec4(color, variance));
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
    let center = load_filter(VARIANCE_WRITE - 1u, index);
    let z = depth[index];
    if is_sky(z) {
        store_filter(VARIANCE_WRITE, index, vec4(center.rgb, 0.0));
        return;
    }
    if load_history(index).w >= f32(u.variance_min_age) {
        store_filter(VARIANCE_WRITE, index, center);
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
            sum += w * load_moments(qi);
            weight_sum += w;
        }
    }
    // The center has weight 1, so weight_sum >= 1.
    let m = sum / weight_sum;
    store_filter(VARIANCE_WRITE, index, vec4(center.rgb, max(m.y - m.x * m.x, 0.0)));
}

// ---------------------------------------------------------------------------------------------
// atrous
// ---------------------------------------------------------------------------------------------

// The center variance prefiltered with a 3 x 3 Gaussian over the non-sky pixels (SVGF: it
// steadies the luminance weight against a noisy variance estimate); `input` is the filter
// write to read.
fn prefiltered_variance(input: u32, pixel: vec2<i32>) -> f32 {
    var sum = 0.0;
    var weight_sum = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let q = pixel + vec2(dx, dy);
            if is_sky(depth_at(q)) {
                continue;
            }
            let w = GAUSSIAN_3X3[abs(dx)] * GAUSSIAN_3X3[abs(dy)];
            sum += w * load_filter(input, pixel_index(q)).w;
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
    // Iteration i has step 2^i.
    let place = FIRST_ATROUS_WRITE + firstTrailingBit(u.step_px);
    let input = place - 1u;
    let center = load_filter(input, index);
    let z = depth[index];
    var result = center;
    if !is_sky(z) {
        let n = unpack_unit_vector(normal[index]);
        let l = luminance(center.rgb);
        let phi_luminance = u.luminance_sigma * sqrt(prefiltered_variance(input, pixel)) + LUMINANCE_EPSILON;
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
                let sample = load_filter(input, qi);
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
    store_filter(place, index, result);
    if place == FIRST_ATROUS_WRITE && u.feedback != 0u {
        // SVGF feeds the first iteration back as the long history's color; `temporal` wrote
        // the age.
        store_history(index, result.rgb, load_history(index).w);
    }
}

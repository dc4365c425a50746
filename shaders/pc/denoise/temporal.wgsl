// Pass `pc/denoise_temporal` of the PC tier's denoiser (`gi::pc::denoise`), two dispatches:
//
//   temporal_short  reproject the histories once (bilinear 2 x 2 taps through the motion
//                   vector, each tap kept only if its previous depth and normal agree with
//                   this pixel's): with `short_clamp_sigma`, clamp the short history into
//                   mean +- short_clamp_sigma sigma of the noisy input's 3 x 3 neighbourhood;
//                   blend this frame's noisy irradiance into the short history
//                   with alpha = max(1 / (age + 1), 1 / short_history), and leave it in
//                   `scratch` (y) and the reprojected long history in `output` (color,
//                   age) and `scratch` (x: luminance variance);
//                   where the temporal gradient's lambda (`gradient_lambda`) says the light
//                   changed, both alphas first become mix(alpha, 1, lambda), the long one
//                   through the age it stores;
//   temporal        clamp the reprojected long color into mean +- clamp_sigma sigma of this
//                   frame's short history over the 5 x 5 neighbourhood and blend with
//                   alpha = max(1 / (age + 1), 1 / long_history); store the long history
//                   (with `feedback`, as SVGF does, the first a-trous iteration replaces its
//                   color); keep this frame's short history, depth and normal for the next
//                   frame's taps.
//
// Bind group 0: the frame's inputs, the histories and the filter buffers; group 1: this
// dispatch's uniforms (`gi::pc::denoise`).

#import gi::packing::{
    unpack_unit_vector, pack_rgb9e5, unpack_rgb9e5, pack_color64, unpack_color64,
    pack_depth_normal, unpack_depth, unpack_normal8
}
#import gi::math::luminance
#import gi::pc::denoise::{
    noisy_at, depth, normal, motion, previous_geometry, short_history, output, scratch,
    uniforms, load_history, store_history, store_filter, is_sky,
    pixel_index, inside, depth_at, depth_derivative, gradient_lambda, TEMPORAL_WRITE
}

// Most error of an RGB9E5 channel relative to the largest channel (half a mantissa step).
const RGB9E5_ERROR: f32 = 1.0 / 512.0;
// Least total bilinear weight of the kept reprojection taps for the history to be used (SVGF's
// reference implementation's threshold).
const MIN_REPROJECTION_WEIGHT: f32 = 0.01;

// The long history reprojected by `temporal_short` for `temporal`, in `output` and
// `scratch` (x), beside this frame's short history (`scratch`, y).
struct Reprojected {
    color: vec3<f32>,
    // Frames accumulated including this one; 1 where no history was kept (then the history's
    // weight, 1 - 1 / age, is 0).
    age: f32,
    // Luminance variance about the color's luminance.
    variance: f32,
}

fn store_reprojected(index: u32, r: Reprojected, short_color: vec3<f32>) {
    output[index] = pack_color64(r.color, r.age);
    scratch[index] = vec2(bitcast<u32>(r.variance), pack_rgb9e5(short_color));
}

fn load_reprojected(index: u32) -> Reprojected {
    let color = unpack_color64(output[index]);
    return Reprojected(color.rgb, color.w, bitcast<f32>(scratch[index].x));
}

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
    if uniforms.history_valid == 0u {
        return taps;
    }
    // Tap space: previous pixel centers sit at integer coordinates.
    let previous = vec2<f32>(pixel) + motion[index];
    let base = floor(previous);
    let f = previous - base;
    let tolerance = uniforms.reprojection_depth_tolerance * z + 2.0 * depth_derivative(pixel, z);
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let tap = vec2<i32>(base) + vec2<i32>(c);
        let w2 = select(1.0 - f, f, c == vec2(1u));
        let bilinear = w2.x * w2.y;
        if bilinear <= 0.0 || !inside(tap) {
            continue;
        }
        let t = pixel_index(tap);
        let geometry = previous_geometry[t];
        let tap_depth = unpack_depth(geometry);
        if is_sky(tap_depth) || abs(tap_depth - z) > tolerance {
            continue;
        }
        if dot(unpack_normal8(geometry), n) < uniforms.reprojection_normal_cos {
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
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let x = noisy_at(index);
    let z = depth[index];
    var long = Reprojected(vec3(0.0), 0.0, 0.0);
    if is_sky(z) {
        store_reprojected(index, long, x);
        return;
    }
    let taps = reproject(pixel, index, z, unpack_unit_vector(normal[index]));
    let total = total_weight(taps);
    var short_color = x;
    var previous_age = 0.0;
    if total >= MIN_REPROJECTION_WEIGHT {
        var previous_short = vec3(0.0);
        var previous_long = vec4(0.0);
        // Per tap its luminance, then about the taps' mean: the second moment of the taps
        // together is the mean of theirs plus their luminances' spread.
        var tap_luminance = vec4(0.0);
        var previous_variance = 0.0;
        for (var k = 0u; k < 4u; k++) {
            let t = taps.pixels[k];
            let w = taps.weights[k];
            previous_short += w * unpack_rgb9e5(short_history[t]);
            let h = load_history(t);
            previous_long += w * vec4(h.rgb, h.age);
            tap_luminance[k] = luminance(h.rgb);
            previous_variance += w * h.variance;
        }
        let mean_luminance = dot(taps.weights, tap_luminance) / total;
        let spread = tap_luminance - mean_luminance;
        previous_variance = (previous_variance + dot(taps.weights, spread * spread)) / total;
        previous_age = previous_long.w / total;
        // Where the light changed the histories weigh less (A-SVGF: alpha' = mix(alpha, 1,
        // lambda)); the long one through its age, which `temporal` turns into its alpha.
        let lambda = gradient_lambda(pixel);
        previous_age = 1.0 / mix(1.0 / (previous_age + 1.0), 1.0, lambda) - 1.0;
        let alpha = max(1.0 / (previous_age + 1.0), mix(1.0 / f32(uniforms.short_history), 1.0, lambda));
        var reprojected_short = previous_short / total;
        if uniforms.short_clamp_sigma > 0.0 {
            let box = neighbourhood(pixel, 1, true);
            let half_width = uniforms.short_clamp_sigma * box.sigma;
            reprojected_short = clamp(reprojected_short, box.mean - half_width, box.mean + half_width);
        }
        short_color = mix(reprojected_short, x, alpha);
        long.color = previous_long.rgb / total;
        long.variance = previous_variance;
    }
    long.age = min(previous_age + 1.0, f32(uniforms.long_history));
    store_reprojected(index, long, short_color);
}

// Per-channel statistics of a neighbourhood.
struct ColorBox {
    mean: vec3<f32>,
    sigma: vec3<f32>,
}

// Mean and standard deviation, per channel, over the (2 radius + 1)^2 neighbourhood of `pixel`
// (sky left out; the pixel itself is not sky) of this frame's noisy input (`noisy`) or of its
// short history.
fn neighbourhood(pixel: vec2<i32>, radius: i32, noisy: bool) -> ColorBox {
    var sum = vec3(0.0);
    var sum_sq = vec3(0.0);
    var count = 0.0;
    for (var dy = -radius; dy <= radius; dy++) {
        for (var dx = -radius; dx <= radius; dx++) {
            let q = pixel + vec2(dx, dy);
            if is_sky(depth_at(q)) {
                continue;
            }
            var s: vec3<f32>;
            if noisy {
                s = noisy_at(pixel_index(q));
            } else {
                s = unpack_rgb9e5(scratch[pixel_index(q)].y);
            }
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
    if any(id.xy >= uniforms.size_px) {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let index = pixel_index(pixel);
    let x = noisy_at(index);
    let z = depth[index];
    let l = luminance(x);
    // Only this pixel reads its reprojection, so its filter data may replace it.
    let previous = load_reprojected(index);
    var color = x;
    // Without history the moments are this frame's alone: no variance.
    var variance = 0.0;
    // An age of 1: no history kept (alpha 1 would take `x` alone).
    if !is_sky(z) && previous.age > 1.0 {
        let box = neighbourhood(pixel, 2, false);
        // Widened by the short history's RGB9E5 rounding, so that a noise-free history is not
        // pulled off by it.
        let rounding = RGB9E5_ERROR * max(max(box.mean.r, box.mean.g), box.mean.b);
        let half_width = uniforms.clamp_sigma * box.sigma + rounding;
        let clamped = clamp(previous.color, box.mean - half_width, box.mean + half_width);
        // `temporal_short` stored the age including this frame: alpha = 1 / (previous + 1).
        let alpha = max(1.0 / previous.age, 1.0 / f32(uniforms.long_history));
        color = mix(clamped, x, alpha);
        // The moments blended with the same alpha as the color, their mean being its
        // luminance: the variance about the clamped history's luminance takes the
        // exponentially weighted update (Finch 2009, "Incremental calculation of weighted
        // mean and variance"), SVGF's mix of first and second moments rewritten.
        let deviation = l - luminance(clamped);
        variance = (1.0 - alpha) * (previous.variance + alpha * deviation * deviation);
    }
    // With `feedback` the first a-trous iteration replaces the color.
    store_history(index, color, variance, previous.age);
    store_filter(TEMPORAL_WRITE, index, vec4(color, variance));
    // `temporal_short`, the only reader of the previous short history and geometry, has run.
    short_history[index] = scratch[index].y;
    previous_geometry[index] = pack_depth_normal(z, unpack_unit_vector(normal[index]));
}

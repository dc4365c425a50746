// The PC tier's denoiser: HSGI's final processing (GDC 2023, "PC / Console Solution":
// temporal supersampling with a long and a short history, variance clamping with the short
// history's 5 x 5 neighbourhood) followed by SVGF's variance estimate and edge-avoiding
// a-trous wavelet filter (Schied et al. 2017, "Spatiotemporal Variance-Guided Filtering:
// Real-Time Reconstruction for Path-Traced Global Illumination", HPG). One pass per file of
// `shaders/pc/denoise/`, in frame order: `temporal.wgsl` (two dispatches, `temporal_short`
// then `temporal`), `variance.wgsl`, `atrous.wgsl` (once per iteration); this module holds
// what they share.
//
// Pixels are one storage-buffer entry each, row-major. Sky pixels (depth +inf) pass their
// input through every pass, keep no history and never mix into their neighbours.
//
// Memory, 32 bytes per pixel (`gi_tiers::pc::denoise` explains the choice; 16 of its own when
// the caller lends `output` and `scratch`): the histories are packed (short color RGB9E5; long
// color with its luminance variance and age `pack_history64`; the previous depth and normal in
// one word), each updated in place, and the filter passes ping-pong between `output` and
// `scratch`, both in `pack_color64` (rgb, and the luminance variance as the value). The long
// history's luminance moments are its color's luminance (the first) and the variance it keeps
// (the second, central): updated with the same alpha as the color, that is SVGF's pair of
// moments, exactly, where the clamp leaves the color alone. `temporal` writes `output`
// (its neighbours still read this frame's short history in `scratch`); `variance` reads only
// its own pixel, so it writes either buffer; the a-trous passes alternate from there, so
// that the last pass writes `output` (`writes_output`).
//
// Bind group 0: the frame's inputs, the histories and the filter buffers
// (`DenoiseBindings` in `gi_tiers::pc::denoise`, in its order); group 1: this dispatch's
// uniforms.
#define_import_path gi::pc::denoise

#import gi::packing::{pack_color64, unpack_color64, pack_history64, unpack_history64, History64}
#import gi::math::{image_contains, image_index}

const INFINITY_BITS: u32 = 0x7f800000u;
// Least depth derivative of the depth weights, relative to the depth: a surface facing the
// camera has no derivative, and its depths still differ by rounding.
const DEPTH_DERIVATIVE_FLOOR: f32 = 1e-4;
// Places of the filter chain's writes (`writes_full`): `temporal` is write 0, `variance`
// write 1, a-trous iteration i write 2 + i.
const TEMPORAL_WRITE: u32 = 0u;
const VARIANCE_WRITE: u32 = 1u;
const FIRST_ATROUS_WRITE: u32 = 2u;

// Mirror of `gi_tiers::pc::denoise::DenoiseUniforms`, 80 bytes.
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
    // Half-width of the short history's clamp box in sigmas of the noisy 3 x 3 neighbourhood
    // (0: off).
    short_clamp_sigma: f32,
    // Full-resolution pixels per side of a temporal-gradient stratum; 0: no gradients (lambda
    // 0 everywhere).
    gradient_scale: u32,
    // Strata per row and per column of `gradients`.
    gradient_strata_x: u32,
    gradient_strata_y: u32,
    pad: u32,
}

// Group 0.
// Noisy demodulated irradiance, `pack_color64` (rgb; the value unused): read through `noisy_at`.
@group(0) @binding(0) var<storage, read> noisy: array<vec2<u32>>;
@group(0) @binding(1) var<storage, read> depth: array<f32>;
@group(0) @binding(2) var<storage, read> normal: array<u32>;
@group(0) @binding(3) var<storage, read> motion: array<vec2<f32>>;
// The previous frame's G-buffer depth and normal (`pack_depth_normal`), which the taps are
// checked against, until `temporal_short` has run; `temporal` writes this frame's.
@group(0) @binding(4) var<storage, read_write> previous_geometry: array<u32>;
// The short history, RGB9E5: the previous frame's until `temporal_short` has run (which
// leaves this frame's in `scratch`), then this frame's, which `temporal` copies back.
@group(0) @binding(5) var<storage, read_write> short_history: array<u32>;
// The long history, `pack_history64`: rgb, the luminance variance about its luminance, and
// age = frames accumulated including the current one (0 for sky). Read through the taps only
// by `temporal_short`.
@group(0) @binding(6) var<storage, read_write> history: array<vec2<u32>>;
// `pack_color64`: the reprojected long history's color and age between `temporal_short` and
// `temporal` (`Reprojected`), then a filter buffer (rgb irradiance, its luminance variance as
// the value), and the result after the last pass.
@group(0) @binding(7) var<storage, read_write> output: array<vec2<u32>>;
// Per temporal-gradient stratum, lambda in z (`pc/restir/gradient.wgsl`): how much of the
// light changed since the last frame.
@group(0) @binding(8) var<storage, read> gradients: array<vec4<f32>>;
// From `temporal_short` to `temporal`: in x the reprojected long history's luminance
// variance (f32 bits), in y this frame's short history (RGB9E5); then the other filter buffer
// (`pack_color64`).
@group(0) @binding(9) var<storage, read_write> scratch: array<vec2<u32>>;

// Group 1.
// Named `uniforms`, not `u`: the passes import it, and naga_oil would rewrite the `u` suffix
// of integer literals into an imported `u`.
@group(1) @binding(0) var<uniform> uniforms: DenoiseUniforms;

// ---------------------------------------------------------------------------------------------
// Packed histories and filter buffers
// ---------------------------------------------------------------------------------------------

// This frame's noisy irradiance at pixel `index`.
fn noisy_at(index: u32) -> vec3<f32> {
    return unpack_color64(noisy[index]).rgb;
}

// Long history of pixel `index`: rgb, luminance variance and age.
fn load_history(index: u32) -> History64 {
    return unpack_history64(history[index]);
}

fn store_history(index: u32, color: vec3<f32>, variance: f32, age: f32) {
    history[index] = pack_history64(color, variance, age);
}

// Index of this frame's last filter write: the last a-trous iteration, or `temporal` without.
fn last_write() -> u32 {
    return select(FIRST_ATROUS_WRITE + uniforms.atrous_iterations - 1u, TEMPORAL_WRITE, uniforms.atrous_iterations == 0u);
}

// Whether filter write `place` goes to `output`, else to `scratch`. `temporal` writes
// `output`; from `variance` on they alternate, so that each a-trous pass reads the other
// buffer and the last write is `output` (`variance`, which reads only its own pixel, may
// write where it reads).
fn writes_output(place: u32) -> bool {
    return place == TEMPORAL_WRITE || ((last_write() - place) & 1u) == 0u;
}

// Filter data (rgb, luminance variance) of pixel `index` as written by filter write `place`.
fn load_filter(place: u32, index: u32) -> vec4<f32> {
    if writes_output(place) {
        return unpack_color64(output[index]);
    }
    return unpack_color64(scratch[index]);
}

fn store_filter(place: u32, index: u32, value: vec4<f32>) {
    let packed = pack_color64(value.rgb, value.w);
    if writes_output(place) {
        output[index] = packed;
    } else {
        scratch[index] = packed;
    }
}

fn is_sky(z: f32) -> bool {
    return bitcast<u32>(z) == INFINITY_BITS;
}

fn pixel_index(pixel: vec2<i32>) -> u32 {
    return image_index(pixel, uniforms.size_px);
}

fn inside(pixel: vec2<i32>) -> bool {
    return image_contains(pixel, uniforms.size_px);
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

// The temporal gradient's lambda at `pixel` (0: the light did not change; 1: it all changed),
// bilinear between the centres of the strata around it.
fn gradient_lambda(pixel: vec2<i32>) -> f32 {
    let scale = uniforms.gradient_scale;
    if scale == 0u {
        return 0.0;
    }
    let strata = vec2<i32>(i32(uniforms.gradient_strata_x), i32(uniforms.gradient_strata_y));
    let at = (vec2<f32>(pixel) + 0.5) / f32(scale) - 0.5;
    let base = floor(at);
    let f = at - base;
    var lambda = 0.0;
    for (var corner = 0u; corner < 4u; corner++) {
        let c = vec2(corner & 1u, corner >> 1u);
        let q = clamp(vec2<i32>(base) + vec2<i32>(c), vec2(0), strata - 1);
        let w = select(1.0 - f, f, c == vec2(1u));
        lambda += w.x * w.y * gradients[u32(q.y * strata.x + q.x)].z;
    }
    return lambda;
}

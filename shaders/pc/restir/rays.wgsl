// What the PC tier's passes that trace BVH rays (`trace`, `shadow`, `specular_trace`) share:
// the storage buffers of their bind group 0, declared once, and where a ray leaves a surface.
// The buffers are those of `TraceBindings` (crates/gi-tiers/src/pc/restir.rs) in its order,
// from binding 8, after the uniforms (binding 0, `gi::pc::restir::common::uniforms`) and the
// scene (bindings 1-7, `gi::scene`). Each pass imports the ones it uses. A unit test checks the
// names and accesses against the Rust list.
#define_import_path gi::pc::restir::rays

#import gi::pc::restir::common::{
    uniforms, Surface, StoredSurface, StoredReservoir, SpecularSample, stored_surface,
    GradientSample, GRADIENT_NONE, gradient_pick, receiver_entry, receiver_at, receiver_pixel,
    NO_RECEIVER, FLAG_TEMPORAL
}

// Shadow rays stop short of their target by this share of the distance.
const SHADOW_MARGIN: f32 = 1e-3;

@group(0) @binding(8) var<storage, read> gbuffer_depth: array<f32>;
@group(0) @binding(9) var<storage, read> gbuffer_normal: array<u32>;
// Per trace pixel: this frame's receiver's pixel (written by `trace`, `receiver_entry`; its
// depth and normal are the G-buffer's there).
@group(0) @binding(10) var<storage, read_write> receivers: array<u32>;
// Per trace pixel: the initial reservoir (written by `trace`).
@group(0) @binding(11) var<storage, read_write> initial: array<StoredReservoir>;
// Per trace pixel: the temporal reuse's result (read by `shadow`).
@group(0) @binding(12) var<storage, read> temporal: array<StoredReservoir>;
// Per trace pixel: the reservoir the shading reads. With spatial reuse, `pc/spatial` wrote
// its result here and `shadow` updates it in place (each invocation reads and writes only its
// own element); without, `shadow` writes it.
@group(0) @binding(13) var<storage, read_write> resolved: array<StoredReservoir>;
@group(0) @binding(14) var<storage, read> gbuffer_base_color: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> gbuffer_metallic_roughness: array<vec2<f32>>;
// Per trace pixel: the specular ray (written by `specular_trace`).
@group(0) @binding(16) var<storage, read_write> specular_samples: array<SpecularSample>;
// Per temporal-gradient stratum, in two halves by frame parity: the ray candidate `trace` kept
// for the next frame's gradient (`kept_sample_slot`). `trace` draws last frame's again in the
// same dispatch, so this frame's go to the other half.
@group(0) @binding(17) var<storage, read_write> gradient_samples: array<GradientSample>;
// Per stratum: the change `draw_gradient` measured (x: new minus old luminance, outside the
// cache and where the cache measured a change, y: the larger of the two luminances of all the
// ray found), and `gradient_filter`'s lambda (z) over the strata around it.
@group(0) @binding(18) var<storage, read_write> gradients: array<vec4<f32>>;
// Per trace pixel with temporal reuse: this frame's receiver whole, kept for the next frame's
// temporal reuse (the G-buffer will have moved on by then).
@group(0) @binding(19) var<storage, read_write> surfaces: array<StoredSurface>;

// This frame's receiver of trace pixel `index`.
fn load_surface(index: u32) -> Surface {
    let xy = receivers[index];
    if xy == NO_RECEIVER {
        return Surface(vec3(0.0), 0u, 0u, 0.0);
    }
    let pixel = receiver_pixel(xy);
    return receiver_at(xy, pixel, gbuffer_depth[pixel], gbuffer_normal[pixel]);
}

// Keeps this frame's receiver of trace pixel `index`: its pixel, and with temporal reuse the
// whole surface for the next frame.
fn store_surface(index: u32, s: Surface) {
    receivers[index] = receiver_entry(s);
    if (uniforms.flags & FLAG_TEMPORAL) != 0u {
        surfaces[index] = stored_surface(s);
    }
}

// `p` pushed off its surface along `n` by a margin relative to its magnitude (the reference's
// `offset_origin`).
fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    return p + n * (1e-4 * (1.0 + max(max(a.x, a.y), a.z)));
}

// Keeps the ray candidate of trace pixel `t` (index `index`) for the next frame's gradient
// when `t` is its stratum's pick this frame: its receiver's offset origin and packed normal,
// and the luminances `gradient_seen` and all that it found.
fn store_gradient_sample(t: vec2<u32>, index: u32, origin: vec3<f32>, normal: u32, seen: f32, total: f32) {
    if uniforms.gradient_stratum == 0u {
        return;
    }
    let stratum = t / uniforms.gradient_stratum;
    if any(gradient_pick(stratum, uniforms.frame_index) != t) {
        return;
    }
    let s = kept_sample_slot(stratum, uniforms.frame_index);
    gradient_samples[s] = GradientSample(origin, normal, seen, index, uniforms.frame_index, total);
}

// Marks the stratum of trace pixel `t` as keeping no sample this frame when `t` is its pick.
fn clear_gradient_sample(t: vec2<u32>) {
    store_gradient_sample(t, GRADIENT_NONE, vec3(0.0), 0u, 0.0, 0.0);
}

// Where frame `frame` keeps the sample of `stratum`: the half of `gradient_samples` of the
// frame's parity.
fn kept_sample_slot(stratum: vec2<u32>, frame: u32) -> u32 {
    let strata = uniforms.gradient_strata_x * uniforms.gradient_strata_y;
    return (frame & 1u) * strata + stratum.y * uniforms.gradient_strata_x + stratum.x;
}

// What the PC tier's passes after the rays (`temporal`, `spatial`, `shade`, `compose`,
// `specular_resolve`, `specular_temporal`) share: the storage buffers of their bind group 0,
// declared once, and the helpers that several of them call. The buffers are those of
// `RestirBindings` (crates/gi-tiers/src/pc/restir.rs) in its order, from binding 8, after the
// uniforms (binding 0, `gi::pc::restir::common::uniforms`). Each pass imports the ones it uses.
// A unit test checks the names and accesses against the Rust list.
#define_import_path gi::pc::restir::bindings

#import gi::pc::restir::common::{
    uniforms, Surface, StoredSurface, StoredReservoir, SpecularSample, specular_kind,
    pixel_point, surface_seen_by, receiver_at, receiver_pixel, NO_RECEIVER
}

@group(0) @binding(8) var<storage, read> gbuffer_depth: array<f32>;
@group(0) @binding(9) var<storage, read> gbuffer_normal: array<u32>;
@group(0) @binding(10) var<storage, read> gbuffer_base_color: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> gbuffer_metallic_roughness: array<vec2<f32>>;
@group(0) @binding(12) var<storage, read> gbuffer_motion: array<vec2<f32>>;
// Per trace pixel: this frame's receiver's pixel (`receiver_entry`; its depth and normal are
// the G-buffer's there), and the previous frame's receivers as `trace` kept them (with
// temporal reuse only).
@group(0) @binding(13) var<storage, read> receivers: array<u32>;
@group(0) @binding(14) var<storage, read> surfaces_prev: array<StoredSurface>;
// Per trace pixel: this frame's new reservoirs (`trace`). `initial`, `specular_noisy` and
// `denoised` are one buffer in turn (`RestirBuffers::transient`), so all three are read_write:
// a dispatch may not bind one buffer both read-only and writable.
@group(0) @binding(15) var<storage, read_write> initial: array<StoredReservoir>;
// Per trace pixel: this frame's temporal reservoirs (the next frame's history) and the
// previous frame's; the resolved reservoirs, which `spatial` writes and the shadow pass
// (`shadow`) then updates in place, and which `shade` reads.
@group(0) @binding(16) var<storage, read_write> temporal_out: array<StoredReservoir>;
@group(0) @binding(17) var<storage, read> temporal_prev: array<StoredReservoir>;
@group(0) @binding(18) var<storage, read_write> resolved: array<StoredReservoir>;
// Per pixel: the multi-sample shading's irradiance and the denoised one (rgb,
// `pack_color64`), the direct light's running mean, the output image.
@group(0) @binding(19) var<storage, read_write> irradiance: array<vec2<u32>>;
@group(0) @binding(20) var<storage, read_write> denoised: array<vec2<u32>>;
@group(0) @binding(21) var<storage, read> direct_mean: array<vec4<f32>>;
@group(0) @binding(22) var<storage, read_write> output: array<vec4<f32>>;
// Per trace pixel: this frame's specular rays (`specular_trace`). `specular_samples` and
// `irradiance` are one buffer in turn (`RestirBuffers::rays`), both read_write.
@group(0) @binding(23) var<storage, read_write> specular_samples: array<SpecularSample>;
// Per pixel: the specular input of this frame (`shade` writes the reused reflection's ratio
// of rough pixels; `specular_resolve` the traced radiance of smooth ones) and the history of
// either (`specular_temporal`).
@group(0) @binding(24) var<storage, read_write> specular_noisy: array<vec2<u32>>;
// The specular history, one buffer updated in place, through `load_specular_history` and
// `store_specular_history`: per pixel its radiance or ratio (RGB9E5), then from entry
// `pixels` on a byte per pixel, four to a word, with its length and kind
// (`pack_specular_history`). Atomic, since four pixels store their bytes into one word.
// And the history each pixel found in the previous frame, copied out first (the whole entry;
// `specular_temporal`; one buffer with `resolved` in turn, `RestirBuffers::resolved`).
@group(0) @binding(25) var<storage, read_write> specular_history: array<atomic<u32>>;
@group(0) @binding(26) var<storage, read_write> specular_reprojected: array<vec2<u32>>;
// Per pixel: the G-buffer's emission and, in w, the material's occlusion factor.
@group(0) @binding(27) var<storage, read> gbuffer_emissive: array<vec4<f32>>;
// Per pixel with FLAG_BLEND_LAYER: the nearest blended surface in front (`gbuffer.blend_layer`).
@group(0) @binding(28) var<storage, read> gbuffer_blend_layer: array<vec4<f32>>;
// Per pixel: the previous frame's G-buffer depth and normal (the denoiser's,
// `gi::packing::pack_depth_normal`), which the specular history's surface is checked against.
@group(0) @binding(29) var<storage, read> previous_geometry: array<u32>;

// Row-major index of trace pixel `t`.
fn trace_index(t: vec2<u32>) -> u32 {
    return t.y * uniforms.trace_px.x + t.x;
}

// Where the specular reflection of pixel `pixel` (with G-buffer depth `depth`) comes from.
fn kind_of(pixel: u32, depth: f32) -> u32 {
    return specular_kind(uniforms.flags, uniforms.specular_max_roughness, depth, gbuffer_metallic_roughness[pixel].y);
}

// The point pixel `p` shows at G-buffer depth `depth` (distance along its camera ray).
fn world_position(p: vec2<u32>, depth: f32) -> vec3<f32> {
    return pixel_point(uniforms.camera, p, depth);
}

// This frame's receiver of trace pixel `index`.
fn load_surface(index: u32) -> Surface {
    let xy = receivers[index];
    if xy == NO_RECEIVER {
        return Surface(vec3(0.0), 0u, 0u, 0.0);
    }
    let pixel = receiver_pixel(xy);
    return receiver_at(xy, pixel, gbuffer_depth[pixel], gbuffer_normal[pixel]);
}

// The previous frame's receiver of trace pixel `index`.
fn load_surface_prev(index: u32) -> Surface {
    return surface_seen_by(surfaces_prev[index], uniforms.previous_camera);
}

// Pixel `pixel`'s specular history entry (`pack_specular_history`).
fn load_specular_history(pixel: u32) -> vec2<u32> {
    let pixels = uniforms.size_px.x * uniforms.size_px.y;
    let bytes = atomicLoad(&specular_history[pixels + pixel / 4u]);
    return vec2(atomicLoad(&specular_history[pixel]), (bytes >> (8u * (pixel % 4u))) & 0xffu);
}

// Stores pixel `pixel`'s specular history entry; its word's other bytes are left as they are,
// whatever order its four pixels store in.
fn store_specular_history(pixel: u32, entry: vec2<u32>) {
    let pixels = uniforms.size_px.x * uniforms.size_px.y;
    atomicStore(&specular_history[pixel], entry.x);
    let shift = 8u * (pixel % 4u);
    let word = pixels + pixel / 4u;
    atomicAnd(&specular_history[word], ~(0xffu << shift));
    atomicOr(&specular_history[word], (entry.y & 0xffu) << shift);
}

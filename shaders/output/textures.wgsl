// `output/textures`: a tier's frame as GPU textures an engine samples. The tiers write their
// images to `array<vec4<f32>>` buffers, one texel per pixel in row-major order; this pass
// copies the composited image into `image_out` and the GI term (the composited image minus
// the tier's direct light, unclamped: a noisy estimate may dip below zero) into `gi_out`.

struct OutputParams {
    size: vec2<u32>,
    // 1 when `direct` holds the direct light; 0: no GI term (`gi_out` is written black).
    has_direct: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> params: OutputParams;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> direct: array<vec4<f32>>;
@group(0) @binding(3) var image_out: texture_storage_2d<rgba16float, write>;
@group(0) @binding(4) var gi_out: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.size.x || id.y >= params.size.y {
        return;
    }
    let index = id.y * params.size.x + id.x;
    let color = image[index].rgb;
    var gi = vec3<f32>(0.0);
    if params.has_direct == 1u {
        gi = color - direct[index].rgb;
    }
    textureStore(image_out, vec2<i32>(id.xy), vec4<f32>(color, 1.0));
    textureStore(gi_out, vec2<i32>(id.xy), vec4<f32>(gi, 1.0));
}

// The viewer's one draw: the renderer's frame (an `rgba16float` texture of linear radiance),
// scaled to the window with nearest texels, encoded as the PNGs the product writes
// (`srgb_oetf(clamp(exposure * L, 0, 1))`), with the text overlay blended over its top left.

struct BlitParams {
    exposure: f32,
    // 1: encode sRGB here (the target is a UNORM format); 0: the target's format encodes it.
    encode_srgb: u32,
    pad: vec2<u32>,
}

@group(0) @binding(0) var frame: texture_2d<f32>;
@group(0) @binding(1) var overlay: texture_2d<f32>;
@group(0) @binding(2) var<uniform> params: BlitParams;

struct VertexOutput {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

// One triangle that covers the target: uv (0,0) at the top left.
@vertex
fn vs(@builtin(vertex_index) index: u32) -> VertexOutput {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: VertexOutput;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

fn srgb_oetf(x: vec3<f32>) -> vec3<f32> {
    let low = 12.92 * x;
    let high = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, x < vec3<f32>(0.0031308));
}

@fragment
fn fs(in: VertexOutput) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(frame));
    let texel = clamp(vec2<i32>(in.uv * size), vec2<i32>(0), vec2<i32>(size) - 1);
    var color = clamp(textureLoad(frame, texel, 0).rgb * params.exposure, vec3<f32>(0.0),
                      vec3<f32>(1.0));
    // NaN and negative estimates show black.
    color = select(color, vec3<f32>(0.0), color != color);
    let pixel = vec2<i32>(in.position.xy);
    let overlay_size = vec2<i32>(textureDimensions(overlay));
    if all(pixel < overlay_size) {
        let text = textureLoad(overlay, pixel, 0);
        color = mix(color, text.rgb, text.a);
    }
    if params.encode_srgb == 1u {
        color = srgb_oetf(color);
    }
    return vec4<f32>(color, 1.0);
}

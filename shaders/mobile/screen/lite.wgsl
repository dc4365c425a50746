// The mobile tier's lite deferred G-buffer (HSGI, GDC 2023, "Mobile Solution": one more 32-bit
// texture, diffuse color r8g8b7 + a dynamic-object mask bit, and an 8-bit encoded normal), the
// only per-pixel surface data the mobile GI passes read besides depth.
//
// One u32 per pixel:
//   bits  0- 7  sqrt(diffuse red)   (8 bits; gamma 2 keeps dark albedo precise)
//   bits  8-15  sqrt(diffuse green) (8 bits)
//   bits 16-22  sqrt(diffuse blue)  (7 bits)
//   bit  23     dynamic: the pixel shows a node moved by an animation
//   bits 24-31  normal: 4 + 4 bits of a hemisphere octahedral map in the pixel's view frame
// Sky pixels hold 0 (and +inf depth, from `gbuffer.depth`).
//
// The normal: the shading normal faces the camera, so it lies in the hemisphere around the
// direction back along the pixel's ray. It is written in that per-pixel frame (z back along the
// ray, x the camera's right made orthogonal to z), folded to the unit square by the hemisphere
// octahedral map and quantized to 16 x 16 cells with a dither of up to half a cell, so the
// quantization averages out over neighbouring pixels and frames (E[decoded cell coordinate]
// equals the exact coordinate away from the square's border).
#define_import_path gi::mobile::lite

#import gi::camera::Camera

const LITE_DYNAMIC_BIT: u32 = 0x00800000u;
const LITE_NORMAL_CELLS: f32 = 16.0;

// The orthonormal frame the normal of a pixel whose ray runs along `ray_dir` is stored in.
fn lite_frame(camera: Camera, ray_dir: vec3<f32>) -> mat3x3<f32> {
    let z = -ray_dir;
    let x = normalize(camera.right - z * dot(camera.right, z));
    let y = cross(z, x);
    return mat3x3<f32>(x, y, z);
}

// Packs a pixel. `n` is the unit shading normal (facing the camera), `ray_dir` the pixel's unit
// ray, `dither` two numbers in [-0.5, 0.5).
fn lite_encode(
    diffuse: vec3<f32>,
    dynamic: bool,
    n: vec3<f32>,
    camera: Camera,
    ray_dir: vec3<f32>,
    dither: vec2<f32>,
) -> u32 {
    let c = sqrt(clamp(diffuse, vec3(0.0), vec3(1.0)));
    let r = u32(round(c.x * 255.0));
    let g = u32(round(c.y * 255.0));
    let b = u32(round(c.z * 127.0));
    let frame = lite_frame(camera, ray_dir);
    // Local normal, clamped to the hemisphere around the frame's z.
    let local = vec3(dot(n, frame[0]), dot(n, frame[1]), max(dot(n, frame[2]), 0.0));
    let p = local.xy / max(abs(local.x) + abs(local.y) + local.z, 1e-8);
    let square = vec2(p.x + p.y, p.x - p.y); // the diamond |x|+|y| <= 1 rotated onto [-1,1]^2
    let cell = clamp(
        floor((square * 0.5 + 0.5) * LITE_NORMAL_CELLS + dither),
        vec2(0.0),
        vec2(LITE_NORMAL_CELLS - 1.0),
    );
    let normal_bits = u32(cell.x) | (u32(cell.y) << 4u);
    var bits = r | (g << 8u) | (b << 16u) | (normal_bits << 24u);
    if dynamic {
        bits |= LITE_DYNAMIC_BIT;
    }
    return bits;
}

// Diffuse albedo of a packed pixel.
fn lite_diffuse(bits: u32) -> vec3<f32> {
    let c = vec3(
        f32(bits & 0xffu) / 255.0,
        f32((bits >> 8u) & 0xffu) / 255.0,
        f32((bits >> 16u) & 0x7fu) / 127.0,
    );
    return c * c;
}

fn lite_is_dynamic(bits: u32) -> bool {
    return (bits & LITE_DYNAMIC_BIT) != 0u;
}

// Unit world normal of a packed pixel whose ray runs along `ray_dir` (the cell's center).
fn lite_normal(bits: u32, camera: Camera, ray_dir: vec3<f32>) -> vec3<f32> {
    let cell = vec2(f32((bits >> 24u) & 15u), f32(bits >> 28u));
    let square = (cell + 0.5) / LITE_NORMAL_CELLS * 2.0 - 1.0;
    let p = vec2(square.x + square.y, square.x - square.y) * 0.5;
    let local = vec3(p, max(1.0 - abs(p.x) - abs(p.y), 0.0));
    let frame = lite_frame(camera, ray_dir);
    return normalize(frame * local);
}

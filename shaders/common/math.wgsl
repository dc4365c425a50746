// Shared math for every GI shader: constants, luminance, pixel indexing, safe normalization and
// an orthonormal basis around a normal. The basis is Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited" (JCGT 6(1)), with the same axes as the CPU reference's `Frame::from_normal`, so
// GPU and CPU map the same local sample to the same world direction.
#define_import_path gi::math

const PI: f32 = 3.14159265358979323846;
const TWO_PI: f32 = 6.28318530717958647692;
const INV_PI: f32 = 0.31830988618379067154;
const INV_TWO_PI: f32 = 0.15915494309189533577;
const FLT_MAX: f32 = 3.40282347e38;

// Rec. 709 luminance of linear RGB (the reference's weights).
fn luminance(rgb: vec3<f32>) -> f32 {
    return dot(rgb, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// Row-major index of pixel `pixel` in an image `size` pixels wide and high.
fn image_index(pixel: vec2<i32>, size: vec2<u32>) -> u32 {
    return u32(pixel.y) * size.x + u32(pixel.x);
}

// Whether pixel `pixel` lies inside an image of `size` pixels.
fn image_contains(pixel: vec2<i32>, size: vec2<u32>) -> bool {
    return all(pixel >= vec2(0)) && all(pixel < vec2<i32>(size));
}

// `v` normalized, or the zero vector when `v` is too short to have a direction (instead of
// the NaNs `normalize` gives), so degenerate geometry cannot poison accumulations.
fn safe_normalize(v: vec3<f32>) -> vec3<f32> {
    let length_sq = dot(v, v);
    if length_sq > 1e-30 {
        return v * inverseSqrt(length_sq);
    }
    return vec3<f32>(0.0);
}

// Columns x, y, z of an orthonormal basis whose z axis is the unit vector `n` (Duff et al.
// 2017, branchless): `world_from_tangent(n) * v_local` turns a local direction into world
// space, and `transpose(world_from_tangent(n)) * v_world` goes back. The sign is read from the
// sign bit, as the reference's `copysign` does, so a normal with z = -0.0 (common on
// axis-aligned walls) gets the same tangents on the CPU and the GPU.
fn world_from_tangent(n: vec3<f32>) -> mat3x3<f32> {
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let x = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let y = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return mat3x3<f32>(x, y, n);
}

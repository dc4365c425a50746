// Scene data of the GPU path tracer (`path/trace.wgsl`, gi-reference's transport contract):
// per-triangle geometry and shading attributes in the frame's original triangle order,
// materials, textures packed in one texel buffer, the emitter power table and the punctual
// lights, with the lookups the reference does on them. Mirrors `gi_gpu::GpuScene`; a test
// checks the struct layouts.
#define_import_path gi::scene

#import gi::brdf::{is_finite, DielectricSpecular, dielectric_specular_new}

// Texture index meaning "none" (`gi_gpu::NO_TEXTURE`): samples as white.
const NO_TEXTURE: u32 = 0xffffffffu;

// Mirror of `gi_gpu::GpuTriangleShading`: vertices, then normals with the u coordinate in w.
struct TriangleShading {
    pa: vec4<f32>,
    pb: vec4<f32>,
    pc: vec4<f32>,
    na: vec4<f32>,
    nb: vec4<f32>,
    nc: vec4<f32>,
    v: vec3<f32>,
    material: u32,
}

// Mirror of `gi_gpu::GpuMaterial`.
struct Material {
    base_color: vec4<f32>,
    emissive: vec3<f32>,
    metallic: f32,
    roughness: f32,
    base_color_texture: u32,
    metallic_roughness_texture: u32,
    emissive_texture: u32,
    double_sided: u32,
    specular: f32,
    ior: f32,
    specular_texture: u32,
    specular_color: vec3<f32>,
    specular_color_texture: u32,
}

// Mirror of `gi_gpu::GpuTextureInfo`.
struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    pad_a: u32,
}

// Mirror of `gi_gpu::GpuEmitter`: a triangle and the integer cdf threshold of its entry.
struct Emitter {
    triangle: u32,
    threshold: u32,
}

// Mirror of `gi_gpu::GpuLight`.
struct PunctualLight {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    range: f32,
    intensity: vec3<f32>,
    has_range: u32,
    cos_outer: f32,
    spot_scale: f32,
    pad_a: u32,
    pad_b: u32,
}

@group(0) @binding(1) var<storage, read> triangles: array<TriangleShading>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> textures: array<TextureInfo>;
@group(0) @binding(4) var<storage, read> texels: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(6) var<storage, read> selection: array<f32>;
@group(0) @binding(7) var<storage, read> lights: array<PunctualLight>;

// glam's `lerp`, `a (1 - s) + b s`, written out so the rounding is the reference's.
fn lerp_rgb(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a * (1.0 - s) + b * s;
}

fn lerp_rgba(a: vec4<f32>, b: vec4<f32>, s: f32) -> vec4<f32> {
    return a * (1.0 - s) + b * s;
}

// Texel (ix, iy) with repeat wrapping (Euclidean remainder, as the reference's `rem_euclid`).
fn texel(info: TextureInfo, ix: i32, iy: i32) -> vec4<f32> {
    let w = i32(info.width);
    let h = i32(info.height);
    let x = ((ix % w) + w) % w;
    let y = ((iy % h) + h) % h;
    return texels[info.offset + u32(y * w + x)];
}

// `gi_scene::Texture::sample_bilinear`: repeat wrap, texel centers at half-integers; white
// when there is no texture.
fn sample_texture(index: u32, uv: vec2<f32>) -> vec4<f32> {
    if index == NO_TEXTURE {
        return vec4<f32>(1.0);
    }
    let info = textures[index];
    let x = uv.x * f32(info.width) - 0.5;
    let y = uv.y * f32(info.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let ix = i32(x0);
    let iy = i32(y0);
    let top = lerp_rgba(texel(info, ix, iy), texel(info, ix + 1, iy), fx);
    let bottom = lerp_rgba(texel(info, ix, iy + 1), texel(info, ix + 1, iy + 1), fx);
    return lerp_rgba(top, bottom, fy);
}
// The dielectric's specular layer of `material` at `uv` (the reference's
// `dielectric_specular`): specular factor x texture alpha, color x texture rgb, the ior.
fn dielectric_specular(material: Material, uv: vec2<f32>) -> DielectricSpecular {
    let weight = material.specular * sample_texture(material.specular_texture, uv).w;
    let color = material.specular_color * sample_texture(material.specular_color_texture, uv).xyz;
    return dielectric_specular_new(weight, color, material.ior);
}

fn emission(material: Material, uv: vec2<f32>) -> vec3<f32> {
    if all(material.emissive == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    return material.emissive * sample_texture(material.emissive_texture, uv).xyz;
}

// `(v1 - v0) x (v2 - v0)`, normalized as the reference does (zero when degenerate).
fn geometric_normal(tri: TriangleShading) -> vec3<f32> {
    let c = cross(tri.pb.xyz - tri.pa.xyz, tri.pc.xyz - tri.pa.xyz);
    let len = sqrt(dot(c, c));
    if len == 0.0 {
        return vec3<f32>(0.0);
    }
    return c * (1.0 / len);
}

fn triangle_uv(tri: TriangleShading, b0: f32, b1: f32, b2: f32) -> vec2<f32> {
    let u = tri.na.w * b0 + tri.nb.w * b1 + tri.nc.w * b2;
    let v = tri.v.x * b0 + tri.v.y * b1 + tri.v.z * b2;
    return vec2<f32>(u, v);
}

// The material of `triangle`; indices at or past `default_material` (the index of the
// appended glTF default material) fall back to it, as the reference does.
fn material_of(triangle: u32, default_material: u32) -> Material {
    let index = triangles[triangle].material;
    return materials[select(default_material, index, index < default_material)];
}

// The reference's shading normal: the interpolated vertex normal `n` flipped to the side of
// the camera-facing geometric normal `ng`, or `ng` itself where `n` is degenerate or where the
// viewer direction `wo` is below its horizon.
fn shading_normal(ng: vec3<f32>, n: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let n_len = sqrt(dot(n, n));
    var ns = ng;
    if n_len > 0.0 && is_finite(1.0 / n_len) {
        ns = n * (1.0 / n_len);
    }
    if dot(ns, ng) < 0.0 {
        ns = -ns;
    }
    if dot(ns, wo) <= 1e-6 {
        ns = ng;
    }
    return ns;
}

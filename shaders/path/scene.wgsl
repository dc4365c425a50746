// Scene data of the GPU path tracer (`path/trace.wgsl`, gi-reference's transport contract):
// per-triangle geometry and shading attributes in the frame's original triangle order,
// materials, texture references into the texture arrays of bind group 3 (`gi_gpu::textures`),
// the emitter power table and the punctual lights, with the lookups the reference does on
// them: texture sampling, normal mapping and alpha coverage. Mirrors `gi_gpu::GpuScene`; a
// test checks the struct layouts.
#define_import_path gi::scene

#import gi::brdf::{is_finite, Brdf, DielectricSpecular, brdf_new, brdf_with_specular, dielectric_specular_new}

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
    normal_texture: u32,
    normal_scale: f32,
    alpha_mode: u32,
    alpha_cutoff: f32,
    occlusion_texture: u32,
    occlusion_strength: f32,
    pad_a: u32,
    pad_b: u32,
}

// `Material::alpha_mode` (`gi_gpu::ALPHA_*`).
const ALPHA_OPAQUE: u32 = 0u;
const ALPHA_MASK: u32 = 1u;
const ALPHA_BLEND: u32 = 2u;

// Mirror of `gi_gpu::GpuTextureRef`: the array layer (`image`: layer in bits 0..24, size class
// in 24..28, sRGB in bit 28) and the texture-coordinate transform with the layer's tiling.
struct TextureRef {
    image: u32,
    tex_coord: u32,
    size: f32,
    pad_a: u32,
    row_u: vec4<f32>,
    row_v: vec4<f32>,
}

// Mirror of `gi_gpu::GpuTriangleExtras`: tangents (w: bitangent sign) and TEXCOORD_1.
struct TriangleExtras {
    ta: vec4<f32>,
    tb: vec4<f32>,
    tc: vec4<f32>,
    uv_ab: vec4<f32>,
    uv_c: vec2<f32>,
    pad_a: vec2<f32>,
}

// Where a surface point samples its textures: TEXCOORD_0 there, the barycentrics and the
// triangle (for TEXCOORD_1, read only when a texture asks for it), and the width of the
// pixel's footprint in TEXCOORD_0 units (0: level 0 with the reference's exact bilinear
// filter; above 0: trilinear at the level the footprint covers).
struct TexCoords {
    uv: vec2<f32>,
    footprint: f32,
    triangle: u32,
    b: vec3<f32>,
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
@group(0) @binding(3) var<storage, read> texture_refs: array<TextureRef>;
@group(0) @binding(4) var<storage, read> triangle_extras: array<TriangleExtras>;
@group(0) @binding(5) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(6) var<storage, read> selection: array<f32>;
@group(0) @binding(7) var<storage, read> lights: array<PunctualLight>;

// Bind group 3 (`gi_gpu::SceneTextures`): a trilinear repeating sampler and one `Rgba8Unorm`
// texture array per size class (64, 128, ..., 2048 texels: classes a..f) holding the stored
// 8-bit values.
@group(3) @binding(0) var texture_sampler: sampler;
@group(3) @binding(1) var texture_class_a: texture_2d_array<f32>;
@group(3) @binding(2) var texture_class_b: texture_2d_array<f32>;
@group(3) @binding(3) var texture_class_c: texture_2d_array<f32>;
@group(3) @binding(4) var texture_class_d: texture_2d_array<f32>;
@group(3) @binding(5) var texture_class_e: texture_2d_array<f32>;
@group(3) @binding(6) var texture_class_f: texture_2d_array<f32>;

const TEXTURE_LAYER_MASK: u32 = 0xffffffu;
const TEXTURE_SRGB_BIT: u32 = 0x10000000u;

// glam's `lerp`, `a (1 - s) + b s`, written out so the rounding is the reference's.
fn lerp_rgb(a: vec3<f32>, b: vec3<f32>, s: f32) -> vec3<f32> {
    return a * (1.0 - s) + b * s;
}

fn lerp_rgba(a: vec4<f32>, b: vec4<f32>, s: f32) -> vec4<f32> {
    return a * (1.0 - s) + b * s;
}

// The exact sRGB EOTF on the color channels of an sRGB-encoded image's value (alpha is
// linear), as `gi_scene::Texture::decode`; data images as stored.
fn decode_texel(image: u32, value: vec4<f32>) -> vec4<f32> {
    if (image & TEXTURE_SRGB_BIT) == 0u {
        return value;
    }
    let c = value.xyz;
    let curve = pow((c + 0.055) / 1.055, vec3(2.4));
    return vec4(select(curve, c / 12.92, c <= vec3(0.04045)), value.w);
}

// Texel `texel` of level `level` of the layer `image` names, decoded to linear values.
fn image_load(image: u32, texel: vec2<i32>, level: i32) -> vec4<f32> {
    let layer = i32(image & TEXTURE_LAYER_MASK);
    var value: vec4<f32>;
    switch (image >> 24u) & 0xfu {
        case 0u: { value = textureLoad(texture_class_a, texel, layer, level); }
        case 1u: { value = textureLoad(texture_class_b, texel, layer, level); }
        case 2u: { value = textureLoad(texture_class_c, texel, layer, level); }
        case 3u: { value = textureLoad(texture_class_d, texel, layer, level); }
        case 4u: { value = textureLoad(texture_class_e, texel, layer, level); }
        default: { value = textureLoad(texture_class_f, texel, layer, level); }
    }
    return decode_texel(image, value);
}

// Trilinear sample of the layer `image` names at layer coordinate `uv`, mip level `level`,
// decoded to linear values.
fn image_sample(image: u32, uv: vec2<f32>, level: f32) -> vec4<f32> {
    let layer = i32(image & TEXTURE_LAYER_MASK);
    var value: vec4<f32>;
    switch (image >> 24u) & 0xfu {
        case 0u: { value = textureSampleLevel(texture_class_a, texture_sampler, uv, layer, level); }
        case 1u: { value = textureSampleLevel(texture_class_b, texture_sampler, uv, layer, level); }
        case 2u: { value = textureSampleLevel(texture_class_c, texture_sampler, uv, layer, level); }
        case 3u: { value = textureSampleLevel(texture_class_d, texture_sampler, uv, layer, level); }
        case 4u: { value = textureSampleLevel(texture_class_e, texture_sampler, uv, layer, level); }
        default: { value = textureSampleLevel(texture_class_f, texture_sampler, uv, layer, level); }
    }
    return decode_texel(image, value);
}

// Texel (ix, iy) of level 0 with repeat wrapping (Euclidean remainder, as the reference's
// `rem_euclid`).
fn layer_texel(image: u32, size: i32, ix: i32, iy: i32) -> vec4<f32> {
    let x = ((ix % size) + size) % size;
    let y = ((iy % size) + size) % size;
    return image_load(image, vec2(x, y), 0);
}

// TEXCOORD_1 of the point `tc` names.
fn second_uv(tc: TexCoords) -> vec2<f32> {
    let e = triangle_extras[tc.triangle];
    return e.uv_ab.xy * tc.b.x + e.uv_ab.zw * tc.b.y + e.uv_c * tc.b.z;
}

// The texture coordinate set a reference reads, in layer coordinates.
fn layer_uv(r: TextureRef, tc: TexCoords) -> vec2<f32> {
    var uv = tc.uv;
    if r.tex_coord == 1u {
        uv = second_uv(tc);
    }
    return vec2(dot(r.row_u.xyz, vec3(uv, 1.0)), dot(r.row_v.xyz, vec3(uv, 1.0)));
}

// Texture reference `index` at `tc` in linear values; white when there is none. Where the
// footprint covers more than a texel, the hardware filters trilinearly at the level whose texels
// match it; otherwise (a zero footprint included) level 0 is read with
// `gi_scene::Texture::sample_bilinear`'s filter (repeat wrap, texel centers at half-integers,
// the same texels, so the reference's values).
fn sample_texture(index: u32, tc: TexCoords) -> vec4<f32> {
    if index == NO_TEXTURE {
        return vec4<f32>(1.0);
    }
    let r = texture_refs[index];
    let uv = layer_uv(r, tc);
    if tc.footprint > 0.0 {
        // Layer texels per TEXCOORD unit: the transform's area scale, times the layer size.
        let stretch = sqrt(abs(r.row_u.x * r.row_v.y - r.row_u.y * r.row_v.x));
        let level = log2(max(tc.footprint * stretch * r.size, 1e-8));
        // Minified: the hardware's trilinear filter. Magnified, level 0 is what any filter
        // reads, and the exact one below reads it as the reference does.
        if level > 0.0 {
            return image_sample(r.image, uv, level);
        }
    }
    let size = i32(r.size);
    let x = uv.x * r.size - 0.5;
    let y = uv.y * r.size - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let ix = i32(x0);
    let iy = i32(y0);
    let top = lerp_rgba(layer_texel(r.image, size, ix, iy), layer_texel(r.image, size, ix + 1, iy), fx);
    let bottom = lerp_rgba(layer_texel(r.image, size, ix, iy + 1), layer_texel(r.image, size, ix + 1, iy + 1), fx);
    return lerp_rgba(top, bottom, fy);
}

// Where the point of `triangle` at barycentrics `b` (weights of v0, v1, v2) samples its
// textures, for a footprint of `footprint` TEXCOORD_0 units (0: exact level 0).
fn tex_coords(triangle: u32, b: vec3<f32>, footprint: f32) -> TexCoords {
    let tri = triangles[triangle];
    return TexCoords(triangle_uv(tri, b.x, b.y, b.z), footprint, triangle, b);
}

// Width in TEXCOORD_0 units of a ray cone of width `cone_width` (world units) meeting the
// triangle at cosine `cos_theta` (Akenine-Moller et al., "Improved Shader and Texture Level of
// Detail Using Ray Cones", JCGT 2021: the texel-to-world area ratio of the triangle, and the
// cone's footprint stretched by the incidence).
fn cone_footprint(tri: TriangleShading, cone_width: f32, cos_theta: f32) -> f32 {
    let world = length(cross(tri.pb.xyz - tri.pa.xyz, tri.pc.xyz - tri.pa.xyz));
    let ua = vec2(tri.na.w, tri.v.x);
    let ub = vec2(tri.nb.w, tri.v.y) - ua;
    let uc = vec2(tri.nc.w, tri.v.z) - ua;
    let texture = abs(ub.x * uc.y - ub.y * uc.x);
    if world <= 0.0 || texture <= 0.0 {
        return 0.0;
    }
    return cone_width / max(abs(cos_theta), 0.05) * sqrt(texture / world);
}

// `gi_scene::blend_coverage_hash`: uniform in [0, 1) from the triangle and its barycentrics
// quantized to 1/4096.
fn blend_coverage_hash(triangle: u32, b1: f32, b2: f32) -> f32 {
    let q1 = u32(clamp(b1, 0.0, 1.0) * 4096.0);
    let q2 = u32(clamp(b2, 0.0, 1.0) * 4096.0);
    var h = (triangle * 0x9e3779b9u) ^ (q1 * 0x85ebca6bu);
    h ^= q2 * 0xc2b2ae35u;
    h = h * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// The alpha that covers the surface at `tc`: the base color factor's alpha times its texture's.
fn material_alpha(material: Material, tc: TexCoords) -> f32 {
    return material.base_color.w * sample_texture(material.base_color_texture, tc).w;
}

// How `alpha_covers` treats `BLEND` surfaces in this invocation: hashed (the rule every tier's
// rays follow, `blend_coverage_hash`), always passed or always hit. The G-buffer uses the
// latter two to find the surface behind a blended layer and the layer itself.
const BLEND_HASHED: u32 = 0u;
const BLEND_PASS: u32 = 1u;
const BLEND_OPAQUE: u32 = 2u;
var<private> blend_policy: u32 = BLEND_HASHED;

fn set_blend_policy(policy: u32) {
    blend_policy = policy;
}

// The reference's `Reference::covers`: whether the surface of `triangle` exists at
// barycentrics `b` (weights of v1 and v2) for a ray. Only called for triangles whose material
// is alpha-tested (their material index is in range).
fn alpha_covers(triangle: u32, b: vec2<f32>) -> bool {
    let tri = triangles[triangle];
    let material = materials[tri.material];
    if material.alpha_mode == ALPHA_OPAQUE {
        return true;
    }
    if material.alpha_mode == ALPHA_BLEND && blend_policy != BLEND_HASHED {
        return blend_policy == BLEND_OPAQUE;
    }
    let alpha = material_alpha(material, tex_coords(triangle, vec3(1.0 - b.x - b.y, b.x, b.y), 0.0));
    if material.alpha_mode == ALPHA_MASK {
        return alpha >= material.alpha_cutoff;
    }
    return blend_coverage_hash(triangle, b.x, b.y) < alpha;
}

// How much of the surface of `triangle` exists at barycentrics `b` (weights of v0, v1, v2), for
// the cache's voxel coverage: 1 for opaque materials, 1 or 0 by the cutoff for `MASK`, the
// alpha for `BLEND` (`gi_cache::cpu_voxelize::coverage_at` on the CPU).
fn surface_coverage(triangle: u32, default_material: u32, b: vec3<f32>) -> f32 {
    let material = material_of(triangle, default_material);
    if material.alpha_mode == ALPHA_OPAQUE {
        return 1.0;
    }
    let alpha = material_alpha(material, tex_coords(triangle, b, 0.0));
    if material.alpha_mode == ALPHA_MASK {
        return select(0.0, 1.0, alpha >= material.alpha_cutoff);
    }
    return clamp(alpha, 0.0, 1.0);
}

// `n` (unit) tilted by `material`'s normal map at `tc`, as the reference's `mapped_normal`:
// the map's xy scaled by `normal_scale` in the frame of the interpolated tangent made
// orthogonal to `n`, bitangent `sign * n x tangent`; `n` itself without a map or a tangent.
fn mapped_normal(material: Material, n: vec3<f32>, tc: TexCoords) -> vec3<f32> {
    if material.normal_texture == NO_TEXTURE {
        return n;
    }
    let e = triangle_extras[tc.triangle];
    let t = (e.ta * tc.b.x + e.tb * tc.b.y + e.tc * tc.b.z).xyz;
    let tangent = normalize_or(t - n * dot(n, t), vec3(0.0));
    if all(tangent == vec3(0.0)) {
        return n;
    }
    let sign = select(1.0, -1.0, e.ta.w < 0.0);
    let bitangent = cross(n, tangent) * sign;
    let m = (sample_texture(material.normal_texture, tc).xyz * 2.0 - 1.0)
        * vec3(material.normal_scale, material.normal_scale, 1.0);
    return normalize_or(tangent * m.x + bitangent * m.y + n * m.z, n);
}

// glam's `normalize_or`: `v / |v|` (times the reciprocal length), or `fallback` where that is
// not finite or zero.
fn normalize_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let rcp = 1.0 / sqrt(dot(v, v));
    if is_finite(rcp) && rcp > 0.0 {
        return v * rcp;
    }
    return fallback;
}

// The dielectric's specular layer of `material` at `uv` (the reference's
// `dielectric_specular`): specular factor x texture alpha, color x texture rgb, the ior.
fn dielectric_specular(material: Material, tc: TexCoords) -> DielectricSpecular {
    let weight = material.specular * sample_texture(material.specular_texture, tc).w;
    let color = material.specular_color * sample_texture(material.specular_color_texture, tc).xyz;
    return dielectric_specular_new(weight, color, material.ior);
}

// The BRDF of `material` at `tc`: base color, metallic-roughness and the dielectric's specular
// layer, factors times textures (the reference's `Reference::brdf`).
fn material_brdf(material: Material, tc: TexCoords) -> Brdf {
    let base = material.base_color.xyz * sample_texture(material.base_color_texture, tc).xyz;
    let mr = sample_texture(material.metallic_roughness_texture, tc);
    return brdf_with_specular(
        brdf_new(base, material.metallic * mr.z, material.roughness * mr.y),
        dielectric_specular(material, tc),
    );
}

fn emission(material: Material, tc: TexCoords) -> vec3<f32> {
    if all(material.emissive == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    return material.emissive * sample_texture(material.emissive_texture, tc).xyz;
}

// The material's ambient occlusion factor at `tc`: `1 + strength * (texel.r - 1)` of its
// `occlusionTexture`, 1 without one. Only the real-time tiers read it, on the indirect diffuse
// light they gather (glTF: "areas that receive less indirect lighting"); the path tracers trace
// the occlusion the geometry makes and never read the map.
fn material_occlusion(material: Material, tc: TexCoords) -> f32 {
    if material.occlusion_texture == NO_TEXTURE {
        return 1.0;
    }
    let ao = sample_texture(material.occlusion_texture, tc).x;
    return clamp(1.0 + material.occlusion_strength * (ao - 1.0), 0.0, 1.0);
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
    return orient_shading_normal(ng, normalize_or(n, ng), wo);
}

// The unit shading normal `ns` flipped to the side of `ng`, or `ng` where the viewer direction
// `wo` is below its horizon.
fn orient_shading_normal(ng: vec3<f32>, ns: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    var n = ns;
    if dot(n, ng) < 0.0 {
        n = -n;
    }
    if dot(n, wo) <= 1e-6 {
        n = ng;
    }
    return n;
}

// The G-buffer pass `gbuffer/primary`: for every pixel, one closest-hit ray through the pixel
// center, and what the path tier would see at that first hit: distance, shading normal,
// textured base color, metallic and roughness, front-face emission, the triangle, and the
// screen-space motion of the surface point since the previous frame.
//
// Ray cast rather than rasterized: the rays are the reference's `CameraView::ray_direction`
// through pixel centers and the hits come from the same CWBVH traversal (`gi::bvh`) as the
// path tier's, so every G-buffer texel describes exactly the surface the CPU reference and the
// path tier find first. It keeps one code path (no vertex pipeline, no second copy of the
// geometry) at the cost of one closest-hit ray per pixel.
//
// Motion vectors: the hit point goes through its node's `previous_from_current` (the previous
// frame's world_from_node times this frame's node_from_world; the exact identity for nodes that
// did not move), which gives where the same surface point was; it is projected with the
// previous camera. Sky pixels project their direction
// (a point at infinity), so only camera rotation moves them.
//
// Bind group 0: uniforms, the scene (`gi_gpu::GpuScene`, declared in `path/scene.wgsl`), the
// per-node motion transforms, the outputs. Bind group 1: the BVH (`gi_gpu::bvh::GpuBvh`).

#import gi::bvh::{Ray, Hit, trace_closest, BVH_MISS}
#import gi::scene::{TriangleShading, triangles, sample_texture, emission, material_occlusion, material_brdf, material_alpha, set_blend_policy, BLEND_PASS, BLEND_OPAQUE, ALPHA_BLEND, Material, dielectric_specular, geometric_normal, material_of, tex_coords, cone_footprint, mapped_normal, normalize_or, orient_shading_normal}
#import gi::packing::pack_unit_vector
#import gi::brdf::{pack_dielectric_specular, brdf_split_sum_albedos}
#import gi::camera::{Camera, camera_ray, camera_project}

const FAR: f32 = 3.40282347e38;
// Bits of +infinity, the depth of sky pixels.
const INFINITY_BITS: u32 = 0x7f800000u;

// Mirror of `gi_gpu::gbuffer::GBufferUniforms`.
struct GBufferUniforms {
    camera: Camera,
    previous_camera: Camera,
    size_px: vec2<u32>,
    default_material: u32,
    // 1 when `previous_from_current` holds the previous frame's node motion.
    has_previous_transforms: u32,
    // 1 when the scene has alpha-`BLEND` materials and `blend_layer` is one entry per pixel.
    blend_layer_on: u32,
    // 1 when `previous_triangles` holds the previous frame's triangles.
    has_previous_triangles: u32,
}

@group(0) @binding(0) var<uniform> uniforms: GBufferUniforms;
// Per scene node, the map from this frame's world position of a point on the node to the
// previous frame's, as rows: `previous = vec4(p, 1) * previous_from_current[node]`.
@group(0) @binding(8) var<storage, read> previous_from_current: array<mat3x4<f32>>;
// Hit distance along the unit camera ray; +infinity for sky.
@group(0) @binding(9) var<storage, read_write> depth: array<f32>;
// World shading normal facing the camera, octahedral-packed (`gi::packing`); 0 for sky.
@group(0) @binding(10) var<storage, read_write> normal: array<u32>;
// Textured linear base color (rgb, w 1); 0 for sky.
@group(0) @binding(11) var<storage, read_write> base_color: array<vec4<f32>>;
// Textured metallic (x) and perceptual roughness (y); 0 for sky.
@group(0) @binding(12) var<storage, read_write> metallic_roughness: array<vec2<f32>>;
// Emitted radiance toward the camera (rgb) and the material's occlusion factor (w,
// `gi::scene::material_occlusion`); 0 for sky.
@group(0) @binding(13) var<storage, read_write> emissive: array<vec4<f32>>;
// Frame triangle index; BVH_MISS for sky.
@group(0) @binding(14) var<storage, read_write> triangle_id: array<u32>;
// Previous pixel position minus this pixel's center, in pixels (+x right, +y down).
@group(0) @binding(15) var<storage, read_write> motion: array<vec2<f32>>;
// The nearest alpha-`BLEND` surface in front of the pixel's surface (`blend_layer_on` only):
// distance along the unit camera ray (0: none), its normal facing the camera (packed, as bits),
// its albedo towards the camera (the split-sum diffuse plus specular, sqrt-encoded 8-bit rgb,
// as bits) and its alpha.
@group(0) @binding(16) var<storage, read_write> blend_layer: array<vec4<f32>>;
// The previous frame's `triangles` (scenes with skinned or morphed meshes), else one entry.
@group(0) @binding(17) var<storage, read> previous_triangles: array<TriangleShading>;

// `blend_layer`'s entry for `hit`, an alpha-`BLEND` surface of `material` along the camera
// ray `dir`, whose cone spreads by `spread` per unit of distance.
fn blend_layer_entry(hit: Hit, material: Material, dir: vec3<f32>, spread: f32) -> vec4<f32> {
    let tri = triangles[hit.triangle];
    let b = vec3(1.0 - hit.barycentrics.x - hit.barycentrics.y, hit.barycentrics.x, hit.barycentrics.y);
    let wo = -dir;
    var ng = geometric_normal(tri);
    if all(ng == vec3<f32>(0.0)) {
        ng = wo;
    }
    ng = select(-ng, ng, dot(ng, wo) >= 0.0);
    let tc = tex_coords(hit.triangle, b, cone_footprint(tri, hit.t * spread, dot(ng, wo)));
    let alpha = clamp(material_alpha(material, tc), 0.0, 1.0);
    let albedos = brdf_split_sum_albedos(material_brdf(material, tc), max(dot(ng, wo), 0.0));
    let albedo = clamp(albedos.diffuse + albedos.specular, vec3(0.0), vec3(1.0));
    return vec4<f32>(
        hit.t,
        bitcast<f32>(pack_unit_vector(ng)),
        bitcast<f32>(pack4x8unorm(vec4(sqrt(albedo), 0.0))),
        alpha,
    );
}

@compute @workgroup_size(8, 8)
fn primary(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = uniforms.size_px;
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let pixel = id.y * size.x + id.x;
    let center = vec2<f32>(f32(id.x) + 0.5, f32(id.y) + 0.5);
    let camera = uniforms.camera;
    let dir = camera_ray(camera, center / vec2<f32>(size));
    // With blended surfaces, the G-buffer holds the surface behind them, and the nearest
    // blended layer in front of it goes to `blend_layer`. The first ray stops at blended
    // surfaces; only when it stops at one does a second ray pass them (all of them: one layer).
    var hit: Hit;
    if uniforms.blend_layer_on != 0u {
        set_blend_policy(BLEND_OPAQUE);
        hit = trace_closest(Ray(camera.position, 0.0, dir, FAR));
        var layer = vec4<f32>(0.0);
        if hit.triangle != BVH_MISS {
            let front = material_of(hit.triangle, uniforms.default_material);
            if front.alpha_mode == ALPHA_BLEND {
                layer = blend_layer_entry(hit, front, dir, 2.0 * camera.tan_half_fov / f32(size.y));
                set_blend_policy(BLEND_PASS);
                hit = trace_closest(Ray(camera.position, 0.0, dir, FAR));
            }
        }
        blend_layer[pixel] = layer;
    } else {
        hit = trace_closest(Ray(camera.position, 0.0, dir, FAR));
    }
    triangle_id[pixel] = hit.triangle;
    if hit.triangle == BVH_MISS {
        depth[pixel] = bitcast<f32>(INFINITY_BITS);
        normal[pixel] = 0u;
        base_color[pixel] = vec4<f32>(0.0);
        metallic_roughness[pixel] = vec2<f32>(0.0);
        emissive[pixel] = vec4<f32>(0.0);
        let previous = camera_project(uniforms.previous_camera, dir, uniforms.size_px);
        motion[pixel] = select(vec2<f32>(0.0), previous.xy - center, previous.z > 0.0);
        return;
    }
    depth[pixel] = hit.t;

    let tri = triangles[hit.triangle];
    let b1 = hit.barycentrics.x;
    let b2 = hit.barycentrics.y;
    let b0 = 1.0 - b1 - b2;
    let wo = -dir;
    var ng_front = geometric_normal(tri);
    if all(ng_front == vec3<f32>(0.0)) {
        ng_front = wo;
    }
    let front_facing = dot(ng_front, wo) >= 0.0;
    let ng = select(-ng_front, ng_front, front_facing);
    let material = material_of(hit.triangle, uniforms.default_material);
    // Textures prefiltered over the pixel's ray cone: its width grows by the pixel's angle
    // (2 tan(fov / 2) / height) per unit of distance.
    let spread = 2.0 * camera.tan_half_fov / f32(size.y);
    let footprint = cone_footprint(tri, hit.t * spread, dot(ng, wo));
    let tc = tex_coords(hit.triangle, vec3(b0, b1, b2), footprint);
    let n = tri.na.xyz * b0 + tri.nb.xyz * b1 + tri.nc.xyz * b2;
    let ns = orient_shading_normal(ng, mapped_normal(material, normalize_or(n, ng), tc), wo);
    normal[pixel] = pack_unit_vector(ns);

    let base = material.base_color.xyz * sample_texture(material.base_color_texture, tc).xyz;
    base_color[pixel] = vec4<f32>(base, pack_dielectric_specular(dielectric_specular(material, tc)));
    let mr = sample_texture(material.metallic_roughness_texture, tc);
    metallic_roughness[pixel] = vec2<f32>(material.metallic * mr.z, material.roughness * mr.y);
    var emitted = vec3<f32>(0.0);
    if front_facing || material.double_sided != 0u {
        emitted = emission(material, tc);
    }
    emissive[pixel] = vec4<f32>(emitted, material_occlusion(material, tc));

    // Where the surface point was: the same barycentric point of the triangle as the
    // previous frame placed it (deforming meshes), else moved back by its node's motion (node
    // index in `pa.w`).
    var p = tri.pa.xyz + (tri.pb.xyz - tri.pa.xyz) * b1 + (tri.pc.xyz - tri.pa.xyz) * b2;
    if uniforms.has_previous_triangles != 0u {
        let was = previous_triangles[hit.triangle];
        p = was.pa.xyz + (was.pb.xyz - was.pa.xyz) * b1 + (was.pc.xyz - was.pa.xyz) * b2;
    } else if uniforms.has_previous_transforms != 0u {
        p = vec4<f32>(p, 1.0) * previous_from_current[u32(tri.pa.w)];
    }
    let previous = camera_project(uniforms.previous_camera, p - uniforms.previous_camera.position, uniforms.size_px);
    motion[pixel] = select(vec2<f32>(0.0), previous.xy - center, previous.z > 0.0);
}

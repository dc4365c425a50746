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
// Motion vectors: the scene evaluated at the previous time has the same triangle order, so the
// hit's barycentrics applied to the previous frame's triangle give where the same surface
// point was; it is projected with the previous camera. Sky pixels project their direction
// (a point at infinity), so only camera rotation moves them.
//
// Bind group 0: uniforms, the scene (`gi_gpu::GpuScene`, declared in `path/scene.wgsl`), the
// previous triangle positions, the outputs. Bind group 1: the BVH (`gi_gpu::bvh::GpuBvh`).

#import gi::bvh::{Ray, trace_closest, BVH_MISS}
#import gi::scene::{triangles, sample_texture, emission, geometric_normal, triangle_uv, material_of, shading_normal}
#import gi::packing::pack_unit_vector

const FAR: f32 = 3.40282347e38;
// Bits of +infinity, the depth of sky pixels.
const INFINITY_BITS: u32 = 0x7f800000u;

// A pinhole camera as `gi_scene::CameraView` holds it, with the values the reference derives
// from it. Mirror of `gi_gpu::gbuffer::GBufferCamera`.
struct GBufferCamera {
    position: vec3<f32>,
    // tan(yfov / 2), computed on the CPU as the reference does.
    tan_half_fov: f32,
    right: vec3<f32>,
    // width / height.
    aspect: f32,
    up: vec3<f32>,
    pad_a: f32,
    forward: vec3<f32>,
    pad_b: f32,
}

// Mirror of `gi_gpu::gbuffer::GBufferUniforms`.
struct GBufferUniforms {
    camera: GBufferCamera,
    previous_camera: GBufferCamera,
    size_px: vec2<u32>,
    default_material: u32,
    // 1 when `previous_positions` holds the previous frame's triangles.
    has_previous_positions: u32,
}

@group(0) @binding(0) var<uniform> uniforms: GBufferUniforms;
// Per frame triangle, the previous frame's world positions of v0, v1, v2 (w unused).
@group(0) @binding(8) var<storage, read> previous_positions: array<vec4<f32>>;
// Hit distance along the unit camera ray; +infinity for sky.
@group(0) @binding(9) var<storage, read_write> depth: array<f32>;
// World shading normal facing the camera, octahedral-packed (`gi::packing`); 0 for sky.
@group(0) @binding(10) var<storage, read_write> normal: array<u32>;
// Textured linear base color (rgb, w 1); 0 for sky.
@group(0) @binding(11) var<storage, read_write> base_color: array<vec4<f32>>;
// Textured metallic (x) and perceptual roughness (y); 0 for sky.
@group(0) @binding(12) var<storage, read_write> metallic_roughness: array<vec2<f32>>;
// Emitted radiance toward the camera (rgb, w 0); 0 for sky.
@group(0) @binding(13) var<storage, read_write> emissive: array<vec4<f32>>;
// Frame triangle index; BVH_MISS for sky.
@group(0) @binding(14) var<storage, read_write> triangle_id: array<u32>;
// Previous pixel position minus this pixel's center, in pixels (+x right, +y down).
@group(0) @binding(15) var<storage, read_write> motion: array<vec2<f32>>;

// `CameraView::ray_direction` through the film point `uv`.
fn camera_ray(camera: GBufferCamera, uv: vec2<f32>) -> vec3<f32> {
    let fx = (2.0 * uv.x - 1.0) * camera.tan_half_fov * camera.aspect;
    let fy = (1.0 - 2.0 * uv.y) * camera.tan_half_fov;
    let d = camera.forward + fx * camera.right + fy * camera.up;
    return d * (1.0 / sqrt(dot(d, d)));
}

// Pixel coordinates of the view-space offset `d` (a point minus the camera position, or a
// direction for points at infinity); the inverse of `camera_ray`. `w` is 0 behind the camera.
fn project(camera: GBufferCamera, d: vec3<f32>) -> vec3<f32> {
    let z = dot(d, camera.forward);
    if z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let fx = dot(d, camera.right) / (z * camera.tan_half_fov * camera.aspect);
    let fy = dot(d, camera.up) / (z * camera.tan_half_fov);
    let uv = vec2<f32>(0.5 * (fx + 1.0), 0.5 * (1.0 - fy));
    return vec3<f32>(uv * vec2<f32>(uniforms.size_px), 1.0);
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
    let hit = trace_closest(Ray(camera.position, 0.0, dir, FAR));
    triangle_id[pixel] = hit.triangle;
    if hit.triangle == BVH_MISS {
        depth[pixel] = bitcast<f32>(INFINITY_BITS);
        normal[pixel] = 0u;
        base_color[pixel] = vec4<f32>(0.0);
        metallic_roughness[pixel] = vec2<f32>(0.0);
        emissive[pixel] = vec4<f32>(0.0);
        let previous = project(uniforms.previous_camera, dir);
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
    let n = tri.na.xyz * b0 + tri.nb.xyz * b1 + tri.nc.xyz * b2;
    normal[pixel] = pack_unit_vector(shading_normal(ng, n, wo));

    let uv = triangle_uv(tri, b0, b1, b2);
    let material = material_of(hit.triangle, uniforms.default_material);
    let base = material.base_color.xyz * sample_texture(material.base_color_texture, uv).xyz;
    base_color[pixel] = vec4<f32>(base, 1.0);
    let mr = sample_texture(material.metallic_roughness_texture, uv);
    metallic_roughness[pixel] = vec2<f32>(material.metallic * mr.z, material.roughness * mr.y);
    var emitted = vec3<f32>(0.0);
    if front_facing || material.double_sided != 0u {
        emitted = emission(material, uv);
    }
    emissive[pixel] = vec4<f32>(emitted, 0.0);

    // Where the surface point was: the same barycentrics on the previous triangle.
    var p = tri.pa.xyz + (tri.pb.xyz - tri.pa.xyz) * b1 + (tri.pc.xyz - tri.pa.xyz) * b2;
    if uniforms.has_previous_positions != 0u {
        let pa = previous_positions[3u * hit.triangle].xyz;
        let pb = previous_positions[3u * hit.triangle + 1u].xyz;
        let pc = previous_positions[3u * hit.triangle + 2u].xyz;
        p = pa + (pb - pa) * b1 + (pc - pa) * b2;
    }
    let previous = project(uniforms.previous_camera, p - uniforms.previous_camera.position);
    motion[pixel] = select(vec2<f32>(0.0), previous.xy - center, previous.z > 0.0);
}

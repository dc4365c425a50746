// Pass `cache/screen_inject`: corrects resident bricks from what the camera sees (HSGI, GDC
// 2023, "Injection": screen injection, one thread per voxel; sample < depth => clear, sample
// > depth => skip, sample ~ depth => update; bricks culled against the view on the CPU).
//
// One 64-thread workgroup per brick the CPU chose (inside the view frustum), one thread per
// occupied voxel. The voxel center projects into the G-buffer:
// - **clear**: every G-buffer pixel over the voxel's projection (its bounding sphere plus one
//   pixel) sees sky or a surface farther than the voxel by more than a margin (the voxel's
//   diagonal plus the depth one pixel footprint spans on that surface, capped at grazing
//   angles). The voxel is empty space in front of the visible surface: its occupancy bit is
//   cleared. Sampling the whole projection, not only the center pixel, keeps voxels whose
//   surface lies next to a silhouette or under a grazing view.
// - **update**: the center pixel's surface (its plane through the hit point) crosses the
//   voxel near the hit point and its normal agrees with the voxel's: the voxel takes the
//   diffuse albedo (the Lambert lobe's at the mean view cosine 2/3, as `cache/voxelize`) and the normal of the
//   G-buffer. Coverage, emission and state are kept.
// - **skip** otherwise (occluded, off screen, too close to the camera, normals disagree).
// Occupancy changes are gathered with workgroup atomics and written once per brick.

#import gi::cache::data::{cache, cache_brick_masks, cache_voxels, cache_mask_cell, cache_mask_test, cache_voxel_normal}
#import gi::camera::{Camera, camera_ray}
#import gi::math::{image_contains, image_index}
#import gi::brdf::{gbuffer_brdf, brdf_diffuse_albedo}
#import gi::packing::{pack_unit_vector, unpack_unit_vector}

// Mirror of `gi_cache::screen_inject::ScreenInjectUniforms`.
struct ScreenInjectUniforms {
    camera: Camera,
    size_px: vec2<u32>,
    job_count: u32,
    pad: u32,
}

// Mirror of `gi_cache::screen_inject::GpuScreenJob`: one resident brick to correct.
struct ScreenJob {
    brick: vec3<i32>,
    level: u32,
    brick_id: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

// `gi_cache::screen_inject::NORMAL_AGREEMENT`: least |cos| between the G-buffer and voxel
// normals for an update.
const NORMAL_AGREEMENT: f32 = 0.9;
// `gi_cache::screen_inject::MIN_COS_VIEW`: grazing views count as this steep in the margin.
const MIN_COS_VIEW: f32 = 0.1;
// Samples per side of the clear test at most (larger projections are sampled with a stride).
const MAX_SAMPLE_RADIUS: i32 = 4;
const SQRT_3: f32 = 1.7320508;

@group(0) @binding(0) var<uniform> inject: ScreenInjectUniforms;
@group(0) @binding(1) var<storage, read> jobs: array<ScreenJob>;
@group(0) @binding(2) var<storage, read> gbuffer_depth: array<f32>;
@group(0) @binding(3) var<storage, read> gbuffer_normal: array<u32>;
@group(0) @binding(4) var<storage, read> gbuffer_base_color: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> gbuffer_metallic_roughness: array<vec2<f32>>;
// [voxels cleared, voxels updated, bricks left empty] over the pass.
@group(0) @binding(6) var<storage, read_write> counts: array<atomic<u32>, 3>;

var<workgroup> cleared: array<atomic<u32>, 2>;

// Continuous pixel position (x right, y down) and view depth of world point `p`.
fn project(p: vec3<f32>) -> vec3<f32> {
    let c = inject.camera;
    let d = p - c.position;
    let z = dot(d, c.forward);
    let fx = dot(d, c.right) / (z * c.tan_half_fov * c.aspect);
    let fy = dot(d, c.up) / (z * c.tan_half_fov);
    let size = vec2<f32>(inject.size_px);
    return vec3(0.5 * (fx + 1.0) * size.x, 0.5 * (1.0 - fy) * size.y, z);
}

fn in_image(px: vec2<i32>) -> bool {
    return image_contains(px, inject.size_px);
}

fn pixel_index(px: vec2<i32>) -> u32 {
    return image_index(px, inject.size_px);
}

// The unit camera ray through the center of pixel `px`, as the G-buffer cast it.
fn pixel_ray(px: vec2<i32>) -> vec3<f32> {
    return camera_ray(inject.camera, (vec2<f32>(px) + 0.5) / vec2<f32>(inject.size_px));
}

// True when pixel `px` shows sky or a surface farther than `distance` by more than the
// margin (the voxel diagonal `diagonal` plus the pixel's footprint depth).
fn pixel_sees_past(px: vec2<i32>, distance: f32, diagonal: f32, pixel_angle: f32) -> bool {
    let i = pixel_index(px);
    let depth = gbuffer_depth[i];
    if depth > 3.0e38 {
        return true;
    }
    let cos_view = max(abs(dot(unpack_unit_vector(gbuffer_normal[i]), pixel_ray(px))), MIN_COS_VIEW);
    return distance + diagonal + depth * pixel_angle / cos_view < depth;
}

@compute @workgroup_size(64)
fn screen_inject(@builtin(workgroup_id) workgroup: vec3<u32>, @builtin(local_invocation_index) bit: u32) {
    if bit < 2u {
        atomicStore(&cleared[bit], 0u);
    }
    workgroupBarrier();

    let job = jobs[workgroup.x];
    let mask = cache_brick_masks[job.brick_id];
    let s = cache.levels[job.level].voxel_size_m;
    let voxel = job.brick * 4 + vec3<i32>(cache_mask_cell(bit));
    let center = (vec3<f32>(voxel) + 0.5) * s;
    let p = project(center);
    let center_px = vec2<i32>(floor(p.xy));
    let pixel_angle = 2.0 * inject.camera.tan_half_fov / f32(inject.size_px.y);
    let diagonal = SQRT_3 * s;
    if cache_mask_test(mask, bit) && p.z > diagonal && in_image(center_px) {
        let distance = length(center - inject.camera.position);
        // Clear: every pixel over the voxel's projection sees past it.
        let radius_px = i32(ceil(0.5 * diagonal / (p.z * pixel_angle))) + 1;
        let samples = min(radius_px, MAX_SAMPLE_RADIUS);
        let stride = f32(radius_px) / f32(samples);
        var empty = true;
        for (var y = -samples; y <= samples && empty; y++) {
            for (var x = -samples; x <= samples && empty; x++) {
                let px = center_px + vec2<i32>(round(vec2<f32>(f32(x), f32(y)) * stride));
                empty = in_image(px) && pixel_sees_past(px, distance, diagonal, pixel_angle);
            }
        }
        if empty {
            atomicOr(&cleared[bit >> 5u], 1u << (bit & 31u));
            atomicAdd(&counts[0], 1u);
        } else {
            // Update: the visible surface crosses the voxel near the center pixel's hit.
            let i = pixel_index(center_px);
            let depth = gbuffer_depth[i];
            let n = unpack_unit_vector(gbuffer_normal[i]);
            let hit = inject.camera.position + pixel_ray(center_px) * depth;
            let plane_distance = abs(dot(center - hit, n));
            let box_extent = 0.5 * s * (abs(n.x) + abs(n.y) + abs(n.z));
            let near_hit = length(center - hit) <= 0.5 * diagonal + depth * pixel_angle;
            let index = job.brick_id * 64u + bit;
            let surface = cache_voxels[index];
            let agreement = dot(n, cache_voxel_normal(surface));
            if depth < 3.0e38 && plane_distance <= box_extent && near_hit && abs(agreement) >= NORMAL_AGREEMENT {
                let brdf = gbuffer_brdf(gbuffer_base_color[i], gbuffer_metallic_roughness[i]);
                let albedo = brdf_diffuse_albedo(brdf, 2.0 / 3.0);
                let coverage = unpack4x8unorm(surface.albedo).w;
                cache_voxels[index].albedo = pack4x8unorm(vec4(albedo, coverage));
                // The voxel keeps its side: the G-buffer normal faces the camera.
                cache_voxels[index].normal = pack_unit_vector(select(-n, n, agreement >= 0.0));
                atomicAdd(&counts[1], 1u);
            }
        }
    }

    workgroupBarrier();
    if bit == 0u {
        let c = vec2(atomicLoad(&cleared[0]), atomicLoad(&cleared[1]));
        if any(c != vec2(0u)) {
            let left = mask & ~c;
            cache_brick_masks[job.brick_id] = left;
            if all(left == vec2(0u)) {
                atomicAdd(&counts[2], 1u);
            }
        }
    }
}

// Pass `cache/voxelize`: fills pooled bricks from the triangles the CPU binned to them
// (SmartGI, SIGGRAPH 2024, "Bricklizer": bricks voxelized from their primitive lists; HSGI,
// GDC 2023, "Radiance Cache": 4^3 surfel voxels of albedo, normal and emission per brick).
//
// The rules are those of `gi_cache::cpu_voxelize`, in the same f32 arithmetic: occupancy by a
// triangle-box separating axis test (half-open along the world axes), normal from the area
// vectors of the triangles clipped to the voxel, coverage from their area projected on that
// normal, albedo from the material at the closest triangle point to the voxel center,
// emission as the emitted power of the clipped triangles over the cross-section of their box
// along the normal, the box around the clipped triangles in the state
// (`gi_cache::layout::geometry_box_bits`). The voxel's sides and age start at 0.
//
// A brick's triangle list is cut into parts (`gi_cache::voxelize`), so that a coarse brick
// listing a hundred thousand triangles runs on many workgroups instead of one. Four entry
// points, one 64-thread workgroup each and one thread per voxel, run in order:
// 1. `gather`, per part: the part's sums of clipped area vectors and areas, the box of its
//    clipped triangles, its closest triangle;
// 2. `resolve`, per brick: merges its parts in list order (the closest triangle is the first
//    of the nearest, as in one walk of the list) and fixes the voxel's normal;
// 3. `project`, per part: the part's projected area and emitted power along that normal;
// 4. `finish`, per brick: sums the parts, writes the surface, the zeroed sides and the
//    occupancy mask.
// Only the order of the f32 sums differs from one walk of the whole list.

#import gi::cache::data::{
    cache, cache_brick_masks, cache_voxels, cache_direct, cache_indirect, cache_emitted,
    cache_keeps_emitted, cache_mask_cell, VoxelSurface, CACHE_STATE_DYNAMIC, CACHE_SIDE_COUNT,
    CACHE_STATE_BOX_SHIFT, CACHE_BOX_STEPS, cache_geometry_box
}
#import gi::scene::{triangles, emission, material_of, geometric_normal, tex_coords, material_brdf, surface_coverage}
#import gi::brdf::brdf_diffuse_albedo
#import gi::packing::{pack_unit_vector, pack_rgb9e5}

// Mirror of `gi_cache::voxelize::VoxelizeUniforms`.
struct VoxelizeUniforms {
    default_material: u32,
    job_count: u32,
    part_count: u32,
    pad: u32,
}

// Mirror of `gi_cache::voxelize::GpuVoxelizeJob`: one brick to fill.
struct VoxelizeJob {
    brick: vec3<i32>,
    level: u32,
    brick_id: u32,
    first_part: u32,
    part_count: u32,
    pad: u32,
}

// Mirror of `gi_cache::voxelize::GpuVoxelizePart`: a run of a brick's triangle list.
struct VoxelizePart {
    job: u32,
    first_triangle: u32,
    triangle_count: u32,
    pad: u32,
}

// What a part found in one voxel (`gather`), then what the brick's parts found together
// (`resolve`). In a part's record `project` replaces `sums` with (emitted power, projected
// area); in a brick's merged record `sums.xyz` is the normal. 64 bytes.
struct VoxelPartial {
    // (sum of clipped area vectors, sum of their lengths)
    sums: vec4<f32>,
    // Bounds of the clipped triangles relative to the voxel center (empty while lo > hi).
    box_lo: vec3<f32>,
    flags: u32,
    box_hi: vec3<f32>,
    closest_distance_sq: f32,
    closest_b: vec3<f32>,
    closest_triangle: u32,
}

// `VoxelPartial::flags`: some triangle overlaps the voxel; one of them is dynamic.
const FOUND: u32 = 1u;
const DYNAMIC: u32 = 2u;

// Bit of a binned triangle reference marking a dynamic node's triangle
// (`gi_cache::binning::TRIANGLE_DYNAMIC_BIT`).
const TRIANGLE_DYNAMIC_BIT: u32 = 0x80000000u;
// `gi_cache::cpu_voxelize::NORMAL_CANCEL_FRACTION`.
const NORMAL_CANCEL_FRACTION: f32 = 0.5;
// Workgroups per row of a dispatch (`gi_cache::voxelize::DISPATCH_WIDTH`): the workgroup's
// index is y * DISPATCH_WIDTH + x.
const DISPATCH_WIDTH: u32 = 32768u;

@group(0) @binding(0) var<uniform> voxelize_uniforms: VoxelizeUniforms;
@group(0) @binding(8) var<storage, read> jobs: array<VoxelizeJob>;
@group(0) @binding(9) var<storage, read> brick_triangles: array<u32>;
@group(0) @binding(10) var<storage, read> parts: array<VoxelizePart>;
// The parts' records (64 per part), then the bricks' merged records (64 per brick).
@group(0) @binding(11) var<storage, read_write> records: array<VoxelPartial>;

var<workgroup> occupancy: array<atomic<u32>, 2>;

// Triangles are read in chunks of 64, one per thread: each thread loads its triangle once into
// workgroup memory and stores the range of the brick's voxels its bounds can touch, so a
// voxel's thread runs the exact tests only on the triangles near it, from workgroup memory,
// instead of loading every triangle of the part from the scene. The range is conservative by
// half a voxel, so every voxel the exact test accepts is inside it, and the voxel's thread
// still sees its triangles in list order.
const CHUNK: u32 = 64u;
// A chunk entry's range: lo.xyz in bits 0..6, hi.xyz in bits 6..12 (2 bits per axis);
// NO_VOXELS when the triangle touches none of the brick's voxels or the slot is past the list.
const NO_VOXELS: u32 = 0xffffffffu;
var<workgroup> chunk_ranges: array<u32, 64>;
// The chunk's binned references and their triangles' vertices.
var<workgroup> chunk_references: array<u32, 64>;
var<workgroup> chunk_vertices: array<array<vec3<f32>, 3>, 64>;

// Loads chunk `chunk` of `part`'s run: slot `slot` (this thread's) gets its triangle's
// reference, vertices and voxel range within the brick whose lowest corner is `origin`.
fn load_chunk(part: VoxelizePart, chunk: u32, slot: u32, origin: vec3<f32>, voxel_size: f32) {
    let i = chunk * CHUNK + slot;
    var range = NO_VOXELS;
    if i < part.triangle_count {
        let reference = brick_triangles[part.first_triangle + i];
        let tri = triangles[reference & ~TRIANGLE_DYNAMIC_BIT];
        chunk_references[slot] = reference;
        chunk_vertices[slot] = array(tri.pa.xyz, tri.pb.xyz, tri.pc.xyz);
        let lo = (min(min(tri.pa.xyz, tri.pb.xyz), tri.pc.xyz) - origin) / voxel_size;
        let hi = (max(max(tri.pa.xyz, tri.pb.xyz), tri.pc.xyz) - origin) / voxel_size;
        let first = floor(lo - 0.5);
        let last = floor(hi + 0.5);
        if all(last >= vec3(0.0)) && all(first <= vec3(3.0)) {
            let a = vec3<u32>(clamp(first, vec3(0.0), vec3(3.0)));
            let b = vec3<u32>(clamp(last, vec3(0.0), vec3(3.0)));
            range = a.x | (a.y << 2u) | (a.z << 4u) | (b.x << 6u) | (b.y << 8u) | (b.z << 10u);
        }
    }
    chunk_ranges[slot] = range;
}

// Whether voxel `cell` (0..3 per axis) lies in chunk entry `range`.
fn in_range(range: u32, cell: vec3<u32>) -> bool {
    if range == NO_VOXELS {
        return false;
    }
    let lo = vec3(range & 3u, (range >> 2u) & 3u, (range >> 4u) & 3u);
    let hi = vec3((range >> 6u) & 3u, (range >> 8u) & 3u, (range >> 10u) & 3u);
    return all(cell >= lo) && all(cell <= hi);
}

// The slots of the loaded chunk whose range holds voxel `cell`, as a 64-bit mask. A thread
// walks only its own slots (lowest first, so in list order): the threads of a wave test
// different triangles side by side instead of idling through the slots of their neighbours.
fn slots_in_range(cell: vec3<u32>) -> vec2<u32> {
    var masks = vec2(0u, 0u);
    for (var slot = 0u; slot < CHUNK; slot++) {
        if in_range(chunk_ranges[slot], cell) {
            masks[slot >> 5u] |= 1u << (slot & 31u);
        }
    }
    return masks;
}

// Takes the lowest slot out of `masks` (not empty).
fn next_slot(masks: ptr<function, vec2<u32>>) -> u32 {
    if (*masks).x != 0u {
        let slot = countTrailingZeros((*masks).x);
        (*masks).x &= (*masks).x - 1u;
        return slot;
    }
    let slot = 32u + countTrailingZeros((*masks).y);
    (*masks).y &= (*masks).y - 1u;
    return slot;
}

// True when the axis separates the triangle (relative to the box center) from the box.
fn separated_on(axis: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, half: f32) -> bool {
    let p0 = dot(axis, v0);
    let p1 = dot(axis, v1);
    let p2 = dot(axis, v2);
    let r = half * (abs(axis.x) + abs(axis.y) + abs(axis.z));
    return min(min(p0, p1), p2) > r || max(max(p0, p1), p2) < -r;
}

// `gi_cache::cpu_voxelize::triangle_box_overlap`.
fn triangle_box_overlap(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, center: vec3<f32>, half: f32) -> bool {
    let v0 = a - center;
    let v1 = b - center;
    let v2 = c - center;
    let lo = min(min(v0, v1), v2);
    let hi = max(max(v0, v1), v2);
    if any(lo >= vec3(half)) || any(hi < vec3(-half)) {
        return false;
    }
    let e0 = v1 - v0;
    let e1 = v2 - v1;
    let e2 = v0 - v2;
    let n = cross(e0, e1);
    if all(n == vec3(0.0)) {
        return false;
    }
    if abs(dot(n, v0)) > half * (abs(n.x) + abs(n.y) + abs(n.z)) {
        return false;
    }
    let edges = array(e0, e1, e2);
    for (var i = 0u; i < 3u; i++) {
        let e = edges[i];
        if separated_on(cross(vec3(1.0, 0.0, 0.0), e), v0, v1, v2, half)
            || separated_on(cross(vec3(0.0, 1.0, 0.0), e), v0, v1, v2, half)
            || separated_on(cross(vec3(0.0, 0.0, 1.0), e), v0, v1, v2, half) {
            return false;
        }
    }
    return true;
}

// A triangle clipped to a voxel: its area vector and the bounds of the clipped polygon
// relative to the voxel center (lo > hi when nothing is left).
struct Clipped {
    area: vec3<f32>,
    lo: vec3<f32>,
    hi: vec3<f32>,
}

// `gi_cache::cpu_voxelize::clipped_area_vector`.
fn clipped_area_vector(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, center: vec3<f32>, half: f32) -> vec3<f32> {
    return clip_to_box(a, b, c, center, half).area;
}

// `gi_cache::cpu_voxelize::clip_to_box`: Sutherland-Hodgman against the six faces.
fn clip_to_box(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, center: vec3<f32>, half: f32) -> Clipped {
    // A triangle inside the box passes every face unchanged: the polygon below would be its
    // three vertices, so its area vector and bounds are computed directly (the same values,
    // bit for bit). Small triangles in coarse voxels, the bulk of a coarse brick's list, take
    // this path.
    let r0 = a - center;
    let r1 = b - center;
    let r2 = c - center;
    if all(abs(r0) <= vec3(half)) && all(abs(r1) <= vec3(half)) && all(abs(r2) <= vec3(half)) {
        return Clipped(cross(r1 - r0, r2 - r0) * 0.5, min(min(r0, r1), r2), max(max(r0, r1), r2));
    }
    let empty = Clipped(vec3(0.0), vec3(half), vec3(-half));
    var polygon: array<vec3<f32>, 10>;
    polygon[0] = a - center;
    polygon[1] = b - center;
    polygon[2] = c - center;
    var count = 3u;
    for (var plane = 0u; plane < 6u; plane++) {
        let axis = plane >> 1u;
        let sign = select(1.0, -1.0, (plane & 1u) != 0u);
        var clipped: array<vec3<f32>, 10>;
        var n = 0u;
        for (var i = 0u; i < count; i++) {
            let p = polygon[i];
            let q = polygon[(i + 1u) % count];
            let p_inside = sign * p[axis] <= half;
            let q_inside = sign * q[axis] <= half;
            if p_inside {
                clipped[n] = p;
                n++;
            }
            if p_inside != q_inside {
                let t = (half - sign * p[axis]) / (sign * (q[axis] - p[axis]));
                clipped[n] = p + (q - p) * t;
                n++;
            }
        }
        polygon = clipped;
        count = n;
        if count < 3u {
            return empty;
        }
    }
    var sum = vec3(0.0);
    var lo = polygon[0];
    var hi = polygon[0];
    for (var i = 1u; i < count; i++) {
        lo = min(lo, polygon[i]);
        hi = max(hi, polygon[i]);
        if i + 1u < count {
            sum += cross(polygon[i] - polygon[0], polygon[i + 1u] - polygon[0]);
        }
    }
    return Clipped(sum * 0.5, lo, hi);
}

// `gi_cache::layout::geometry_box_bits`: the state bits of the box [lo, hi] (relative to the
// voxel center) around a voxel's geometry, rounded outwards to eighths of the voxel edge.
fn geometry_box_bits(lo: vec3<f32>, hi: vec3<f32>, half: f32) -> u32 {
    let steps = f32(CACHE_BOX_STEPS);
    var bits = 0u;
    for (var axis = 0u; axis < 3u; axis++) {
        let lo_steps = (lo[axis] + half) / (2.0 * half) * steps;
        let hi_steps = (hi[axis] + half) / (2.0 * half) * steps;
        let a = u32(clamp(floor(lo_steps - 1e-3), 0.0, steps - 1.0));
        let b = max(u32(clamp(ceil(hi_steps + 1e-3), 1.0, steps)), a + 1u);
        bits |= (a | ((CACHE_BOX_STEPS - b) << 3u)) << (CACHE_STATE_BOX_SHIFT + 6u * axis);
    }
    return bits;
}

// `gi_cache::layout::box_cross_section`: the area the stored box (state bits `box_bits`, 0 the
// whole voxel) of a voxel of edge `s` shows along unit direction `n`.
fn box_cross_section(box_bits: u32, n: vec3<f32>, s: f32) -> f32 {
    let geometry = cache_geometry_box(box_bits);
    let e = vec3<f32>(geometry.hi - geometry.lo) * (s / f32(CACHE_BOX_STEPS));
    let a = abs(n);
    return a.x * e.y * e.z + a.y * e.x * e.z + a.z * e.x * e.y;
}

// `gi_cache::cpu_voxelize::closest_point_barycentrics` (Ericson, 5.1.5).
fn closest_point_barycentrics(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return vec3(1.0, 0.0, 0.0);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return vec3(0.0, 1.0, 0.0);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return vec3(1.0 - t, t, 0.0);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return vec3(0.0, 0.0, 1.0);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return vec3(1.0 - t, 0.0, t);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec3(0.0, 1.0 - t, t);
    }
    let denom = 1.0 / (va + vb + vc);
    let w1 = vb * denom;
    let w2 = vc * denom;
    return vec3(1.0 - w1 - w2, w1, w2);
}

// The index of the workgroup in a dispatch of `DISPATCH_WIDTH` columns.
fn workgroup_index(workgroup: vec3<u32>) -> u32 {
    return workgroup.y * DISPATCH_WIDTH + workgroup.x;
}

// A voxel's geometry: its edge, half edge and center, and its brick's lowest corner.
struct VoxelBox {
    size: f32,
    half: f32,
    center: vec3<f32>,
    origin: vec3<f32>,
}

fn voxel_box(job: VoxelizeJob, bit: u32) -> VoxelBox {
    let size = cache.levels[job.level].voxel_size_m;
    let voxel = job.brick * 4 + vec3<i32>(cache_mask_cell(bit));
    return VoxelBox(
        size,
        0.5 * size,
        (vec3<f32>(voxel) + 0.5) * size,
        vec3<f32>(job.brick * 4) * size,
    );
}

// A record of nothing found.
fn empty_record(half: f32) -> VoxelPartial {
    return VoxelPartial(vec4(0.0), vec3(half), 0u, vec3(-half), 0.0, vec3(0.0), 0u);
}

// Index of brick `job`'s merged record of voxel `bit`.
fn merged_index(job: u32, bit: u32) -> u32 {
    return (voxelize_uniforms.part_count + job) * 64u + bit;
}

// What a part's voxel thread works on.
struct PartVoxel {
    part: VoxelizePart,
    voxel: VoxelBox,
    cell: vec3<u32>,
}

fn part_voxel(part_index: u32, bit: u32) -> PartVoxel {
    let part = parts[part_index];
    return PartVoxel(part, voxel_box(jobs[part.job], bit), cache_mask_cell(bit));
}

@compute @workgroup_size(64)
fn gather(@builtin(workgroup_id) workgroup: vec3<u32>, @builtin(local_invocation_index) bit: u32) {
    let part_index = workgroup_index(workgroup);
    if part_index >= voxelize_uniforms.part_count {
        return;
    }
    let at = part_voxel(part_index, bit);
    let part = at.part;
    let voxel = at.voxel;
    var record = empty_record(voxel.half);
    let chunks = (part.triangle_count + CHUNK - 1u) / CHUNK;
    for (var chunk = 0u; chunk < chunks; chunk++) {
        workgroupBarrier();
        load_chunk(part, chunk, bit, voxel.origin, voxel.size);
        workgroupBarrier();
        var slots = slots_in_range(at.cell);
        while any(slots != vec2(0u)) {
            let slot = next_slot(&slots);
            let reference = chunk_references[slot];
            let index = reference & ~TRIANGLE_DYNAMIC_BIT;
            let a = chunk_vertices[slot][0];
            let b = chunk_vertices[slot][1];
            let c = chunk_vertices[slot][2];
            if !triangle_box_overlap(a, b, c, voxel.center, voxel.half) {
                continue;
            }
            if (reference & TRIANGLE_DYNAMIC_BIT) != 0u {
                record.flags |= DYNAMIC;
            }
            let clip = clip_to_box(a, b, c, voxel.center, voxel.half);
            record.box_lo = min(record.box_lo, clip.lo);
            record.box_hi = max(record.box_hi, clip.hi);
            record.sums += vec4(clip.area, length(clip.area));
            let w = closest_point_barycentrics(a, b, c, voxel.center);
            let d = a * w.x + b * w.y + c * w.z - voxel.center;
            let distance_sq = dot(d, d);
            if (record.flags & FOUND) == 0u || distance_sq < record.closest_distance_sq {
                record.flags |= FOUND;
                record.closest_distance_sq = distance_sq;
                record.closest_triangle = index;
                record.closest_b = w;
            }
        }
    }
    records[part_index * 64u + bit] = record;
}

@compute @workgroup_size(64)
fn resolve(@builtin(workgroup_id) workgroup: vec3<u32>, @builtin(local_invocation_index) bit: u32) {
    let job_index = workgroup_index(workgroup);
    if job_index >= voxelize_uniforms.job_count {
        return;
    }
    let job = jobs[job_index];
    let half = voxel_box(job, bit).half;
    var merged = empty_record(half);
    for (var i = 0u; i < job.part_count; i++) {
        let part = records[(job.first_part + i) * 64u + bit];
        merged.sums += part.sums;
        merged.box_lo = min(merged.box_lo, part.box_lo);
        merged.box_hi = max(merged.box_hi, part.box_hi);
        // A later part's triangle wins only when strictly nearer: the first of the nearest.
        if (part.flags & FOUND) != 0u
            && ((merged.flags & FOUND) == 0u || part.closest_distance_sq < merged.closest_distance_sq) {
            merged.closest_distance_sq = part.closest_distance_sq;
            merged.closest_triangle = part.closest_triangle;
            merged.closest_b = part.closest_b;
        }
        merged.flags |= part.flags;
    }
    // The normal the projected areas are taken along (only voxels with geometry use it).
    var normal = vec3(0.0, 0.0, 1.0);
    if (merged.flags & FOUND) != 0u {
        let area_total = merged.sums.w;
        let sum_length = length(merged.sums.xyz);
        if area_total > 0.0 && sum_length > NORMAL_CANCEL_FRACTION * area_total {
            normal = merged.sums.xyz / sum_length;
        } else {
            normal = geometric_normal(triangles[merged.closest_triangle]);
        }
    }
    merged.sums = vec4(normal, 0.0);
    records[merged_index(job_index, bit)] = merged;
}

@compute @workgroup_size(64)
fn project(@builtin(workgroup_id) workgroup: vec3<u32>, @builtin(local_invocation_index) bit: u32) {
    let part_index = workgroup_index(workgroup);
    if part_index >= voxelize_uniforms.part_count {
        return;
    }
    let at = part_voxel(part_index, bit);
    let part = at.part;
    let voxel = at.voxel;
    let merged = records[merged_index(part.job, bit)];
    let found = (merged.flags & FOUND) != 0u;
    let normal = merged.sums.xyz;
    // Every thread walks the chunks (their barriers need the whole workgroup); voxels without
    // geometry test nothing.
    var projected = 0.0;
    var emitted = vec3(0.0);
    let chunks = (part.triangle_count + CHUNK - 1u) / CHUNK;
    for (var chunk = 0u; chunk < chunks; chunk++) {
        workgroupBarrier();
        load_chunk(part, chunk, bit, voxel.origin, voxel.size);
        workgroupBarrier();
        var slots = vec2(0u);
        if found {
            slots = slots_in_range(at.cell);
        }
        while any(slots != vec2(0u)) {
            let slot = next_slot(&slots);
            let index = chunk_references[slot] & ~TRIANGLE_DYNAMIC_BIT;
            let a = chunk_vertices[slot][0];
            let b = chunk_vertices[slot][1];
            let c = chunk_vertices[slot][2];
            if triangle_box_overlap(a, b, c, voxel.center, voxel.half) {
                let w = closest_point_barycentrics(a, b, c, voxel.center);
                let area = abs(dot(clipped_area_vector(a, b, c, voxel.center, voxel.half), normal))
                    * surface_coverage(index, voxelize_uniforms.default_material, w);
                projected += area;
                let material = material_of(index, voxelize_uniforms.default_material);
                if any(material.emissive != vec3(0.0)) {
                    emitted += emission(material, tex_coords(index, w, 0.0)) * area;
                }
            }
        }
    }
    records[part_index * 64u + bit].sums = vec4(emitted, projected);
}

@compute @workgroup_size(64)
fn finish(@builtin(workgroup_id) workgroup: vec3<u32>, @builtin(local_invocation_index) bit: u32) {
    let job_index = workgroup_index(workgroup);
    if job_index >= voxelize_uniforms.job_count {
        return;
    }
    if bit < 2u {
        atomicStore(&occupancy[bit], 0u);
    }
    workgroupBarrier();
    let job = jobs[job_index];
    let half = voxel_box(job, bit).half;
    let merged = records[merged_index(job_index, bit)];
    var surface = VoxelSurface(0u, 0u, 0u, 0u);
    if (merged.flags & FOUND) != 0u {
        var sums = vec4(0.0);
        for (var i = 0u; i < job.part_count; i++) {
            sums += records[(job.first_part + i) * 64u + bit].sums;
        }
        let normal = merged.sums.xyz;
        let coverage = min(sums.w / (4.0 * half * half), 1.0);
        var box_bits = 0u;
        if all(merged.box_lo <= merged.box_hi) {
            box_bits = geometry_box_bits(merged.box_lo, merged.box_hi, half);
        }
        let material = material_of(merged.closest_triangle, voxelize_uniforms.default_material);
        // The cache reflects diffusely into every direction: the Lambert lobe's albedo at the
        // cosine-weighted mean view cosine (2/3) stands for its mean over the hemisphere.
        let brdf = material_brdf(material, tex_coords(merged.closest_triangle, merged.closest_b, 0.0));
        let albedo = brdf_diffuse_albedo(brdf, 2.0 / 3.0);
        surface = VoxelSurface(
            pack4x8unorm(vec4(albedo, coverage)),
            pack_unit_vector(normal),
            pack_rgb9e5(sums.xyz / box_cross_section(box_bits, normal, 2.0 * half)),
            select(0u, CACHE_STATE_DYNAMIC, (merged.flags & DYNAMIC) != 0u) | box_bits,
        );
        atomicOr(&occupancy[bit >> 5u], 1u << (bit & 31u));
    }
    let voxel_index = job.brick_id * 64u + bit;
    cache_voxels[voxel_index] = surface;
    for (var side = 0u; side < CACHE_SIDE_COUNT; side++) {
        cache_direct[voxel_index * CACHE_SIDE_COUNT + side] = 0u;
        cache_indirect[voxel_index * CACHE_SIDE_COUNT + side] = 0u;
        if cache_keeps_emitted() {
            cache_emitted[voxel_index * CACHE_SIDE_COUNT + side] = 0u;
        }
    }

    workgroupBarrier();
    if bit == 0u {
        cache_brick_masks[job.brick_id] = vec2(atomicLoad(&occupancy[0]), atomicLoad(&occupancy[1]));
    }
}

// Rays through the brick radiance cache with a hierarchical DDA (HDDA): SmartGI, SIGGRAPH 2024,
// "Bricklizer / Brick Tracing" (a coarse test on the 64-bit group mask, a fine test on the
// 64-bit brick mask, then voxels); HSGI, GDC 2023, "Software Ray Trace" (HDDA after GVDB,
// Hoetzlein 2016: one 64-bit occupancy fetch per cell) and "Light Propagation - Origin
// Geometry" (rays leave a surface voxel from an offset origin).
//
// Traversal, per clipmap level (finest first):
//   - cells of 16 voxels (a group): skipped in one step when the group mask is 0;
//   - cells of 4 voxels (a brick): skipped when their bit of the group mask is clear;
//   - voxels: a hit when their bit of the brick mask is set and the ray meets the box around
//     the voxel's geometry (`cache_ray_meets_box`), so that a surface's voxels reaching into
//     free space (a door jamb's, up to a voxel into the opening) do not narrow the opening.
// An occupied cell is entered at the same point (descend); a step that leaves the parent cell
// goes back up to the coarsest scale whose cell changed. Leaving a level's window continues in
// the next coarser level from the same boundary point, whose voxel there is the fine voxel's
// coordinate halved (windows start on group boundaries, so the halving is exact and the coarse
// voxel lies wholly outside the finer window, which a ray never enters again).
//
// Robustness: the current cell is an integer voxel coordinate; each step computes the crossing
// distance afresh from the integer boundary plane and the ray's origin (no accumulated float
// position), keeps the other coordinates inside the cell being left (clamped), and never lets
// `t` decrease. Zero direction components never step on their axis.
#define_import_path gi::cache::trace

#import gi::cache::data::{
    cache, cache_link, cache_group_masks, cache_brick_masks, cache_voxels, VoxelRef,
    cache_mask_bit, cache_mask_test, cache_face_index, cache_voxel_of_point, cache_in_window,
    cache_level_of_point, cache_link_index, cache_group_index, cache_voxel_at, cache_voxel_index,
    cache_voxel_normal, cache_side_radiance, cache_side_seen_by_ray,
    cache_side_normal, cache_side_slot, cache_direct, cache_indirect, cache_emitted,
    cache_keeps_emitted, CACHE_SIDE_FRONT, CACHE_SIDE_BACK, CACHE_STATE_BOX_SHIFT, CACHE_BOX_STEPS,
    cache_geometry_box, cache_voxel_recent_change
}
#import gi::packing::{unpack_rgb9e5, unpack_unit_vector}
#import gi::math::INV_PI

// Most cells one trace visits (all scales and levels together). A ray crossing a default
// level (128 x 64 x 128 voxels) voxel by voxel takes at most 320 voxel steps; empty space goes
// by in groups, so this bound is only reached by rays grazing long surfaces through several
// levels. A ray that reaches it is reported as a miss.
const CACHE_TRACE_MAX_STEPS: u32 = 2048u;

// Distance standing for "never" on an axis the ray does not move along.
const CACHE_TRACE_FAR: f32 = 3.0e38;

// What a ray found in the cache.
struct CacheHit {
    // Distance along the (unit) direction to where the ray entered the hit voxel; the surface
    // lies somewhere inside that voxel, so this is early by up to one voxel diagonal of `level`.
    t: f32,
    // Level of the hit voxel (its edge is `cache.levels[level].voxel_size_m`).
    level: u32,
    // The hit voxel (brick_id 0 on a miss).
    voxel: VoxelRef,
    // Axis face the ray entered through (moving +x the ray enters through face 1, -x), for
    // debugging: the lighting it sees is that of `side`.
    face: u32,
    // Side of the hit surfel facing the ray (`cache_side_seen_by_ray`): 0 front, 1 back.
    side: u32,
    // False when the ray reached `t_max`, left the coarsest window or ran out of steps.
    hit: bool,
}

fn cache_miss(t_max: f32) -> CacheHit {
    return CacheHit(t_max, 0u, VoxelRef(0u, 0u), 0u, 0u, false);
}

// Index of the smallest component (ties: x, then y).
fn cache_argmin3(v: vec3<f32>) -> u32 {
    if v.x <= v.y && v.x <= v.z {
        return 0u;
    }
    return select(2u, 1u, v.y <= v.z);
}

// Index of the largest component (ties: x, then y).
fn cache_argmax3(v: vec3<f32>) -> u32 {
    if v.x >= v.y && v.x >= v.z {
        return 0u;
    }
    return select(2u, 1u, v.y >= v.z);
}

// Traces `origin + t * dir`, `t` in (0, t_max], `dir` of unit length, through the cache, and
// returns the first occupied voxel.
//
// It starts at the finest level whose window holds `origin` (from a point outside every window,
// where the ray enters the coarsest one) and skips the voxel that holds `origin`: rays leave
// surfaces, and the surface's own voxel would hit at once. Callers therefore start rays about
// one voxel (of the level they start in) off the surface along its normal, as HSGI does, so
// that the neighbouring voxels of the same surface are not hit either; a ray leaving at a
// grazing angle may still hit them.
fn cache_trace(origin: vec3<f32>, dir: vec3<f32>, t_max: f32) -> CacheHit {
    return cache_trace_from(origin, dir, t_max, true);
}

// `cache_trace`, skipping the voxel that holds `origin` only when `skip_origin` (a ray's later
// segment starts in open space and must not skip anything).
fn cache_trace_from(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, skip_origin_voxel: bool) -> CacheHit {
    if cache.level_count == 0u {
        return cache_miss(t_max);
    }
    let moving = dir != vec3(0.0);
    let inv_dir = 1.0 / select(vec3(1.0), dir, moving);
    let step = select(vec3(-1), vec3(1), dir >= vec3(0.0));

    var level = cache_level_of_point(origin);
    var t = 0.0;
    var face = 0u;
    var vox: vec3<i32>;
    var skip_origin = skip_origin_voxel;
    if level < cache.level_count {
        vox = cache_voxel_of_point(origin, level);
    } else {
        // Outside every window: clip the ray to the coarsest window (slab test) and enter it.
        level = cache.level_count - 1u;
        let s = cache.levels[level].voxel_size_m;
        let lo_voxel = cache.levels[level].origin_brick * 4;
        let hi_voxel = lo_voxel + vec3<i32>(cache.level_bricks * 4u);
        let ta = (vec3<f32>(lo_voxel) * s - origin) * inv_dir;
        let tb = (vec3<f32>(hi_voxel) * s - origin) * inv_dir;
        let inside_slab = (origin >= vec3<f32>(lo_voxel) * s) & (origin < vec3<f32>(hi_voxel) * s);
        if any(!moving & !inside_slab) {
            return cache_miss(t_max);
        }
        let t_near = select(vec3(-CACHE_TRACE_FAR), min(ta, tb), moving);
        let t_far = select(vec3(CACHE_TRACE_FAR), max(ta, tb), moving);
        let t_enter = max(max(t_near.x, t_near.y), max(t_near.z, 0.0));
        let t_exit = min(min(t_far.x, t_far.y), t_far.z);
        if t_enter >= t_exit || t_enter > t_max {
            return cache_miss(t_max);
        }
        let axis = cache_argmax3(t_near);
        t = t_enter;
        face = cache_face_index(axis, step[axis] < 0);
        vox = clamp(cache_voxel_of_point(origin + dir * t, level), lo_voxel, hi_voxel - vec3(1));
        vox[axis] = select(hi_voxel[axis] - 1, lo_voxel[axis], step[axis] > 0);
        skip_origin = false;
    }
    let origin_level = level;
    let origin_voxel = vox;

    // log2 of the current cell's edge in voxels: 4 (group), 2 (brick) or 0 (voxel).
    var shift = 4u;
    // Masks and brick of the cells the traversal is inside of (valid below the group scale).
    var group_mask = vec2(0u);
    var brick_id = 0u;
    var brick_mask = vec2(0u);
    for (var i = 0u; i < CACHE_TRACE_MAX_STEPS; i++) {
        if t > t_max {
            break;
        }
        if !cache_in_window(level, vox >> vec3(2u)) {
            // Left this level's window: go on from the same point one level coarser.
            level += 1u;
            if level >= cache.level_count {
                break;
            }
            vox = vox >> vec3(1u);
            shift = 4u;
            continue;
        }
        var occupied = false;
        if shift == 4u {
            group_mask = cache_group_masks[cache_group_index(level, vox >> vec3(4u))];
            occupied = any(group_mask != vec2(0u));
        } else if shift == 2u {
            let brick = vox >> vec3(2u);
            if cache_mask_test(group_mask, cache_mask_bit(vec3<u32>(brick & vec3(3)))) {
                brick_id = cache_link[cache_link_index(level, brick)];
                brick_mask = cache_brick_masks[brick_id];
                occupied = brick_id != 0u && any(brick_mask != vec2(0u));
            }
        } else {
            let bit = cache_mask_bit(vec3<u32>(vox & vec3(3)));
            let is_origin = skip_origin && level == origin_level && all(vox == origin_voxel);
            if cache_mask_test(brick_mask, bit) && !is_origin {
                let v = VoxelRef(brick_id, bit);
                let surface = cache_voxels[cache_voxel_index(v)];
                let s = cache.levels[level].voxel_size_m;
                if cache_ray_meets_box(origin, dir, inv_dir, moving, vox, s, surface.state) {
                    let n = cache_voxel_normal(surface);
                    return CacheHit(t, level, v, face, cache_side_seen_by_ray(n, dir), true);
                }
            }
        }
        if occupied {
            shift -= 2u;
            continue;
        }

        // Step over the empty cell: find the boundary plane the ray leaves it through.
        let s = cache.levels[level].voxel_size_m;
        let size = 1 << shift;
        let lo = (vox >> vec3(shift)) * size;
        let boundary = lo + select(vec3(0), vec3(size), step > vec3(0));
        let t_axis = select(vec3(CACHE_TRACE_FAR), (vec3<f32>(boundary) * s - origin) * inv_dir, moving);
        let axis = cache_argmin3(t_axis);
        t = max(t, t_axis[axis]);
        var next = clamp(vec3<i32>(floor((origin + dir * t) / s)), lo, lo + vec3(size - 1));
        next[axis] = select(lo[axis] - 1, lo[axis] + size, step[axis] > 0);
        face = cache_face_index(axis, step[axis] < 0);
        // Back up to the coarsest scale whose cell changed (the group and brick masks held
        // are those of the cells still containing the traversal).
        if any((next >> vec3(4u)) != (vox >> vec3(4u))) {
            shift = 4u;
        } else if any((next >> vec3(2u)) != (vox >> vec3(2u))) {
            shift = max(shift, 2u);
        }
        vox = next;
    }
    return cache_miss(t_max);
}

// True when the ray `origin + t * dir` meets the box around the geometry of voxel `vox` (edge
// `s`) that the voxel's `state` holds (`gi_cache::layout::geometry_box_bits`, bounds in eighths
// of the edge from the voxel's lowest corner; zero bits are the whole voxel), widened by a
// thousandth of the edge against rounding. Only called for voxels the ray is inside of, so
// the whole line can be tested. A ray that meets the voxel's geometry meets its box; one that
// passes beside it (through a door's opening along its jamb) goes on.
fn cache_ray_meets_box(
    origin: vec3<f32>,
    dir: vec3<f32>,
    inv_dir: vec3<f32>,
    moving: vec3<bool>,
    vox: vec3<i32>,
    s: f32,
    state: u32,
) -> bool {
    if (state >> CACHE_STATE_BOX_SHIFT) == 0u {
        return true;
    }
    let geometry = cache_geometry_box(state);
    let step = s / f32(CACHE_BOX_STEPS);
    let margin = 1e-3 * s;
    let lo = vec3<f32>(vox) * s + vec3<f32>(geometry.lo) * step - margin;
    let hi = vec3<f32>(vox) * s + vec3<f32>(geometry.hi) * step + margin;
    let inside = (origin >= lo) & (origin <= hi);
    if any(!moving & !inside) {
        return false;
    }
    let ta = (lo - origin) * inv_dir;
    let tb = (hi - origin) * inv_dir;
    let t_near = select(vec3(-CACHE_TRACE_FAR), min(ta, tb), moving);
    let t_far = select(vec3(CACHE_TRACE_FAR), max(ta, tb), moving);
    return max(max(t_near.x, t_near.y), t_near.z) <= min(min(t_far.x, t_far.y), t_far.z);
}

// Distance along `origin + t * dir` at which the ray leaves `level`'s window (0 when it is never
// inside it ahead of the origin).
fn cache_window_exit(origin: vec3<f32>, dir: vec3<f32>, level: u32) -> f32 {
    let s = cache.levels[level].voxel_size_m;
    let lo = vec3<f32>(cache.levels[level].origin_brick * 4) * s;
    let hi = lo + vec3<f32>(cache.level_bricks * 4u) * s;
    let moving = dir != vec3(0.0);
    let inv_dir = 1.0 / select(vec3(1.0), dir, moving);
    let t_far = select(vec3(CACHE_TRACE_FAR), max((lo - origin) * inv_dir, (hi - origin) * inv_dir), moving);
    return max(min(min(t_far.x, t_far.y), t_far.z), 0.0);
}

// One lane's share of a ray that `lanes` invocations trace together, each through its own part
// of the clipmap: with `per = ceil(level_count / lanes)`, lane k traces the part of the ray
// between leaving the windows of levels below `k * per` and leaving the window of level
// `(k + 1) * per - 1` (the last lane: to `t_max`). Lanes below the one holding the origin's
// level trace nothing, and only that lane skips the origin's voxel. A ray's lanes together
// visit the cells `cache_trace` visits, so the hit of the lowest lane that has one is
// `cache_trace`'s hit (its `t` along the whole ray); `cache_trace_shared` combines them.
//
// Why: a ray crossing the clipmap steps through every level's shell in turn, one dependent
// memory load after another, and a pass with few rays (a probe per screen tile, a ray per
// volume probe) cannot hide that latency with other threads; traced in lanes, the ray costs
// its longest shell instead of all of them.
fn cache_trace_lane(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, lane: u32, lanes: u32) -> CacheHit {
    let count = cache.level_count;
    if count == 0u {
        return cache_miss(t_max);
    }
    let per = (count + lanes - 1u) / lanes;
    let first = lane * per;
    let origin_lane = min(cache_level_of_point(origin), count - 1u) / per;
    if first >= count || lane < origin_lane {
        return cache_miss(t_max);
    }
    var t0 = 0.0;
    if lane > origin_lane {
        t0 = cache_window_exit(origin, dir, first - 1u);
    }
    var t1 = t_max;
    if first + per < count {
        t1 = min(t_max, cache_window_exit(origin, dir, first + per - 1u));
    }
    if t0 >= t1 {
        return cache_miss(t_max);
    }
    var hit = cache_trace_from(origin + dir * t0, dir, t1 - t0, lane == origin_lane);
    if !hit.hit {
        return cache_miss(t_max);
    }
    hit.t += t0;
    return hit;
}

// Radiance leaving the hit surfel's side towards the ray (its Lambertian radiance, plus the
// voxel's emission when `with_emission`); black on a miss.
fn cache_hit_radiance(hit: CacheHit, with_emission: bool) -> vec3<f32> {
    if !hit.hit {
        return vec3(0.0);
    }
    return cache_side_radiance(hit.voxel, hit.side, with_emission);
}

// The hit voxel's surface normal on the side the ray sees (the side whose lighting it reads);
// zero on a miss.
fn cache_hit_normal(hit: CacheHit) -> vec3<f32> {
    if !hit.hit {
        return vec3(0.0);
    }
    return cache_side_normal(cache_voxel_normal(cache_voxels[cache_voxel_index(hit.voxel)]), hit.side);
}

// The change the cache just measured (`cache_voxel_recent_change`) in the light of the voxel a
// ray hit; 0 on a miss.
fn cache_hit_change(hit: CacheHit) -> f32 {
    if !hit.hit {
        return 0.0;
    }
    return cache_voxel_recent_change(cache_voxels[cache_voxel_index(hit.voxel)]);
}

// Least agreement |n_voxel . n| of a voxel's surfel with a query's normal for the voxel to count
// in `cache_irradiance`: voxels of a crossing surface (a wall meeting the floor, at 0) stay out,
// voxels whose normal is averaged over the edge between them (at about 0.71) count.
const CACHE_IRRADIANCE_MIN_AGREEMENT: f32 = 0.5;

// Irradiance (rgb) at surface point `p` with unit normal `n`, and in w whether the cache has a
// voxel there (1) or not (0, rgb 0), at the finest level whose window holds `p` and that has a
// voxel there.
//
// Interpolation: trilinear over the 2 x 2 x 2 voxels around the point half a voxel behind the
// surface (`p - n * s / 2`, where the surface's own voxels are). Each occupied voxel gives the
// side of its surfel that faces the same way as `n` (the front when n_voxel . n >= 0), weighted
// by its trilinear weight times how well the two normals agree (|n_voxel . n|); voxels that
// agree less than CACHE_IRRADIANCE_MIN_AGREEMENT are left out, and the weights renormalized.
// Empty voxels and voxels of a crossing surface thus never leak in, and a voxel at a concave
// edge or corner (its normal averaged over the surfaces meeting there) brings the light of its
// side, lit from outside the corner. When none qualifies, the voxel containing `p` or else its
// neighbour behind `p` along `-n` is used as is.
fn cache_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    return cache_irradiance_of(p, n, CACHE_PART_ALL);
}

// `cache_irradiance` without the punctual lights' direct irradiance (`cache_direct`) and without
// what emissive triangles give directly (`cache_emitted`): the light that arrives after at least
// one bounce, or from the sky. What a caller that lights the point itself from the punctual
// lights and the emitters (with shadow rays) adds to it. Needs a cache that keeps the emitted
// part (`gi_cache::CacheConfig::keep_emitted`); without, the emitters' light stays in.
fn cache_bounced_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    return cache_irradiance_of(p, n, CACHE_PART_BOUNCED);
}

// `cache_irradiance` without what emissive triangles give directly: the punctual lights' direct
// irradiance as the cache's voxels received it (shadow rays per voxel, so shadows as sharp as a
// voxel) and the bounced light. What a hit that samples the emitters itself but leaves the
// punctual lights to the cache adds (the PC tier's `HitLights::Cache`).
fn cache_lit_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    return cache_irradiance_of(p, n, CACHE_PART_LIT);
}

// `cache_irradiance` without the punctual lights' direct irradiance (`cache_direct`): the light
// of the sky, of the emissive triangles and of every bounce. What a surface lit by the punctual
// lights elsewhere (the direct-light pass of the real-time tiers) adds as its GI.
fn cache_indirect_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    return cache_irradiance_of(p, n, CACHE_PART_INDIRECT);
}

// The GI of a pixel with the G-buffer's blended layer `layer` (`gbuffer.blend_layer`: distance,
// packed normal, packed albedo, alpha) composited over `behind`, the GI of the surface behind
// it, for the camera ray from `origin` along `dir`: the layer reflects its albedo times the
// cache's irradiance there without the punctual lights (which the direct-light pass gives).
fn cache_blend_layer_gi(layer: vec4<f32>, origin: vec3<f32>, dir: vec3<f32>, behind: vec3<f32>) -> vec3<f32> {
    if layer.x <= 0.0 {
        return behind;
    }
    let p = origin + dir * layer.x;
    let n = unpack_unit_vector(bitcast<u32>(layer.y));
    let albedo_sqrt = unpack4x8unorm(bitcast<u32>(layer.z)).xyz;
    let e = cache_indirect_irradiance(p, n).xyz;
    return mix(behind, albedo_sqrt * albedo_sqrt * e * INV_PI, layer.w);
}

// The change the cache just measured in its light at surface point `p` with unit normal `n`
// (`cache_voxel_recent_change`: the share of the voxels' reflected light that changed in this
// frame's lighting update or the last), interpolated over the voxels `cache_irradiance` reads
// there; 0 where the cache has none.
fn cache_change(p: vec3<f32>, n: vec3<f32>) -> f32 {
    return cache_irradiance_of(p, n, CACHE_PART_CHANGE).x;
}

// The change the cache just measured (`cache_voxel_recent_change`) of the voxel holding the
// surface at `p` (unit normal `n`: the voxel half a voxel behind `p`) at the finest level whose
// window holds `p`: one lookup, for passes that ask at every pixel; 0 where that voxel is
// empty.
fn cache_surface_change(p: vec3<f32>, n: vec3<f32>) -> f32 {
    let level = cache_level_of_point(p);
    if level >= cache.level_count {
        return 0.0;
    }
    let s = cache.levels[level].voxel_size_m;
    let v = cache_voxel_at(level, cache_voxel_of_point(p - n * (0.5 * s), level));
    if v.brick_id == 0u {
        return 0.0;
    }
    return cache_voxel_recent_change(cache_voxels[cache_voxel_index(v)]);
}

// Which part of the cached irradiance a lookup returns.
const CACHE_PART_ALL: u32 = 0u;
const CACHE_PART_BOUNCED: u32 = 1u;
const CACHE_PART_INDIRECT: u32 = 2u;
// The bounced light and the punctual lights' direct light: all of it but what the emissive
// triangles give directly.
const CACHE_PART_LIT: u32 = 3u;
// Not light: the voxel's measured change, in every channel (`cache_change`).
const CACHE_PART_CHANGE: u32 = 4u;

// Irradiance of side `side` of `v`: all of it, without the punctual lights' direct part, or only
// its bounced part (`CACHE_PART_*`). The emitted part was
// accumulated alongside the indirect irradiance it is part of, with the same weights, so their
// difference differs from the bounced light only by their rounding.
fn cache_side_irradiance_of(v: VoxelRef, side: u32, part: u32) -> vec3<f32> {
    if part == CACHE_PART_CHANGE {
        return vec3(cache_voxel_recent_change(cache_voxels[cache_voxel_index(v)]));
    }
    let slot = cache_side_slot(v, side);
    let indirect = unpack_rgb9e5(cache_indirect[slot]);
    if part == CACHE_PART_INDIRECT {
        return indirect;
    }
    var lit = indirect;
    if part == CACHE_PART_BOUNCED || part == CACHE_PART_LIT {
        if cache_keeps_emitted() {
            lit = max(indirect - unpack_rgb9e5(cache_emitted[slot]), vec3(0.0));
        }
        if part == CACHE_PART_BOUNCED {
            return lit;
        }
    }
    return lit + unpack_rgb9e5(cache_direct[slot]);
}

// `cache_irradiance` or `cache_bounced_irradiance`. A point near the edge of its level's window
// can find no voxel at that level: the surface's own voxels lie behind it, outside the window.
// The lookup then falls back to the coarser levels, whose windows hold it.
fn cache_irradiance_of(p: vec3<f32>, n: vec3<f32>, part: u32) -> vec4<f32> {
    for (var level = cache_level_of_point(p); level < cache.level_count; level++) {
        let e = cache_irradiance_at_level(p, n, level, part);
        if e.w > 0.0 {
            return e;
        }
    }
    return vec4(0.0);
}

// `cache_irradiance_of` at one level.
fn cache_irradiance_at_level(p: vec3<f32>, n: vec3<f32>, level: u32, part: u32) -> vec4<f32> {
    let s = cache.levels[level].voxel_size_m;
    let q = (p - n * (0.5 * s)) / s - 0.5;
    let base = vec3<i32>(floor(q));
    let f = q - floor(q);
    var sum = vec3(0.0);
    var weight = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = vec3(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        let v = cache_voxel_at(level, base + vec3<i32>(offset));
        if v.brick_id == 0u {
            continue;
        }
        let agreement = dot(cache_voxel_normal(cache_voxels[cache_voxel_index(v)]), n);
        if abs(agreement) < CACHE_IRRADIANCE_MIN_AGREEMENT {
            continue;
        }
        let w3 = select(1.0 - f, f, offset == vec3(1u));
        let w = w3.x * w3.y * w3.z * abs(agreement);
        sum += w * cache_side_irradiance_of(v, select(CACHE_SIDE_BACK, CACHE_SIDE_FRONT, agreement >= 0.0), part);
        weight += w;
    }
    if weight > 1e-6 {
        return vec4(sum / weight, 1.0);
    }
    var v = cache_voxel_at(level, cache_voxel_of_point(p, level));
    if v.brick_id == 0u {
        v = cache_voxel_at(level, cache_voxel_of_point(p - n * s, level));
    }
    if v.brick_id == 0u {
        return vec4(0.0);
    }
    let agreement = dot(cache_voxel_normal(cache_voxels[cache_voxel_index(v)]), n);
    return vec4(cache_side_irradiance_of(v, select(CACHE_SIDE_BACK, CACHE_SIDE_FRONT, agreement >= 0.0), part), 1.0);
}

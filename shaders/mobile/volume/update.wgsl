// Pass `mobile/volume`, the probe volume's update (HSGI, GDC 2023, "Probe Volume /
// Update": "collect probes close to the surface with the voxel hierarchy structure; each frame
// rand 1 face to update, trace 1 ray; Monte Carlo integration" with the cosine pdf, so a face's
// irradiance is pi times the mean radiance of its rays), plus DDGI's relocation (Majercik et
// al. 2021, "Scaling Probe-Based Real-Time Dynamic Global Illumination for Production": probes
// inside geometry move to a free spot of their cell).
//
// Two dispatches in one compute pass:
//   - `classify_probes`, one invocation per slot: resets the probes that entered the clipmap,
//     marks active those with an occupied cache brick within one spacing (group-mask bits of
//     the cache level whose bricks are at least a spacing wide), flags relocation when static
//     geometry took a probe's spot, and appends the active
//     probes to `active_list`, counting workgroups into the indirect arguments;
//   - `trace_probes`, indirect, CACHE_LANES invocations per listed probe: its first relocates
//     it when flagged, then all trace `rays_per_probe` rays together (`gi::cache::trace_shared`),
//     each updating one random face of its ambient cube and the depth moments of the ray
//     direction's bin.
//
// Bind group 0 (this file's; bindings 1-7 are `gi::scene`'s, which `gi::lights` declares):
//   binding 0: `update` uniform UpdateUniforms
//   binding 8: `active_list` array<u32>: slots of the probes to trace this frame
//   binding 9: `dispatch_args` array<atomic<u32>>: x, y, z workgroups of `trace_probes`
//              (classify only: the same buffer is the indirect argument of the second dispatch)
//   binding 10: `active_count` array<atomic<u32>>: entries of `active_list`
// Group 1 is the volume (`gi::mobile::volume`), group 2 the cache (`gi::cache::data`).

#import gi::math::PI
#import gi::sampling::{Sampler, sampler_new, sampler_next_f32, sampler_next_2d, cosine_hemisphere, frame_from_normal, frame_to_world}
#import gi::sky::Sky
#import gi::lights::sky_radiance
#import gi::cache::data::{
    cache, cache_group_masks, cache_group_index, cache_mask_bit, cache_mask_test,
    cache_in_window, cache_voxel_at, cache_level_of_point, cache_voxel_of_point, CACHE_SIDE_BACK,
    cache_voxels, cache_voxel_index, CACHE_STATE_DYNAMIC
}
#import gi::cache::trace::{CacheHit, cache_trace, cache_hit_radiance}
#import gi::cache::trace_shared::{cache_trace_shared, CACHE_LANES}
#import gi::mobile::volume::{
    volume, volume_probes, volume_faces, volume_moments, ProbeState, volume_slot_coord,
    volume_probe_position, volume_major_face, volume_moment_count,
    VOLUME_FACES, VOLUME_FAR_SPACINGS, VOLUME_MOMENT_COUNT_BITS, VOLUME_MOMENT_MAX_COUNT,
    WORKGROUP_SIZE, PROBE_INITIALIZED, PROBE_ACTIVE, PROBE_RELOCATE, PROBE_BURIED
}

// Active probes per workgroup of `trace_probes` (CACHE_LANES invocations each).
const PROBES_PER_GROUP: u32 = WORKGROUP_SIZE / CACHE_LANES;

// How far a probe's rays go: to the end of the cache (a miss then sees the sky).
const RAY_T_MAX: f32 = 1.0e30;
// Relocation candidates: the grid point, then the 26 directions of the 3 x 3 x 3 neighbourhood
// (faces, edges, corners: nearest first) at these fractions of a spacing per component. 0.45
// keeps a probe inside its cell (DDGI's limit is half a spacing).
const RELOCATION_NEAR_STEP: f32 = 0.225;
const RELOCATION_FAR_STEP: f32 = 0.45;
// Candidate scores, lower is better; a probe whose best candidate scores RELOCATION_BLOCKED or
// more is buried.
const SPOT_FREE: u32 = 0u;
// A cache voxel next to the spot is occupied: rays start fine, but the spot hugs a surface.
const SPOT_NEAR_SURFACE: u32 = 1u;
// The spot's own voxel is occupied: rays would skip it and see through that surface.
const SPOT_IN_SURFACE: u32 = 2u;
// More than a quarter of 8 diagonal rays of INSIDE_REACH_SPACINGS reach the back side of a
// surface: the spot is inside closed geometry (DDGI's back-face test, threshold 25%).
const SPOT_INSIDE: u32 = 3u;
const RELOCATION_BLOCKED: u32 = 2u;
const INSIDE_BACK_HITS: u32 = 3u;
// Reach of those rays, in spacings: a diagonal ray of 2 spacings meets any plane within 1.15
// spacings of the spot, beyond the farthest relocation (0.45 per axis) and the cell's probes.
const INSIDE_REACH_SPACINGS: f32 = 2.0;
// A relocation that moves a probe further than this (in spacings) keeps at most
// RELOCATED_MAX_AGE samples of its faces and depth bins, so the new spot's samples take
// over within a few frames.
const RELOCATION_MOVED_SPACINGS: f32 = 0.1;
const RELOCATED_MAX_AGE: u32 = 4u;

// Mirror of `gi_tiers::mobile::volume::GpuUpdateUniforms` (80 bytes).
struct UpdateUniforms {
    sky: Sky,
    // Sample index of every probe's random sequence this frame.
    frame_index: u32,
    rays_per_probe: u32,
    seed: u32,
    // Slots of all levels.
    slot_count: u32,
    // 1: every face's running mean restarts (`VolumeInputs::restart`).
    restart: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
}

@group(0) @binding(0) var<uniform> update: UpdateUniforms;
@group(0) @binding(8) var<storage, read_write> active_list: array<u32>;
@group(0) @binding(9) var<storage, read_write> dispatch_args: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> active_count: array<atomic<u32>>;

// ---------------------------------------------------------------------------------------------
// Occupancy around a probe, from the cache's hierarchy.
// ---------------------------------------------------------------------------------------------

// The bricks within one spacing `s` of `p`, read from the group masks of the finest cache level
// whose bricks are at least `s` wide and whose window holds them all (coarser levels where it
// does not): at most 3 x 3 x 3 bricks, one bit each.
struct Neighbourhood {
    // Occupied bricks (bits 0-26, x fastest) and the cache level read (bits 27-31).
    signature: u32,
    occupied: bool,
    // False when no cache level holds the neighbourhood.
    valid: bool,
}

fn volume_neighbourhood(p: vec3<f32>, s: f32) -> Neighbourhood {
    var level = 0u;
    while level + 1u < cache.level_count && 4.0 * cache.levels[level].voxel_size_m < s {
        level++;
    }
    for (; level < cache.level_count; level++) {
        let b = 4.0 * cache.levels[level].voxel_size_m;
        // Bricks touching [p - s, p + s), at most 3 per axis.
        let lo = vec3<i32>(floor((p - s) / b));
        let hi = min(vec3<i32>(ceil((p + s) / b)) - 1, lo + 2);
        if !cache_in_window(level, lo) || !cache_in_window(level, hi) {
            continue;
        }
        var bits = 0u;
        for (var z = lo.z; z <= hi.z; z++) {
            for (var y = lo.y; y <= hi.y; y++) {
                for (var x = lo.x; x <= hi.x; x++) {
                    let brick = vec3(x, y, z);
                    let mask = cache_group_masks[cache_group_index(level, brick >> vec3(2u))];
                    if cache_mask_test(mask, cache_mask_bit(vec3<u32>(brick & vec3(3)))) {
                        let d = vec3<u32>(brick - lo);
                        bits |= 1u << (d.x + 3u * d.y + 9u * d.z);
                    }
                }
            }
        }
        return Neighbourhood(bits | (level << 27u), bits != 0u, true);
    }
    return Neighbourhood(0u, false, false);
}

// True when the cache voxel holding `q` (at the finest level holding it) is occupied.
fn volume_spot_occupied(q: vec3<f32>) -> bool {
    let level = cache_level_of_point(q);
    if level >= cache.level_count {
        return false;
    }
    return cache_voxel_at(level, cache_voxel_of_point(q, level)).brick_id != 0u;
}

// Rays a probe has traced before its surroundings count as settled: a first fill of the cache
// takes about 20 frames at the default budget.
const YOUNG_PROBE_RAYS: u32 = 32u;

// True when the cache voxel holding `q` holds static geometry (occupied, not dynamic).
fn volume_spot_occupied_static(q: vec3<f32>) -> bool {
    let level = cache_level_of_point(q);
    if level >= cache.level_count {
        return false;
    }
    let v = cache_voxel_at(level, cache_voxel_of_point(q, level));
    return v.brick_id != 0u
        && (cache_voxels[cache_voxel_index(v)].state & CACHE_STATE_DYNAMIC) == 0u;
}

// ---------------------------------------------------------------------------------------------
// Relocation.
// ---------------------------------------------------------------------------------------------

// How bad spot `q` is for a probe of spacing `s`: SPOT_* times 16 plus the number of diagonal
// rays that reached a back side (0 to 8), so that among spots of one class the one seeing
// fewer back sides wins (a spot under a floor against one above it, when both hug it).
fn volume_spot_score(q: vec3<f32>, s: f32) -> u32 {
    let level = cache_level_of_point(q);
    if level >= cache.level_count {
        return SPOT_FREE;
    }
    let voxel = cache_voxel_of_point(q, level);
    if cache_voxel_at(level, voxel).brick_id != 0u {
        return SPOT_IN_SURFACE * 16u + 8u;
    }
    var near = false;
    for (var cell = 0; cell < 27 && !near; cell++) {
        let d = vec3(cell % 3, (cell / 3) % 3, cell / 9) - 1;
        near = cache_voxel_at(level, voxel + d).brick_id != 0u;
    }
    var back_hits = 0u;
    for (var i = 0u; i < 8u; i++) {
        let dir = normalize(select(vec3(-1.0), vec3(1.0), (vec3(i) & vec3(1u, 2u, 4u)) != vec3(0u)));
        let hit = cache_trace(q, dir, INSIDE_REACH_SPACINGS * s);
        if hit.hit && hit.side == CACHE_SIDE_BACK {
            back_hits++;
        }
    }
    if back_hits >= INSIDE_BACK_HITS {
        return SPOT_INSIDE * 16u + back_hits;
    }
    return select(SPOT_FREE, SPOT_NEAR_SURFACE, near) * 16u + back_hits;
}

struct Relocation {
    offset: vec3<f32>,
    buried: bool,
}

// The best spot for the probe at `grid` (spacing `s`): the first free candidate (no occupied
// voxel around it, no back side in reach), nearest first, or else the best-scoring one; buried
// when even that is in or inside geometry.
fn volume_relocate(grid: vec3<f32>, s: f32) -> Relocation {
    var best = vec3(0.0);
    var best_score = volume_spot_score(grid, s);
    for (var step = 0u; step < 2u && best_score != SPOT_FREE; step++) {
        for (var nonzero = 1; nonzero <= 3 && best_score != SPOT_FREE; nonzero++) {
            for (var cell = 0; cell < 27 && best_score != SPOT_FREE; cell++) {
                let d = vec3(cell % 3, (cell / 3) % 3, cell / 9) - 1;
                if abs(d.x) + abs(d.y) + abs(d.z) != nonzero {
                    continue;
                }
                let offset = vec3<f32>(d) * (select(RELOCATION_FAR_STEP, RELOCATION_NEAR_STEP, step == 0u) * s);
                let score = volume_spot_score(grid + offset, s);
                if score < best_score {
                    best_score = score;
                    best = offset;
                }
            }
        }
    }
    return Relocation(best, best_score >= RELOCATION_BLOCKED * 16u);
}

// ---------------------------------------------------------------------------------------------
// classify_probes
// ---------------------------------------------------------------------------------------------

// A probe that entered the window: no data, relocation pending.
fn volume_reset(slot: u32, coord: vec3<i32>) -> ProbeState {
    for (var face = 0u; face < VOLUME_FACES; face++) {
        volume_faces[slot * VOLUME_FACES + face] = vec4(0.0);
        volume_moments[slot * VOLUME_FACES + face] = vec2(0.0);
    }
    return ProbeState(coord, PROBE_INITIALIZED | PROBE_RELOCATE, vec3(0.0), 0u, 0u, 0u, 0u, 0u);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn classify_probes(@builtin(global_invocation_id) id: vec3<u32>) {
    let slot = id.x;
    if slot >= update.slot_count {
        return;
    }
    let level = slot / volume.probes_per_level;
    let coord = volume_slot_coord(slot);
    var state = volume_probes[slot];
    if (state.flags & PROBE_INITIALIZED) == 0u || any(state.coord != coord) {
        state = volume_reset(slot, coord);
    }
    if update.restart != 0u {
        // The light changed: the faces' next samples replace what they hold (the depth
        // moments, which describe geometry, are kept).
        for (var face = 0u; face < VOLUME_FACES; face++) {
            volume_faces[slot * VOLUME_FACES + face].w = 0.0;
        }
    }
    let s = volume.levels[level].spacing_m;
    let grid = volume_probe_position(level, coord, vec3(0.0));
    let hood = volume_neighbourhood(grid, s);
    state.flags &= ~PROBE_ACTIVE;
    if hood.valid && hood.occupied {
        state.flags |= PROBE_ACTIVE;
        // Find the probe's spot again when static geometry took it (the cache re-voxelized
        // the place), or, while the probe is young (the cache around it may still be filling),
        // when the occupancy around it changed. Later changes around it do not move it: one
        // relocation costs hundreds of cache rays in one invocation, and moving objects pass
        // over probe spots and change the occupancy around them every frame (on an H100,
        // relocating for them cost 1.3-1.9 ms per frame on `dynamic`, against 0.2 ms for the
        // whole pass on static scenes). A probe a moving object covers keeps its spot; its
        // rays see the object's inside until it has passed.
        let buried = (state.flags & PROBE_BURIED) != 0u;
        let young = state.age < YOUNG_PROBE_RAYS;
        if (!buried && volume_spot_occupied_static(grid + state.offset))
            || (young && hood.signature != state.signature) {
            state.flags |= PROBE_RELOCATE;
            state.signature = hood.signature;
        }
    }
    volume_probes[slot] = state;
    let listed = (state.flags & PROBE_ACTIVE) != 0u
        && ((state.flags & PROBE_BURIED) == 0u || (state.flags & PROBE_RELOCATE) != 0u);
    if listed {
        let index = atomicAdd(&active_count[0], 1u);
        active_list[index] = slot;
        if index % PROBES_PER_GROUP == 0u {
            atomicAdd(&dispatch_args[0], 1u);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// trace_probes
// ---------------------------------------------------------------------------------------------

// Keeps at most `max_count` samples of every face and depth bin of `slot`.
fn volume_clamp_ages(slot: u32, state: ptr<function, ProbeState>, max_count: u32) {
    var counts = 0u;
    for (var face = 0u; face < VOLUME_FACES; face++) {
        let i = slot * VOLUME_FACES + face;
        volume_faces[i].w = min(volume_faces[i].w, f32(max_count));
        let count = min(volume_moment_count((*state).moment_counts, face), max_count);
        counts |= count << (face * VOLUME_MOMENT_COUNT_BITS);
    }
    (*state).moment_counts = counts;
}

// Per probe of the workgroup (`trace_probes`): where its rays start (xyz), and in w 1 when it
// traces this frame; then each ray's radiance (xyz) and hit distance (w).
var<workgroup> probe_origin: array<vec4<f32>, PROBES_PER_GROUP>;
var<workgroup> probe_ray: array<vec4<f32>, PROBES_PER_GROUP>;

// One active probe per CACHE_LANES invocations: lane 0 relocates the probe and updates its
// state; each ray is traced by all the probe's lanes (`gi::cache::trace_shared`), a pass of a
// few thousand rays being too small to hide the cache's memory latency one ray per thread.
@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_probes(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) local_index: u32) {
    let index = id.x / CACHE_LANES;
    let lane = local_index % CACHE_LANES;
    let probe = local_index / CACHE_LANES;
    let valid = index < atomicLoad(&active_count[0]);
    var slot = 0u;
    var state: ProbeState;
    var s = 1.0;
    if valid {
        slot = active_list[index];
        state = volume_probes[slot];
        s = volume.levels[slot / volume.probes_per_level].spacing_m;
    }
    if valid && lane == 0u {
        let grid = volume_probe_position(slot / volume.probes_per_level, state.coord, vec3(0.0));
        if (state.flags & PROBE_RELOCATE) != 0u {
            let relocation = volume_relocate(grid, s);
            if length(relocation.offset - state.offset) > RELOCATION_MOVED_SPACINGS * s {
                volume_clamp_ages(slot, &state, RELOCATED_MAX_AGE);
            }
            state.offset = relocation.offset;
            state.flags &= ~(PROBE_RELOCATE | PROBE_BURIED);
            if relocation.buried {
                state.flags |= PROBE_BURIED;
            }
        }
        if (state.flags & PROBE_BURIED) != 0u {
            volume_probes[slot] = state;
        }
        probe_origin[probe] = vec4(grid + state.offset, select(0.0, 1.0, (state.flags & PROBE_BURIED) == 0u));
    }
    workgroupBarrier();
    let origin = probe_origin[probe];
    let traced = valid && origin.w > 0.0;

    let far = VOLUME_FAR_SPACINGS * s;
    var sampler = sampler_new(vec2(update.seed, 0u), slot, update.frame_index);
    for (var ray = 0u; ray < update.rays_per_probe; ray++) {
        // One random face of the ambient cube, one cosine-distributed ray about its axis (every
        // lane draws the same).
        let face = min(u32(sampler_next_f32(&sampler) * 6.0), 5u);
        var axis = vec3(0.0);
        axis[face >> 1u] = select(1.0, -1.0, (face & 1u) != 0u);
        let dir = frame_to_world(frame_from_normal(axis), cosine_hemisphere(sampler_next_2d(&sampler)));
        let shared_hit = cache_trace_shared(origin.xyz, dir, RAY_T_MAX, traced, local_index);
        if traced && shared_hit.owner {
            let hit = shared_hit.hit;
            if hit.hit {
                // `hit.t` is where the ray entered the hit voxel: the surface lies on average
                // about half a voxel further.
                probe_ray[probe] = vec4(cache_hit_radiance(hit, true), hit.t + 0.5 * cache.levels[hit.level].voxel_size_m);
            } else {
                probe_ray[probe] = vec4(sky_radiance(update.sky, dir), far);
            }
        }
        workgroupBarrier();
        if traced && lane == 0u {
            volume_add_sample(slot, &state, face, dir, probe_ray[probe], far);
        }
    }
    if traced && lane == 0u {
        state.age = min(state.age + update.rays_per_probe, 0x7fffffffu);
        volume_probes[slot] = state;
    }
}

// Adds one ray's sample to probe `slot`: `sample` is the radiance it brought back (xyz) and the
// distance to its hit (w), `face` the ambient-cube face it was drawn for.
fn volume_add_sample(slot: u32, state: ptr<function, ProbeState>, face: u32, dir: vec3<f32>, sample: vec4<f32>, far: f32) {
    let radiance = sample.xyz;
    let distance = sample.w;
    // Running mean of pi * L with weight 1 / min(age, max_age): with the cosine pdf the
    // Monte Carlo estimate of the face's irradiance is pi times the mean radiance.
    let face_index = slot * VOLUME_FACES + face;
    var value = volume_faces[face_index];
    let age = value.w + 1.0;
    let alpha = 1.0 / min(age, f32(volume.max_age));
    value = vec4(mix(value.rgb, PI * radiance, alpha), min(age, 16777216.0));
    volume_faces[face_index] = value;

    // Depth moments of the bin of the ray's direction: the hit's depth along the bin's
    // axis (`gi::mobile::volume::volume_visibility` explains why depth).
    let bin = volume_major_face(dir);
    let depth = min(distance * abs(dir[bin >> 1u]), far);
    let count = min(volume_moment_count((*state).moment_counts, bin) + 1u, VOLUME_MOMENT_MAX_COUNT);
    let bin_index = slot * VOLUME_FACES + bin;
    volume_moments[bin_index] = mix(volume_moments[bin_index], vec2(depth, depth * depth), 1.0 / f32(count));
    let shift = bin * VOLUME_MOMENT_COUNT_BITS;
    (*state).moment_counts = ((*state).moment_counts & ~(VOLUME_MOMENT_MAX_COUNT << shift)) | (count << shift);
}

#define_import_path gi::mobile::volume
// The mobile tier's world-space probe volume: HSGI (GDC 2023, "Mobile Solution / Probe Volume":
// ambient-cube irradiance with an age, visibility, relocation; a clipmap of 2 levels on mobile)
// sampled as DDGI does (Majercik et al. 2019, "Dynamic Diffuse Global Illumination with
// Ray-Traced Irradiance Fields": trilinear weights, a smooth back-face term and Chebyshev
// visibility from depth moments, with a normal bias).
//
// Layout: `volume.level_count` clipmap levels of `volume.probes` probes each, level k spaced
// `volume.levels[k].spacing_m` apart, its window starting at world probe coordinate
// `volume.levels[k].origin` (a probe of coordinate c sits at c * spacing, moved by its
// relocation offset). Slots are toroidal: world coordinate c of level k lives in slot
// `k * probes_per_level + linear(c mod probes)`, and each slot records the coordinate it holds,
// so a window that moves keeps the probes that stay. Per slot:
//   - `volume_probes`: ProbeState (coordinate, flags, relocation offset, age, ...);
//   - `volume_faces`, 6 per slot (+x, -x, +y, -y, +z, -z): rgb the face's irradiance, the
//     running mean of pi * L over cosine-distributed rays about the face's axis (HSGI: "c * mean
//     L"); w the face's sample count;
//   - `volume_moments`, 6 per slot, binned by the ray direction's major axis (same order): mean
//     and mean square of the depth of the first hit along the bin's axis (a miss counts as
//     VOLUME_FAR_SPACINGS spacings), whose counts are packed in ProbeState::moment_counts: a
//     variance shadow map of one texel per face (HSGI's "Visibility VSM").
//
// The update (`update.wgsl`) and the batch queries (`irradiance_at.wgsl`) are the passes of
// `shaders/mobile/volume/`; the screen gather (`shaders/mobile/screen/gather.wgsl`) samples
// the volume through `volume_irradiance`.
//
// Bind group 1 (`gi_tiers::mobile::ProbeVolume::bind_group_layout`), compute stages:
//   binding 0: `volume` uniform VolumeUniforms
//   binding 1: `volume_probes` array<ProbeState>
//   binding 2: `volume_faces` array<vec4<f32>>
//   binding 3: `volume_moments` array<vec2<f32>>
// The storage buffers are read_write so the update passes and the gather passes share one
// layout; gather passes only read them.

// Invocations per workgroup of the volume's passes (`gi_tiers::mobile::volume::WORKGROUP_SIZE`).
const WORKGROUP_SIZE: u32 = 64u;
const VOLUME_MAX_LEVELS: u32 = 4u;
const VOLUME_FACES: u32 = 6u;

// ProbeState::flags.
// The slot holds the probe of `coord` (cleared buffers hold none).
const PROBE_INITIALIZED: u32 = 1u;
// The cache has geometry within about one spacing: the probe is updated.
const PROBE_ACTIVE: u32 = 2u;
// The relocation must be (re)computed before the next update.
const PROBE_RELOCATE: u32 = 4u;
// No candidate position is outside geometry: the probe is not updated and not sampled.
const PROBE_BURIED: u32 = 8u;

// Depth standing for a miss (and the largest depth recorded), in spacings of the probe's level:
// beyond every depth a query of the probe's cells asks about (at most one spacing plus the
// normal bias), so a miss never occludes.
const VOLUME_FAR_SPACINGS: f32 = 4.0;
// Normal bias of a query point, in spacings of the level sampled (DDGI's normal bias): it moves
// the point off its surface so that probes seeing that surface measure a larger distance to it
// than to the point, and pushes points beside a thin wall away from the wall.
const VOLUME_NORMAL_BIAS_SPACINGS: f32 = 0.25;
// Least variance of a probe bin's depth distribution, in squared spacings: keeps Chebyshev's
// bound finite for a bin whose rays all hit at one depth.
const VOLUME_MIN_VARIANCE_SPACINGS2: f32 = 1e-4;
// Cells over which a level fades into the next coarser one near its window's border.
const VOLUME_BLEND_CELLS: f32 = 2.0;
// DDGI's weight crush: probe weights below this are squashed towards zero (cubically).
const VOLUME_CRUSH_THRESHOLD: f32 = 0.2;
// Bits per bin of ProbeState::moment_counts; a bin's moments average over its last
// (2^bits - 1) = 31 samples at most.
const VOLUME_MOMENT_COUNT_BITS: u32 = 5u;
const VOLUME_MOMENT_MAX_COUNT: u32 = 31u;

// One level's window: world probe coordinate of its lowest corner, and its probe spacing.
struct VolumeLevel {
    origin: vec3<i32>,
    spacing_m: f32,
}

// Mirror of `gi_tiers::mobile::volume::GpuVolumeUniforms` (96 bytes).
struct VolumeUniforms {
    levels: array<VolumeLevel, 4>,
    probes: vec3<u32>,
    level_count: u32,
    probes_per_level: u32,
    max_age: u32,
    pad_a: u32,
    pad_b: u32,
}

// Mirror of `gi_tiers::mobile::volume::GpuProbeState` (48 bytes).
struct ProbeState {
    // World probe coordinate of the probe the slot holds.
    coord: vec3<i32>,
    // PROBE_* bits.
    flags: u32,
    // Relocation offset from the grid point, meters (each component within 0.45 spacing).
    offset: vec3<f32>,
    // Rays traced since the probe entered the window.
    age: u32,
    // Occupancy of the bricks around the probe when its relocation was computed (bits 0-26)
    // and the cache level they were read at (bits 27-31).
    signature: u32,
    // Sample counts of the six depth bins, VOLUME_MOMENT_COUNT_BITS bits each.
    moment_counts: u32,
    pad_a: u32,
    pad_b: u32,
}

@group(1) @binding(0) var<uniform> volume: VolumeUniforms;
@group(1) @binding(1) var<storage, read_write> volume_probes: array<ProbeState>;
@group(1) @binding(2) var<storage, read_write> volume_faces: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> volume_moments: array<vec2<f32>>;

// Slot of world probe coordinate `coord` of `level`.
fn volume_slot(level: u32, coord: vec3<i32>) -> u32 {
    let dims = vec3<i32>(volume.probes);
    let p = vec3<u32>(((coord % dims) + dims) % dims);
    return level * volume.probes_per_level + p.x + volume.probes.x * (p.y + volume.probes.y * p.z);
}

// The world probe coordinate slot `slot` holds under the current windows: the one coordinate
// of the level's window congruent to the slot's position.
fn volume_slot_coord(slot: u32) -> vec3<i32> {
    let level = slot / volume.probes_per_level;
    let i = slot % volume.probes_per_level;
    let local = vec3<i32>(vec3(
        i % volume.probes.x,
        (i / volume.probes.x) % volume.probes.y,
        i / (volume.probes.x * volume.probes.y),
    ));
    let dims = vec3<i32>(volume.probes);
    let origin = volume.levels[level].origin;
    return origin + (((local - origin) % dims) + dims) % dims;
}

// World position of the probe of `coord` at `level` moved by `offset`.
fn volume_probe_position(level: u32, coord: vec3<i32>, offset: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(coord) * volume.levels[level].spacing_m + offset;
}

// Index of the axis face along `dir`'s major axis (0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z).
fn volume_major_face(dir: vec3<f32>) -> u32 {
    let a = abs(dir);
    var axis = 2u;
    if a.x >= a.y && a.x >= a.z {
        axis = 0u;
    } else if a.y >= a.z {
        axis = 1u;
    }
    return axis * 2u + select(0u, 1u, dir[axis] < 0.0);
}

// Sample count of depth bin `face` in a packed ProbeState::moment_counts.
fn volume_moment_count(counts: u32, face: u32) -> u32 {
    return (counts >> (face * VOLUME_MOMENT_COUNT_BITS)) & VOLUME_MOMENT_MAX_COUNT;
}

// The ambient cube of slot `slot` evaluated for unit normal `n`: sum of n_i^2 E(face i, sign
// n_i) over the faces with samples, renormalized by their n_i^2 (a face not sampled yet does not
// count as black). rgb irradiance, w the share of n_i^2 covered (0: no face with data).
fn volume_ambient_cube(slot: u32, n: vec3<f32>) -> vec4<f32> {
    let n2 = n * n;
    var sum = vec3(0.0);
    var weight = 0.0;
    for (var axis = 0u; axis < 3u; axis++) {
        let face = volume_faces[slot * VOLUME_FACES + axis * 2u + select(0u, 1u, n[axis] < 0.0)];
        if face.w > 0.0 {
            sum += n2[axis] * face.rgb;
            weight += n2[axis];
        }
    }
    if weight <= 1e-6 {
        return vec4(0.0);
    }
    return vec4(sum / weight, weight);
}

// Chebyshev's visibility of a point at `offset` from the probe of slot `slot` (level spacing
// `s`), from the depth moments of the bin `offset` points into (the probe's face facing the
// point), as a variance shadow map of that face: DDGI's one-sided bound, cubed, where the
// point's depth along the face's axis lies beyond the mean depth. Depth along the axis rather
// than distance along the ray: a wall facing the probe has one depth over the whole bin (no
// variance), where its distance grows by up to sqrt(3) towards the bin's corners and would blur
// the bound until points beside the wall read as hidden and points behind it as visible. The
// bins are not blended either: mixing a near bin (a wall) with a far one (the sky) would inflate
// the variance; the trilinear weights smooth the seams between bins instead.
fn volume_visibility(slot: u32, counts: u32, offset: vec3<f32>, s: f32) -> f32 {
    let bin = volume_major_face(offset);
    let depth = abs(offset[bin >> 1u]);
    if depth <= 1e-6 || volume_moment_count(counts, bin) == 0u {
        return 1.0;
    }
    let moments = volume_moments[slot * VOLUME_FACES + bin];
    let mean = moments.x;
    if depth <= mean {
        return 1.0;
    }
    let variance = max(moments.y - mean * mean, VOLUME_MIN_VARIANCE_SPACINGS2 * s * s);
    let excess = depth - mean;
    let chebyshev = variance / (variance + excess * excess);
    return chebyshev * chebyshev * chebyshev;
}

// One level's estimate at `p` (normal `n`): rgb irradiance normalized by the weights, w the sum
// of the weights, and in `blend` (out) how far `p` is inside the level's interior, 0 at its
// border to 1 VOLUME_BLEND_CELLS cells in. w = 0 when the cell around the biased point is not
// inside the window or none of its probes has data.
struct VolumeLevelSample {
    irradiance: vec3<f32>,
    weight: f32,
    blend: f32,
}

fn volume_level_irradiance(level: u32, p: vec3<f32>, n: vec3<f32>) -> VolumeLevelSample {
    var result = VolumeLevelSample(vec3(0.0), 0.0, 0.0);
    let s = volume.levels[level].spacing_m;
    let biased = p + n * (VOLUME_NORMAL_BIAS_SPACINGS * s);
    let g = biased / s;
    let base = vec3<i32>(floor(g));
    let f = g - floor(g);
    let local = base - volume.levels[level].origin;
    let last = vec3<i32>(volume.probes) - 2;
    if any(local < vec3(0)) || any(local > last) {
        return result;
    }
    // Distance in cells from the biased point to the interior's border (where a corner would
    // leave the window).
    let to_border = min(vec3<f32>(local) + f, vec3<f32>(last - local) + 1.0 - f);
    result.blend = clamp(min(to_border.x, min(to_border.y, to_border.z)) / VOLUME_BLEND_CELLS, 0.0, 1.0);

    var sum = vec3(0.0);
    var weight_sum = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = vec3(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        let coord = base + vec3<i32>(offset);
        let slot = volume_slot(level, coord);
        let state = volume_probes[slot];
        let usable = PROBE_INITIALIZED | PROBE_ACTIVE;
        if any(state.coord != coord) || (state.flags & (usable | PROBE_BURIED)) != usable || state.age == 0u {
            continue;
        }
        let cube = volume_ambient_cube(slot, n);
        if cube.w <= 0.0 {
            continue;
        }
        let probe = volume_probe_position(level, coord, state.offset);
        // DDGI's smooth back-face term: probes behind the surface count less, never zero.
        let to_probe = normalize(probe - p);
        let backface = 0.5 * (dot(to_probe, n) + 1.0);
        var w = backface * backface + 0.2;
        w *= volume_visibility(slot, state.moment_counts, biased - probe, s);
        w = max(w, 1e-6);
        if w < VOLUME_CRUSH_THRESHOLD {
            w *= w * w / (VOLUME_CRUSH_THRESHOLD * VOLUME_CRUSH_THRESHOLD);
        }
        let t3 = select(1.0 - f, f, offset == vec3(1u));
        w *= t3.x * t3.y * t3.z;
        sum += w * cube.rgb;
        weight_sum += w;
    }
    if weight_sum > 0.0 {
        result.irradiance = sum / weight_sum;
        result.weight = weight_sum;
    }
    return result;
}

// Irradiance E = integral of L_in(w) max(0, n . w) dw at point `p` for unit normal `n`, in the
// units of `gi::cache::trace::cache_irradiance` (rgb), and in w the sum of the weights of the
// probes used (0 when no probe with data covers `p`: the caller falls back to something else).
//
// The finest level whose interior holds the (normal-biased) point is used; near its border it
// fades over VOLUME_BLEND_CELLS cells into the next coarser level, and where it has no valid
// probe around the point the coarser level takes over. Cost: 8 probe states, up to 8 x 3 face
// and 8 x 3 moment reads per level used (usually one).
fn volume_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    var sum = vec3(0.0);
    var weight = 0.0;
    var remaining = 1.0;
    // The finest estimate with data, used alone when the point sits on its level's border and
    // no coarser level has data.
    var finest = VolumeLevelSample(vec3(0.0), 0.0, 0.0);
    for (var level = 0u; level < volume.level_count; level++) {
        let estimate = volume_level_irradiance(level, p, n);
        if estimate.weight <= 0.0 {
            continue;
        }
        if finest.weight <= 0.0 {
            finest = estimate;
        }
        let share = remaining * select(estimate.blend, 1.0, level + 1u == volume.level_count);
        sum += share * estimate.irradiance;
        weight += share * estimate.weight;
        remaining -= share;
        if remaining <= 1e-4 {
            break;
        }
    }
    let used = 1.0 - remaining;
    if used <= 1e-4 {
        return vec4(finest.irradiance, finest.weight);
    }
    return vec4(sum / used, weight / used);
}

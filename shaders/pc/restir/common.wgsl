// What every pass of the PC tier's ReSTIR GI (`shaders/pc/restir/`) shares: the uniforms, the
// per-trace-pixel surface and the ReSTIR GI reservoir, and the reservoir arithmetic (Ouyang et
// al. 2021, "ReSTIR GI: Path Resampling for Real-Time Path Tracing"; Bitterli et al. 2020 for
// the streaming reservoir and its unbiased contribution weight W).
//
// A reservoir holds one sample: a point `y` that a ray from a receiver `x` found (or a sky
// direction), the radiance leaving `y` towards `x`, its weight W and its sample count M. The
// estimate of the receiver's irradiance is `L(y) cos(n_x, y - x) W`; the target function is
// `p(y) = luminance(L(y)) cos(n_x, y - x)`, the irradiance integrand without colour.
#define_import_path gi::pc::restir::common

#import gi::camera::{Camera, camera_ray}
#import gi::sampling::{sampler_new, sampler_next_u32}
#import gi::math::luminance
#import gi::sky::Sky
#import gi::packing::{
    unpack_unit_vector, unpack_rgb9e5, pack_rgb9e5_dithered, pack_color64, unpack_color64,
    half_bits, half_value, pack_half2, unpack_half2
}

// Bits of `PcUniforms::flags`.
const FLAG_TEMPORAL: u32 = 1u;
const FLAG_SPATIAL: u32 = 2u;
const FLAG_SHADOW: u32 = 4u;
const FLAG_MULTI_SAMPLE: u32 = 8u;
const FLAG_BOILING: u32 = 16u;
// The previous frame's surfaces and reservoirs are there to reuse.
const FLAG_HISTORY: u32 = 32u;
// Trace specular rays below `specular_max_roughness`.
const FLAG_SPECULAR: u32 = 64u;
// Rougher surfaces (all surfaces without `FLAG_SPECULAR`) reflect the diffuse irradiance
// reshaped by their lobe: HSGI's reuse of the diffuse result (`pc/restir/shade.wgsl`).
const FLAG_REUSE_SPECULAR: u32 = 128u;
// The material's occlusion map darkens the gathered diffuse light (`PcConfig::material_occlusion`).
const FLAG_MATERIAL_OCCLUSION: u32 = 256u;
// `gbuffer.blend_layer` holds a blended layer per pixel (the scene has alpha-`BLEND` materials).
const FLAG_BLEND_LAYER: u32 = 512u;
// The diffuse rays' hits take the punctual lights' direct light from the brick cache instead of
// tracing shadow rays (`PcConfig::hit_lights`).
const FLAG_HIT_LIGHTS_CACHE: u32 = 1024u;

// What a pixel's specular reflection comes from (`specular_kind`).
const SPECULAR_NONE: u32 = 0u;
// A traced GGX VNDF ray (`pc/restir/specular_trace.wgsl`, `pc/restir/specular_resolve.wgsl`).
const SPECULAR_TRACED: u32 = 1u;
// The diffuse samples weighted by the lobe (`pc/restir/shade.wgsl`).
const SPECULAR_REUSED: u32 = 2u;

// Bits of `Reservoir::flags`.
const SAMPLE_SKY: u32 = 1u;
// The shadow pass found the chosen sample occluded and fell back to the temporal one.
const SAMPLE_OCCLUDED: u32 = 2u;

// Bits of +infinity, the G-buffer depth of sky pixels.
const INFINITY_BITS: u32 = 0x7f800000u;
// The largest float: the length of an unbounded ray, the bound of a finite weight.
const FAR: f32 = 3.40282347e38;

// Mirror of `gi_tiers::pc::PcUniforms`.
struct PcUniforms {
    camera: Camera,
    previous_camera: Camera,
    sky: Sky,
    size_px: vec2<u32>,
    trace_px: vec2<u32>,
    seed: vec2<u32>,
    frame_index: u32,
    // Full-resolution pixels per trace pixel along each axis (1 or 2).
    trace_scale: u32,
    flags: u32,
    light_count: u32,
    default_material: u32,
    m_clamp: f32,
    jacobian_max: f32,
    spatial_radius: f32,
    spatial_samples: u32,
    shade_radius: u32,
    normal_cos: f32,
    plane_tolerance: f32,
    boil_factor: f32,
    shadow_cos: f32,
    shadow_distance_ratio: f32,
    // Emissive triangles in the scene's emitter table (0: no emitter candidates).
    emitter_count: u32,
    specular_max_roughness: f32,
    // Most frames the specular history averages.
    specular_history: f32,
    specular_clamp_sigma: f32,
    // BVH segment length of a diffuse ray: the largest float, or in trace-probe mode the
    // short ray beyond which the cache answers.
    probe_ray_m: f32,
    // Multi-sample shading skips a neighbour whose sample lies nearer its receiver than this
    // times the two receivers' distance (0: never).
    shade_contact_ratio: f32,
    // Roughness above which the reused reflection blends linearly to the irradiance over pi,
    // reached at roughness 1 (1: no blend).
    specular_diffuse_from: f32,
    // Trace pixels per side of a temporal-gradient stratum (`PcConfig::gradients`); 0: no
    // gradients.
    gradient_stratum: u32,
    // Strata per row and per column.
    gradient_strata_x: u32,
    gradient_strata_y: u32,
    // The gradient's gain: the history's weight falls by `min(gain * lambda, 1)`.
    gradient_gain: f32,
}

// Binding 0 of bind group 0 in every pass. Named `uniforms`, not `u`: an entry file imports
// it, and naga_oil would rewrite the `u` suffix of integer literals into an imported `u`.
@group(0) @binding(0) var<uniform> uniforms: PcUniforms;

// Mirror of `gi_tiers::pc::GpuGradientSample`, 32 bytes: the BVH ray candidate one trace pixel
// of a temporal-gradient stratum drew in frame `frame_index`, which `gradient` draws again
// (A-SVGF's forward-projected sample, Schied et al. 2018): the receiver's offset origin and
// packed normal give the ray again with the random numbers of that frame and trace pixel.
// `seen` is the luminance of what it found then that does not come from the brick cache
// (`gradient_seen`), `total` the luminance of all of it.
struct GradientSample {
    origin: vec3<f32>,
    normal: u32,
    seen: f32,
    // `GRADIENT_NONE`: the stratum kept no sample (sky, or gradients off).
    trace_index: u32,
    frame_index: u32,
    total: f32,
}

const GRADIENT_NONE: u32 = 0xffffffffu;

// The part of a ray candidate `r` the gradient compares: all but the brick cache's light, so
// the same ray drawn again finds the same value unless the scene changed (the hit's emission
// and direct light, whose shadow rays and emitter sample are drawn again alike, or the sky).
// The cache's light changes every frame by its updates' noise, and lags a change anyway.
fn gradient_seen(r: Reservoir) -> f32 {
    if (r.flags & SAMPLE_SKY) != 0u {
        return luminance(unpack_rgb9e5(r.radiance));
    }
    return luminance(unpack_rgb9e5(r.fixed_radiance));
}

// The trace pixel of `stratum` whose ray is kept for the gradient in frame `frame`, chosen
// anew each frame (A-SVGF picks one pixel per stratum at random); outside the image when the
// stratum, at the image's edge, has no such pixel.
fn gradient_pick(stratum: vec2<u32>, frame: u32) -> vec2<u32> {
    let side = uniforms.gradient_stratum;
    let index = stratum.y * uniforms.gradient_strata_x + stratum.x;
    var sampler = sampler_new(uniforms.seed ^ vec2(0x68e31da4u, 0u), index, frame);
    let o = sampler_next_u32(&sampler) % (side * side);
    return stratum * side + vec2(o % side, o / side);
}

// One trace pixel's receiver: the G-buffer surface of the full-resolution pixel it picked
// this frame. `depth` 0: no surface (every pixel of its block shows the sky).
struct Surface {
    position: vec3<f32>,
    normal: u32,
    // The full-resolution pixel (row-major index).
    pixel: u32,
    // Its G-buffer depth (distance along its camera ray).
    depth: f32,
}

// Mirror of `gi_tiers::pc::GpuSurface`, 12 bytes: a `Surface` as the surface buffers keep it,
// without its position, which `surface_seen_by` computes again from the pixel and the depth
// with the camera of the frame that picked it, as `trace` computed it (`pixel_point`).
struct StoredSurface {
    // The pixel's column and row (x | y << 16; sides are at most 16384): no division to find
    // them again.
    pixel_xy: u32,
    depth: f32,
    normal: u32,
}

// The point pixel `p` shows at depth `depth` (distance along its ray) through `camera`.
fn pixel_point(camera: Camera, p: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(p) + 0.5) / vec2<f32>(uniforms.size_px);
    return camera.position + camera_ray(camera, uv) * depth;
}

fn stored_surface(s: Surface) -> StoredSurface {
    let width = uniforms.size_px.x;
    return StoredSurface((s.pixel % width) | ((s.pixel / width) << 16u), s.depth, s.normal);
}

// A trace pixel without a receiver, in the receivers' buffer (which holds pixels' x | y << 16).
const NO_RECEIVER: u32 = 0xffffffffu;

// The receivers' entry of `s`: its pixel's column and row, or NO_RECEIVER.
fn receiver_entry(s: Surface) -> u32 {
    if s.depth <= 0.0 {
        return NO_RECEIVER;
    }
    let width = uniforms.size_px.x;
    return (s.pixel % width) | ((s.pixel / width) << 16u);
}

// The row-major index of the pixel whose column and row are `xy` (x | y << 16).
fn receiver_pixel(xy: u32) -> u32 {
    return (xy >> 16u) * uniforms.size_px.x + (xy & 0xffffu);
}

// The receiver at `xy` (x | y << 16; `pixel`, its `receiver_pixel`), with this frame's
// G-buffer depth and normal there (`receiver_entry`'s inverse; a receiver is this frame's
// G-buffer surface at its pixel, so only the pixel is kept).
fn receiver_at(xy: u32, pixel: u32, depth: f32, normal: u32) -> Surface {
    let p = vec2(xy & 0xffffu, xy >> 16u);
    return Surface(pixel_point(uniforms.camera, p, depth), normal, pixel, depth);
}

// The receiver `s` keeps, picked in a frame rendered through `camera`.
fn surface_seen_by(s: StoredSurface, camera: Camera) -> Surface {
    let p = vec2(s.pixel_xy & 0xffffu, s.pixel_xy >> 16u);
    let pixel = p.y * uniforms.size_px.x + p.x;
    if s.depth <= 0.0 {
        return Surface(vec3(0.0), s.normal, pixel, s.depth);
    }
    return Surface(pixel_point(camera, p, s.depth), s.normal, pixel, s.depth);
}

// A reservoir as the passes work on it; the buffers keep it as a `StoredReservoir`.
struct Reservoir {
    // The sample point `y`, or for a sky sample its unit direction.
    position: vec3<f32>,
    // Unbiased contribution weight W (0: empty).
    w: f32,
    // Radiance leaving `y` towards the receiver (Lambertian, so towards any receiver on its
    // side), or the sky's radiance along the direction (RGB9E5).
    radiance: u32,
    // Samples behind it.
    m: f32,
    // Packed normal of the surface at `y`, on the side the ray arrived from; 0 for sky.
    normal: u32,
    flags: u32,
    // After the shadow pass, for an occluded pixel: distance to the occluder and packed
    // direction of the occluded sample.
    occluder_distance: f32,
    occluder_direction: u32,
    // What `radiance` is made of at a surface sample, so that reuse in later frames can
    // refresh its indirect part from the cache as the cache converges: the emission and the
    // punctual lights' and emitters' direct light (RGB9E5), and the albedo (unorm8 rgb: diffuse
    // plus split-sum specular towards the receiver) that reflects the cache's bounced light.
    fixed_radiance: u32,
    albedo: u32,
}

// Mirror of `gi_tiers::pc::GpuReservoir`, 32 bytes: a `Reservoir` as the buffers keep it.
// The initial and temporal reservoirs keep what a later frame needs to refresh a surface
// sample (`fixed_radiance`, `albedo`); the resolved ones, which no later frame reads, keep the
// shadow pass's occluder instead (`store_resolved`).
struct StoredReservoir {
    position: vec3<f32>,
    w: f32,
    radiance: u32,
    // The packed normal's two 16-bit snorm components cut to their upper 15 bits (bits 0-14,
    // 15-29), and the flags (bits 30-31).
    normal_flags: u32,
    // M as an f16 (bits 0-15; integers exact to 2048), and the albedo as unorm 5:6:5 or the
    // occluder's distance as an f16 (bits 16-31).
    m_extra: u32,
    // `fixed_radiance`, or the occluder's direction.
    extra: u32,
}

fn pack_normal_flags(normal: u32, flags: u32) -> u32 {
    return ((normal & 0xffffu) >> 1u) | ((normal >> 17u) << 15u) | (flags << 30u);
}

fn unpack_normal(packed: u32) -> u32 {
    return ((packed & 0x7fffu) << 1u) | (((packed >> 15u) & 0x7fffu) << 17u);
}

// Unorm8 rgb (`pack4x8unorm`, alpha 0) to 5:6:5 and back (0 stays 0, and so does an albedo
// below 8/255 in every channel: a sample that dark is not refreshed).
fn albedo_to_565(albedo: u32) -> u32 {
    return ((albedo & 0xffu) >> 3u) | (((albedo >> 10u) & 0x3fu) << 5u) | (((albedo >> 19u) & 0x1fu) << 11u);
}

fn albedo_from_565(packed: u32) -> u32 {
    let r = packed & 0x1fu;
    let g = (packed >> 5u) & 0x3fu;
    let b = (packed >> 11u) & 0x1fu;
    return ((r << 3u) | (r >> 2u)) | (((g << 2u) | (g >> 4u)) << 8u) | (((b << 3u) | (b >> 2u)) << 16u);
}

// The initial and temporal reservoirs' form: no occluder (none is set before `shadow`).
fn store_reservoir(r: Reservoir) -> StoredReservoir {
    let m = half_bits(r.m);
    return StoredReservoir(
        r.position, r.w, r.radiance, pack_normal_flags(r.normal, r.flags),
        m | (albedo_to_565(r.albedo) << 16u), r.fixed_radiance
    );
}

fn load_reservoir(s: StoredReservoir) -> Reservoir {
    let m = half_value(s.m_extra & 0xffffu);
    return Reservoir(
        s.position, s.w, s.radiance, m, unpack_normal(s.normal_flags), s.normal_flags >> 30u,
        0.0, 0u, s.extra, albedo_from_565(s.m_extra >> 16u)
    );
}

// The resolved reservoirs' form: the occluder, not what a refresh needs.
fn store_resolved(r: Reservoir) -> StoredReservoir {
    return StoredReservoir(
        r.position, r.w, r.radiance, pack_normal_flags(r.normal, r.flags),
        pack_half2(vec2(r.m, r.occluder_distance)), r.occluder_direction
    );
}

fn load_resolved(s: StoredReservoir) -> Reservoir {
    let m = unpack_half2(s.m_extra);
    return Reservoir(
        s.position, s.w, s.radiance, m.x, unpack_normal(s.normal_flags), s.normal_flags >> 30u,
        m.y, s.extra, 0u, 0u
    );
}

// Mirror of `gi_tiers::pc::GpuSpecularSample`, 32 bytes: one trace pixel's specular ray.
struct SpecularSample {
    // The point the ray hit, or for a miss its unit direction (`SAMPLE_SKY`).
    position: vec3<f32>,
    // Solid-angle pdf with which the receiver's VNDF sampling drew the ray (0: no sample).
    pdf: f32,
    // Radiance arriving along the ray.
    radiance: vec3<f32>,
    flags: u32,
}

// A pixel's specular history (`pc/restir/specular_temporal.wgsl`): the averaged radiance of
// traced rays or ratio of reused diffuse samples, the frames it averages (0: none) and which
// of the two it is.
struct SpecularHistory {
    value: vec3<f32>,
    length: f32,
    reused: bool,
}

// A specular history entry (`pack_specular_history`): x the value in RGB9E5, rounded
// stochastically by `u` (`pack_rgb9e5_dithered`: unbiased, so that a history converging on a
// value less than half a step away still reaches it on average), y a byte: the length in bits
// 0-6 (lengths are at most 127 frames) and the kind in bit 7 (set: a reused ratio).
const SPECULAR_REUSED_BIT: u32 = 0x80u;

fn pack_specular_history(value: vec3<f32>, length: f32, reused: bool, u: f32) -> vec2<u32> {
    let byte = u32(round(clamp(length, 0.0, 127.0))) | select(0u, SPECULAR_REUSED_BIT, reused);
    return vec2(pack_rgb9e5_dithered(value, u), byte);
}

fn unpack_specular_history(packed: vec2<u32>) -> SpecularHistory {
    return SpecularHistory(
        unpack_rgb9e5(packed.x),
        f32(packed.y & 0x7fu),
        (packed.y & SPECULAR_REUSED_BIT) != 0u,
    );
}

fn empty_reservoir() -> Reservoir {
    return Reservoir(vec3(0.0), 0.0, 0u, 0.0, 0u, 0u, 0.0, 0u, 0u, 0u);
}

fn is_sky_depth(depth: f32) -> bool {
    return bitcast<u32>(depth) == INFINITY_BITS || !(depth < 3.0e38);
}

// The source of the specular reflection of a pixel with G-buffer depth `depth` and roughness
// `roughness`, under shader flags `flags`: traced below `max_roughness`, reused from the
// diffuse samples from it up, none for the sky or a stage switched off.
fn specular_kind(flags: u32, max_roughness: f32, depth: f32, roughness: f32) -> u32 {
    if is_sky_depth(depth) {
        return SPECULAR_NONE;
    }
    if roughness < max_roughness {
        return select(SPECULAR_NONE, SPECULAR_TRACED, (flags & FLAG_SPECULAR) != 0u);
    }
    return select(SPECULAR_NONE, SPECULAR_REUSED, (flags & FLAG_REUSE_SPECULAR) != 0u);
}

fn has_surface(s: Surface) -> bool {
    return s.depth > 0.0;
}

// Unit direction from receiver `x` to the sample, and the distance (for sky samples 3e38).
fn sample_direction(r: Reservoir, x: vec3<f32>) -> vec4<f32> {
    if (r.flags & SAMPLE_SKY) != 0u {
        return vec4(r.position, 3.0e38);
    }
    let d = r.position - x;
    let len = length(d);
    return vec4(d / max(len, 1e-12), len);
}

// Target function of `r`'s sample at receiver (`x`, `n`): luminance of its radiance times the
// cosine at the receiver; 0 when the sample lies below the receiver's horizon or sees the
// receiver from behind its own surface.
fn target_pdf(r: Reservoir, x: vec3<f32>, n: vec3<f32>) -> f32 {
    let d = sample_direction(r, x);
    let cos_x = dot(n, d.xyz);
    if cos_x <= 0.0 {
        return 0.0;
    }
    if (r.flags & SAMPLE_SKY) == 0u && dot(unpack_unit_vector(r.normal), -d.xyz) <= 0.0 {
        return 0.0;
    }
    return luminance(unpack_rgb9e5(r.radiance)) * cos_x;
}

// Jacobian of the reconnection shift that moves `r`'s sample from receiver `old_receiver` to
// `new_receiver` (Ouyang et al. 2021, eq. 11: the ratio of the solid angles the sample's surface patch
// subtends), at most `j_max` (HSGI: bound the maximum, "prefer darken bias than lighten
// bias"). Sky samples (at infinity) keep their solid angle: 1.
fn reconnection_jacobian(r: Reservoir, old_receiver: vec3<f32>, new_receiver: vec3<f32>, j_max: f32) -> f32 {
    if (r.flags & SAMPLE_SKY) != 0u {
        return 1.0;
    }
    let n = unpack_unit_vector(r.normal);
    let a = old_receiver - r.position;
    let b = new_receiver - r.position;
    let la2 = max(dot(a, a), 1e-12);
    let lb2 = max(dot(b, b), 1e-12);
    let cos_from = abs(dot(n, a)) / sqrt(la2);
    let cos_to = abs(dot(n, b)) / sqrt(lb2);
    if cos_from <= 1e-6 {
        return select(0.0, j_max, cos_to > 0.0);
    }
    return min((cos_to / cos_from) * (la2 / lb2), j_max);
}

// Streaming combination of reservoirs (Bitterli et al. 2020, Alg. 4): `chosen` is kept with
// probability proportional to its weight.
struct Combiner {
    chosen: Reservoir,
    // Target function of `chosen` at the receiver.
    chosen_pdf: f32,
    weight_sum: f32,
    m: f32,
}

fn combiner_new() -> Combiner {
    return Combiner(empty_reservoir(), 0.0, 0.0, 0.0);
}

// Adds `r` (whose `m` counts) with target value `p` at the receiver and shift Jacobian `j`;
// `u` uniform in [0, 1).
fn combiner_add(c: ptr<function, Combiner>, r: Reservoir, m: f32, p: f32, j: f32, u: f32) {
    let w = p * r.w * m * j;
    (*c).m += m;
    if !(w > 0.0) || !(w < 3.0e38) {
        return;
    }
    (*c).weight_sum += w;
    if u * (*c).weight_sum < w {
        (*c).chosen = r;
        (*c).chosen_pdf = p;
    }
}

// The combined reservoir: the chosen sample with W = weight_sum / (M p(chosen)) and M.
fn combiner_finish(c: Combiner) -> Reservoir {
    var r = c.chosen;
    r.m = c.m;
    if c.chosen_pdf > 0.0 && c.m > 0.0 {
        r.w = c.weight_sum / (c.m * c.chosen_pdf);
    } else {
        r.w = 0.0;
    }
    r.flags &= ~SAMPLE_OCCLUDED;
    r.occluder_distance = 0.0;
    r.occluder_direction = 0u;
    return r;
}

// The irradiance `r` gives receiver (`x`, `n`) that it was built for (`from`): L cos W times
// the shift's Jacobian when the receivers differ.
fn reservoir_irradiance(r: Reservoir, source: vec3<f32>, x: vec3<f32>, n: vec3<f32>, j_max: f32) -> vec3<f32> {
    if r.w <= 0.0 {
        return vec3(0.0);
    }
    let d = sample_direction(r, x);
    let cos_x = dot(n, d.xyz);
    if cos_x <= 0.0 {
        return vec3(0.0);
    }
    if (r.flags & SAMPLE_SKY) == 0u && dot(unpack_unit_vector(r.normal), -d.xyz) <= 0.0 {
        return vec3(0.0);
    }
    return unpack_rgb9e5(r.radiance) * (cos_x * r.w * reconnection_jacobian(r, source, x, j_max));
}

// Whether two receivers lie on one surface for reuse: normals within the cone and `b` within
// `tolerance` times `a`'s depth of `a`'s tangent plane (Ouyang et al. 2021 compare depths within
// 10% and normals within 25 degrees; the plane distance also accepts a plane seen at a grazing
// angle, whose depth changes fast from pixel to pixel).
fn similar_surfaces(a: Surface, b: Surface, normal_cos: f32, tolerance: f32) -> bool {
    if !has_surface(a) || !has_surface(b) {
        return false;
    }
    let na = unpack_unit_vector(a.normal);
    let nb = unpack_unit_vector(b.normal);
    if dot(na, nb) < normal_cos {
        return false;
    }
    return abs(dot(b.position - a.position, na)) <= tolerance * a.depth;
}

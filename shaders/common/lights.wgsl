// The scene's light sources as every GI technique evaluates them: KHR_lights_punctual lights
// through the rule of `gi_scene::WorldLight::incident` (glTF inverse-square falloff, the range
// window, the spot cone), the constant or gradient sky of `gi_scene::Sky::radiance`, and a point
// drawn on the emissive triangles as the reference's `Reference::sample_emitter` draws it (by
// power through the emitter table, then uniformly by area). Written operation for operation like
// the CPU rules, so that the path tracer (`path/trace.wgsl`), which matches the reference up to
// f32 rounding, and the cache's lighting read what a light delivers from one statement.
#define_import_path gi::lights

#import gi::sky::Sky
#import gi::brdf::is_finite
#import gi::sampling::uniform_triangle
#import gi::scene::{PunctualLight, lerp_rgb, triangles, emitters, selection, emission, geometric_normal, tex_coords, material_of, alpha_covers, ALPHA_OPAQUE}

// Light kinds of `PunctualLight::kind`.
const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_SPOT: u32 = 2u;
// Distance standing for "infinitely far" (directional lights).
const LIGHT_FAR: f32 = 3.40282347e38;

// What one punctual light delivers at a point, before visibility and the cosine.
struct LightIncident {
    // Unit direction from the point towards the light.
    wi: vec3<f32>,
    // Distance to the light; LIGHT_FAR for directional lights.
    distance: f32,
    // Irradiance on a surface facing the light (W/m^2 per channel).
    irradiance: vec3<f32>,
}

// `gi_scene::WorldLight::incident(point)`.
fn light_incident(light: PunctualLight, point: vec3<f32>) -> LightIncident {
    if light.kind == LIGHT_DIRECTIONAL {
        return LightIncident(-light.direction, LIGHT_FAR, light.intensity);
    }
    let to_light = light.position - point;
    let distance_sq = max(dot(to_light, to_light), 1e-8);
    let distance = sqrt(distance_sq);
    let wi = to_light / distance;
    var falloff = 1.0 / distance_sq;
    if light.has_range != 0u {
        let ratio = distance / light.range;
        let r2 = ratio * ratio;
        let window = clamp(1.0 - r2 * r2, 0.0, 1.0);
        falloff *= window * window;
    }
    if light.kind == LIGHT_SPOT {
        let cd = dot(light.direction, -wi);
        let cone = clamp((cd - light.cos_outer) * light.spot_scale, 0.0, 1.0);
        falloff *= cone * cone;
    }
    return LightIncident(wi, distance, light.intensity * falloff);
}

// `gi_scene::Sky::radiance(dir)` for a unit direction.
fn sky_radiance(sky: Sky, dir: vec3<f32>) -> vec3<f32> {
    if sky.kind == 0u {
        return sky.zenith.xyz;
    }
    let y = clamp(dir.y, -1.0, 1.0);
    if y >= 0.0 {
        return lerp_rgb(sky.horizon.xyz, sky.zenith.xyz, y);
    }
    return lerp_rgb(sky.horizon.xyz, sky.ground.xyz, -y);
}

// A point drawn on an emissive triangle, seen from a shading point.
struct EmitterSample {
    // Unit direction from the shading point to the emitter point.
    wi: vec3<f32>,
    // Distance to the emitter point.
    distance: f32,
    // Radiance leaving the emitter point towards the shading point.
    radiance: vec3<f32>,
    // Solid-angle pdf at the shading point; 0 when the sample cannot contribute (the back of a
    // single-sided emitter, degenerate geometry).
    pdf: f32,
    // The emitter's geometric normal on the side facing the shading point.
    normal: vec3<f32>,
}

// The entry `partition_point(cdf <= u)` of the emitter table (`gi_gpu::EmitterTable`'s integer
// thresholds), as the reference's `EmitterTable::pick` picks it.
fn pick_emitter(u: f32, emitter_count: u32) -> u32 {
    let k = u32(u * 16777216.0);
    var lo = 0u;
    var hi = emitter_count;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if emitters[mid].threshold <= k {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return emitters[min(lo, emitter_count - 1u)].triangle;
}

// The solid-angle pdf with which `sample_emitter` draws the point of emitter triangle
// `triangle` that a ray from the receiver along `dir` hit at distance `t`; 0 for triangles
// outside the emitter table (the path tracer's MIS weights and the PC tier's candidates).
fn emitter_pdf(triangle: u32, t: f32, dir: vec3<f32>) -> f32 {
    let p_select = selection[triangle];
    if p_select <= 0.0 {
        return 0.0;
    }
    let tri = triangles[triangle];
    let c = cross(tri.pb.xyz - tri.pa.xyz, tri.pc.xyz - tri.pa.xyz);
    let len = sqrt(dot(c, c));
    let area = 0.5 * len;
    var cos_light = 0.0;
    if len > 0.0 {
        cos_light = abs(dot(c * (1.0 / len), dir));
    }
    if area <= 0.0 || cos_light <= 0.0 {
        return 0.0;
    }
    return p_select * t * t / (area * cos_light);
}

// `Reference::sample_emitter(p, u_select, u_point)`; `emitter_count` must be at least 1.
fn sample_emitter(
    p: vec3<f32>,
    u_select: f32,
    u_point: vec2<f32>,
    emitter_count: u32,
    default_material: u32,
) -> EmitterSample {
    var sample = EmitterSample(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0));
    let triangle = pick_emitter(u_select, emitter_count);
    let p_select = selection[triangle];
    let tri = triangles[triangle];
    let b = uniform_triangle(u_point);
    let e1 = tri.pb.xyz - tri.pa.xyz;
    let e2 = tri.pc.xyz - tri.pa.xyz;
    let y = tri.pa.xyz + e1 * b.x + e2 * b.y;
    let c = cross(e1, e2);
    let area = 0.5 * sqrt(dot(c, c));
    let to_light = y - p;
    let distance_sq = dot(to_light, to_light);
    if area <= 0.0 || distance_sq <= 0.0 {
        return sample;
    }
    let distance = sqrt(distance_sq);
    let wi = to_light / distance;
    let ng = geometric_normal(tri);
    let cos_light = -dot(ng, wi);
    let material = material_of(triangle, default_material);
    if cos_light == 0.0 || (cos_light < 0.0 && material.double_sided == 0u) {
        return sample;
    }
    // Where an alpha-tested emitter is absent it emits nothing.
    if material.alpha_mode != ALPHA_OPAQUE && !alpha_covers(triangle, b) {
        return sample;
    }
    let pdf = p_select * distance_sq / (area * abs(cos_light));
    if !(pdf > 0.0 && is_finite(pdf)) {
        return sample;
    }
    let tc = tex_coords(triangle, vec3(1.0 - b.x - b.y, b.x, b.y), 0.0);
    return EmitterSample(wi, distance, emission(material, tc), pdf, select(-ng, ng, cos_light > 0.0));
}

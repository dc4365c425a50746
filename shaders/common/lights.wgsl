// The scene's light sources as every GI technique evaluates them: KHR_lights_punctual lights
// through the rule of `gi_scene::WorldLight::incident` (glTF inverse-square falloff, the range
// window, the spot cone), and the constant or gradient sky of `gi_scene::Sky::radiance`. Written
// operation for operation like the CPU rules (and like `path/trace.wgsl`'s inline copies), so
// the cache's lighting and the path tracer agree on what a light delivers.
#define_import_path gi::lights

#import gi::scene::{PunctualLight, lerp_rgb}

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

// The scene's sky (`gi_scene::Sky`): kind 0 constant (`zenith` is its radiance), 1 gradient.
// 64 bytes, uniform-compatible; mirrored by `gi_cache::lighting::GpuSky`.
struct Sky {
    zenith: vec4<f32>,
    horizon: vec4<f32>,
    ground: vec4<f32>,
    kind: u32,
    pad_a: u32,
    pad_b: u32,
    pad_c: u32,
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

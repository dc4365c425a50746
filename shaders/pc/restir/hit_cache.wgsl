// What a hit of the PC tier's rays reads from the brick cache, shared by `hit.wgsl` (the hits
// as they are shaded) and `temporal.wgsl` (a reused sample's cached part read again): the
// bounced light, plus the punctual lights' direct light when the diffuse rays' hits leave those
// to the cache (`FLAG_HIT_LIGHTS_CACHE`, `PcConfig::hit_lights`). It imports no bindings but the
// uniforms and the cache (group 2), so passes without the scene or the BVH can use it.
#define_import_path gi::pc::restir::hit_cache

#import gi::cache::trace::{cache_bounced_irradiance, cache_lit_irradiance}
#import gi::pc::restir::common::{uniforms, FLAG_HIT_LIGHTS_CACHE}

// Whether a diffuse ray's hit takes the punctual lights from the cache.
fn hit_lights_from_cache() -> bool {
    return (uniforms.flags & FLAG_HIT_LIGHTS_CACHE) != 0u;
}

// The cache's part a hit at `p` with geometric normal `n` adds to what it lit itself: the
// bounced light, and the punctual lights' direct light when `lights_from_cache`.
fn hit_cache_irradiance(p: vec3<f32>, n: vec3<f32>, lights_from_cache: bool) -> vec3<f32> {
    if lights_from_cache {
        return cache_lit_irradiance(p, n).xyz;
    }
    return cache_bounced_irradiance(p, n).xyz;
}

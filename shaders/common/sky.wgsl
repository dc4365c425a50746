// The sky's parameters, apart from the lights (`gi::lights`, which evaluates them with
// `sky_radiance`), so that uniforms holding a sky import the struct alone: naga_oil parses and
// validates every module an entry file imports, and `gi::lights` brings the scene with it.
#define_import_path gi::sky

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

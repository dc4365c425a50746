// Per-frame uniforms every pass of a frame reads: camera transforms, position, exposure,
// image size and frame counters. Mirrored by `gi_gpu::FrameUniforms` on the Rust side; a test
// checks the two layouts agree.
#define_import_path gi::frame

struct FrameUniforms {
    // World space -> clip space of the current frame's camera (projection times view).
    clip_from_world: mat4x4<f32>,
    // Clip space -> world space, to turn pixels and depths back into world positions.
    world_from_clip: mat4x4<f32>,
    // Camera (pinhole) position in world space, meters.
    camera_position_ws: vec3<f32>,
    // Scalar exposure applied before display; GI passes work in unexposed radiance.
    exposure: f32,
    // Render target size in pixels.
    size_px: vec2<u32>,
    // Frames rendered since the tier was created (drives temporal sample sequences).
    frame_index: u32,
    // Random seed of the render, mixed into every per-pixel random stream.
    seed: u32,
}

//! Per-frame uniforms shared by every pass of a frame.

use bytemuck::{Pod, Zeroable};

/// Rust mirror of `gi::frame::FrameUniforms` (`shaders/common/frame.wgsl`). Matrices are
/// column-major (`m[column][row]`, as glam's `Mat4::to_cols_array_2d`). The layout is checked
/// against naga's by a test, not trusted.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    /// World space -> clip space of the current frame's camera.
    pub clip_from_world: [[f32; 4]; 4],
    /// Clip space -> world space.
    pub world_from_clip: [[f32; 4]; 4],
    /// Camera position in world space, meters.
    pub camera_position_ws: [f32; 3],
    /// Scalar exposure applied before display.
    pub exposure: f32,
    /// Render target size in pixels.
    pub size_px: [u32; 2],
    /// Frames rendered since the tier was created.
    pub frame_index: u32,
    /// Random seed of the render.
    pub seed: u32,
}

impl FrameUniforms {
    /// The WGSL struct's name, for layout checks.
    pub const WGSL_NAME: &'static str = "FrameUniforms";
    /// The shader file that declares it.
    pub const WGSL_FILE: &'static str = "common/frame.wgsl";
}

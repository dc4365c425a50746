//! The pinhole camera shared by every ray-cast pass: [`GpuCamera`], the Rust mirror of
//! `Camera` in `shaders/common/camera.wgsl` (import path `gi::camera`, which also has
//! `camera_ray`, the reference's `CameraView::ray_direction`).

use bytemuck::{Pod, Zeroable};
use gi_scene::CameraView;

/// A pinhole camera with the values the reference derives from it, 64 bytes (`Camera` in
/// WGSL).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCamera {
    /// Pinhole position, world space.
    pub position: [f32; 3],
    /// `tan(yfov / 2)`.
    pub tan_half_fov: f32,
    /// Unit camera axes in world space.
    pub right: [f32; 3],
    /// Image width over height.
    pub aspect: f32,
    pub up: [f32; 3],
    pub pad_a: f32,
    pub forward: [f32; 3],
    pub pad_b: f32,
}

impl GpuCamera {
    /// `camera` for an image of `size` pixels, computed as the reference computes it (so GPU
    /// and CPU rays agree bit for bit).
    pub fn new(camera: &CameraView, size: (u32, u32)) -> Self {
        Self {
            position: camera.position.to_array(),
            tan_half_fov: (camera.yfov * 0.5).tan(),
            right: camera.right.to_array(),
            aspect: size.0 as f32 / size.1 as f32,
            up: camera.up.to_array(),
            pad_a: 0.0,
            forward: camera.forward.to_array(),
            pad_b: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_matches_wgsl() {
        let module = crate::ShaderLibrary::new()
            .compose("common/camera.wgsl", &[])
            .expect("camera.wgsl composes");
        let layout = crate::wgsl_struct_layout(&module, "Camera").expect("struct Camera");
        assert_eq!(layout.size as usize, size_of::<GpuCamera>());
        assert_eq!(
            layout.members,
            crate::rust_field_offsets!(GpuCamera {
                position,
                tan_half_fov,
                right,
                aspect,
                up,
                pad_a,
                forward,
                pad_b
            })
        );
    }
}

//! Debug views of the cache: what a pinhole camera sees when its rays go through the cache's
//! hierarchical DDA instead of the scene (entry point `debug_view` of
//! `shaders/cache/query/debug_view.wgsl`). They show what the cache holds, not what the scene
//! looks like: voxel sizes, holes, leaks through thin walls and the lighting stored per surfel
//! side.

use std::fmt;
use std::str::FromStr;

use bytemuck::{Pod, Zeroable};
use gi_gpu::{GpuContext, GpuError, ShaderLibrary, wgpu};
use gi_image::Image;
use gi_scene::CameraView;
use glam::Vec3;

use crate::buffers::CacheBuffers;
use crate::query::{Batch, CACHE_BIND_GROUP, CacheTracer};

/// What a debug image shows at each pixel whose ray hits a voxel (misses are black).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DebugView {
    /// The voxel's diffuse albedo.
    Albedo,
    /// The voxel's normal on the ray's side, mapped from [-1, 1] to [0, 1].
    Normal,
    /// Radiance leaving the surfel side the ray sees (its stored irradiance times albedo / pi,
    /// plus emission): what a ray gathering light from the cache receives. Black until the
    /// cache has been lit.
    Radiance,
    /// The stored irradiance (direct + indirect) of the side the ray sees, before the albedo.
    Irradiance,
    /// One color per clipmap level, shaded by the entered face's orientation: shows voxel
    /// sizes and where each level ends.
    Occupancy,
    /// The entered axis face and the side seen: the face's axis in hue (x red, y green, z
    /// blue), bright where the ray sees the surfel's front side, dim where it sees the back.
    Face,
    /// Distance to the hit, `1 / (1 + t / 4 m)`.
    Distance,
}

impl DebugView {
    /// Every view, in the order of their shader constants.
    pub const ALL: [DebugView; 7] = [
        DebugView::Albedo,
        DebugView::Normal,
        DebugView::Radiance,
        DebugView::Irradiance,
        DebugView::Occupancy,
        DebugView::Face,
        DebugView::Distance,
    ];

    /// The name the command line uses.
    pub fn name(self) -> &'static str {
        match self {
            DebugView::Albedo => "albedo",
            DebugView::Normal => "normal",
            DebugView::Radiance => "radiance",
            DebugView::Irradiance => "irradiance",
            DebugView::Occupancy => "occupancy",
            DebugView::Face => "face",
            DebugView::Distance => "distance",
        }
    }

    /// The `DEBUG_*` constant of `shaders/cache/query/debug_view.wgsl`.
    fn shader_index(self) -> u32 {
        Self::ALL.iter().position(|&v| v == self).unwrap_or(0) as u32
    }
}

impl fmt::Display for DebugView {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A view name that is not one of [`DebugView::ALL`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown cache debug view `{0}` (expected one of: albedo, normal, radiance, irradiance, occupancy, face, distance)"
)]
pub struct UnknownDebugView(pub String);

impl FromStr for DebugView {
    type Err = UnknownDebugView;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|v| v.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownDebugView(s.to_owned()))
    }
}

/// Uniforms of `debug_view` (`DebugViewUniforms` in the shader, 80 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuDebugView {
    pub position: [f32; 3],
    pub tan_half_fov_y: f32,
    pub right: [f32; 3],
    pub aspect: f32,
    pub up: [f32; 3],
    pub width: u32,
    pub forward: [f32; 3],
    pub height: u32,
    pub view: u32,
    /// Longest ray, meters.
    pub t_max: f32,
    pub pad_a: u32,
    pub pad_b: u32,
}

impl CacheTracer {
    /// Renders `view` of `cache` through `camera` into a `width x height`
    /// linear image (pixel centers as [`CameraView::ray_direction`]). Stalls the GPU.
    pub fn render_debug_view(
        &self,
        ctx: &GpuContext,
        cache: &CacheBuffers,
        view: DebugView,
        camera: &CameraView,
        width: u32,
        height: u32,
    ) -> Image {
        let uniforms = GpuDebugView {
            position: camera.position.to_array(),
            tan_half_fov_y: (camera.yfov * 0.5).tan(),
            right: camera.right.to_array(),
            aspect: width as f32 / height.max(1) as f32,
            up: camera.up.to_array(),
            width,
            forward: camera.forward.to_array(),
            height,
            view: view.shader_index(),
            t_max: f32::MAX,
            ..Default::default()
        };
        let pixels = u64::from(width) * u64::from(height);
        let uniform = ctx.create_buffer_init(
            "cache.debug_view_uniforms",
            bytemuck::bytes_of(&uniforms),
            wgpu::BufferUsages::UNIFORM,
        );
        let output = ctx.create_buffer(
            "cache.debug_view_pixels",
            pixels.max(1) * 16,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache.debug_view_batch"),
            layout: &self.debug_view_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        let batch = Batch {
            buffers: vec![uniform, output],
            bind_group,
        };
        let mut encoder = ctx.create_encoder("cache.debug_view");
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cache/debug_view"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.debug_view);
            pass.set_bind_group(0, &batch.bind_group, &[]);
            pass.set_bind_group(CACHE_BIND_GROUP, &cache.bind_group, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        ctx.submit_and_wait(encoder);
        let values = ctx.read_buffer::<[f32; 4]>(&batch.buffers[1]);
        batch.release(ctx);
        Image::from_fn(width, height, |x, y| {
            let [r, g, b, _] = values[(x + y * width) as usize];
            Vec3::new(r, g, b)
        })
    }
}

/// Renders `view` of `cache` through `camera` with a tracer made for this one image (building
/// the pipelines costs more than a small image; keep a [`CacheTracer`] to render many).
pub fn render_debug_view(
    ctx: &GpuContext,
    cache: &CacheBuffers,
    view: DebugView,
    camera: &CameraView,
    width: u32,
    height: u32,
) -> Result<Image, GpuError> {
    let tracer = CacheTracer::new(ctx, &ShaderLibrary::new())?;
    Ok(tracer.render_debug_view(ctx, cache, view, camera, width, height))
}

//! The GPU core of the product: a headless wgpu (Vulkan) context with memory accounting, the
//! WGSL shader library composed with naga_oil, per-pass GPU timers, and the structs shared
//! between Rust and WGSL.
//!
//! ```no_run
//! # fn demo() -> Result<(), gi_gpu::GpuError> {
//! use gi_gpu::{GpuContext, GpuTimer, ShaderLibrary};
//!
//! let ctx = GpuContext::new()?;
//! let shaders = ShaderLibrary::new();
//! let module = shaders.create_module(&ctx, "test/double.wgsl", &[])?;
//! let pipeline = ctx.create_compute_pipeline("test/double", &module, "double_values");
//! let values = ctx.create_buffer_init(
//!     "test.values",
//!     bytemuck::cast_slice(&[1.0f32; 64]),
//!     wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
//! );
//! let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
//!     label: Some("test/double"),
//!     layout: &pipeline.get_bind_group_layout(0),
//!     entries: &[wgpu::BindGroupEntry { binding: 0, resource: values.as_entire_binding() }],
//! });
//! let mut timer = GpuTimer::new(&ctx, "frame", 8);
//! let mut encoder = ctx.create_encoder("frame");
//! timer.compute_pass(&ctx, &mut encoder, "test/double", |pass| {
//!     pass.set_pipeline(&pipeline);
//!     pass.set_bind_group(0, &bind_group, &[]);
//!     pass.dispatch_workgroups(1, 1, 1);
//! });
//! println!("{}", timer.finish(&ctx, encoder));
//! assert_eq!(ctx.read_buffer::<f32>(&values), vec![2.0; 64]);
//! println!("{}", ctx.memory());
//! # Ok(()) }
//! ```
//!
//! A technique of a tier (the G-buffer here, the brick cache, ReSTIR GI, a denoiser) is an
//! object implementing [`Technique`]: it owns its pipelines, buffers and histories and records
//! a frame's passes through a [`Recorder`] from typed inputs to typed outputs, so a tier's
//! frame reads as the list of its techniques.
//!
//! Buffers and textures made through the context are counted per label in
//! [`GpuContext::memory`] and stay alive until released ([`GpuContext::release_buffer`],
//! [`GpuContext::release_labeled`]): a technique releases what it replaces.
//!
//! GPU tests run on Mesa's software Vulkan driver (lavapipe). They skip with a loud notice when
//! no adapter exists, unless `GI_REQUIRE_GPU` is set (CI sets it), which makes a missing
//! adapter a failure: see [`GpuContext::new_or_skip`].

pub mod binding;
pub mod bvh;
mod camera;
mod context;
mod error;
mod frame;
pub mod gbuffer;
mod layout;
mod memory;
mod pingpong;
mod scene;
mod shaders;
mod skin;
mod technique;
pub mod textures;
mod timer;

pub use camera::GpuCamera;
pub use context::{ADAPTER_ENV, DeviceSharing, GpuContext, GpuOptions, REQUIRE_GPU_ENV};
pub use error::GpuError;
pub use frame::FrameUniforms;
pub use gbuffer::{GBuffer, GBufferData, GBufferInputs, GBufferOutputs};
pub use layout::{StructLayout, wgsl_struct_layout};
pub use memory::MemoryReport;
pub use pingpong::PingPong;
pub use scene::{
    ALPHA_BLEND, ALPHA_MASK, ALPHA_OPAQUE, ALPHA_TEST, EmitterTable, GpuEmitter, GpuLight,
    GpuMaterial, GpuScene, GpuTriangleExtras, GpuTriangleShading, NO_TEXTURE, SceneUploadError,
    triangle_extras, triangle_shading,
};
pub use shaders::{SHADER_CAPABILITIES, SHADER_DIR_ENV, ShaderDefValue, ShaderLibrary};
pub use skin::gpu_skinned_nodes;
pub use technique::{Recorder, Technique};
pub use textures::{
    GpuTextureRef, SceneTextures, TEXTURE_BIND_GROUP, TextureError, TextureOptions,
};
pub use timer::{FRAMES_IN_FLIGHT, GpuTimer, PassTimings, TimerMode};

/// The naga and wgpu versions this crate is built against, re-exported so users name the same
/// types.
pub use {naga, wgpu};

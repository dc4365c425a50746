//! The tiered crate: the interface every GI tier implements, the tiers, the [`Renderer`]
//! facade that renders the frames of a scene as an engine asks for them (one
//! [`FrameRequest`] per frame, on the engine's device if given, the frame as textures), and
//! [`select`], the policy by which [`TierChoice::Auto`] picks a tier for the adapter.
//!
//! Layout: [`tier`](Tier) (what a tier is), [`requirements`] (what each tier declares for
//! selection), [`tracer`] (the path tracer every GPU tier takes its direct light from),
//! [`output`] (frames as textures), one module per tier (`cpu`, [`path`], [`mobile`], [`pc`];
//! none imports another), [`select`] and the renderer on top.
//!
//! ```no_run
//! # fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use gi_tiers::{FrameBudget, FrameRequest, Renderer, TierChoice};
//! use glam::{Quat, Vec3};
//!
//! let mut scene = gi_scene::load("cornell-box")?;
//! // A node the caller moves between frames is marked before rendering.
//! let moving = scene.nodes.len() - 1;
//! scene.nodes[moving].movable = true;
//! // The best real-time GI tier whose estimated frame fits 16 ms on this adapter.
//! let mut renderer = Renderer::builder(scene)
//!     .tier(TierChoice::AutoWithin(FrameBudget::from_ms(16.0)))
//!     .size(320, 240)
//!     .build()?;
//! if let Some(selection) = renderer.selection() {
//!     println!("{}: {}", selection.chosen, selection.reason);
//! }
//! for frame in 0..4 {
//!     let time_s = frame as f32 / 60.0;
//!     renderer.set_node_transform(moving, Vec3::X * time_s, Quat::IDENTITY, Vec3::ONE)?;
//!     renderer.submit(&FrameRequest::at(time_s))?; // no wait, no readback
//! }
//! // The last frame as textures on the renderer's device (GPU tiers), or read back.
//! if let Some(textures) = renderer.output_textures()? {
//!     println!("{:?} image and GI textures", textures.size());
//! }
//! let frame = renderer.render(&FrameRequest::at(4.0 / 60.0))?;
//! println!("{} ms, {} bytes", frame.ms_total(), renderer.memory_bytes());
//! # Ok(()) }
//! ```
//!
//! `Auto` without a budget picks by adapter class: `pc` on a discrete GPU, `mobile` on an
//! integrated one, the CPU `reference` on a software adapter or none. Tiers an adapter cannot
//! run (a limit it misses) are left out with the reason, and a tier that fails to create falls
//! back to the next candidate, down to the CPU reference. [`select`] documents the policy and
//! its figures.

mod cpu;
pub mod mobile;
pub mod output;
pub mod path;
pub mod pc;
mod realtime;
mod renderer;
pub mod requirements;
mod scene_state;
pub mod select;
mod tier;
pub mod tracer;

pub use cpu::{CancelCheck, CpuTier};
pub use gi_gpu::TextureOptions;
pub use mobile::{MobileConfig, MobileTier};
pub use output::{GpuOutput, OUTPUT_FORMAT, OutputTextures};
pub use path::{GpuPathTier, GpuReferenceEngine, Moments, reference_cache, reference_engine};
pub use pc::{PcConfig, PcTier};
pub use realtime::GiMemory;
pub use renderer::{CameraMode, FrameRequest, Renderer, RendererBuilder, Selection};
pub use tier::{
    FrameBudget, FrameInput, FrameOutput, FrameTimings, Tier, TierChoice, TierError, TierKind,
    TierSettings,
};
pub use tracer::PathUniforms;

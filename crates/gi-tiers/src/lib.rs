//! The tiered crate: the interface every GI tier implements, the tiers, the [`Renderer`]
//! facade that renders the frames of a scene, and [`select`], the policy by which
//! [`TierChoice::Auto`] picks a tier for the adapter.
//!
//! ```no_run
//! # fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use gi_tiers::{CameraMode, FrameBudget, Renderer, TierChoice, TierSettings};
//!
//! let scene = gi_scene::load("cornell-box")?;
//! let settings = TierSettings {
//!     width: 320,
//!     height: 240,
//!     spp: 16,
//!     seed: 1,
//!     textures: gi_tiers::TextureOptions::DEFAULT,
//! };
//! // The best real-time GI tier whose estimated frame fits 16 ms on this adapter.
//! let choice = TierChoice::AutoWithin(FrameBudget::from_ms(16.0));
//! let mut renderer = Renderer::new(scene, choice, settings, CameraMode::Default)?;
//! if let Some(selection) = renderer.selection() {
//!     println!("{}: {}", selection.chosen, selection.reason);
//! }
//! let frame = renderer.render_frames(4, None)?; // three warm-up frames, then the measured one
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
mod renderer;
pub mod requirements;
mod scene_state;
pub mod select;
mod tier;
pub mod tracer;

pub use cpu::CpuTier;
pub use gi_gpu::TextureOptions;
pub use mobile::{MobileConfig, MobileTier};
pub use output::{GpuOutput, OUTPUT_FORMAT, OutputTextures};
pub use path::{GpuPathTier, GpuReferenceEngine, Moments, reference_cache, reference_engine};
pub use pc::{PcConfig, PcTier};
pub use renderer::{CameraMode, FrameRequest, Renderer, RendererBuilder, Selection};
pub use tier::{
    FrameBudget, FrameInput, FrameOutput, FrameTimings, Tier, TierChoice, TierError, TierKind,
    TierSettings,
};
pub use tracer::PathUniforms;

//! The tiered crate: the interface every GI tier implements, the tiers, and the [`Renderer`]
//! facade that picks a tier and renders the frames of a scene.
//!
//! ```no_run
//! # fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use gi_tiers::{CameraMode, Renderer, TierChoice, TierSettings};
//!
//! let scene = gi_scene::load("cornell-box")?;
//! let settings = TierSettings { width: 320, height: 240, spp: 16, seed: 1 };
//! let mut renderer = Renderer::new(scene, TierChoice::Auto, settings, CameraMode::Default)?;
//! let frame = renderer.render_frames(4, None)?; // three warm-up frames, then the measured one
//! println!("{} ms, {} bytes", frame.ms_total(), renderer.memory_bytes());
//! # Ok(()) }
//! ```

mod cpu;
pub mod mobile;
mod path;
pub mod pc;
mod renderer;
mod scene_state;
mod tier;

pub use cpu::CpuTier;
pub use mobile::{MobileConfig, MobileTier};
pub use path::{GpuPathTier, Moments, PathUniforms};
pub use pc::{PcConfig, PcTier};
pub use renderer::{CameraMode, Renderer};
pub use tier::{FrameInput, FrameOutput, Tier, TierChoice, TierError, TierKind, TierSettings};

//! Which path tracer renders a reference: the [`ReferenceEngine`] a [`ReferenceCache`] is given
//! ([`CpuEngine`] here; the GPU one lives in gi-tiers, which this crate must not depend on) and
//! the user's [`EngineChoice`] between them.
//!
//! Both engines compute the same estimator from the same random numbers (the GPU path tier
//! draws the reference's), so their images agree up to f32 rounding and the few paths that
//! rounding sends another way: a cached reference made by either serves [`EngineChoice::Auto`].
//!
//! [`ReferenceCache`]: crate::cache::ReferenceCache

use std::{fmt, str::FromStr};

use gi_image::Image;
use serde::{Deserialize, Serialize};

use crate::RenderStats;
use crate::cache::{CacheError, ReferenceRequest};

/// Which kind of processor an engine renders on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EngineKind {
    /// The CPU path tracer of this crate.
    Cpu,
    /// The GPU path tier (gi-tiers).
    Gpu,
}

impl EngineKind {
    /// `"cpu"` or `"gpu"`: the start of every description of an engine of this kind.
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Cpu => "cpu",
            EngineKind::Gpu => "gpu",
        }
    }

    /// The kind an engine description (`"cpu"`, `"gpu: <adapter>"`) names, `None` for any
    /// other text.
    pub fn of_description(description: &str) -> Option<Self> {
        let name = description.split(':').next().unwrap_or_default().trim();
        [EngineKind::Cpu, EngineKind::Gpu]
            .into_iter()
            .find(|kind| kind.name() == name)
    }
}

/// What the user asked to render references with (`--reference-engine`); in JSON its name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EngineChoice {
    /// The GPU path tier when a hardware adapter exists (not a software one such as
    /// lavapipe, which is slower than the CPU path tracer), else the CPU. Accepts a cached
    /// reference made by either engine.
    #[default]
    Auto,
    /// The GPU path tier on the best Vulkan adapter, a software one included; an error when
    /// there is none. Accepts only cached references made on a GPU.
    Gpu,
    /// The CPU path tracer. Accepts only cached references made on the CPU.
    Cpu,
}

impl EngineChoice {
    /// Every choice, in the order help texts list them.
    pub const ALL: [EngineChoice; 3] = [EngineChoice::Auto, EngineChoice::Gpu, EngineChoice::Cpu];

    /// The name on the command line and in configuration: `auto`, `gpu` or `cpu`.
    pub fn name(self) -> &'static str {
        match self {
            EngineChoice::Auto => "auto",
            EngineChoice::Gpu => "gpu",
            EngineChoice::Cpu => "cpu",
        }
    }

    /// Whether a cached reference made by an engine of `kind` serves this choice: any under
    /// `Auto`, only its own kind under an explicit choice.
    pub fn accepts(self, kind: EngineKind) -> bool {
        match self {
            EngineChoice::Auto => true,
            EngineChoice::Gpu => kind == EngineKind::Gpu,
            EngineChoice::Cpu => kind == EngineKind::Cpu,
        }
    }
}

impl fmt::Display for EngineChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An engine name that is not `auto`, `gpu` or `cpu`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown reference engine '{0}' (expected auto, gpu or cpu)")]
pub struct UnknownEngine(pub String);

impl FromStr for EngineChoice {
    type Err = UnknownEngine;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        EngineChoice::ALL
            .into_iter()
            .find(|choice| choice.name() == s)
            .ok_or_else(|| UnknownEngine(s.to_string()))
    }
}

/// A path tracer that renders [`ReferenceRequest`]s: full transport with MIS
/// ([`ReferenceRequest::settings`]), the request's seed and sample count.
pub trait ReferenceEngine: Send + Sync {
    /// Which kind of processor it renders on.
    fn kind(&self) -> EngineKind;

    /// What the cache stores of it beside each entry it made: `"cpu"`, or `"gpu: <adapter
    /// name>"`. Starts with [`EngineKind::name`].
    fn description(&self) -> String;

    /// Renders `request`, calling `progress` with the samples per pixel done now and then and
    /// stopping once `cancelled` answers true (then `None`). The stats' `seconds` plus
    /// `bvh_build_seconds` is the time the cache records.
    fn render(
        &self,
        request: &ReferenceRequest,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<(Image, RenderStats)>, CacheError>;
}

/// The CPU path tracer ([`ReferenceRequest::render`]), the engine of every cache that is not
/// given another.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuEngine;

impl ReferenceEngine for CpuEngine {
    fn kind(&self) -> EngineKind {
        EngineKind::Cpu
    }

    fn description(&self) -> String {
        EngineKind::Cpu.name().to_string()
    }

    fn render(
        &self,
        request: &ReferenceRequest,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<(Image, RenderStats)>, CacheError> {
        Ok(request.render(progress, cancelled)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_parse_their_names_only() {
        for choice in EngineChoice::ALL {
            assert_eq!(choice.name().parse::<EngineChoice>(), Ok(choice));
        }
        assert_eq!(EngineChoice::default(), EngineChoice::Auto);
        for bad in ["", "GPU", "vulkan", "gpu "] {
            assert_eq!(
                bad.parse::<EngineChoice>(),
                Err(UnknownEngine(bad.to_string()))
            );
        }
    }

    #[test]
    fn descriptions_name_their_kind() {
        assert_eq!(EngineKind::of_description("cpu"), Some(EngineKind::Cpu));
        assert_eq!(
            EngineKind::of_description("gpu: NVIDIA H100 80GB HBM3"),
            Some(EngineKind::Gpu)
        );
        assert_eq!(EngineKind::of_description("gpus"), None);
        assert_eq!(CpuEngine.description(), "cpu");
        assert!(EngineChoice::Auto.accepts(EngineKind::Gpu));
        assert!(!EngineChoice::Cpu.accepts(EngineKind::Gpu));
        assert!(!EngineChoice::Gpu.accepts(EngineKind::Cpu));
    }
}

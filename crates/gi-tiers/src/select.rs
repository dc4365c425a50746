//! Tier selection: which tier [`TierChoice::Auto`](crate::TierChoice::Auto) renders with on an
//! adapter, and why. Pure: [`plan`] reads an [`AdapterDescription`] (made from the opened GPU
//! context, or by hand) and never touches a GPU, so the policy is tested with synthetic
//! adapters.
//!
//! # The policy
//!
//! `Auto` means "the best real-time GI tier that fits the frame budget on this adapter".
//!
//! 1. **Quality order** of the real-time tiers: `pc` > `mobile` > `direct` (no GI). The offline
//!    tiers (`path`, `reference`) are picked only when asked for by name, or as the fallback
//!    when there is no GPU or only a software one.
//! 2. **Requirements.** Each GPU tier needs some adapter limits ([`requirements`]: storage
//!    buffers per shader stage, bind groups, compute workgroup size and invocations, and the
//!    storage binding size of its largest per-pixel buffer at the requested resolution). A tier
//!    whose requirement the adapter misses is rejected with the limit and both values named.
//! 3. **Cost.** A tier's frame time is estimated by [`estimate_ms`]: measured H100 frame costs
//!    ([`H100_FRAME_COSTS`]) at the requested resolution, times the adapter's slowdown
//!    ([`slowdown`]): measured for the H100 itself and for software adapters, an assumption
//!    per class for other GPUs.
//! 4. **With a budget** ([`TierChoice::AutoWithin`](crate::TierChoice::AutoWithin)): the first
//!    tier in quality order whose estimate fits. When none fits, `mobile`, the cheapest tier
//!    with GI, with a reason that says it exceeds the budget (a frame over budget with GI is
//!    more use than none; pick `direct` by name for the cheapest frame).
//! 5. **Without a budget**, by adapter class: a discrete, virtual or unknown hardware GPU gets
//!    `pc`, an integrated GPU `mobile`. A software adapter (`DeviceType::Cpu`, e.g. Mesa's
//!    lavapipe) gets the CPU `reference`: its "GPU" runs on the same CPU cores, so no GPU tier
//!    is real-time there (measured: [`SOFTWARE_SLOWDOWN`]), and the reference at least gives
//!    the exact image for that time. No adapter: the CPU `reference`.
//! 6. **Fallback.** After the chosen tier come the cheaper real-time tiers that pass their
//!    requirements, in quality order, and last always the CPU `reference`, which needs no GPU:
//!    [`crate::Renderer::new`] tries them in order when one cannot be created.
//!
//! The estimates are coarse (a model of two or three figures per tier, and assumed factors for
//! GPUs nobody measured here); they rank tiers and catch budgets that are far off, they do not
//! predict a frame to the millisecond.

use gi_gpu::{GpuContext, wgpu};

pub use crate::requirements::{FrameCost, Requirements, check_requirements};
pub use crate::tier::FrameBudget;
use crate::{
    mobile, path, pc,
    tier::{TierKind, TierSettings},
};

/// What [`plan`] knows of an adapter: what `wgpu` reports of it. Built from an opened context
/// ([`AdapterDescription::from_context`]) or by hand, for tests and for planning another
/// machine's renders.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterDescription {
    pub name: String,
    pub device_type: wgpu::DeviceType,
    /// The driver and its version, as the adapter reports them (informational).
    pub driver: String,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
}

impl AdapterDescription {
    /// The adapter of `info` with the device's `limits` and `features`.
    pub fn from_info(
        info: &wgpu::AdapterInfo,
        limits: wgpu::Limits,
        features: wgpu::Features,
    ) -> Self {
        let driver = match (info.driver.is_empty(), info.driver_info.is_empty()) {
            (false, false) => format!("{} {}", info.driver, info.driver_info),
            (false, true) => info.driver.clone(),
            _ => info.driver_info.clone(),
        };
        Self {
            name: info.name.clone(),
            device_type: info.device_type,
            driver,
            limits,
            features,
        }
    }

    /// The adapter `ctx` runs on.
    pub fn from_context(ctx: &GpuContext) -> Self {
        Self::from_info(&ctx.adapter_info, ctx.limits.clone(), ctx.features)
    }

    /// True for a software rasterizer (`DeviceType::Cpu`), which runs "GPU" work on the CPU.
    pub fn is_software(&self) -> bool {
        self.device_type == wgpu::DeviceType::Cpu
    }

    /// The name and type, for messages: `"llvmpipe (LLVM 19.1.7, 256 bits) (Cpu)"`.
    pub fn label(&self) -> String {
        format!("{} ({:?})", self.name, self.device_type)
    }
}

/// Where a planned tier runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RunsOn {
    Gpu,
    Cpu,
}

/// One tier [`plan`] proposes, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub kind: TierKind,
    pub runs_on: RunsOn,
    pub reason: String,
}

/// The tiers to try, best first, and the tiers left out with the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Best first; never empty: the last is always the CPU `reference`.
    pub candidates: Vec<Candidate>,
    /// Tiers the adapter cannot run or that the policy left out, with the reason.
    pub rejected: Vec<(TierKind, String)>,
}

impl Plan {
    /// The first candidate: what a renderer uses when it can be created.
    pub fn chosen(&self) -> &Candidate {
        &self.candidates[0]
    }
}

/// Requirements of the GPU version of `kind` at `settings`' resolution, as the tier declares
/// them at its default configuration; `None` for a tier that has no GPU version
/// (`reference`).
pub fn requirements(kind: TierKind, settings: &TierSettings) -> Option<Requirements> {
    match kind {
        TierKind::Reference => None,
        TierKind::Direct | TierKind::Path => Some(path::requirements(settings)),
        TierKind::Mobile => Some(mobile::requirements(settings)),
        TierKind::Pc => Some(pc::requirements(settings, &pc::PcConfig::default())),
    }
}

/// Measured frame costs on an NVIDIA H100 (Vulkan): whole frames (G-buffer, direct light and
/// GI) at the default settings, scaled in proportion to the pixel count. The PC and mobile
/// figures are medians over 64 frames of `dynamic`, whose moving objects make every frame
/// re-voxelize them and re-trace the direct light, as a moving view does (a still view
/// accumulates its direct light and stops tracing it, so still frames cost less).
pub const H100_FRAME_COSTS: [FrameCost; 3] =
    [pc::H100_COST, mobile::H100_COST, path::DIRECT_H100_COST];

/// Adapters whose speed was measured against [`H100_FRAME_COSTS`], by a case-insensitive
/// substring of their name: `(name, slowdown, source)`. They take this factor instead of their
/// class's assumption ([`slowdown`]).
pub const MEASURED_ADAPTERS: [(&str, f64, &str); 1] = [(
    "H100",
    1.0,
    "the GPU the cost table was measured on (benchmarks/RESULTS-history.md, benchmark suite)",
)];

/// How much slower a software adapter runs the GPU tiers than the H100 figures of
/// [`H100_FRAME_COSTS`] say, measured on Mesa's lavapipe on a 2-core x86-64 CPU (2026-11-22):
/// `gi compare cornell-box --tiers mobile,pc --width 320 --height 240 --spp 1
/// --reference-spp 16 --warmup 8 --frames 4` gave 441.7 ms per `mobile` frame and 972.0 ms
/// per `pc` frame, 4,600 and 5,500 times the H100 estimates at that size (0.097 and 0.175
/// ms). At 160 x 120 the same command gave 304.0 and 434.0 ms, 12,600 and 9,900 times the
/// estimates: fixed per-frame costs (the brick cache's passes) dominate a tiny frame, which
/// the proportional model leaves out. So software frames are estimated too cheap at the
/// smallest sizes, never real-time either way.
pub const SOFTWARE_SLOWDOWN: f64 = 5000.0;

/// How much slower than the H100 `adapter` runs a frame: the measured factor of a
/// [`MEASURED_ADAPTERS`] entry its name matches, else its class's:
///
/// | class | factor | source |
/// |---|---:|---|
/// | discrete | 4 | assumption: a mid-range discrete GPU has a quarter of an H100's throughput |
/// | virtual | 4 | assumption: a virtual GPU is a share of a datacenter or discrete GPU |
/// | integrated | 16 | assumption: a quarter of the mid-range discrete GPU |
/// | other (unknown) | 16 | assumption: unknown hardware is planned as the slow class |
/// | software (`Cpu`) | 5000 ([`SOFTWARE_SLOWDOWN`]) | measured, lavapipe on 2 cores |
pub fn slowdown(adapter: &AdapterDescription) -> f64 {
    let name = adapter.name.to_lowercase();
    if let Some((_, factor, _)) = MEASURED_ADAPTERS
        .iter()
        .find(|(known, _, _)| name.contains(&known.to_lowercase()))
    {
        return *factor;
    }
    match adapter.device_type {
        wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::VirtualGpu => 4.0,
        wgpu::DeviceType::IntegratedGpu | wgpu::DeviceType::Other => 16.0,
        wgpu::DeviceType::Cpu => SOFTWARE_SLOWDOWN,
    }
}

/// Estimated ms per frame of the GPU version of `kind` on `adapter` at `settings`; `None` for
/// tiers without a real-time estimate (`path`, `reference`). The direct tier scales with its
/// samples per pixel; the temporal tiers add one direct sample per frame whatever `spp` is.
pub fn estimate_ms(
    kind: TierKind,
    adapter: &AdapterDescription,
    settings: &TierSettings,
) -> Option<f64> {
    let cost = H100_FRAME_COSTS.iter().find(|c| c.kind == kind)?;
    let megapixels = f64::from(settings.width) * f64::from(settings.height) / 1e6;
    let h100_ms = match cost.points {
        [(mp, ms)] => ms * megapixels / mp,
        [(mp0, ms0), (mp1, ms1), ..] => {
            let per_megapixel = (ms1 - ms0) / (mp1 - mp0);
            (ms0 - per_megapixel * mp0) + per_megapixel * megapixels
        }
        [] => return None,
    };
    let samples = if kind == TierKind::Direct {
        f64::from(settings.spp.max(1))
    } else {
        1.0
    };
    Some(h100_ms * samples * slowdown(adapter))
}

/// The real-time tiers, best first.
const QUALITY_ORDER: [TierKind; 3] = [TierKind::Pc, TierKind::Mobile, TierKind::Direct];

/// The tiers to try for `Auto` on `adapter` (`None`: no GPU) at `settings`, within `budget`
/// if one is given. See the module docs for the policy.
pub fn plan(
    adapter: Option<&AdapterDescription>,
    settings: &TierSettings,
    budget: Option<FrameBudget>,
) -> Plan {
    let reference = |reason: String| Candidate {
        kind: TierKind::Reference,
        runs_on: RunsOn::Cpu,
        reason,
    };
    let Some(adapter) = adapter else {
        return Plan {
            candidates: vec![reference(
                "no GPU adapter: the CPU reference needs none".to_string(),
            )],
            rejected: QUALITY_ORDER
                .iter()
                .map(|&kind| (kind, "no GPU adapter".to_string()))
                .collect(),
        };
    };
    let mut rejected = Vec::new();
    // The real-time tiers this adapter can run, with their estimates, best first.
    let mut runnable: Vec<(TierKind, f64)> = Vec::new();
    for kind in QUALITY_ORDER {
        let req = requirements(kind, settings).expect("real-time tiers have a GPU version");
        match check_requirements(&req, &adapter.limits) {
            Ok(()) => runnable.push((
                kind,
                estimate_ms(kind, adapter, settings).expect("real-time tiers have an estimate"),
            )),
            Err(missing) => rejected.push((kind, missing)),
        }
    }
    let label = adapter.label();
    let size = format!("{}x{}", settings.width, settings.height);
    let mut candidates = Vec::new();
    let fallbacks_from = |chosen: usize, candidates: &mut Vec<Candidate>| {
        for &(kind, ms) in &runnable[chosen + 1..] {
            candidates.push(Candidate {
                kind,
                runs_on: RunsOn::Gpu,
                reason: format!("fallback: a cheaper real-time tier (about {ms:.1} ms at {size})"),
            });
        }
    };
    match budget {
        Some(budget) => {
            let fits = runnable.iter().position(|&(_, ms)| ms <= budget.ms());
            // When nothing fits: mobile, the cheapest tier with GI, else the best that runs.
            let over = runnable
                .iter()
                .position(|&(kind, _)| kind == TierKind::Mobile)
                .or((!runnable.is_empty()).then_some(0));
            if let Some(index) = fits.or(over) {
                let (kind, ms) = runnable[index];
                for &(better, better_ms) in &runnable[..index] {
                    rejected.push((
                        better,
                        format!(
                            "about {better_ms:.1} ms at {size} on {label}, over the {budget} budget"
                        ),
                    ));
                }
                let reason = if fits.is_some() {
                    format!(
                        "the best real-time tier within the {budget} budget on {label}: about \
                         {ms:.1} ms at {size}"
                    )
                } else {
                    format!(
                        "no real-time tier fits the {budget} budget on {label} at {size}; the \
                         cheapest with GI exceeds it at about {ms:.1} ms"
                    )
                };
                candidates.push(Candidate {
                    kind,
                    runs_on: RunsOn::Gpu,
                    reason,
                });
                fallbacks_from(index, &mut candidates);
            }
        }
        None if adapter.is_software() => {
            for &(kind, ms) in &runnable {
                rejected.push((
                    kind,
                    format!(
                        "{label} is a software adapter: about {ms:.0} ms per frame at {size} on \
                         the CPU cores the reference uses too"
                    ),
                ));
            }
        }
        None => {
            let class_best = match adapter.device_type {
                wgpu::DeviceType::IntegratedGpu => TierKind::Mobile,
                _ => TierKind::Pc,
            };
            let start = runnable.iter().position(|&(kind, _)| {
                QUALITY_ORDER.iter().position(|&k| k == kind)
                    >= QUALITY_ORDER.iter().position(|&k| k == class_best)
            });
            if let Some(index) = start {
                let (kind, ms) = runnable[index];
                for &(better, _) in &runnable[..index] {
                    rejected.push((
                        better,
                        format!(
                            "{label} is a {:?} adapter: {class_best} is its best tier without a budget",
                            adapter.device_type
                        ),
                    ));
                }
                let why = if kind == class_best {
                    format!("the best tier for a {:?} adapter", adapter.device_type)
                } else {
                    format!("the best tier {label} meets the requirements of")
                };
                candidates.push(Candidate {
                    kind,
                    runs_on: RunsOn::Gpu,
                    reason: format!("{why} ({label}, about {ms:.1} ms at {size}, no budget given)"),
                });
                fallbacks_from(index, &mut candidates);
            }
        }
    }
    let last = if candidates.is_empty() {
        if adapter.is_software() && budget.is_none() {
            format!(
                "{label} is a software adapter, on which no GPU tier is real-time: the CPU \
                 reference renders the exact image instead"
            )
        } else {
            format!("no real-time tier can run on {label}: the CPU reference needs no GPU")
        }
    } else {
        "last fallback: the CPU reference needs no GPU".to_string()
    };
    candidates.push(reference(last));
    Plan {
        candidates,
        rejected,
    }
}

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

use std::fmt;

use gi_gpu::{GpuContext, wgpu};

use crate::{
    pc::{GpuReservoir, GpuSpecularSample, GpuSurface, PcConfig},
    tier::{TierKind, TierSettings},
};

/// A frame-time budget, kept in whole microseconds so it stays `Copy + Eq` inside
/// [`TierChoice`](crate::TierChoice).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameBudget {
    micros: u64,
}

impl FrameBudget {
    /// A budget of `ms` milliseconds, rounded to the microsecond; negative or non-finite values
    /// give a zero budget, which nothing fits.
    pub fn from_ms(ms: f64) -> Self {
        let micros = if ms.is_finite() && ms > 0.0 {
            (ms * 1000.0).round() as u64
        } else {
            0
        };
        Self { micros }
    }

    /// The budget in milliseconds.
    pub fn ms(self) -> f64 {
        self.micros as f64 / 1000.0
    }
}

impl fmt::Display for FrameBudget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ms", self.ms())
    }
}

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

/// What a GPU tier needs of the adapter, from the tier's pipeline layouts and shaders. The
/// test `tier_requirements_match_the_shaders` (tests/select.rs) checks them against the WGSL:
/// each storage-buffer count lies between what one entry point uses and what its file
/// declares, and the other figures are the shaders' own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Requirements {
    /// Storage buffers the tier's largest compute pipeline layout binds, summed over its bind
    /// groups (a layout counts every buffer it binds, used by the entry point or not).
    pub storage_buffers_per_stage: u32,
    /// Bind groups of the pipeline with the most (`@group(0..n)`).
    pub bind_groups: u32,
    /// Sampled textures of one stage: the scene's texture arrays (`gi_gpu::SceneTextures`).
    pub sampled_textures_per_stage: u32,
    /// The largest `@workgroup_size` product.
    pub invocations_per_workgroup: u32,
    /// The largest `@workgroup_size` along x.
    pub workgroup_size_x: u32,
    /// Bytes of the largest buffer bound whole at the requested resolution: one `vec4<f32>` per
    /// pixel for every tier, and the PC tier's reservoirs and surfaces per trace pixel.
    pub largest_binding_bytes: u64,
}

/// Requirements of the GPU version of `kind` at `settings`' resolution; `None` for a tier
/// that has no GPU version (`reference`).
pub fn requirements(kind: TierKind, settings: &TierSettings) -> Option<Requirements> {
    let pixels = u64::from(settings.width) * u64::from(settings.height);
    let image = pixels * 16;
    // direct and path: `path/trace` binds the scene (7 storage buffers), its accumulation
    // buffers (3) and the BVH (4), and the scene's texture arrays in group 3, 8 x 8
    // invocations; `path/resolve` 64 x 1.
    let path = Requirements {
        storage_buffers_per_stage: 14,
        bind_groups: 4,
        sampled_textures_per_stage: gi_gpu::textures::TEXTURE_ARRAYS,
        invocations_per_workgroup: 64,
        workgroup_size_x: 64,
        largest_binding_bytes: image,
    };
    match kind {
        TierKind::Reference => None,
        TierKind::Direct | TierKind::Path => Some(path),
        // The screen-probe passes' layouts (mobile/screen.rs): 20 storage buffers of their own,
        // the probe volume's 3 and the brick cache's 7; four groups (the cache's is group 2,
        // the textures group 3); the largest workgroups (the cache's passes, the probe
        // volume's, the 1D screen passes) run 64 invocations in x.
        TierKind::Mobile => Some(Requirements {
            storage_buffers_per_stage: 30,
            bind_groups: 4,
            sampled_textures_per_stage: gi_gpu::textures::TEXTURE_ARRAYS,
            invocations_per_workgroup: 64,
            workgroup_size_x: 64,
            largest_binding_bytes: image,
        }),
        TierKind::Pc => {
            let scale = PcConfig::default().trace_scale;
            let traced = u64::from(settings.width.div_ceil(scale))
                * u64::from(settings.height.div_ceil(scale));
            let per_trace_pixel = [
                size_of::<GpuReservoir>(),
                size_of::<GpuSurface>(),
                size_of::<GpuSpecularSample>(),
            ]
            .into_iter()
            .max()
            .unwrap_or(0) as u64;
            // The trace passes' layouts (pc/mod.rs): the scene's 7 storage buffers and 10 of
            // their own, the BVH's 4 and the brick cache's 7; the cache passes as for mobile.
            Some(Requirements {
                storage_buffers_per_stage: 28,
                bind_groups: 4,
                sampled_textures_per_stage: gi_gpu::textures::TEXTURE_ARRAYS,
                invocations_per_workgroup: 64,
                workgroup_size_x: 64,
                largest_binding_bytes: image.max(traced * per_trace_pixel),
            })
        }
    }
}

/// The first requirement `limits` misses, as a sentence naming the limit and both values.
pub fn check_requirements(req: &Requirements, limits: &wgpu::Limits) -> Result<(), String> {
    let checks: [(&str, u64, u64); 6] = [
        (
            "max_storage_buffers_per_shader_stage",
            req.storage_buffers_per_stage.into(),
            limits.max_storage_buffers_per_shader_stage.into(),
        ),
        (
            "max_bind_groups",
            req.bind_groups.into(),
            limits.max_bind_groups.into(),
        ),
        (
            "max_sampled_textures_per_shader_stage",
            req.sampled_textures_per_stage.into(),
            limits.max_sampled_textures_per_shader_stage.into(),
        ),
        (
            "max_compute_invocations_per_workgroup",
            req.invocations_per_workgroup.into(),
            limits.max_compute_invocations_per_workgroup.into(),
        ),
        (
            "max_compute_workgroup_size_x",
            req.workgroup_size_x.into(),
            limits.max_compute_workgroup_size_x.into(),
        ),
        (
            "max_storage_buffer_binding_size",
            req.largest_binding_bytes,
            limits.max_storage_buffer_binding_size,
        ),
    ];
    match checks
        .iter()
        .find(|(_, needed, available)| needed > available)
    {
        Some((limit, needed, available)) => Err(format!(
            "needs {limit} >= {needed}, the adapter has {available}"
        )),
        None => Ok(()),
    }
}

/// A tier's measured whole-frame cost on the H100 at one or two sizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCost {
    pub kind: TierKind,
    /// `(megapixels, ms per frame)`, smallest first. With two points the model is
    /// `fixed + per-megapixel x megapixels` through both; with one it is proportional.
    pub points: &'static [(f64, f64)],
    /// Where the figures were measured.
    pub source: &'static str,
}

/// Measured frame costs on an NVIDIA H100 (Vulkan): whole frames (G-buffer, direct light and
/// GI) at the default settings, scaled in proportion to the pixel count. The PC and mobile
/// figures are medians over 64 frames of `dynamic`, whose moving objects make every frame
/// re-voxelize them and re-trace the direct light, as a moving view does (a still view
/// accumulates its direct light and stops tracing it, so still frames cost less).
pub const H100_FRAME_COSTS: [FrameCost; 3] = [
    FrameCost {
        kind: TierKind::Pc,
        points: &[(2.0736, 4.73)],
        source: "benchmarks/RESULTS.md, benchmark suite, `gi-bench pc --scenes dynamic --size \
                 1920x1080 --frames 64`: GI 3.709 + gbuffer/primary 0.334 + direct 0.688 ms",
    },
    FrameCost {
        kind: TierKind::Mobile,
        points: &[(2.0736, 2.61)],
        source: "benchmarks/RESULTS.md, benchmark suite, `gi-bench mobile --scenes dynamic --size \
                 1920x1080 --frames 64`: GI 1.589 + gbuffer/primary 0.334 + direct 0.688 ms",
    },
    FrameCost {
        kind: TierKind::Direct,
        points: &[(0.9216, 0.446)],
        source: "benchmarks/RESULTS.md, benchmark suite at 1280x720: the direct tier's dearest \
                 scene (open-world) 7.129 ms at 16 samples per pixel, 0.446 ms per sample",
    },
];

/// Adapters whose speed was measured against [`H100_FRAME_COSTS`], by a case-insensitive
/// substring of their name: `(name, slowdown, source)`. They take this factor instead of their
/// class's assumption ([`slowdown`]).
pub const MEASURED_ADAPTERS: [(&str, f64, &str); 1] = [(
    "H100",
    1.0,
    "the GPU the cost table was measured on (benchmarks/RESULTS.md, benchmark suite)",
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

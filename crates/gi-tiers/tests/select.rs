//! The `Auto` policy (`gi_tiers::select`) on synthetic adapters, without a GPU, and through
//! `Renderer::new` on the adapter present.

use gi_gpu::{GpuContext, ShaderLibrary, wgpu};
use gi_tiers::{
    CameraMode, FrameBudget, Renderer, TierChoice, TierKind, TierSettings,
    select::{self, AdapterDescription, Candidate, Plan, RunsOn, estimate_ms, plan, requirements},
};

const SIZE_640: TierSettings = TierSettings {
    width: 640,
    height: 360,
    spp: 1,
    seed: 1,
    textures: gi_tiers::TextureOptions::DEFAULT,
};

const SIZE_4K: TierSettings = TierSettings {
    width: 3840,
    height: 2160,
    spp: 1,
    seed: 1,
    textures: gi_tiers::TextureOptions::DEFAULT,
};

/// An adapter of `device_type` with limits like an H100's under Vulkan (large everywhere).
fn adapter(device_type: wgpu::DeviceType) -> AdapterDescription {
    let limits = wgpu::Limits {
        max_storage_buffers_per_shader_stage: 1 << 20,
        max_bind_groups: 8,
        max_compute_invocations_per_workgroup: 1024,
        max_compute_workgroup_size_x: 1024,
        max_storage_buffer_binding_size: 1 << 32,
        ..wgpu::Limits::default()
    };
    AdapterDescription {
        name: format!("synthetic {device_type:?}"),
        device_type,
        driver: "test".to_string(),
        limits,
        features: wgpu::Features::empty(),
    }
}

fn kinds(plan: &Plan) -> Vec<(TierKind, RunsOn)> {
    plan.candidates
        .iter()
        .map(|c| (c.kind, c.runs_on))
        .collect()
}

fn rejection(plan: &Plan, kind: TierKind) -> &str {
    plan.rejected
        .iter()
        .find(|(k, _)| *k == kind)
        .map(|(_, why)| why.as_str())
        .unwrap_or_else(|| panic!("{kind} not rejected: {plan:?}"))
}

fn ends_with_the_cpu_reference(plan: &Plan) {
    let last = plan.candidates.last().expect("a plan is never empty");
    assert_eq!(
        (last.kind, last.runs_on),
        (TierKind::Reference, RunsOn::Cpu)
    );
}

#[test]
fn without_a_budget_the_adapter_class_decides() {
    use wgpu::DeviceType::*;
    let gpu = RunsOn::Gpu;
    let cpu = RunsOn::Cpu;
    let reference = (TierKind::Reference, cpu);
    for (device_type, expected) in [
        (
            DiscreteGpu,
            vec![
                (TierKind::Pc, gpu),
                (TierKind::Mobile, gpu),
                (TierKind::Direct, gpu),
                reference,
            ],
        ),
        (
            VirtualGpu,
            vec![
                (TierKind::Pc, gpu),
                (TierKind::Mobile, gpu),
                (TierKind::Direct, gpu),
                reference,
            ],
        ),
        (
            IntegratedGpu,
            vec![(TierKind::Mobile, gpu), (TierKind::Direct, gpu), reference],
        ),
        (Cpu, vec![reference]),
    ] {
        let plan = plan(Some(&adapter(device_type)), &SIZE_640, None);
        assert_eq!(kinds(&plan), expected, "{device_type:?}: {plan:?}");
        ends_with_the_cpu_reference(&plan);
    }
    let integrated = plan(Some(&adapter(IntegratedGpu)), &SIZE_640, None);
    assert!(rejection(&integrated, TierKind::Pc).contains("IntegratedGpu"));
    let software = plan(Some(&adapter(Cpu)), &SIZE_640, None);
    assert!(
        software.chosen().reason.contains("software adapter"),
        "{software:?}"
    );
    for kind in [TierKind::Pc, TierKind::Mobile, TierKind::Direct] {
        assert!(rejection(&software, kind).contains("software adapter"));
    }
}

#[test]
fn without_an_adapter_only_the_cpu_reference_is_planned() {
    for budget in [None, Some(FrameBudget::from_ms(16.0))] {
        let plan = plan(None, &SIZE_640, budget);
        assert_eq!(kinds(&plan), [(TierKind::Reference, RunsOn::Cpu)]);
        assert!(plan.chosen().reason.contains("no GPU adapter"));
        assert_eq!(plan.rejected.len(), 3, "{plan:?}");
    }
}

#[test]
fn a_tier_whose_limit_the_adapter_misses_is_rejected_with_the_limit_named() {
    let pc = requirements(TierKind::Pc, &SIZE_640).unwrap();
    let direct = requirements(TierKind::Direct, &SIZE_640).unwrap();
    // One storage buffer per stage short of pc (and mobile, whose layouts bind as many):
    // the direct tier, which needs fewer, is chosen.
    let mut small = adapter(wgpu::DeviceType::DiscreteGpu);
    small.limits.max_storage_buffers_per_shader_stage = pc.storage_buffers_per_stage - 1;
    assert!(direct.storage_buffers_per_stage < pc.storage_buffers_per_stage);
    let plan = plan(Some(&small), &SIZE_640, None);
    assert_eq!(
        kinds(&plan),
        [
            (TierKind::Direct, RunsOn::Gpu),
            (TierKind::Reference, RunsOn::Cpu)
        ],
        "{plan:?}"
    );
    let why = rejection(&plan, TierKind::Pc);
    assert!(
        why.contains("max_storage_buffers_per_shader_stage"),
        "{why}"
    );
    let needed = pc.storage_buffers_per_stage;
    assert!(
        why.contains(&format!(">= {needed}")) && why.contains(&format!("has {}", needed - 1)),
        "{why}"
    );
    assert!(plan.chosen().reason.contains("requirements"), "{plan:?}");

    // A workgroup limit below the 64 invocations of every GPU tier's largest workgroups
    // leaves the CPU reference alone.
    let mut narrow = adapter(wgpu::DeviceType::IntegratedGpu);
    narrow.limits.max_compute_invocations_per_workgroup = 32;
    let plan = select::plan(Some(&narrow), &SIZE_640, None);
    assert_eq!(
        kinds(&plan),
        [(TierKind::Reference, RunsOn::Cpu)],
        "{plan:?}"
    );
    assert!(rejection(&plan, TierKind::Mobile).contains("max_compute_invocations_per_workgroup"));

    // WebGPU's baseline (8 storage buffers per stage) runs no GPU tier: only the reference.
    let mut baseline = adapter(wgpu::DeviceType::DiscreteGpu);
    baseline.limits = wgpu::Limits::default();
    let plan = select::plan(Some(&baseline), &SIZE_640, None);
    assert_eq!(kinds(&plan), [(TierKind::Reference, RunsOn::Cpu)]);
    assert_eq!(plan.rejected.len(), 3);
}

#[test]
fn the_storage_binding_limit_depends_on_the_resolution() {
    let mut small = adapter(wgpu::DeviceType::DiscreteGpu);
    small.limits.max_storage_buffer_binding_size = 100 << 20;
    assert_eq!(
        plan(Some(&small), &SIZE_640, None).chosen().kind,
        TierKind::Pc
    );
    // 3840 x 2160 x 16 bytes is 133 MB, over a 100 MiB binding for every GPU tier.
    let plan = plan(Some(&small), &SIZE_4K, None);
    assert_eq!(
        kinds(&plan),
        [(TierKind::Reference, RunsOn::Cpu)],
        "{plan:?}"
    );
    assert!(rejection(&plan, TierKind::Pc).contains("max_storage_buffer_binding_size"));
}

#[test]
fn a_budget_picks_the_best_tier_that_fits_and_says_so() {
    let discrete = adapter(wgpu::DeviceType::DiscreteGpu);
    let ms = |kind| estimate_ms(kind, &discrete, &SIZE_640).unwrap();
    let (pc, mobile, direct) = (ms(TierKind::Pc), ms(TierKind::Mobile), ms(TierKind::Direct));
    assert!(pc > mobile && mobile > direct, "{pc} {mobile} {direct}");

    let generous = plan(
        Some(&discrete),
        &SIZE_640,
        Some(FrameBudget::from_ms(pc * 1.01)),
    );
    assert_eq!(generous.chosen().kind, TierKind::Pc);

    let between = FrameBudget::from_ms((pc + mobile) / 2.0);
    let tight = plan(Some(&discrete), &SIZE_640, Some(between));
    assert_eq!(
        kinds(&tight),
        [
            (TierKind::Mobile, RunsOn::Gpu),
            (TierKind::Direct, RunsOn::Gpu),
            (TierKind::Reference, RunsOn::Cpu)
        ]
    );
    assert!(tight.chosen().reason.contains("budget"), "{tight:?}");
    assert!(rejection(&tight, TierKind::Pc).contains("over the"));

    let only_direct = plan(
        Some(&discrete),
        &SIZE_640,
        Some(FrameBudget::from_ms((mobile + direct) / 2.0)),
    );
    assert_eq!(only_direct.chosen().kind, TierKind::Direct);
}

#[test]
fn when_nothing_fits_the_budget_mobile_is_chosen_and_the_reason_says_it_exceeds() {
    for device_type in [wgpu::DeviceType::DiscreteGpu, wgpu::DeviceType::Cpu] {
        let plan = plan(
            Some(&adapter(device_type)),
            &SIZE_640,
            Some(FrameBudget::from_ms(0.001)),
        );
        assert_eq!(plan.chosen().kind, TierKind::Mobile, "{plan:?}");
        assert_eq!(plan.chosen().runs_on, RunsOn::Gpu);
        assert!(plan.chosen().reason.contains("exceeds"), "{plan:?}");
        ends_with_the_cpu_reference(&plan);
    }
}

#[test]
fn a_larger_resolution_raises_the_estimates() {
    let discrete = adapter(wgpu::DeviceType::DiscreteGpu);
    for kind in [TierKind::Pc, TierKind::Mobile, TierKind::Direct] {
        let small = estimate_ms(kind, &discrete, &SIZE_640).unwrap();
        let large = estimate_ms(kind, &discrete, &SIZE_4K).unwrap();
        assert!(large > small, "{kind}: {small} at 640x360, {large} at 4K");
    }
    // A budget that fits pc at 640x360 does not at 3840x2160.
    let pc_small = estimate_ms(TierKind::Pc, &discrete, &SIZE_640).unwrap();
    let budget = Some(FrameBudget::from_ms(pc_small * 1.5));
    assert_eq!(
        plan(Some(&discrete), &SIZE_640, budget).chosen().kind,
        TierKind::Pc
    );
    assert_ne!(
        plan(Some(&discrete), &SIZE_4K, budget).chosen().kind,
        TierKind::Pc
    );
}

#[test]
fn frame_budgets_keep_microseconds() {
    assert_eq!(FrameBudget::from_ms(16.667).ms(), 16.667);
    assert_eq!(FrameBudget::from_ms(-1.0), FrameBudget::from_ms(0.0));
    assert_eq!(FrameBudget::from_ms(f64::NAN).ms(), 0.0);
    assert_eq!(
        TierChoice::AutoWithin(FrameBudget::from_ms(8.0)).budget(),
        Some(FrameBudget::from_ms(8.0))
    );
    assert_eq!(TierChoice::Auto.budget(), None);
}

/// What a set of shader files asks of the adapter, counted from the composed WGSL: the most
/// storage buffers one entry point uses and the most the files of one pipeline layout declare
/// together (a pipeline layout binds at least the first and, in this product, at most the
/// second), the bind groups the entry points use, and the largest workgroup (invocations,
/// width).
struct ShaderNeeds {
    storage_used: u32,
    storage_declared: u32,
    bind_groups: u32,
    sampled_textures: u32,
    invocations: u32,
    width: u32,
}

/// `layouts`: the files of the passes that share one pipeline layout, one list per layout.
fn shader_needs(layouts: &[&[&str]]) -> ShaderNeeds {
    let library = ShaderLibrary::new();
    let mut needs = ShaderNeeds {
        storage_used: 0,
        storage_declared: 0,
        bind_groups: 0,
        sampled_textures: 0,
        invocations: 0,
        width: 0,
    };
    let is_storage =
        |g: &naga::GlobalVariable| matches!(g.space, naga::AddressSpace::Storage { .. });
    for files in layouts {
        // The storage bindings the layout's files declare, each counted once.
        let mut declared = std::collections::BTreeSet::new();
        for file in *files {
            let module = library
                .compose(file, &[])
                .unwrap_or_else(|e| panic!("{file}: {e}"));
            let info = naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                gi_gpu::SHADER_CAPABILITIES,
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{file}: {e:?}"));
            declared.extend(
                module
                    .global_variables
                    .iter()
                    .filter(|(_, g)| is_storage(g))
                    .filter_map(|(_, g)| g.binding.as_ref().map(|b| (b.group, b.binding))),
            );
            for (index, entry) in module.entry_points.iter().enumerate() {
                let uses = info.get_entry_point(index);
                let used: Vec<&naga::GlobalVariable> = module
                    .global_variables
                    .iter()
                    .filter(|(handle, _)| !uses[*handle].is_empty())
                    .map(|(_, g)| g)
                    .collect();
                let storage = used.iter().filter(|g| is_storage(g)).count() as u32;
                let groups = used
                    .iter()
                    .filter_map(|g| g.binding.as_ref().map(|b| b.group + 1))
                    .max()
                    .unwrap_or(0);
                needs.storage_used = needs.storage_used.max(storage);
                needs.bind_groups = needs.bind_groups.max(groups);
                let sampled = used
                    .iter()
                    .filter(|g| matches!(module.types[g.ty].inner, naga::TypeInner::Image { .. }))
                    .count() as u32;
                needs.sampled_textures = needs.sampled_textures.max(sampled);
                needs.invocations = needs.invocations.max(entry.workgroup_size.iter().product());
                needs.width = needs.width.max(entry.workgroup_size[0]);
            }
        }
        needs.storage_declared = needs.storage_declared.max(declared.len() as u32);
    }
    needs
}

#[test]
fn tier_requirements_match_the_shaders() {
    // Every GPU tier skins moving skinned meshes (`gi_gpu::GpuScene::update`).
    let path: [&[&str]; 3] = [
        &["path/trace.wgsl"],
        &["path/resolve.wgsl"],
        &["skin/skin.wgsl"],
    ];
    let frame: [&[&str]; 4] = [
        &["skin/skin.wgsl"],
        &["gbuffer/primary.wgsl"],
        &["path/trace.wgsl"],
        &["path/resolve.wgsl"],
    ];
    let cache: [&[&str]; 9] = [
        &["cache/voxelize.wgsl"],
        &["cache/screen_inject.wgsl"],
        &[
            "cache/query/trace_rays.wgsl",
            "cache/query/trace_rays_shared.wgsl",
        ],
        &["cache/query/irradiance_at.wgsl"],
        &["cache/query/debug_view.wgsl"],
        &["cache/inject.wgsl"],
        &["cache/propagate_list.wgsl"],
        &["cache/propagate.wgsl"],
        &["cache/propagate_resolve.wgsl"],
    ];
    let mobile: [&[&str]; 3] = [
        &[
            "mobile/screen/lite_pack.wgsl",
            "mobile/screen/reproject.wgsl",
            "mobile/screen/place.wgsl",
            "mobile/screen/trace.wgsl",
            "mobile/screen/gather.wgsl",
            "mobile/screen/compose.wgsl",
        ],
        &["mobile/volume/update.wgsl"],
        &["mobile/volume/irradiance_at.wgsl"],
    ];
    let pc: [&[&str]; 3] = [
        &[
            "pc/restir/trace.wgsl",
            "pc/restir/shadow.wgsl",
            "pc/restir/specular_trace.wgsl",
        ],
        &[
            "pc/restir/temporal.wgsl",
            "pc/restir/spatial.wgsl",
            "pc/restir/shade.wgsl",
            "pc/restir/compose.wgsl",
            "pc/restir/specular_resolve.wgsl",
            "pc/restir/specular_temporal.wgsl",
        ],
        &[
            "pc/denoise/temporal.wgsl",
            "pc/denoise/variance.wgsl",
            "pc/denoise/atrous.wgsl",
        ],
    ];
    let cases: [(TierKind, Vec<&[&str]>); 4] = [
        (TierKind::Direct, path.to_vec()),
        (TierKind::Path, path.to_vec()),
        (TierKind::Mobile, [&frame[..], &cache, &mobile].concat()),
        (TierKind::Pc, [&frame[..], &cache, &pc].concat()),
    ];
    for (kind, layouts) in cases {
        let req = requirements(kind, &SIZE_640).unwrap();
        let needs = shader_needs(&layouts);
        assert!(
            (needs.storage_used..=needs.storage_declared).contains(&req.storage_buffers_per_stage),
            "{kind}: {} storage buffers per stage, shaders use {} and declare {}",
            req.storage_buffers_per_stage,
            needs.storage_used,
            needs.storage_declared
        );
        assert_eq!(
            (
                req.bind_groups,
                req.sampled_textures_per_stage,
                req.invocations_per_workgroup,
                req.workgroup_size_x
            ),
            (
                needs.bind_groups,
                needs.sampled_textures,
                needs.invocations,
                needs.width
            ),
            "{kind}"
        );
        assert!(req.largest_binding_bytes >= 640 * 360 * 16, "{kind}");
    }
    assert!(requirements(TierKind::Reference, &SIZE_640).is_none());
}

const GPU_SETTINGS: TierSettings = TierSettings {
    width: 32,
    height: 24,
    spp: 1,
    seed: 7,
    textures: gi_tiers::TextureOptions::DEFAULT,
};

#[test]
fn auto_within_a_budget_renders_the_tier_the_plan_chose() {
    let Some(ctx) = GpuContext::new_or_skip("auto_within_a_budget_renders_the_planned_tier") else {
        return;
    };
    let adapter = AdapterDescription::from_context(&ctx);
    drop(ctx);
    // A budget between the mobile and pc estimates on this adapter: mobile where it runs.
    let ms = |kind| estimate_ms(kind, &adapter, &GPU_SETTINGS).unwrap();
    let budget = FrameBudget::from_ms((ms(TierKind::Pc) + ms(TierKind::Mobile)) / 2.0);
    let plan = plan(Some(&adapter), &GPU_SETTINGS, Some(budget));
    let scene = gi_scene::load("cornell-box").unwrap();
    let choice = TierChoice::AutoWithin(budget);
    let mut renderer = Renderer::new(scene, choice, GPU_SETTINGS, CameraMode::Default).unwrap();
    let selection = renderer
        .selection()
        .expect("auto reports its selection")
        .clone();
    assert_eq!(renderer.tier(), plan.chosen().kind);
    assert_eq!(selection.chosen, plan.chosen().kind);
    assert_eq!(selection.reason, plan.chosen().reason);
    assert!(selection.reason.contains("budget"), "{}", selection.reason);
    assert!(selection.fallbacks.is_empty(), "{:?}", selection.fallbacks);
    assert_eq!(selection.adapter, Some(adapter.label()));
    assert_eq!(selection.plan, plan);
    if selection.chosen == TierKind::Mobile {
        let frame = renderer.render_frame(None).unwrap();
        assert!(
            frame
                .passes
                .iter()
                .any(|(name, _)| name.starts_with("mobile/"))
        );
    }
    // Explicit choices have no selection to report.
    let scene = gi_scene::load("cornell-box").unwrap();
    let explicit = Renderer::new(
        scene,
        TierChoice::Tier(TierKind::Reference),
        GPU_SETTINGS,
        CameraMode::Default,
    );
    assert!(explicit.unwrap().selection().is_none());
}

#[test]
fn a_candidate_that_cannot_be_created_falls_back_to_the_next() {
    if GpuContext::new_or_skip("a_candidate_that_cannot_be_created_falls_back").is_none() {
        return;
    }
    // A plan edited by hand: the reference has no GPU version, so its GPU candidate fails in
    // the tier's own creation and the direct tier on the CPU takes over.
    let plan = Plan {
        candidates: vec![
            Candidate {
                kind: TierKind::Reference,
                runs_on: RunsOn::Gpu,
                reason: "asked for on the GPU".to_string(),
            },
            Candidate {
                kind: TierKind::Direct,
                runs_on: RunsOn::Cpu,
                reason: "the next candidate".to_string(),
            },
        ],
        rejected: Vec::new(),
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let mut renderer = Renderer::from_plan(scene, plan, GPU_SETTINGS, CameraMode::Default).unwrap();
    assert_eq!(renderer.tier(), TierKind::Direct);
    let selection = renderer.selection().unwrap();
    assert_eq!(
        (selection.chosen, selection.runs_on),
        (TierKind::Direct, RunsOn::Cpu)
    );
    assert_eq!(selection.reason, "the next candidate");
    assert_eq!(selection.fallbacks.len(), 1, "{:?}", selection.fallbacks);
    let (kind, error) = &selection.fallbacks[0];
    assert_eq!(*kind, TierKind::Reference);
    assert!(error.contains("no GPU version"), "{error}");
    assert!(selection.adapter.is_some());
    assert!(!renderer.render_frame(None).unwrap().image.pixels.is_empty());

    // When every candidate fails, the last error comes back.
    let plan = Plan {
        candidates: vec![Candidate {
            kind: TierKind::Pc,
            runs_on: RunsOn::Cpu,
            reason: "pc has no CPU version".to_string(),
        }],
        rejected: Vec::new(),
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    assert!(Renderer::from_plan(scene, plan, GPU_SETTINGS, CameraMode::Default).is_err());
}

#[test]
fn a_measured_adapter_takes_its_measured_factor_instead_of_its_class_assumption() {
    let generic = adapter(wgpu::DeviceType::DiscreteGpu);
    let h100 = AdapterDescription {
        name: "NVIDIA H100 80GB HBM3".to_string(),
        ..generic.clone()
    };
    assert_eq!(select::slowdown(&h100), 1.0);
    assert_eq!(select::slowdown(&generic), 4.0);
    let pc = |a: &AdapterDescription| estimate_ms(TierKind::Pc, a, &SIZE_640).unwrap();
    assert!((pc(&generic) / pc(&h100) - 4.0).abs() < 1e-9);
    // A budget between the two pc estimates: the H100 runs pc within it, a generic discrete
    // GPU does not.
    let budget = Some(FrameBudget::from_ms((pc(&generic) + pc(&h100)) / 2.0));
    assert_eq!(
        plan(Some(&h100), &SIZE_640, budget).chosen().kind,
        TierKind::Pc
    );
    assert_ne!(
        plan(Some(&generic), &SIZE_640, budget).chosen().kind,
        TierKind::Pc
    );
}

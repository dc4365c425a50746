//! The reference rendered by the GPU path tier: the same image as the CPU path tracer's for
//! the same request, recorded in the cache as made on the GPU.

use gi_gpu::GpuContext;
use gi_reference::cache::ReferenceRequest;
use gi_reference::engine::{EngineChoice, EngineKind, ReferenceEngine};
use gi_tiers::{GpuReferenceEngine, reference_cache, reference_engine};
use glam::Vec3;

#[test]
fn the_gpu_engine_renders_the_cpu_reference_and_the_cache_says_so() {
    let Some(ctx) = GpuContext::new_or_skip("the_gpu_engine_renders_the_cpu_reference") else {
        return;
    };
    let scene = gi_scene::load("cornell-box").unwrap();
    let request = ReferenceRequest::new(&scene, scene.default_view(0.0), 0.0, (16, 12), 64, 9);
    let engine = GpuReferenceEngine::open().unwrap();
    assert_eq!(engine.kind(), EngineKind::Gpu);
    let description = engine.description();
    assert_eq!(description, format!("gpu: {}", ctx.adapter_info.name));

    let progress = std::sync::Mutex::new(Vec::new());
    let (gpu, stats) = engine
        .render(
            &request,
            &|done| progress.lock().unwrap().push(done),
            &|| false,
        )
        .unwrap()
        .unwrap();
    assert_eq!(progress.into_inner().unwrap().last(), Some(&64));
    assert_eq!(stats.samples, 16 * 12 * 64);
    assert_eq!(stats.nonfinite_samples, 0);
    let (cpu, _) = request.render(&|_| {}, &|| false).unwrap().unwrap();
    // The same random numbers: each pixel agrees to f32 rounding but for the rare path that
    // rounding sends another way (tests/path.rs has the statistics).
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-3 * a.max(b).max_element();
    let agreeing = gpu
        .pixels
        .iter()
        .zip(&cpu.pixels)
        .filter(|&(g, c)| close(*g, *c))
        .count();
    assert!(agreeing * 10 >= cpu.pixels.len() * 9, "{agreeing} agree");
    // Cancelled before the first frame: nothing.
    assert!(
        engine
            .render(&request, &|_| {}, &|| true)
            .unwrap()
            .is_none()
    );

    let dir = tempfile::tempdir().unwrap();
    let cache = reference_cache(dir.path(), EngineChoice::Gpu).unwrap();
    let made = cache
        .get_or_render(&request, true, &|_| {}, &|| false)
        .unwrap()
        .unwrap();
    assert!(!made.cached);
    assert_eq!(made.engine, description);
    assert_eq!(made.image.pixels, gpu.pixels);
    // An explicit CPU choice renders its own; auto takes either.
    let cpu_cache = reference_cache(dir.path(), EngineChoice::Cpu).unwrap();
    assert!(cpu_cache.load(&request.key()).is_none());
    let auto_cache = reference_cache(dir.path(), EngineChoice::Auto).unwrap();
    assert_eq!(auto_cache.load(&request.key()).unwrap().engine, description);
}

#[test]
fn auto_renders_on_a_hardware_gpu_and_on_the_cpu_otherwise() {
    let Some(ctx) = GpuContext::new_or_skip("auto_renders_on_a_hardware_gpu") else {
        return;
    };
    let hardware = ctx.adapter_info.device_type != gi_gpu::wgpu::DeviceType::Cpu;
    let auto = reference_engine(EngineChoice::Auto).unwrap();
    let expected = if hardware {
        EngineKind::Gpu
    } else {
        EngineKind::Cpu
    };
    assert_eq!(auto.kind(), expected, "{}", auto.description());
    assert_eq!(
        reference_engine(EngineChoice::Cpu).unwrap().description(),
        "cpu"
    );
    assert_eq!(
        reference_engine(EngineChoice::Gpu).unwrap().kind(),
        EngineKind::Gpu
    );
}

//! `gi-bench deform`: the per-frame cost of deforming geometry in the GPU BVH, refit against
//! rebuilt, on `skinned_tube(rings, sides)` (a skinned arm of 2 x rings x sides triangles
//! whose elbow bends through 90 degrees and back every 2 s).
//!
//! The same `frames` frames of the animation are evaluated on the CPU once, complete
//! (`Scene::evaluate`) and as the GPU tiers evaluate them (`Scene::evaluate_with` leaving out
//! the normals and tangents of the meshes skinned on the GPU), both reported apart, and
//! followed by a `GpuScene`, as a tier follows them (`GpuScene::update` with the tiers'
//! frames: the BVH with the default rule, the deforming triangles' shading data written by
//! the GPU skinning pass `skin`; its CPU time and the GPU time of `skin` are reported apart
//! too). Then for each way of following them in the BVH alone (refit: the
//! level built at rest, then refit on the GPU every frame; default: refit until the level's
//! upper nodes grow past `DEFORMING_REBUILD_GROWTH`, then built again; rebuild: built again
//! on the CPU every frame, the behaviour before refits), [`GpuBvh::update_timed`] follows
//! each frame: its CPU time (writing the vertices and recording the refit, or the build and
//! its upload) and the GPU time of pass `bvh/refit`, as
//! medians. Then, at the last frame, each BVH traces the same `rays` rays aimed at the arm
//! (from points around it towards random points in its box; closest hit), after `settle_s`
//! seconds of tracing for the GPU's clock to climb: what the refit's looser boxes cost the
//! traversal. With 30 frames the last is the arm bent by 90 degrees; with 60, back at rest.

use std::time::Instant;

use anyhow::bail;
use gi_gpu::bvh::{BvhTracer, DEFORMING_REBUILD_GROWTH, GpuBvh, GpuRay};
use gi_gpu::{GpuContext, GpuScene, GpuTimer, ShaderLibrary, TimerMode};
use glam::Vec3;

/// One way of following the frames.
pub struct ModeResult {
    /// `refit` or `rebuild`.
    pub mode: &'static str,
    /// Median CPU milliseconds of `GpuBvh::update` per frame.
    pub update_cpu_ms: f64,
    /// Median GPU milliseconds of pass `bvh/refit` (0 when rebuilt).
    pub refit_gpu_ms: f64,
    /// Updates that refit and that rebuilt.
    pub refits: u32,
    pub rebuilds: u32,
    /// Median GPU milliseconds of tracing the rays at the last frame.
    pub trace_ms: f64,
    /// The level's watched growth at the last frame (`BottomLevels::deforming_growth`).
    pub growth: f32,
}

/// Everything `gi-bench deform` measured.
pub struct DeformReport {
    pub triangles: usize,
    pub frames: u32,
    pub rays: usize,
    pub adapter: String,
    pub timer_mode: TimerMode,
    /// Median CPU milliseconds of `Scene::evaluate` per frame (skinning), the same for both.
    pub skinning_ms: f64,
    /// Median CPU milliseconds of the GPU tiers' evaluation (`Scene::evaluate_with`, normals
    /// and tangents of the GPU-skinned meshes left out).
    pub positions_only_ms: f64,
    /// Median CPU milliseconds of `GpuScene::update` per frame (the BVH with the default rule,
    /// the shading data of the deforming triangles, lights and emitters).
    pub scene_update_ms: f64,
    /// Median GPU milliseconds of its pass `skin` (0 when no mesh is skinned on the GPU).
    pub skin_gpu_ms: f64,
    pub modes: Vec<ModeResult>,
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

/// Runs both modes; see the module docs.
pub fn run(
    rings: u32,
    sides: u32,
    frames: u32,
    rays: usize,
    repeats: usize,
    settle_s: f64,
) -> anyhow::Result<DeformReport> {
    if frames == 0 || rays == 0 {
        bail!("--frames and --rays must be at least 1");
    }
    let scene = gi_scene::generate::skinned_tube(rings, sides);
    let ctx = GpuContext::new()?;
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new())?;
    let evaluation = gi_scene::Evaluation {
        positions_only: gi_gpu::gpu_skinned_nodes(&scene),
    };
    let rest = scene.evaluate_with(0.0, None, &evaluation);
    let mut skinning = Vec::with_capacity(frames as usize);
    let mut positions_only = Vec::with_capacity(frames as usize);
    let evaluated: Vec<_> = (1..=frames)
        .map(|f| {
            let start = Instant::now();
            drop(scene.evaluate(scene.frame_time(f), None));
            skinning.push(start.elapsed().as_secs_f64() * 1e3);
            let start = Instant::now();
            let frame = scene.evaluate_with(scene.frame_time(f), None, &evaluation);
            positions_only.push(start.elapsed().as_secs_f64() * 1e3);
            frame
        })
        .collect();
    let last = evaluated.last().expect("frames >= 1");
    let arm = scene.nodes.iter().position(|n| n.name == "arm");
    let (lo, hi) = (last.triangles.iter().zip(&last.attributes))
        .filter(|(_, a)| Some(a.node as usize) == arm)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (t, _)| {
            let box_ = t.aabb();
            (lo.min(box_.min.into()), hi.max(box_.max.into()))
        });
    let center = (lo + hi) * 0.5;
    let radius = (hi - lo).length();
    let aimed: Vec<GpuRay> = (0..rays)
        .map(|i| {
            let u = |salt| crate::rays::random(i, salt);
            let z = 2.0 * u(1) - 1.0;
            let phi = std::f32::consts::TAU * u(2);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let origin = center + Vec3::new(r * phi.cos(), z, r * phi.sin()) * radius;
            let target = lo + (hi - lo) * Vec3::new(u(3), u(4), u(5));
            GpuRay::new(origin, (target - origin).normalize(), 0.0, f32::INFINITY)
        })
        .collect();
    let mut gpu_scene = GpuScene::upload(&ctx, &scene, &rest)?;
    let mut scene_update = Vec::with_capacity(evaluated.len());
    let mut skin_gpu = Vec::with_capacity(evaluated.len());
    let mut timer = GpuTimer::new(&ctx, "deform.scene_timer", 2);
    for frame in &evaluated {
        let start = Instant::now();
        gpu_scene.update_timed(&ctx, &scene, frame, &mut timer)?;
        scene_update.push(start.elapsed().as_secs_f64() * 1e3);
        let timings = timer.finish(&ctx, ctx.create_encoder("deform.scene_frame"));
        skin_gpu.push(timings.get("skin").unwrap_or(0.0));
    }
    gpu_scene.release(&ctx);
    let mut timer_mode = TimerMode::Gpu;
    let mut modes = Vec::new();
    for (mode, growth) in [
        ("refit", f32::INFINITY),
        ("default", DEFORMING_REBUILD_GROWTH),
        ("rebuild", 0.0),
    ] {
        let mut bvh = GpuBvh::from_scene(&ctx, &scene, &rest)?;
        bvh.set_deforming_rebuild_growth(growth);
        let mut timer = GpuTimer::new(&ctx, "deform.timer", 1);
        timer_mode = timer.mode();
        let (mut cpu, mut gpu) = (Vec::new(), Vec::new());
        for frame in &evaluated {
            bvh.update_timed(&ctx, frame, &mut timer)?;
            cpu.push(bvh.deform_seconds * 1e3);
            let timings = timer.finish(&ctx, ctx.create_encoder("deform.frame"));
            gpu.push(timings.get("bvh/refit").unwrap_or(0.0));
        }
        // The GPU idled while the CPU rebuilt: let its clock climb again before timing.
        let started = Instant::now();
        while started.elapsed().as_secs_f64() < settle_s {
            tracer.time(&ctx, &bvh, &aimed, 1);
        }
        let trace = tracer.time(&ctx, &bvh, &aimed, repeats);
        modes.push(ModeResult {
            mode,
            update_cpu_ms: median(&mut cpu),
            refit_gpu_ms: median(&mut gpu),
            refits: bvh.deform_refits,
            rebuilds: bvh.deform_rebuilds,
            trace_ms: trace.closest_ms,
            growth: bvh.bottom_levels().deforming_growth()[0],
        });
        bvh.release(&ctx);
    }
    Ok(DeformReport {
        triangles: scene
            .meshes
            .last()
            .map_or(0, |m| m.primitives[0].indices.len() / 3),
        frames,
        rays,
        adapter: ctx.adapter_info.name.clone(),
        timer_mode,
        skinning_ms: median(&mut skinning),
        positions_only_ms: median(&mut positions_only),
        scene_update_ms: median(&mut scene_update),
        skin_gpu_ms: median(&mut skin_gpu),
        modes,
    })
}

impl DeformReport {
    pub fn table(&self) -> String {
        let mut out = format!(
            "skinned tube: {} deforming triangles, {} frames, {} rays aimed at it; {} ({}); \
             CPU skinning (Scene::evaluate) {:.3} ms per frame, positions only \
             (Scene::evaluate_with, as the GPU tiers) {:.3} ms; GpuScene::update {:.3} ms of CPU \
             per frame, its pass skin {:.4} ms of GPU\n\n\
             | mode | update CPU ms | bvh/refit GPU ms | refits / rebuilds | growth | trace ms | Mrays/s |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
            self.triangles,
            self.frames,
            self.rays,
            self.adapter,
            self.timer_mode.describe(),
            self.skinning_ms,
            self.positions_only_ms,
            self.scene_update_ms,
            self.skin_gpu_ms,
        );
        for m in &self.modes {
            out.push_str(&format!(
                "| {} | {:.3} | {:.4} | {} / {} | {:.2} | {:.3} | {:.1} |\n",
                m.mode,
                m.update_cpu_ms,
                m.refit_gpu_ms,
                m.refits,
                m.rebuilds,
                m.growth,
                m.trace_ms,
                self.rays as f64 / (m.trace_ms * 1e3),
            ));
        }
        out
    }

    pub fn json(&self) -> serde_json::Value {
        let modes: Vec<_> = (self.modes.iter())
            .map(|m| {
                serde_json::json!({
                    "mode": m.mode,
                    "update_cpu_ms": m.update_cpu_ms,
                    "refit_gpu_ms": m.refit_gpu_ms,
                    "refits": m.refits,
                    "rebuilds": m.rebuilds,
                    "trace_ms": m.trace_ms,
                    "growth": m.growth,
                })
            })
            .collect();
        serde_json::json!({
            "benchmark": "deform",
            "triangles": self.triangles,
            "frames": self.frames,
            "rays": self.rays,
            "adapter": self.adapter,
            "skinning_ms": self.skinning_ms,
            "positions_only_ms": self.positions_only_ms,
            "skin_gpu_ms": self.skin_gpu_ms,
            "scene_update_ms": self.scene_update_ms,
            "modes": modes,
        })
    }
}

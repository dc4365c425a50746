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
//! too). The renderer's own evaluation, each frame moving the last one in place
//! (`Scene::evaluate_into`, which evaluates only the animated nodes' triangles again), is
//! reported as well; `--level-triangles` adds a static grid of that many triangles below the
//! tube, a level around an animated character. Then for each way of following them in the BVH alone (refit: the
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
    /// Median CPU milliseconds of the renderer's evaluation of the same frames: the last frame
    /// moved in place (`Scene::evaluate_into`, positions only as above).
    pub in_place_ms: f64,
    /// Triangles of the scene, and triangles `evaluate_into` evaluated at the last frame.
    pub scene_triangles: usize,
    pub evaluated_triangles: usize,
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

/// What `gi-bench deform` runs.
pub struct DeformOptions {
    pub rings: u32,
    pub sides: u32,
    pub frames: u32,
    pub rays: usize,
    pub repeats: usize,
    pub settle_s: f64,
    /// Static triangles in a grid below the tube (0: none).
    pub level_triangles: u32,
}

/// Adds a static node to `scene`: a grid of at least `triangles` triangles 40 m wide, 0.5 m
/// below the origin, in the scene's last material.
fn add_level(scene: &mut gi_scene::Scene, triangles: u32) {
    let cells = ((f64::from(triangles) / 2.0).sqrt().ceil() as u32).max(1);
    let mut grid = gi_scene::Primitive {
        material: scene.materials.len().saturating_sub(1),
        ..gi_scene::Primitive::default()
    };
    for z in 0..=cells {
        for x in 0..=cells {
            let at = |i: u32| 40.0 * (i as f32 / cells as f32 - 0.5);
            grid.positions.push(Vec3::new(at(x), -0.5, at(z)));
            grid.normals.push(Vec3::Y);
        }
    }
    let row = cells + 1;
    for z in 0..cells {
        for x in 0..cells {
            let a = z * row + x;
            grid.indices
                .extend_from_slice(&[a, a + row, a + 1, a + 1, a + row, a + row + 1]);
        }
    }
    scene.meshes.push(gi_scene::Mesh {
        name: "level".into(),
        primitives: vec![grid],
        weights: Vec::new(),
    });
    scene.nodes.push(gi_scene::Node {
        name: "level".into(),
        mesh: Some(scene.meshes.len() - 1),
        ..gi_scene::Node::default()
    });
}

/// Runs both modes; see the module docs.
pub fn run(options: &DeformOptions) -> anyhow::Result<DeformReport> {
    let &DeformOptions {
        rings,
        sides,
        frames,
        rays,
        repeats,
        settle_s,
        level_triangles,
    } = options;
    if frames == 0 || rays == 0 {
        bail!("--frames and --rays must be at least 1");
    }
    let mut scene = gi_scene::generate::skinned_tube(rings, sides);
    if level_triangles > 0 {
        add_level(&mut scene, level_triangles);
    }
    let ctx = GpuContext::new()?;
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new())?;
    let evaluation = gi_scene::Evaluation {
        positions_only: gi_gpu::gpu_skinned_nodes(&scene),
    };
    // A fixed camera, as the renderer passes one: without it every evaluation would frame the
    // scene's bounds (`Scene::fallback_view`, a pass over every vertex; the tube has no camera).
    let camera = Some(gi_scene::CameraView::look_at(
        Vec3::new(0.0, 1.0, 6.0),
        Vec3::new(0.0, 1.0, 0.0),
        0.8,
    ));
    let rest = scene.evaluate_with(0.0, camera, &evaluation);
    // Each way of evaluating in its own pass over the frames, each frame dropped before the
    // next as a renderer drops it, so that all pay the same allocations.
    let times: Vec<f32> = (1..=frames).map(|f| scene.frame_time(f)).collect();
    let timed = |evaluate: &dyn Fn(f32) -> gi_scene::SceneFrame| -> Vec<f64> {
        (times.iter())
            .map(|&time_s| {
                let start = Instant::now();
                drop(evaluate(time_s));
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect()
    };
    // The first pass over large frames pays for memory the later ones reuse (1.6x on a 2-core
    // machine): an untimed pass first, then the two ways alternate over two rounds.
    drop(timed(&|time_s| scene.evaluate(time_s, camera)));
    let (mut skinning, mut positions_only) = (Vec::new(), Vec::new());
    for _ in 0..2 {
        skinning.extend(timed(&|time_s| scene.evaluate(time_s, camera)));
        positions_only.extend(timed(&|time_s| {
            scene.evaluate_with(time_s, camera, &evaluation)
        }));
    }
    // As the renderer evaluates an animated scene's frames: the last one moved in place.
    let mut moved = rest.clone();
    let mut evaluated_triangles = 0;
    let mut in_place: Vec<f64> = (times.iter())
        .map(|&time_s| {
            let start = Instant::now();
            evaluated_triangles = scene.evaluate_into(&mut moved, time_s, camera, &evaluation);
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let evaluated: Vec<_> = (times.iter())
        .map(|&time_s| scene.evaluate_with(time_s, camera, &evaluation))
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
        triangles: (arm.and_then(|a| scene.nodes[a].mesh))
            .map_or(0, |m| scene.meshes[m].primitives[0].indices.len() / 3),
        frames,
        rays,
        adapter: ctx.adapter_info.name.clone(),
        timer_mode,
        skinning_ms: median(&mut skinning),
        positions_only_ms: median(&mut positions_only),
        in_place_ms: median(&mut in_place),
        scene_triangles: rest.triangles.len(),
        evaluated_triangles,
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
             (Scene::evaluate_with, as the GPU tiers) {:.3} ms, moved in place \
             (Scene::evaluate_into, as the renderer) {:.3} ms for {} of {} triangles; \
             GpuScene::update {:.3} ms of CPU per frame, its pass skin {:.4} ms of GPU\n\n\
             | mode | update CPU ms | bvh/refit GPU ms | refits / rebuilds | growth | trace ms | Mrays/s |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
            self.triangles,
            self.frames,
            self.rays,
            self.adapter,
            self.timer_mode.describe(),
            self.skinning_ms,
            self.positions_only_ms,
            self.in_place_ms,
            self.evaluated_triangles,
            self.scene_triangles,
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
            "in_place_ms": self.in_place_ms,
            "scene_triangles": self.scene_triangles,
            "evaluated_triangles": self.evaluated_triangles,
            "skin_gpu_ms": self.skin_gpu_ms,
            "scene_update_ms": self.scene_update_ms,
            "modes": modes,
        })
    }
}

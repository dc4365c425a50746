//! `gi-bench rays`: rays per second of the GPU's two-level CWBVH traversal (`gi::bvh`) and of
//! the CPU's (obvhs with rayon, one BVH over the flattened frame) on the same rays, in one run.
//!
//! The GPU structure is the one the tiers use (`GpuBvh::from_scene`): a static scene is one
//! world-space instance; an animated one has an object-space instance per moving node. Its
//! bottom levels are built at time 0, then the top level is updated over `repeats` frames of
//! the scene's animation (the per-frame cost, reported as the update time), and the rays are
//! traced at the last of those frames.
//!
//! Three kinds of rays, `count` of each:
//! - primary: camera rays over a pixel grid in 8 x 8 tiles, as the tiers' G-buffer casts them
//!   (coherent; closest hit),
//! - shadow: from the primary hits towards the scene's lights, or towards random points in the
//!   scene bounds when it has no punctual lights (any hit, finite segments),
//! - incoherent: cosine-distributed bounces off the primary hits (closest hit).
//!
//! GPU times are the median of `repeats` dispatches measured with timestamp queries (CPU
//! wall-clock around each pass when the adapter has none), after `--settle-s` seconds of
//! tracing so the GPU's clock has climbed (an idle H100 read up to 5x slower otherwise), all
//! kinds back to back; CPU times are the median wall-clock of `repeats` parallel runs over all
//! cores, timed afterwards.

use std::time::Instant;

use anyhow::{Context, bail};
use gi_gpu::bvh::{BvhTracer, GpuBvh, GpuRay, MeshSharing, TraceTimings};
use gi_gpu::{GpuContext, ShaderLibrary, TimerMode};
use gi_scene::{SceneBvh, SceneFrame};
use glam::Vec3;
use rayon::prelude::*;

/// Offset of secondary ray origins along the surface normal, in meters.
const SURFACE_OFFSET_M: f32 = 1e-3;

/// Timings of one kind of ray.
pub struct KindResult {
    /// `primary`, `shadow` or `incoherent`.
    pub kind: &'static str,
    /// `closest` or `occluded`: the query timed.
    pub query: &'static str,
    pub rays: usize,
    pub gpu_ms: f64,
    pub cpu_ms: f64,
}

impl KindResult {
    fn gpu_mrays_per_s(&self) -> f64 {
        self.rays as f64 / (self.gpu_ms * 1e3)
    }

    fn cpu_mrays_per_s(&self) -> f64 {
        self.rays as f64 / (self.cpu_ms * 1e3)
    }
}

/// Everything `gi-bench rays` measured.
pub struct RaysReport {
    pub scene: String,
    pub triangles: usize,
    /// Bottom-level nodes on the GPU (all levels) and the deepest bottom level.
    pub bvh_nodes: u32,
    pub bvh_depth: u32,
    /// Instances in the top level (1 for a static scene) and its node count.
    pub instances: u32,
    pub top_nodes: u32,
    /// CPU build and packing of every GPU bottom level, once per scene.
    pub bvh_build_ms: f64,
    /// Median per-frame top-level update (build plus queued upload) over the animated frames.
    pub update_ms: f64,
    /// The CPU baseline's single BVH build over the flattened frame.
    pub cpu_bvh_build_ms: f64,
    pub adapter: String,
    pub timer_mode: TimerMode,
    pub cpu_threads: usize,
    pub repeats: usize,
    /// Seconds of tracing before anything was timed (the GPU's clock settling).
    pub settle_s: f64,
    pub kinds: Vec<KindResult>,
}

/// `--mesh-sharing`: `auto`, `off` or `all`.
pub fn parse_sharing(value: &str) -> Result<MeshSharing, String> {
    match value {
        "auto" => Ok(MeshSharing::default()),
        "off" => Ok(MeshSharing::OFF),
        "all" => Ok(MeshSharing::ALL),
        other => Err(format!(
            "unknown mesh sharing '{other}': expected auto, off or all"
        )),
    }
}

/// Loads `scene`, builds and uploads its BVH (static meshes shared by `sharing`), traces for
/// `settle_s` seconds, and times `count` rays of each kind.
pub fn run(
    scene_name: &str,
    count: usize,
    repeats: usize,
    sharing: MeshSharing,
    settle_s: f64,
) -> anyhow::Result<RaysReport> {
    if count == 0 {
        bail!("--rays must be at least 1");
    }
    let scene = gi_scene::load(scene_name).with_context(|| format!("loading {scene_name}"))?;
    let ctx = GpuContext::new()?;
    let mut gpu_bvh = GpuBvh::from_scene_with(&ctx, &scene, &scene.evaluate(0.0, None), sharing)?;
    let mut updates = Vec::with_capacity(repeats);
    let mut time_s = 0.0;
    for frame_index in 1..=repeats as u32 {
        time_s = scene.frame_time(frame_index);
        gpu_bvh.update(&ctx, &scene.evaluate(time_s, None))?;
        updates.push(gpu_bvh.update_seconds * 1e3);
    }
    updates.sort_by(f64::total_cmp);
    let frame = scene.evaluate(time_s, None);
    let cpu_bvh = SceneBvh::build(&frame.triangles);
    let tracer = BvhTracer::new(&ctx, &ShaderLibrary::new())?;

    let primary = primary_rays(&frame, count);
    let surfaces = surfaces(&frame, &cpu_bvh, &primary);
    let sets = [
        ("primary", "closest", primary),
        ("shadow", "occluded", shadow_rays(&frame, &surfaces, count)),
        ("incoherent", "closest", bounce_rays(&surfaces, count)),
    ];
    // The GPU's clock climbs under load only: trace until it has, then time every kind on the
    // GPU back to back, and only then the CPU, which would leave the GPU idle in between.
    let started = Instant::now();
    while started.elapsed().as_secs_f64() < settle_s {
        tracer.time(&ctx, &gpu_bvh, &sets[2].2, 1);
    }
    let mut timer_mode = TimerMode::Gpu;
    let gpu_ms: Vec<f64> = (sets.iter())
        .map(|(_, query, rays)| {
            let gpu: TraceTimings = tracer.time(&ctx, &gpu_bvh, rays, repeats);
            timer_mode = gpu.mode;
            if *query == "occluded" {
                gpu.occluded_ms
            } else {
                gpu.closest_ms
            }
        })
        .collect();
    let kinds = (sets.iter().zip(gpu_ms))
        .map(|((kind, query, rays), gpu_ms)| KindResult {
            kind,
            query,
            rays: rays.len(),
            gpu_ms,
            cpu_ms: cpu_time_ms(&frame, &cpu_bvh, rays, query, repeats),
        })
        .collect();
    let report = RaysReport {
        scene: scene.name.clone(),
        triangles: frame.triangles.len(),
        bvh_nodes: gpu_bvh.node_count,
        bvh_depth: gpu_bvh.depth,
        instances: gpu_bvh.instance_count,
        top_nodes: gpu_bvh.top_node_count,
        bvh_build_ms: gpu_bvh.build_seconds * 1e3,
        update_ms: updates[updates.len() / 2],
        cpu_bvh_build_ms: cpu_bvh.build_time.as_secs_f64() * 1e3,
        adapter: ctx.adapter_info.name.clone(),
        timer_mode,
        cpu_threads: rayon::current_num_threads(),
        repeats,
        settle_s,
        kinds,
    };
    gpu_bvh.release(&ctx);
    Ok(report)
}

/// Side of the square pixel tiles primary rays are ordered in: the tiers' ray-cast G-buffer
/// (`gbuffer/primary`) runs 8 x 8 workgroups, so a 64-ray workgroup here covers the same
/// pixels as one there.
const TILE: usize = 8;

/// Camera rays through the pixel centers of a 4:3 grid of about `count` pixels (its sides
/// multiples of [`TILE`]), tile by tile in rows of tiles, each tile row by row; the first
/// `count` of them.
fn primary_rays(frame: &SceneFrame, count: usize) -> Vec<GpuRay> {
    let aspect = 4.0 / 3.0;
    let width = ((count as f32 * aspect).sqrt().ceil() as usize)
        .max(1)
        .next_multiple_of(TILE);
    let height = count.div_ceil(width).next_multiple_of(TILE);
    let tiles_x = width / TILE;
    (0..count)
        .map(|i| {
            let (tile, within) = (i / (TILE * TILE), i % (TILE * TILE));
            let x = (tile % tiles_x) * TILE + within % TILE;
            let y = (tile / tiles_x) * TILE + within / TILE;
            let u = (x as f32 + 0.5) / width as f32;
            let v = (y as f32 + 0.5) / height as f32;
            let dir = frame.camera.ray_direction(u, v, aspect);
            GpuRay::new(frame.camera.position, dir, 0.0, f32::INFINITY)
        })
        .collect()
}

/// A point just off a surface the camera sees, and the surface normal facing the camera.
#[derive(Clone, Copy)]
struct Surface {
    point: Vec3,
    normal: Vec3,
}

fn surfaces(frame: &SceneFrame, bvh: &SceneBvh, primary: &[GpuRay]) -> Vec<Surface> {
    let found: Vec<Surface> = primary
        .par_iter()
        .filter_map(|ray| {
            let (origin, dir) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
            let hit = bvh.closest_hit(&frame.triangles, origin, dir, 0.0, f32::INFINITY)?;
            let normal = Vec3::from(frame.triangles[hit.triangle as usize].compute_normal());
            let normal = if normal.dot(dir) > 0.0 {
                -normal
            } else {
                normal
            };
            let point = origin + dir * hit.t + normal * SURFACE_OFFSET_M;
            Some(Surface { point, normal })
        })
        .collect();
    if found.is_empty() {
        // The camera sees only sky: secondary rays leave the camera position instead.
        vec![Surface {
            point: frame.camera.position,
            normal: frame.camera.forward,
        }]
    } else {
        found
    }
}

/// SplitMix64 hash of `(index, salt)` to a float in `[0, 1)`: deterministic per ray, and free
/// of shared state so rays can be made in any order.
pub(crate) fn random(index: usize, salt: u64) -> f32 {
    let mut z = (index as u64 ^ salt.rotate_left(32)).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

fn shadow_rays(frame: &SceneFrame, surfaces: &[Surface], count: usize) -> Vec<GpuRay> {
    let (min, max) = bounds(frame);
    (0..count)
        .map(|i| {
            let surface = surfaces[i % surfaces.len()];
            let (wi, distance) = if frame.lights.is_empty() {
                let target =
                    min + (max - min) * Vec3::new(random(i, 1), random(i, 2), random(i, 3));
                let to_target = target - surface.point;
                (to_target.normalize_or(surface.normal), to_target.length())
            } else {
                let (wi, distance, _) =
                    frame.lights[i % frame.lights.len()].incident(surface.point);
                (wi, distance)
            };
            // Stop just short of the light so a light inside geometry's plane does not block.
            let t_max = if distance.is_finite() {
                distance * 0.999
            } else {
                f32::INFINITY
            };
            GpuRay::new(surface.point, wi, 0.0, t_max)
        })
        .collect()
}

/// Cosine-distributed directions about each surface normal (a diffuse bounce).
fn bounce_rays(surfaces: &[Surface], count: usize) -> Vec<GpuRay> {
    (0..count)
        .map(|i| {
            let surface = surfaces[i % surfaces.len()];
            let (r, phi) = (random(i, 4).sqrt(), std::f32::consts::TAU * random(i, 5));
            let (tangent, bitangent) = surface.normal.any_orthonormal_pair();
            let local_z = (1.0 - r * r).max(0.0).sqrt();
            let dir =
                tangent * (r * phi.cos()) + bitangent * (r * phi.sin()) + surface.normal * local_z;
            GpuRay::new(
                surface.point,
                dir.normalize_or(surface.normal),
                0.0,
                f32::INFINITY,
            )
        })
        .collect()
}

fn bounds(frame: &SceneFrame) -> (Vec3, Vec3) {
    frame.triangles.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(min, max), tri| {
            let lo = Vec3::from(tri.v0.min(tri.v1).min(tri.v2));
            let hi = Vec3::from(tri.v0.max(tri.v1).max(tri.v2));
            (min.min(lo), max.max(hi))
        },
    )
}

/// Median wall-clock milliseconds of tracing `rays` on all cores, after one warm-up run.
fn cpu_time_ms(
    frame: &SceneFrame,
    bvh: &SceneBvh,
    rays: &[GpuRay],
    query: &str,
    repeats: usize,
) -> f64 {
    let triangles = &frame.triangles;
    let trace = || {
        let start = Instant::now();
        let hits: usize = rays
            .par_iter()
            .map(|ray| {
                let (origin, dir) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
                let hit = if query == "occluded" {
                    bvh.occluded(triangles, origin, dir, ray.t_min, ray.t_max)
                } else {
                    bvh.closest_hit(triangles, origin, dir, ray.t_min, ray.t_max)
                        .is_some()
                };
                hit as usize
            })
            .sum();
        // Using the count keeps the traversal from being optimized away.
        std::hint::black_box(hits);
        start.elapsed().as_secs_f64() * 1e3
    };
    trace();
    let mut samples: Vec<f64> = (0..repeats).map(|_| trace()).collect();
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

impl RaysReport {
    /// A markdown table, one row per ray kind, with a header naming scene, BVH and devices.
    pub fn table(&self) -> String {
        let mut out = format!(
            "scene {}: {} triangles; GPU bottom levels {} nodes, depth {}, build {:.2} ms; \
             top level {} instances, {} nodes, update {:.3} ms per frame; CPU BVH build {:.2} ms\n\
             GPU: {} ({}, after {:.1} s of tracing), CPU: {} threads, median of {} runs\n\n",
            self.scene,
            self.triangles,
            self.bvh_nodes,
            self.bvh_depth,
            self.bvh_build_ms,
            self.instances,
            self.top_nodes,
            self.update_ms,
            self.cpu_bvh_build_ms,
            self.adapter,
            self.timer_mode.describe(),
            self.settle_s,
            self.cpu_threads,
            self.repeats
        );
        out.push_str(
            "| rays | query | count | GPU ms | GPU Mrays/s | CPU ms | CPU Mrays/s | GPU/CPU |\n",
        );
        out.push_str("|---|---|---:|---:|---:|---:|---:|---:|\n");
        for k in &self.kinds {
            out.push_str(&format!(
                "| {} | {} | {} | {:.3} | {:.2} | {:.3} | {:.2} | {:.2} |\n",
                k.kind,
                k.query,
                k.rays,
                k.gpu_ms,
                k.gpu_mrays_per_s(),
                k.cpu_ms,
                k.cpu_mrays_per_s(),
                k.cpu_ms / k.gpu_ms
            ));
        }
        out
    }

    /// The same figures as JSON (rates in millions of rays per second).
    pub fn json(&self) -> serde_json::Value {
        let kinds: Vec<_> = self
            .kinds
            .iter()
            .map(|k| {
                serde_json::json!({
                    "kind": k.kind,
                    "query": k.query,
                    "rays": k.rays,
                    "gpu_ms": k.gpu_ms,
                    "gpu_mrays_per_s": k.gpu_mrays_per_s(),
                    "cpu_ms": k.cpu_ms,
                    "cpu_mrays_per_s": k.cpu_mrays_per_s(),
                    "gpu_over_cpu": k.cpu_ms / k.gpu_ms,
                })
            })
            .collect();
        serde_json::json!({
            "benchmark": "rays",
            "scene": self.scene,
            "triangles": self.triangles,
            "bvh_nodes": self.bvh_nodes,
            "bvh_depth": self.bvh_depth,
            "bvh_build_ms": self.bvh_build_ms,
            "instances": self.instances,
            "top_nodes": self.top_nodes,
            "update_ms": self.update_ms,
            "cpu_bvh_build_ms": self.cpu_bvh_build_ms,
            "adapter": self.adapter,
            "gpu_timer": format!("{:?}", self.timer_mode),
            "cpu_threads": self.cpu_threads,
            "repeats": self.repeats,
            "settle_s": self.settle_s,
            "kinds": kinds,
        })
    }
}

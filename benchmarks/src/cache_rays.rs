//! `gi-bench cache-rays`: throughput of the brick cache's hierarchical DDA
//! (`gi::cache::trace`) against the GPU BVH (`gi::bvh`) on the same rays: camera rays, and
//! diffuse bounce rays leaving the surfaces the camera sees. The cache is filled on the CPU
//! with the default configuration, around the camera.
//!
//! Bounce rays start one level-0 voxel off their surface along its normal, as cache rays must
//! (the HDDA skips only the origin's voxel); the BVH gets the same rays.

use anyhow::{Context, bail};
use gi_cache::{CacheConfig, CacheTracer, CpuCache};
use gi_gpu::bvh::{BvhTracer, GpuBvh, GpuRay};
use gi_gpu::{GpuContext, ShaderLibrary, TimerMode};
use gi_scene::{SceneBvh, SceneFrame};
use glam::Vec3;

/// One kind of ray, timed through both structures.
pub struct KindResult {
    pub kind: &'static str,
    pub rays: usize,
    pub bvh_ms: f64,
    pub cache_ms: f64,
    /// The same rays traced `CACHE_LANES` invocations per ray (`trace_rays_shared`).
    pub shared_ms: f64,
    /// Share of the rays the cache hits.
    pub cache_hit_share: f64,
}

/// The figures of one scene.
pub struct CacheRaysReport {
    pub scene: String,
    pub adapter: String,
    pub timer_mode: TimerMode,
    pub bricks: u32,
    pub dropped_bricks: u32,
    pub cache_bytes: u64,
    pub repeats: usize,
    pub kinds: Vec<KindResult>,
}

fn mrays_per_s(rays: usize, ms: f64) -> f64 {
    if ms > 0.0 {
        rays as f64 / (ms * 1e3)
    } else {
        0.0
    }
}

pub fn run(scene_name: &str, count: usize, repeats: usize) -> anyhow::Result<CacheRaysReport> {
    if count == 0 {
        bail!("--rays must be at least 1");
    }
    let scene = gi_scene::load(scene_name).with_context(|| format!("loading {scene_name}"))?;
    let frame = scene.evaluate(0.0, None);
    let ctx = GpuContext::new()?;
    let shaders = ShaderLibrary::new();
    let config = CacheConfig::default();
    let cpu = CpuCache::build(&config, &scene, &frame, frame.camera.position)?;
    let cache = cpu.upload(&ctx);
    let bvh = GpuBvh::from_scene(&ctx, &scene, &frame)?;
    let cpu_bvh = SceneBvh::build(&frame.triangles);
    let bvh_tracer = BvhTracer::new(&ctx, &shaders)?;
    let cache_tracer = CacheTracer::new(&ctx, &shaders)?;

    let primary = primary_rays(&frame, count);
    let bounce = bounce_rays(&frame, &cpu_bvh, &primary, config.voxel_size_m);
    let mut kinds = Vec::new();
    let mut timer_mode = TimerMode::Gpu;
    for (kind, rays) in [("primary", primary), ("incoherent", bounce)] {
        let hits = cache_tracer.trace(&ctx, &cache, &rays);
        let cache_hit_share =
            hits.iter().filter(|h| h.hit).count() as f64 / rays.len().max(1) as f64;
        let bvh_ms = bvh_tracer.time(&ctx, &bvh, &rays, repeats).closest_ms;
        let timing = cache_tracer.time(&ctx, &cache, &rays, repeats);
        timer_mode = timing.mode;
        kinds.push(KindResult {
            kind,
            rays: rays.len(),
            bvh_ms,
            cache_ms: timing.trace_ms,
            shared_ms: timing.shared_ms,
            cache_hit_share,
        });
    }
    let report = CacheRaysReport {
        scene: scene.name.clone(),
        adapter: ctx.adapter_info.name.clone(),
        timer_mode,
        bricks: cpu.bricks_per_level().iter().sum(),
        dropped_bricks: cpu.dropped_for_pool,
        cache_bytes: cache.bytes(),
        repeats,
        kinds,
    };
    cache.release(&ctx);
    bvh.release(&ctx);
    Ok(report)
}

/// Camera rays through the pixel centers of a 4:3 grid of about `count` pixels.
fn primary_rays(frame: &SceneFrame, count: usize) -> Vec<GpuRay> {
    let aspect = 4.0 / 3.0;
    let width = ((count as f32 * aspect).sqrt().ceil() as usize).max(1);
    let height = count.div_ceil(width);
    (0..count)
        .map(|i| {
            let (u, v) = (
                ((i % width) as f32 + 0.5) / width as f32,
                ((i / width) as f32 + 0.5) / height as f32,
            );
            let dir = frame.camera.ray_direction(u, v, aspect);
            GpuRay::new(frame.camera.position, dir, 0.0, 1e30)
        })
        .collect()
}

/// SplitMix64 hash of `(index, salt)` to `[0, 1)`.
fn random(index: usize, salt: u64) -> f32 {
    let mut z = (index as u64 ^ salt.rotate_left(32)).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// Cosine-distributed rays leaving the surfaces the camera rays hit, from one `offset_m` off
/// each surface along its normal (one ray per camera ray; camera rays that see nothing give
/// none, so there may be fewer).
fn bounce_rays(
    frame: &SceneFrame,
    bvh: &SceneBvh,
    primary: &[GpuRay],
    offset_m: f32,
) -> Vec<GpuRay> {
    primary
        .iter()
        .enumerate()
        .filter_map(|(i, ray)| {
            let (origin, dir) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
            let hit = bvh.closest_hit(&frame.triangles, origin, dir, 0.0, f32::INFINITY)?;
            let n = Vec3::from(frame.triangles[hit.triangle as usize].compute_normal()).normalize();
            let n = if n.dot(dir) > 0.0 { -n } else { n };
            let point = origin + dir * hit.t + n * offset_m;
            let (r, phi) = (random(i, 4).sqrt(), std::f32::consts::TAU * random(i, 5));
            let (t, b) = n.any_orthonormal_pair();
            let z = (1.0 - r * r).max(0.0).sqrt();
            let wi = (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize_or(n);
            Some(GpuRay::new(point, wi, 0.0, 1e30))
        })
        .collect()
}

impl CacheRaysReport {
    pub fn table(&self) -> String {
        let mut out = format!(
            "scene {} on {} ({:?} timer, median of {}), cache {} bricks ({} dropped), {:.1} MiB\n",
            self.scene,
            self.adapter,
            self.timer_mode,
            self.repeats,
            self.bricks,
            self.dropped_bricks,
            self.cache_bytes as f64 / (1024.0 * 1024.0)
        );
        out += &format!(
            "{:<11} {:>8} {:>10} {:>12} {:>10} {:>12} {:>7} {:>11} {:>9}\n",
            "kind",
            "rays",
            "bvh ms",
            "bvh Mray/s",
            "hdda ms",
            "hdda Mray/s",
            "speedup",
            "lanes ms",
            "cache hit"
        );
        for k in &self.kinds {
            let (bvh, hdda) = (
                mrays_per_s(k.rays, k.bvh_ms),
                mrays_per_s(k.rays, k.cache_ms),
            );
            out += &format!(
                "{:<11} {:>8} {:>10.3} {:>12.3} {:>10.3} {:>12.3} {:>6.2}x {:>11.3} {:>8.1}%\n",
                k.kind,
                k.rays,
                k.bvh_ms,
                bvh,
                k.cache_ms,
                hdda,
                if bvh > 0.0 { hdda / bvh } else { 0.0 },
                k.shared_ms,
                100.0 * k.cache_hit_share
            );
        }
        out
    }

    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "scene": self.scene,
            "adapter": self.adapter,
            "timer": format!("{:?}", self.timer_mode),
            "repeats": self.repeats,
            "cache_bricks": self.bricks,
            "cache_dropped_bricks": self.dropped_bricks,
            "cache_bytes": self.cache_bytes,
            "kinds": self.kinds.iter().map(|k| serde_json::json!({
                "kind": k.kind,
                "rays": k.rays,
                "bvh_ms": k.bvh_ms,
                "bvh_mrays_per_s": mrays_per_s(k.rays, k.bvh_ms),
                "hdda_ms": k.cache_ms,
                "hdda_mrays_per_s": mrays_per_s(k.rays, k.cache_ms),
                "hdda_lanes_ms": k.shared_ms,
                "cache_hit_share": k.cache_hit_share,
            })).collect::<Vec<_>>(),
        })
    }
}

#[cfg(test)]
mod tests {
    /// The tiny mode: the benchmark runs end to end on a few rays, so it cannot rot.
    #[test]
    fn tiny_run_times_both_structures() {
        if gi_gpu::GpuContext::new_or_skip("cache_rays::tiny_run_times_both_structures").is_none() {
            return;
        }
        let report = super::run("cornell-box", 64, 1).unwrap();
        assert_eq!(report.kinds.len(), 2);
        assert!(report.kinds[0].cache_hit_share > 0.5, "{}", report.table());
        assert!(report.table().contains("hdda"));
    }
}

//! `gi-bench path`: samples per second of the GPU path tracer (`path/trace`) at a given image
//! size and samples per pixel.
//!
//! The tier renders `frames` frames of the still scene after one warm-up frame; each adds `spp`
//! samples per pixel, so every frame does the same work. The reported time is the median of the
//! `path/trace` pass over those frames, from GPU timestamps (CPU wall-clock around the pass
//! when the adapter has none, which adds submission overhead).

use anyhow::{Context, bail};
use gi_tiers::{FrameInput, GpuPathTier, Tier, TierKind, TierSettings};

/// What `gi-bench path` measured.
pub struct PathReport {
    pub scene: String,
    pub triangles: usize,
    pub adapter: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub frames: u32,
    /// True when the pass times come from GPU timestamps.
    pub gpu_timestamps: bool,
    /// Median time of `path/trace` per frame.
    pub trace_ms: f64,
    /// Median time of `path/resolve` per frame.
    pub resolve_ms: f64,
    /// Median rays (closest-hit and shadow) traced per frame.
    pub rays_per_frame: f64,
    /// Bytes the tier holds on the GPU.
    pub memory_bytes: u64,
}

impl PathReport {
    /// Camera paths per second of `path/trace`.
    pub fn samples_per_second(&self) -> f64 {
        f64::from(self.width) * f64::from(self.height) * f64::from(self.spp)
            / (self.trace_ms * 1e-3)
    }

    /// Rays per second of `path/trace`.
    pub fn rays_per_second(&self) -> f64 {
        self.rays_per_frame / (self.trace_ms * 1e-3)
    }

    /// A markdown table of the results.
    pub fn table(&self) -> String {
        let clock = if self.gpu_timestamps {
            "GPU timestamps"
        } else {
            "CPU wall-clock"
        };
        format!(
            "{} ({} triangles) on {}, {}x{} at {} spp, median of {} frames ({clock})\n\
             | pass | ms | Msamples/s | Mrays/s |\n|---|---|---|---|\n\
             | path/trace | {:.3} | {:.2} | {:.1} |\n| path/resolve | {:.3} | | |\n\
             memory: {:.2} MiB\n",
            self.scene,
            self.triangles,
            self.adapter,
            self.width,
            self.height,
            self.spp,
            self.frames,
            self.trace_ms,
            self.samples_per_second() * 1e-6,
            self.rays_per_second() * 1e-6,
            self.resolve_ms,
            self.memory_bytes as f64 / (1 << 20) as f64,
        )
    }

    /// The results as JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "scene": self.scene,
            "triangles": self.triangles,
            "adapter": self.adapter,
            "width": self.width,
            "height": self.height,
            "spp": self.spp,
            "frames": self.frames,
            "gpu_timestamps": self.gpu_timestamps,
            "trace_ms": self.trace_ms,
            "resolve_ms": self.resolve_ms,
            "samples_per_second": self.samples_per_second(),
            "rays_per_frame": self.rays_per_frame,
            "rays_per_second": self.rays_per_second(),
            "memory_bytes": self.memory_bytes,
        })
    }
}

/// Loads `scene_name` and times the path tracer on it.
pub fn run(
    scene_name: &str,
    (width, height): (u32, u32),
    spp: u32,
    frames: u32,
) -> anyhow::Result<PathReport> {
    if frames == 0 {
        bail!("--frames must be at least 1");
    }
    let scene = gi_scene::load(scene_name).with_context(|| format!("loading {scene_name}"))?;
    let frame = scene.evaluate(0.0, None);
    let settings = TierSettings {
        width,
        height,
        spp,
        seed: 0,
        textures: gi_tiers::TextureOptions::DEFAULT,
    };
    let mut tier = GpuPathTier::open(TierKind::Path, settings)?;
    let mut trace = Vec::new();
    let mut resolve = Vec::new();
    let mut rays = Vec::new();
    for index in 0..=frames {
        let output = tier.render(&FrameInput {
            scene: &scene,
            frame: &frame,
            index,
            progress: None,
        })?;
        // Frame 0 is the warm-up: it includes the scene upload and pipeline first use.
        if index == 0 {
            continue;
        }
        if let Some(stats) = &output.stats {
            rays.push(stats.rays as f64);
        }
        for (name, ms) in output.passes {
            match name.as_str() {
                "path/trace" => trace.push(ms),
                "path/resolve" => resolve.push(ms),
                _ => {}
            }
        }
    }
    let ctx = tier.context();
    Ok(PathReport {
        scene: scene_name.to_owned(),
        triangles: frame.triangles.len(),
        adapter: ctx.adapter_info.name.clone(),
        width,
        height,
        spp,
        frames,
        gpu_timestamps: ctx.supports_timestamps(),
        trace_ms: median(&mut trace),
        resolve_ms: median(&mut resolve),
        rays_per_frame: median(&mut rays),
        memory_bytes: tier.memory_bytes(),
    })
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(0.0)
}

//! What `results.json` holds, and how the repeats of a cell become its mean and spread.
//!
//! The child process of a scene reports one [`CellRun`] per tier and repeat; the parent folds
//! the runs of each (scene, tier) into a [`Cell`] of [`Stat`]s.

use gi_reference::engine::EngineChoice;
use serde::{Deserialize, Serialize};

/// Version of the `results.json` layout; a baseline of another version is refused.
pub const SCHEMA_VERSION: u32 = 1;

/// The whole `results.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Results {
    pub schema: u32,
    /// Commit the binary was built from (`-dirty` when tracked files differed), or `unknown`.
    pub commit: String,
    /// When the suite started, UTC, RFC 3339.
    pub date: String,
    /// The command line, program first.
    pub command: Vec<String>,
    /// Logical CPUs of the machine (the CPU tiers and the references use them all).
    pub cpu_count: usize,
    /// The Vulkan adapter the GPU tiers ran on, as the first scene's process found it; null
    /// when no process could open one.
    pub adapter: Option<Adapter>,
    pub options: Options,
    /// One per scene whose reference was found or rendered.
    pub references: Vec<ReferenceInfo>,
    /// One per scene and tier, in the order of the options' scenes, then tiers.
    pub cells: Vec<Cell>,
    /// Every scene or cell that failed, with its error.
    pub failures: Vec<Failure>,
    /// The comparison with `--baseline`, when one was given.
    pub regressions: Option<crate::suite::regress::Comparison>,
}

impl Results {
    /// The cells of `tier` that measured passes, in scene order, and every pass name among
    /// them in first-seen order; `None` when no scene measured the tier.
    pub fn pass_cells(&self, tier: &str) -> Option<(Vec<&Cell>, Vec<&str>)> {
        let cells: Vec<&Cell> = self
            .cells
            .iter()
            .filter(|c| c.tier == tier && !c.passes_ms.is_empty())
            .collect();
        if cells.is_empty() {
            return None;
        }
        let mut names: Vec<&str> = Vec::new();
        for pass in cells.iter().flat_map(|c| &c.passes_ms) {
            if !names.contains(&pass.name.as_str()) {
                names.push(&pass.name);
            }
        }
        Some((cells, names))
    }
}

/// wgpu's description of the adapter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Adapter {
    pub name: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` (lavapipe) or `Other`.
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    pub backend: String,
}

impl Adapter {
    pub fn from_info(info: &gi_gpu::wgpu::AdapterInfo) -> Self {
        Self {
            name: info.name.clone(),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            backend: format!("{:?}", info.backend),
        }
    }

    /// `NVIDIA H100 (DiscreteGpu, NVIDIA 570.1)`.
    pub fn describe(&self) -> String {
        format!(
            "{} ({}, {} {})",
            self.name, self.device_type, self.driver, self.driver_info
        )
    }
}

/// The suite's settings, resolved (defaults filled in).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Options {
    pub scenes: Vec<String>,
    pub tiers: Vec<String>,
    pub width: u32,
    pub height: u32,
    /// Measured frames of the tiers that run on the GPU.
    pub frames: u32,
    /// Measured frames of the tiers that run on the CPU (at most `frames`).
    pub cpu_frames: u32,
    /// Still warm-up frames for every tier; null: each tier's default.
    pub warmup: Option<u32>,
    /// Samples per pixel per frame of the path-tracing tiers (anti-aliasing samples for
    /// `direct`).
    pub spp: u32,
    pub repeats: u32,
    pub reference_spp: u32,
    pub reference_seed: u64,
    /// `--reference-engine`; results from before it existed rendered on the CPU.
    #[serde(default = "cpu_choice")]
    pub reference_engine: EngineChoice,
    pub cache_dir: String,
    pub out_dir: String,
    /// `--lighting`: the lighting file applied to every scene (null: each scene's own
    /// `<stem>.lighting.json`, if any).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting: Option<String>,
}

fn cpu_choice() -> EngineChoice {
    EngineChoice::Cpu
}

fn cpu_description() -> String {
    "cpu".to_string()
}

/// The reference of one scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceInfo {
    pub scene: String,
    pub spp: u32,
    /// Scene time of the measured frame the reference shows.
    pub time_s: f32,
    /// Seconds its render took when it was made.
    pub seconds: f64,
    /// True when it came from the cache.
    pub cached: bool,
    /// The engine that rendered it: `cpu` or `gpu: <adapter name>`.
    #[serde(default = "cpu_description")]
    pub engine: String,
}

/// What one repeat of one (scene, tier) measured; a child process prints these.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellRun {
    pub rmse_srgb8: f64,
    /// Mean FLIP (LDR) against the reference, in 0..1 (`gi_image::flip_ldr`).
    pub flip: f64,
    pub rmse_linear: f64,
    /// Against the direct-only render of the same repeat; null when that error is 0.
    pub gain_vs_direct: Option<f64>,
    /// Median over the measured frames of the frame's summed passes.
    pub ms_per_frame: f64,
    /// Median over the measured frames of the GI passes' sum; null for tiers that compute
    /// their image as one transport ([`gi_tiers::TierKind::is_gi_pass`] never true).
    pub gi_ms: Option<f64>,
    /// Each pass's median over the measured frames, in the first frame's order (a pass
    /// recorded several times in a frame counts with its sum).
    pub passes_ms: Vec<(String, f64)>,
    pub memory_bytes: u64,
    /// Still warm-up frames rendered before the measured ones.
    pub warmup: u32,
    pub measured_frames: u32,
    /// True when the tier ran on the CPU (the reference, and `direct` without a hardware GPU).
    pub on_cpu: bool,
}

/// Mean and sample standard deviation of one metric over the repeats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    pub mean: f64,
    /// Sample standard deviation (n - 1); null with a single value.
    pub sd: Option<f64>,
    /// Every repeat's value, repeat 0 first.
    pub values: Vec<f64>,
}

impl Stat {
    /// `None` for no values.
    pub fn of(values: Vec<f64>) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let sd = (values.len() > 1).then(|| {
            let squares: f64 = values.iter().map(|v| (v - mean).powi(2)).sum();
            (squares / (n - 1.0)).sqrt()
        });
        Some(Self { mean, sd, values })
    }

    /// `12.34 ± 0.05` (or `12.34` without a spread) with `decimals` digits.
    pub fn format(&self, decimals: usize) -> String {
        match self.sd {
            Some(sd) => format!("{:.decimals$} ± {sd:.decimals$}", self.mean),
            None => format!("{:.decimals$}", self.mean),
        }
    }
}

/// A pass of a cell: the mean and spread over the repeats of its per-repeat median.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PassStat {
    pub name: String,
    pub ms: Stat,
}

/// One scene and tier over every repeat.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Cell {
    pub scene: String,
    pub tier: String,
    /// Repeats that finished (each a fresh renderer, seed = repeat index + 1).
    pub repeats: u32,
    pub rmse_srgb8: Option<Stat>,
    /// Mean FLIP (LDR); null in results from before it was measured.
    #[serde(default)]
    pub flip: Option<Stat>,
    pub rmse_linear: Option<Stat>,
    pub gain_vs_direct: Option<Stat>,
    pub ms_per_frame: Option<Stat>,
    pub gi_ms: Option<Stat>,
    pub memory_bytes: Option<Stat>,
    /// Per pass, in the order of the first repeat's frames.
    pub passes_ms: Vec<PassStat>,
    pub warmup: Option<u32>,
    pub measured_frames: Option<u32>,
    pub on_cpu: Option<bool>,
    /// The first error of a failed repeat; the statistics cover the repeats that finished.
    pub error: Option<String>,
}

impl Cell {
    /// Folds the finished repeats (`runs`, repeat order) and the first error, if any.
    pub fn from_runs(scene: &str, tier: &str, runs: &[CellRun], error: Option<String>) -> Self {
        let stat = |f: &dyn Fn(&CellRun) -> Option<f64>| {
            let values: Vec<f64> = runs.iter().filter_map(f).collect();
            // A metric some repeats lack (gain without a direct error) is left out entirely.
            if values.len() == runs.len() {
                Stat::of(values)
            } else {
                None
            }
        };
        let mut passes_ms = Vec::new();
        if let Some(first) = runs.first() {
            for (name, _) in &first.passes_ms {
                let values: Vec<f64> = runs
                    .iter()
                    .filter_map(|run| run.passes_ms.iter().find(|(n, _)| n == name))
                    .map(|(_, ms)| *ms)
                    .collect();
                if let Some(ms) = Stat::of(values) {
                    passes_ms.push(PassStat {
                        name: name.clone(),
                        ms,
                    });
                }
            }
        }
        Self {
            scene: scene.to_owned(),
            tier: tier.to_owned(),
            repeats: runs.len() as u32,
            rmse_srgb8: stat(&|r| Some(r.rmse_srgb8)),
            flip: stat(&|r| Some(r.flip)),
            rmse_linear: stat(&|r| Some(r.rmse_linear)),
            gain_vs_direct: stat(&|r| r.gain_vs_direct),
            ms_per_frame: stat(&|r| Some(r.ms_per_frame)),
            gi_ms: stat(&|r| r.gi_ms),
            memory_bytes: stat(&|r| Some(r.memory_bytes as f64)),
            passes_ms,
            warmup: runs.first().map(|r| r.warmup),
            measured_frames: runs.first().map(|r| r.measured_frames),
            on_cpu: runs.first().map(|r| r.on_cpu),
            error,
        }
    }

    /// True when every repeat finished.
    pub fn is_complete(&self) -> bool {
        self.error.is_none()
    }
}

/// A scene or cell that failed.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Failure {
    pub scene: String,
    /// Null when the whole scene failed (its process, scene load or reference).
    pub tier: Option<String>,
    pub error: String,
}

/// Median of `values` (the mean of the middle two for an even count); 0 for none.
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    match sorted.len() {
        0 => 0.0,
        n if n % 2 == 1 => sorted[mid],
        _ => 0.5 * (sorted[mid - 1] + sorted[mid]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(rmse: f64, ms: f64, gain: Option<f64>) -> CellRun {
        CellRun {
            rmse_srgb8: rmse,
            flip: rmse / 255.0,
            rmse_linear: rmse / 100.0,
            gain_vs_direct: gain,
            ms_per_frame: ms,
            gi_ms: None,
            passes_ms: vec![("a/x".into(), ms / 2.0), ("b/y".into(), ms / 2.0)],
            memory_bytes: 1000,
            warmup: 3,
            measured_frames: 4,
            on_cpu: false,
        }
    }

    #[test]
    fn stat_has_the_sample_standard_deviation() {
        let stat = Stat::of(vec![2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]).unwrap();
        assert_eq!(stat.mean, 5.0);
        // Sum of squares 32 over n - 1 = 7.
        assert!((stat.sd.unwrap() - (32.0f64 / 7.0).sqrt()).abs() < 1e-12);
        assert_eq!(Stat::of(vec![3.0]).unwrap().sd, None);
        assert_eq!(Stat::of(vec![]), None);
    }

    #[test]
    fn cell_folds_repeats_and_drops_metrics_some_repeats_lack() {
        let runs = [run(10.0, 2.0, Some(0.5)), run(12.0, 4.0, None)];
        let cell = Cell::from_runs("s", "t", &runs, None);
        assert_eq!(cell.repeats, 2);
        assert_eq!(cell.rmse_srgb8.as_ref().unwrap().mean, 11.0);
        assert_eq!(
            cell.flip.as_ref().unwrap().values,
            vec![10.0 / 255.0, 12.0 / 255.0]
        );
        assert_eq!(cell.ms_per_frame.as_ref().unwrap().values, vec![2.0, 4.0]);
        assert!(cell.gain_vs_direct.is_none());
        assert!(cell.gi_ms.is_none());
        assert_eq!(cell.memory_bytes.as_ref().unwrap().sd, Some(0.0));
        let names: Vec<&str> = cell.passes_ms.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["a/x", "b/y"]);
        assert_eq!(cell.passes_ms[0].ms.mean, 1.5);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }
}

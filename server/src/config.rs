//! The service's configuration: command-line flags, each with an environment variable and a
//! safe default.

use std::{net::SocketAddr, path::PathBuf};

use clap::Parser;
use gi_reference::engine::EngineChoice;

/// Queued render jobs over HTTP: every GI tier, its error against the path-traced reference,
/// and a web page to submit and inspect them.
#[derive(Clone, Debug, Parser)]
#[command(name = "gi-server", version, about, long_about = None)]
pub struct Config {
    /// Address to listen on. The default serves this machine only; put a proxy with
    /// authentication in front before binding a public address (the service has none).
    #[arg(long, env = "GI_SERVER_BIND", default_value = "127.0.0.1:8080")]
    pub bind: SocketAddr,

    /// Folder holding jobs, their images and uploaded scenes. Everything the service
    /// accepted lives here, so a restart (or a crash) loses nothing.
    #[arg(long, env = "GI_SERVER_DATA_DIR", default_value = "gi-server-data")]
    pub data_dir: PathBuf,

    /// Extra folders of scenes (`<name>.gltf` or `<name>.glb`) that jobs may name, besides the
    /// bundled scenes (`$GI_SCENES_DIR` or the source tree's `scenes/`). Repeat the flag or
    /// separate folders with commas.
    #[arg(
        long = "scene-dir",
        env = "GI_SERVER_SCENE_DIRS",
        value_delimiter = ','
    )]
    pub scene_dirs: Vec<PathBuf>,

    /// Reference cache folder, shared with `gi compare` (default: $GI_CACHE_DIR,
    /// $XDG_CACHE_HOME/gi or ~/.cache/gi).
    #[arg(long, env = "GI_CACHE_DIR")]
    pub cache_dir: Option<PathBuf>,

    /// Largest image width a job may ask for. Time and memory grow with the pixel count.
    #[arg(long, env = "GI_SERVER_MAX_WIDTH", default_value_t = 3840)]
    pub max_width: u32,

    /// Largest image height a job may ask for.
    #[arg(long, env = "GI_SERVER_MAX_HEIGHT", default_value_t = 2160)]
    pub max_height: u32,

    /// Most frames (warm-up plus measured) one job may render. Each frame of a temporal tier
    /// costs a whole frame of GPU time.
    #[arg(long, env = "GI_SERVER_MAX_FRAMES", default_value_t = 256)]
    pub max_frames: u32,

    /// Most samples per pixel a job may ask for, for its tier and for its reference. Time
    /// grows linearly with it.
    #[arg(long, env = "GI_SERVER_MAX_SPP", default_value_t = 4096)]
    pub max_spp: u32,

    /// Samples per pixel of the reference when a job compares and does not say.
    #[arg(long, env = "GI_SERVER_REFERENCE_SPP", default_value_t = gi_reference::cache::DEFAULT_REFERENCE_SPP)]
    pub reference_spp: u32,

    /// What renders the references of comparisons: auto (the GPU path tier on a hardware
    /// GPU, many times faster, else the CPU path tracer; a cached reference of either
    /// serves), gpu (the GPU path tier on any Vulkan adapter, a software one too) or cpu. An
    /// explicit choice serves only cached references its own engine made.
    #[arg(long, env = "GI_SERVER_REFERENCE_ENGINE", default_value_t = EngineChoice::Auto)]
    pub reference_engine: EngineChoice,

    /// Largest accepted scene upload in bytes.
    #[arg(long, env = "GI_SERVER_MAX_UPLOAD_BYTES", default_value_t = 64 << 20)]
    pub max_upload_bytes: usize,

    /// Most texels in all the PNG textures of an uploaded scene, checked from their headers
    /// before anything is decoded: each texel takes about 36 bytes while the scene loads.
    #[arg(long, env = "GI_SERVER_MAX_UPLOAD_TEXELS", default_value_t = 1 << 24)]
    pub max_upload_texels: u64,

    /// Most jobs waiting to run; a submission beyond it is answered 429 with Retry-After.
    #[arg(long, env = "GI_SERVER_MAX_QUEUE", default_value_t = 64)]
    pub max_queue: usize,

    /// Most jobs kept (finished ones included); a submission beyond it is answered 429 until
    /// jobs are deleted from the data folder. Bounds the disk the service can fill.
    #[arg(long, env = "GI_SERVER_MAX_JOBS", default_value_t = 100_000)]
    pub max_jobs: usize,

    /// CPU renders (the reference tier, and references and direct-only images of comparisons)
    /// running at once. Each already uses every core, so more only helps small renders
    /// overlap their serial parts.
    #[arg(long, env = "GI_SERVER_REFERENCE_POOL", default_value_t = 2)]
    pub reference_pool: usize,

    /// How often a job interrupted by a crash or restart runs again before it fails (so a
    /// job that crashes the process cannot crash it forever).
    #[arg(long, env = "GI_SERVER_MAX_ATTEMPTS", default_value_t = 3)]
    pub max_attempts: u32,

    /// Seconds a shutdown (SIGTERM, Ctrl-C) waits for running jobs to stop at their next
    /// frame or pass; a job still running after it runs again after the restart.
    #[arg(long, env = "GI_SERVER_SHUTDOWN_GRACE_S", default_value_t = 30)]
    pub shutdown_grace_s: u64,

    /// Run without a GPU even if one exists: GPU tiers answer an error, `auto` and `direct`
    /// render on the CPU.
    #[arg(long, env = "GI_SERVER_NO_GPU")]
    pub no_gpu: bool,
}

impl Config {
    /// The defaults, with data in `data_dir`: what tests and embedders start from.
    pub fn with_data_dir(data_dir: impl Into<PathBuf>) -> Self {
        let mut config = Self::parse_from(["gi-server"]);
        config.data_dir = data_dir.into();
        config
    }

    /// Checks the settings that could make the service unusable.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("--max-width", self.max_width as usize),
            ("--max-height", self.max_height as usize),
            ("--max-frames", self.max_frames as usize),
            ("--max-spp", self.max_spp as usize),
            ("--reference-spp", self.reference_spp as usize),
            ("--max-queue", self.max_queue),
            ("--max-jobs", self.max_jobs),
            ("--reference-pool", self.reference_pool),
            ("--max-attempts", self.max_attempts as usize),
        ];
        for (name, value) in positive {
            if value == 0 {
                return Err(format!("{name} must be at least 1"));
            }
        }
        if self.max_width > gi_reference::MAX_SIDE || self.max_height > gi_reference::MAX_SIDE {
            return Err(format!(
                "--max-width and --max-height must be at most {}",
                gi_reference::MAX_SIDE
            ));
        }
        if u64::from(self.max_width) * u64::from(self.max_height) > gi_reference::MAX_PIXELS {
            return Err(format!(
                "--max-width x --max-height must be at most {} pixels",
                gi_reference::MAX_PIXELS
            ));
        }
        if self.reference_spp > self.max_spp {
            return Err("--reference-spp must not exceed --max-spp".to_string());
        }
        if self.no_gpu && self.reference_engine == EngineChoice::Gpu {
            return Err("--reference-engine gpu needs a GPU, and --no-gpu forbids one".to_string());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_engine_parses_and_gpu_needs_a_gpu() {
        assert_eq!(
            Config::parse_from(["gi-server"]).reference_engine,
            EngineChoice::Auto
        );
        let mut config =
            Config::try_parse_from(["gi-server", "--reference-engine", "gpu"]).unwrap();
        assert_eq!(config.reference_engine, EngineChoice::Gpu);
        assert_eq!(config.validate(), Ok(()));
        config.no_gpu = true;
        let refused = config.validate().unwrap_err();
        assert!(refused.contains("--no-gpu"), "{refused}");
        let err = Config::try_parse_from(["gi-server", "--reference-engine", "vulkan"])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("vulkan") && err.contains("auto, gpu or cpu"),
            "{err}"
        );
    }
}

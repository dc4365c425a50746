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
    /// Address to listen on. The default serves this machine only; any other address needs
    /// `--api-token` (or `--insecure-no-auth`), and a public one TLS from a proxy in front.
    #[arg(long, env = "GI_SERVER_BIND", default_value = "127.0.0.1:8080")]
    pub bind: SocketAddr,

    /// Scale-out mode: the PostgreSQL database holding the job queue
    /// (`postgres://user:password@host:5432/database`). With it (and `--store-url`) this
    /// process serves the API only and `gi-worker` processes render; without it everything
    /// runs in this process over `--data-dir`.
    #[arg(long, env = "GI_SERVER_DATABASE_URL", requires = "store_url")]
    pub database_url: Option<String>,

    /// Scale-out mode: the object store holding results and uploaded scenes, shared with the
    /// workers: a folder every machine mounts (`file:///srv/gi-store` or a plain path) or,
    /// built with the `s3` feature, `s3://bucket/prefix`.
    #[arg(long, env = "GI_SERVER_STORE_URL", requires = "database_url")]
    pub store_url: Option<String>,

    /// Scale-out mode: seconds a worker holds a job without a heartbeat before the job goes
    /// back to the queue (its worker is taken for dead). Workers beat every third of it.
    #[arg(long, env = "GI_SERVER_LEASE_S", default_value_t = 30)]
    pub lease_s: u64,

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

    /// Most texels in all the images of an uploaded scene (PNG, JPEG or DDS, wherever they
    /// are stored), read from their headers before any is decoded: each texel takes about 36
    /// bytes while the scene loads. An image whose header does not read is refused too.
    #[arg(long, env = "GI_SERVER_MAX_UPLOAD_TEXELS", default_value_t = 1 << 24)]
    pub max_upload_texels: u64,

    /// Bytes kept free on the data folder's disk: below it `/healthz` answers 503 and new
    /// jobs and uploads are refused with 507, before a write fails halfway. A job stores a
    /// few megabytes of images (a 4K EXR about 130 MB); higher leaves more room for the jobs
    /// already running and the rest of the machine, lower uses more of the disk.
    #[arg(long, env = "GI_SERVER_MIN_FREE_BYTES", default_value_t = 64 << 20)]
    pub min_free_bytes: u64,

    /// Most jobs waiting to run; a submission beyond it is answered 429 with Retry-After.
    #[arg(long, env = "GI_SERVER_MAX_QUEUE", default_value_t = 64)]
    pub max_queue: usize,

    /// Most jobs kept (finished ones included); a submission beyond it is answered 429 until
    /// finished jobs are deleted (`DELETE /v1/jobs/{id}`).
    #[arg(long, env = "GI_SERVER_MAX_JOBS", default_value_t = 100_000)]
    pub max_jobs: usize,

    /// Most bytes the data folder may hold (job records and images, uploaded scenes, cached
    /// references): at or past it new jobs and uploads are answered 507 until finished jobs
    /// or uploaded scenes are deleted. The folder's size is measured at most about a second
    /// before, and jobs already accepted still store their images, so it can be passed by
    /// what the running jobs write. 0: no quota (`--min-free-bytes` still applies).
    #[arg(long, env = "GI_SERVER_MAX_STORED_BYTES", default_value_t = 0)]
    pub max_stored_bytes: u64,

    /// Most pixel samples one job may cost, estimated at submission: width x height x
    /// (spp x frames, warm-up included, for the path, reference and direct tiers; one per
    /// pixel and frame for the real-time tiers and auto), plus width x height x reference_spp
    /// for the comparison's reference. A job over it is refused (422 `job_too_costly`) with
    /// its estimate. The default, 2^36 (6.9e10), is a 3840x2160 frame at 8192 samples: about
    /// 3 minutes of the path tier on one H100, hours of the CPU reference.
    #[arg(long, env = "GI_SERVER_MAX_JOB_SAMPLES", default_value_t = 1 << 36)]
    pub max_job_samples: u64,

    /// Seconds a job may run, from its start to its end (its render and its comparison): one
    /// still running then stops and fails (`time_limit`): at once, its process ended (with
    /// `--in-process` at its next frame or pass, once its scene's preparation and BVH build
    /// end). 0: no limit. In the scale-out mode it is stored with each job submitted here, and
    /// the job's worker applies the lower of it and its own.
    #[arg(long, env = "GI_SERVER_JOB_TIME_LIMIT_S", default_value_t = 3600)]
    pub job_time_limit_s: u64,

    /// Render every job inside the server. By default jobs render in job processes (one for
    /// the GPU lane, one for each CPU worker, kept from job to job; a GPU job's comparison in a
    /// CPU worker's): a cancellation, the time limit or a shutdown kills the job's process at
    /// once, inside its scene's import and BVH build too, and a crash fails only that job.
    #[arg(long, env = "GI_SERVER_IN_PROCESS")]
    pub in_process: bool,

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

    /// Bearer token every API route requires (`Authorization: Bearer <token>`); the web
    /// page's files and `/healthz` stay open. Prefer the environment variable or
    /// `--api-token-file`: a flag is visible to every user of the machine.
    #[arg(
        long,
        env = "GI_SERVER_API_TOKEN",
        hide_env_values = true,
        conflicts_with = "api_token_file"
    )]
    pub api_token: Option<ApiToken>,

    /// File holding the bearer token (surrounding whitespace ignored), read at start.
    #[arg(long, env = "GI_SERVER_API_TOKEN_FILE")]
    pub api_token_file: Option<PathBuf>,

    /// Serve a non-loopback `--bind` address without a token. Anyone who can reach the
    /// address can then queue renders and read every job.
    #[arg(long, env = "GI_SERVER_INSECURE_NO_AUTH")]
    pub insecure_no_auth: bool,

    /// Host names (`name` for any port, or `name:port`) requests may carry in their `Host`
    /// header besides the address they reached (and `localhost` on loopback); `*` allows any.
    /// Others are answered 421, which defeats DNS rebinding. Repeat or separate with commas.
    #[arg(long, env = "GI_SERVER_ALLOWED_HOSTS", value_delimiter = ',')]
    pub allowed_hosts: Vec<String>,

    /// Most connections open at once. A connection past it takes the place of the open one
    /// idle the longest (no request running), or is answered 503 and closed when every one
    /// is busy. Keep it below the open-file limit (`ulimit -n`).
    #[arg(long, env = "GI_SERVER_MAX_CONNECTIONS", default_value_t = 512)]
    pub max_connections: usize,

    /// Seconds a client has to send a whole request head (request line and headers), from
    /// the moment the connection opens or its previous answer was sent; then it is closed.
    /// Longer tolerates slower links, shorter frees stalled connections sooner.
    #[arg(long, env = "GI_SERVER_HEADER_READ_TIMEOUT_S", default_value_t = 10.0)]
    pub header_read_timeout_s: f64,

    /// Seconds a connection may stay silent while no request of it runs (kept alive between
    /// requests, or partway through a request head) and the longest pause in a request body;
    /// then it is closed. At most `--header-read-timeout-s`, which also bounds the wait for
    /// the next request. Longer saves clients reconnecting, shorter holds fewer idle sockets.
    #[arg(long, env = "GI_SERVER_IDLE_TIMEOUT_S", default_value_t = 5.0)]
    pub idle_timeout_s: f64,
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
            ("--max-connections", self.max_connections),
        ];
        for (name, value) in positive {
            if value == 0 {
                return Err(format!("{name} must be at least 1"));
            }
        }
        if self.lease_s < 3 {
            return Err("--lease-s must be at least 3".to_string());
        }
        if self.max_job_samples == 0 {
            return Err("--max-job-samples must be at least 1".to_string());
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
        for (name, seconds) in [
            ("--header-read-timeout-s", self.header_read_timeout_s),
            ("--idle-timeout-s", self.idle_timeout_s),
        ] {
            if !(seconds > 0.0 && seconds <= MAX_TIMEOUT_S) {
                return Err(format!(
                    "{name} must be above 0 and at most {MAX_TIMEOUT_S}"
                ));
            }
        }
        if self.idle_timeout_s > self.header_read_timeout_s {
            return Err(
                "--idle-timeout-s must not exceed --header-read-timeout-s (which also \
                 bounds the wait for the next request)"
                    .to_string(),
            );
        }
        let has_token = self.api_token.is_some() || self.api_token_file.is_some();
        if !self.bind.ip().is_loopback() && !has_token && !self.insecure_no_auth {
            return Err(format!(
                "--bind {} is reachable from other machines and no API token is set: set \
                 GI_SERVER_API_TOKEN (or --api-token-file), or pass --insecure-no-auth to \
                 serve it without authentication",
                self.bind
            ));
        }
        Ok(())
    }

    /// The bearer token API routes require: `--api-token`, or the contents of
    /// `--api-token-file` (read now), or none.
    pub fn resolve_api_token(&self) -> Result<Option<ApiToken>, String> {
        if let Some(token) = &self.api_token {
            return Ok(Some(token.clone()));
        }
        let Some(path) = &self.api_token_file else {
            return Ok(None);
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("--api-token-file {}: {e}", path.display()))?;
        text.parse()
            .map(Some)
            .map_err(|e| format!("--api-token-file {}: {e}", path.display()))
    }
}

/// Longest accepted connection timeout: a day (anything longer is a mistake).
const MAX_TIMEOUT_S: f64 = 86_400.0;

/// A bearer token: never printed, compared in constant time.
#[derive(Clone)]
pub struct ApiToken(String);

impl ApiToken {
    /// True when `presented` is the token. Both sides are hashed first, so the time taken
    /// depends on neither the token's length nor where the first difference is.
    pub fn matches(&self, presented: &str) -> bool {
        use sha2::{Digest, Sha256};
        let (expected, presented) = (Sha256::digest(&self.0), Sha256::digest(presented));
        expected
            .iter()
            .zip(presented.iter())
            .fold(0u8, |difference, (a, b)| difference | (a ^ b))
            == 0
    }
}

impl std::str::FromStr for ApiToken {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let token = text.trim();
        if token.is_empty() {
            return Err("the API token is empty".to_string());
        }
        // What an `Authorization` header can carry after `Bearer `.
        if !token.bytes().all(|b| b.is_ascii_graphic()) {
            return Err("the API token must be printable ASCII without spaces".to_string());
        }
        Ok(Self(token.to_string()))
    }
}

impl std::fmt::Debug for ApiToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ApiToken(<redacted>)")
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

    #[test]
    fn tokens_match_exactly_and_other_addresses_need_one() {
        let token: ApiToken = " s3cret-token\n".parse().unwrap();
        assert!(token.matches("s3cret-token"));
        for wrong in ["", "s3cret-toke", "s3cret-token2", "S3cret-token"] {
            assert!(!token.matches(wrong), "{wrong:?}");
        }
        assert!(!format!("{token:?}").contains("s3cret"));
        assert!("two words".parse::<ApiToken>().is_err());
        assert!("  ".parse::<ApiToken>().is_err());

        let public = ["gi-server", "--bind", "0.0.0.0:8080"];
        let refused = Config::parse_from(public).validate().unwrap_err();
        assert!(
            refused.contains("GI_SERVER_API_TOKEN") && refused.contains("--insecure-no-auth"),
            "{refused}"
        );
        let with_token = Config::parse_from([&public[..], &["--api-token", "t"]].concat());
        assert_eq!(with_token.validate(), Ok(()));
        let insecure = Config::parse_from([&public[..], &["--insecure-no-auth"]].concat());
        assert_eq!(insecure.validate(), Ok(()));
        let loopback = Config::parse_from(["gi-server", "--bind", "[::1]:8080"]);
        assert_eq!(loopback.validate(), Ok(()));
    }
}

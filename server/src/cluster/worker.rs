//! `gi-worker`: takes jobs from the scale-out service's queue and renders them, one at a time,
//! on this machine's GPU (or its CPU, for the tiers that run there). Run one per GPU, on any
//! number of machines, all with the same `--database-url`, `--store-url` and scene folders.
//!
//! A job's life on a worker: taken from the queue (highest priority first), its scene
//! resolved (an upload fetched from the store), then rendered in a process of its own
//! ([`crate::job_process`]): its tier rendered, compared with the reference when it asks to
//! be, its images written; the worker puts them in the store and stores the job's end. A
//! heartbeat renews the worker's hold on the job every third of the lease and brings back
//! whether the job is still the worker's to run: a job cancelled or deleted meanwhile has its
//! process ended. A worker that stops (SIGTERM) puts its job back in the queue, its start not
//! counted; one that dies leaves it to be put back once its lease runs out.
//!
//! Jobs render in processes of their own where the executable serves them
//! ([`crate::job_process::serve`], as `gi-worker` does) and `--in-process` is not set.

use std::{
    path::PathBuf,
    sync::{
        Arc, Mutex,
        atomic::{AtomicBool, Ordering},
    },
    time::{Duration, Instant},
};

use clap::Parser;
use gi_reference::{cache::ReferenceCache, engine::EngineChoice};
use gi_tiers::CancelCheck;

use super::{
    Scenes,
    objects::{Objects, job_key},
    queue::{Claimed, Lane, Queue},
};
use crate::{
    error::ApiError,
    job::{IMAGE_FILES, JobFailure, JobRecord, JobState, Progress, now_rfc3339},
    job_process::{self, JobHost, JobPart, JobTask},
    runner::{self, References},
    service::{GpuInfo, plan_for, requeue_stopped, with_lighting},
    store::Writer,
};

/// Takes render jobs from the service's queue (PostgreSQL) and puts their images in its
/// object store.
#[derive(Clone, Debug, Parser)]
#[command(name = "gi-worker", version, about, long_about = None)]
pub struct WorkerConfig {
    /// The job queue's database, as given to gi-server.
    #[arg(long, env = "GI_SERVER_DATABASE_URL")]
    pub database_url: String,

    /// The object store, as given to gi-server.
    #[arg(long, env = "GI_SERVER_STORE_URL")]
    pub store_url: String,

    /// This worker's name in the worker list and the logs (default: host name and process
    /// id). Two running workers must not share one.
    #[arg(long, env = "GI_WORKER_NAME")]
    pub name: Option<String>,

    /// Local folder for uploaded scenes fetched from the store.
    #[arg(long, env = "GI_WORKER_DIR", default_value = "gi-worker-data")]
    pub work_dir: PathBuf,

    /// Extra scene folders, as given to gi-server (the same scenes on every machine).
    #[arg(
        long = "scene-dir",
        env = "GI_SERVER_SCENE_DIRS",
        value_delimiter = ','
    )]
    pub scene_dirs: Vec<PathBuf>,

    /// Reference cache folder (default: $GI_CACHE_DIR, $XDG_CACHE_HOME/gi or ~/.cache/gi).
    #[arg(long, env = "GI_CACHE_DIR")]
    pub cache_dir: Option<PathBuf>,

    /// Where the references of comparisons are rendered: `auto` (the GPU path tier when a
    /// hardware GPU exists, else the CPU), `gpu` or `cpu`.
    #[arg(long, env = "GI_SERVER_REFERENCE_ENGINE", default_value = "auto")]
    pub reference_engine: EngineChoice,

    /// Take only jobs that run on the CPU, even if a GPU exists.
    #[arg(long, env = "GI_SERVER_NO_GPU")]
    pub no_gpu: bool,

    /// Seconds this worker holds a job without a heartbeat (as gi-server's `--lease-s`).
    #[arg(long, env = "GI_SERVER_LEASE_S", default_value_t = 30)]
    pub lease_s: u64,

    /// Starts of a job (its earlier workers lost) after which it fails instead of running.
    #[arg(long, env = "GI_SERVER_MAX_ATTEMPTS", default_value_t = 3)]
    pub max_attempts: u32,

    /// Seconds a job may run on this worker before it stops and fails (`time_limit`); 0: no
    /// limit. The API server's own `--job-time-limit-s` travels with each job, and the lower
    /// of the two applies.
    #[arg(long, env = "GI_SERVER_JOB_TIME_LIMIT_S", default_value_t = 3600)]
    pub job_time_limit_s: u64,

    /// Render jobs inside the worker instead of in its job process (kept from job to job,
    /// restarted after a job of it was stopped). A job then stops only between its frames and
    /// passes: a cancellation, the time limit or a shutdown waits for its scene's import and
    /// BVH builds; and a render that crashes ends the worker.
    #[arg(long, env = "GI_WORKER_IN_PROCESS")]
    pub in_process: bool,

    /// Milliseconds between looks at an empty queue.
    #[arg(long, env = "GI_WORKER_POLL_MS", default_value_t = 500)]
    pub poll_ms: u64,
}

impl WorkerConfig {
    fn validate(&self) -> Result<(), String> {
        if self.lease_s < 3 {
            return Err("--lease-s must be at least 3".to_string());
        }
        if self.max_attempts == 0 {
            return Err("--max-attempts must be at least 1".to_string());
        }
        if self.poll_ms == 0 || self.poll_ms > 60_000 {
            return Err("--poll-ms must be between 1 and 60000".to_string());
        }
        if self.no_gpu && self.reference_engine == EngineChoice::Gpu {
            return Err("--reference-engine gpu needs a GPU, and --no-gpu forbids one".to_string());
        }
        Ok(())
    }

    fn lease(&self) -> Duration {
        Duration::from_secs(self.lease_s)
    }
}

/// Connections a worker keeps to the database: its loop and its heartbeat.
const WORKER_CONNECTIONS: usize = 3;

/// The job a worker runs, as its heartbeat sees it.
struct Current {
    id: u64,
    progress: Option<Progress>,
    /// Set when the job is no longer this worker's (cancelled, deleted, or taken back).
    lost: Arc<AtomicBool>,
    /// When the lease held now was last renewed, at the latest (taken before the database
    /// was asked): once a lease has passed since, the job may have gone back to the queue.
    renewed: Instant,
}

struct Worker {
    config: WorkerConfig,
    name: String,
    queue: Queue,
    objects: Objects,
    scenes: Scenes,
    gpu: Option<GpuInfo>,
    references: References,
    /// The reference cache's folder (job processes open it themselves).
    cache_dir: PathBuf,
    current: Mutex<Option<Current>>,
    stopping: AtomicBool,
}

/// Runs a worker until `shutdown` completes; then the job it runs stops at its next frame or
/// pass and goes back to the queue.
pub async fn run(
    config: WorkerConfig,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    config.validate().map_err(anyhow::Error::msg)?;
    let name = config
        .name
        .clone()
        .unwrap_or_else(|| format!("{}-{}", host_name(), std::process::id()));
    let gpu = if config.no_gpu {
        None
    } else {
        tokio::task::spawn_blocking(crate::probe_gpu).await?
    };
    let choice = config.reference_engine;
    let no_gpu = config.no_gpu;
    let engine = tokio::task::spawn_blocking(move || {
        if no_gpu {
            return Ok(Arc::new(gi_reference::engine::CpuEngine)
                as Arc<dyn gi_reference::engine::ReferenceEngine>);
        }
        gi_tiers::reference_engine(choice)
    })
    .await?
    .map_err(|e| anyhow::anyhow!("--reference-engine {choice}: {e}"))?;
    let queue = Queue::connect(&config.database_url, WORKER_CONNECTIONS).await?;
    let objects = Objects::open(&config.store_url)?;
    let scenes = Scenes::new(
        &config.scene_dirs,
        config.work_dir.join("scenes"),
        objects.clone(),
    );
    let cache_dir = (config.cache_dir.clone()).unwrap_or_else(gi_reference::cache::default_dir);
    let worker = Arc::new(Worker {
        references: References::new(
            ReferenceCache::new(cache_dir.clone()).with_engine(engine, choice),
        ),
        cache_dir,
        name,
        queue,
        objects,
        scenes,
        gpu,
        current: Mutex::new(None),
        stopping: AtomicBool::new(false),
        config,
    });
    let gpu_name = worker.gpu.as_ref().map(|g| g.name.as_str());
    worker
        .queue
        .register_worker(&worker.name, gpu_name)
        .await
        .map_err(|e| anyhow::anyhow!(e.message))?;
    tracing::info!(
        worker = %worker.name,
        gpu = gpu_name.unwrap_or("none"),
        "taking jobs"
    );
    let beating = tokio::spawn(worker.clone().heartbeat());
    let stopper = worker.clone();
    tokio::spawn(async move {
        shutdown.await;
        tracing::info!("stopping: the running job goes back to the queue");
        stopper.stopping.store(true, Ordering::SeqCst);
    });
    worker.clone().take_jobs().await;
    beating.abort();
    if let Err(error) = worker.queue.unregister_worker(&worker.name).await {
        tracing::warn!("{}", error.message);
    }
    Ok(())
}

fn host_name() -> String {
    std::fs::read_to_string("/etc/hostname")
        .ok()
        .map(|name| name.trim().to_string())
        .filter(|name| !name.is_empty())
        .unwrap_or_else(|| "worker".to_string())
}

fn past(deadline: Option<Instant>) -> bool {
    deadline.is_some_and(|d| Instant::now() >= d)
}

impl Worker {
    fn lock_current(&self) -> std::sync::MutexGuard<'_, Option<Current>> {
        self.current.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn is_stopping(&self) -> bool {
        self.stopping.load(Ordering::SeqCst)
    }

    /// Every third of the lease: this worker is alive, holds its job, and how far the job
    /// is; and the jobs of lost workers go back to the queue.
    async fn heartbeat(self: Arc<Self>) {
        let every = self.config.lease() / 3;
        loop {
            let (job, progress, lost) = match self.lock_current().as_ref() {
                Some(current) => (
                    Some(current.id),
                    current
                        .progress
                        .as_ref()
                        .and_then(|p| serde_json::to_value(p).ok()),
                    Some(current.lost.clone()),
                ),
                None => (None, None, None),
            };
            let asked = Instant::now();
            match self
                .queue
                .heartbeat(&self.name, job, self.config.lease(), progress)
                .await
            {
                Ok(true) => {
                    if let Some(current) = self.lock_current().as_mut()
                        && Some(current.id) == job
                    {
                        current.renewed = asked;
                    }
                }
                Ok(false) => {
                    if let Some(lost) = lost {
                        tracing::info!(
                            job = job.unwrap_or(0),
                            "the job was cancelled or taken back; stopping it"
                        );
                        lost.store(true, Ordering::SeqCst);
                    }
                }
                Err(error) => tracing::warn!("{}", error.message),
            }
            if let Err(error) = self.queue.requeue_expired().await {
                tracing::warn!("{}", error.message);
            }
            tokio::time::sleep(every).await;
        }
    }

    /// Takes and runs jobs until the worker stops.
    async fn take_jobs(self: Arc<Self>) {
        let lanes: &[Lane] = if self.gpu.is_some() {
            &[Lane::Gpu, Lane::Any]
        } else {
            &[Lane::Any]
        };
        let poll = Duration::from_millis(self.config.poll_ms);
        let mut host = JobHost::default();
        while !self.is_stopping() {
            let asked = Instant::now();
            let claimed = self
                .queue
                .claim(
                    &self.name,
                    lanes,
                    self.config.lease(),
                    self.config.max_attempts,
                )
                .await;
            match claimed {
                Ok(Some(Claimed {
                    record,
                    time_limit_s,
                })) => {
                    (self.clone())
                        .run_job(record, asked, time_limit_s, &mut host)
                        .await
                }
                Ok(None) => tokio::time::sleep(poll).await,
                Err(error) => {
                    tracing::warn!("{}", error.message);
                    tokio::time::sleep(poll * 4).await;
                }
            }
        }
    }

    /// Whether the lease on the current job may have run out: no heartbeat got through for a
    /// lease (the database is unreachable, or too slow). The job may then be queued again and
    /// taken by another worker, so this one stops it instead of rendering it twice.
    fn lease_lapsed(&self) -> bool {
        let lapsed = self
            .lock_current()
            .as_ref()
            .is_some_and(|current| current.renewed.elapsed() >= self.config.lease());
        if lapsed {
            tracing::warn!(
                "no heartbeat got through for {} s (--lease-s): the job may have gone back to \
                 the queue; stopping it",
                self.config.lease_s
            );
        }
        lapsed
    }

    /// Runs a job this worker took (`claimed` before it asked for it) and stores its end. It
    /// may run the lower of this worker's time limit and `job_limit_s`, its API server's.
    async fn run_job(
        self: Arc<Self>,
        mut record: JobRecord,
        claimed: Instant,
        job_limit_s: Option<u64>,
        host: &mut JobHost,
    ) {
        let id = record.id;
        let lost = Arc::new(AtomicBool::new(false));
        *self.lock_current() = Some(Current {
            id,
            progress: None,
            lost: lost.clone(),
            renewed: claimed,
        });
        tracing::info!(job = id, scene = %record.spec.scene, tier = %record.spec.tier, "running");
        let own = Some(self.config.job_time_limit_s).filter(|&s| s > 0);
        let limit = [
            own.map(|s| (s, "this worker's")),
            job_limit_s.map(|s| (s, "the service's")),
        ]
        .into_iter()
        .flatten()
        .min_by_key(|&(seconds, _)| seconds);
        let deadline = limit.map(|(seconds, _)| Instant::now() + Duration::from_secs(seconds));
        let started = Instant::now();
        let outcome = (self.clone())
            .render(&record, lost.clone(), deadline, host)
            .await;
        *self.lock_current() = None;
        match outcome {
            Ok(Some(result)) => {
                record.result = Some(result);
                record.state = JobState::Done;
                record.finished_at = Some(now_rfc3339());
            }
            Ok(None) if lost.load(Ordering::SeqCst) => {
                // No longer this worker's: whoever changed it owns its record.
                let _ = self.objects.delete_folder(&format!("jobs/{id}")).await;
                return;
            }
            Ok(None) if past(deadline) => {
                let (seconds, whose) = limit.unwrap_or_default();
                fail(
                    &mut record,
                    "time_limit",
                    format!(
                        "the job ran longer than {whose} limit of {seconds} s \
                         (--job-time-limit-s)"
                    ),
                );
            }
            Ok(None) => {
                // The worker is stopping: the job runs again elsewhere, this start not
                // counted.
                requeue_stopped(&mut record);
            }
            Err(error) => fail(&mut record, &error.code, error.message),
        }
        let state = record.state;
        // The end is stored until it is (or the job is found no longer this worker's): a
        // finished render is not thrown away for a database that blinked.
        loop {
            match self.queue.finish(&self.name, &record).await {
                Ok(true) => break,
                Ok(false) => {
                    tracing::info!(job = id, "the job was cancelled or taken back meanwhile");
                    let _ = self.objects.delete_folder(&format!("jobs/{id}")).await;
                    return;
                }
                Err(error) => {
                    tracing::warn!(job = id, "{}; retrying", error.message);
                    tokio::time::sleep(Duration::from_secs(1)).await;
                }
            }
        }
        tracing::info!(
            job = id,
            state = state.name(),
            seconds = started.elapsed().as_secs_f64(),
            "ended"
        );
    }

    fn set_progress(&self, progress: Progress) {
        if let Some(current) = self.lock_current().as_mut() {
            current.progress = Some(progress);
        }
    }

    /// Renders job `record` (and compares it), puts its images in the store and answers its
    /// result; `None` when it stopped (lost, stopping, or past its deadline).
    async fn render(
        self: Arc<Self>,
        record: &JobRecord,
        lost: Arc<AtomicBool>,
        deadline: Option<Instant>,
        host: &mut JobHost,
    ) -> Result<Option<crate::job::JobResult>, JobFailure> {
        let spec = &record.spec;
        let (plan, _) = plan_for(spec, self.gpu.as_ref(), self.config.no_gpu)?;
        let stop = {
            let worker = self.clone();
            move || {
                if !lost.load(Ordering::SeqCst) && worker.lease_lapsed() {
                    lost.store(true, Ordering::SeqCst);
                }
                lost.load(Ordering::SeqCst) || worker.is_stopping() || past(deadline)
            }
        };
        self.set_progress(job_process::preparing());
        if self.config.in_process {
            return Ok(self
                .clone()
                .render_here(record, plan, Arc::new(stop))
                .await?);
        }
        let dir = self
            .config
            .work_dir
            .join("jobs")
            .join(record.id.to_string());
        let task = JobTask {
            id: record.id,
            spec: spec.clone(),
            scene: self.scenes.resolve(&spec.scene).await?,
            plan,
            gpu_name: self.gpu.as_ref().map(|g| g.name.clone()),
            reference_engine: self.config.reference_engine,
            no_gpu: self.config.no_gpu,
            cache_dir: self.cache_dir.clone(),
            out_dir: dir.clone(),
            part: JobPart::Whole,
        };
        let rendered = host.run(&task, |p| self.set_progress(p), stop).await;
        let stored = match &rendered {
            Ok(Some(_)) => self.put_images(record.id, &dir).await,
            _ => Ok(()),
        };
        let _ = tokio::fs::remove_dir_all(&dir).await;
        stored?;
        rendered
    }

    /// Renders job `record` in this process ([`WorkerConfig::in_process`]).
    async fn render_here(
        self: Arc<Self>,
        record: &JobRecord,
        plan: runner::TierPlan,
        stop: CancelCheck,
    ) -> Result<Option<crate::job::JobResult>, ApiError> {
        let spec = record.spec.clone();
        let scene = with_lighting(self.scenes.load(&spec.scene).await?, &spec)?;
        let gpu_name = self.gpu.as_ref().map(|g| g.name.clone());
        let prepare_spec = spec.clone();
        let job = Arc::new(
            tokio::task::spawn_blocking(move || {
                runner::prepare(scene, &prepare_spec, plan, gpu_name)
            })
            .await
            .map_err(|e| ApiError::internal(e.to_string()))??,
        );
        let worker = self.clone();
        let rendering = job.clone();
        let stop_render = stop.clone();
        let share = if spec.compare { 0.5 } else { 1.0 };
        let rendered = tokio::task::spawn_blocking(move || {
            runner::render_tier(&rendering, &|p| worker.set_progress(p), stop_render, share)
        })
        .await
        .map_err(|e| ApiError::internal(format!("the render failed unexpectedly: {e}")))?
        .map_err(|message| ApiError::invalid("render_failed", message))?;
        let Some(output) = rendered else {
            return Ok(None);
        };
        let (output, compared) = match spec.reference_spp {
            None => (output, None),
            Some(reference_spp) => {
                let worker = self.clone();
                let comparing = job.clone();
                let stop_compare = stop.clone();
                let (mut output, compared) = tokio::task::spawn_blocking(move || {
                    let compared = runner::compare(
                        &comparing,
                        &output,
                        reference_spp,
                        &worker.references,
                        &|p| worker.set_progress(p),
                        &|| stop_compare(),
                        0.5,
                    );
                    (output, compared)
                })
                .await
                .map_err(|e| {
                    ApiError::internal(format!("the comparison failed unexpectedly: {e}"))
                })?;
                let compared =
                    compared.map_err(|message| ApiError::invalid("compare_failed", message))?;
                let Some(compared) = compared else {
                    return Ok(None);
                };
                output.result.comparison = Some(compared.comparison);
                (output, Some((compared.reference, compared.flip)))
            }
        };
        let result = output.result.clone();
        self.store_images(record.id, job.scene.exposure, output.image, compared)
            .await?;
        Ok(Some(result))
    }

    /// Encodes the images (in a local folder, as the embedded service writes them) and puts
    /// them in the store under `jobs/<id>/`.
    async fn store_images(
        &self,
        id: u64,
        exposure: f32,
        image: gi_image::Image,
        compared: Option<(gi_image::Image, gi_image::Flip)>,
    ) -> Result<(), ApiError> {
        let dir = self.config.work_dir.join("jobs").join(id.to_string());
        let local = dir.clone();
        let written = tokio::task::spawn_blocking(move || {
            let compared = compared.as_ref().map(|(reference, flip)| (reference, flip));
            runner::write_images(&Writer::default(), &local, exposure, &image, compared)
        })
        .await
        .map_err(|e| ApiError::internal(e.to_string()))?
        .map_err(|e| ApiError::storage("the images", &e));
        let stored = match written {
            Ok(()) => self.put_images(id, &dir).await,
            Err(error) => Err(error),
        };
        let _ = tokio::fs::remove_dir_all(&dir).await;
        stored
    }

    /// Puts the images of job `id` found in local folder `dir` in the store.
    async fn put_images(&self, id: u64, dir: &std::path::Path) -> Result<(), ApiError> {
        for file in IMAGE_FILES {
            match tokio::fs::read(dir.join(file)).await {
                Ok(bytes) => self.objects.put(&job_key(id, file), bytes).await?,
                Err(error) if error.kind() == std::io::ErrorKind::NotFound => {}
                Err(error) => return Err(ApiError::storage("the images", &error)),
            }
        }
        Ok(())
    }
}

fn fail(record: &mut JobRecord, code: &str, message: String) {
    record.state = JobState::Failed;
    record.finished_at = Some(now_rfc3339());
    record.failure = Some(JobFailure {
        code: code.to_string(),
        message,
    });
}

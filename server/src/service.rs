//! The job service: the job table, the queues, the GPU worker and the CPU pool, and the
//! persistence of every state change.
//!
//! A job is `queued` until a worker takes it; GPU tiers wait in one queue served by a single
//! GPU worker (jobs run one at a time), CPU renders in another served by a bounded pool. A job
//! that compares renders its tier first, then goes to the front of the CPU queue for the
//! reference, so the GPU worker never waits on a path tracer. Every state change is written to
//! the data folder before it is acknowledged.

use std::{
    collections::{BTreeMap, HashMap, VecDeque},
    sync::{
        Arc, Mutex, MutexGuard,
        atomic::{AtomicBool, Ordering},
    },
    time::Instant,
};

use gi_reference::cache::ReferenceCache;
use gi_reference::engine::ReferenceEngine;
use gi_scene::Scene;
use gi_tiers::{
    TierChoice, TierKind, TierSettings,
    select::{self, AdapterDescription, RunsOn},
};
use tokio::sync::Notify;

use crate::{
    config::Config,
    error::ApiError,
    job::{JobFailure, JobRecord, JobRequest, JobSpec, JobState, Progress, now_rfc3339},
    metrics::Metrics,
    runner::{self, PreparedJob, References, TierOutput, TierPlan},
    scenes::{SceneCatalog, SceneSource},
    store::Store,
};

/// The GPU the service found at startup.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GpuInfo {
    pub name: String,
    pub device_type: String,
    /// False for a software adapter (lavapipe), on which `direct` runs on the CPU.
    pub hardware: bool,
    /// What `auto` plans with ([`gi_tiers::select::plan`]).
    #[serde(skip)]
    pub adapter: AdapterDescription,
}

/// Which worker runs a job's tier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    Gpu,
    Cpu,
}

/// Work for the CPU pool.
enum CpuWork {
    /// Render a CPU tier.
    Render(u64),
    /// Compare a rendered tier image with the reference.
    Compare(Box<Comparing>),
}

struct Comparing {
    id: u64,
    job: Arc<PreparedJob>,
    output: TierOutput,
    reference_spp: u32,
}

struct Entry {
    record: JobRecord,
    progress: Option<Progress>,
    /// Set by a cancellation; a running render checks it between frames and passes.
    cancel: Arc<AtomicBool>,
}

#[derive(Default)]
struct Inner {
    jobs: BTreeMap<u64, Entry>,
    next_id: u64,
    gpu_queue: VecDeque<u64>,
    cpu_queue: VecDeque<CpuWork>,
    /// Jobs per state, indexed by [`JobState::index`].
    counts: [usize; 5],
}

impl Inner {
    fn set_state(&mut self, id: u64, state: JobState) {
        if let Some(entry) = self.jobs.get_mut(&id) {
            self.counts[entry.record.state.index()] -= 1;
            self.counts[state.index()] += 1;
            entry.record.state = state;
            if state != JobState::Running {
                entry.progress = None;
            }
        }
    }
}

/// Scenes kept loaded between jobs (bundled scenes load in milliseconds, but open-world and
/// large uploads do not).
const SCENE_CACHE_ENTRIES: usize = 8;

/// Stripes of the write lock: writes of one job are serialized (so the last write is the
/// newest state), writes of different jobs mostly run in parallel.
const WRITE_STRIPES: usize = 16;

/// The service state shared by the HTTP handlers and the workers.
pub struct Service {
    pub config: Config,
    pub store: Store,
    pub catalog: SceneCatalog,
    pub gpu: Option<GpuInfo>,
    pub metrics: Metrics,
    references: References,
    inner: Mutex<Inner>,
    work_ready: Notify,
    shutting_down: AtomicBool,
    write_stripes: Vec<Mutex<()>>,
    scenes: Mutex<HashMap<String, Arc<Scene>>>,
}

/// Locks a mutex whose data stays consistent even if a holder panicked (every update under
/// these locks is a handful of assignments that cannot panic halfway).
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|e| e.into_inner())
}

impl Service {
    /// The service over an opened data folder, with the jobs found in it: queued jobs wait
    /// again, interrupted running jobs run again (or fail after `max_attempts` starts), and
    /// finished jobs are served as they were.
    /// References of comparisons are rendered by `reference_engine`, picked for
    /// `config.reference_engine`.
    pub fn recover(
        config: Config,
        store: Store,
        gpu: Option<GpuInfo>,
        reference_engine: Arc<dyn ReferenceEngine>,
    ) -> std::io::Result<(Arc<Self>, Vec<u64>)> {
        let (records, problems, next_id) = store.load_jobs()?;
        for problem in problems {
            tracing::warn!("unreadable job left in place: {problem}");
        }
        let catalog = SceneCatalog::open(&config.scene_dirs, store.scenes_dir());
        let cache_dir = config
            .cache_dir
            .clone()
            .unwrap_or_else(gi_reference::cache::default_dir);
        let mut inner = Inner {
            next_id,
            ..Inner::default()
        };
        let mut changed = Vec::new();
        for mut record in records {
            if record.state == JobState::Running {
                if record.attempts >= config.max_attempts {
                    record.state = JobState::Failed;
                    record.finished_at = Some(now_rfc3339());
                    record.failure = Some(JobFailure {
                        code: "interrupted".to_string(),
                        message: format!(
                            "the service stopped while the job ran, {} times",
                            record.attempts
                        ),
                    });
                } else {
                    tracing::info!(job = record.id, "interrupted while running; queued again");
                    record.state = JobState::Queued;
                }
                changed.push(record.id);
            }
            inner.counts[record.state.index()] += 1;
            inner.jobs.insert(
                record.id,
                Entry {
                    record,
                    progress: None,
                    cancel: Arc::new(AtomicBool::new(false)),
                },
            );
        }
        let service = Arc::new(Self {
            references: References::new(
                ReferenceCache::new(cache_dir)
                    .with_engine(reference_engine, config.reference_engine),
            ),
            config,
            store,
            catalog,
            gpu,
            metrics: Metrics::default(),
            inner: Mutex::new(inner),
            work_ready: Notify::new(),
            shutting_down: AtomicBool::new(false),
            write_stripes: (0..WRITE_STRIPES).map(|_| Mutex::new(())).collect(),
            scenes: Mutex::new(HashMap::new()),
        });
        for id in &changed {
            service.persist_blocking(*id)?;
        }
        // Queue the waiting jobs in submission order.
        let queued: Vec<(u64, JobSpec)> = lock(&service.inner)
            .jobs
            .values()
            .filter(|e| e.record.state == JobState::Queued)
            .map(|e| (e.record.id, e.record.spec.clone()))
            .collect();
        let mut ids = Vec::new();
        for (id, spec) in queued {
            let lane = match service.plan(&spec) {
                Ok((_, lane)) => lane,
                // Failed at run time, with the reason, like any job whose tier cannot run.
                Err(_) => Lane::Gpu,
            };
            service.enqueue(id, lane);
            ids.push(id);
        }
        Ok((service, ids))
    }

    /// How a job's tier is rendered here, or why it cannot be. `auto` is the library's
    /// policy ([`select::plan`], no budget) for the service's adapter at the job's size: a GPU
    /// choice goes to the GPU worker as [`TierChoice::Auto`] (which falls back as the library
    /// does), the CPU reference to the CPU pool.
    pub fn plan(&self, spec: &JobSpec) -> Result<(TierPlan, Lane), ApiError> {
        let tier = spec.tier.as_str();
        let hardware = self.gpu.as_ref().is_some_and(|g| g.hardware);
        if tier == "auto" {
            let settings = TierSettings {
                width: spec.width,
                height: spec.height,
                spp: spec.spp,
                seed: spec.seed,
                textures: gi_tiers::TextureOptions::DEFAULT,
            };
            let plan = select::plan(self.gpu.as_ref().map(|g| &g.adapter), &settings, None);
            let chosen = plan.chosen();
            return Ok(match chosen.runs_on {
                RunsOn::Gpu => (TierPlan::Gpu(TierChoice::Auto), Lane::Gpu),
                RunsOn::Cpu => (TierPlan::Cpu(chosen.kind), Lane::Cpu),
            });
        }
        let kind: TierKind = tier.parse().map_err(|_| {
            ApiError::invalid(
                "unknown_tier",
                format!(
                    "unknown tier {tier:?} (available: auto, {})",
                    TierKind::ALL.map(TierKind::name).join(", ")
                ),
            )
        })?;
        match kind {
            TierKind::Reference => Ok((TierPlan::Cpu(kind), Lane::Cpu)),
            TierKind::Direct if hardware => Ok((TierPlan::Gpu(TierChoice::Tier(kind)), Lane::Gpu)),
            TierKind::Direct => Ok((TierPlan::Cpu(kind), Lane::Cpu)),
            _ if self.gpu.is_none() => Err(ApiError::invalid(
                "gpu_unavailable",
                format!(
                    "the {kind} tier needs a GPU and this service has no GPU adapter{}; the \
                     auto, reference and direct tiers run on the CPU",
                    if self.config.no_gpu {
                        " (started with --no-gpu)"
                    } else {
                        ""
                    }
                ),
            )),
            _ => Ok((TierPlan::Gpu(TierChoice::Tier(kind)), Lane::Gpu)),
        }
    }

    /// Loads a scene (blocking), from the in-memory cache when it was loaded before.
    pub fn load_scene_blocking(&self, source: &SceneSource) -> Result<Arc<Scene>, ApiError> {
        let key = match source {
            SceneSource::Bundled(name) | SceneSource::File { name, .. } => name.clone(),
        };
        if let Some(scene) = lock(&self.scenes).get(&key) {
            return Ok(scene.clone());
        }
        let scene = Arc::new(
            source
                .load()
                .map_err(|e| ApiError::invalid("invalid_scene", e.to_string()))?,
        );
        let mut scenes = lock(&self.scenes);
        if scenes.len() >= SCENE_CACHE_ENTRIES {
            scenes.clear();
        }
        scenes.insert(key, scene.clone());
        Ok(scene)
    }

    /// Loads a scene on the blocking pool.
    pub async fn load_scene(self: &Arc<Self>, source: SceneSource) -> Result<Arc<Scene>, ApiError> {
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.load_scene_blocking(&source))
            .await
            .map_err(|e| {
                ApiError::invalid("invalid_scene", format!("loading the scene failed: {e}"))
            })?
    }

    /// Validates a job request and queues it; answers the new job's record.
    pub async fn submit(self: &Arc<Self>, request: JobRequest) -> Result<JobRecord, ApiError> {
        let spec = request.normalize(&self.config)?;
        let (_, lane) = self.plan(&spec)?;
        let source = self.catalog.resolve(&spec.scene)?;
        let scene = with_lighting(self.load_scene(source).await?, &spec)?;
        runner::check_camera(&scene, &spec.camera)?;

        let id = {
            let mut inner = lock(&self.inner);
            if self.is_shutting_down() {
                return Err(ApiError::new(
                    axum::http::StatusCode::SERVICE_UNAVAILABLE,
                    "shutting_down",
                    "the service is shutting down; submit again once it is back",
                ));
            }
            let queued = inner.counts[JobState::Queued.index()];
            if queued >= self.config.max_queue {
                self.metrics.rejected_queue_full.inc();
                let mut error = ApiError::new(
                    axum::http::StatusCode::TOO_MANY_REQUESTS,
                    "queue_full",
                    format!("{queued} jobs are waiting, the most this service queues; retry later"),
                );
                error.retry_after_s = Some(self.retry_after_s(queued));
                return Err(error);
            }
            if inner.jobs.len() >= self.config.max_jobs {
                self.metrics.rejected_job_limit.inc();
                let mut error = ApiError::new(
                    axum::http::StatusCode::TOO_MANY_REQUESTS,
                    "job_limit",
                    format!(
                        "the service keeps at most {} jobs and has them all",
                        self.config.max_jobs
                    ),
                );
                error.retry_after_s = Some(60);
                return Err(error);
            }
            let id = inner.next_id;
            inner.next_id += 1;
            inner.counts[JobState::Queued.index()] += 1;
            let record = JobRecord {
                id,
                spec,
                state: JobState::Queued,
                submitted_at: now_rfc3339(),
                started_at: None,
                finished_at: None,
                attempts: 0,
                failure: None,
                result: None,
            };
            inner.jobs.insert(
                id,
                Entry {
                    record,
                    progress: None,
                    cancel: Arc::new(AtomicBool::new(false)),
                },
            );
            id
        };
        if let Err(error) = self.persist(id).await {
            // Not stored, so not accepted: forget it.
            let mut inner = lock(&self.inner);
            if let Some(entry) = inner.jobs.remove(&id) {
                inner.counts[entry.record.state.index()] -= 1;
            }
            return Err(ApiError::internal(format!("storing the job: {error}")));
        }
        self.metrics.submitted.inc();
        self.enqueue(id, lane);
        self.record(id)
            .ok_or_else(|| ApiError::internal("the job vanished"))
    }

    /// Seconds a client turned away by a full queue should wait: about the time the queue
    /// ahead takes to move by a tenth, from the average job so far; between 1 and 60.
    fn retry_after_s(&self, queued: usize) -> u64 {
        let average = self.metrics.average_render_seconds().unwrap_or(1.0);
        (average * queued as f64 / 10.0).clamp(1.0, 60.0).ceil() as u64
    }

    fn enqueue(&self, id: u64, lane: Lane) {
        {
            let mut inner = lock(&self.inner);
            match lane {
                Lane::Gpu => inner.gpu_queue.push_back(id),
                Lane::Cpu => inner.cpu_queue.push_back(CpuWork::Render(id)),
            }
        }
        self.work_ready.notify_waiters();
    }

    /// A copy of job `id`'s record.
    pub fn record(&self, id: u64) -> Option<JobRecord> {
        lock(&self.inner).jobs.get(&id).map(|e| e.record.clone())
    }

    /// Job `id` as the API shows it.
    pub fn view(&self, id: u64) -> Option<serde_json::Value> {
        let inner = lock(&self.inner);
        let entry = inner.jobs.get(&id)?;
        Some(entry.record.view(entry.progress.as_ref()))
    }

    /// Up to `limit` jobs, newest first, with ids below `before`, in `state` if given; and
    /// how many match in all.
    pub fn list(
        &self,
        limit: usize,
        before: Option<u64>,
        state: Option<JobState>,
    ) -> (Vec<serde_json::Value>, usize) {
        let inner = lock(&self.inner);
        let matches = |e: &&Entry| state.is_none_or(|s| e.record.state == s);
        let total = match state {
            Some(state) => inner.counts[state.index()],
            None => inner.jobs.len(),
        };
        let jobs = inner
            .jobs
            .range(..before.unwrap_or(u64::MAX))
            .rev()
            .map(|(_, e)| e)
            .filter(matches)
            .take(limit)
            .map(|e| e.record.view(e.progress.as_ref()))
            .collect();
        (jobs, total)
    }

    /// Jobs per state, and the queue depth.
    pub fn counts(&self) -> [usize; 5] {
        lock(&self.inner).counts
    }

    /// Cancels job `id`: a queued job never runs, a running one stops at its next frame or
    /// pass and its result is dropped. Finished jobs cannot be cancelled.
    pub async fn cancel(self: &Arc<Self>, id: u64) -> Result<JobRecord, ApiError> {
        {
            let mut inner = lock(&self.inner);
            let Some(entry) = inner.jobs.get_mut(&id) else {
                return Err(job_not_found(id));
            };
            let state = entry.record.state;
            if state.is_final() {
                return Err(ApiError::new(
                    axum::http::StatusCode::CONFLICT,
                    "job_finished",
                    format!("job {id} is already {}", state.name()),
                ));
            }
            entry.cancel.store(true, Ordering::SeqCst);
            entry.record.finished_at = Some(now_rfc3339());
            inner.set_state(id, JobState::Cancelled);
        }
        self.persist(id)
            .await
            .map_err(|e| ApiError::internal(format!("storing the job: {e}")))?;
        self.record(id).ok_or_else(|| job_not_found(id))
    }

    /// Writes job `id`'s current record to the data folder (blocking).
    fn persist_blocking(&self, id: u64) -> std::io::Result<()> {
        let _write = lock(&self.write_stripes[id as usize % WRITE_STRIPES]);
        // The record is read under the write lock, so whichever write comes last stores the
        // newest state.
        let Some(record) = self.record(id) else {
            return Ok(());
        };
        self.store.write_job(&record)
    }

    async fn persist(self: &Arc<Self>, id: u64) -> std::io::Result<()> {
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.persist_blocking(id))
            .await
            .map_err(std::io::Error::other)?
    }

    /// Persists, logging a failure: for the workers' state changes, which have no client to
    /// answer (the job runs again after a restart if its final state was not stored).
    async fn persist_or_log(self: &Arc<Self>, id: u64) {
        if let Err(error) = self.persist(id).await {
            tracing::error!(job = id, "storing the job failed: {error}");
        }
    }

    pub fn is_shutting_down(&self) -> bool {
        self.shutting_down.load(Ordering::SeqCst)
    }

    /// Stops the workers: each finishes (or stops) what it runs and takes nothing more.
    pub fn shut_down(&self) {
        self.shutting_down.store(true, Ordering::SeqCst);
        self.work_ready.notify_waiters();
    }

    /// After the workers stopped: jobs still marked running (stopped between their tier and
    /// their comparison, or still running past the grace period) go back to the queue on disk
    /// without counting the start, so the next start runs them again.
    pub fn requeue_running_blocking(&self) {
        let running: Vec<u64> = {
            let mut inner = lock(&self.inner);
            let ids: Vec<u64> = inner
                .jobs
                .values()
                .filter(|e| e.record.state == JobState::Running)
                .map(|e| e.record.id)
                .collect();
            for id in &ids {
                if let Some(entry) = inner.jobs.get_mut(id) {
                    entry.record.attempts = entry.record.attempts.saturating_sub(1);
                    entry.record.started_at = None;
                }
                inner.set_state(*id, JobState::Queued);
            }
            ids
        };
        for id in running {
            if let Err(error) = self.persist_blocking(id) {
                tracing::error!(job = id, "storing the job failed: {error}");
            }
        }
    }

    /// The GPU worker: one job at a time.
    pub async fn gpu_worker(self: Arc<Self>) {
        while let Some(id) = self.next_work(|inner| inner.gpu_queue.pop_front()).await {
            self.run_tier(id, Lane::Gpu).await;
        }
    }

    /// One worker of the CPU pool.
    pub async fn cpu_worker(self: Arc<Self>) {
        while let Some(work) = self.next_work(|inner| inner.cpu_queue.pop_front()).await {
            match work {
                CpuWork::Render(id) => self.run_tier(id, Lane::Cpu).await,
                CpuWork::Compare(comparing) => self.run_compare(*comparing).await,
            }
        }
    }

    /// Waits for work taken by `take`; `None` once the service shuts down.
    async fn next_work<T>(&self, take: impl Fn(&mut Inner) -> Option<T>) -> Option<T> {
        loop {
            // Registered before the queue is looked at, so a push in between still wakes us.
            let notified = self.work_ready.notified();
            if self.is_shutting_down() {
                return None;
            }
            if let Some(work) = take(&mut lock(&self.inner)) {
                return Some(work);
            }
            notified.await;
        }
    }

    /// Marks job `id` running if it is still queued; its spec and cancel flag.
    fn start(&self, id: u64) -> Option<(JobSpec, Arc<AtomicBool>)> {
        let mut inner = lock(&self.inner);
        let entry = inner.jobs.get_mut(&id)?;
        if entry.record.state != JobState::Queued {
            return None;
        }
        entry.record.attempts += 1;
        entry.record.started_at = Some(now_rfc3339());
        entry.progress = Some(Progress {
            stage: "starting",
            done: 0,
            total: 1,
            fraction: 0.0,
        });
        let started = (entry.record.spec.clone(), entry.cancel.clone());
        inner.set_state(id, JobState::Running);
        Some(started)
    }

    fn set_progress(&self, id: u64, progress: Progress) {
        let mut inner = lock(&self.inner);
        if let Some(entry) = inner.jobs.get_mut(&id)
            && entry.record.state == JobState::Running
        {
            entry.progress = Some(progress);
        }
    }

    /// Renders job `id`'s tier, then finishes it or hands it to the CPU pool to compare.
    async fn run_tier(self: &Arc<Self>, id: u64, lane: Lane) {
        let Some((spec, cancel)) = self.start(id) else {
            return; // cancelled while queued
        };
        self.persist_or_log(id).await;
        let prepared = match self.prepare(&spec).await {
            Ok(prepared) => Arc::new(prepared),
            Err(error) => return self.fail(id, error.code, error.message).await,
        };
        let service = self.clone();
        let job = prepared.clone();
        let share = if spec.compare { 0.5 } else { 1.0 };
        let started = Instant::now();
        let rendered = tokio::task::spawn_blocking(move || {
            let stop = || cancel.load(Ordering::SeqCst) || service.is_shutting_down();
            runner::render_tier(&job, &|p| service.set_progress(id, p), &stop, share)
        })
        .await;
        let seconds = started.elapsed().as_secs_f64();
        if lane == Lane::Gpu {
            self.metrics.add_gpu_busy(seconds);
        }
        match rendered {
            Err(panic) => {
                self.fail(
                    id,
                    "internal",
                    format!("the render failed unexpectedly: {panic}"),
                )
                .await
            }
            Ok(Err(message)) => self.fail(id, "render_failed", message).await,
            Ok(Ok(None)) => self.stopped(id).await,
            Ok(Ok(Some(output))) => {
                self.metrics.add_render(&output.result.tier, seconds);
                match spec.reference_spp {
                    Some(reference_spp) => {
                        // Ahead of new renders: this job already holds its tier's image.
                        lock(&self.inner)
                            .cpu_queue
                            .push_front(CpuWork::Compare(Box::new(Comparing {
                                id,
                                job: prepared,
                                output,
                                reference_spp,
                            })));
                        self.work_ready.notify_waiters();
                    }
                    None => self.finish(id, &prepared, output, None).await,
                }
            }
        }
    }

    async fn run_compare(self: &Arc<Self>, comparing: Comparing) {
        let id = comparing.id;
        let Some(cancel) = lock(&self.inner)
            .jobs
            .get(&id)
            .filter(|e| e.record.state == JobState::Running)
            .map(|e| e.cancel.clone())
        else {
            return; // cancelled while it waited
        };
        let service = self.clone();
        let comparing = Arc::new(comparing);
        let work = comparing.clone();
        let compared = tokio::task::spawn_blocking(move || {
            let stop = || cancel.load(Ordering::SeqCst) || service.is_shutting_down();
            runner::compare(
                &work.job,
                &work.output,
                work.reference_spp,
                &service.references,
                &|p| service.set_progress(id, p),
                &stop,
                0.5,
            )
        })
        .await;
        let Ok(comparing) = Arc::try_unwrap(comparing) else {
            return self
                .fail(id, "internal", "the comparison is still referenced")
                .await;
        };
        match compared {
            Err(panic) => {
                self.fail(
                    id,
                    "internal",
                    format!("the comparison failed unexpectedly: {panic}"),
                )
                .await
            }
            Ok(Err(message)) => self.fail(id, "compare_failed", message).await,
            Ok(Ok(None)) => self.stopped(id).await,
            Ok(Ok(Some(compared))) => {
                if compared.comparison.reference_cached {
                    self.metrics.reference_cache_hits.inc();
                } else {
                    self.metrics.reference_cache_misses.inc();
                }
                let mut output = comparing.output;
                output.result.comparison = Some(compared.comparison);
                let compared = (compared.reference, compared.flip);
                self.finish(id, &comparing.job, output, Some(compared))
                    .await
            }
        }
    }

    async fn prepare(self: &Arc<Self>, spec: &JobSpec) -> Result<PreparedJob, ApiError> {
        let (plan, _) = self.plan(spec)?;
        let source = self.catalog.resolve(&spec.scene)?;
        let scene = with_lighting(self.load_scene(source).await?, spec)?;
        let gpu_name = self.gpu.as_ref().map(|g| g.name.clone());
        let spec = spec.clone();
        tokio::task::spawn_blocking(move || runner::prepare(scene, &spec, plan, gpu_name))
            .await
            .map_err(|e| ApiError::internal(e.to_string()))?
    }

    /// Stores the images and result of a job that is still running (a cancelled job's are
    /// dropped).
    async fn finish(
        self: &Arc<Self>,
        id: u64,
        job: &PreparedJob,
        output: TierOutput,
        compared: Option<(gi_image::Image, gi_image::Flip)>,
    ) {
        let dir = self.store.job_dir(id);
        let exposure = job.scene.exposure;
        let TierOutput { image, result } = output;
        let written = tokio::task::spawn_blocking(move || {
            let compared = compared.as_ref().map(|(reference, flip)| (reference, flip));
            runner::write_images(&dir, exposure, &image, compared)
        })
        .await
        .map_err(std::io::Error::other)
        .and_then(|r| r);
        if let Err(error) = written {
            return self
                .fail(id, "internal", format!("storing the images: {error}"))
                .await;
        }
        {
            let mut inner = lock(&self.inner);
            let Some(entry) = inner.jobs.get_mut(&id) else {
                return;
            };
            if entry.record.state != JobState::Running {
                return;
            }
            entry.record.result = Some(result);
            entry.record.finished_at = Some(now_rfc3339());
            inner.set_state(id, JobState::Done);
        }
        self.persist_or_log(id).await;
    }

    async fn fail(self: &Arc<Self>, id: u64, code: &str, message: impl Into<String>) {
        let message = message.into();
        tracing::warn!(job = id, code, "job failed: {message}");
        {
            let mut inner = lock(&self.inner);
            let Some(entry) = inner.jobs.get_mut(&id) else {
                return;
            };
            if entry.record.state != JobState::Running {
                return;
            }
            entry.record.failure = Some(JobFailure {
                code: code.to_string(),
                message,
            });
            entry.record.finished_at = Some(now_rfc3339());
            inner.set_state(id, JobState::Failed);
        }
        self.persist_or_log(id).await;
    }

    /// A render stopped before its end: by a cancellation (already recorded) or by the
    /// shutdown, which puts the job back in the queue for the next start.
    async fn stopped(self: &Arc<Self>, id: u64) {
        {
            let mut inner = lock(&self.inner);
            let Some(entry) = inner.jobs.get_mut(&id) else {
                return;
            };
            if entry.record.state != JobState::Running {
                return;
            }
            // This start did not count: the job never got to finish through no fault of its own.
            entry.record.attempts = entry.record.attempts.saturating_sub(1);
            entry.record.started_at = None;
            inner.set_state(id, JobState::Queued);
        }
        tracing::info!(
            job = id,
            "stopped by the shutdown; it runs again after the restart"
        );
        self.persist_or_log(id).await;
    }
}

pub fn job_not_found(id: impl std::fmt::Display) -> ApiError {
    ApiError::not_found("job_not_found", format!("no job {id}"))
}

/// `scene` with the job's lighting applied (a copy; the cached scene stays as loaded).
fn with_lighting(scene: Arc<Scene>, spec: &JobSpec) -> Result<Arc<Scene>, ApiError> {
    let Some(lighting) = &spec.lighting else {
        return Ok(scene);
    };
    let mut lit = Scene::clone(&scene);
    lighting
        .apply(&mut lit)
        .map_err(|e| ApiError::invalid("invalid_lighting", e.to_string()))?;
    Ok(Arc::new(lit))
}

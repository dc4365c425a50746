//! The job service: the job table, the queues, the GPU worker and the CPU pool, and the
//! persistence of every state change.
//!
//! A job is `queued` until a worker takes it; GPU tiers wait in one queue served by a single
//! GPU worker (jobs run one at a time), CPU renders in another served by a bounded pool. A job
//! that compares renders its tier first, then goes to the front of the CPU queue for the
//! reference, so the GPU worker never waits on a path tracer.
//!
//! Every change of a job's record goes through one function ([`Service::transition_blocking`]):
//! the new record is written to the data folder first and only then shown, so the API never
//! reports a state a restart would not find, and a final state (done, failed, cancelled) is
//! never left. A write that fails (a full disk) changes nothing: a request is answered 507 or
//! 500, a worker's final change is retried until it is stored.

mod backend;
mod health;
mod records;
#[cfg(test)]
mod tests;
mod workers;

use std::{
    collections::{BTreeMap, HashMap, VecDeque},
    sync::{
        Arc, Mutex, MutexGuard,
        atomic::{AtomicBool, Ordering},
    },
    time::Duration,
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
    job::{
        JobFailure, JobRecord, JobRequest, JobResult, JobSpec, JobState, Progress, StateFilter,
        now_rfc3339, unreadable_view,
    },
    metrics::Metrics,
    runner::{self, PreparedJob, References, TierOutput, TierPlan},
    scenes::{SceneCatalog, SceneSource, UploadedScene},
    store::{LoadedJobs, Store},
};
pub(crate) use workers::requeue_stopped;

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
    /// Compare, in a process of its own, the image a job process rendered into the job's
    /// folder (with its result).
    CompareRendered(u64, Box<JobResult>),
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
    /// When a running job reaches `--job-time-limit-s` (none without a limit, or before it
    /// starts).
    deadline: Option<std::time::Instant>,
}

#[derive(Default)]
struct Inner {
    jobs: BTreeMap<u64, Entry>,
    /// Job folders whose record could not be read at startup, and why: listed as
    /// `unreadable` jobs, never run and never overwritten.
    unreadable: BTreeMap<u64, String>,
    next_id: u64,
    /// Submissions whose first record is being written: they count against the queue and
    /// job limits like the jobs they may become.
    storing: usize,
    gpu_queue: VecDeque<u64>,
    cpu_queue: VecDeque<CpuWork>,
    /// Jobs per state, indexed by [`JobState::index`].
    counts: [usize; 5],
}

impl Inner {
    /// Adds a stored job.
    fn insert(&mut self, record: JobRecord) {
        self.counts[record.state.index()] += 1;
        self.jobs.insert(
            record.id,
            Entry {
                record,
                progress: None,
                cancel: Arc::new(AtomicBool::new(false)),
                deadline: None,
            },
        );
    }

    /// Drops a deleted job.
    fn remove(&mut self, id: u64) {
        if let Some(entry) = self.jobs.remove(&id) {
            self.counts[entry.record.state.index()] -= 1;
        }
    }

    /// Replaces a job's record with `record`, just stored.
    fn commit(&mut self, record: JobRecord) {
        let Some(entry) = self.jobs.get_mut(&record.id) else {
            return;
        };
        self.counts[entry.record.state.index()] -= 1;
        self.counts[record.state.index()] += 1;
        if record.state != JobState::Running {
            entry.progress = None;
        }
        entry.record = record;
    }
}

/// Scenes kept loaded between jobs (bundled scenes load in milliseconds, but open-world and
/// large uploads do not).
const SCENE_CACHE_ENTRIES: usize = 8;

/// Stripes of the write lock: writes of one job are serialized (so the last write is the
/// newest state), writes of different jobs mostly run in parallel.
const WRITE_STRIPES: usize = 16;

/// How long a worker waits before it tries again to store a change the data folder refused
/// (a full disk): often enough to go on soon after space is freed, rarely enough not to flood
/// the log.
const STORE_RETRY: Duration = Duration::from_secs(1);

/// The service state shared by the HTTP handlers and the workers.
pub struct Service {
    pub config: Config,
    pub store: Store,
    pub catalog: SceneCatalog,
    pub gpu: Option<GpuInfo>,
    pub metrics: Metrics,
    references: References,
    /// The reference cache's folder (job processes open it themselves).
    cache_dir: std::path::PathBuf,
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
        let LoadedJobs {
            records,
            unreadable,
            next_id,
        } = store.load_jobs()?;
        let catalog = SceneCatalog::open(
            &config.scene_dirs,
            store.scenes_dir(),
            store.writer().clone(),
        );
        let cache_dir = config
            .cache_dir
            .clone()
            .unwrap_or_else(gi_reference::cache::default_dir);
        let mut inner = Inner {
            next_id,
            ..Inner::default()
        };
        for broken in unreadable {
            // Not dropped: listed as an unreadable job and reported by /healthz until a person
            // repairs or removes its folder.
            tracing::error!(
                job = broken.id,
                "{}; the job is shown as unreadable and left as it is",
                broken.error
            );
            inner.unreadable.insert(broken.id, broken.error);
        }
        let interrupted: Vec<u64> = (records.iter())
            .filter(|r| r.state == JobState::Running)
            .map(|r| r.id)
            .collect();
        for record in records {
            inner.insert(record);
        }
        let service = Arc::new(Self {
            references: References::new(
                ReferenceCache::new(cache_dir.clone())
                    .with_engine(reference_engine, config.reference_engine),
            ),
            cache_dir,
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
        let max_attempts = service.config.max_attempts;
        for id in interrupted {
            // A folder that cannot take the change stops the start: running the job again
            // without recording the attempt could let a job that crashes the service do it
            // forever.
            service.transition_blocking(id, |record| {
                if record.state != JobState::Running {
                    return false;
                }
                if record.attempts >= max_attempts {
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
                true
            })?;
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
        plan_for(spec, self.gpu.as_ref(), self.config.no_gpu)
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
        let (plan, lane) = self.plan(&spec)?;
        // A GPU `auto` picks a real-time tier (or falls back as the library does).
        let traces_spp = matches!(
            plan,
            TierPlan::Cpu(_) | TierPlan::Gpu(TierChoice::Tier(TierKind::Path | TierKind::Direct))
        );
        spec.check_cost(traces_spp, self.config.max_job_samples)?;
        let source = self.catalog.resolve(&spec.scene)?;
        let scene = with_lighting(self.load_scene(source).await?, &spec)?;
        runner::check_camera(&scene, &spec.camera)?;

        self.check_free_space()?;
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.check_quota())
            .await
            .map_err(|e| ApiError::internal(e.to_string()))??;

        let id = {
            let mut inner = lock(&self.inner);
            if self.is_shutting_down() {
                return Err(ApiError::new(
                    axum::http::StatusCode::SERVICE_UNAVAILABLE,
                    "shutting_down",
                    "the service is shutting down; submit again once it is back",
                ));
            }
            let queued = inner.counts[JobState::Queued.index()] + inner.storing;
            if queued >= self.config.max_queue {
                self.metrics.rejected_queue_full.inc();
                return Err(ApiError::queue_full(queued, self.retry_after_s(queued)));
            }
            if inner.jobs.len() + inner.unreadable.len() + inner.storing >= self.config.max_jobs {
                self.metrics.rejected_job_limit.inc();
                return Err(ApiError::job_limit(self.config.max_jobs));
            }
            let id = inner.next_id;
            inner.next_id += 1;
            inner.storing += 1;
            id
        };
        let record = JobRecord::queued(id, spec);
        // On the blocking pool, which finishes it even if the client goes away meanwhile.
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.store_new_job(record, lane))
            .await
            .map_err(|e| ApiError::internal(e.to_string()))?
            .map_err(|e| ApiError::storage("the job", &e))
    }

    /// Seconds a client turned away by a full queue should wait: about the time the queue
    /// ahead takes to move by a tenth, from the average job so far; between 1 and 60.
    fn retry_after_s(&self, queued: usize) -> u64 {
        let average = self.metrics.average_render_seconds().unwrap_or(1.0);
        (average * queued as f64 / 10.0).clamp(1.0, 60.0).ceil() as u64
    }

    /// Queues job `id` behind the queued jobs of its priority or a higher one.
    fn enqueue(&self, id: u64, lane: Lane) {
        {
            let mut inner = lock(&self.inner);
            let priority_of =
                |inner: &Inner, id: u64| inner.jobs.get(&id).map_or(0, |e| e.record.spec.priority);
            let priority = priority_of(&inner, id);
            match lane {
                Lane::Gpu => {
                    let at = (inner.gpu_queue.iter())
                        .rposition(|&queued| priority_of(&inner, queued) >= priority)
                        .map_or(0, |last| last + 1);
                    inner.gpu_queue.insert(at, id);
                }
                Lane::Cpu => {
                    // Comparisons waiting for the pool go first whatever their priority.
                    let at = (inner.cpu_queue.iter())
                        .rposition(|work| match work {
                            CpuWork::Render(queued) => priority_of(&inner, *queued) >= priority,
                            CpuWork::Compare(_) | CpuWork::CompareRendered(..) => true,
                        })
                        .map_or(0, |last| last + 1);
                    inner.cpu_queue.insert(at, CpuWork::Render(id));
                }
            }
        }
        self.work_ready.notify_waiters();
    }

    /// A copy of job `id`'s record.
    pub fn record(&self, id: u64) -> Option<JobRecord> {
        lock(&self.inner).jobs.get(&id).map(|e| e.record.clone())
    }

    /// A copy of job `id`'s record, or the error to answer: the job does not exist, or its
    /// record could not be read.
    pub fn readable_record(&self, id: u64) -> Result<JobRecord, ApiError> {
        let inner = lock(&self.inner);
        if let Some(entry) = inner.jobs.get(&id) {
            return Ok(entry.record.clone());
        }
        Err(match inner.unreadable.get(&id) {
            Some(error) => job_unreadable(id, error),
            None => job_not_found(id),
        })
    }

    /// Job `id` as the API shows it.
    pub fn view(&self, id: u64) -> Option<serde_json::Value> {
        let inner = lock(&self.inner);
        match inner.jobs.get(&id) {
            Some(entry) => Some(entry.record.view(entry.progress.as_ref())),
            None => (inner.unreadable.get(&id)).map(|error| unreadable_view(id, error)),
        }
    }

    /// Up to `limit` jobs, newest first, with ids below `before`, in `state` if given (jobs
    /// whose record cannot be read included); and how many match in all.
    pub fn list(
        &self,
        limit: usize,
        before: Option<u64>,
        state: Option<StateFilter>,
    ) -> (Vec<serde_json::Value>, usize) {
        let inner = lock(&self.inner);
        let job_state = state.map(StateFilter::job_state);
        let wants_unreadable = matches!(state, None | Some(StateFilter::Unreadable));
        let total = match job_state {
            None => inner.jobs.len() + inner.unreadable.len(),
            Some(Some(state)) => inner.counts[state.index()],
            Some(None) => inner.unreadable.len(),
        };
        let range = ..before.unwrap_or(u64::MAX);
        let mut jobs = (inner.jobs.range(range).rev())
            .filter(|(_, e)| job_state.is_none_or(|s| s == Some(e.record.state)))
            .peekable();
        let mut unreadable = (inner.unreadable.range(range).rev())
            .filter(|_| wants_unreadable)
            .peekable();
        let mut page = Vec::new();
        while page.len() < limit {
            // Newest (largest id) first, from whichever map holds it.
            let job_next = match (jobs.peek(), unreadable.peek()) {
                (Some((a, _)), Some((b, _))) => a > b,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (None, None) => break,
            };
            if job_next && let Some((_, e)) = jobs.next() {
                page.push(e.record.view(e.progress.as_ref()));
            } else if let Some((id, error)) = unreadable.next() {
                page.push(unreadable_view(*id, error));
            }
        }
        (page, total)
    }

    /// Job folders whose record could not be read at startup.
    pub fn unreadable_count(&self) -> usize {
        lock(&self.inner).unreadable.len()
    }

    /// Jobs per state, and the queue depth.
    pub fn counts(&self) -> [usize; 5] {
        lock(&self.inner).counts
    }

    /// Cancels job `id`: a queued job never runs, a running one stops at its next frame or
    /// pass and its result is dropped. Finished jobs cannot be cancelled; nor can a job whose
    /// record cannot be read.
    pub async fn cancel(self: &Arc<Self>, id: u64) -> Result<JobRecord, ApiError> {
        self.readable_record(id)?;
        let service = self.clone();
        // On the blocking pool, which finishes it even if the client goes away meanwhile.
        let cancelled = tokio::task::spawn_blocking(move || {
            let cancelled = service.transition_blocking(id, |record| {
                if record.state.is_final() {
                    return false;
                }
                record.finished_at = Some(now_rfc3339());
                record.state = JobState::Cancelled;
                true
            });
            if let (Ok(Some(_)), Some(entry)) = (&cancelled, lock(&service.inner).jobs.get(&id)) {
                entry.cancel.store(true, Ordering::SeqCst);
            }
            cancelled
        })
        .await
        .map_err(|e| ApiError::internal(e.to_string()))?
        .map_err(|e| ApiError::storage(&format!("job {id}'s cancellation"), &e))?;
        match cancelled {
            Some(record) => Ok(record),
            None => {
                let record = self.readable_record(id)?;
                Err(ApiError::new(
                    axum::http::StatusCode::CONFLICT,
                    "job_finished",
                    format!("job {id} is already {}", record.state.name()),
                ))
            }
        }
    }

    /// `DELETE /v1/jobs/{id}`: cancels a queued or running job ([`Service::cancel`]);
    /// deletes a finished one (done, failed or cancelled) with its images, or the folder of
    /// one whose record could not be read. Answers the job's view, with `deleted` true when it
    /// was deleted.
    pub async fn delete(self: &Arc<Self>, id: u64) -> Result<serde_json::Value, ApiError> {
        let unreadable = lock(&self.inner).unreadable.contains_key(&id);
        if !unreadable && !self.readable_record(id)?.state.is_final() {
            self.cancel(id).await?;
            return self.view(id).ok_or_else(|| job_not_found(id));
        }
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.delete_blocking(id))
            .await
            .map_err(|e| ApiError::internal(e.to_string()))?
    }

    fn delete_blocking(&self, id: u64) -> Result<serde_json::Value, ApiError> {
        // Under the job's write lock: no change of it is being stored meanwhile.
        let _write = lock(&self.write_stripes[id as usize % WRITE_STRIPES]);
        let mut view = self.view(id).ok_or_else(|| job_not_found(id))?;
        let next_id = lock(&self.inner).next_id;
        self.store
            .delete_job(id, next_id)
            .map_err(|e| ApiError::storage(&format!("job {id}'s deletion"), &e))?;
        let mut inner = lock(&self.inner);
        inner.remove(id);
        inner.unreadable.remove(&id);
        drop(inner);
        view["deleted"] = serde_json::Value::Bool(true);
        Ok(view)
    }

    /// `DELETE /v1/scenes/{id}`: deletes an uploaded scene, unless a queued or running job
    /// names it (409 `scene_in_use`). Bundled and folder scenes are not the service's to
    /// delete. Blocking.
    pub fn delete_scene_blocking(&self, id: &str) -> Result<UploadedScene, ApiError> {
        let users: Vec<u64> = (lock(&self.inner).jobs.values())
            .filter(|e| !e.record.state.is_final() && e.record.spec.scene == id)
            .map(|e| e.record.id)
            .collect();
        if !users.is_empty() {
            return Err(ApiError::new(
                axum::http::StatusCode::CONFLICT,
                "scene_in_use",
                format!(
                    "jobs {users:?} are queued or running with scene {id}; delete it once they \
                     end (or cancel them)"
                ),
            ));
        }
        let deleted = self.catalog.delete(id)?;
        lock(&self.scenes).remove(id);
        Ok(deleted)
    }

    /// Uploads a scene ([`SceneCatalog::upload`]) within the service's texel budget, unless
    /// the data folder's disk is below its free-space floor. Blocking.
    pub fn upload_scene_blocking(
        &self,
        bytes: &[u8],
        name: &str,
    ) -> Result<(UploadedScene, bool), ApiError> {
        self.check_free_space()?;
        self.check_quota()?;
        self.catalog
            .upload(bytes, name, self.config.max_upload_texels)
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
        let running: Vec<u64> = (lock(&self.inner).jobs.values())
            .filter(|e| e.record.state == JobState::Running)
            .map(|e| e.record.id)
            .collect();
        for id in running {
            if let Err(error) = self.transition_blocking(id, requeue_stopped) {
                // The record says running: the next start counts this start and runs it again.
                tracing::error!(job = id, "storing the job failed: {error}");
            }
        }
    }
}

pub fn job_not_found(id: impl std::fmt::Display) -> ApiError {
    ApiError::not_found("job_not_found", format!("no job {id}"))
}

/// 409 for a job whose record could not be read at startup (`error` says why).
pub(crate) fn job_unreadable(id: u64, error: &str) -> ApiError {
    ApiError::new(
        axum::http::StatusCode::CONFLICT,
        "job_unreadable",
        format!(
            "job {id}'s record could not be read ({error}); repair or remove its folder, then \
             restart the service"
        ),
    )
}

/// How a job's tier is rendered on a machine with `gpu` (see [`Service::plan`]).
pub(crate) fn plan_for(
    spec: &JobSpec,
    gpu: Option<&GpuInfo>,
    no_gpu: bool,
) -> Result<(TierPlan, Lane), ApiError> {
    let tier = spec.tier.as_str();
    let hardware = gpu.is_some_and(|g| g.hardware);
    if tier == "auto" {
        let settings = TierSettings {
            width: spec.width,
            height: spec.height,
            spp: spec.spp,
            seed: spec.seed,
            textures: gi_tiers::TextureOptions::DEFAULT,
        };
        let plan = select::plan(gpu.map(|g| &g.adapter), &settings, None);
        let chosen = plan.chosen();
        return Ok(match chosen.runs_on {
            RunsOn::Gpu => (TierPlan::Gpu(TierChoice::Auto), Lane::Gpu),
            RunsOn::Cpu => (TierPlan::Cpu(chosen.kind), Lane::Cpu),
        });
    }
    let kind: TierKind = tier.parse().map_err(|_| ApiError::unknown_tier(tier))?;
    match kind {
        TierKind::Reference => Ok((TierPlan::Cpu(kind), Lane::Cpu)),
        TierKind::Direct if hardware => Ok((TierPlan::Gpu(TierChoice::Tier(kind)), Lane::Gpu)),
        TierKind::Direct => Ok((TierPlan::Cpu(kind), Lane::Cpu)),
        _ if gpu.is_none() => Err(ApiError::invalid(
            "gpu_unavailable",
            format!(
                "the {kind} tier needs a GPU and this service has no GPU adapter{}; the \
                 auto, reference and direct tiers run on the CPU",
                if no_gpu {
                    " (started with --no-gpu)"
                } else {
                    ""
                }
            ),
        )),
        _ => Ok((TierPlan::Gpu(TierChoice::Tier(kind)), Lane::Gpu)),
    }
}

/// `scene` with the job's lighting applied (a copy; the cached scene stays as loaded).
pub(crate) fn with_lighting(scene: Arc<Scene>, spec: &JobSpec) -> Result<Arc<Scene>, ApiError> {
    let Some(lighting) = &spec.lighting else {
        return Ok(scene);
    };
    let mut lit = Scene::clone(&scene);
    lighting
        .apply(&mut lit)
        .map_err(|e| ApiError::invalid("invalid_lighting", e.to_string()))?;
    Ok(Arc::new(lit))
}

//! The scale-out service: API servers that keep no state of their own, over a job queue in
//! PostgreSQL ([`queue`]) and results and uploaded scenes in an object store ([`objects`]),
//! with `gi-worker` processes ([`worker`]), one per GPU on any number of machines, taking
//! the jobs. Any number of API servers may run side by side behind a load balancer.
//!
//! The API is the embedded service's, route for route; what differs is where things live:
//! - a job's record is its row; the API reads it there on every request, so each API server
//!   sees every job and a killed one loses nothing;
//! - a worker holds its job by a lease its heartbeat renews; the job of a worker that stops
//!   beating goes back to the queue (any process that talks to the queue requeues it);
//! - cancelling a running job changes its row; its worker learns at its next heartbeat and
//!   stops the render at its next frame or pass;
//! - an uploaded scene is checked by the API server that receives it, stored in the object
//!   store and fetched by the workers (and other API servers) that need it.

pub mod objects;
pub mod queue;
pub mod worker;

use std::{
    collections::HashMap,
    path::PathBuf,
    sync::{
        Arc, Mutex,
        atomic::{AtomicBool, Ordering},
    },
    time::Duration,
};

use axum::http::StatusCode;
use futures_util::{FutureExt, future::BoxFuture};
use gi_scene::Scene;
use serde_json::json;

use crate::{
    backend::{Backend, JobPage, blocking},
    config::Config,
    error::ApiError,
    job::{JobRecord, JobRequest, JobState, StateFilter, now_rfc3339},
    metrics::{DiskUsage, Metrics},
    runner,
    scenes::{SceneCatalog, SceneInfo, SceneSource, UPLOAD_PREFIX, UploadedScene},
    service::{job_not_found, job_unreadable, with_lighting},
    store::Writer,
};
use objects::{Objects, job_key};
use queue::{Lane, Queue, Refused};

/// Connections each API server keeps to the database.
const API_CONNECTIONS: usize = 16;

/// Scenes an API server keeps loaded to check the cameras of submissions.
const SCENE_CACHE_ENTRIES: usize = 8;

/// How often an API server looks for jobs whose worker was lost.
const REQUEUE_EVERY: Duration = Duration::from_secs(2);

/// The lane of a job's tier (`auto` and the CPU-capable tiers run on any worker, the
/// real-time and path tiers on a worker with a GPU), and whether it traces `spp` samples
/// per pixel for the cost estimate (`auto` is counted as if it did: the worker that takes it
/// may have no GPU).
pub fn lane_of(tier: &str) -> Result<(Lane, bool), ApiError> {
    use gi_tiers::TierKind;
    if tier == "auto" {
        return Ok((Lane::Any, true));
    }
    let kind: TierKind = tier.parse().map_err(|_| ApiError::unknown_tier(tier))?;
    Ok(match kind {
        TierKind::Reference | TierKind::Direct => (Lane::Any, true),
        TierKind::Path => (Lane::Gpu, true),
        _ => (Lane::Gpu, false),
    })
}

/// Scenes by name: the bundled ones, the scene folders of this machine (the same on every
/// machine of a deployment) and the uploads, fetched from the object store into a local
/// folder the first time they are needed.
pub struct Scenes {
    catalog: SceneCatalog,
    objects: Objects,
    loaded: Mutex<HashMap<String, Arc<Scene>>>,
}

impl Scenes {
    pub fn new(scene_dirs: &[PathBuf], local_dir: PathBuf, objects: Objects) -> Self {
        Self {
            catalog: SceneCatalog::open(scene_dirs, local_dir, Writer::default()),
            objects,
            loaded: Mutex::new(HashMap::new()),
        }
    }

    /// Where scene `name` comes from; an upload this machine has not seen is fetched.
    pub async fn resolve(&self, name: &str) -> Result<SceneSource, ApiError> {
        match self.catalog.resolve(name) {
            Err(error) if name.starts_with(UPLOAD_PREFIX) && error.code == "unknown_scene" => {
                let Some(description) = self.objects.get(&format!("scenes/{name}.json")).await?
                else {
                    return Err(error);
                };
                let Some(glb) = self.objects.get(&format!("scenes/{name}.glb")).await? else {
                    return Err(error);
                };
                let scene: UploadedScene = serde_json::from_slice(&description).map_err(|e| {
                    ApiError::internal(format!("scenes/{name}.json in the store: {e}"))
                })?;
                self.catalog.adopt(&scene, &glb)?;
                self.catalog.resolve(name)
            }
            resolved => resolved,
        }
    }

    /// Scene `name`, loaded (kept for the next time).
    pub async fn load(&self, name: &str) -> Result<Arc<Scene>, ApiError> {
        if let Some(scene) = self
            .loaded
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(name)
        {
            return Ok(scene.clone());
        }
        let source = self.resolve(name).await?;
        let scene = blocking(move || {
            source.load().map(Arc::new).map_err(|e| {
                ApiError::invalid("invalid_scene", format!("loading the scene failed: {e}"))
            })
        })
        .await?;
        let mut loaded = self.loaded.lock().unwrap_or_else(|e| e.into_inner());
        if loaded.len() >= SCENE_CACHE_ENTRIES {
            loaded.clear();
        }
        loaded.insert(name.to_string(), scene.clone());
        Ok(scene)
    }

    /// Forgets upload `id` on this machine.
    fn forget(&self, id: &str) {
        let _ = self.catalog.delete(id);
        self.loaded
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
    }
}

/// The API of the scale-out service.
pub struct ClusterApi {
    config: Config,
    metrics: Metrics,
    queue: Queue,
    objects: Objects,
    scenes: Scenes,
    shutting_down: AtomicBool,
}

impl ClusterApi {
    /// Connects to the database and the store named in `config`, and starts looking for the
    /// jobs of lost workers.
    pub async fn start(config: Config) -> anyhow::Result<Arc<Self>> {
        let (Some(database_url), Some(store_url)) = (&config.database_url, &config.store_url)
        else {
            anyhow::bail!("the scale-out mode needs --database-url and --store-url");
        };
        let queue = Queue::connect(database_url, API_CONNECTIONS).await?;
        let objects = Objects::open(store_url)?;
        let scenes = Scenes::new(
            &config.scene_dirs,
            config.data_dir.join("scenes"),
            objects.clone(),
        );
        let api = Arc::new(Self {
            config,
            metrics: Metrics::default(),
            queue,
            objects,
            scenes,
            shutting_down: AtomicBool::new(false),
        });
        let requeuer = Arc::downgrade(&api);
        tokio::spawn(async move {
            loop {
                tokio::time::sleep(REQUEUE_EVERY).await;
                let Some(api) = requeuer.upgrade() else {
                    return;
                };
                if api.shutting_down.load(Ordering::SeqCst) {
                    return;
                }
                if let Err(error) = api.queue.requeue_expired().await {
                    tracing::warn!("{}", error.message);
                }
            }
        });
        Ok(api)
    }

    async fn submit(self: Arc<Self>, request: JobRequest) -> Result<JobRecord, ApiError> {
        let spec = request.normalize(&self.config)?;
        let (lane, traces_spp) = lane_of(&spec.tier)?;
        spec.check_cost(traces_spp, self.config.max_job_samples)?;
        let scene = with_lighting(self.scenes.load(&spec.scene).await?, &spec)?;
        runner::check_camera(&scene, &spec.camera)?;
        if self.shutting_down.load(Ordering::SeqCst) {
            return Err(ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "shutting_down",
                "this API server is shutting down; submit again (to another one, or once it \
                 is back)",
            ));
        }
        self.check_quota().await?;
        let record = JobRecord::queued(0, spec);
        let max_queue = self.config.max_queue as u64;
        let max_jobs = self.config.max_jobs as u64;
        let time_limit_s = Some(self.config.job_time_limit_s).filter(|&s| s > 0);
        match (self.queue)
            .insert(record, lane, max_queue, max_jobs, time_limit_s)
            .await?
        {
            Ok(record) => {
                self.metrics.submitted.inc();
                Ok(record)
            }
            Err(Refused::QueueFull(queued)) => {
                self.metrics.rejected_queue_full.inc();
                Err(ApiError::queue_full(queued as usize, 10))
            }
            Err(Refused::JobLimit(_)) => {
                self.metrics.rejected_job_limit.inc();
                Err(ApiError::job_limit(self.config.max_jobs))
            }
        }
    }

    /// 507 `quota_exceeded` once the store holds `--max-stored-bytes`.
    async fn check_quota(&self) -> Result<(), ApiError> {
        let quota = self.config.max_stored_bytes;
        if quota == 0 {
            return Ok(());
        }
        let used = self.objects.size("").await?;
        if used < quota {
            return Ok(());
        }
        Err(ApiError::quota_exceeded("the object store", used, quota))
    }

    async fn readable(&self, id: u64) -> Result<JobRecord, ApiError> {
        match self.queue.record(id).await? {
            None => Err(job_not_found(id)),
            Some(Err(error)) => Err(job_unreadable(id, &error)),
            Some(Ok(record)) => Ok(record),
        }
    }

    async fn delete(self: Arc<Self>, id: u64) -> Result<serde_json::Value, ApiError> {
        let view = self
            .queue
            .view(id)
            .await?
            .ok_or_else(|| job_not_found(id))?;
        let readable = self.queue.record(id).await?.and_then(Result::ok);
        if let Some(record) = readable.filter(|r| !r.state.is_final()) {
            let cancelled = self
                .queue
                .transition(record.id, |record| {
                    if record.state.is_final() {
                        return false;
                    }
                    record.finished_at = Some(now_rfc3339());
                    record.state = JobState::Cancelled;
                    true
                })
                .await?;
            if cancelled.is_none() {
                // It finished meanwhile: deleting it now would surprise the caller.
                let record = self.readable(id).await?;
                return Err(ApiError::new(
                    StatusCode::CONFLICT,
                    "job_finished",
                    format!("job {id} is already {}", record.state.name()),
                ));
            }
            return self.queue.view(id).await?.ok_or_else(|| job_not_found(id));
        }
        // Images first: a crash between the two leaves a finished job without images
        // rather than images no job lists.
        self.objects.delete_folder(&format!("jobs/{id}")).await?;
        if !self.queue.delete_finished(id).await? {
            return Err(job_not_found(id));
        }
        let mut view = view;
        view["deleted"] = serde_json::Value::Bool(true);
        Ok(view)
    }

    async fn health(self: Arc<Self>) -> (StatusCode, serde_json::Value) {
        let mut problems = Vec::new();
        let database = self.queue.ping().await;
        if let Err(error) = &database {
            problems.push(error.message.clone());
        }
        let probe = "healthz";
        let store = match self.objects.put(probe, b"ok".to_vec()).await {
            Ok(()) => self.objects.delete(probe).await,
            Err(error) => Err(error),
        };
        if let Err(error) = &store {
            problems.push(error.message.clone());
        }
        let counts = self.queue.counts().await.ok();
        let workers = self.queue.workers(self.lease()).await.unwrap_or_default();
        let reachable = problems.is_empty();
        let status = match (self.shutting_down.load(Ordering::SeqCst), reachable) {
            (true, _) => "shutting_down",
            (false, false) => "unavailable",
            (false, true) if workers.is_empty() => "degraded",
            (false, true) => "ok",
        };
        if workers.is_empty() && reachable {
            problems.push(
                "no worker has beaten within the lease: queued jobs wait until a gi-worker \
                 runs"
                    .to_string(),
            );
        }
        let code = if reachable {
            StatusCode::OK
        } else {
            StatusCode::SERVICE_UNAVAILABLE
        };
        let body = json!({
            "status": status,
            "version": env!("CARGO_PKG_VERSION"),
            "mode": "scale-out",
            "queue_depth": counts.map(|c| c[JobState::Queued.index()]),
            "running": counts.map(|c| c[JobState::Running.index()]),
            "workers": workers,
            "storage": {
                "database": database.is_ok(),
                "store": store.is_ok(),
                "store_url": self.objects.url(),
            },
            "problems": problems,
        });
        (code, body)
    }

    fn lease(&self) -> Duration {
        Duration::from_secs(self.config.lease_s)
    }

    async fn metrics_text(self: Arc<Self>) -> Result<String, ApiError> {
        let counts = self.queue.counts().await?;
        let workers = self.queue.workers(self.lease()).await?;
        let used_bytes = self.objects.size("").await?;
        let disk = DiskUsage {
            used_bytes,
            free_bytes: None,
        };
        let gpus = workers.iter().filter(|w| w.gpu.is_some()).count();
        let mut body = self.metrics.render(counts, gpus > 0, disk);
        body.push_str(&format!(
            "# HELP gi_workers Workers heard from within the lease.\n# TYPE gi_workers gauge\n\
             gi_workers {}\n\
             # HELP gi_workers_gpu Workers with a GPU heard from within the lease.\n\
             # TYPE gi_workers_gpu gauge\ngi_workers_gpu {gpus}\n",
            workers.len()
        ));
        Ok(body)
    }

    async fn scenes(self: Arc<Self>) -> Result<serde_json::Value, ApiError> {
        let mut scenes: Vec<SceneInfo> = (self.scenes.catalog.list().into_iter())
            .filter(|scene| scene.source != "uploaded")
            .collect();
        for key in self.objects.list("scenes").await? {
            if !key.ends_with(".json") {
                continue;
            }
            let Some(bytes) = self.objects.get(&key).await? else {
                continue;
            };
            match serde_json::from_slice::<UploadedScene>(&bytes) {
                Ok(scene) => scenes.push(SceneInfo {
                    name: scene.id.clone(),
                    source: "uploaded",
                    description: format!("{} ({} triangles)", scene.name, scene.triangles),
                    upload: Some(scene),
                }),
                Err(error) => tracing::warn!("{key} in the store: {error}; not listed"),
            }
        }
        Ok(json!(scenes))
    }

    async fn upload_scene(
        self: Arc<Self>,
        bytes: bytes::Bytes,
        name: String,
    ) -> Result<(serde_json::Value, bool), ApiError> {
        self.check_quota().await?;
        let api = self.clone();
        let glb = bytes.clone();
        let (scene, _) = tokio::task::spawn_blocking(move || {
            api.scenes
                .catalog
                .upload(&glb, &name, api.config.max_upload_texels)
        })
        .await
        .map_err(|e| {
            ApiError::invalid(
                "invalid_scene",
                format!("the scene could not be imported: {e}"),
            )
        })??;
        let description = format!("scenes/{}.json", scene.id);
        let created = self.objects.get(&description).await?.is_none();
        if created {
            // The file goes in before the description that lists it.
            self.objects
                .put(&format!("scenes/{}.glb", scene.id), bytes.to_vec())
                .await?;
            let json = serde_json::to_vec_pretty(&scene).expect("the scene serializes");
            self.objects.put(&description, json).await?;
        }
        Ok((json!(scene), created))
    }

    async fn delete_scene(self: Arc<Self>, id: String) -> Result<serde_json::Value, ApiError> {
        if !id.starts_with(UPLOAD_PREFIX) {
            // Refused as the embedded service refuses it (bundled, folder or unknown).
            return self.scenes.catalog.delete(&id).map(|scene| json!(scene));
        }
        let users = self.queue.jobs_using(&id).await?;
        if !users.is_empty() {
            return Err(ApiError::new(
                StatusCode::CONFLICT,
                "scene_in_use",
                format!(
                    "jobs {users:?} are queued or running with scene {id}; delete it once they \
                     end (or cancel them)"
                ),
            ));
        }
        let description = format!("scenes/{id}.json");
        let Some(bytes) = self.objects.get(&description).await? else {
            return Err(crate::scenes::scene_not_found(&id));
        };
        let scene: UploadedScene = serde_json::from_slice(&bytes)
            .map_err(|e| ApiError::internal(format!("{description} in the store: {e}")))?;
        // The description first: a crash leaves at most an unlisted file.
        self.objects.delete(&description).await?;
        self.objects.delete(&format!("scenes/{id}.glb")).await?;
        self.scenes.forget(&id);
        Ok(json!(scene))
    }
}

impl Backend for ClusterApi {
    fn config(&self) -> &Config {
        &self.config
    }

    fn metrics(&self) -> &Metrics {
        &self.metrics
    }

    fn shut_down(&self) {
        self.shutting_down.store(true, Ordering::SeqCst);
    }

    fn stopped(self: Arc<Self>) -> BoxFuture<'static, ()> {
        // Nothing runs here: the jobs are the workers'.
        async {}.boxed()
    }

    fn submit(
        self: Arc<Self>,
        request: JobRequest,
    ) -> BoxFuture<'static, Result<JobRecord, ApiError>> {
        ClusterApi::submit(self, request).boxed()
    }

    fn view(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        async move { self.queue.view(id).await?.ok_or_else(|| job_not_found(id)) }.boxed()
    }

    fn record(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<JobRecord, ApiError>> {
        async move { self.readable(id).await }.boxed()
    }

    fn list(
        self: Arc<Self>,
        limit: usize,
        before: Option<u64>,
        state: Option<StateFilter>,
    ) -> BoxFuture<'static, Result<JobPage, ApiError>> {
        async move { self.queue.list(limit, before, state).await }.boxed()
    }

    fn delete(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        ClusterApi::delete(self, id).boxed()
    }

    fn image(
        self: Arc<Self>,
        id: u64,
        file: &'static str,
    ) -> BoxFuture<'static, Result<Vec<u8>, ApiError>> {
        async move {
            match self.objects.get(&job_key(id, file)).await? {
                Some(bytes) => Ok(bytes.to_vec()),
                None => Err(ApiError::internal(format!(
                    "job {id} is done but its {file} is missing from the object store"
                ))),
            }
        }
        .boxed()
    }

    fn health(self: Arc<Self>) -> BoxFuture<'static, (StatusCode, serde_json::Value)> {
        ClusterApi::health(self).boxed()
    }

    fn metrics_text(self: Arc<Self>) -> BoxFuture<'static, Result<String, ApiError>> {
        ClusterApi::metrics_text(self).boxed()
    }

    fn scenes(self: Arc<Self>) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        ClusterApi::scenes(self).boxed()
    }

    fn upload_scene(
        self: Arc<Self>,
        bytes: bytes::Bytes,
        name: String,
    ) -> BoxFuture<'static, Result<(serde_json::Value, bool), ApiError>> {
        ClusterApi::upload_scene(self, bytes, name).boxed()
    }

    fn delete_scene(
        self: Arc<Self>,
        id: String,
    ) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        ClusterApi::delete_scene(self, id).boxed()
    }
}

//! What the HTTP layer asks of the service behind it. Two services answer: the embedded one
//! ([`crate::service::Service`]: one process, its data folder, its own workers) and the
//! scale-out API ([`crate::cluster::ClusterApi`]: stateless over a PostgreSQL job queue and
//! an object store, with `gi-worker` processes rendering). The routes, their answers and
//! their errors are the same for both.

use std::sync::Arc;

use axum::http::StatusCode;
use futures_util::future::BoxFuture;

use crate::{
    config::Config,
    error::ApiError,
    job::{JobRecord, JobRequest, StateFilter},
    metrics::Metrics,
};

/// One page of `GET /v1/jobs`: the jobs as the API shows them, newest first, and how many
/// match in all.
pub type JobPage = (Vec<serde_json::Value>, usize);

/// The service behind the routes. Methods take `Arc<Self>` so the work they start outlives a
/// client that goes away.
pub trait Backend: Send + Sync + 'static {
    fn config(&self) -> &Config;

    /// The counters of this process (requests, connections, renders).
    fn metrics(&self) -> &Metrics;

    /// Starts a graceful stop: nothing new is taken; running work stops at its next frame.
    fn shut_down(&self);

    /// Once requests are drained and workers stopped (or the grace period ended): leaves the
    /// stored state so a restart goes on where this process stopped.
    fn stopped(self: Arc<Self>) -> BoxFuture<'static, ()>;

    /// Validates a job request and queues it; answers the new job's record.
    fn submit(
        self: Arc<Self>,
        request: JobRequest,
    ) -> BoxFuture<'static, Result<JobRecord, ApiError>>;

    /// Job `id` as the API shows it.
    fn view(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>>;

    /// Job `id`'s record (404 for no job, 500 `unreadable_record` for one that cannot be read).
    fn record(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<JobRecord, ApiError>>;

    /// Up to `limit` jobs, newest first, with ids below `before`, in `state` if given.
    fn list(
        self: Arc<Self>,
        limit: usize,
        before: Option<u64>,
        state: Option<StateFilter>,
    ) -> BoxFuture<'static, Result<JobPage, ApiError>>;

    /// `DELETE /v1/jobs/{id}`: cancels a queued or running job, deletes a finished one with its
    /// images.
    fn delete(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>>;

    /// The bytes of a finished job's image `file` (one of [`crate::job::IMAGE_FILES`]).
    fn image(
        self: Arc<Self>,
        id: u64,
        file: &'static str,
    ) -> BoxFuture<'static, Result<Vec<u8>, ApiError>>;

    /// `GET /healthz`: its status code and body.
    fn health(self: Arc<Self>) -> BoxFuture<'static, (StatusCode, serde_json::Value)>;

    /// `GET /metrics`: the Prometheus text.
    fn metrics_text(self: Arc<Self>) -> BoxFuture<'static, Result<String, ApiError>>;

    /// `GET /v1/scenes`.
    fn scenes(self: Arc<Self>) -> BoxFuture<'static, Result<serde_json::Value, ApiError>>;

    /// `POST /v1/scenes`: the uploaded scene, and whether it is new.
    fn upload_scene(
        self: Arc<Self>,
        bytes: bytes::Bytes,
        name: String,
    ) -> BoxFuture<'static, Result<(serde_json::Value, bool), ApiError>>;

    /// `DELETE /v1/scenes/{id}`.
    fn delete_scene(
        self: Arc<Self>,
        id: String,
    ) -> BoxFuture<'static, Result<serde_json::Value, ApiError>>;
}

/// Runs blocking work on tokio's blocking pool, which finishes it even if the client goes
/// away meanwhile.
pub async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(work)
        .await
        .map_err(|e| ApiError::internal(e.to_string()))?
}

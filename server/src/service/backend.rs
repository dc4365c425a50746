//! The embedded service behind the HTTP routes.

use std::sync::Arc;

use axum::http::StatusCode;
use futures_util::{FutureExt, future::BoxFuture};
use serde_json::json;

use super::{Service, job_not_found};
use crate::{
    backend::{Backend, JobPage, blocking},
    config::Config,
    error::ApiError,
    job::{JobRecord, JobRequest, StateFilter},
    metrics::{DiskUsage, Metrics},
};

impl Backend for Service {
    fn config(&self) -> &Config {
        &self.config
    }

    fn metrics(&self) -> &Metrics {
        &self.metrics
    }

    fn shut_down(&self) {
        Service::shut_down(self);
    }

    fn stopped(self: Arc<Self>) -> BoxFuture<'static, ()> {
        async move {
            let _ = tokio::task::spawn_blocking(move || self.requeue_running_blocking()).await;
        }
        .boxed()
    }

    fn submit(
        self: Arc<Self>,
        request: JobRequest,
    ) -> BoxFuture<'static, Result<JobRecord, ApiError>> {
        async move { Service::submit(&self, request).await }.boxed()
    }

    fn view(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        async move { Service::view(&self, id).ok_or_else(|| job_not_found(id)) }.boxed()
    }

    fn record(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<JobRecord, ApiError>> {
        async move { self.readable_record(id) }.boxed()
    }

    fn list(
        self: Arc<Self>,
        limit: usize,
        before: Option<u64>,
        state: Option<StateFilter>,
    ) -> BoxFuture<'static, Result<JobPage, ApiError>> {
        async move { Ok(Service::list(&self, limit, before, state)) }.boxed()
    }

    fn delete(self: Arc<Self>, id: u64) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        async move { Service::delete(&self, id).await }.boxed()
    }

    fn image(
        self: Arc<Self>,
        id: u64,
        file: &'static str,
    ) -> BoxFuture<'static, Result<Vec<u8>, ApiError>> {
        let path = self.store.job_dir(id).join(file);
        blocking(move || {
            std::fs::read(path)
                .map_err(|e| ApiError::internal(format!("reading {file} of job {id}: {e}")))
        })
        .boxed()
    }

    fn health(self: Arc<Self>) -> BoxFuture<'static, (StatusCode, serde_json::Value)> {
        async move {
            match blocking(move || Ok(self.health_blocking())).await {
                Ok(answer) => answer,
                Err(error) => (
                    StatusCode::INTERNAL_SERVER_ERROR,
                    json!({ "status": "unavailable", "problems": [error.message] }),
                ),
            }
        }
        .boxed()
    }

    fn metrics_text(self: Arc<Self>) -> BoxFuture<'static, Result<String, ApiError>> {
        async move {
            let measured = self.clone();
            let disk = blocking(move || {
                Ok(DiskUsage {
                    used_bytes: measured
                        .metrics
                        .data_dir_used_bytes(&measured.config.data_dir),
                    free_bytes: measured.store.free_bytes(),
                })
            })
            .await?;
            let mut body = self.metrics.render(self.counts(), self.gpu.is_some(), disk);
            body.push_str(&self.record_metrics());
            Ok(body)
        }
        .boxed()
    }

    fn scenes(self: Arc<Self>) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        async move { Ok(json!(self.catalog.list())) }.boxed()
    }

    fn upload_scene(
        self: Arc<Self>,
        bytes: bytes::Bytes,
        name: String,
    ) -> BoxFuture<'static, Result<(serde_json::Value, bool), ApiError>> {
        async move {
            let (scene, created) =
                tokio::task::spawn_blocking(move || self.upload_scene_blocking(&bytes, &name))
                    .await
                    .map_err(|e| {
                        // The importer panicked on this file.
                        ApiError::invalid(
                            "invalid_scene",
                            format!("the scene could not be imported: {e}"),
                        )
                    })??;
            Ok((json!(scene), created))
        }
        .boxed()
    }

    fn delete_scene(
        self: Arc<Self>,
        id: String,
    ) -> BoxFuture<'static, Result<serde_json::Value, ApiError>> {
        blocking(move || self.delete_scene_blocking(&id).map(|scene| json!(scene))).boxed()
    }
}

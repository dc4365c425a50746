//! What `/healthz` and `/metrics` say about the service beyond its counters: the data folder's
//! disk and the jobs whose record cannot be read.

use axum::http::StatusCode;
use serde_json::json;

use super::Service;
use crate::{error::ApiError, job::JobState};

impl Service {
    /// Refuses new work (507) while the data folder's disk has less free space than
    /// `--min-free-bytes`, so jobs already accepted keep the room to store their results.
    pub fn check_free_space(&self) -> Result<(), ApiError> {
        match self.store.free_bytes() {
            Some(free) if free < self.config.min_free_bytes => {
                Err(ApiError::low_on_disk(free, self.config.min_free_bytes))
            }
            _ => Ok(()),
        }
    }

    /// Refuses new work (507 `quota_exceeded`) once the data folder holds `--max-stored-bytes`
    /// (its size measured at most about a second before). Blocking: it may walk the folder.
    pub fn check_quota(&self) -> Result<(), ApiError> {
        let quota = self.config.max_stored_bytes;
        if quota == 0 {
            return Ok(());
        }
        let used = self.metrics.data_dir_used_bytes(&self.config.data_dir);
        if used < quota {
            return Ok(());
        }
        Err(ApiError::quota_exceeded("the data folder", used, quota))
    }

    /// `GET /healthz`: its status code and body. Blocking (it writes a probe file).
    ///
    /// 503 when the data folder cannot be written or has less free space than
    /// `--min-free-bytes`: accepted work could not be stored. 200 with status `degraded` when
    /// job records could not be read at startup: the service works, and restarting it would
    /// not repair them, so it stays in rotation while a person looks (`problems` says what).
    pub fn health_blocking(&self) -> (StatusCode, serde_json::Value) {
        let counts = self.counts();
        let unreadable = self.unreadable_count();
        let free_bytes = self.store.free_bytes();
        let writable = self.store.check_writable();
        let mut problems = Vec::new();
        if let Err(error) = &writable {
            problems.push(format!("the data folder cannot be written: {error}"));
        }
        let low = free_bytes.filter(|&free| free < self.config.min_free_bytes);
        if let Some(free) = low {
            problems.push(format!(
                "the data folder's disk has {free} bytes free, less than the {} kept free \
                 (--min-free-bytes): new jobs and uploads are refused",
                self.config.min_free_bytes
            ));
        }
        let storage_ok = problems.is_empty();
        if unreadable > 0 {
            problems.push(format!(
                "{unreadable} job records could not be read (listed with state unreadable); \
                 repair or remove their folders, then restart"
            ));
        }
        let status = match (self.is_shutting_down(), storage_ok, unreadable) {
            (true, _, _) => "shutting_down",
            (false, false, _) => "unavailable",
            (false, true, 0) => "ok",
            (false, true, _) => "degraded",
        };
        let code = if storage_ok {
            StatusCode::OK
        } else {
            StatusCode::SERVICE_UNAVAILABLE
        };
        let body = json!({
            "status": status,
            "version": env!("CARGO_PKG_VERSION"),
            "gpu": self.gpu,
            "queue_depth": counts[JobState::Queued.index()],
            "running": counts[JobState::Running.index()],
            "unreadable_jobs": unreadable,
            "storage": {
                "writable": writable.is_ok(),
                "free_bytes": free_bytes,
                "min_free_bytes": self.config.min_free_bytes,
            },
            "problems": problems,
        });
        (code, body)
    }

    /// The Prometheus text of what the counters do not hold: job folders whose record could
    /// not be read.
    pub fn record_metrics(&self) -> String {
        format!(
            "# HELP gi_jobs_unreadable Job folders whose record could not be read at startup \
             (listed with state unreadable).\n# TYPE gi_jobs_unreadable gauge\n\
             gi_jobs_unreadable {}\n",
            self.unreadable_count()
        )
    }
}

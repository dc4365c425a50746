//! Errors as the API answers them: `{ "error": { "code", "message" } }` with a status.

use axum::{
    Json,
    extract::rejection::{BytesRejection, JsonRejection, QueryRejection},
    http::{HeaderValue, StatusCode, header},
    response::{IntoResponse, Response},
};
use serde_json::json;

/// An error answer: the HTTP status, a stable machine-readable code and a message for people.
#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
    /// Seconds after which the same request may succeed (sent as `Retry-After`).
    pub retry_after_s: Option<u64>,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        Self {
            status,
            code,
            message: message.into(),
            retry_after_s: None,
        }
    }

    /// 422: the request is well-formed but asks for something this service cannot do.
    pub fn invalid(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNPROCESSABLE_ENTITY, code, message)
    }

    pub fn not_found(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, code, message)
    }

    /// 500, for failures of the service itself (its disk, a lost worker).
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", message)
    }

    /// A failure to store `what` in the data folder: 507 `insufficient_storage` when its disk
    /// (or the service's quota) is full, else 500 `internal`. Nothing was accepted or changed.
    pub fn storage(what: &str, error: &std::io::Error) -> Self {
        if is_disk_full(error) {
            Self::new(
                StatusCode::INSUFFICIENT_STORAGE,
                "insufficient_storage",
                format!(
                    "storing {what} failed: the data folder's disk is full ({error}); nothing \
                     was changed, retry once space is freed"
                ),
            )
        } else {
            Self::internal(format!(
                "storing {what} failed: {error}; nothing was changed"
            ))
        }
    }

    /// 429 `queue_full`: `queued` jobs wait, the most the service queues; retry after
    /// `retry_after_s`.
    pub fn queue_full(queued: usize, retry_after_s: u64) -> Self {
        let mut error = Self::new(
            StatusCode::TOO_MANY_REQUESTS,
            "queue_full",
            format!("{queued} jobs are waiting, the most this service queues; retry later"),
        );
        error.retry_after_s = Some(retry_after_s);
        error
    }

    /// 429 `job_limit`: the service keeps `max_jobs` jobs, finished ones included.
    pub fn job_limit(max_jobs: usize) -> Self {
        let mut error = Self::new(
            StatusCode::TOO_MANY_REQUESTS,
            "job_limit",
            format!("the service keeps at most {max_jobs} jobs and has them all"),
        );
        error.retry_after_s = Some(60);
        error
    }

    /// 507 `quota_exceeded`: `place` (the data folder, the object store) holds `used` bytes,
    /// at or past the `quota` of `--max-stored-bytes`.
    pub fn quota_exceeded(place: &str, used: u64, quota: u64) -> Self {
        Self::new(
            StatusCode::INSUFFICIENT_STORAGE,
            "quota_exceeded",
            format!(
                "{place} holds {used} bytes, the {quota} this service may store \
                 (--max-stored-bytes); delete finished jobs (DELETE /v1/jobs/{{id}}) or \
                 uploaded scenes (DELETE /v1/scenes/{{id}}), then retry"
            ),
        )
    }

    /// 422 `unknown_tier`.
    pub fn unknown_tier(tier: &str) -> Self {
        Self::invalid(
            "unknown_tier",
            format!(
                "unknown tier {tier:?} (available: auto, {})",
                gi_tiers::TierKind::ALL
                    .map(gi_tiers::TierKind::name)
                    .join(", ")
            ),
        )
    }

    /// 507: the data folder has less free space than the service keeps free.
    pub fn low_on_disk(free_bytes: u64, min_free_bytes: u64) -> Self {
        Self::new(
            StatusCode::INSUFFICIENT_STORAGE,
            "insufficient_storage",
            format!(
                "the data folder's disk has {free_bytes} bytes free, less than the \
                 {min_free_bytes} this service keeps free (--min-free-bytes); retry once space \
                 is freed"
            ),
        )
    }
}

/// True for the errors of a full disk or an exhausted quota (ENOSPC, EDQUOT).
pub fn is_disk_full(error: &std::io::Error) -> bool {
    matches!(
        error.kind(),
        std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
    )
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}): {}", self.status, self.code, self.message)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = json!({ "error": { "code": self.code, "message": self.message } });
        let mut response = (self.status, Json(body)).into_response();
        if let Some(seconds) = self.retry_after_s {
            response
                .headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(seconds));
        }
        response
    }
}

impl From<JsonRejection> for ApiError {
    fn from(rejection: JsonRejection) -> Self {
        match rejection {
            JsonRejection::JsonDataError(e) => {
                Self::invalid("invalid_request", e.body_text().replace("\n", " "))
            }
            JsonRejection::JsonSyntaxError(e) => Self::new(
                StatusCode::BAD_REQUEST,
                "malformed_json",
                e.body_text().replace("\n", " "),
            ),
            JsonRejection::MissingJsonContentType(_) => Self::new(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "unsupported_media_type",
                "send the job as JSON with `Content-Type: application/json`",
            ),
            JsonRejection::BytesRejection(e) => from_bytes_rejection(e),
            other => Self::new(StatusCode::BAD_REQUEST, "bad_request", other.body_text()),
        }
    }
}

impl From<BytesRejection> for ApiError {
    fn from(rejection: BytesRejection) -> Self {
        from_bytes_rejection(rejection)
    }
}

fn from_bytes_rejection(rejection: BytesRejection) -> ApiError {
    if rejection.status() == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "payload_too_large",
            "the request body is larger than this service accepts",
        )
    } else {
        ApiError::new(rejection.status(), "bad_request", rejection.body_text())
    }
}

impl From<QueryRejection> for ApiError {
    fn from(rejection: QueryRejection) -> Self {
        Self::new(
            StatusCode::BAD_REQUEST,
            "invalid_query",
            rejection.body_text(),
        )
    }
}

impl From<ApiError> for crate::job::JobFailure {
    fn from(error: ApiError) -> Self {
        Self {
            code: error.code.to_string(),
            message: error.message,
        }
    }
}

//! The HTTP API: the route table, the router built from it and the handlers.

use std::{sync::Arc, time::Instant};

use axum::{
    Json, Router,
    body::{Body, Bytes},
    extract::{
        DefaultBodyLimit, Path, Query, Request, State,
        rejection::{BytesRejection, JsonRejection, QueryRejection},
    },
    http::{HeaderMap, HeaderValue, Method, StatusCode, Uri, header},
    middleware::{self, Next},
    response::{IntoResponse, Response},
    routing::{MethodRouter, delete, get},
};
use serde::Deserialize;
use serde_json::json;

use crate::{
    access::{self, Access},
    backend::Backend,
    error::ApiError,
    job::{IMAGE_FILES, JobRequest, JobState, StateFilter},
    openapi,
    service::job_not_found,
    web,
};

type AppState = Arc<dyn Backend>;

/// Every route the router serves: path and methods. The router is built from this table and
/// `/openapi.json` must describe exactly these (a test holds them together).
pub const ROUTES: &[(&str, &[&str])] = &[
    ("/", &["GET"]),
    ("/app.js", &["GET"]),
    ("/style.css", &["GET"]),
    ("/healthz", &["GET"]),
    ("/metrics", &["GET"]),
    ("/openapi.json", &["GET"]),
    ("/v1/jobs", &["GET", "POST"]),
    ("/v1/jobs/{id}", &["GET", "DELETE"]),
    ("/v1/jobs/{id}/image.png", &["GET"]),
    ("/v1/jobs/{id}/image.exr", &["GET"]),
    ("/v1/jobs/{id}/reference.png", &["GET"]),
    ("/v1/jobs/{id}/error.png", &["GET"]),
    ("/v1/jobs/{id}/flip.png", &["GET"]),
    ("/v1/scenes", &["GET", "POST"]),
    ("/v1/scenes/{id}", &["DELETE"]),
];

/// Largest job request body: a job is a few hundred bytes of JSON.
const MAX_JOB_BODY_BYTES: usize = 64 << 10;

/// The handlers of `path`.
fn method_router(path: &str, service: &dyn Backend) -> MethodRouter<AppState> {
    match path {
        "/" => get(web::index),
        "/app.js" => get(web::script),
        "/style.css" => get(web::style),
        "/healthz" => get(healthz),
        "/metrics" => get(metrics),
        "/openapi.json" => get(openapi_json),
        "/v1/jobs" => get(list_jobs)
            .post(submit_job)
            .layer(DefaultBodyLimit::max(MAX_JOB_BODY_BYTES)),
        "/v1/jobs/{id}" => get(get_job).delete(delete_job),
        "/v1/jobs/{id}/image.png" => {
            get(|s: State<AppState>, p: Path<String>| job_file(s, p, "image.png"))
        }
        "/v1/jobs/{id}/image.exr" => {
            get(|s: State<AppState>, p: Path<String>| job_file(s, p, "image.exr"))
        }
        "/v1/jobs/{id}/reference.png" => {
            get(|s: State<AppState>, p: Path<String>| job_file(s, p, "reference.png"))
        }
        "/v1/jobs/{id}/error.png" => {
            get(|s: State<AppState>, p: Path<String>| job_file(s, p, "error.png"))
        }
        "/v1/jobs/{id}/flip.png" => {
            get(|s: State<AppState>, p: Path<String>| job_file(s, p, "flip.png"))
        }
        "/v1/scenes" => get(list_scenes)
            .post(upload_scene)
            .layer(DefaultBodyLimit::max(service.config().max_upload_bytes)),
        "/v1/scenes/{id}" => delete(delete_scene),
        other => unreachable!("route {other} is in ROUTES but has no handler"),
    }
}

/// The router over [`ROUTES`], with JSON answers for unknown paths and methods, every
/// request checked by `access` and counted in the metrics.
pub fn router(service: AppState, access: Arc<Access>) -> Router {
    let mut router = Router::new();
    for (path, _) in ROUTES {
        router = router.route(path, method_router(path, service.as_ref()));
    }
    router
        .fallback(no_route)
        .method_not_allowed_fallback(method_not_allowed)
        .with_state(service.clone())
        .layer(middleware::from_fn_with_state(access, access::check))
        // Outermost, so refused requests (421, 401) are counted too.
        .layer(middleware::from_fn_with_state(service, count_request))
}

/// Counts a request in the metrics by its route template (`unmatched` for unknown paths),
/// method and status, with the time until its answer's head.
async fn count_request(State(service): State<AppState>, request: Request, next: Next) -> Response {
    let route = ROUTES
        .iter()
        .find(|(pattern, _)| path_matches(pattern, request.uri().path()))
        .map_or("unmatched", |(pattern, _)| pattern);
    let method = match *request.method() {
        Method::GET => "GET",
        Method::HEAD => "HEAD",
        Method::POST => "POST",
        Method::PUT => "PUT",
        Method::DELETE => "DELETE",
        Method::PATCH => "PATCH",
        Method::OPTIONS => "OPTIONS",
        _ => "other",
    };
    let started = Instant::now();
    let response = next.run(request).await;
    service.metrics().add_request(
        route,
        method,
        response.status().as_u16(),
        started.elapsed().as_secs_f64(),
    );
    response
}

async fn no_route(method: Method, uri: Uri) -> ApiError {
    ApiError::not_found(
        "not_found",
        format!("no route for {method} {}; see /openapi.json", uri.path()),
    )
}

async fn method_not_allowed(method: Method, uri: Uri) -> ApiError {
    let allowed = ROUTES
        .iter()
        .find(|(path, _)| path_matches(path, uri.path()))
        .map(|(_, methods)| methods.join(", "))
        .unwrap_or_default();
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method_not_allowed",
        format!(
            "{method} is not allowed on {} (allowed: {allowed})",
            uri.path()
        ),
    )
}

/// True when `path` matches the route `pattern` (`{param}` matches one segment).
fn path_matches(pattern: &str, path: &str) -> bool {
    let (pattern, path): (Vec<_>, Vec<_>) =
        (pattern.split('/').collect(), path.split('/').collect());
    pattern.len() == path.len()
        && pattern
            .iter()
            .zip(&path)
            .all(|(p, s)| p == s || (p.starts_with('{') && p.ends_with('}') && !s.is_empty()))
}

/// 503 when the data folder cannot take writes, 200 otherwise (see
/// `Service::health_blocking`).
async fn healthz(State(service): State<AppState>) -> Response {
    let (status, body) = service.health().await;
    (status, Json(body)).into_response()
}

async fn metrics(State(service): State<AppState>) -> Result<Response, ApiError> {
    let body = service.metrics_text().await?;
    Ok((
        [(
            header::CONTENT_TYPE,
            HeaderValue::from_static("text/plain; version=0.0.4; charset=utf-8"),
        )],
        body,
    )
        .into_response())
}

async fn openapi_json(State(service): State<AppState>) -> Json<serde_json::Value> {
    Json(openapi::document(service.config()))
}

async fn submit_job(
    State(service): State<AppState>,
    body: Result<Json<JobRequest>, JsonRejection>,
) -> Result<Response, ApiError> {
    let Json(request) = body?;
    let record = service.submit(request).await?;
    let url = format!("/v1/jobs/{}", record.id);
    let mut response = (
        StatusCode::ACCEPTED,
        Json(json!({ "id": record.id.to_string(), "url": url, "state": record.state })),
    )
        .into_response();
    if let Ok(location) = HeaderValue::from_str(&url) {
        response.headers_mut().insert(header::LOCATION, location);
    }
    Ok(response)
}

/// Query of `GET /v1/jobs`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ListQuery {
    /// Jobs per page, 1..=100 (default 20).
    limit: Option<usize>,
    /// Only jobs with a smaller id (the previous page's `next` sets it).
    before: Option<u64>,
    /// Only jobs in this state (or `unreadable`: those whose record cannot be read).
    state: Option<StateFilter>,
}

async fn list_jobs(
    State(service): State<AppState>,
    query: Result<Query<ListQuery>, QueryRejection>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let Query(query) = query?;
    let limit = query.limit.unwrap_or(20);
    if !(1..=100).contains(&limit) {
        return Err(ApiError::new(
            StatusCode::BAD_REQUEST,
            "invalid_query",
            format!("limit {limit} is out of range (1..=100)"),
        ));
    }
    let (jobs, total) = service.list(limit, query.before, query.state).await?;
    let next = (jobs.len() == limit)
        .then(|| jobs.last())
        .flatten()
        .and_then(|job| job["id"].as_str().map(str::to_string))
        .map(|last| {
            let state = query
                .state
                .map(|s| format!("&state={}", s.name()))
                .unwrap_or_default();
            format!("/v1/jobs?limit={limit}&before={last}{state}")
        });
    Ok(Json(json!({ "jobs": jobs, "total": total, "next": next })))
}

fn parse_id(id: &str) -> Result<u64, ApiError> {
    id.parse().map_err(|_| job_not_found(format!("{id:?}")))
}

async fn get_job(
    State(service): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let id = parse_id(&id)?;
    service.view(id).await.map(Json)
}

async fn delete_job(
    State(service): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let id = parse_id(&id)?;
    service.delete(id).await.map(Json)
}

async fn delete_scene(
    State(service): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let scene = service.delete_scene(id).await?;
    Ok(Json(json!({ "scene": scene, "deleted": true })))
}

async fn job_file(
    State(service): State<AppState>,
    Path(id): Path<String>,
    file: &'static str,
) -> Result<Response, ApiError> {
    debug_assert!(IMAGE_FILES.contains(&file));
    let id = parse_id(&id)?;
    let record = service.clone().record(id).await?;
    if record.state != JobState::Done {
        return Err(ApiError::not_found(
            "image_not_ready",
            format!(
                "job {id} is {}; its images exist once it is done",
                record.state.name()
            ),
        ));
    }
    if let Some(why) = record.missing_image(file) {
        return Err(ApiError::not_found(
            "image_not_found",
            format!("job {id} {why}, so it has no {file}"),
        ));
    }
    let bytes = service.image(id, file).await?;
    let content_type = if file.ends_with(".exr") {
        "image/x-exr"
    } else {
        "image/png"
    };
    Ok((
        [
            (header::CONTENT_TYPE, content_type),
            // A finished job's images never change.
            (header::CACHE_CONTROL, "private, max-age=86400"),
        ],
        Body::from(bytes),
    )
        .into_response())
}

async fn list_scenes(State(service): State<AppState>) -> Result<Json<serde_json::Value>, ApiError> {
    Ok(Json(json!({ "scenes": service.scenes().await? })))
}

/// Query of `POST /v1/scenes`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct UploadQuery {
    /// A name for people (jobs use the returned id).
    name: Option<String>,
}

async fn upload_scene(
    State(service): State<AppState>,
    query: Result<Query<UploadQuery>, QueryRejection>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, ApiError> {
    let Query(query) = query?;
    let content_type = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    let essence = content_type.split(';').next().unwrap_or("").trim();
    if !matches!(essence, "model/gltf-binary" | "application/octet-stream") {
        return Err(ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported_media_type",
            "upload the .glb file as the body with `Content-Type: model/gltf-binary`",
        ));
    }
    let bytes = body?;
    let name = query.name.unwrap_or_default();
    let (scene, created) = service.clone().upload_scene(bytes, name).await?;
    if created {
        service.metrics().uploads.inc();
    }
    let status = if created {
        StatusCode::CREATED
    } else {
        StatusCode::OK
    };
    Ok((status, Json(json!({ "scene": scene }))).into_response())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn route_patterns_match_one_segment_per_parameter() {
        assert!(path_matches("/v1/jobs/{id}", "/v1/jobs/12"));
        assert!(!path_matches("/v1/jobs/{id}", "/v1/jobs/12/image.png"));
        assert!(!path_matches("/v1/jobs/{id}", "/v1/jobs/"));
        assert!(path_matches("/healthz", "/healthz"));
    }
}

//! The OpenAPI 3.1 document served at `/openapi.json`. Its paths are exactly the router's
//! ([`crate::api::ROUTES`]); a test checks both ways over HTTP.

use serde_json::{Value, json};

use crate::config::Config;

fn error_response(description: &str) -> Value {
    json!({
        "description": description,
        "content": { "application/json": { "schema": { "$ref": "#/components/schemas/Error" } } }
    })
}

fn json_response(description: &str, schema: Value) -> Value {
    json!({ "description": description, "content": { "application/json": { "schema": schema } } })
}

fn id_parameter() -> Value {
    json!({
        "name": "id", "in": "path", "required": true,
        "description": "The job's id, as returned by POST /v1/jobs.",
        "schema": { "type": "string", "pattern": "^[0-9]+$" }
    })
}

fn image_route(file: &str, media_type: &str, what: &str) -> Value {
    json!({
        "get": {
            "summary": format!("The job's {what}"),
            "operationId": format!("get_{}", file.replace('.', "_")),
            "parameters": [id_parameter()],
            "responses": {
                "200": { "description": what, "content": { media_type: { "schema": { "type": "string", "format": "binary" } } } },
                "404": error_response("No such job, the job is not done, or it did not compare (reference, error and FLIP maps)"),
                "409": error_response("The job's record could not be read (job_unreadable)")
            }
        }
    })
}

fn static_route(summary: &str, operation: &str, media_type: &str) -> Value {
    json!({
        "get": {
            "summary": summary,
            "operationId": operation,
            "responses": { "200": { "description": summary, "content": { media_type: { "schema": { "type": "string" } } } } }
        }
    })
}

/// The document, with the limits of this configuration in the request schema.
pub fn document(config: &Config) -> Value {
    let tiers: Vec<&str> = std::iter::once("auto")
        .chain(gi_tiers::TierKind::ALL.iter().map(|t| t.name()))
        .collect();
    let mut document = json!({
        "openapi": "3.1.0",
        "info": {
            "title": "gi render service",
            "version": env!("CARGO_PKG_VERSION"),
            "description": "Queued render jobs of the GI tiers, measured against the path-traced reference. Errors are {\"error\": {\"code\", \"message\"}}."
        },
        "paths": {
            "/": static_route("The web page: submit jobs, watch them, compare images", "web_page", "text/html"),
            "/app.js": static_route("The web page's script", "web_script", "text/javascript"),
            "/style.css": static_route("The web page's style sheet", "web_style", "text/css"),
            "/healthz": {
                "get": {
                    "summary": "Liveness, the data folder's storage, the GPU found at startup and the queue depth",
                    "operationId": "healthz",
                    "responses": {
                        "200": json_response("The service is up (status ok, or degraded when job records could not be read)", json!({ "$ref": "#/components/schemas/Health" })),
                        "503": json_response("The data folder cannot be written or has less free space than --min-free-bytes (status unavailable)", json!({ "$ref": "#/components/schemas/Health" }))
                    }
                }
            },
            "/metrics": static_route("Prometheus metrics: queue depth, jobs by state, GPU busy time, render seconds", "metrics", "text/plain"),
            "/openapi.json": {
                "get": {
                    "summary": "This document",
                    "operationId": "openapi",
                    "responses": { "200": json_response("The OpenAPI document", json!({ "type": "object" })) }
                }
            },
            "/v1/jobs": {
                "post": {
                    "summary": "Queue a render job",
                    "operationId": "submit_job",
                    "requestBody": {
                        "required": true,
                        "content": { "application/json": { "schema": { "$ref": "#/components/schemas/JobRequest" } } }
                    },
                    "responses": {
                        "202": {
                            "description": "Queued; poll its URL",
                            "headers": { "Location": { "schema": { "type": "string" } } },
                            "content": { "application/json": { "schema": { "$ref": "#/components/schemas/Accepted" } } }
                        },
                        "400": error_response("Malformed JSON"),
                        "413": error_response("The body is too large"),
                        "415": error_response("Not JSON"),
                        "422": error_response("Unknown scene, tier or camera, a limit exceeded (the estimated cost over --max-job-samples: job_too_costly), or a GPU tier without a GPU"),
                        "429": {
                            "description": "The queue is full (code queue_full) or the job limit is reached (job_limit); retry after Retry-After seconds",
                            "headers": { "Retry-After": { "schema": { "type": "integer" } } },
                            "content": { "application/json": { "schema": { "$ref": "#/components/schemas/Error" } } }
                        },
                        "500": error_response("The job could not be stored (an I/O error other than a full disk); nothing was queued"),
                        "503": error_response("The service is shutting down"),
                        "507": error_response("The data folder's disk is full, or below --min-free-bytes (insufficient_storage), or holds --max-stored-bytes (quota_exceeded); nothing was queued")
                    }
                },
                "get": {
                    "summary": "List jobs, newest first",
                    "operationId": "list_jobs",
                    "parameters": [
                        { "name": "limit", "in": "query", "schema": { "type": "integer", "minimum": 1, "maximum": 100, "default": 20 } },
                        { "name": "before", "in": "query", "description": "Only jobs with a smaller id (from the previous page's next)", "schema": { "type": "string", "pattern": "^[0-9]+$" } },
                        { "name": "state", "in": "query", "description": "Only jobs in this state (unreadable: those whose record could not be read)", "schema": { "$ref": "#/components/schemas/JobState" } }
                    ],
                    "responses": {
                        "200": json_response("A page of jobs", json!({
                            "type": "object",
                            "required": ["jobs", "total", "next"],
                            "properties": {
                                "jobs": { "type": "array", "items": { "$ref": "#/components/schemas/Job" } },
                                "total": { "type": "integer", "description": "Jobs matching the filter in all" },
                                "next": { "type": ["string", "null"], "description": "URL of the next page" }
                            }
                        })),
                        "400": error_response("Bad query")
                    }
                }
            },
            "/v1/jobs/{id}": {
                "get": {
                    "summary": "A job: state, progress, result and image URLs",
                    "operationId": "get_job",
                    "parameters": [id_parameter()],
                    "responses": {
                        "200": json_response("The job", json!({ "$ref": "#/components/schemas/Job" })),
                        "404": error_response("No such job")
                    }
                },
                "delete": {
                    "summary": "Cancel a queued or running job; delete a finished one (done, failed, cancelled) with its images, or an unreadable one's folder",
                    "operationId": "delete_job",
                    "parameters": [id_parameter()],
                    "responses": {
                        "200": json_response("The cancelled job, or the deleted one's last view with deleted: true (its id is never used again)", json!({ "$ref": "#/components/schemas/Job" })),
                        "404": error_response("No such job"),
                        "500": error_response("The change could not be stored; the job is unchanged"),
                        "507": error_response("The data folder's disk is full; the job is unchanged")
                    }
                }
            },
            "/v1/jobs/{id}/image.png": image_route("image.png", "image/png", "image (8-bit sRGB with the scene's exposure)"),
            "/v1/jobs/{id}/image.exr": image_route("image.exr", "image/x-exr", "image (linear HDR OpenEXR)"),
            "/v1/jobs/{id}/reference.png": image_route("reference.png", "image/png", "reference image"),
            "/v1/jobs/{id}/error.png": image_route("error.png", "image/png", "per-pixel error heat map against the reference"),
            "/v1/jobs/{id}/flip.png": image_route("flip.png", "image/png", "per-pixel FLIP error map against the reference (NVIDIA's magma colour map)"),
            "/v1/scenes": {
                "get": {
                    "summary": "The scenes jobs may name",
                    "operationId": "list_scenes",
                    "responses": { "200": json_response("Scenes", json!({
                        "type": "object",
                        "properties": { "scenes": { "type": "array", "items": { "$ref": "#/components/schemas/Scene" } } }
                    })) }
                },
                "post": {
                    "summary": "Upload a self-contained .glb scene",
                    "operationId": "upload_scene",
                    "parameters": [{ "name": "name", "in": "query", "description": "A name for people", "schema": { "type": "string" } }],
                    "requestBody": {
                        "required": true,
                        "description": format!("The .glb file, at most {} bytes", config.max_upload_bytes),
                        "content": { "model/gltf-binary": { "schema": { "type": "string", "format": "binary" } } }
                    },
                    "responses": {
                        "201": json_response("Stored; jobs name it by its id", json!({ "type": "object", "properties": { "scene": { "$ref": "#/components/schemas/UploadedScene" } } })),
                        "200": json_response("The same file was uploaded before", json!({ "type": "object", "properties": { "scene": { "$ref": "#/components/schemas/UploadedScene" } } })),
                        "413": error_response("Larger than the upload limit"),
                        "415": error_response("Not model/gltf-binary"),
                        "422": error_response("Not a valid, self-contained glTF 2.0 binary with triangles, or its images (every one, from its header) exceed the texel budget or have no readable PNG, JPEG or DDS header"),
                        "500": error_response("The scene could not be stored"),
                        "507": error_response("The data folder's disk is full, or below --min-free-bytes, or holds --max-stored-bytes (quota_exceeded)")
                    }
                }
            },
            "/v1/scenes/{id}": {
                "delete": {
                    "summary": "Delete an uploaded scene",
                    "operationId": "delete_scene",
                    "parameters": [{ "name": "id", "in": "path", "required": true, "schema": { "type": "string" }, "description": "The uploaded scene's id (upload-...)" }],
                    "responses": {
                        "200": json_response("Deleted", json!({ "type": "object", "properties": { "scene": { "$ref": "#/components/schemas/UploadedScene" }, "deleted": { "type": "boolean" } } })),
                        "404": error_response("No such uploaded scene (scene_not_found)"),
                        "409": error_response("A queued or running job uses it (scene_in_use), or it is a bundled or folder scene (scene_not_deletable)"),
                        "500": error_response("The scene could not be deleted")
                    }
                }
            }
        },
        "components": {
            "schemas": {
                "Error": {
                    "type": "object",
                    "required": ["error"],
                    "properties": { "error": { "type": "object", "required": ["code", "message"], "properties": {
                        "code": { "type": "string" }, "message": { "type": "string" } } } }
                },
                "JobState": { "type": "string", "enum": ["queued", "running", "done", "failed", "cancelled", "unreadable"], "description": "unreadable: the job's record could not be read at startup; its folder is left for a person, its error says why, and nothing else about it is known" },
                "Camera": {
                    "oneOf": [
                        { "type": "string", "description": "\"default\", \"path\" (the scene's camera path) or a camera node's name" },
                        { "type": "object", "required": ["position", "target"], "additionalProperties": false, "properties": {
                            "position": { "type": "array", "items": { "type": "number" }, "minItems": 3, "maxItems": 3 },
                            "target": { "type": "array", "items": { "type": "number" }, "minItems": 3, "maxItems": 3 },
                            "fov_deg": { "type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 180, "default": 50 } } }
                    ]
                },
                "JobRequest": {
                    "type": "object",
                    "required": ["scene"],
                    "additionalProperties": false,
                    "properties": {
                        "scene": { "type": "string", "description": "A name from GET /v1/scenes" },
                        "tier": { "type": "string", "enum": tiers, "default": "auto" },
                        "width": { "type": "integer", "minimum": 1, "maximum": config.max_width, "default": crate::job::DEFAULT_WIDTH },
                        "height": { "type": "integer", "minimum": 1, "maximum": config.max_height, "default": crate::job::DEFAULT_HEIGHT },
                        "frames": { "type": "integer", "minimum": 1, "maximum": config.max_frames, "default": 1, "description": "Measured frames; the last is the image" },
                        "warmup": { "type": "integer", "minimum": 0, "description": "Still warm-up frames (default: the tier's own); warmup + frames <= the frame limit" },
                        "spp": { "type": "integer", "minimum": 1, "maximum": config.max_spp, "default": crate::job::DEFAULT_SPP },
                        "seed": { "type": "integer", "minimum": 0, "default": crate::job::DEFAULT_SEED },
                        "camera": { "$ref": "#/components/schemas/Camera" },
                        "compare": { "type": "boolean", "default": true, "description": "Measure against the path-traced reference (false: no reference, no comparison images)" },
                        "reference_spp": { "type": "integer", "minimum": 1, "maximum": config.max_spp, "default": config.reference_spp, "description": "Only when the job compares" },
                        "lighting": { "$ref": "#/components/schemas/Lighting" },
                        "priority": { "type": "integer", "minimum": crate::job::PRIORITY_RANGE.start(), "maximum": crate::job::PRIORITY_RANGE.end(), "default": 0, "description": "Higher runs first; equal priorities run in submission order" }
                    }
                },
                "Lighting": {
                    "type": "object",
                    "additionalProperties": false,
                    "description": "Sun, sky, exposure and default camera applied to the scene before rendering (the lighting file format of docs/scenes.md)",
                    "properties": {
                        "sun": { "type": "object", "additionalProperties": false, "properties": {
                            "direction": { "type": "array", "items": { "type": "number" }, "minItems": 3, "maxItems": 3, "description": "The vector the light travels along" },
                            "azimuth_deg": { "type": "number", "description": "Towards the sun, degrees from +X towards +Z" },
                            "elevation_deg": { "type": "number", "description": "Degrees above the horizon" },
                            "color": { "type": "array", "items": { "type": "number", "minimum": 0 }, "minItems": 3, "maxItems": 3 },
                            "irradiance": { "type": "number", "minimum": 0, "description": "W/m^2 facing the sun" } } },
                        "sky": { "type": "object", "description": "One of constant: [r, g, b], gradient: {zenith, horizon, ground}, preset: day | overcast | night" },
                        "exposure": { "type": "number", "exclusiveMinimum": 0 },
                        "camera": { "oneOf": [ { "type": "string" }, { "type": "integer", "minimum": 0 } ], "description": "A camera node's name, or the index of a camera node" }
                    }
                },
                "Accepted": {
                    "type": "object",
                    "required": ["id", "url", "state"],
                    "properties": { "id": { "type": "string" }, "url": { "type": "string" }, "state": { "$ref": "#/components/schemas/JobState" } }
                },
                "Progress": {
                    "type": "object",
                    "properties": {
                        "stage": { "type": "string", "enum": ["preparing", "warmup", "frames", "reference", "direct"] },
                        "done": { "type": "integer" }, "total": { "type": "integer" },
                        "fraction": { "type": "number", "minimum": 0, "maximum": 1 }
                    }
                },
                "Comparison": {
                    "type": "object",
                    "properties": {
                        "rmse_srgb8": { "type": "number" },
                        "flip": { "type": ["number", "null"], "minimum": 0, "maximum": 1, "description": "Mean FLIP (LDR, NVIDIA's, 67 pixels per degree) of the 8-bit sRGB image against the reference's: how visible the difference is, lower is better; null for jobs compared before it was measured" },
                        "rmse_linear": { "type": "number" }, "rel_mse": { "type": "number" },
                        "gain_vs_direct": { "type": ["number", "null"] }, "direct_rmse_srgb8": { "type": "number" },
                        "reference_spp": { "type": "integer" }, "reference_seed": { "type": "integer" },
                        "reference_seconds": { "type": "number" }, "reference_cached": { "type": "boolean" },
                        "reference_engine": { "type": "string", "description": "What rendered the reference: cpu, or gpu: <adapter name>" }
                    }
                },
                "Result": {
                    "type": "object",
                    "properties": {
                        "tier": { "type": "string", "description": "The tier that rendered" },
                        "device": { "type": "string" },
                        "width": { "type": "integer" }, "height": { "type": "integer" },
                        "frames": { "type": "integer" }, "warmup": { "type": "integer" },
                        "ms_per_frame": { "type": "number" },
                        "passes": { "type": "object", "additionalProperties": { "type": "number" }, "description": "Milliseconds per pass of the measured frame" },
                        "gi_ms": { "type": ["number", "null"] },
                        "memory_bytes": { "type": "integer" },
                        "samples_per_second": { "type": ["number", "null"] },
                        "rays_per_second": { "type": ["number", "null"] },
                        "render_seconds": { "type": "number" },
                        "comparison": { "oneOf": [{ "$ref": "#/components/schemas/Comparison" }, { "type": "null" }] }
                    }
                },
                "Job": {
                    "type": "object",
                    "required": ["id", "url", "state", "request", "submitted_at"],
                    "description": "A job whose record could not be read has state unreadable, its reason as error, and null request, times and attempts",
                    "properties": {
                        "id": { "type": "string" }, "url": { "type": "string" },
                        "state": { "$ref": "#/components/schemas/JobState" },
                        "progress": { "oneOf": [{ "$ref": "#/components/schemas/Progress" }, { "type": "null" }] },
                        "request": { "oneOf": [{ "$ref": "#/components/schemas/JobRequest" }, { "type": "null" }] },
                        "submitted_at": { "type": ["string", "null"], "format": "date-time" },
                        "started_at": { "type": ["string", "null"], "format": "date-time" },
                        "finished_at": { "type": ["string", "null"], "format": "date-time" },
                        "attempts": { "type": ["integer", "null"] },
                        "error": { "oneOf": [{ "type": "object", "properties": { "code": { "type": "string" }, "message": { "type": "string" } } }, { "type": "null" }] },
                        "result": { "oneOf": [{ "$ref": "#/components/schemas/Result" }, { "type": "null" }] },
                        "images": { "type": "object", "additionalProperties": { "type": "string" }, "description": "URLs of the images once done" }
                    }
                },
                "UploadedScene": {
                    "type": "object",
                    "properties": {
                        "id": { "type": "string" }, "name": { "type": "string" }, "bytes": { "type": "integer" },
                        "sha256": { "type": "string" }, "triangles": { "type": "integer" },
                        "uploaded_at": { "type": "string", "format": "date-time" },
                        "warnings": { "type": "array", "items": { "type": "string" } }
                    }
                },
                "Scene": {
                    "type": "object",
                    "properties": {
                        "name": { "type": "string" },
                        "source": { "type": "string", "enum": ["bundled", "folder", "uploaded"] },
                        "description": { "type": "string" },
                        "upload": { "$ref": "#/components/schemas/UploadedScene" }
                    }
                },
                "Health": {
                    "type": "object",
                    "properties": {
                        "status": { "type": "string", "enum": ["ok", "degraded", "unavailable", "shutting_down"] },
                        "version": { "type": "string" },
                        "gpu": { "oneOf": [{ "type": "object" }, { "type": "null" }] },
                        "queue_depth": { "type": "integer" },
                        "running": { "type": "integer" },
                        "unreadable_jobs": { "type": "integer", "description": "Job records that could not be read at startup" },
                        "storage": { "type": "object", "properties": {
                            "writable": { "type": "boolean" },
                            "free_bytes": { "type": ["integer", "null"] },
                            "min_free_bytes": { "type": "integer" } } },
                        "problems": { "type": "array", "items": { "type": "string" }, "description": "Why the status is not ok" }
                    }
                }
            }
        }
    });
    describe_access(&mut document, config);
    document
}

/// Adds what any operation may answer before its handler runs: 421 for a `Host` naming
/// another service, and when this configuration has a token, 401 and the bearer scheme on
/// every route but the open ones.
fn describe_access(document: &mut Value, config: &Config) {
    let has_token = config.api_token.is_some() || config.api_token_file.is_some();
    document["components"]["securitySchemes"] = json!({
        "bearer": {
            "type": "http",
            "scheme": "bearer",
            "description": "With --api-token: every route but the web page's files and /healthz"
        }
    });
    let Some(paths) = document["paths"].as_object_mut() else {
        return;
    };
    for (path, item) in paths {
        let open = crate::access::OPEN_ROUTES.contains(&path.as_str());
        for operation in item
            .as_object_mut()
            .into_iter()
            .flat_map(|o| o.values_mut())
        {
            operation["responses"]["421"] = error_response(
                "The Host header names neither the address this service was reached at nor a host of --allowed-hosts",
            );
            if has_token && !open {
                operation["responses"]["401"] = json!({
                    "description": "No bearer token, or the wrong one",
                    "headers": { "WWW-Authenticate": { "schema": { "type": "string" } } },
                    "content": { "application/json": { "schema": { "$ref": "#/components/schemas/Error" } } }
                });
                operation["security"] = json!([{ "bearer": [] }]);
            }
        }
    }
}

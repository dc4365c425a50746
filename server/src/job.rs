//! What a job is: the request a client posts, the normalized spec the service keeps, its state
//! and its result.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::{config::Config, error::ApiError};

/// Defaults of a job's optional fields.
pub const DEFAULT_WIDTH: u32 = 320;
pub const DEFAULT_HEIGHT: u32 = 240;
pub const DEFAULT_SPP: u32 = 16;
pub const DEFAULT_SEED: u64 = 1;

/// The body of `POST /v1/jobs`. Unknown fields are refused so a typo never silently renders
/// something else.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobRequest {
    /// A bundled scene name, a scene of the configured scene folders, or an uploaded scene's id.
    pub scene: String,
    /// `auto` (the default), or a tier name: `reference`, `direct`, `path`, `mobile`, `pc`...
    #[serde(default)]
    pub tier: Option<String>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Frames rendered after the warm-up; scene time advances by the scene's frame time per
    /// frame and the last one is the image.
    pub frames: Option<u32>,
    /// Still warm-up frames before `frames` (default: the tier's own, e.g. 63 for `mobile`).
    pub warmup: Option<u32>,
    /// Samples per pixel for the path tracers, anti-aliasing samples for `direct`.
    pub spp: Option<u32>,
    pub seed: Option<u64>,
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    /// Measure the image against the path-traced reference (default true: the service's
    /// purpose; `false` skips the reference and its render time).
    #[serde(default)]
    pub compare: Option<bool>,
    /// Samples per pixel of the reference (default: the service's).
    pub reference_spp: Option<u32>,
    /// Sun, sky, exposure and default camera applied to the scene before rendering, in the
    /// lighting file format (see `gi_scene::Lighting`).
    #[serde(default)]
    pub lighting: Option<gi_scene::Lighting>,
    /// Jobs with a higher priority run first (default 0, from -100 to 100); jobs of equal
    /// priority run in the order they were submitted.
    pub priority: Option<i32>,
}

/// Bounds of a job's priority.
pub const PRIORITY_RANGE: std::ops::RangeInclusive<i32> = -100..=100;

/// Which camera a job looks through.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum CameraSpec {
    /// `"default"` (the scene's default camera), `"path"` (the scene's camera path), or the
    /// name of a camera node in the scene.
    Named(String),
    /// An explicit pinhole camera.
    LookAt(LookAt),
}

/// A camera at `position` looking at `target` (+Y up), in world meters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LookAt {
    pub position: [f32; 3],
    pub target: [f32; 3],
    /// Vertical field of view in degrees (default 50).
    #[serde(default = "default_fov_deg")]
    pub fov_deg: f32,
}

fn default_fov_deg() -> f32 {
    50.0
}

/// A validated job: every field resolved to a value. Stored with the job.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobSpec {
    pub scene: String,
    /// The tier asked for (`auto` or a tier name).
    pub tier: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// `None`: the tier's default warm-up.
    pub warmup: Option<u32>,
    pub spp: u32,
    pub seed: u64,
    pub camera: CameraSpec,
    pub compare: bool,
    /// Set when `compare` is.
    pub reference_spp: Option<u32>,
    /// The request's lighting; absent from jobs stored before the field existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lighting: Option<gi_scene::Lighting>,
    /// See [`JobRequest::priority`]; 0 for jobs stored before the field existed.
    #[serde(default)]
    pub priority: i32,
}

impl JobRequest {
    /// Checks every field against the service's limits and fills in the defaults. The scene
    /// and tier names are checked by the caller, who knows the catalog and the GPU.
    pub fn normalize(self, config: &Config) -> Result<JobSpec, ApiError> {
        let width = self.width.unwrap_or(DEFAULT_WIDTH);
        let height = self.height.unwrap_or(DEFAULT_HEIGHT);
        let frames = self.frames.unwrap_or(1);
        let spp = self.spp.unwrap_or(DEFAULT_SPP);
        within("width", width, 1, config.max_width)?;
        within("height", height, 1, config.max_height)?;
        within("frames", frames, 1, config.max_frames)?;
        if let Some(warmup) = self.warmup {
            within("warmup", warmup, 0, config.max_frames)?;
        }
        within("spp", spp, 1, config.max_spp)?;
        // The whole job is bounded, not only each field: warm-up and frames are both frames.
        let all_frames = u64::from(frames) + u64::from(self.warmup.unwrap_or(0));
        if all_frames > u64::from(config.max_frames) {
            return Err(ApiError::invalid(
                "limit_exceeded",
                format!(
                    "warmup + frames is {all_frames}, more than the {} this service renders per job",
                    config.max_frames
                ),
            ));
        }
        let compare = self.compare.unwrap_or(true);
        let reference_spp = if compare {
            let spp = self.reference_spp.unwrap_or(config.reference_spp);
            within("reference_spp", spp, 1, config.max_spp)?;
            Some(spp)
        } else if self.reference_spp.is_some() {
            return Err(ApiError::invalid(
                "invalid_request",
                "reference_spp is only used when the job compares (\"compare\": false turns \
                 the comparison off)",
            ));
        } else {
            None
        };
        let camera = self
            .camera
            .unwrap_or_else(|| CameraSpec::Named("default".to_string()));
        if let CameraSpec::LookAt(look) = &camera {
            look.validate()?;
        }
        if let Some(lighting) = &self.lighting {
            lighting
                .validate()
                .map_err(|e| ApiError::invalid("invalid_request", format!("lighting: {e}")))?;
        }
        let priority = self.priority.unwrap_or(0);
        if !PRIORITY_RANGE.contains(&priority) {
            return Err(ApiError::invalid(
                "invalid_request",
                format!(
                    "priority {priority} is out of range ({}..={})",
                    PRIORITY_RANGE.start(),
                    PRIORITY_RANGE.end()
                ),
            ));
        }
        let spec = JobSpec {
            scene: self.scene,
            tier: self.tier.unwrap_or_else(|| "auto".to_string()),
            width,
            height,
            frames,
            warmup: self.warmup,
            spp,
            seed: self.seed.unwrap_or(DEFAULT_SEED),
            camera,
            compare,
            reference_spp,
            lighting: self.lighting,
            priority,
        };
        Ok(spec)
    }
}

impl JobSpec {
    /// The job's cost in pixel samples, as `--max-job-samples` bounds it: width x height x
    /// spp per frame (warm-up included) when its tier traces `spp` samples per pixel (path,
    /// reference, direct: `traces_spp`), one per pixel and frame for the real-time tiers,
    /// plus width x height x reference_spp for the comparison's reference.
    pub fn estimated_samples(&self, traces_spp: bool) -> u64 {
        let pixels = u64::from(self.width) * u64::from(self.height);
        let frames = u64::from(self.frames) + u64::from(self.warmup.unwrap_or(0));
        let per_pixel_frame = if traces_spp { u64::from(self.spp) } else { 1 };
        let reference = self.reference_spp.map_or(0, u64::from);
        pixels.saturating_mul(
            frames
                .saturating_mul(per_pixel_frame)
                .saturating_add(reference),
        )
    }

    /// Refuses the job (422 `job_too_costly`, with its estimate) when
    /// [`JobSpec::estimated_samples`] is over `max_samples`.
    pub fn check_cost(&self, traces_spp: bool, max_samples: u64) -> Result<(), ApiError> {
        let samples = self.estimated_samples(traces_spp);
        if samples <= max_samples {
            return Ok(());
        }
        Err(ApiError::invalid(
            "job_too_costly",
            format!(
                "the job would cost about {:.3e} pixel samples (its render{}), more than the \
                 {:.3e} this service runs per job (--max-job-samples); lower the size, spp, \
                 frames or reference_spp",
                samples as f64,
                if self.compare {
                    " and its reference"
                } else {
                    ""
                },
                max_samples as f64
            ),
        ))
    }
}

impl LookAt {
    fn validate(&self) -> Result<(), ApiError> {
        let finite = self
            .position
            .iter()
            .chain(&self.target)
            .all(|v| v.is_finite());
        if !finite {
            return Err(ApiError::invalid(
                "invalid_camera",
                "camera position and target must be finite numbers",
            ));
        }
        let position = glam::Vec3::from(self.position);
        let target = glam::Vec3::from(self.target);
        if (target - position).length() < 1e-6 {
            return Err(ApiError::invalid(
                "invalid_camera",
                "camera target must differ from its position",
            ));
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(ApiError::invalid(
                "invalid_camera",
                format!("fov_deg {} is out of range (0, 180)", self.fov_deg),
            ));
        }
        Ok(())
    }
}

fn within(name: &str, value: u32, min: u32, max: u32) -> Result<(), ApiError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(ApiError::invalid(
            "limit_exceeded",
            format!("{name} {value} is out of range ({min}..={max})"),
        ))
    }
}

/// Where a job is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    Queued,
    Running,
    Done,
    Failed,
    Cancelled,
}

impl JobState {
    pub const ALL: [JobState; 5] = [
        JobState::Queued,
        JobState::Running,
        JobState::Done,
        JobState::Failed,
        JobState::Cancelled,
    ];

    pub fn name(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }

    /// Done, failed or cancelled: the job will not change any more.
    pub fn is_final(self) -> bool {
        matches!(
            self,
            JobState::Done | JobState::Failed | JobState::Cancelled
        )
    }
}

/// What `GET /v1/jobs?state=` selects: the jobs in one state, or those whose record cannot
/// be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StateFilter {
    Queued,
    Running,
    Done,
    Failed,
    Cancelled,
    Unreadable,
}

impl StateFilter {
    pub fn name(self) -> &'static str {
        match self.job_state() {
            Some(state) => state.name(),
            None => UNREADABLE,
        }
    }

    /// The job state it selects; `None` for unreadable records.
    pub fn job_state(self) -> Option<JobState> {
        match self {
            StateFilter::Queued => Some(JobState::Queued),
            StateFilter::Running => Some(JobState::Running),
            StateFilter::Done => Some(JobState::Done),
            StateFilter::Failed => Some(JobState::Failed),
            StateFilter::Cancelled => Some(JobState::Cancelled),
            StateFilter::Unreadable => None,
        }
    }
}

/// The state the API shows for a job whose record cannot be read.
pub const UNREADABLE: &str = "unreadable";

/// How far a running job is.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Progress {
    /// `preparing` (the scene's import, BVH builds and the tier's set-up), `warmup`,
    /// `frames`, `reference` or `direct`.
    pub stage: &'static str,
    /// Frames (or samples per pixel, for CPU renders) done in this stage, of `total`.
    pub done: u32,
    pub total: u32,
    /// The whole job's share done, 0..1 (a rough estimate across stages).
    pub fraction: f64,
}

/// Why a job failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobFailure {
    pub code: String,
    pub message: String,
}

/// What a finished job measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobResult {
    /// The tier that rendered (what `auto` resolved to).
    pub tier: String,
    /// `gpu` or `cpu`, and the adapter for GPU tiers.
    pub device: String,
    pub width: u32,
    pub height: u32,
    /// Measured frames and the still warm-up frames rendered before them (0 for tiers
    /// without history).
    pub frames: u32,
    pub warmup: u32,
    /// The measured frame's time (the sum of its passes).
    pub ms_per_frame: f64,
    /// The measured frame's passes in milliseconds (a pass recorded several times, summed).
    pub passes: BTreeMap<String, f64>,
    /// The tier's GI passes (`cache/*` and the tier's own) for tiers that split them out.
    pub gi_ms: Option<f64>,
    /// Bytes the tier owned after the measured frame.
    pub memory_bytes: u64,
    pub samples_per_second: Option<f64>,
    pub rays_per_second: Option<f64>,
    /// Wall time of the whole tier render (warm-up and every frame).
    pub render_seconds: f64,
    /// Present when the job compared against the reference.
    pub comparison: Option<Comparison>,
}

/// The image measured against the path-traced reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    pub rmse_srgb8: f64,
    /// Mean FLIP (LDR, `gi_image::flip_ldr`) against the reference, in 0..1: how visible the
    /// difference is. Null for jobs compared before FLIP was measured (they have no
    /// `flip.png` either).
    #[serde(default)]
    pub flip: Option<f64>,
    pub rmse_linear: f64,
    pub rel_mse: f64,
    /// `rmse_srgb8 / direct_rmse_srgb8`; null when the direct-only image matches the reference.
    pub gain_vs_direct: Option<f64>,
    pub direct_rmse_srgb8: f64,
    pub reference_spp: u32,
    pub reference_seed: u64,
    /// How long the reference took when it was rendered.
    pub reference_seconds: f64,
    /// True when the reference came from the cache.
    pub reference_cached: bool,
    /// The engine that rendered the reference: `cpu` or `gpu: <adapter name>` (results from
    /// before this was recorded were rendered on the CPU).
    #[serde(default = "cpu_engine")]
    pub reference_engine: String,
}

fn cpu_engine() -> String {
    "cpu".to_string()
}

/// A job as stored in the data folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    pub id: u64,
    pub spec: JobSpec,
    pub state: JobState,
    pub submitted_at: String,
    pub started_at: Option<String>,
    pub finished_at: Option<String>,
    /// Times the job started running (a crash or restart while it ran starts it again).
    pub attempts: u32,
    pub failure: Option<JobFailure>,
    pub result: Option<JobResult>,
}

/// The image files of a finished job, as served under `/v1/jobs/{id}/`.
pub const IMAGE_FILES: [&str; 5] = [
    "image.png",
    "image.exr",
    "reference.png",
    "error.png",
    "flip.png",
];

impl JobRecord {
    /// A job just submitted: queued, never started.
    pub fn queued(id: u64, spec: JobSpec) -> Self {
        Self {
            id,
            spec,
            state: JobState::Queued,
            submitted_at: now_rfc3339(),
            started_at: None,
            finished_at: None,
            attempts: 0,
            failure: None,
            result: None,
        }
    }

    /// Why this finished job has no `file` (one of [`IMAGE_FILES`]), or `None` when it has it:
    /// the comparison's images exist only for jobs that compared, and the FLIP map only for
    /// those compared since FLIP is measured.
    pub fn missing_image(&self, file: &str) -> Option<&'static str> {
        let compared = self.result.as_ref().and_then(|r| r.comparison.as_ref());
        match file {
            "reference.png" | "error.png" | "flip.png" if !self.spec.compare => {
                Some("did not compare against the reference")
            }
            "flip.png" if compared.is_some_and(|c| c.flip.is_none()) => {
                Some("was compared before FLIP was measured")
            }
            _ => None,
        }
    }

    /// The job as the API shows it: the record, its URL, its progress while running and the
    /// URLs of its images once done.
    pub fn view(&self, progress: Option<&Progress>) -> serde_json::Value {
        let url = format!("/v1/jobs/{}", self.id);
        let images: serde_json::Map<String, serde_json::Value> = if self.state == JobState::Done {
            IMAGE_FILES
                .iter()
                .filter(|file| self.missing_image(file).is_none())
                .map(|file| {
                    let key = file.replace('.', "_");
                    (key, format!("{url}/{file}").into())
                })
                .collect()
        } else {
            serde_json::Map::new()
        };
        serde_json::json!({
            "id": self.id.to_string(),
            "url": url,
            "state": self.state,
            "progress": if self.state == JobState::Running { progress } else { None },
            "request": self.spec,
            "submitted_at": self.submitted_at,
            "started_at": self.started_at,
            "finished_at": self.finished_at,
            "attempts": self.attempts,
            "error": self.failure,
            "result": self.result,
            "images": images,
        })
    }
}

/// A job whose record could not be read at startup, as the API shows it: every field of a
/// job, with state `unreadable`, the reason as its error, and nothing else known.
pub fn unreadable_view(id: u64, error: &str) -> serde_json::Value {
    let url = format!("/v1/jobs/{id}");
    serde_json::json!({
        "id": id.to_string(),
        "url": url,
        "state": UNREADABLE,
        "progress": null,
        "request": null,
        "submitted_at": null,
        "started_at": null,
        "finished_at": null,
        "attempts": null,
        "error": JobFailure {
            code: "unreadable_record".to_string(),
            message: format!(
                "{error}; the job's folder is left as it is: repair or remove it, then restart \
                 the service"
            ),
        },
        "result": null,
        "images": {},
    })
}

/// The current time as RFC 3339 in UTC with milliseconds (`2026-11-22T12:00:00.123Z`).
pub fn now_rfc3339() -> String {
    humantime::format_rfc3339_millis(std::time::SystemTime::now()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cost_counts_spp_only_where_the_tier_traces_it_and_the_reference_always() {
        let config = Config::with_data_dir("unused");
        let request: JobRequest = serde_json::from_str(
            r#"{"scene": "cornell-box", "width": 10, "height": 10, "spp": 8, "frames": 3,
                "warmup": 2, "reference_spp": 100}"#,
        )
        .unwrap();
        let spec = request.normalize(&config).unwrap();
        // 100 pixels x (5 frames x 8 spp + 100 reference samples).
        assert_eq!(spec.estimated_samples(true), 100 * (5 * 8 + 100));
        // A real-time tier: one sample per pixel and frame.
        assert_eq!(spec.estimated_samples(false), 100 * (5 + 100));
        assert!(spec.check_cost(true, 14_000).is_ok());
        let refused = spec.check_cost(true, 13_999).unwrap_err();
        assert_eq!(refused.code, "job_too_costly");
    }

    #[test]
    fn defaults_fill_in_and_limits_hold() {
        let config = Config::with_data_dir("unused");
        let request: JobRequest = serde_json::from_str(r#"{"scene": "cornell-box"}"#).unwrap();
        let spec = request.normalize(&config).unwrap();
        assert_eq!((spec.width, spec.height, spec.frames), (320, 240, 1));
        assert_eq!(spec.tier, "auto");
        assert_eq!(spec.camera, CameraSpec::Named("default".to_string()));
        // Every job is measured against the reference unless it opts out.
        assert!(spec.compare);
        assert_eq!(spec.reference_spp, Some(config.reference_spp));
        let plain: JobRequest =
            serde_json::from_str(r#"{"scene": "x", "compare": false}"#).unwrap();
        let plain = plain.normalize(&config).unwrap();
        assert!(!plain.compare);
        assert_eq!(plain.reference_spp, None);
        let contradictory: JobRequest =
            serde_json::from_str(r#"{"scene": "x", "compare": false, "reference_spp": 8}"#)
                .unwrap();
        assert_eq!(
            contradictory.normalize(&config).unwrap_err().code,
            "invalid_request"
        );

        let too_many: JobRequest =
            serde_json::from_str(r#"{"scene": "x", "frames": 200, "warmup": 100}"#).unwrap();
        let error = too_many.normalize(&config).unwrap_err();
        assert_eq!(error.code, "limit_exceeded");
    }

    #[test]
    fn lighting_is_validated_and_kept_in_the_spec() {
        let config = Config::with_data_dir("unused");
        let request: JobRequest = serde_json::from_str(
            r#"{"scene": "x", "lighting": {"sun": {"direction": [0, -1, 0]}, "exposure": 2}}"#,
        )
        .unwrap();
        let spec = request.normalize(&config).unwrap();
        assert_eq!(spec.lighting.as_ref().and_then(|l| l.exposure), Some(2.0));
        // Stored jobs from before the field existed still read.
        let stored = serde_json::to_value(&spec).unwrap();
        let mut old = stored.clone();
        old.as_object_mut().unwrap().remove("lighting");
        let back: JobSpec = serde_json::from_value(old).unwrap();
        assert_eq!(back.lighting, None);

        let bad: JobRequest =
            serde_json::from_str(r#"{"scene": "x", "lighting": {"exposure": -1}}"#).unwrap();
        assert!(bad.normalize(&config).is_err());
        assert!(
            serde_json::from_str::<JobRequest>(r#"{"scene": "x", "lighting": {"sunn": {}}}"#)
                .is_err()
        );
    }

    #[test]
    fn jobs_compared_before_flip_read_and_list_no_flip_map() {
        let comparison = |flip: Option<f64>| Comparison {
            rmse_srgb8: 4.0,
            flip,
            rmse_linear: 0.01,
            rel_mse: 0.02,
            gain_vs_direct: Some(0.1),
            direct_rmse_srgb8: 40.0,
            reference_spp: 16,
            reference_seed: 7,
            reference_seconds: 1.0,
            reference_cached: false,
            reference_engine: "cpu".to_string(),
        };
        // A comparison stored before FLIP was measured has no `flip` key.
        let mut stored = serde_json::to_value(comparison(Some(0.05))).unwrap();
        stored.as_object_mut().unwrap().remove("flip");
        let old: Comparison = serde_json::from_value(stored).unwrap();
        assert_eq!(old, comparison(None));

        let config = Config::with_data_dir("unused");
        let request: JobRequest =
            serde_json::from_str(r#"{"scene": "cornell-box", "compare": true}"#).unwrap();
        let result = JobResult {
            tier: "reference".to_string(),
            device: "cpu".to_string(),
            width: 320,
            height: 240,
            frames: 1,
            warmup: 0,
            ms_per_frame: 1.0,
            passes: BTreeMap::new(),
            gi_ms: None,
            memory_bytes: 1,
            samples_per_second: None,
            rays_per_second: None,
            render_seconds: 1.0,
            comparison: Some(comparison(Some(0.05))),
        };
        let mut record = JobRecord {
            id: 3,
            spec: request.normalize(&config).unwrap(),
            state: JobState::Done,
            submitted_at: now_rfc3339(),
            started_at: None,
            finished_at: None,
            attempts: 1,
            failure: None,
            result: Some(result),
        };
        let listed = |record: &JobRecord| -> Vec<String> {
            let view = record.view(None);
            let mut keys: Vec<String> = view["images"]
                .as_object()
                .unwrap()
                .keys()
                .cloned()
                .collect();
            keys.sort();
            keys
        };
        assert_eq!(
            listed(&record),
            [
                "error_png",
                "flip_png",
                "image_exr",
                "image_png",
                "reference_png"
            ]
        );
        assert_eq!(record.missing_image("flip.png"), None);
        record.result.as_mut().unwrap().comparison = Some(comparison(None));
        assert!(!listed(&record).contains(&"flip_png".to_string()));
        assert!(
            record
                .missing_image("flip.png")
                .unwrap()
                .contains("before FLIP")
        );
        assert_eq!(record.missing_image("error.png"), None);
        record.spec.compare = false;
        record.result.as_mut().unwrap().comparison = None;
        assert_eq!(listed(&record), ["image_exr", "image_png"]);
        assert!(
            record
                .missing_image("flip.png")
                .unwrap()
                .contains("did not compare")
        );
    }

    #[test]
    fn cameras_parse_by_name_or_look_at() {
        let named: CameraSpec = serde_json::from_str(r#""path""#).unwrap();
        assert_eq!(named, CameraSpec::Named("path".to_string()));
        let look: CameraSpec =
            serde_json::from_str(r#"{"position": [0, 1, 5], "target": [0, 1, 0]}"#).unwrap();
        assert_eq!(
            look,
            CameraSpec::LookAt(LookAt {
                position: [0.0, 1.0, 5.0],
                target: [0.0, 1.0, 0.0],
                fov_deg: 50.0
            })
        );
        assert!(serde_json::from_str::<CameraSpec>(r#"{"position": [0, 1, 5]}"#).is_err());
    }
}

//! Counters of the service and their Prometheus text exposition (`GET /metrics`).

use std::{
    collections::BTreeMap,
    fmt::Write,
    sync::{
        Mutex,
        atomic::{AtomicU64, Ordering},
    },
};

use crate::job::JobState;

/// A monotonically increasing count.
#[derive(Default)]
pub struct Counter(AtomicU64);

impl Counter {
    pub fn inc(&self) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }

    pub fn get(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }
}

/// What the service counts while it runs (the job counts by state come from the job table).
#[derive(Default)]
pub struct Metrics {
    pub submitted: Counter,
    pub rejected_queue_full: Counter,
    pub rejected_job_limit: Counter,
    pub reference_cache_hits: Counter,
    pub reference_cache_misses: Counter,
    pub uploads: Counter,
    /// Microseconds the GPU worker spent rendering.
    gpu_busy_us: AtomicU64,
    /// Per tier: seconds of tier renders and how many.
    render: Mutex<BTreeMap<String, (f64, u64)>>,
}

impl Metrics {
    pub fn add_gpu_busy(&self, seconds: f64) {
        self.gpu_busy_us
            .fetch_add((seconds * 1e6) as u64, Ordering::Relaxed);
    }

    pub fn add_render(&self, tier: &str, seconds: f64) {
        let mut render = self.render.lock().unwrap_or_else(|e| e.into_inner());
        let entry = render.entry(tier.to_string()).or_insert((0.0, 0));
        entry.0 += seconds;
        entry.1 += 1;
    }

    /// Mean seconds of a tier render so far, over every tier.
    pub fn average_render_seconds(&self) -> Option<f64> {
        let render = self.render.lock().unwrap_or_else(|e| e.into_inner());
        let (seconds, count) = render
            .values()
            .fold((0.0, 0), |(s, c), (ds, dc)| (s + ds, c + dc));
        (count > 0).then(|| seconds / count as f64)
    }

    /// The Prometheus text format (version 0.0.4) of every metric.
    pub fn render(&self, counts: [usize; 5], gpu_available: bool) -> String {
        let mut out = String::new();
        let mut metric = |name: &str, kind: &str, help: &str, samples: &[(String, String)]| {
            let _ = writeln!(out, "# HELP {name} {help}");
            let _ = writeln!(out, "# TYPE {name} {kind}");
            for (labels, value) in samples {
                let _ = writeln!(out, "{name}{labels} {value}");
            }
        };
        let plain = |value: String| vec![(String::new(), value)];
        metric(
            "gi_queue_depth",
            "gauge",
            "Jobs waiting to run.",
            &plain(counts[JobState::Queued.index()].to_string()),
        );
        let by_state: Vec<_> = JobState::ALL
            .iter()
            .map(|s| {
                (
                    format!("{{state=\"{}\"}}", s.name()),
                    counts[s.index()].to_string(),
                )
            })
            .collect();
        metric("gi_jobs", "gauge", "Jobs by state.", &by_state);
        metric(
            "gi_jobs_submitted_total",
            "counter",
            "Jobs accepted since the service started.",
            &plain(self.submitted.get().to_string()),
        );
        metric(
            "gi_jobs_rejected_total",
            "counter",
            "Submissions turned away with 429, by reason.",
            &[
                (
                    "{reason=\"queue_full\"}".to_string(),
                    self.rejected_queue_full.get().to_string(),
                ),
                (
                    "{reason=\"job_limit\"}".to_string(),
                    self.rejected_job_limit.get().to_string(),
                ),
            ],
        );
        metric(
            "gi_gpu_available",
            "gauge",
            "1 when the service has a GPU adapter.",
            &plain(u8::from(gpu_available).to_string()),
        );
        metric(
            "gi_gpu_busy_seconds_total",
            "counter",
            "Seconds the GPU worker spent rendering jobs.",
            &plain(format!(
                "{:.6}",
                self.gpu_busy_us.load(Ordering::Relaxed) as f64 / 1e6
            )),
        );
        let render = self
            .render
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        let mut samples = Vec::new();
        for (tier, (seconds, count)) in &render {
            samples.push((format!("_sum{{tier=\"{tier}\"}}"), format!("{seconds:.6}")));
            samples.push((format!("_count{{tier=\"{tier}\"}}"), count.to_string()));
        }
        metric(
            "gi_render_seconds",
            "summary",
            "Wall time of tier renders (warm-up and frames), by the tier that rendered.",
            &samples,
        );
        metric(
            "gi_reference_cache_total",
            "counter",
            "References of comparisons, from the cache (hit) or path traced (miss).",
            &[
                (
                    "{result=\"hit\"}".to_string(),
                    self.reference_cache_hits.get().to_string(),
                ),
                (
                    "{result=\"miss\"}".to_string(),
                    self.reference_cache_misses.get().to_string(),
                ),
            ],
        );
        metric(
            "gi_scene_uploads_total",
            "counter",
            "Scenes uploaded and accepted.",
            &plain(self.uploads.get().to_string()),
        );
        out
    }
}

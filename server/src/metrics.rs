//! Counters of the service and their Prometheus text exposition (`GET /metrics`): jobs,
//! renders, HTTP requests and connections, and the data folder's disk.

use std::{
    collections::BTreeMap,
    fmt::Write,
    path::Path,
    sync::{
        Mutex,
        atomic::{AtomicU64, Ordering},
    },
    time::{Duration, Instant},
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

/// A value that goes up and down.
#[derive(Default)]
pub struct Gauge(AtomicU64);

impl Gauge {
    pub fn inc(&self) {
        self.0.fetch_add(1, Ordering::Relaxed);
    }

    pub fn dec(&self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }

    pub fn get(&self) -> u64 {
        self.0.load(Ordering::Relaxed)
    }
}

/// Why the service closed a connection before its client did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dropped {
    /// Its request head did not arrive within `--header-read-timeout-s`.
    HeaderTimeout,
    /// Silent for `--idle-timeout-s` with no request running, or paused that long in a
    /// request body.
    IdleTimeout,
    /// Idle the longest when a new connection came past `--max-connections`.
    Evicted,
    /// Came past `--max-connections` while every open one was busy (answered 503).
    Refused,
}

impl Dropped {
    pub const ALL: [Dropped; 4] = [
        Dropped::HeaderTimeout,
        Dropped::IdleTimeout,
        Dropped::Evicted,
        Dropped::Refused,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Dropped::HeaderTimeout => "header_timeout",
            Dropped::IdleTimeout => "idle_timeout",
            Dropped::Evicted => "evicted",
            Dropped::Refused => "refused",
        }
    }
}

/// Upper bounds (seconds) of the request latency histogram's buckets: from a cached status
/// answer (sub-millisecond) to an upload being imported (seconds).
const LATENCY_BUCKETS_S: [f64; 12] = [
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 10.0,
];

/// Requests of one route and method: answers by status class and a latency histogram.
#[derive(Clone, Default)]
struct RouteStats {
    /// Answers by status class: 1xx to 5xx.
    by_class: [u64; 5],
    /// Requests at most as slow as each bound of [`LATENCY_BUCKETS_S`] (not cumulative here).
    buckets: [u64; LATENCY_BUCKETS_S.len()],
    seconds: f64,
    count: u64,
}

/// The data folder's disk: what the service stored and what is left on its file system.
#[derive(Clone, Copy, Debug)]
pub struct DiskUsage {
    pub used_bytes: u64,
    pub free_bytes: Option<u64>,
}

/// The last walk of the data folder: when, how long it took, what it found.
struct DiskWalk {
    at: Instant,
    took: Duration,
    used_bytes: u64,
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
    /// Per route template and method (both from fixed sets, so the label count is bounded).
    http: Mutex<BTreeMap<(&'static str, &'static str), RouteStats>>,
    pub connections_open: Gauge,
    pub connections_accepted: Counter,
    connections_dropped: [Counter; Dropped::ALL.len()],
    disk_walk: Mutex<Option<DiskWalk>>,
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

    /// Counts a request answered with `status` after `seconds` (until its head was ready).
    pub fn add_request(
        &self,
        route: &'static str,
        method: &'static str,
        status: u16,
        seconds: f64,
    ) {
        let mut http = self.http.lock().unwrap_or_else(|e| e.into_inner());
        let stats = http.entry((route, method)).or_default();
        let class = usize::from(status / 100).clamp(1, 5) - 1;
        stats.by_class[class] += 1;
        if let Some(bucket) = LATENCY_BUCKETS_S.iter().position(|&le| seconds <= le) {
            stats.buckets[bucket] += 1;
        }
        stats.seconds += seconds;
        stats.count += 1;
    }

    pub fn add_dropped(&self, why: Dropped) {
        self.connections_dropped[why as usize].inc();
    }

    /// Bytes stored under `data_dir`, allocated blocks as `du` counts them (blocking). The
    /// folder is walked again only once the last walk is older than 20 times what it took (and
    /// a second), so scrapes of a folder of many jobs spend at most about 5% of a core on it.
    pub fn data_dir_used_bytes(&self, data_dir: &Path) -> u64 {
        let mut walk = self.disk_walk.lock().unwrap_or_else(|e| e.into_inner());
        let stale = walk
            .as_ref()
            .is_none_or(|w| w.at.elapsed() > (w.took * 20).max(Duration::from_secs(1)));
        if stale {
            let started = Instant::now();
            let used_bytes = bytes_under(data_dir);
            *walk = Some(DiskWalk {
                at: Instant::now(),
                took: started.elapsed(),
                used_bytes,
            });
        }
        walk.as_ref().map_or(0, |w| w.used_bytes)
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
    pub fn render(&self, counts: [usize; 5], gpu_available: bool, disk: DiskUsage) -> String {
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

        let http = self.http.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let mut requests = Vec::new();
        let mut latency = Vec::new();
        for ((route, method), stats) in &http {
            let labels = format!("route=\"{route}\",method=\"{method}\"");
            for (class, count) in stats.by_class.iter().enumerate() {
                if *count > 0 {
                    let status = format!("{}xx", class + 1);
                    requests.push((
                        format!("{{{labels},status=\"{status}\"}}"),
                        count.to_string(),
                    ));
                }
            }
            let mut cumulative = 0;
            for (le, count) in LATENCY_BUCKETS_S.iter().zip(&stats.buckets) {
                cumulative += count;
                latency.push((
                    format!("_bucket{{{labels},le=\"{le}\"}}"),
                    cumulative.to_string(),
                ));
            }
            latency.push((
                format!("_bucket{{{labels},le=\"+Inf\"}}"),
                stats.count.to_string(),
            ));
            latency.push((format!("_sum{{{labels}}}"), format!("{:.6}", stats.seconds)));
            latency.push((format!("_count{{{labels}}}"), stats.count.to_string()));
        }
        metric(
            "gi_http_requests_total",
            "counter",
            "HTTP requests answered, by route template, method and status class.",
            &requests,
        );
        metric(
            "gi_http_request_duration_seconds",
            "histogram",
            "Seconds from a request's head to its answer's, by route template and method.",
            &latency,
        );
        metric(
            "gi_http_connections_open",
            "gauge",
            "HTTP connections open now.",
            &plain(self.connections_open.get().to_string()),
        );
        metric(
            "gi_http_connections_total",
            "counter",
            "HTTP connections accepted.",
            &plain(self.connections_accepted.get().to_string()),
        );
        let dropped: Vec<_> = Dropped::ALL
            .iter()
            .map(|&why| {
                (
                    format!("{{reason=\"{}\"}}", why.name()),
                    self.connections_dropped[why as usize].get().to_string(),
                )
            })
            .collect();
        metric(
            "gi_http_connections_dropped_total",
            "counter",
            "HTTP connections the service closed, by reason.",
            &dropped,
        );
        metric(
            "gi_data_dir_used_bytes",
            "gauge",
            "Bytes stored in the data folder (jobs, images, uploads).",
            &plain(disk.used_bytes.to_string()),
        );
        if let Some(free) = disk.free_bytes {
            metric(
                "gi_data_dir_free_bytes",
                "gauge",
                "Bytes free for the service on the data folder's file system.",
                &plain(free.to_string()),
            );
        }
        out
    }
}

/// Bytes allocated to the files under `dir` (not following links); unreadable parts count 0.
fn bytes_under(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|entry| match entry.metadata() {
            Ok(meta) if meta.is_dir() => allocated(&meta) + bytes_under(&entry.path()),
            Ok(meta) => allocated(&meta),
            Err(_) => 0,
        })
        .sum()
}

#[cfg(unix)]
fn allocated(meta: &std::fs::Metadata) -> u64 {
    std::os::unix::fs::MetadataExt::blocks(meta) * 512
}

#[cfg(not(unix))]
fn allocated(meta: &std::fs::Metadata) -> u64 {
    meta.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_counted_by_class_and_latency_buckets_are_cumulative() {
        let metrics = Metrics::default();
        metrics.add_request("/v1/jobs", "POST", 202, 0.003);
        metrics.add_request("/v1/jobs", "POST", 429, 0.2);
        metrics.add_request("/v1/jobs", "POST", 202, 30.0);
        let disk = DiskUsage {
            used_bytes: 4096,
            free_bytes: Some(1 << 30),
        };
        let text = metrics.render([0; 5], false, disk);
        let labels = "route=\"/v1/jobs\",method=\"POST\"";
        for line in [
            format!("gi_http_requests_total{{{labels},status=\"2xx\"}} 2"),
            format!("gi_http_requests_total{{{labels},status=\"4xx\"}} 1"),
            format!("gi_http_request_duration_seconds_bucket{{{labels},le=\"0.001\"}} 0"),
            format!("gi_http_request_duration_seconds_bucket{{{labels},le=\"0.005\"}} 1"),
            format!("gi_http_request_duration_seconds_bucket{{{labels},le=\"0.25\"}} 2"),
            format!("gi_http_request_duration_seconds_bucket{{{labels},le=\"10\"}} 2"),
            format!("gi_http_request_duration_seconds_bucket{{{labels},le=\"+Inf\"}} 3"),
            format!("gi_http_request_duration_seconds_count{{{labels}}} 3"),
            "gi_data_dir_used_bytes 4096".to_string(),
            "gi_data_dir_free_bytes 1073741824".to_string(),
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
        assert!(!text.contains("status=\"5xx\""), "{text}");
    }

    #[test]
    fn the_data_folder_is_measured() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("jobs")).unwrap();
        std::fs::write(dir.path().join("jobs/image.png"), vec![7u8; 100_000]).unwrap();
        let used = Metrics::default().data_dir_used_bytes(dir.path());
        assert!(used >= 100_000, "{used}");
    }
}

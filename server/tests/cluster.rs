//! The scale-out service with its real parts: `gi-server` binaries serving the API over a
//! PostgreSQL database and an object store (a local folder), and `gi-worker` binaries taking
//! the jobs. Each test gets a database of its own.
//!
//! They need a PostgreSQL server: `GI_TEST_DATABASE_URL` names a role that may create
//! databases (`.ci/run` starts one and sets it). Without it they pass with a note, unless
//! `GI_REQUIRE_POSTGRES=1` makes a missing server a failure (as in CI).

mod common;

use std::{
    collections::HashSet,
    ffi::{OsStr, OsString},
    net::SocketAddr,
    path::PathBuf,
    process::{Command, Stdio},
    sync::atomic::{AtomicUsize, Ordering},
    time::{Duration, Instant},
};

use common::{browser, *};
use serde_json::{Value, json};

/// A database of its own, an object store folder and the processes of one test.
struct Cluster {
    dir: tempfile::TempDir,
    admin_url: String,
    database: String,
    url: String,
}

/// Seconds a worker holds a job without a heartbeat, short so failover is quick to test.
const LEASE_S: &str = "3";

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

/// Runs `sql` on the database at `url`.
fn execute(url: &str, sql: &str) {
    runtime().block_on(async {
        let (client, connection) = tokio_postgres::connect(url, tokio_postgres::NoTls)
            .await
            .unwrap_or_else(|e| panic!("connecting to {url}: {e}"));
        tokio::spawn(connection);
        client
            .batch_execute(sql)
            .await
            .unwrap_or_else(|e| panic!("{sql}: {e}"));
    });
}

/// `url` with its database replaced by `database`.
fn with_database(url: &str, database: &str) -> String {
    let (base, _) = url
        .rsplit_once('/')
        .expect("a database URL ends with /database");
    format!("{base}/{database}")
}

impl Cluster {
    /// A fresh database, or `None` (the test passes with a note) where no PostgreSQL is
    /// configured and none is required.
    fn new() -> Option<Self> {
        let Ok(admin_url) = std::env::var("GI_TEST_DATABASE_URL") else {
            assert!(
                std::env::var("GI_REQUIRE_POSTGRES").as_deref() != Ok("1"),
                "GI_REQUIRE_POSTGRES=1 but GI_TEST_DATABASE_URL is not set"
            );
            eprintln!("note: GI_TEST_DATABASE_URL is not set; the scale-out test is skipped");
            return None;
        };
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let database = format!(
            "gi_test_{}_{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::SeqCst)
        );
        execute(&admin_url, &format!("CREATE DATABASE {database}"));
        let url = with_database(&admin_url, &database);
        Some(Self {
            dir: tempfile::tempdir().unwrap(),
            admin_url,
            database,
            url,
        })
    }

    fn store(&self) -> PathBuf {
        self.dir.path().join("store")
    }

    /// An API server on a free port with `extra` flags.
    fn api(&self, name: &str, extra: &[&str]) -> (ServerProcess, SocketAddr) {
        let mut args: Vec<OsString> = ["--bind", "127.0.0.1:0", "--lease-s", LEASE_S]
            .iter()
            .chain(extra)
            .map(OsString::from)
            .collect();
        args.extend([
            "--database-url".into(),
            self.url.clone().into(),
            "--store-url".into(),
            self.store().into(),
            "--data-dir".into(),
            self.dir.path().join(name).into(),
        ]);
        spawn_server(args)
    }

    /// A worker without a GPU (CPU tiers only) called `name`.
    fn worker(&self, name: &str) -> ServerProcess {
        self.worker_with(name, &[])
    }

    /// [`Cluster::worker`] with `extra` flags.
    fn worker_with(&self, name: &str, extra: &[&OsStr]) -> ServerProcess {
        self.worker_at(name, &self.url, extra)
    }

    /// [`Cluster::worker_with`] reaching the database at `database_url`.
    fn worker_at(&self, name: &str, database_url: &str, extra: &[&OsStr]) -> ServerProcess {
        let child = Command::new(env!("CARGO_BIN_EXE_gi-worker"))
            .args(extra)
            .args([
                "--name",
                name,
                "--no-gpu",
                "--lease-s",
                LEASE_S,
                "--poll-ms",
                "100",
            ])
            .arg("--database-url")
            .arg(database_url)
            .arg("--store-url")
            .arg(self.store())
            .arg("--work-dir")
            .arg(self.dir.path().join(name))
            .arg("--cache-dir")
            .arg(self.dir.path().join("cache"))
            .env("RUST_LOG", "warn")
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("gi-worker starts");
        ServerProcess(child)
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        execute(
            &self.admin_url,
            &format!("DROP DATABASE IF EXISTS {} WITH (FORCE)", self.database),
        );
    }
}

/// A CPU job of a few seconds (a reference render with enough samples to be caught running).
fn slow_job() -> Value {
    json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48,
           "spp": 4096, "compare": false})
}

/// [`small_job`] with a priority.
fn small_job_with_priority(priority: i32) -> Value {
    let mut job = small_job();
    job["priority"] = priority.into();
    job
}

/// A CPU job of a minute or more.
fn long_job() -> Value {
    json!({"scene": "cornell-box", "tier": "reference", "width": 128, "height": 96,
           "spp": 4096, "compare": false})
}

fn small_job() -> Value {
    json!({"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12, "spp": 1,
           "compare": false})
}

#[test]
fn a_killed_worker_s_job_is_finished_by_another_and_a_killed_api_server_loses_nothing() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (mut api, addr) = cluster.api("api-1", &[]);
    let health = get(addr, "/healthz").json();
    assert_eq!(health["mode"], "scale-out", "{health}");
    // No worker yet: the service works but says jobs would wait.
    assert_eq!(health["status"], "degraded", "{health}");

    let mut first = cluster.worker("first");
    let slow = submit(addr, &slow_job());
    let running = wait_for(addr, &slow, Duration::from_secs(60), |job| {
        job["state"] == "running" && job["progress"].is_object()
    });
    assert_eq!(running["worker"], "first", "{running}");
    assert_eq!(running["attempts"], 1);

    // The first worker dies mid-render; a second one takes the job once the lease runs out.
    first.kill().unwrap();
    first.wait().unwrap();
    let second = cluster.worker("second");
    let done = wait_final(addr, &slow, Duration::from_secs(180));
    assert_eq!(done["state"], "done", "{done}");
    assert_eq!(done["attempts"], 2, "{done}");
    let image = get(addr, &format!("/v1/jobs/{slow}/image.png"));
    assert_eq!(image.status, 200);
    assert_eq!(png_size(&image.body), (64, 48));

    // The API server dies with jobs queued behind it; another one over the same database
    // shows every job as it was, and the worker runs them.
    drop(second);
    let queued: Vec<String> = (0..5).map(|_| submit(addr, &small_job())).collect();
    api.kill().unwrap();
    api.wait().unwrap();
    let (_api, addr) = cluster.api("api-2", &[]);
    for id in &queued {
        assert_eq!(
            get(addr, &format!("/v1/jobs/{id}")).json()["state"],
            "queued"
        );
    }
    let listed = get(addr, "/v1/jobs?limit=100").json();
    assert_eq!(listed["total"], 6, "{listed}");
    // The finished job's image is served by the new API server byte for byte.
    assert_eq!(
        get(addr, &format!("/v1/jobs/{slow}/image.png")).body,
        image.body
    );
    let _worker = cluster.worker("third");
    for id in &queued {
        let job = wait_final(addr, id, Duration::from_secs(120));
        assert_eq!(job["state"], "done", "{job}");
        assert_eq!(job["attempts"], 1, "{job}");
    }
    let health = get(addr, "/healthz").json();
    assert_eq!(health["status"], "ok", "{health}");
    // The counts by state follow every change (submissions, starts, a lost worker's job
    // requeued, ends).
    let metrics = get(addr, "/metrics").text();
    assert_eq!(
        metric(&metrics, "gi_jobs{state=\"done\"}"),
        Some(6.0),
        "{metrics}"
    );
    for state in ["queued", "running", "failed", "cancelled"] {
        let series = format!("gi_jobs{{state=\"{state}\"}}");
        assert_eq!(metric(&metrics, &series), Some(0.0), "{metrics}");
    }
    assert_eq!(get(addr, "/v1/jobs?state=done").json()["total"], 6);
    assert_eq!(health["workers"][0]["name"], "third", "{health}");
}

#[test]
fn priorities_lanes_cancellation_and_deletion_reach_the_workers() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (_api, addr) = cluster.api("api", &[]);
    // Queued before any worker runs: a low-priority job, a job only a GPU worker may take, and
    // a high-priority one.
    let low = submit(addr, &small_job_with_priority(-5));
    let gpu = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "pc", "width": 16,
                                   "height": 12, "compare": false}),
    );
    let high = submit(addr, &small_job_with_priority(7));
    let refused = post_json(
        addr,
        "/v1/jobs",
        &json!({"scene": "cornell-box", "priority": 101}),
    );
    assert_eq!(refused.status, 422, "{}", refused.text());

    let mut worker = cluster.worker("cpu");
    let low_done = wait_final(addr, &low, Duration::from_secs(60));
    let high_done = wait_final(addr, &high, Duration::from_secs(60));
    assert_eq!(low_done["state"], "done");
    assert_eq!(high_done["state"], "done");
    let started = |job: &Value| job["started_at"].as_str().unwrap().to_string();
    assert!(
        started(&high_done) < started(&low_done),
        "the higher priority runs first: {high_done} {low_done}"
    );
    // The GPU tier waits for a worker with a GPU.
    assert_eq!(
        get(addr, &format!("/v1/jobs/{gpu}")).json()["state"],
        "queued"
    );

    // Cancelling a running job reaches its worker, which goes on to the next job at once
    // instead of finishing a render of a minute or more.
    let long = submit(addr, &long_job());
    wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["state"] == "running"
    });
    let next = submit(addr, &small_job());
    let cancelled = delete(addr, &format!("/v1/jobs/{long}"));
    assert_eq!(cancelled.status, 200, "{}", cancelled.text());
    assert_eq!(cancelled.json()["state"], "cancelled");
    let cancelled_at = Instant::now();
    let next_done = wait_final(addr, &next, Duration::from_secs(60));
    assert_eq!(next_done["state"], "done", "{next_done}");
    assert!(
        cancelled_at.elapsed() < Duration::from_secs(20),
        "the worker stopped the cancelled render: {:?}",
        cancelled_at.elapsed()
    );
    assert_eq!(
        get(addr, &format!("/v1/jobs/{long}")).json()["state"],
        "cancelled"
    );
    assert_eq!(get(addr, &format!("/v1/jobs/{long}/image.png")).status, 404);

    // SIGTERM: the worker stops its render, puts the job back in the queue (the start not
    // counted) and leaves the worker list; another worker runs it.
    let interrupted = submit(addr, &slow_job());
    let running = wait_for(addr, &interrupted, Duration::from_secs(60), |job| {
        job["state"] == "running" && job["progress"].is_object()
    });
    assert_eq!(running["attempts"], 1);
    let status = Command::new("kill")
        .args(["-TERM", &worker.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let stopped_at = Instant::now();
    let exit = wait_exit(&mut worker, Duration::from_secs(30));
    assert!(exit.success(), "{exit:?}");
    assert!(
        stopped_at.elapsed() < Duration::from_secs(10),
        "{:?}",
        stopped_at.elapsed()
    );
    let requeued = get(addr, &format!("/v1/jobs/{interrupted}")).json();
    assert_eq!(requeued["state"], "queued", "{requeued}");
    assert_eq!(requeued["attempts"], 0, "{requeued}");
    assert_eq!(get(addr, "/healthz").json()["workers"], json!([]));
    let _worker = cluster.worker("cpu-2");
    let finished = wait_final(addr, &interrupted, Duration::from_secs(120));
    assert_eq!(finished["state"], "done", "{finished}");
    assert_eq!(finished["attempts"], 1, "{finished}");

    // Deleting a finished job removes its row and its images from the store.
    let images = cluster.store().join("jobs").join(&high);
    assert!(images.join("image.png").is_file());
    let deleted = delete(addr, &format!("/v1/jobs/{high}"));
    assert_eq!(deleted.status, 200, "{}", deleted.text());
    assert_eq!(deleted.json()["deleted"], true);
    assert!(
        !images.exists(),
        "the job's folder is removed from the store"
    );
    assert_eq!(get(addr, &format!("/v1/jobs/{high}")).status, 404);
}

#[test]
fn concurrent_submissions_to_two_api_servers_are_all_accounted_for() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    // No worker: every accepted job stays queued, and the queue holds at most 150.
    let (_a, first) = cluster.api("api-a", &["--max-queue", "150"]);
    let (_b, second) = cluster.api("api-b", &["--max-queue", "150"]);
    let answers: Vec<(u16, Value)> = std::thread::scope(|scope| {
        let threads: Vec<_> = (0..200)
            .map(|i| {
                let addr = if i % 2 == 0 { first } else { second };
                scope.spawn(move || {
                    let response = post_json(addr, "/v1/jobs", &small_job());
                    (response.status, response.json())
                })
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    });
    let mut accepted = HashSet::new();
    let mut full = 0;
    for (status, body) in &answers {
        match status {
            202 => assert!(accepted.insert(body["id"].as_str().unwrap().to_string())),
            429 => {
                assert_eq!(body["error"]["code"], "queue_full", "{body}");
                full += 1;
            }
            other => panic!("unexpected answer {other}: {body}"),
        }
    }
    assert_eq!(accepted.len() + full, 200);
    // The limit holds across the two API servers.
    assert_eq!(accepted.len(), 150);
    // Every accepted job is listed by both servers, none twice, nothing else.
    for addr in [first, second] {
        let mut listed = HashSet::new();
        let mut next = Some("/v1/jobs?limit=100".to_string());
        while let Some(page) = next {
            let body = get(addr, &page).json();
            for job in body["jobs"].as_array().unwrap() {
                assert_eq!(job["state"], "queued");
                assert!(listed.insert(job["id"].as_str().unwrap().to_string()));
            }
            next = body["next"].as_str().map(str::to_string);
        }
        assert_eq!(listed, accepted);
    }
}

#[test]
fn an_uploaded_scene_renders_on_a_worker_and_is_deleted_from_the_store() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (_api, addr) = cluster.api("api", &[]);
    let uploaded = upload_glb(addr, &sample_glb("Box"));
    assert_eq!(uploaded.status, 201, "{}", uploaded.text());
    let scene = uploaded.json()["scene"]["id"].as_str().unwrap().to_string();
    assert!(
        cluster
            .store()
            .join("scenes")
            .join(format!("{scene}.glb"))
            .is_file()
    );
    let listed = get(addr, "/v1/scenes").json();
    assert!(
        listed["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["name"] == scene.as_str() && s["source"] == "uploaded"),
        "{listed}"
    );
    let job = submit(
        addr,
        &json!({"scene": scene, "tier": "reference", "width": 16,
                                   "height": 12, "spp": 1, "compare": false}),
    );
    let in_use = delete(addr, &format!("/v1/scenes/{scene}"));
    assert_eq!(in_use.status, 409, "{}", in_use.text());
    // The worker fetches the scene from the store.
    let _worker = cluster.worker("worker");
    let done = wait_final(addr, &job, Duration::from_secs(60));
    assert_eq!(done["state"], "done", "{done}");
    let deleted = delete(addr, &format!("/v1/scenes/{scene}"));
    assert_eq!(deleted.status, 200, "{}", deleted.text());
    assert!(
        !cluster
            .store()
            .join("scenes")
            .join(format!("{scene}.glb"))
            .exists()
    );
    assert_eq!(delete(addr, &format!("/v1/scenes/{scene}")).status, 404);
    let gone = post_json(addr, "/v1/jobs", &json!({"scene": scene, "compare": false}));
    assert_eq!(gone.status, 422, "{}", gone.text());
}

#[test]
fn the_web_page_lists_the_workers_and_runs_a_job_on_them() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (_api, addr) = cluster.api("api", &[]);
    let _worker = cluster.worker("page-worker");
    browser::with_browser(
        "the_web_page_lists_the_workers_and_runs_a_job_on_them",
        |session| {
            session.call(
                "POST",
                "/url",
                Some(json!({"url": format!("http://{addr}/")})),
            );
            session.wait_for(
                "return document.querySelector('#workers tbody tr[data-name=\"page-worker\"]') !== null",
                Duration::from_secs(20),
            );
            let header = session.script("return document.getElementById('health').textContent");
            assert!(
                header
                    .as_str()
                    .unwrap()
                    .contains("1 worker(s), 0 with a GPU"),
                "{header}"
            );
            session.wait_for(
                "return document.querySelector('#tier option[value=reference]') !== null",
                Duration::from_secs(20),
            );
            assert_eq!(session.render_small_job(&[("#priority", "-2")]), "done");
            let sizes = session.wait_for(
                "const imgs = ['img-tier', 'img-flip'].map(id => document.getElementById(id)); \
                 return imgs.every(i => i.complete && i.naturalWidth > 0) ? imgs.map(i => i.naturalWidth) : null",
                Duration::from_secs(20),
            );
            assert_eq!(sizes, json!([24, 24]));
        },
    );
    let job = get(addr, "/v1/jobs/1").json();
    assert_eq!(job["request"]["priority"], -2, "{job}");
}

/// The same priorities and cancellation against the embedded default (no database): one
/// process whose CPU pool of one renders the jobs.
#[test]
fn priorities_and_cancellation_hold_in_the_embedded_default_too() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, addr) = spawn_embedded(dir.path(), ["--no-gpu", "--reference-pool", "1"]);
    // A render of a minute or more holds the only CPU worker while two jobs queue behind it.
    let long = submit(addr, &long_job());
    wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["state"] == "running"
    });
    let low = submit(addr, &small_job_with_priority(-5));
    let high = submit(addr, &small_job_with_priority(7));
    let cancelled = delete(addr, &format!("/v1/jobs/{long}"));
    assert_eq!(cancelled.status, 200, "{}", cancelled.text());
    let cancelled_at = Instant::now();
    let low_done = wait_final(addr, &low, Duration::from_secs(60));
    let high_done = wait_final(addr, &high, Duration::from_secs(60));
    assert!(
        cancelled_at.elapsed() < Duration::from_secs(20),
        "the cancelled render stopped: {:?}",
        cancelled_at.elapsed()
    );
    assert_eq!(low_done["state"], "done");
    assert_eq!(high_done["state"], "done");
    let started = |job: &Value| job["started_at"].as_str().unwrap().to_string();
    assert!(
        started(&high_done) < started(&low_done),
        "the higher priority runs first: {high_done} {low_done}"
    );
    assert_eq!(
        get(addr, &format!("/v1/jobs/{long}")).json()["state"],
        "cancelled"
    );
}

/// A `.glb` of `count` copies of one unit box (12 triangles) all at one place, with a camera
/// and no light: the worst case of the BVH builders, whose neighbours all tie (benchmarks/
/// scale/box_instances.py writes the same file). 200,000 copies take the CPU reference over
/// ten seconds to prepare.
fn coincident_boxes_glb(count: usize) -> Vec<u8> {
    let corners = (0..8u32).map(|i| [i >> 2 & 1, i >> 1 & 1, i & 1].map(|c| c as f32));
    let positions: Vec<u8> = corners.flatten().flat_map(f32::to_le_bytes).collect();
    let indices: [u16; 36] = [
        0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4,
        1, 5, 7, 1, 7, 3,
    ];
    let mut binary = positions.clone();
    binary.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let nodes: Vec<Value> = (0..count)
        .map(|_| json!({"mesh": 0}))
        .chain([json!({"camera": 0, "translation": [0.5, 0.5, 5.0]})])
        .collect();
    let gltf = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..=count).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": binary.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": positions.len()},
            {"buffer": 0, "byteOffset": positions.len(), "byteLength": 72},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"},
        ],
    });
    let mut text = serde_json::to_vec(&gltf).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    binary.resize(binary.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + binary.len();
    let mut glb = Vec::with_capacity(total);
    for word in [0x4654_6C67, 2, total as u32, text.len() as u32, 0x4E4F_534A] {
        glb.extend(u32::to_le_bytes(word));
    }
    glb.extend(text);
    glb.extend(u32::to_le_bytes(binary.len() as u32));
    glb.extend(u32::to_le_bytes(0x004E_4942));
    glb.extend(binary);
    glb
}

/// The processes whose parent is `pid` (Linux's /proc).
fn children_of(pid: u32) -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .filter_map(|entry| {
            let child: u32 = entry.ok()?.file_name().to_str()?.parse().ok()?;
            let stat = std::fs::read_to_string(format!("/proc/{child}/stat")).ok()?;
            // pid (comm) state ppid ...: the command may hold spaces and parentheses.
            let (_, rest) = stat.rsplit_once(')')?;
            let mut fields = rest.split_whitespace();
            let state = fields.next()?;
            let ppid: u32 = fields.next()?.parse().ok()?;
            (ppid == pid && state != "Z").then_some(child)
        })
        .collect()
}

/// Waits until `pid` has no child process; false after `timeout`.
fn children_end(pid: u32, timeout: Duration) -> bool {
    let started = Instant::now();
    while started.elapsed() < timeout {
        if children_of(pid).is_empty() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

/// A folder holding `boxes.glb`, 200,000 coincident boxes ([`coincident_boxes_glb`]).
fn boxes_scene_dir(parent: &std::path::Path) -> PathBuf {
    let scenes = parent.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::write(scenes.join("boxes.glb"), coincident_boxes_glb(200_000)).unwrap();
    scenes
}

/// On the service at `addr`, whose process `renderer` starts the jobs' processes: a job
/// cancelled while it builds the BVH of `boxes` has its process ended within seconds, and a
/// job whose process is killed fails alone while the next job runs.
fn job_processes_stop_and_fail_alone(addr: SocketAddr, renderer: u32) {
    // Caught while its scene is prepared (imported, its BVH built: 19 s in a debug build).
    let heavy = submit(
        addr,
        &json!({"scene": "boxes", "tier": "reference", "width": 16, "height": 12, "spp": 1,
                "compare": false}),
    );
    let preparing = wait_for(addr, &heavy, Duration::from_secs(60), |job| {
        job["progress"]["stage"].is_string() || job["finished_at"].is_string()
    });
    assert_eq!(preparing["progress"]["stage"], "preparing", "{preparing}");
    let children = children_of(renderer);
    assert_eq!(
        children.len(),
        1,
        "one process renders the job: {children:?}"
    );
    let cancelled = delete(addr, &format!("/v1/jobs/{heavy}"));
    assert_eq!(cancelled.status, 200, "{}", cancelled.text());
    let cancelled_at = Instant::now();
    assert!(
        children_end(renderer, Duration::from_secs(5)),
        "the job's process still runs {:?} after the cancellation",
        cancelled_at.elapsed()
    );
    let next = submit(addr, &small_job());
    let next_done = wait_final(addr, &next, Duration::from_secs(60));
    assert_eq!(next_done["state"], "done", "{next_done}");
    assert_eq!(
        get(addr, &format!("/v1/jobs/{heavy}")).json()["state"],
        "cancelled"
    );

    // A render process that dies (here by SIGKILL, as the kernel's OOM killer would end it)
    // fails its job; the service lives on and runs the next one.
    let doomed = submit(addr, &slow_job());
    wait_for(addr, &doomed, Duration::from_secs(60), |job| {
        job["state"] == "running" && job["progress"]["stage"] == "frames"
    });
    kill_the_job_process(addr, renderer, &doomed);
    let after = submit(addr, &small_job());
    assert_eq!(
        wait_final(addr, &after, Duration::from_secs(60))["state"],
        "done"
    );
}

/// Kills, as the kernel's OOM killer would, the one job process of `renderer` (rendering job
/// `id` of the service at `addr`): the job fails with `render_crashed`.
fn kill_the_job_process(addr: SocketAddr, renderer: u32, id: &str) {
    let children = children_of(renderer);
    assert_eq!(children.len(), 1, "{children:?}");
    let status = Command::new("kill")
        .args(["-KILL", &children[0].to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let failed = wait_final(addr, id, Duration::from_secs(60));
    assert_eq!(failed["state"], "failed", "{failed}");
    assert_eq!(failed["error"]["code"], "render_crashed", "{failed}");
}

/// Jobs run in processes of their own: a cancellation ends a job still importing its scene
/// and building its BVH (which check for nothing), and a render that dies fails its job, not
/// the worker.
#[test]
fn a_cancelled_job_stops_inside_its_bvh_build_and_a_crashed_render_fails_only_its_job() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let scenes = boxes_scene_dir(cluster.dir.path());
    let (_api, addr) = cluster.api("api", &["--scene-dir", scenes.to_str().unwrap()]);
    let worker = cluster.worker_with("worker", &["--scene-dir".as_ref(), scenes.as_os_str()]);
    job_processes_stop_and_fail_alone(addr, worker.id());
    let health = get(addr, "/healthz").json();
    assert_eq!(health["workers"][0]["name"], "worker", "{health}");
}

/// The same in the embedded default, whose CPU jobs run in processes of its own.
#[test]
fn the_embedded_default_s_cpu_jobs_stop_inside_their_bvh_build_and_fail_alone() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = boxes_scene_dir(dir.path());
    let flags = ["--no-gpu", "--reference-pool", "1", "--scene-dir"].map(OsStr::new);
    let (server, addr) = spawn_embedded(dir.path(), flags.into_iter().chain([scenes.as_os_str()]));
    job_processes_stop_and_fail_alone(addr, server.id());
}

/// The embedded default's GPU jobs render in one process and compare in another: the result
/// and the comparison's images are whole, and a GPU render process that dies fails its job.
#[test]
fn the_embedded_default_s_gpu_jobs_render_and_compare_in_processes_of_their_own() {
    if gi_gpu::GpuContext::new_or_skip(
        "the_embedded_default_s_gpu_jobs_render_and_compare_in_processes_of_their_own",
    )
    .is_none()
    {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (server, addr) = spawn_embedded(dir.path(), ["--reference-pool", "1"]);
    // The GPU lane's job process dies; the next job starts a fresh one.
    let doomed = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "path", "width": 64, "height": 48,
                "spp": 4096, "compare": false}),
    );
    wait_for(addr, &doomed, Duration::from_secs(60), |job| {
        job["state"] == "running" && job["progress"].is_object()
    });
    kill_the_job_process(addr, server.id(), &doomed);
    let compared = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "path", "width": 32, "height": 24, "spp": 4,
                "compare": true, "reference_spp": 16}),
    );
    let done = wait_final(addr, &compared, Duration::from_secs(120));
    assert_eq!(done["state"], "done", "{done}");
    assert_eq!(done["result"]["tier"], "path", "{done}");
    assert!(
        done["result"]["comparison"]["flip"].as_f64().unwrap() > 0.0,
        "{done}"
    );
    for file in ["image.png", "reference.png", "error.png", "flip.png"] {
        let image = get(addr, &format!("/v1/jobs/{compared}/{file}"));
        assert_eq!(image.status, 200, "{file}");
        assert_eq!(png_size(&image.body), (32, 24), "{file}");
    }
    // The GPU lane's and the CPU worker's job processes are kept for the next jobs.
    let sorted = |mut pids: Vec<u32>| {
        pids.sort_unstable();
        pids
    };
    let kept = sorted(children_of(server.id()));
    assert_eq!(kept.len(), 2, "{kept:?}");
    let again = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "path", "width": 32, "height": 24, "spp": 2,
                "compare": true, "reference_spp": 16}),
    );
    assert_eq!(
        wait_final(addr, &again, Duration::from_secs(120))["state"],
        "done"
    );
    assert_eq!(sorted(children_of(server.id())), kept);
}

/// A TCP relay to the database that the test can cut, as a network partition would: its open
/// connections are shut and new ones closed at once.
struct Relay {
    addr: SocketAddr,
    cut: std::sync::Arc<std::sync::atomic::AtomicBool>,
    open: std::sync::Arc<std::sync::Mutex<Vec<std::net::TcpStream>>>,
}

impl Relay {
    fn to(target: &str) -> Self {
        use std::net::{TcpListener, TcpStream};
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let cut = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let open = std::sync::Arc::new(std::sync::Mutex::new(Vec::<TcpStream>::new()));
        let target = target.to_string();
        let (cutting, opened) = (cut.clone(), open.clone());
        std::thread::spawn(move || {
            for client in listener.incoming() {
                let Ok(client) = client else { return };
                if cutting.load(Ordering::SeqCst) {
                    continue; // dropped: closed at once
                }
                let Ok(server) = TcpStream::connect(&target) else {
                    continue;
                };
                let mut streams = opened.lock().unwrap();
                for (mut from, mut to) in [
                    (client.try_clone().unwrap(), server.try_clone().unwrap()),
                    (server.try_clone().unwrap(), client.try_clone().unwrap()),
                ] {
                    std::thread::spawn(move || {
                        let _ = std::io::copy(&mut from, &mut to);
                        let _ = to.shutdown(std::net::Shutdown::Both);
                    });
                }
                streams.extend([client, server]);
            }
        });
        Self { addr, cut, open }
    }

    /// `url` (`postgres://user:password@host:port/database`) through this relay.
    fn url(&self, url: &str) -> String {
        let (user, rest) = url.split_once('@').expect("the database URL names a host");
        let (_, database) = rest
            .split_once('/')
            .expect("the database URL names a database");
        format!("{user}@{}/{database}", self.addr)
    }

    fn cut(&self) {
        self.cut.store(true, Ordering::SeqCst);
        for stream in self.open.lock().unwrap().drain(..) {
            let _ = stream.shutdown(std::net::Shutdown::Both);
        }
    }
}

/// A worker cut from the database stops its job once its lease may have run out, instead of
/// rendering on while the job goes back to the queue and another worker renders it too.
#[test]
fn a_worker_cut_from_the_database_stops_its_job_when_its_lease_runs_out() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (_api, addr) = cluster.api("api", &[]);
    let target = cluster
        .url
        .split_once('@')
        .and_then(|(_, rest)| rest.split_once('/'))
        .map(|(host, _)| host.to_string())
        .expect("the database URL names a host");
    let relay = Relay::to(&target);
    let cut_off = cluster.worker_at("cut-off", &relay.url(&cluster.url), &[]);
    // A render of a minute or more.
    let long = submit(addr, &long_job());
    let running = wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["state"] == "running" && job["progress"]["stage"] == "frames"
    });
    assert_eq!(running["worker"], "cut-off", "{running}");
    assert_eq!(children_of(cut_off.id()).len(), 1);
    relay.cut();
    let cut_at = Instant::now();
    // The lease is 3 s; its last renewal was at most a third of it before the cut.
    assert!(
        children_end(cut_off.id(), Duration::from_secs(6)),
        "the cut-off worker still renders {:?} after the cut",
        cut_at.elapsed()
    );
    assert!(
        cut_at.elapsed() < Duration::from_secs(4),
        "{:?}",
        cut_at.elapsed()
    );
    // The job goes back to the queue, and another worker takes it: its second start.
    let _other = cluster.worker("other");
    let taken = wait_for(addr, &long, Duration::from_secs(60), |job| {
        job["worker"] == "other"
    });
    assert_eq!(taken["attempts"], 2, "{taken}");
    assert_eq!(delete(addr, &format!("/v1/jobs/{long}")).status, 200);
}

/// The API server's `--job-time-limit-s` travels with each job: its worker, whose own limit is
/// an hour, stops the job when the service's runs out.
#[test]
fn the_api_server_s_time_limit_reaches_the_worker() {
    let Some(cluster) = Cluster::new() else {
        return;
    };
    let (_api, addr) = cluster.api("api", &["--job-time-limit-s", "2"]);
    let _worker = cluster.worker("worker");
    let long = submit(addr, &long_job());
    let failed = wait_final(addr, &long, Duration::from_secs(60));
    assert_eq!(failed["state"], "failed", "{failed}");
    assert_eq!(failed["error"]["code"], "time_limit", "{failed}");
    let message = failed["error"]["message"].as_str().unwrap();
    assert!(message.contains("the service's limit of 2 s"), "{message}");
}

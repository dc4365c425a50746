//! What keeps a long-running service within bounds: deleting finished jobs and uploaded scenes,
//! a byte quota on the data folder, a per-job time limit and a cost budget at submission.
//! Each is checked through the HTTP API on a service running in this process (no GPU: the
//! jobs render on the CPU).

mod common;

use std::time::Duration;

use common::*;
use serde_json::{Value, json};

const TIMEOUT: Duration = Duration::from_secs(120);

fn small_job(scene: &str) -> Value {
    json!({"scene": scene, "tier": "reference", "width": 8, "height": 6, "spp": 1, "compare": false})
}

/// A reference job that runs for minutes on the CPU (its progress stops it early).
fn long_job(scene: &str) -> Value {
    json!({"scene": scene, "tier": "reference", "width": 64, "height": 48, "spp": 1 << 20,
           "compare": false})
}

fn configure(c: &mut gi_server::Config) {
    c.no_gpu = true;
    c.reference_pool = 1;
    c.max_spp = 1 << 20;
    c.max_job_samples = u64::MAX;
}

#[test]
fn finished_jobs_are_deleted_with_their_images_and_their_ids_never_come_back() {
    let server = TestServer::start(configure);
    let addr = server.addr;
    let first = submit(addr, &small_job("cornell-box"));
    let last = submit(addr, &small_job("cornell-box"));
    for id in [&first, &last] {
        assert_eq!(wait_final(addr, id, TIMEOUT)["state"], "done");
    }
    let data = server.path().join("data");
    // The newest job is deleted: no later start may give its id to another job.
    let deleted = delete(addr, &format!("/v1/jobs/{last}"));
    assert_eq!(deleted.status, 200, "{}", deleted.text());
    let deleted = deleted.json();
    assert_eq!(deleted["deleted"], true, "{deleted}");
    assert_eq!(deleted["state"], "done", "{deleted}");
    assert_eq!(get(addr, &format!("/v1/jobs/{last}")).status, 404);
    assert_eq!(get(addr, &format!("/v1/jobs/{last}/image.png")).status, 404);
    assert!(!data.join("jobs").join(&last).exists());
    assert_eq!(delete(addr, &format!("/v1/jobs/{last}")).status, 404);
    let listed = get(addr, "/v1/jobs").json();
    assert_eq!(listed["total"], 1, "{listed}");
    let health: Value = get(addr, "/healthz").json();
    assert_eq!(health["status"], "ok", "{health}");

    // A running job is cancelled by DELETE, not deleted; a second DELETE deletes it.
    let running = submit(addr, &long_job("cornell-box"));
    wait_for(addr, &running, TIMEOUT, |job| job["state"] == "running");
    let cancelled = delete(addr, &format!("/v1/jobs/{running}")).json();
    assert_eq!(cancelled["state"], "cancelled", "{cancelled}");
    assert_eq!(cancelled.get("deleted"), None, "{cancelled}");
    assert_eq!(wait_final(addr, &running, TIMEOUT)["state"], "cancelled");
    assert_eq!(
        delete(addr, &format!("/v1/jobs/{running}")).json()["deleted"],
        true
    );

    // After a restart the next id is past every deleted one.
    let dir = server.stop();
    let server = TestServer::start(|c| {
        configure(c);
        c.data_dir = dir.path().join("data");
    });
    let addr = server.addr;
    let next = submit(addr, &small_job("cornell-box"));
    let number = |id: &str| id.parse::<u64>().unwrap();
    assert!(
        number(&next) > number(&running).max(number(&last)),
        "{next} after {last} and {running}"
    );
    assert_eq!(
        get(addr, &format!("/v1/jobs/{first}")).json()["state"],
        "done"
    );
    assert_eq!(get(addr, &format!("/v1/jobs/{last}")).status, 404);
}

#[test]
fn uploaded_scenes_are_deleted_unless_a_job_uses_them() {
    let server = TestServer::start(configure);
    let addr = server.addr;
    let uploaded = upload_glb(addr, &sample_glb("Box"));
    assert_eq!(uploaded.status, 201, "{}", uploaded.text());
    let id = uploaded.json()["scene"]["id"].as_str().unwrap().to_string();
    let scene_url = format!("/v1/scenes/{id}");

    // In use by a running job: refused, and the scene stays.
    let running = submit(addr, &long_job(&id));
    wait_for(addr, &running, TIMEOUT, |job| job["state"] == "running");
    let refused = delete(addr, &scene_url);
    assert_eq!(refused.status, 409, "{}", refused.text());
    assert_eq!(refused.error_code(), "scene_in_use");
    assert!(refused.text().contains(&running), "{}", refused.text());
    assert_eq!(delete(addr, &format!("/v1/jobs/{running}")).status, 200);
    wait_final(addr, &running, TIMEOUT);

    // Then deleted: gone from the list and from disk, and jobs cannot name it.
    let deleted = delete(addr, &scene_url);
    assert_eq!(deleted.status, 200, "{}", deleted.text());
    assert_eq!(deleted.json()["scene"]["id"], id.as_str());
    let scenes = get(addr, "/v1/scenes").json();
    assert!(
        scenes["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["name"] != id.as_str()),
        "{scenes}"
    );
    let uploads = server.path().join("data").join("scenes");
    assert!(!uploads.join(format!("{id}.glb")).exists());
    assert!(!uploads.join(format!("{id}.json")).exists());
    let refused = post_json(addr, "/v1/jobs", &small_job(&id));
    assert_eq!(refused.error_code(), "unknown_scene", "{}", refused.text());
    assert_eq!(delete(addr, &scene_url).error_code(), "scene_not_found");

    // Bundled scenes are not the service's to delete.
    let bundled = delete(addr, "/v1/scenes/cornell-box");
    assert_eq!(bundled.status, 409);
    assert_eq!(bundled.error_code(), "scene_not_deletable");
    assert_eq!(
        delete(addr, "/v1/scenes/no-such-scene").error_code(),
        "unknown_scene"
    );
}

#[test]
fn a_full_quota_refuses_new_work_until_something_is_deleted() {
    let server = TestServer::start(configure);
    let addr = server.addr;
    let id = submit(addr, &small_job("cornell-box"));
    assert_eq!(wait_final(addr, &id, TIMEOUT)["state"], "done");
    let used = |addr| {
        metric(&get(addr, "/metrics").text(), "gi_data_dir_used_bytes")
            .expect("the data folder's size") as u64
    };
    // Restarted with a quota of what the folder holds now: full.
    let quota = used(addr);
    let dir = server.stop();
    let data = dir.path().join("data");
    let server = TestServer::start(|c| {
        configure(c);
        c.data_dir = data.clone();
        c.max_stored_bytes = quota;
    });
    let addr = server.addr;
    for refused in [
        post_json(addr, "/v1/jobs", &small_job("cornell-box")),
        upload_glb(addr, &sample_glb("Box")),
    ] {
        assert_eq!(refused.status, 507, "{}", refused.text());
        assert_eq!(refused.error_code(), "quota_exceeded");
        assert!(refused.text().contains("--max-stored-bytes"));
    }
    // Deleting the finished job frees room (the folder is measured again after a second).
    assert_eq!(delete(addr, &format!("/v1/jobs/{id}")).status, 200);
    std::thread::sleep(Duration::from_millis(1100));
    assert!(used(addr) < quota);
    let again = submit(addr, &small_job("cornell-box"));
    assert_eq!(wait_final(addr, &again, TIMEOUT)["state"], "done");
}

#[test]
fn a_job_past_its_time_limit_fails_and_the_next_one_runs() {
    let server = TestServer::start(|c| {
        configure(c);
        c.job_time_limit_s = 1;
    });
    let addr = server.addr;
    let started = std::time::Instant::now();
    let long = submit(addr, &long_job("cornell-box"));
    let job = wait_final(addr, &long, TIMEOUT);
    assert_eq!(job["state"], "failed", "{job}");
    assert_eq!(job["error"]["code"], "time_limit", "{job}");
    assert!(
        job["error"]["message"]
            .as_str()
            .unwrap()
            .contains("--job-time-limit-s"),
        "{job}"
    );
    // Stopped at its next pass, long before its minutes of samples.
    assert!(
        started.elapsed() < Duration::from_secs(30),
        "{:?}",
        started.elapsed()
    );
    let small = submit(addr, &small_job("cornell-box"));
    assert_eq!(wait_final(addr, &small, TIMEOUT)["state"], "done");
}

#[test]
fn a_job_over_the_cost_budget_is_refused_with_its_estimate() {
    let server = TestServer::start(|c| {
        configure(c);
        c.max_job_samples = 10_000;
    });
    let addr = server.addr;
    // 64 x 48 pixels at 4 samples: 12,288 samples, over the budget; the same at 3 is not.
    let mut job = json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48,
                         "spp": 4, "compare": false});
    let refused = post_json(addr, "/v1/jobs", &job);
    assert_eq!(refused.status, 422, "{}", refused.text());
    assert_eq!(refused.error_code(), "job_too_costly");
    assert!(refused.text().contains("1.229e4"), "{}", refused.text());
    job["spp"] = json!(3);
    submit(addr, &job);
    // A comparison's reference counts: 64 x 48 x (1 + 3) samples.
    let compared = json!({"scene": "cornell-box", "tier": "reference", "width": 64,
                          "height": 48, "spp": 1, "compare": true, "reference_spp": 3});
    let refused = post_json(addr, "/v1/jobs", &compared);
    assert_eq!(refused.error_code(), "job_too_costly", "{}", refused.text());
    assert!(
        refused.text().contains("its reference"),
        "{}",
        refused.text()
    );
    // Without a GPU, auto renders the reference: its spp counts.
    let auto = json!({"scene": "cornell-box", "tier": "auto", "width": 64, "height": 48,
                      "spp": 4, "compare": false});
    let refused = post_json(addr, "/v1/jobs", &auto);
    assert_eq!(refused.error_code(), "job_too_costly", "{}", refused.text());
}

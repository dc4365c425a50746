//! Job records corrupted on disk while the service is stopped (one torn, one garbage; one of a
//! finished job, one of a queued job): after the restart neither job vanishes. Both are listed
//! and served as `unreadable` with the parse error, counted by `/healthz` (200, `degraded`)
//! and `/metrics`, never run and never overwritten, and new jobs take other ids. `DELETE`
//! removes such a job's folder, and the service is healthy again.

mod common;

use std::time::Duration;

use common::*;
use serde_json::{Value, json};

const TIMEOUT: Duration = Duration::from_secs(120);

#[test]
fn corrupt_records_are_listed_as_unreadable_jobs_after_a_restart() {
    let configure = |c: &mut gi_server::Config| {
        c.no_gpu = true;
        c.reference_pool = 1;
        c.max_spp = 1 << 20;
    };
    let server = TestServer::start(configure);
    let addr = server.addr;
    let small = json!({"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1, "compare": false});
    let finished = submit(addr, &small);
    assert_eq!(wait_final(addr, &finished, TIMEOUT)["state"], "done");
    // The only CPU worker busy with a long reference, so the next job stays queued.
    let blocker = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48, "spp": 1,
                "compare": true, "reference_spp": 1 << 20}),
    );
    wait_for(addr, &blocker, TIMEOUT, |job| {
        job["progress"]["stage"] == "reference"
    });
    let queued = submit(addr, &small);
    assert_eq!(
        get(addr, &format!("/v1/jobs/{queued}")).json()["state"],
        "queued"
    );
    let dir = server.stop();

    let data = dir.path().join("data");
    let record = |id: &str| data.join("jobs").join(id).join("job.json");
    let queued_record = std::fs::read(record(&queued)).unwrap();
    assert!(String::from_utf8_lossy(&queued_record).contains("\"queued\""));
    std::fs::write(record(&queued), &queued_record[..queued_record.len() / 2]).unwrap();
    std::fs::write(record(&finished), b"\x00\x01 not json").unwrap();

    let server = TestServer::start(|c| {
        configure(c);
        c.data_dir = data.clone();
    });
    let addr = server.addr;
    assert_eq!(delete(addr, &format!("/v1/jobs/{blocker}")).status, 200);

    for (id, why) in [
        (&queued, "EOF while parsing"),
        (&finished, "expected value"),
    ] {
        let job = get(addr, &format!("/v1/jobs/{id}"));
        assert_eq!(job.status, 200, "{}", job.text());
        let job = job.json();
        assert_eq!(job["state"], "unreadable", "{job}");
        assert_eq!(job["error"]["code"], "unreadable_record", "{job}");
        let message = job["error"]["message"].as_str().unwrap();
        assert!(
            message.contains(&format!("jobs/{id}/job.json")) && message.contains(why),
            "{message}"
        );
        // Not served as a finished job.
        let image = get(addr, &format!("/v1/jobs/{id}/image.png"));
        assert_eq!(image.error_code(), "job_unreadable");
    }

    // Listed, newest first, among the readable jobs; and on their own.
    let listed = get(addr, "/v1/jobs").json();
    assert_eq!(listed["total"], 3, "{listed}");
    let states: Vec<(&str, &str)> = listed["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| (j["id"].as_str().unwrap(), j["state"].as_str().unwrap()))
        .collect();
    assert_eq!(
        states,
        [
            (queued.as_str(), "unreadable"),
            (blocker.as_str(), "cancelled"),
            (finished.as_str(), "unreadable")
        ]
    );
    let only = get(addr, "/v1/jobs?state=unreadable&limit=1").json();
    assert_eq!(only["total"], 2, "{only}");
    assert_eq!(only["jobs"][0]["id"], queued.as_str());
    let next = only["next"].as_str().unwrap();
    assert_eq!(get(addr, next).json()["jobs"][0]["id"], finished.as_str());

    // The service works, and says a person should look.
    let health = get(addr, "/healthz");
    assert_eq!(health.status, 200);
    let health: Value = health.json();
    assert_eq!(health["status"], "degraded", "{health}");
    assert_eq!(health["unreadable_jobs"], 2, "{health}");
    let metrics = get(addr, "/metrics").text();
    assert!(
        metrics.lines().any(|l| l == "gi_jobs_unreadable 2"),
        "{metrics}"
    );

    // New jobs never take an unreadable job's id, and the broken files are left as they were.
    let new = submit(addr, &small);
    assert!(new.parse::<u64>().unwrap() > queued.parse::<u64>().unwrap());
    assert_eq!(wait_final(addr, &new, TIMEOUT)["state"], "done");
    assert_eq!(
        std::fs::read(record(&finished)).unwrap(),
        b"\x00\x01 not json"
    );

    // Deleting them removes their folders; the service says it is healthy again.
    for id in [&queued, &finished] {
        let deleted = delete(addr, &format!("/v1/jobs/{id}"));
        assert_eq!(deleted.status, 200, "{}", deleted.text());
        let deleted = deleted.json();
        assert_eq!(
            (&deleted["state"], &deleted["deleted"]),
            (&json!("unreadable"), &json!(true)),
            "{deleted}"
        );
        assert_eq!(get(addr, &format!("/v1/jobs/{id}")).status, 404);
        assert!(!data.join("jobs").join(id).exists());
    }
    let health: Value = get(addr, "/healthz").json();
    assert_eq!(health["status"], "ok", "{health}");
}

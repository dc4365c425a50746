//! 200 concurrent submissions against a bounded queue: every one is either accepted (and then
//! listed and run) or turned away with 429 and Retry-After; none is lost or counted twice.

mod common;

use std::{collections::BTreeSet, sync::Arc, time::Duration};

use common::*;
use serde_json::json;

const QUEUE: usize = 20;
const SUBMISSIONS: usize = 200;
const CLIENTS: usize = 20;

#[test]
fn concurrent_submissions_are_all_accounted_for_and_a_full_queue_answers_429() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.reference_pool = 1;
        c.max_queue = QUEUE;
        c.max_spp = 1 << 20;
    });
    let addr = server.addr;

    // Occupy the only CPU worker with a reference it would take hours to finish, so the queue
    // cannot drain while the clients submit.
    let blocker = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 64, "height": 48, "spp": 1,
                "compare": true, "reference_spp": 1 << 20}),
    );
    wait_for(addr, &blocker, Duration::from_secs(60), |job| {
        job["progress"]["stage"] == "reference"
    });

    let job = Arc::new(
        json!({"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1, "compare": false}),
    );
    let clients: Vec<_> = (0..CLIENTS)
        .map(|_| {
            let job = job.clone();
            std::thread::spawn(move || {
                (0..SUBMISSIONS / CLIENTS)
                    .map(|_| post_json(addr, "/v1/jobs", &job))
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    let responses: Vec<Response> = clients
        .into_iter()
        .flat_map(|c| c.join().unwrap())
        .collect();
    assert_eq!(responses.len(), SUBMISSIONS);

    let mut accepted = BTreeSet::new();
    let mut rejected = 0;
    for response in &responses {
        match response.status {
            202 => {
                let id: u64 = response.json()["id"].as_str().unwrap().parse().unwrap();
                assert!(accepted.insert(id), "id {id} given twice");
            }
            429 => {
                assert_eq!(response.error_code(), "queue_full");
                let retry: u64 = response
                    .header("retry-after")
                    .expect("Retry-After")
                    .parse()
                    .unwrap();
                assert!((1..=60).contains(&retry), "Retry-After {retry}");
                rejected += 1;
            }
            other => panic!("unexpected status {other}: {}", response.text()),
        }
    }
    // Exactly the queue's room was accepted: the worker took nothing meanwhile.
    assert_eq!(accepted.len(), QUEUE);
    assert_eq!(rejected, SUBMISSIONS - QUEUE);
    let metrics = get(addr, "/metrics").text();
    assert!(
        metrics
            .lines()
            .any(|l| l == format!("gi_queue_depth {QUEUE}")),
        "{metrics}"
    );
    assert!(
        metrics
            .lines()
            .any(|l| l == format!("gi_jobs_rejected_total{{reason=\"queue_full\"}} {rejected}")),
        "{metrics}"
    );

    // The list holds exactly the accepted jobs and the blocker.
    let listed: BTreeSet<u64> = get(addr, "/v1/jobs?limit=100").json()["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_str().unwrap().parse().unwrap())
        .collect();
    let mut expected = accepted.clone();
    expected.insert(blocker.parse().unwrap());
    assert_eq!(listed, expected);

    // Freed, the worker runs every accepted job.
    assert_eq!(delete(addr, &format!("/v1/jobs/{blocker}")).status, 200);
    for id in &accepted {
        let job = wait_final(addr, &id.to_string(), Duration::from_secs(60));
        assert_eq!(job["state"], "done", "{job}");
    }
    // Room again.
    submit(addr, &job);
}

//! The service over a data folder whose writes fail on demand, as on a full disk: requests
//! are answered 507 (500 for other errors) and change nothing, a job's state on disk and in
//! the API never contradict each other, and a final state is never left.

use std::{
    io,
    path::Path,
    sync::{
        Arc,
        atomic::{AtomicUsize, Ordering},
    },
    time::{Duration, Instant},
};

use axum::http::StatusCode;
use gi_reference::engine::CpuEngine;

use super::Service;
use crate::{
    config::Config,
    job::{JobRecord, JobRequest, JobState},
    store::Store,
};

/// A service without a GPU over `dir`, its workers not started.
fn open(dir: &Path) -> Arc<Service> {
    let mut config = Config::with_data_dir(dir.join("data"));
    config.no_gpu = true;
    config.cache_dir = Some(dir.join("cache"));
    config.reference_pool = 1;
    let store = Store::open(&config.data_dir).unwrap();
    Service::recover(config, store, None, Arc::new(CpuEngine))
        .unwrap()
        .0
}

/// A small CPU job that does not compare.
fn small_job() -> JobRequest {
    serde_json::from_str(
        r#"{"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1,
            "compare": false}"#,
    )
    .unwrap()
}

/// Job `id`'s record as the data folder holds it.
fn on_disk(service: &Service, id: u64) -> JobRecord {
    let bytes = std::fs::read(service.store.job_dir(id).join("job.json")).unwrap();
    serde_json::from_slice(&bytes).unwrap()
}

fn shown_state(service: &Service, id: u64) -> String {
    service.view(id).unwrap()["state"]
        .as_str()
        .unwrap()
        .to_string()
}

/// Waits until `done` holds, failing the test after a minute.
async fn wait_until(what: &str, done: impl Fn() -> bool) {
    let started = Instant::now();
    while !done() {
        assert!(started.elapsed() < Duration::from_secs(60), "never {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_disk_refuses_submissions_and_cancellations_with_507_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let service = open(dir.path());
    let writer = service.store.writer().clone();
    let queued = service.submit(small_job()).await.unwrap();

    writer.fail_with(Some(io::ErrorKind::StorageFull));
    let refused = service.submit(small_job()).await.unwrap_err();
    assert_eq!(
        refused.status,
        StatusCode::INSUFFICIENT_STORAGE,
        "{refused}"
    );
    assert_eq!(refused.code, "insufficient_storage");
    assert!(refused.message.contains("disk is full"), "{refused}");
    // Not accepted: not listed, no folder left behind, its id never shown.
    assert_eq!(service.list(100, None, None).1, 1);
    assert!(!service.store.job_dir(queued.id + 1).exists());

    let refused = service.cancel(queued.id).await.unwrap_err();
    assert_eq!(
        refused.status,
        StatusCode::INSUFFICIENT_STORAGE,
        "{refused}"
    );
    assert_eq!(shown_state(&service, queued.id), "queued");
    assert_eq!(on_disk(&service, queued.id).state, JobState::Queued);

    // Another I/O error is a 500 that says what failed.
    writer.fail_with(Some(io::ErrorKind::PermissionDenied));
    let refused = service.submit(small_job()).await.unwrap_err();
    assert_eq!(refused.status, StatusCode::INTERNAL_SERVER_ERROR);
    assert!(
        refused.message.contains("storing the job failed"),
        "{refused}"
    );

    let (status, health) = service.health_blocking();
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE, "{health}");
    assert_eq!(health["storage"]["writable"], false, "{health}");

    // Space again: the same requests succeed.
    writer.fail_with(None);
    assert_eq!(service.health_blocking().0, StatusCode::OK);
    let cancelled = service.cancel(queued.id).await.unwrap();
    assert_eq!(cancelled.state, JobState::Cancelled);
    assert_eq!(on_disk(&service, queued.id).state, JobState::Cancelled);
    let next = service.submit(small_job()).await.unwrap();
    assert!(
        next.id > queued.id + 1,
        "the refused submission's id is not reused"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_result_that_cannot_be_stored_never_shows_a_state_the_disk_does_not_hold() {
    let dir = tempfile::tempdir().unwrap();
    let service = open(dir.path());
    let id = service.submit(small_job()).await.unwrap().id;
    // The disk fills up once the job runs: after its `running` record, its images and every
    // record fail to store.
    let records = Arc::new(AtomicUsize::new(0));
    let stored = records.clone();
    service.store.writer().fail_when(move |path| {
        let earlier = if path.ends_with("job.json") {
            stored.fetch_add(1, Ordering::SeqCst)
        } else {
            stored.load(Ordering::SeqCst)
        };
        (earlier >= 1).then_some(io::ErrorKind::StorageFull)
    });
    let worker = tokio::spawn(service.clone().cpu_worker());

    // The render ends, its images and then its failure cannot be stored: the service keeps
    // showing what the disk holds, `running`, and tries again.
    wait_until("tried to store the failure twice", || {
        records.load(Ordering::SeqCst) >= 3
    })
    .await;
    assert_eq!(shown_state(&service, id), "running");
    assert_eq!(on_disk(&service, id).state, JobState::Running);

    // Space again: the failure is stored, then shown.
    service.store.writer().fail_with(None);
    wait_until("failed", || shown_state(&service, id) == "failed").await;
    let record = on_disk(&service, id);
    assert_eq!(record.state, JobState::Failed);
    let failure = record.failure.unwrap();
    assert_eq!(failure.code, "insufficient_storage", "{failure:?}");
    assert!(
        failure.message.contains("storing the images"),
        "{failure:?}"
    );
    assert!(!service.store.job_dir(id).join("image.png").exists());

    // Final is final: no change leaves it, in memory or on disk.
    let reopened = service.transition_blocking(id, |record| {
        record.state = JobState::Done;
        true
    });
    assert!(matches!(reopened, Ok(None)), "{reopened:?}");
    assert_eq!(shown_state(&service, id), "failed");
    assert_eq!(on_disk(&service, id).state, JobState::Failed);

    // A restart finds it failed, and does not run it again.
    service.shut_down();
    worker.await.unwrap();
    drop(service);
    let service = open(dir.path());
    assert_eq!(shown_state(&service, id), "failed");
    assert_eq!(service.counts()[JobState::Queued.index()], 0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_start_that_cannot_be_stored_leaves_the_job_queued_until_it_can() {
    let dir = tempfile::tempdir().unwrap();
    let service = open(dir.path());
    let id = service.submit(small_job()).await.unwrap().id;
    service
        .store
        .writer()
        .fail_with(Some(io::ErrorKind::StorageFull));
    let worker = tokio::spawn(service.clone().cpu_worker());
    tokio::time::sleep(Duration::from_millis(1500)).await;
    assert_eq!(shown_state(&service, id), "queued");
    assert_eq!(on_disk(&service, id).state, JobState::Queued);
    assert_eq!(on_disk(&service, id).attempts, 0);

    service.store.writer().fail_with(None);
    wait_until("done", || shown_state(&service, id) == "done").await;
    let record = on_disk(&service, id);
    assert_eq!((record.state, record.attempts), (JobState::Done, 1));
    service.shut_down();
    worker.await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_disk_below_the_free_space_floor_refuses_new_work_and_fails_the_health_check() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = Config::with_data_dir(dir.path().join("data"));
    config.no_gpu = true;
    config.min_free_bytes = u64::MAX;
    let store = Store::open(&config.data_dir).unwrap();
    let (service, _) = Service::recover(config, store, None, Arc::new(CpuEngine)).unwrap();
    let refused = service.submit(small_job()).await.unwrap_err();
    assert_eq!(
        refused.status,
        StatusCode::INSUFFICIENT_STORAGE,
        "{refused}"
    );
    assert!(refused.message.contains("--min-free-bytes"), "{refused}");
    let refused = service.upload_scene_blocking(b"glTF", "x").unwrap_err();
    assert_eq!(
        refused.status,
        StatusCode::INSUFFICIENT_STORAGE,
        "{refused}"
    );
    let (status, health) = service.health_blocking();
    assert_eq!(status, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(health["status"], "unavailable");
    assert_eq!(health["storage"]["writable"], true);
    assert!(
        health["problems"][0]
            .as_str()
            .unwrap()
            .contains("--min-free-bytes"),
        "{health}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn higher_priorities_are_queued_first_and_equal_ones_in_submission_order() {
    let dir = tempfile::tempdir().unwrap();
    let service = open(dir.path());
    let with_priority = |priority: i32| {
        let mut request = small_job();
        request.priority = Some(priority);
        request
    };
    let mut ids = Vec::new();
    for priority in [0, 5, -3, 5, 0, 100] {
        ids.push(service.submit(with_priority(priority)).await.unwrap().id);
    }
    let queued: Vec<u64> = super::lock(&service.inner)
        .cpu_queue
        .iter()
        .map(|work| match work {
            super::CpuWork::Render(id) => *id,
            super::CpuWork::Compare(_) | super::CpuWork::CompareRendered(..) => {
                panic!("no comparison was queued")
            }
        })
        .collect();
    // 100, then the two 5s in order, the two 0s in order, then -3.
    assert_eq!(queued, [ids[5], ids[1], ids[3], ids[0], ids[4], ids[2]]);
    let error = service.submit(with_priority(101)).await.unwrap_err();
    assert_eq!(error.code, "invalid_request");
    assert!(error.message.contains("priority 101"), "{}", error.message);
}

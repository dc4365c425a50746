//! The job queue in PostgreSQL: one row per job, holding the record the API shows beside the
//! columns the queue works on (state, lane, priority, the worker running it and its lease).
//!
//! A worker takes the first queued job of its lanes, highest priority first, with
//! `FOR UPDATE SKIP LOCKED`, so any number of workers take jobs without taking one twice or
//! waiting on each other. It holds a job by a lease that its heartbeat renews; a job whose
//! lease ran out (its worker was killed, lost its machine or its network) goes back to the
//! queue, or fails once it started `max_attempts` times. Every change of a record is one
//! transaction that reads the row locked, applies the change in Rust (the same state rules as
//! the embedded service: a final state is never left) and writes it back.

use std::time::Duration;

use deadpool_postgres::{GenericClient, Pool, PoolConfig, Runtime};
use serde_json::Value;
use tokio_postgres::{NoTls, Row};

use crate::{
    error::ApiError,
    job::{JobFailure, JobRecord, JobState, StateFilter, now_rfc3339, unreadable_view},
};

/// Which workers may run a job: `any` worker, or only one with a `gpu`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    Gpu,
    Any,
}

impl Lane {
    pub fn name(self) -> &'static str {
        match self {
            Lane::Gpu => "gpu",
            Lane::Any => "any",
        }
    }
}

/// The schema, created by the first process that connects (under an advisory lock, so
/// processes starting together do not race).
const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS gi_jobs (
    id BIGSERIAL PRIMARY KEY,
    state TEXT NOT NULL,
    lane TEXT NOT NULL,
    priority INTEGER NOT NULL,
    scene TEXT NOT NULL,
    record JSONB NOT NULL,
    progress JSONB,
    worker TEXT,
    lease_until TIMESTAMPTZ
);
-- The API server's time limit for the job (seconds), applied by its worker with its own.
ALTER TABLE gi_jobs ADD COLUMN IF NOT EXISTS time_limit_s BIGINT;
CREATE INDEX IF NOT EXISTS gi_jobs_waiting ON gi_jobs (lane, priority DESC, id) WHERE state = 'queued';
CREATE INDEX IF NOT EXISTS gi_jobs_leases ON gi_jobs (lease_until) WHERE state = 'running';
CREATE INDEX IF NOT EXISTS gi_jobs_states ON gi_jobs (state, id);
CREATE TABLE IF NOT EXISTS gi_job_counts (
    state TEXT PRIMARY KEY,
    jobs BIGINT NOT NULL
);
CREATE OR REPLACE FUNCTION gi_count_jobs() RETURNS trigger AS $$
BEGIN
    -- One statement over the rows of both states, so concurrent changes lock them in the
    -- same order.
    IF TG_OP = 'INSERT' THEN
        UPDATE gi_job_counts SET jobs = jobs + 1 WHERE state = NEW.state;
    ELSIF TG_OP = 'DELETE' THEN
        UPDATE gi_job_counts SET jobs = jobs - 1 WHERE state = OLD.state;
    ELSE
        UPDATE gi_job_counts
        SET jobs = jobs + CASE WHEN state = NEW.state THEN 1 ELSE -1 END
        WHERE state IN (OLD.state, NEW.state);
    END IF;
    RETURN NULL;
END
$$ LANGUAGE plpgsql;
DROP TRIGGER IF EXISTS gi_jobs_added_or_removed ON gi_jobs;
CREATE TRIGGER gi_jobs_added_or_removed AFTER INSERT OR DELETE ON gi_jobs
    FOR EACH ROW EXECUTE FUNCTION gi_count_jobs();
DROP TRIGGER IF EXISTS gi_jobs_moved ON gi_jobs;
CREATE TRIGGER gi_jobs_moved AFTER UPDATE OF state ON gi_jobs
    FOR EACH ROW WHEN (OLD.state IS DISTINCT FROM NEW.state) EXECUTE FUNCTION gi_count_jobs();
-- Every state's row, counted from the jobs where the table is new (the triggers keep them).
INSERT INTO gi_job_counts (state, jobs)
    SELECT s.state, (SELECT count(*) FROM gi_jobs j WHERE j.state = s.state)
    FROM unnest(ARRAY['queued', 'running', 'done', 'failed', 'cancelled']) AS s(state)
    ON CONFLICT (state) DO NOTHING;
CREATE TABLE IF NOT EXISTS gi_workers (
    name TEXT PRIMARY KEY,
    gpu TEXT,
    started_at TIMESTAMPTZ NOT NULL,
    last_seen TIMESTAMPTZ NOT NULL,
    job BIGINT
);
";

/// Key of the advisory lock held while the schema is created.
const SCHEMA_LOCK: i64 = 0x6769_7363_6865_6d61;

/// Key of the advisory lock a submission holds while it checks the limits and stores its job.
const SUBMIT_LOCK: i64 = 0x6769_7375_626d_6974;

/// Why a submission was not stored.
#[derive(Debug)]
pub enum Refused {
    /// This many jobs are queued, the most allowed.
    QueueFull(u64),
    /// This many jobs are kept, the most allowed.
    JobLimit(u64),
}

/// The queue over a pool of connections.
#[derive(Clone)]
pub struct Queue {
    pool: Pool,
}

/// A job a worker took.
pub struct Claimed {
    pub record: JobRecord,
    /// The submitting API server's `--job-time-limit-s` (none: no limit).
    pub time_limit_s: Option<u64>,
}

/// A worker as the API lists it.
#[derive(Debug, serde::Serialize)]
pub struct WorkerInfo {
    pub name: String,
    pub gpu: Option<String>,
    pub started_at: String,
    pub last_seen: String,
    /// Seconds since its last heartbeat.
    pub silent_s: f64,
    pub job: Option<String>,
}

fn db_error(what: &str, error: impl std::fmt::Display) -> ApiError {
    ApiError::new(
        axum::http::StatusCode::SERVICE_UNAVAILABLE,
        "database_unavailable",
        format!("{what}: the job database failed: {error}"),
    )
}

fn id_of(row: &Row) -> u64 {
    row.get::<_, i64>("id") as u64
}

/// A row's record, or why it cannot be read.
fn parse_record(id: u64, record: Value) -> Result<JobRecord, String> {
    match serde_json::from_value::<JobRecord>(record) {
        Ok(record) if record.id == id => Ok(record),
        Ok(record) => Err(format!("gi_jobs row {id}: holds job {}", record.id)),
        Err(error) => Err(format!("gi_jobs row {id}: not a job record: {error}")),
    }
}

fn to_json(record: &JobRecord) -> Value {
    serde_json::to_value(record).expect("a job record serializes")
}

impl Queue {
    /// Connects to `url` (`postgres://user:password@host:port/database`) with at most
    /// `connections` connections, and creates the tables if they do not exist.
    pub async fn connect(url: &str, connections: usize) -> anyhow::Result<Self> {
        let mut config = deadpool_postgres::Config::new();
        config.url = Some(url.to_string());
        config.pool = Some(PoolConfig::new(connections.max(1)));
        let pool = config.create_pool(Some(Runtime::Tokio1), NoTls)?;
        let mut client = pool.get().await?;
        let transaction = client.transaction().await?;
        transaction
            .execute("SELECT pg_advisory_xact_lock($1)", &[&SCHEMA_LOCK])
            .await?;
        transaction.batch_execute(SCHEMA).await?;
        transaction.commit().await?;
        Ok(Self { pool })
    }

    async fn client(&self) -> Result<deadpool_postgres::Object, ApiError> {
        self.pool.get().await.map_err(|e| db_error("connecting", e))
    }

    /// Answers once the database answers a query.
    pub async fn ping(&self) -> Result<(), ApiError> {
        let client = self.client().await?;
        client
            .simple_query("SELECT 1")
            .await
            .map_err(|e| db_error("ping", e))?;
        Ok(())
    }

    /// Jobs per state, indexed by [`JobState::index`] (kept by triggers: no table scan).
    pub async fn counts(&self) -> Result<[usize; 5], ApiError> {
        let client = self.client().await?;
        let rows = client
            .query("SELECT state, jobs FROM gi_job_counts", &[])
            .await
            .map_err(|e| db_error("counting jobs", e))?;
        let mut counts = [0; 5];
        for row in rows {
            let state: String = row.get(0);
            if let Some(state) = JobState::ALL.iter().find(|s| s.name() == state) {
                counts[state.index()] = row.get::<_, i64>(1) as usize;
            }
        }
        Ok(counts)
    }

    /// Stores a new queued job, giving `record` its id, unless `max_queued` jobs are queued
    /// or `max_jobs` kept: then [`Refused`] says which, with the count. Submissions are
    /// serialized by a lock in the database, so the limits hold across API servers. The job
    /// may run `time_limit_s` seconds (none: no limit) on its worker.
    pub async fn insert(
        &self,
        mut record: JobRecord,
        lane: Lane,
        max_queued: u64,
        max_jobs: u64,
        time_limit_s: Option<u64>,
    ) -> Result<Result<JobRecord, Refused>, ApiError> {
        let mut client = self.client().await?;
        let fail = |e| db_error("storing the job", e);
        let transaction = client.transaction().await.map_err(fail)?;
        transaction
            .execute("SELECT pg_advisory_xact_lock($1)", &[&SUBMIT_LOCK])
            .await
            .map_err(fail)?;
        let sizes = transaction
            .query_one(
                "SELECT coalesce(sum(jobs) FILTER (WHERE state = 'queued'), 0)::BIGINT,
                        coalesce(sum(jobs), 0)::BIGINT
                 FROM gi_job_counts",
                &[],
            )
            .await
            .map_err(fail)?;
        let (queued, total) = (sizes.get::<_, i64>(0) as u64, sizes.get::<_, i64>(1) as u64);
        if queued >= max_queued {
            return Ok(Err(Refused::QueueFull(queued)));
        }
        if total >= max_jobs {
            return Ok(Err(Refused::JobLimit(total)));
        }
        let id: i64 = transaction
            .query_one(
                "SELECT nextval(pg_get_serial_sequence('gi_jobs', 'id'))",
                &[],
            )
            .await
            .map_err(fail)?
            .get(0);
        record.id = id as u64;
        transaction
            .execute(
                "INSERT INTO gi_jobs (id, state, lane, priority, scene, record, time_limit_s)
                 VALUES ($1, $2, $3, $4, $5, $6, $7)",
                &[
                    &id,
                    &record.state.name(),
                    &lane.name(),
                    &record.spec.priority,
                    &record.spec.scene,
                    &to_json(&record),
                    &time_limit_s.map(|s| s.min(i64::MAX as u64) as i64),
                ],
            )
            .await
            .map_err(fail)?;
        transaction.commit().await.map_err(fail)?;
        Ok(Ok(record))
    }

    /// Job `id` as the API shows it (its progress while it runs), `None` if there is none.
    pub async fn view(&self, id: u64) -> Result<Option<Value>, ApiError> {
        let client = self.client().await?;
        let row = client
            .query_opt(
                "SELECT id, record, progress, worker FROM gi_jobs WHERE id = $1",
                &[&(id as i64)],
            )
            .await
            .map_err(|e| db_error("reading the job", e))?;
        Ok(row.map(|row| row_view(&row)))
    }

    /// Job `id`'s record: `Ok(None)` if there is none, `Err(why)` inside when it cannot be
    /// read.
    pub async fn record(&self, id: u64) -> Result<Option<Result<JobRecord, String>>, ApiError> {
        let client = self.client().await?;
        let row = client
            .query_opt(
                "SELECT id, record FROM gi_jobs WHERE id = $1",
                &[&(id as i64)],
            )
            .await
            .map_err(|e| db_error("reading the job", e))?;
        Ok(row.map(|row| parse_record(id_of(&row), row.get("record"))))
    }

    /// Up to `limit` jobs, newest first, with ids below `before`, in `state` if given; and
    /// how many match in all.
    pub async fn list(
        &self,
        limit: usize,
        before: Option<u64>,
        state: Option<StateFilter>,
    ) -> Result<(Vec<Value>, usize), ApiError> {
        let client = self.client().await?;
        let before = before.map_or(i64::MAX, |b| b.min(i64::MAX as u64) as i64);
        let fail = |e| db_error("listing jobs", e);
        if state == Some(StateFilter::Unreadable) {
            // Rows whose record does not parse: only a damaged database has any, so they are
            // looked for by reading the records.
            let rows = client
                .query(
                    "SELECT id, record, progress, worker FROM gi_jobs ORDER BY id DESC",
                    &[],
                )
                .await
                .map_err(fail)?;
            let unreadable: Vec<Value> = rows
                .iter()
                .filter(|row| parse_record(id_of(row), row.get("record")).is_err())
                .map(row_view)
                .collect();
            let total = unreadable.len();
            let page = (unreadable.into_iter())
                .filter(|job| {
                    job["id"].as_str().and_then(|id| id.parse::<i64>().ok()) < Some(before)
                })
                .take(limit)
                .collect();
            return Ok((page, total));
        }
        let state = state.and_then(StateFilter::job_state).map(JobState::name);
        let rows = client
            .query(
                "SELECT id, record, progress, worker FROM gi_jobs
                 WHERE id < $1 AND ($2::TEXT IS NULL OR state = $2)
                 ORDER BY id DESC LIMIT $3",
                &[&before, &state, &(limit as i64)],
            )
            .await
            .map_err(fail)?;
        let total: i64 = client
            .query_one(
                "SELECT coalesce(sum(jobs), 0)::BIGINT FROM gi_job_counts
                 WHERE $1::TEXT IS NULL OR state = $1",
                &[&state],
            )
            .await
            .map_err(fail)?
            .get(0);
        Ok((rows.iter().map(row_view).collect(), total as usize))
    }

    /// Changes job `id`'s record in one transaction: `change` edits it and says whether it
    /// applies. A final state is never left. Answers the stored record (`None`: unchanged or
    /// no such job).
    pub async fn transition(
        &self,
        id: u64,
        change: impl FnOnce(&mut JobRecord) -> bool,
    ) -> Result<Option<JobRecord>, ApiError> {
        let mut client = self.client().await?;
        let fail = |e| db_error("changing the job", e);
        let transaction = client.transaction().await.map_err(fail)?;
        let Some(row) = transaction
            .query_opt(
                "SELECT id, record FROM gi_jobs WHERE id = $1 FOR UPDATE",
                &[&(id as i64)],
            )
            .await
            .map_err(fail)?
        else {
            return Ok(None);
        };
        let Ok(mut record) = parse_record(id, row.get("record")) else {
            return Ok(None);
        };
        let before = record.state;
        if before.is_final() || !change(&mut record) {
            return Ok(None);
        }
        write_record(&transaction, &record, None)
            .await
            .map_err(fail)?;
        transaction.commit().await.map_err(fail)?;
        Ok(Some(record))
    }

    /// Deletes job `id`'s row if its job is finished (or unreadable). Answers whether it did.
    pub async fn delete_finished(&self, id: u64) -> Result<bool, ApiError> {
        let client = self.client().await?;
        let deleted = client
            .execute(
                "DELETE FROM gi_jobs WHERE id = $1 AND state NOT IN ('queued', 'running')",
                &[&(id as i64)],
            )
            .await
            .map_err(|e| db_error("deleting the job", e))?;
        Ok(deleted == 1)
    }

    /// Queued or running jobs that render scene `scene`.
    pub async fn jobs_using(&self, scene: &str) -> Result<Vec<u64>, ApiError> {
        let client = self.client().await?;
        let rows = client
            .query(
                "SELECT id FROM gi_jobs WHERE scene = $1 AND state IN ('queued', 'running')
                 ORDER BY id",
                &[&scene],
            )
            .await
            .map_err(|e| db_error("reading jobs", e))?;
        Ok(rows.iter().map(id_of).collect())
    }

    /// Registers (or re-registers) worker `name`.
    pub async fn register_worker(&self, name: &str, gpu: Option<&str>) -> Result<(), ApiError> {
        let client = self.client().await?;
        client
            .execute(
                "INSERT INTO gi_workers (name, gpu, started_at, last_seen)
                 VALUES ($1, $2, now(), now())
                 ON CONFLICT (name) DO UPDATE
                 SET gpu = $2, started_at = now(), last_seen = now(), job = NULL",
                &[&name, &gpu],
            )
            .await
            .map_err(|e| db_error("registering the worker", e))?;
        Ok(())
    }

    /// Removes worker `name` from the list (it stopped).
    pub async fn unregister_worker(&self, name: &str) -> Result<(), ApiError> {
        let client = self.client().await?;
        client
            .execute("DELETE FROM gi_workers WHERE name = $1", &[&name])
            .await
            .map_err(|e| db_error("unregistering the worker", e))?;
        Ok(())
    }

    /// The workers heard from within `within`, newest first.
    pub async fn workers(&self, within: Duration) -> Result<Vec<WorkerInfo>, ApiError> {
        let client = self.client().await?;
        let rows = client
            .query(
                "SELECT name, gpu,
                        to_char(started_at AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"'),
                        to_char(last_seen AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"'),
                        EXTRACT(EPOCH FROM now() - last_seen)::FLOAT8, job
                 FROM gi_workers
                 WHERE last_seen > now() - make_interval(secs => $1)
                 ORDER BY started_at DESC",
                &[&within.as_secs_f64()],
            )
            .await
            .map_err(|e| db_error("listing workers", e))?;
        Ok(rows
            .iter()
            .map(|row| WorkerInfo {
                name: row.get(0),
                gpu: row.get(1),
                started_at: row.get(2),
                last_seen: row.get(3),
                silent_s: row.get(4),
                job: row.get::<_, Option<i64>>(5).map(|id| id.to_string()),
            })
            .collect())
    }

    /// Takes the first queued job of `lanes` (highest priority, then oldest) for worker
    /// `worker`, holding it for `lease`: it becomes running, its start counted. A job that
    /// already started `max_attempts` times fails instead and the next one is looked at.
    pub async fn claim(
        &self,
        worker: &str,
        lanes: &[Lane],
        lease: Duration,
        max_attempts: u32,
    ) -> Result<Option<Claimed>, ApiError> {
        let lanes: Vec<&str> = lanes.iter().map(|l| l.name()).collect();
        let mut client = self.client().await?;
        let fail = |e| db_error("taking a job", e);
        loop {
            let transaction = client.transaction().await.map_err(fail)?;
            let Some(row) = transaction
                .query_opt(
                    "SELECT id, record, time_limit_s FROM gi_jobs
                     WHERE state = 'queued' AND lane = ANY($1)
                     ORDER BY priority DESC, id LIMIT 1
                     FOR UPDATE SKIP LOCKED",
                    &[&lanes],
                )
                .await
                .map_err(fail)?
            else {
                return Ok(None);
            };
            let id = id_of(&row);
            let time_limit_s = row
                .get::<_, Option<i64>>("time_limit_s")
                .map(|s| s.max(0) as u64);
            let mut record = match parse_record(id, row.get("record")) {
                Ok(record) => record,
                Err(error) => {
                    // Never taken again: marked failed in its columns, the record left as it
                    // is for a person to look at.
                    tracing::error!("{error}; the job is set aside");
                    transaction
                        .execute(
                            "UPDATE gi_jobs SET state = 'failed' WHERE id = $1",
                            &[&(id as i64)],
                        )
                        .await
                        .map_err(fail)?;
                    transaction.commit().await.map_err(fail)?;
                    continue;
                }
            };
            if record.attempts >= max_attempts {
                record.state = JobState::Failed;
                record.finished_at = Some(now_rfc3339());
                record.failure = Some(JobFailure {
                    code: "too_many_attempts".to_string(),
                    message: format!(
                        "the job started {} times without finishing (its workers stopped or \
                         were lost)",
                        record.attempts
                    ),
                });
                write_record(&transaction, &record, None)
                    .await
                    .map_err(fail)?;
                transaction.commit().await.map_err(fail)?;
                continue;
            }
            record.state = JobState::Running;
            record.attempts += 1;
            record.started_at = Some(now_rfc3339());
            write_record(&transaction, &record, Some((worker, lease)))
                .await
                .map_err(fail)?;
            transaction
                .execute(
                    "UPDATE gi_workers SET job = $2, last_seen = now() WHERE name = $1",
                    &[&worker, &(id as i64)],
                )
                .await
                .map_err(fail)?;
            transaction.commit().await.map_err(fail)?;
            return Ok(Some(Claimed {
                record,
                time_limit_s,
            }));
        }
    }

    /// Worker `worker`'s heartbeat: it is alive, and still holds job `job` (if any) for
    /// another `lease`, with `progress`. Answers false when the job is no longer its to run
    /// (cancelled, deleted, or taken back after a lease ran out): the render should stop.
    pub async fn heartbeat(
        &self,
        worker: &str,
        job: Option<u64>,
        lease: Duration,
        progress: Option<Value>,
    ) -> Result<bool, ApiError> {
        let client = self.client().await?;
        let fail = |e| db_error("heartbeat", e);
        let job = job.map(|id| id as i64);
        client
            .execute(
                "UPDATE gi_workers SET last_seen = now(), job = $2 WHERE name = $1",
                &[&worker, &job],
            )
            .await
            .map_err(fail)?;
        let Some(job) = job else {
            return Ok(true);
        };
        let held = client
            .execute(
                "UPDATE gi_jobs
                 SET lease_until = now() + make_interval(secs => $3), progress = $4
                 WHERE id = $1 AND worker = $2 AND state = 'running'",
                &[&job, &worker, &lease.as_secs_f64(), &progress],
            )
            .await
            .map_err(fail)?;
        Ok(held == 1)
    }

    /// Stores the end of job `record.id` run by `worker` (done, failed, or queued again
    /// when its worker stops), if the job is still running there. Answers whether it was.
    pub async fn finish(&self, worker: &str, record: &JobRecord) -> Result<bool, ApiError> {
        let mut client = self.client().await?;
        let fail = |e| db_error("storing the job's end", e);
        let transaction = client.transaction().await.map_err(fail)?;
        let held = transaction
            .query_opt(
                "SELECT id FROM gi_jobs
                 WHERE id = $1 AND worker = $2 AND state = 'running' FOR UPDATE",
                &[&(record.id as i64), &worker],
            )
            .await
            .map_err(fail)?
            .is_some();
        if held {
            write_record(&transaction, record, None)
                .await
                .map_err(fail)?;
        }
        transaction
            .execute(
                "UPDATE gi_workers SET job = NULL, last_seen = now() WHERE name = $1",
                &[&worker],
            )
            .await
            .map_err(fail)?;
        transaction.commit().await.map_err(fail)?;
        Ok(held)
    }

    /// Jobs whose worker's lease ran out go back to the queue (their start counted: the
    /// next claim fails a job that started `max_attempts` times). Answers their ids.
    pub async fn requeue_expired(&self) -> Result<Vec<u64>, ApiError> {
        let mut client = self.client().await?;
        let fail = |e| db_error("requeueing lost jobs", e);
        let transaction = client.transaction().await.map_err(fail)?;
        let rows = transaction
            .query(
                "SELECT id, record, worker FROM gi_jobs
                 WHERE state = 'running' AND lease_until < now()
                 FOR UPDATE SKIP LOCKED",
                &[],
            )
            .await
            .map_err(fail)?;
        let mut requeued = Vec::new();
        for row in rows {
            let id = id_of(&row);
            let Ok(mut record) = parse_record(id, row.get("record")) else {
                continue;
            };
            let worker: Option<String> = row.get("worker");
            tracing::warn!(
                job = id,
                worker = worker.as_deref().unwrap_or("?"),
                "the job's worker stopped renewing its lease; the job is queued again"
            );
            record.state = JobState::Queued;
            record.started_at = None;
            write_record(&transaction, &record, None)
                .await
                .map_err(fail)?;
            requeued.push(id);
        }
        transaction.commit().await.map_err(fail)?;
        Ok(requeued)
    }
}

/// Writes `record` into its row with its state; `held`: the worker that runs it and for how
/// long (a running job), else the worker and lease are cleared.
async fn write_record(
    client: &impl GenericClient,
    record: &JobRecord,
    held: Option<(&str, Duration)>,
) -> Result<(), tokio_postgres::Error> {
    let (worker, lease) = match held {
        Some((worker, lease)) => (Some(worker), Some(lease.as_secs_f64())),
        None => (None, None),
    };
    client
        .execute(
            "UPDATE gi_jobs
             SET state = $2, record = $3, worker = $4,
                 lease_until = now() + make_interval(secs => $5), progress = NULL
             WHERE id = $1",
            &[
                &(record.id as i64),
                &record.state.name(),
                &to_json(record),
                &worker,
                &lease,
            ],
        )
        .await?;
    Ok(())
}

/// A row as the API shows its job.
fn row_view(row: &Row) -> Value {
    let id = id_of(row);
    match parse_record(id, row.get("record")) {
        Ok(record) => {
            let mut view = record.view(None);
            if record.state == JobState::Running {
                if let Some(progress) = row.get::<_, Option<Value>>("progress") {
                    view["progress"] = progress;
                }
                // Which gi-worker runs it.
                view["worker"] = row.get::<_, Option<String>>("worker").into();
            }
            view
        }
        Err(error) => unreadable_view(id, &error),
    }
}

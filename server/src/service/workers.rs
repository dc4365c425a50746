//! The workers: the GPU worker and the CPU pool take jobs from their queues, render them,
//! compare them with the reference and store their end.

use std::{
    sync::{
        Arc,
        atomic::{AtomicBool, Ordering},
    },
    time::{Duration, Instant},
};

use gi_tiers::CancelCheck;

use super::{Comparing, CpuWork, Inner, Lane, STORE_RETRY, Service, lock, with_lighting};
use crate::{
    error::{ApiError, is_disk_full},
    job::{
        Comparison, IMAGE_FILES, JobFailure, JobRecord, JobResult, JobSpec, JobState, Progress,
        now_rfc3339,
    },
    job_process::{self, JobHost, JobPart, JobTask},
    runner::{self, PreparedJob, TierOutput},
};

impl Service {
    /// The GPU worker: one job at a time.
    pub async fn gpu_worker(self: Arc<Self>) {
        let mut host = JobHost::default();
        while let Some(id) = self.next_work(|inner| inner.gpu_queue.pop_front()).await {
            self.run_tier(id, Lane::Gpu, &mut host).await;
        }
    }

    /// One worker of the CPU pool.
    pub async fn cpu_worker(self: Arc<Self>) {
        let mut host = JobHost::default();
        while let Some(work) = self.next_work(|inner| inner.cpu_queue.pop_front()).await {
            match work {
                CpuWork::Render(id) => self.run_tier(id, Lane::Cpu, &mut host).await,
                CpuWork::Compare(comparing) => self.run_compare(*comparing).await,
                CpuWork::CompareRendered(id, rendered) => {
                    self.compare_rendered(id, rendered, &mut host).await
                }
            }
        }
    }

    /// Waits for work taken by `take`; `None` once the service shuts down.
    async fn next_work<T>(&self, take: impl Fn(&mut Inner) -> Option<T>) -> Option<T> {
        loop {
            // Registered before the queue is looked at, so a push in between still wakes us.
            let notified = self.work_ready.notified();
            if self.is_shutting_down() {
                return None;
            }
            if let Some(work) = take(&mut lock(&self.inner)) {
                return Some(work);
            }
            notified.await;
        }
    }

    /// Marks job `id` running if it is still queued, and sets its deadline; its spec, cancel
    /// flag and deadline. `Err` when the change could not be stored: the job is still queued.
    async fn start(self: &Arc<Self>, id: u64) -> std::io::Result<Option<Started>> {
        let started = self
            .transition(id, |record| {
                if record.state != JobState::Queued {
                    return false;
                }
                record.attempts += 1;
                record.started_at = Some(now_rfc3339());
                record.state = JobState::Running;
                true
            })
            .await?;
        let Some(record) = started else {
            return Ok(None);
        };
        self.set_progress(id, job_process::preparing());
        let limit = self.config.job_time_limit_s;
        let deadline = (limit > 0).then(|| Instant::now() + Duration::from_secs(limit));
        let mut inner = lock(&self.inner);
        let Some(entry) = inner.jobs.get_mut(&id) else {
            return Ok(None);
        };
        entry.deadline = deadline;
        Ok(Some(Started {
            spec: record.spec,
            cancel: entry.cancel.clone(),
            deadline,
        }))
    }

    fn set_progress(&self, id: u64, progress: Progress) {
        let mut inner = lock(&self.inner);
        if let Some(entry) = inner.jobs.get_mut(&id)
            && entry.record.state == JobState::Running
        {
            entry.progress = Some(progress);
        }
    }

    /// Renders job `id`'s tier, then finishes it or hands it to the CPU pool to compare.
    async fn run_tier(self: &Arc<Self>, id: u64, lane: Lane, host: &mut JobHost) {
        let Started {
            spec,
            cancel,
            deadline,
        } = match self.start(id).await {
            Ok(Some(started)) => started,
            Ok(None) => return, // cancelled while queued
            Err(error) => {
                // Still queued, on disk as in memory: it goes back to the front of its queue
                // and this worker waits before it takes work again.
                tracing::error!(job = id, "storing the job's start failed: {error}");
                tokio::time::sleep(STORE_RETRY).await;
                let mut inner = lock(&self.inner);
                match lane {
                    Lane::Gpu => inner.gpu_queue.push_front(id),
                    Lane::Cpu => inner.cpu_queue.push_front(CpuWork::Render(id)),
                }
                drop(inner);
                self.work_ready.notify_waiters();
                return;
            }
        };
        if !self.config.in_process && job_process::available() {
            // A GPU job compares in a process of its own on the CPU pool, the GPU free for
            // the next job meanwhile.
            let part = match lane {
                Lane::Gpu if spec.reference_spp.is_some() => JobPart::Render,
                _ => JobPart::Whole,
            };
            let started = Instant::now();
            let result = self
                .run_job_process(host, id, &spec, part, cancel, deadline)
                .await;
            if lane == Lane::Gpu {
                self.metrics.add_gpu_busy(started.elapsed().as_secs_f64());
            }
            let Some(result) = result else {
                return;
            };
            self.metrics.add_render(&result.tier, result.render_seconds);
            if result.comparison.is_none() && spec.reference_spp.is_some() {
                // Ahead of new renders: this job already holds its tier's image.
                lock(&self.inner)
                    .cpu_queue
                    .push_front(CpuWork::CompareRendered(id, Box::new(result)));
                self.work_ready.notify_waiters();
                return;
            }
            return self.completed(id, result).await;
        }
        let prepared = match self.prepare(&spec).await {
            Ok(prepared) => Arc::new(prepared),
            Err(error) => return self.fail(id, error.code, error.message).await,
        };
        let service = self.clone();
        let job = prepared.clone();
        let share = if spec.compare { 0.5 } else { 1.0 };
        let started = Instant::now();
        let stopping = service.clone();
        let stop: CancelCheck = Arc::new(move || {
            cancel.load(Ordering::SeqCst) || stopping.is_shutting_down() || past(deadline)
        });
        let rendered = tokio::task::spawn_blocking(move || {
            runner::render_tier(&job, &|p| service.set_progress(id, p), stop, share)
        })
        .await;
        let seconds = started.elapsed().as_secs_f64();
        if lane == Lane::Gpu {
            self.metrics.add_gpu_busy(seconds);
        }
        match rendered {
            Err(panic) => {
                self.fail(
                    id,
                    "internal",
                    format!("the render failed unexpectedly: {panic}"),
                )
                .await
            }
            Ok(Err(message)) => self.fail(id, "render_failed", message).await,
            Ok(Ok(None)) => self.stopped(id, deadline).await,
            Ok(Ok(Some(output))) => {
                self.metrics.add_render(&output.result.tier, seconds);
                match spec.reference_spp {
                    Some(reference_spp) => {
                        // Ahead of new renders: this job already holds its tier's image.
                        lock(&self.inner)
                            .cpu_queue
                            .push_front(CpuWork::Compare(Box::new(Comparing {
                                id,
                                job: prepared,
                                output,
                                reference_spp,
                            })));
                        self.work_ready.notify_waiters();
                    }
                    None => self.finish(id, &prepared, output, None).await,
                }
            }
        }
    }

    /// Compares, in a process of its own, the image job `id` rendered in one (`rendered`: its
    /// result), and stores the job's end.
    async fn compare_rendered(
        self: &Arc<Self>,
        id: u64,
        rendered: Box<JobResult>,
        host: &mut JobHost,
    ) {
        let Some((spec, cancel, deadline)) = lock(&self.inner)
            .jobs
            .get(&id)
            .filter(|e| e.record.state == JobState::Running)
            .map(|e| (e.record.spec.clone(), e.cancel.clone(), e.deadline))
        else {
            // Cancelled while it waited: its rendered image serves no one.
            for file in IMAGE_FILES {
                let _ = std::fs::remove_file(self.store.job_dir(id).join(file));
            }
            return;
        };
        let part = JobPart::Compare { rendered };
        if let Some(result) = self
            .run_job_process(host, id, &spec, part, cancel, deadline)
            .await
        {
            self.completed(id, result).await;
        }
    }

    /// Counts a finished comparison's reference in the metrics and stores the job's end.
    async fn completed(self: &Arc<Self>, id: u64, result: JobResult) {
        if let Some(comparison) = &result.comparison {
            self.count_reference(comparison);
        }
        self.complete(id, result).await;
    }

    /// Counts whether a comparison's reference came from the cache.
    fn count_reference(&self, comparison: &Comparison) {
        if comparison.reference_cached {
            self.metrics.reference_cache_hits.inc();
        } else {
            self.metrics.reference_cache_misses.inc();
        }
    }

    /// Runs `part` of job `id` in the job process of `host`, which writes the images into the
    /// job's folder; stopping the job ends that process at once. Answers the result; `None`
    /// when the job failed or stopped (its end then stored, its images removed).
    async fn run_job_process(
        self: &Arc<Self>,
        host: &mut JobHost,
        id: u64,
        spec: &JobSpec,
        part: JobPart,
        cancel: Arc<AtomicBool>,
        deadline: Option<Instant>,
    ) -> Option<JobResult> {
        let dir = self.store.job_dir(id);
        let task = match self.plan(spec).and_then(|(plan, _)| {
            Ok(JobTask {
                id,
                spec: spec.clone(),
                scene: self.catalog.resolve(&spec.scene)?,
                plan,
                gpu_name: self.gpu.as_ref().map(|g| g.name.clone()),
                reference_engine: self.config.reference_engine,
                no_gpu: self.config.no_gpu,
                cache_dir: self.cache_dir.clone(),
                out_dir: dir.clone(),
                part,
            })
        }) {
            Ok(task) => task,
            Err(error) => {
                self.fail(id, error.code, error.message).await;
                return None;
            }
        };
        let service = self.clone();
        let stop =
            move || cancel.load(Ordering::SeqCst) || service.is_shutting_down() || past(deadline);
        let rendered = host.run(&task, |p| self.set_progress(id, p), stop).await;
        let Ok(Some(result)) = rendered else {
            // What did get written serves no one.
            for file in IMAGE_FILES {
                let _ = std::fs::remove_file(dir.join(file));
            }
            match rendered {
                Err(failure) => self.fail(id, &failure.code, failure.message).await,
                _ => self.stopped(id, deadline).await,
            }
            return None;
        };
        Some(result)
    }

    async fn run_compare(self: &Arc<Self>, comparing: Comparing) {
        let id = comparing.id;
        let Some((cancel, deadline)) = lock(&self.inner)
            .jobs
            .get(&id)
            .filter(|e| e.record.state == JobState::Running)
            .map(|e| (e.cancel.clone(), e.deadline))
        else {
            return; // cancelled while it waited
        };
        let service = self.clone();
        let comparing = Arc::new(comparing);
        let work = comparing.clone();
        let compared = tokio::task::spawn_blocking(move || {
            let stop =
                || cancel.load(Ordering::SeqCst) || service.is_shutting_down() || past(deadline);
            runner::compare(
                &work.job,
                &work.output,
                work.reference_spp,
                &service.references,
                &|p| service.set_progress(id, p),
                &stop,
                0.5,
            )
        })
        .await;
        let Ok(comparing) = Arc::try_unwrap(comparing) else {
            return self
                .fail(id, "internal", "the comparison is still referenced")
                .await;
        };
        match compared {
            Err(panic) => {
                self.fail(
                    id,
                    "internal",
                    format!("the comparison failed unexpectedly: {panic}"),
                )
                .await
            }
            Ok(Err(message)) => self.fail(id, "compare_failed", message).await,
            Ok(Ok(None)) => self.stopped(id, deadline).await,
            Ok(Ok(Some(compared))) => {
                self.count_reference(&compared.comparison);
                let mut output = comparing.output;
                output.result.comparison = Some(compared.comparison);
                let compared = (compared.reference, compared.flip);
                self.finish(id, &comparing.job, output, Some(compared))
                    .await
            }
        }
    }

    async fn prepare(self: &Arc<Self>, spec: &JobSpec) -> Result<PreparedJob, ApiError> {
        let (plan, _) = self.plan(spec)?;
        let source = self.catalog.resolve(&spec.scene)?;
        let scene = with_lighting(self.load_scene(source).await?, spec)?;
        let gpu_name = self.gpu.as_ref().map(|g| g.name.clone());
        let spec = spec.clone();
        tokio::task::spawn_blocking(move || runner::prepare(scene, &spec, plan, gpu_name))
            .await
            .map_err(|e| ApiError::internal(e.to_string()))?
    }

    /// Stores the images and result of a job that is still running (a cancelled job's are
    /// dropped). Images that cannot be stored fail the job.
    async fn finish(
        self: &Arc<Self>,
        id: u64,
        job: &PreparedJob,
        output: TierOutput,
        compared: Option<(gi_image::Image, gi_image::Flip)>,
    ) {
        let dir = self.store.job_dir(id);
        let writer = self.store.writer().clone();
        let exposure = job.scene.exposure;
        let TierOutput { image, result } = output;
        let written = tokio::task::spawn_blocking(move || {
            let compared = compared.as_ref().map(|(reference, flip)| (reference, flip));
            let written = runner::write_images(&writer, &dir, exposure, &image, compared);
            if written.is_err() {
                // What did get written serves no one and takes the space a retry needs.
                for file in IMAGE_FILES {
                    let _ = std::fs::remove_file(dir.join(file));
                }
            }
            written
        })
        .await
        .map_err(std::io::Error::other)
        .and_then(|r| r);
        if let Err(error) = written {
            let code = if is_disk_full(&error) {
                "insufficient_storage"
            } else {
                "internal"
            };
            return self
                .fail(id, code, format!("storing the images failed: {error}"))
                .await;
        }
        self.complete(id, result).await;
    }

    /// Stores the end of job `id`, done with `result`, if it is still running.
    async fn complete(self: &Arc<Self>, id: u64, result: JobResult) {
        self.transition_until_stored(id, move |record| {
            if record.state != JobState::Running {
                return false;
            }
            record.result = Some(result.clone());
            record.finished_at = Some(now_rfc3339());
            record.state = JobState::Done;
            true
        })
        .await;
    }

    async fn fail(self: &Arc<Self>, id: u64, code: &str, message: impl Into<String>) {
        let failure = JobFailure {
            code: code.to_string(),
            message: message.into(),
        };
        tracing::warn!(job = id, code, "job failed: {}", failure.message);
        self.transition_until_stored(id, move |record| {
            if record.state != JobState::Running {
                return false;
            }
            record.failure = Some(failure.clone());
            record.finished_at = Some(now_rfc3339());
            record.state = JobState::Failed;
            true
        })
        .await;
    }

    /// A render stopped before its end: by a cancellation (already recorded), by the
    /// shutdown, which puts the job back in the queue for the next start, or by its deadline,
    /// which fails it.
    async fn stopped(self: &Arc<Self>, id: u64, deadline: Option<Instant>) {
        if !self.is_shutting_down() && past(deadline) {
            let limit = self.config.job_time_limit_s;
            return self
                .fail(
                    id,
                    "time_limit",
                    format!(
                        "the job ran longer than the {limit} s this service allows a job \
                         (--job-time-limit-s)"
                    ),
                )
                .await;
        }
        match self.transition(id, requeue_stopped).await {
            Ok(Some(_)) => tracing::info!(
                job = id,
                "stopped by the shutdown; it runs again after the restart"
            ),
            Ok(None) => {}
            // The record says running: the next start counts this start and runs it again.
            Err(error) => tracing::error!(job = id, "storing the job failed: {error}"),
        }
    }
}

/// What a worker needs of a job it started.
struct Started {
    spec: JobSpec,
    cancel: Arc<AtomicBool>,
    deadline: Option<Instant>,
}

/// Whether `deadline` has passed.
fn past(deadline: Option<Instant>) -> bool {
    deadline.is_some_and(|d| Instant::now() >= d)
}

/// The change of a running job stopped by the shutdown: back to the queue, the start not
/// counted (the job never got to finish through no fault of its own).
pub(crate) fn requeue_stopped(record: &mut JobRecord) -> bool {
    if record.state != JobState::Running {
        return false;
    }
    record.attempts = record.attempts.saturating_sub(1);
    record.started_at = None;
    record.state = JobState::Queued;
    true
}

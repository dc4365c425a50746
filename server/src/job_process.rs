//! A job rendered in a child process of its worker. Stopping the job (a cancellation, a
//! DELETE, the time limit, the worker's shutdown) then ends all of its work at once: the
//! scene's import and its BVH builds too, which check for nothing while they run. And a render
//! that crashes (a GPU driver's abort, the memory running out) fails its job, not the worker.
//!
//! Job processes are used where the executable serves them: its `main` calls [`serve`] first
//! (`gi-server` and `gi-worker` do). Elsewhere (a test binary, a program embedding the
//! service that does not call it) jobs render in the calling process.
//!
//! The worker starts its own executable with [`JOB_PROCESS_ARG`] as the only argument, in a
//! process group of its own (a terminal's Ctrl-C reaches the worker, which then stops the
//! job itself), and keeps it for its next jobs ([`JobHost`]): it reads [`JobTask`]s (one line
//! of JSON each) from its stdin, writes each job's images into the task's folder, and reports
//! on its stdout, one JSON [`Report`] a line: a job's progress while it works, then its end.
//! Its logs go to the worker's stderr. Stopping a job kills the process; the next job starts a
//! fresh one. When its stdin closes the worker is gone (even by `kill -9`) or done with it, and
//! the process exits instead of rendering for no one.

use std::{
    io::{BufRead, Write},
    path::PathBuf,
    process::{ExitCode, Stdio},
    sync::{
        Arc,
        atomic::{AtomicBool, Ordering},
    },
    time::Duration,
};

use gi_reference::{
    cache::ReferenceCache,
    engine::{CpuEngine, EngineChoice, ReferenceEngine},
};
use serde::{Deserialize, Serialize};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt};

use crate::{
    job::{JobFailure, JobResult, JobSpec, Progress},
    runner::{self, References, TierPlan},
    scenes::SceneSource,
    service::with_lighting,
    store::Writer,
};

/// The argument that makes a worker's executable run one job and exit.
pub const JOB_PROCESS_ARG: &str = "--job-process";

/// Whether this executable's `main` called [`serve`].
static SERVED: AtomicBool = AtomicBool::new(false);

/// Call first in `main`. In a job process (started with [`JOB_PROCESS_ARG`]) it runs the job
/// and answers the exit code to return from `main`; otherwise it answers `None` and marks this
/// executable as one that runs jobs in processes of their own.
pub fn serve() -> Option<ExitCode> {
    if std::env::args_os()
        .nth(1)
        .is_some_and(|arg| arg == JOB_PROCESS_ARG)
    {
        return Some(child_main());
    }
    SERVED.store(true, Ordering::SeqCst);
    None
}

/// Whether jobs can render in processes of their own ([`serve`] was called).
pub(crate) fn available() -> bool {
    SERVED.load(Ordering::SeqCst)
}

/// How often the worker asks whether a running job must stop.
const STOP_POLL: Duration = Duration::from_millis(100);

/// Everything a job process needs, as its worker resolved it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct JobTask {
    pub id: u64,
    pub spec: JobSpec,
    /// The scene, already on this machine (an upload is fetched by the worker).
    pub scene: SceneSource,
    pub plan: TierPlan,
    /// The adapter the worker found, for the result's `device`.
    pub gpu_name: Option<String>,
    /// How the references of comparisons are rendered.
    pub reference_engine: EngineChoice,
    /// The worker may not use a GPU (`--no-gpu`): references render on the CPU.
    pub no_gpu: bool,
    pub cache_dir: PathBuf,
    /// Where the images go (created by the child).
    pub out_dir: PathBuf,
    /// What of the job this process does.
    pub part: JobPart,
}

/// What of a job one process does. A GPU job of the embedded service renders in one process
/// and compares in another, so its GPU renders the next job while the reference is traced.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum JobPart {
    /// The render, and the comparison when the job asks for one.
    Whole,
    /// Only the render (the image and its result).
    Render,
    /// Only the comparison of the image a [`JobPart::Render`] process wrote into the task's
    /// folder (`image.exr`, lossless), which answered `rendered`.
    Compare { rendered: Box<JobResult> },
}

/// A line of a job process's stdout.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(tag = "report", rename_all = "snake_case")]
pub(crate) enum Report {
    Progress {
        stage: String,
        done: u32,
        total: u32,
        fraction: f64,
    },
    /// The job rendered; its images are in the task's folder.
    Done {
        result: Box<JobResult>,
    },
    Failed {
        code: String,
        message: String,
    },
}

/// The stages a job reports ([`Progress::stage`]); an unknown one reads as `frames`.
const STAGES: [&str; 5] = ["preparing", "warmup", "frames", "reference", "direct"];

impl Report {
    fn progress(progress: Progress) -> Self {
        Report::Progress {
            stage: progress.stage.to_string(),
            done: progress.done,
            total: progress.total,
            fraction: progress.fraction,
        }
    }

    fn failed(code: &str, message: impl Into<String>) -> Self {
        Report::Failed {
            code: code.to_string(),
            message: message.into(),
        }
    }
}

/// The stage of a job's preparation: its scene loaded, its BVH built, its tier set up.
pub(crate) fn preparing() -> Progress {
    Progress {
        stage: "preparing",
        done: 0,
        total: 1,
        fraction: 0.0,
    }
}

/// A job process kept for the jobs of one worker slot (the GPU lane, one CPU worker, a
/// scale-out worker): started for its first job, it renders one job after another, keeping its
/// GPU device and compiled pipelines, until a job of its is stopped or it dies; the next job
/// then starts a fresh one. Dropping the host ends its process.
#[derive(Default)]
pub(crate) struct JobHost {
    process: Option<HostProcess>,
}

struct HostProcess {
    child: tokio::process::Child,
    stdin: tokio::process::ChildStdin,
    lines: tokio::io::Lines<tokio::io::BufReader<tokio::process::ChildStdout>>,
}

fn internal(message: String) -> JobFailure {
    JobFailure {
        code: "internal".to_string(),
        message,
    }
}

impl HostProcess {
    fn start() -> Result<Self, JobFailure> {
        let exe = std::env::current_exe()
            .map_err(|e| internal(format!("finding this program to run the job: {e}")))?;
        let mut command = tokio::process::Command::new(exe);
        #[cfg(unix)]
        command.process_group(0);
        let mut child = command
            .arg(JOB_PROCESS_ARG)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .kill_on_drop(true)
            .spawn()
            .map_err(|e| internal(format!("starting the job's process: {e}")))?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            return Err(internal("the job's process has no pipes".to_string()));
        };
        Ok(Self {
            child,
            stdin,
            lines: tokio::io::BufReader::new(stdout).lines(),
        })
    }

    async fn send(&mut self, line: &[u8]) -> std::io::Result<()> {
        self.stdin.write_all(line).await?;
        self.stdin.flush().await
    }
}

impl JobHost {
    /// Runs `task` in this host's process (started if there is none). Answers the job's
    /// result (its images in `task.out_dir`), `Ok(None)` when `stop` answered true first (the
    /// process is then killed and waited for), or why the job failed, a crash of the process
    /// included.
    pub(crate) async fn run(
        &mut self,
        task: &JobTask,
        on_progress: impl Fn(Progress),
        stop: impl Fn() -> bool,
    ) -> Result<Option<JobResult>, JobFailure> {
        let mut input = serde_json::to_vec(task).map_err(|e| internal(e.to_string()))?;
        input.push(b'\n');
        // A kept process may have died while it waited: then a fresh one takes the job. A
        // fresh one that cannot take it has crashed (its end is read below).
        if let Some(kept) = self.process.as_mut()
            && kept.send(&input).await.is_err()
        {
            self.end().await;
        }
        if self.process.is_none() {
            let mut fresh = HostProcess::start()?;
            let _ = fresh.send(&input).await;
            self.process = Some(fresh);
        }
        let Some(process) = self.process.as_mut() else {
            return Err(internal("the job's process is gone".to_string()));
        };
        let mut poll = tokio::time::interval(STOP_POLL);
        loop {
            tokio::select! {
                line = process.lines.next_line() => match line {
                    Ok(Some(line)) => match serde_json::from_str::<Report>(&line) {
                        Ok(Report::Progress { stage, done, total, fraction }) => {
                            let stage = STAGES
                                .iter()
                                .find(|known| **known == stage)
                                .copied()
                                .unwrap_or("frames");
                            on_progress(Progress { stage, done, total, fraction });
                        }
                        Ok(Report::Done { result }) => return Ok(Some(*result)),
                        Ok(Report::Failed { code, message }) => {
                            return Err(JobFailure { code, message });
                        }
                        Err(error) => {
                            tracing::warn!(job = task.id, "the job's process wrote {line:?}: {error}");
                        }
                    },
                    Ok(None) | Err(_) => break,
                },
                _ = poll.tick() => {
                    if stop() {
                        self.end().await;
                        return Ok(None);
                    }
                }
            }
        }
        // The process ended without the job's end.
        let status = match self.process.take() {
            Some(mut process) => process.child.wait().await.map(|s| s.to_string()),
            None => Ok("gone".to_string()),
        };
        let status = status.unwrap_or_else(|e| format!("not known: {e}"));
        if stop() {
            // Stopped meanwhile: the process may have been ended by the same cause.
            return Ok(None);
        }
        Err(JobFailure {
            code: "render_crashed".to_string(),
            message: format!(
                "the job's render process ended without a result ({status}); nothing else \
                 was affected"
            ),
        })
    }

    /// Ends this host's process, if any, and waits for it.
    async fn end(&mut self) {
        if let Some(mut process) = self.process.take() {
            let _ = process.child.kill().await;
        }
    }
}

/// The child's side: reads tasks from stdin, one line each, runs them one after another and
/// reports on stdout. The end of stdin (the worker is done with it, or gone) ends the process,
/// even in the middle of a job.
fn child_main() -> ExitCode {
    crate::init_logging();
    let (send, tasks) = std::sync::mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { break };
            if send.send(line).is_err() {
                break;
            }
        }
        std::process::exit(0);
    });
    let stdout = std::sync::Mutex::new(std::io::stdout());
    let report = |report: Report| {
        let Ok(mut line) = serde_json::to_vec(&report) else {
            return;
        };
        line.push(b'\n');
        let mut out = stdout.lock().unwrap_or_else(|e| e.into_inner());
        // A worker that is gone no longer reads: the job is over either way.
        let _ = out.write_all(&line).and_then(|()| out.flush());
    };
    let mut references = None;
    for line in tasks {
        let end = match serde_json::from_str::<JobTask>(&line) {
            Err(error) => Report::failed("internal", format!("the job's task: {error}")),
            Ok(task) => match execute(
                &task,
                &|progress| report(Report::progress(progress)),
                &mut references,
            ) {
                Ok(result) => Report::Done {
                    result: Box::new(result),
                },
                Err(failure) => Report::failed(&failure.code, failure.message),
            },
        };
        report(end);
    }
    ExitCode::SUCCESS
}

/// The references of a job process's comparisons, kept for its next jobs (its engine holds a
/// GPU device and the path tier's pipelines when it renders on the GPU).
struct KeptReferences {
    key: (EngineChoice, bool, PathBuf),
    references: References,
}

/// Renders the task in this process: scene, tier, comparison, images.
fn execute(
    task: &JobTask,
    progress: &(dyn Fn(Progress) + Sync),
    kept: &mut Option<KeptReferences>,
) -> Result<JobResult, JobFailure> {
    let failure = |code: &str, message: String| JobFailure {
        code: code.to_string(),
        message,
    };
    let api = |error: crate::error::ApiError| failure(error.code, error.message);
    progress(preparing());
    let scene = task
        .scene
        .load()
        .map_err(|e| failure("invalid_scene", format!("loading the scene failed: {e}")))?;
    let scene = with_lighting(Arc::new(scene), &task.spec).map_err(api)?;
    let job = runner::prepare(scene, &task.spec, task.plan, task.gpu_name.clone()).map_err(api)?;
    let output = match &task.part {
        JobPart::Compare { rendered } => {
            let image = gi_image::read_exr(task.out_dir.join("image.exr"))
                .map_err(|e| failure("internal", format!("reading the rendered image: {e}")))?;
            runner::TierOutput {
                image,
                result: JobResult::clone(rendered),
            }
        }
        JobPart::Whole | JobPart::Render => {
            let never: gi_tiers::CancelCheck = Arc::new(|| false);
            let share = if task.spec.compare { 0.5 } else { 1.0 };
            runner::render_tier(&job, progress, never, share)
                .map_err(|message| failure("render_failed", message))?
                .ok_or_else(|| failure("internal", "the render stopped by itself".to_string()))?
        }
    };
    let reference_spp = match task.part {
        JobPart::Render => None,
        JobPart::Whole | JobPart::Compare { .. } => task.spec.reference_spp,
    };
    let compared = match reference_spp {
        None => None,
        Some(reference_spp) => {
            let key = (task.reference_engine, task.no_gpu, task.cache_dir.clone());
            if !matches!(kept, Some(k) if k.key == key) {
                let engine: Arc<dyn ReferenceEngine> = if task.no_gpu {
                    Arc::new(CpuEngine)
                } else {
                    gi_tiers::reference_engine(task.reference_engine).map_err(|e| {
                        failure(
                            "compare_failed",
                            format!("--reference-engine {}: {e}", task.reference_engine),
                        )
                    })?
                };
                let cache = ReferenceCache::new(task.cache_dir.clone())
                    .with_engine(engine, task.reference_engine);
                *kept = Some(KeptReferences {
                    key,
                    references: References::new(cache),
                });
            }
            let Some(KeptReferences { references, .. }) = kept.as_ref() else {
                return Err(failure("internal", "no reference engine".to_string()));
            };
            let compared = runner::compare(
                &job,
                &output,
                reference_spp,
                references,
                progress,
                &|| false,
                0.5,
            )
            .map_err(|message| failure("compare_failed", message))?
            .ok_or_else(|| failure("internal", "the comparison stopped by itself".to_string()))?;
            Some(compared)
        }
    };
    let mut result = output.result;
    if let Some(compared) = &compared {
        result.comparison = Some(compared.comparison.clone());
    }
    let images = compared.as_ref().map(|c| (&c.reference, &c.flip));
    runner::write_images(
        &Writer::default(),
        &task.out_dir,
        job.scene.exposure,
        &output.image,
        images,
    )
    .map_err(|e| {
        let code = if crate::error::is_disk_full(&e) {
            "insufficient_storage"
        } else {
            "internal"
        };
        failure(code, format!("storing the images failed: {e}"))
    })?;
    Ok(result)
}

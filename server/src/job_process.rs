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
//! job itself). The child reads a [`JobTask`] (one line of JSON) from its stdin, writes the
//! job's images into the task's folder, and reports on its stdout, one JSON [`Report`] a line:
//! its progress while it works, then its end. Its logs go to the worker's stderr. The worker
//! keeps the child's stdin open: when it closes, the worker is gone (even by `kill -9`), and
//! the child exits too instead of rendering for no one.

use std::{
    io::{BufRead, Read, Write},
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

/// Runs `task` in a child process of this executable. Answers the job's result (its images
/// in `task.out_dir`), `Ok(None)` when `stop` answered true first (the child is then killed and
/// waited for), or why the job failed, a crash of the child included.
pub(crate) async fn run(
    task: &JobTask,
    on_progress: impl Fn(Progress),
    stop: impl Fn() -> bool,
) -> Result<Option<JobResult>, JobFailure> {
    let internal = |message: String| JobFailure {
        code: "internal".to_string(),
        message,
    };
    let exe = std::env::current_exe()
        .map_err(|e| internal(format!("finding this program to run the job: {e}")))?;
    let mut input = serde_json::to_vec(task).map_err(|e| internal(e.to_string()))?;
    input.push(b'\n');
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
    let (Some(mut stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
        return Err(internal("the job's process has no pipes".to_string()));
    };
    // The task is small; the child reads its line before it starts. The pipe stays open
    // until the job ends (see the module's docs).
    let written = async {
        stdin.write_all(&input).await?;
        stdin.flush().await
    };
    if let Err(error) = written.await {
        let _ = child.kill().await;
        return Err(internal(format!("sending the job to its process: {error}")));
    }
    let mut lines = tokio::io::BufReader::new(stdout).lines();
    let mut end = None;
    let mut poll = tokio::time::interval(STOP_POLL);
    loop {
        tokio::select! {
            line = lines.next_line() => match line {
                Ok(Some(line)) => match serde_json::from_str::<Report>(&line) {
                    Ok(Report::Progress { stage, done, total, fraction }) => {
                        let stage = STAGES
                            .iter()
                            .find(|known| **known == stage)
                            .copied()
                            .unwrap_or("frames");
                        on_progress(Progress { stage, done, total, fraction });
                    }
                    Ok(Report::Done { result }) => end = Some(Ok(*result)),
                    Ok(Report::Failed { code, message }) => {
                        end = Some(Err(JobFailure { code, message }));
                    }
                    Err(error) => {
                        tracing::warn!(job = task.id, "the job's process wrote {line:?}: {error}");
                    }
                },
                Ok(None) | Err(_) => break,
            },
            _ = poll.tick() => {
                if stop() {
                    let _ = child.kill().await;
                    return Ok(None);
                }
            }
        }
    }
    drop(stdin);
    let status = child
        .wait()
        .await
        .map_err(|e| internal(format!("waiting for the job's process: {e}")))?;
    match end {
        Some(Ok(result)) if status.success() => Ok(Some(result)),
        Some(Err(failure)) => Err(failure),
        // Stopped meanwhile: the child may have been ended by the same cause (a shutdown's
        // signal reaches the whole process group).
        _ if stop() => Ok(None),
        _ => Err(JobFailure {
            code: "render_crashed".to_string(),
            message: format!(
                "the job's render process ended without a result ({status}); nothing else \
                 was affected"
            ),
        }),
    }
}

/// The child's side: reads its task from stdin, runs it, reports on stdout. Only a task that
/// cannot be read fails the exit status; a job's failure is a report.
fn child_main() -> ExitCode {
    crate::init_logging();
    let mut input = String::new();
    if let Err(error) = std::io::stdin().lock().read_line(&mut input) {
        eprintln!("error: reading the job from stdin: {error}");
        return ExitCode::FAILURE;
    }
    // The rest of stdin is the worker's liveness: its end means the worker is gone.
    std::thread::spawn(|| {
        let _ = std::io::stdin().lock().read_to_end(&mut Vec::new());
        eprintln!("the worker is gone: the job's process stops");
        std::process::exit(2);
    });
    let task: JobTask = match serde_json::from_str(&input) {
        Ok(task) => task,
        Err(error) => {
            eprintln!("error: the job on stdin: {error}");
            return ExitCode::FAILURE;
        }
    };
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
    let end = match execute(&task, &|progress| report(Report::progress(progress))) {
        Ok(result) => Report::Done {
            result: Box::new(result),
        },
        Err(failure) => Report::failed(&failure.code, failure.message),
    };
    report(end);
    ExitCode::SUCCESS
}

/// Renders the task in this process: scene, tier, comparison, images.
fn execute(task: &JobTask, progress: &(dyn Fn(Progress) + Sync)) -> Result<JobResult, JobFailure> {
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
            let references = References::new(cache);
            let compared = runner::compare(
                &job,
                &output,
                reference_spp,
                &references,
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

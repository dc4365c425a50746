//! `gi-worker`: renders the jobs of a scale-out gi-server (`gi-worker --help`). Run one per
//! GPU, on any number of machines.

use std::process::ExitCode;

use clap::Parser;
use gi_server::{
    cluster::worker::{self, WorkerConfig},
    job_process,
};

fn main() -> ExitCode {
    // A job's own process (see gi_server::job_process), started by a worker.
    if std::env::args_os()
        .nth(1)
        .is_some_and(|arg| arg == job_process::JOB_PROCESS_ARG)
    {
        return job_process::child_main();
    }
    let config = WorkerConfig::parse();
    gi_server::init_logging();
    gi_server::run_main(worker::run(config, gi_server::shutdown_signal()))
}

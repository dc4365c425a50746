//! `gi-worker`: renders the jobs of a scale-out gi-server (`gi-worker --help`). Run one per
//! GPU, on any number of machines.

use std::process::ExitCode;

use clap::Parser;
use gi_server::{
    cluster::worker::{self, WorkerConfig},
    job_process,
};

fn main() -> ExitCode {
    // Started as a job's own process by the worker: run that job.
    if let Some(code) = job_process::serve() {
        return code;
    }
    let config = WorkerConfig::parse();
    gi_server::init_logging();
    gi_server::run_main(worker::run(config, gi_server::shutdown_signal()))
}

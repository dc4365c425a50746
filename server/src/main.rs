//! `gi-server`: the render service. Configuration comes from flags or `GI_SERVER_*`
//! environment variables (`gi-server --help`).

use std::{process::ExitCode, time::Duration};

use clap::Parser;
use gi_server::{Config, Server};

/// Seconds past the grace period after which a shutdown that has not finished ends the
/// process anyway.
const FORCE_EXIT_MARGIN_S: u64 = 5;

async fn run(config: Config) -> anyhow::Result<()> {
    let grace = Duration::from_secs(config.shutdown_grace_s);
    let server = Server::start(config).await?;
    // One line on stdout that scripts (and the tests) read the address from.
    println!("gi-server listening on http://{}", server.local_addr());
    server
        .run(async move {
            gi_server::shutdown_signal().await;
            // The last resort, should stopping itself hang: every accepted job is on disk
            // already, and one still marked running runs again after the restart.
            std::thread::spawn(move || {
                std::thread::sleep(grace + Duration::from_secs(FORCE_EXIT_MARGIN_S));
                eprintln!(
                    "error: still stopping {} s after the signal; exiting",
                    grace.as_secs() + FORCE_EXIT_MARGIN_S
                );
                std::process::exit(1);
            });
        })
        .await
}

fn main() -> ExitCode {
    // Started as a job's own process by the service: run that job.
    if let Some(code) = gi_server::job_process::serve() {
        return code;
    }
    let config = Config::parse();
    gi_server::init_logging();
    gi_server::run_main(run(config))
}

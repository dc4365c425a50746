//! `gi-server`: the render service. Configuration comes from flags or `GI_SERVER_*`
//! environment variables (`gi-server --help`).

use std::{process::ExitCode, time::Duration};

use clap::Parser;
use gi_server::{Config, Server};

fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .init();
}

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
    let config = Config::parse();
    init_logging();
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(runtime) => runtime,
        Err(error) => {
            eprintln!("error: starting the async runtime: {error}");
            return ExitCode::FAILURE;
        }
    };
    let result = runtime.block_on(run(config));
    // Dropping the runtime would wait for renders still running on its blocking threads (a
    // BVH build, a CPU render's pass), which nothing can interrupt; their jobs are queued
    // again on disk, so exit without them.
    runtime.shutdown_background();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let causes: Vec<String> = error.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", causes.join(": "));
            ExitCode::FAILURE
        }
    }
}

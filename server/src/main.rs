//! `gi-server`: the render service. Configuration comes from flags or `GI_SERVER_*`
//! environment variables (`gi-server --help`).

use std::process::ExitCode;

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

async fn run(config: Config) -> anyhow::Result<()> {
    let server = Server::start(config).await?;
    // One line on stdout that scripts (and the tests) read the address from.
    println!("gi-server listening on http://{}", server.local_addr());
    server.run(gi_server::shutdown_signal()).await
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
    match runtime.block_on(run(config)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            let causes: Vec<String> = error.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", causes.join(": "));
            ExitCode::FAILURE
        }
    }
}

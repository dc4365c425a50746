//! The render service: queued render jobs over HTTP (axum + tokio), their error against the
//! path-traced reference, and a web page to submit and inspect them.
//!
//! ```no_run
//! # async fn demo() -> anyhow::Result<()> {
//! let config = gi_server::Config::with_data_dir("gi-server-data");
//! let server = gi_server::Server::start(config).await?;
//! println!("listening on http://{}", server.local_addr());
//! server.run(gi_server::shutdown_signal()).await?;
//! # Ok(()) }
//! ```
//!
//! Jobs and results live in the data folder; a restart (or a crash) finds queued jobs queued
//! and runs interrupted ones again. GPU tiers run one job at a time on a GPU worker, CPU
//! renders (the reference tier, and the references of comparisons) on a bounded pool, and
//! references are cached in the folder `gi compare` uses. Connections are capped and timed
//! out, requests must name the service in `Host`, and API routes can require a bearer token.

#![recursion_limit = "512"]

mod access;
mod api;
mod backend;
pub mod cluster;
pub mod config;
mod connections;
mod error;
pub mod job;
pub mod job_process;
mod metrics;
mod openapi;
mod runner;
mod scenes;
mod service;
mod store;
mod web;

use std::{future::Future, net::SocketAddr, sync::Arc, time::Duration};

use anyhow::Context;
pub use api::ROUTES;
pub use config::Config;
use gi_reference::engine::{CpuEngine, ReferenceEngine};
use service::{GpuInfo, Service};
use tokio::{net::TcpListener, task::JoinHandle};

/// A started service: data folder recovered, GPU probed, socket bound, workers running.
pub struct Server {
    listener: TcpListener,
    service: Arc<dyn backend::Backend>,
    workers: Vec<JoinHandle<()>>,
    access: Arc<access::Access>,
}

impl Server {
    /// Opens the data folder (recovering its jobs), looks for a GPU, binds the address and
    /// starts the workers. Requests are served once [`Server::run`] is called.
    pub async fn start(config: Config) -> anyhow::Result<Self> {
        config.validate().map_err(anyhow::Error::msg)?;
        let token = config.resolve_api_token().map_err(anyhow::Error::msg)?;
        let access = access::Access::new(&config, token).map_err(anyhow::Error::msg)?;
        if access.has_token() {
            tracing::info!("API routes need the bearer token");
        } else if !config.bind.ip().is_loopback() {
            tracing::warn!(
                "serving {} without authentication (--insecure-no-auth)",
                config.bind
            );
        }
        if config.database_url.is_some() {
            let listener = TcpListener::bind(config.bind)
                .await
                .with_context(|| format!("binding {}", config.bind))?;
            let api = cluster::ClusterApi::start(config)
                .await
                .context("connecting to the job database and the object store")?;
            tracing::info!("scale-out mode: jobs are queued in PostgreSQL for gi-worker processes");
            return Ok(Self {
                listener,
                service: api,
                workers: Vec::new(),
                access: Arc::new(access),
            });
        }
        let store = store::Store::open(&config.data_dir)
            .with_context(|| format!("opening the data folder {}", config.data_dir.display()))?;
        let gpu = if config.no_gpu {
            None
        } else {
            tokio::task::spawn_blocking(probe_gpu).await?
        };
        match &gpu {
            Some(gpu) => tracing::info!(adapter = %gpu.name, hardware = gpu.hardware, "GPU found"),
            None => {
                tracing::warn!("no GPU adapter: GPU tiers are refused, auto renders on the CPU")
            }
        }
        let choice = config.reference_engine;
        let no_gpu = config.no_gpu;
        let reference_engine = tokio::task::spawn_blocking(move || {
            if no_gpu {
                // `validate` refused `gpu`: auto and cpu render on the CPU.
                return Ok(Arc::new(CpuEngine) as Arc<dyn ReferenceEngine>);
            }
            gi_tiers::reference_engine(choice)
        })
        .await?
        .with_context(|| format!("--reference-engine {choice}"))?;
        tracing::info!(engine = %reference_engine.description(), "references render here");
        let listener = TcpListener::bind(config.bind)
            .await
            .with_context(|| format!("binding {}", config.bind))?;
        let pool = config.reference_pool;
        let (service, queued) = tokio::task::spawn_blocking(move || {
            Service::recover(config, store, gpu, reference_engine)
        })
        .await?
        .context("reading the jobs of the data folder")?;
        if !queued.is_empty() {
            tracing::info!("{} jobs waiting from before the restart", queued.len());
        }
        let mut workers = vec![tokio::spawn(service.clone().gpu_worker())];
        for _ in 0..pool {
            workers.push(tokio::spawn(service.clone().cpu_worker()));
        }
        Ok(Self {
            listener,
            service: service as Arc<dyn backend::Backend>,
            workers,
            access: Arc::new(access),
        })
    }

    /// The bound address (useful with port 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.listener
            .local_addr()
            .expect("a bound listener has an address")
    }

    /// Serves requests until `shutdown` completes, then stops gracefully: no new connections,
    /// open requests answered, running jobs stopped at their next frame or pass, side by side
    /// within the configured grace period. Jobs still running then are queued again on disk
    /// (they run again after the restart) and it returns, leaving behind whatever render
    /// cannot be interrupted (a BVH build, a CPU render's pass): the binary exits without
    /// waiting for it.
    pub async fn run(
        self,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> anyhow::Result<()> {
        let service = self.service.clone();
        let grace = Duration::from_secs(service.config().shutdown_grace_s);
        let stopping = service.clone();
        let app = api::router(service.clone(), self.access);
        let limits = connections::Limits::from_config(service.config());
        let mut connections =
            connections::serve(self.listener, app, limits, service.clone(), async move {
                shutdown.await;
                tracing::info!("shutting down");
                stopping.shut_down();
            })
            .await;
        service.shut_down();
        let deadline = tokio::time::Instant::now() + grace;
        let drained = async { while connections.join_next().await.is_some() {} };
        let stopped = async { tokio::join!(drained, futures_join_all(self.workers)) };
        if tokio::time::timeout_at(deadline, stopped).await.is_err() {
            tracing::warn!(
                "requests or jobs still running after {} s; the jobs run again after the restart",
                grace.as_secs()
            );
        }
        // Closes the connections still open.
        drop(connections);
        service.stopped().await;
        Ok(())
    }
}

async fn futures_join_all(handles: Vec<JoinHandle<()>>) {
    for handle in handles {
        let _ = handle.await;
    }
}

/// Logs to stderr, filtered by `RUST_LOG` (default `info`): what the binaries do first.
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .init();
}

/// Runs a binary's `main` on a new runtime: its error, with its causes, goes to stderr and
/// fails the exit status. Renders still running on the runtime's blocking threads when `main`
/// returns (a BVH build, a CPU render's pass) are not waited for: nothing can interrupt them,
/// and their jobs are queued again.
pub fn run_main(main: impl Future<Output = anyhow::Result<()>>) -> std::process::ExitCode {
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(runtime) => runtime,
        Err(error) => {
            eprintln!("error: starting the async runtime: {error}");
            return std::process::ExitCode::FAILURE;
        }
    };
    let result = runtime.block_on(main);
    runtime.shutdown_background();
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            let causes: Vec<String> = error.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", causes.join(": "));
            std::process::ExitCode::FAILURE
        }
    }
}

/// Completes on SIGTERM or Ctrl-C (SIGINT).
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = terminate => {},
    }
}

/// The GPU adapter, if any (blocking: it opens a device).
pub(crate) fn probe_gpu() -> Option<GpuInfo> {
    match gi_gpu::GpuContext::new() {
        Ok(ctx) => Some(GpuInfo {
            name: ctx.adapter_info.name.clone(),
            device_type: format!("{:?}", ctx.adapter_info.device_type),
            hardware: ctx.adapter_info.device_type != gi_gpu::wgpu::DeviceType::Cpu,
            adapter: gi_tiers::select::AdapterDescription::from_context(&ctx),
        }),
        Err(error) => {
            tracing::warn!("no GPU: {error}");
            None
        }
    }
}

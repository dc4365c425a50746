//! The HTTP connections: accepted under a cap, closed when a request head is late or when they
//! stay silent with nothing running, and drained on shutdown.
//!
//! A client that opens connections and sends half a request costs a socket and a small task
//! each. `--max-connections` bounds the sockets; a connection past it takes the place of the
//! open one idle the longest (no request running), so stalled clients cannot lock out
//! `/healthz` or a submission, and it is refused with 503 only while every connection is
//! busy. The header-read timeout (hyper's) and the idle timeout (here) then free the rest.

use std::{
    collections::HashMap,
    future::Future,
    io,
    net::SocketAddr,
    pin::Pin,
    sync::{
        Arc, Mutex,
        atomic::{AtomicU64, AtomicUsize, Ordering},
    },
    task::{Context, Poll},
    time::Duration,
};

use axum::{BoxError, Router, body::Body, extract::Request};
use http_body::{Frame, SizeHint};
use hyper::{
    body::{Bytes, Incoming},
    server::conn::http1,
    service::Service as _,
};
use hyper_util::{
    rt::{TokioIo, TokioTimer},
    service::TowerToHyperService,
};
use tokio::{
    io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt, ReadBuf},
    net::{TcpListener, TcpStream},
    sync::{Notify, Semaphore, watch},
    task::JoinSet,
    time::{Instant, Sleep},
};

use crate::{
    backend::Backend,
    config::Config,
    metrics::{Dropped, Metrics},
};

/// What a request knows of its connection (a request extension).
#[derive(Clone, Copy, Debug)]
pub struct ConnectionInfo {
    /// The address the client reached: the `Host` check compares against it.
    pub local_addr: SocketAddr,
}

/// The connection settings of the configuration.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub max_connections: usize,
    pub header_read_timeout: Duration,
    pub idle_timeout: Duration,
}

impl Limits {
    pub fn from_config(config: &Config) -> Self {
        Self {
            max_connections: config.max_connections,
            header_read_timeout: Duration::from_secs_f64(config.header_read_timeout_s),
            idle_timeout: Duration::from_secs_f64(config.idle_timeout_s),
        }
    }
}

/// One open connection as the cap and the idle timeout see it.
struct Open {
    /// Requests of this connection being handled now.
    in_flight: AtomicUsize,
    /// Milliseconds since the server's start of its last byte read or written, or of its last
    /// request finishing.
    last_activity_ms: AtomicU64,
    /// Told when a request finishes, so the idle timeout starts counting from then.
    activity: Notify,
    /// Told to close when a newer connection takes its place.
    evict: Notify,
}

impl Open {
    fn touch(&self, clock: Instant) {
        self.last_activity_ms
            .store(clock.elapsed().as_millis() as u64, Ordering::Relaxed);
    }

    fn busy(&self) -> bool {
        self.in_flight.load(Ordering::Relaxed) > 0
    }

    fn last_activity(&self, clock: Instant) -> Instant {
        clock + Duration::from_millis(self.last_activity_ms.load(Ordering::Relaxed))
    }
}

/// The open connections, by id.
struct Registry {
    open: Mutex<HashMap<u64, Arc<Open>>>,
    next_id: AtomicU64,
    /// Origin of the connections' activity times.
    clock: Instant,
}

impl Registry {
    /// Registers a new connection, evicting the one idle the longest when the cap is reached;
    /// `None` when every open connection is busy.
    fn admit(&self, max: usize, metrics: &Metrics) -> Option<(u64, Arc<Open>)> {
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        if open.len() >= max {
            let victim = open
                .iter()
                .filter(|(_, c)| !c.busy())
                .min_by_key(|(_, c)| c.last_activity_ms.load(Ordering::Relaxed))
                .map(|(id, _)| *id)?;
            if let Some(evicted) = open.remove(&victim) {
                evicted.evict.notify_one();
                metrics.add_dropped(Dropped::Evicted);
            }
        }
        let id = self.next_id.fetch_add(1, Ordering::Relaxed);
        let connection = Arc::new(Open {
            in_flight: AtomicUsize::new(0),
            last_activity_ms: AtomicU64::new(0),
            activity: Notify::new(),
            evict: Notify::new(),
        });
        connection.touch(self.clock);
        open.insert(id, connection.clone());
        Some((id, connection))
    }

    fn remove(&self, id: u64) {
        self.open
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&id);
    }
}

/// Accepts connections on `listener` and serves `app` on them until `shutdown` completes.
/// Then it stops accepting, asks every connection to finish its request and close, and
/// returns them still running: the caller waits as long as its grace allows, and dropping
/// them closes what is left.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    limits: Limits,
    service: Arc<dyn Backend>,
    shutdown: impl Future<Output = ()>,
) -> JoinSet<()> {
    let registry = Arc::new(Registry {
        open: Mutex::default(),
        next_id: AtomicU64::new(0),
        clock: Instant::now(),
    });
    let (stop, stopping) = watch::channel(false);
    let refusals = Arc::new(Semaphore::new(MAX_REFUSALS));
    let mut connections = JoinSet::new();
    tokio::pin!(shutdown);
    loop {
        let stream = tokio::select! {
            biased;
            () = &mut shutdown => break,
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(error) => {
                    // Out of file descriptors or a connection reset before it was taken:
                    // wait a moment rather than spin, and go on.
                    tracing::warn!("accepting a connection: {error}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
        };
        while connections.try_join_next().is_some() {}
        let metrics = service.metrics();
        let Some((id, open)) = registry.admit(limits.max_connections, metrics) else {
            metrics.add_dropped(Dropped::Refused);
            refuse(stream, &refusals);
            continue;
        };
        metrics.connections_accepted.inc();
        metrics.connections_open.inc();
        let guard = Registered {
            id,
            registry: registry.clone(),
            service: service.clone(),
        };
        connections.spawn(serve_connection(
            stream,
            open,
            guard,
            app.clone(),
            limits,
            stopping.clone(),
        ));
    }
    drop(listener);
    let _ = stop.send(true);
    connections
}

/// Refusals being answered at once; past it a refused connection is closed without an answer.
const MAX_REFUSALS: usize = 64;

/// Seconds a refused connection may take to read its answer and close.
const REFUSAL_TIMEOUT: Duration = Duration::from_secs(1);

/// Answers 503 without serving anything and closes: every connection is busy.
fn refuse(mut stream: TcpStream, refusals: &Arc<Semaphore>) {
    let Ok(permit) = refusals.clone().try_acquire_owned() else {
        return;
    };
    tokio::spawn(async move {
        let body = r#"{"error":{"code":"too_many_connections","message":"every connection of the service is busy; retry shortly"}}"#;
        let answer = format!(
            "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\n\
             retry-after: 1\r\nconnection: close\r\ncontent-length: {}\r\n\r\n{body}",
            body.len()
        );
        let answered = async {
            stream.write_all(answer.as_bytes()).await?;
            stream.shutdown().await?;
            // Closing with the request unread would reset the connection and could discard
            // the answer before the client reads it: read until the client closes.
            let mut unread = [0u8; 4096];
            while stream.read(&mut unread).await? > 0 {}
            io::Result::Ok(())
        };
        let _ = tokio::time::timeout(REFUSAL_TIMEOUT, answered).await;
        drop(permit);
    });
}

/// Unregisters a connection when its task ends, however it ends.
struct Registered {
    id: u64,
    registry: Arc<Registry>,
    service: Arc<dyn Backend>,
}

impl Drop for Registered {
    fn drop(&mut self) {
        self.registry.remove(self.id);
        self.service.metrics().connections_open.dec();
    }
}

/// Counts a request of a connection as running while it lives.
struct Running {
    open: Arc<Open>,
    clock: Instant,
}

impl Running {
    fn new(open: Arc<Open>, clock: Instant) -> Self {
        open.in_flight.fetch_add(1, Ordering::Relaxed);
        Self { open, clock }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.open.touch(self.clock);
        self.open.in_flight.fetch_sub(1, Ordering::Relaxed);
        self.open.activity.notify_one();
    }
}

async fn serve_connection(
    stream: TcpStream,
    open: Arc<Open>,
    registered: Registered,
    app: Router,
    limits: Limits,
    mut stopping: watch::Receiver<bool>,
) {
    let clock = registered.registry.clock;
    let metrics = &registered.service.metrics();
    let local_addr = stream.local_addr().ok();
    let _ = stream.set_nodelay(true);
    let app = TowerToHyperService::new(app);
    let service = {
        let open = open.clone();
        let service = registered.service.clone();
        hyper::service::service_fn(move |request: Request<Incoming>| {
            let running = Running::new(open.clone(), clock);
            let service = service.clone();
            let mut request = request
                .map(|body| Body::new(PausedBodyTimeout::new(body, limits.idle_timeout, service)));
            if let Some(local_addr) = local_addr {
                request
                    .extensions_mut()
                    .insert(ConnectionInfo { local_addr });
            }
            let answer = app.call(request);
            async move {
                let response = answer.await?;
                // The request runs until its answer's body is sent.
                Ok::<_, std::convert::Infallible>(response.map(|body| {
                    Body::new(WhileRunning {
                        body,
                        running: Some(running),
                    })
                }))
            }
        })
    };
    let io = TokioIo::new(Tracked {
        stream,
        open: open.clone(),
        clock,
    });
    let connection = http1::Builder::new()
        .timer(TokioTimer::new())
        .header_read_timeout(limits.header_read_timeout)
        .keep_alive(true)
        .serve_connection(io, service);
    tokio::pin!(connection);
    let mut draining = false;
    loop {
        // While a request runs the idle clock is stopped; it restarts when the request ends.
        let idle_deadline = if open.busy() {
            Instant::now() + limits.idle_timeout
        } else {
            open.last_activity(clock) + limits.idle_timeout
        };
        tokio::select! {
            result = connection.as_mut() => {
                if let Err(error) = result {
                    if error.is_timeout() {
                        metrics.add_dropped(Dropped::HeaderTimeout);
                    } else {
                        tracing::debug!("connection closed: {error}");
                    }
                }
                break;
            }
            () = open.evict.notified() => break,
            () = open.activity.notified() => {}
            _ = stopping.changed(), if !draining => {
                // With no request running there is nothing to finish (a request head still
                // arriving is not answered once the service stops).
                if !open.busy() {
                    break;
                }
                draining = true;
                connection.as_mut().graceful_shutdown();
            }
            () = tokio::time::sleep_until(idle_deadline) => {
                let idle_since = open.last_activity(clock);
                if !open.busy() && idle_since + limits.idle_timeout <= Instant::now() {
                    metrics.add_dropped(Dropped::IdleTimeout);
                    break;
                }
            }
        }
    }
}

/// A connection's socket that records when bytes last moved.
struct Tracked {
    stream: TcpStream,
    open: Arc<Open>,
    clock: Instant,
}

impl AsyncRead for Tracked {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let before = buf.filled().len();
        let result = Pin::new(&mut self.stream).poll_read(cx, buf);
        if buf.filled().len() > before {
            self.open.touch(self.clock);
        }
        result
    }
}

impl AsyncWrite for Tracked {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let result = Pin::new(&mut self.stream).poll_write(cx, buf);
        if matches!(result, Poll::Ready(Ok(n)) if n > 0) {
            self.open.touch(self.clock);
        }
        result
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let result = Pin::new(&mut self.stream).poll_write_vectored(cx, bufs);
        if matches!(result, Poll::Ready(Ok(n)) if n > 0) {
            self.open.touch(self.clock);
        }
        result
    }

    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
}

/// A request body that fails when no data comes for the idle timeout, so a client that stops
/// sending a body it announced cannot hold its connection (and its place under the cap).
struct PausedBodyTimeout {
    body: Incoming,
    timeout: Duration,
    deadline: Pin<Box<Sleep>>,
    service: Arc<dyn Backend>,
}

impl PausedBodyTimeout {
    fn new(body: Incoming, timeout: Duration, service: Arc<dyn Backend>) -> Self {
        Self {
            body,
            timeout,
            deadline: Box::pin(tokio::time::sleep(timeout)),
            service,
        }
    }
}

impl http_body::Body for PausedBodyTimeout {
    type Data = Bytes;
    type Error = BoxError;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, BoxError>>> {
        match Pin::new(&mut self.body).poll_frame(cx) {
            Poll::Ready(frame) => {
                let deadline = Instant::now() + self.timeout;
                self.deadline.as_mut().reset(deadline);
                Poll::Ready(frame.map(|f| f.map_err(BoxError::from)))
            }
            Poll::Pending => {
                if self.deadline.as_mut().poll(cx).is_pending() {
                    return Poll::Pending;
                }
                self.service.metrics().add_dropped(Dropped::IdleTimeout);
                let message = format!(
                    "the request body paused for more than {} s (--idle-timeout-s)",
                    self.timeout.as_secs_f64()
                );
                Poll::Ready(Some(Err(message.into())))
            }
        }
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.body.size_hint()
    }
}

/// An answer's body that keeps its request counted as running until it is sent (or dropped).
struct WhileRunning {
    body: Body,
    running: Option<Running>,
}

impl http_body::Body for WhileRunning {
    type Data = Bytes;
    type Error = axum::Error;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, axum::Error>>> {
        let polled = Pin::new(&mut self.body).poll_frame(cx);
        if matches!(polled, Poll::Ready(None | Some(Err(_)))) {
            self.running = None;
        }
        polled
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.body.size_hint()
    }
}

//! The service's connections under abuse, over real sockets: hundreds of half-sent requests
//! do not lock out `/healthz` or a submission, stalled and slow clients are closed after
//! their timeouts, a service whose every connection is busy answers 503 at once, and
//! `/metrics` counts requests, connections and the data folder.

mod common;

use std::{
    io::{ErrorKind, Read, Write},
    net::{SocketAddr, TcpStream},
    time::{Duration, Instant},
};

use common::*;
use serde_json::json;

/// Opens a connection and sends the start of a request head, never its end.
fn half_sent(addr: SocketAddr) -> TcpStream {
    let mut stream = TcpStream::connect(addr).expect("connect");
    write!(stream, "GET /healthz HTTP/1.1\r\nHost: {addr}\r\nX-Slow: ").unwrap();
    stream
}

/// True once the server closed `stream` (end of stream or reset); false while it is open.
fn closed_now(stream: &TcpStream) -> bool {
    stream.set_nonblocking(true).unwrap();
    let mut buffer = [0u8; 1024];
    let closed = loop {
        match (&mut &*stream).read(&mut buffer) {
            Ok(0) => break true,
            Ok(_) => continue, // an error answer before the close
            Err(e) if e.kind() == ErrorKind::WouldBlock => break false,
            Err(_) => break true,
        }
    };
    stream.set_nonblocking(false).unwrap();
    closed
}

/// Seconds until the server closes `stream`; fails after `limit`.
fn seconds_until_closed(stream: &mut TcpStream, since: Instant, limit: Duration) -> f64 {
    stream
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut buffer = [0u8; 1024];
    loop {
        match stream.read(&mut buffer) {
            Ok(0) => return since.elapsed().as_secs_f64(),
            Ok(_) => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return since.elapsed().as_secs_f64(),
        }
        assert!(since.elapsed() < limit, "still open after {limit:?}");
    }
}

/// `/metrics` of the service.
fn scrape(addr: SocketAddr) -> String {
    let response = get(addr, "/metrics");
    assert_eq!(response.status, 200);
    response.text()
}

#[test]
fn hundreds_of_stalled_connections_do_not_lock_out_health_or_submissions() {
    const CAP: usize = 64;
    const STALLED: usize = 300;
    // Timeouts far longer than the test: only the cap can make room.
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.max_connections = CAP;
        c.header_read_timeout_s = 600.0;
        c.idle_timeout_s = 600.0;
    });
    let addr = server.addr;
    let stalled: Vec<TcpStream> = (0..STALLED).map(|_| half_sent(addr)).collect();

    let started = Instant::now();
    let health = get(addr, "/healthz");
    assert_eq!(health.status, 200, "{}", health.text());
    let submitted = post_json(
        addr,
        "/v1/jobs",
        &json!({"scene": "cornell-box",
        "tier": "reference", "width": 8, "height": 6, "spp": 1}),
    );
    assert_eq!(submitted.status, 202, "{}", submitted.text());
    assert!(
        started.elapsed() < Duration::from_secs(3),
        "answered after {:?}",
        started.elapsed()
    );

    // The oldest stalled connections made room; the newest are still open (the timeouts did
    // not close them).
    std::thread::sleep(Duration::from_millis(300));
    let closed = stalled.iter().filter(|s| closed_now(s)).count();
    assert!(
        (STALLED - CAP..=STALLED - CAP + 8).contains(&closed),
        "{closed} of {STALLED} stalled connections closed under a cap of {CAP}"
    );
    assert!(!closed_now(stalled.last().unwrap()));
    let text = scrape(addr);
    let open = metric(&text, "gi_http_connections_open").unwrap();
    assert!(open <= CAP as f64, "{open} connections open");
    let evicted = metric(
        &text,
        "gi_http_connections_dropped_total{reason=\"evicted\"}",
    )
    .unwrap();
    assert!(evicted >= (STALLED - CAP) as f64, "{evicted} evicted");
}

#[test]
fn stalled_and_slow_clients_are_closed_after_their_timeouts() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.header_read_timeout_s = 2.0;
        c.idle_timeout_s = 1.0;
    });
    let addr = server.addr;
    let limit = Duration::from_secs(10);

    // Half a head, then silence: closed after the idle timeout.
    let silent = std::thread::spawn(move || {
        let mut stream = half_sent(addr);
        seconds_until_closed(&mut stream, Instant::now(), limit)
    });
    // A head trickling a byte every 250 ms never idles, but is closed after the header
    // timeout.
    let trickling = std::thread::spawn(move || {
        let mut stream = half_sent(addr);
        let since = Instant::now();
        stream
            .set_read_timeout(Some(Duration::from_millis(250)))
            .unwrap();
        let mut buffer = [0u8; 1024];
        loop {
            if stream.write_all(b"a").is_err() {
                return since.elapsed().as_secs_f64();
            }
            match stream.read(&mut buffer) {
                Ok(0) => return since.elapsed().as_secs_f64(),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                _ => return since.elapsed().as_secs_f64(),
            }
            assert!(since.elapsed() < limit, "still open after {limit:?}");
        }
    });
    // A body announced and never sent: refused after the idle timeout.
    let paused_body = std::thread::spawn(move || {
        let mut stream = TcpStream::connect(addr).unwrap();
        write!(
            stream,
            "POST /v1/jobs HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\n\
             Content-Length: 100\r\n\r\n{{\"scene\":"
        )
        .unwrap();
        let since = Instant::now();
        let response = read_response(&mut stream);
        (response.status, since.elapsed().as_secs_f64())
    });
    // A kept-alive connection after its answer: closed after the idle timeout.
    let kept_alive = std::thread::spawn(move || {
        let mut stream = TcpStream::connect(addr).unwrap();
        write!(stream, "GET /healthz HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
        let response = read_response(&mut stream);
        assert_eq!(response.status, 200);
        seconds_until_closed(&mut stream, Instant::now(), limit)
    });

    let silent = silent.join().unwrap();
    assert!(
        (0.8..3.0).contains(&silent),
        "silent head closed after {silent} s"
    );
    let trickling = trickling.join().unwrap();
    assert!(
        (1.5..4.0).contains(&trickling),
        "trickling head closed after {trickling} s"
    );
    let (status, paused) = paused_body.join().unwrap();
    assert_eq!(status, 400);
    assert!(
        (0.8..3.0).contains(&paused),
        "paused body refused after {paused} s"
    );
    let kept_alive = kept_alive.join().unwrap();
    assert!(
        (0.8..3.0).contains(&kept_alive),
        "idle connection closed after {kept_alive} s"
    );

    let text = scrape(addr);
    let dropped = |reason: &str| {
        metric(
            &text,
            &format!("gi_http_connections_dropped_total{{reason=\"{reason}\"}}"),
        )
        .unwrap()
    };
    assert!(dropped("header_timeout") >= 1.0, "{text}");
    assert!(dropped("idle_timeout") >= 3.0, "{text}");
}

#[test]
fn past_the_cap_with_every_connection_busy_the_answer_is_503_at_once() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.max_connections = 2;
        c.header_read_timeout_s = 4.0;
        c.idle_timeout_s = 2.0;
    });
    let addr = server.addr;
    // Two uploads whose bodies do not come: both connections run a request.
    let _busy: Vec<TcpStream> = (0..2)
        .map(|_| {
            let mut stream = TcpStream::connect(addr).unwrap();
            write!(
                stream,
                "POST /v1/scenes HTTP/1.1\r\nHost: {addr}\r\n\
                 Content-Type: model/gltf-binary\r\nContent-Length: 1000\r\n\r\nglTF"
            )
            .unwrap();
            stream
        })
        .collect();
    std::thread::sleep(Duration::from_millis(300));

    let started = Instant::now();
    let refused = get(addr, "/healthz");
    assert_eq!(refused.status, 503, "{}", refused.text());
    assert_eq!(refused.error_code(), "too_many_connections");
    assert_eq!(refused.header("retry-after"), Some("1"));
    assert!(started.elapsed() < Duration::from_secs(1));

    // Once the paused bodies time out, the service answers again.
    let deadline = Instant::now() + Duration::from_secs(6);
    loop {
        let response = get(addr, "/healthz");
        if response.status == 200 {
            break;
        }
        assert!(Instant::now() < deadline, "still {}", response.status);
        std::thread::sleep(Duration::from_millis(100));
    }
    let text = scrape(addr);
    assert!(
        metric(
            &text,
            "gi_http_connections_dropped_total{reason=\"refused\"}"
        )
        .unwrap()
            >= 1.0,
        "{text}"
    );
}

#[test]
fn metrics_count_requests_connections_and_the_data_folder() {
    let server = TestServer::start(|c| c.no_gpu = true);
    let addr = server.addr;
    let before = scrape(addr);
    let healthz = "{route=\"/healthz\",method=\"GET\"";
    assert_eq!(
        metric(
            &before,
            &format!("gi_http_requests_total{healthz},status=\"2xx\"}}")
        ),
        None
    );
    let used_before = metric(&before, "gi_data_dir_used_bytes").unwrap();
    assert!(metric(&before, "gi_data_dir_free_bytes").unwrap() > 0.0);
    let accepted_before = metric(&before, "gi_http_connections_total").unwrap();

    for _ in 0..3 {
        assert_eq!(get(addr, "/healthz").status, 200);
    }
    assert_eq!(get(addr, "/v1/jobs/999").status, 404);
    assert_eq!(get(addr, "/no/such/route").status, 404);
    let misdirected = request(addr, "GET", "/healthz", &[("Host", "evil.example")], b"");
    assert_eq!(misdirected.status, 421);
    let id = submit(
        addr,
        &json!({"scene": "cornell-box", "tier": "reference", "width": 16, "height": 12,
                "spp": 1, "compare": true, "reference_spp": 4}),
    );
    assert_eq!(
        wait_final(addr, &id, Duration::from_secs(60))["state"],
        "done"
    );
    // Past the data folder walk's one-second floor, so it is measured again.
    std::thread::sleep(Duration::from_millis(1100));

    let after = scrape(addr);
    let sample = |series: String| {
        metric(&after, &series).unwrap_or_else(|| panic!("no {series} in\n{after}"))
    };
    assert_eq!(
        sample(format!("gi_http_requests_total{healthz},status=\"2xx\"}}")),
        3.0
    );
    assert_eq!(
        sample(format!("gi_http_requests_total{healthz},status=\"4xx\"}}")),
        1.0
    );
    assert_eq!(
        sample(format!("gi_http_request_duration_seconds_count{healthz}}}")),
        4.0
    );
    assert_eq!(
        sample(format!(
            "gi_http_request_duration_seconds_bucket{healthz},le=\"+Inf\"}}"
        )),
        4.0
    );
    let job_route = "{route=\"/v1/jobs/{id}\",method=\"GET\"";
    assert!(
        sample(format!(
            "gi_http_requests_total{job_route},status=\"2xx\"}}"
        )) >= 1.0
    );
    assert_eq!(
        sample(format!(
            "gi_http_requests_total{job_route},status=\"4xx\"}}"
        )),
        1.0
    );
    assert_eq!(
        sample(
            "gi_http_requests_total{route=\"unmatched\",method=\"GET\",status=\"4xx\"}".to_string()
        ),
        1.0
    );
    assert_eq!(
        sample(
            "gi_http_requests_total{route=\"/v1/jobs\",method=\"POST\",status=\"2xx\"}".to_string()
        ),
        1.0
    );
    assert!(sample("gi_http_connections_total".to_string()) >= accepted_before + 7.0);
    // This scrape's own connection at least.
    assert!(sample("gi_http_connections_open".to_string()) >= 1.0);
    let used_after = sample("gi_data_dir_used_bytes".to_string());
    assert!(
        used_after > used_before,
        "data folder {used_before} then {used_after} bytes"
    );
}

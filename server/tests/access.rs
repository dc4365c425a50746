//! Who may call the service: requests naming another host are answered 421 (DNS rebinding),
//! with a token every API route answers 401 without it, and the binary refuses to serve
//! other machines without a token.

mod common;

use std::{
    io::Write,
    net::{SocketAddr, TcpStream},
    process::Command,
    time::Duration,
};

use common::*;
use serde_json::json;

const TOKEN: &str = "c0rrect-horse_battery.staple";

fn small_job() -> serde_json::Value {
    json!({"scene": "cornell-box", "tier": "reference", "width": 8, "height": 6, "spp": 1})
}

#[test]
fn requests_naming_another_host_are_misdirected_and_change_nothing() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.allowed_hosts = vec!["render.example.org".to_string()];
    });
    let addr = server.addr;
    let port = addr.port();
    for host in [
        addr.to_string(),
        format!("localhost:{port}"),
        "render.example.org".to_string(),
        "Render.Example.org:443".to_string(),
    ] {
        let response = request(addr, "GET", "/v1/scenes", &[("Host", &host)], b"");
        assert_eq!(response.status, 200, "{host}: {}", response.text());
    }
    // A page of evil.example whose name was pointed at 127.0.0.1 (DNS rebinding) sends its
    // own name; so does anything reaching the port under another name.
    let job = small_job().to_string();
    for host in [
        format!("evil.example:{port}"),
        "evil.example".to_string(),
        format!("127.0.0.1:{}", port.wrapping_add(1)),
        format!("localhost.evil.example:{port}"),
    ] {
        for (method, path, body) in [
            ("POST", "/v1/jobs", job.as_bytes()),
            ("GET", "/v1/jobs", b"".as_slice()),
            ("GET", "/healthz", b""),
            ("GET", "/", b""),
            ("GET", "/no/such/route", b""),
        ] {
            let response = request(
                addr,
                method,
                path,
                &[("Host", &host), ("Content-Type", "application/json")],
                body,
            );
            assert_eq!(response.status, 421, "{method} {path} as {host}");
            assert_eq!(response.error_code(), "misdirected_request");
            assert!(
                response.json()["error"]["message"]
                    .as_str()
                    .unwrap()
                    .contains(&host)
            );
        }
    }
    // Without a Host header at all (HTTP/1.0).
    let mut stream = TcpStream::connect(addr).unwrap();
    stream.write_all(b"GET /v1/jobs HTTP/1.0\r\n\r\n").unwrap();
    assert_eq!(read_response(&mut stream).status, 421);

    assert_eq!(get(addr, "/v1/jobs").json()["total"], 0, "a job was queued");
}

/// Every route of the router, with a job id where it takes one.
fn every_route() -> Vec<(&'static str, String)> {
    gi_server::ROUTES
        .iter()
        .flat_map(|(path, methods)| {
            methods
                .iter()
                .map(move |method| (*method, path.replace("{id}", "1")))
        })
        .chain([("GET", "/no/such/route".to_string())])
        .collect()
}

#[test]
fn with_a_token_every_api_route_needs_it_and_the_page_does_not() {
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.api_token = Some(TOKEN.parse().unwrap());
    });
    let addr = server.addr;
    let open = ["/", "/app.js", "/style.css", "/healthz"];
    let job = small_job().to_string();
    for (method, path) in every_route() {
        let call = |authorization: Option<&str>| {
            let mut headers = vec![("Content-Type", "application/json")];
            headers.extend(authorization.map(|a| ("Authorization", a)));
            request(addr, method, &path, &headers, job.as_bytes())
        };
        let anonymous = call(None);
        if open.contains(&path.as_str()) {
            assert_eq!(anonymous.status, 200, "{method} {path}");
            continue;
        }
        assert_eq!(anonymous.status, 401, "{method} {path}");
        assert_eq!(anonymous.error_code(), "unauthorized");
        assert_eq!(
            anonymous.header("www-authenticate"),
            Some("Bearer realm=\"gi-server\""),
            "{method} {path}"
        );
        for wrong in [
            format!("Bearer {TOKEN}x"),
            format!("Bearer {}", &TOKEN[1..]),
            format!("Basic {TOKEN}"),
            "Bearer".to_string(),
        ] {
            let refused = call(Some(&wrong));
            assert_eq!(refused.status, 401, "{method} {path} with {wrong:?}");
            assert!(
                refused
                    .header("www-authenticate")
                    .is_some_and(|c| c.starts_with("Bearer realm=\"gi-server\", error=")),
                "{method} {path}: {:?}",
                refused.headers
            );
        }
        let allowed = call(Some(&format!("Bearer {TOKEN}")));
        assert_ne!(allowed.status, 401, "{method} {path}: {}", allowed.text());
    }

    // With the token the API works end to end.
    let bearer = format!("Bearer {TOKEN}");
    let auth = [("Authorization", bearer.as_str())];
    let jobs = request(addr, "GET", "/v1/jobs", &auth, b"").json();
    let id = jobs["jobs"][0]["id"]
        .as_str()
        .expect("the job submitted above");
    let metrics = request(addr, "GET", "/metrics", &auth, b"");
    assert_eq!(metrics.status, 200);
    assert!(metrics.text().contains("status=\"4xx\""));
    let job = request(addr, "GET", &format!("/v1/jobs/{id}"), &auth, b"");
    assert_eq!(job.status, 200, "{}", job.text());

    // The OpenAPI document says so.
    let document = request(addr, "GET", "/openapi.json", &auth, b"").json();
    let submit = &document["paths"]["/v1/jobs"]["post"];
    assert!(submit["responses"]["401"].is_object(), "{submit}");
    assert!(submit["responses"]["421"].is_object(), "{submit}");
    assert_eq!(submit["security"], json!([{ "bearer": [] }]));
    let health = &document["paths"]["/healthz"]["get"];
    assert!(health["responses"]["401"].is_null(), "{health}");
    assert!(health["security"].is_null(), "{health}");
}

/// Runs the binary with `args` until it exits (it must, quickly); its success and stderr.
fn run_to_exit(args: &[&str], data_dir: &std::path::Path) -> (bool, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_gi-server"))
        .args(args)
        .arg("--data-dir")
        .arg(data_dir)
        .env_remove("GI_SERVER_API_TOKEN")
        .env_remove("GI_SERVER_API_TOKEN_FILE")
        .env_remove("GI_SERVER_INSECURE_NO_AUTH")
        .env("RUST_LOG", "warn")
        .output()
        .expect("gi-server runs");
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn the_binary_serves_other_machines_only_with_a_token_or_when_told_not_to() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let (ok, stderr) = run_to_exit(&["--bind", "0.0.0.0:0", "--no-gpu"], &data);
    assert!(!ok);
    assert!(
        stderr.contains("0.0.0.0:0")
            && stderr.contains("GI_SERVER_API_TOKEN")
            && stderr.contains("--insecure-no-auth"),
        "{stderr}"
    );
    assert!(!data.exists(), "refused, yet it created its data folder");
    let empty = dir.path().join("empty-token");
    std::fs::write(&empty, "\n").unwrap();
    let (ok, stderr) = run_to_exit(
        &[
            "--bind",
            "127.0.0.1:0",
            "--api-token-file",
            empty.to_str().unwrap(),
        ],
        &data,
    );
    assert!(!ok);
    assert!(stderr.contains("token is empty"), "{stderr}");

    // A token from a file: other machines may connect, with the token.
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, format!("{TOKEN}\n")).unwrap();
    let (server, bound) = spawn_server([
        "--bind",
        "0.0.0.0:0",
        "--no-gpu",
        "--api-token-file",
        token_file.to_str().unwrap(),
        "--data-dir",
        data.to_str().unwrap(),
    ]);
    let addr = SocketAddr::from(([127, 0, 0, 1], bound.port()));
    assert_eq!(get(addr, "/v1/jobs").status, 401);
    let bearer = format!("Bearer {TOKEN}");
    let listed = request(addr, "GET", "/v1/jobs", &[("Authorization", &bearer)], b"");
    assert_eq!(listed.status, 200, "{}", listed.text());
    drop(server);

    // Told to serve without authentication, it does.
    let (mut server, bound) = spawn_server([
        "--bind",
        "0.0.0.0:0",
        "--no-gpu",
        "--insecure-no-auth",
        "--data-dir",
        data.to_str().unwrap(),
    ]);
    let addr = SocketAddr::from(([127, 0, 0, 1], bound.port()));
    assert_eq!(get(addr, "/v1/jobs").status, 200);
    server.kill().unwrap();
    let _ = wait_exit(&mut server, Duration::from_secs(10));
}

//! The web page in headless Chromium, driven over WebDriver (plain HTTP + JSON to
//! `chromedriver`): submit a job from the form, wait for it, check that the tier image, the
//! reference and the error map load and the metrics show, and save a screenshot; and with an
//! API token, the page asks for it and sends it with every call, images included.
//!
//! Without `chromium` and `chromedriver` the test prints a loud `SKIPPED` line and passes,
//! unless `GI_REQUIRE_BROWSER=1` (as CI sets), which makes their absence a failure.

mod common;

use std::{
    net::{SocketAddr, TcpListener},
    path::PathBuf,
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

use common::*;
use serde_json::{Value, json};

const REQUIRE_BROWSER_ENV: &str = "GI_REQUIRE_BROWSER";

/// The first of `names` found on the PATH.
fn find_program(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| names.iter().map(move |name| dir.join(name)))
        .find(|candidate| candidate.is_file())
}

/// chromedriver, killed when dropped.
struct Driver {
    child: Child,
    addr: SocketAddr,
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Driver {
    fn start(program: &PathBuf) -> Self {
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new(program)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("chromedriver starts");
        let driver = Self {
            child,
            addr: SocketAddr::from(([127, 0, 0, 1], port)),
        };
        let started = Instant::now();
        loop {
            if std::net::TcpStream::connect(driver.addr).is_ok()
                && driver.call("GET", "/status", None)["ready"] == true
            {
                return driver;
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "chromedriver is not ready"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// One WebDriver command; its `value`, after checking it is not an error.
    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let response = request(
            self.addr,
            method,
            path,
            &[("Content-Type", "application/json")],
            body.as_bytes(),
        );
        let value = response.json()["value"].clone();
        assert!(
            response.status == 200 && value.get("error").is_none(),
            "WebDriver {method} {path}: {} {value}",
            response.status
        );
        value
    }
}

/// A browser session, closed when dropped.
struct Session<'a> {
    driver: &'a Driver,
    id: String,
}

impl Drop for Session<'_> {
    fn drop(&mut self) {
        let _ = request(
            self.driver.addr,
            "DELETE",
            &format!("/session/{}", self.id),
            &[],
            b"",
        );
    }
}

impl Session<'_> {
    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        self.driver
            .call(method, &format!("/session/{}{path}", self.id), body)
    }

    fn script(&self, script: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(json!({"script": script, "args": []})),
        )
    }

    fn element(&self, css: &str) -> String {
        let found = self.call(
            "POST",
            "/element",
            Some(json!({"using": "css selector", "value": css})),
        );
        found["element-6066-11e4-a52e-4f735466cecf"]
            .as_str()
            .unwrap_or_else(|| panic!("no element {css}: {found}"))
            .to_string()
    }

    fn type_into(&self, css: &str, text: &str) {
        let element = self.element(css);
        self.call(
            "POST",
            &format!("/element/{element}/clear"),
            Some(json!({})),
        );
        self.call(
            "POST",
            &format!("/element/{element}/value"),
            Some(json!({"text": text})),
        );
    }

    fn click(&self, css: &str) {
        let element = self.element(css);
        self.call(
            "POST",
            &format!("/element/{element}/click"),
            Some(json!({})),
        );
    }

    /// Runs `script` until it returns something other than null or false.
    fn wait_for(&self, script: &str, timeout: Duration) -> Value {
        let started = Instant::now();
        loop {
            let value = self.script(script);
            if !value.is_null() && value != false {
                return value;
            }
            assert!(
                started.elapsed() < timeout,
                "timed out waiting for: {script}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

fn decode_base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let digits: Vec<u8> = text
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .map(value)
        .collect();
    digits
        .chunks(4)
        .flat_map(|chunk| {
            let bits = chunk
                .iter()
                .enumerate()
                .fold(0u32, |acc, (i, &d)| acc | u32::from(d) << (18 - 6 * i));
            let bytes = bits.to_be_bytes();
            bytes[1..chunk.len()].to_vec()
        })
        .collect()
}

/// Runs `test` in a fresh headless Chromium session, or prints `SKIPPED` (for the test
/// `name`) without chromium and chromedriver unless they are required.
fn with_browser(name: &str, test: impl FnOnce(&Session)) {
    let browser = find_program(&["chromium", "chromium-browser", "google-chrome"]);
    let driver = find_program(&["chromedriver"]);
    let (Some(browser), Some(driver)) = (browser, driver) else {
        if std::env::var(REQUIRE_BROWSER_ENV).is_ok_and(|v| v == "1") {
            panic!("{REQUIRE_BROWSER_ENV}=1 but chromium or chromedriver is not installed");
        }
        eprintln!(
            "SKIPPED {name}: chromium and chromedriver are not installed (apt-get install \
             chromium chromium-driver); set {REQUIRE_BROWSER_ENV}=1 to make this a failure"
        );
        return;
    };
    let profile = tempfile::tempdir().unwrap();
    let driver = Driver::start(&driver);
    let args = [
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--window-size=1400,1100",
    ]
    .iter()
    .map(|a| a.to_string())
    .chain([format!("--user-data-dir={}", profile.path().display())])
    .collect::<Vec<_>>();
    let created = driver.call(
        "POST",
        "/session",
        Some(json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"binary": browser, "args": args}
        }}})),
    );
    let session = Session {
        driver: &driver,
        id: created["sessionId"]
            .as_str()
            .expect("session id")
            .to_string(),
    };
    test(&session);
}

#[test]
fn the_web_page_submits_a_job_and_shows_its_images_and_metrics() {
    with_browser(
        "the_web_page_submits_a_job_and_shows_its_images_and_metrics",
        submits_a_job_and_shows_its_images_and_metrics,
    );
}

fn submits_a_job_and_shows_its_images_and_metrics(session: &Session) {
    let server = TestServer::start(|c| c.no_gpu = true);
    session.call(
        "POST",
        "/url",
        Some(json!({"url": format!("http://{}/", server.addr)})),
    );
    // The form fills its choices from the API.
    session.wait_for(
        "return document.querySelectorAll('#scene option').length > 0 && document.querySelector('#tier option[value=reference]') !== null",
        Duration::from_secs(20),
    );
    session.click("#scene option[value=cornell-box]");
    session.click("#tier option[value=reference]");
    session.type_into("#width", "48");
    session.type_into("#height", "36");
    session.type_into("#spp", "2");
    session.type_into("#reference_spp", "16");
    session.click("#submit");

    let state = session.wait_for(
        "const s = document.getElementById('job').dataset.state; return (s === 'done' || s === 'failed' || s === 'cancelled') ? s : null",
        Duration::from_secs(60),
    );
    assert_eq!(
        state,
        "done",
        "{}",
        session.script("return document.getElementById('job-error').textContent")
    );

    // All four images loaded, at the job's size.
    let sizes = session.wait_for(
        "const ids = ['img-tier', 'img-reference', 'img-error', 'img-flip']; \
         const imgs = ids.map(id => document.getElementById(id)); \
         return imgs.every(i => i.complete && i.naturalWidth > 0) ? imgs.map(i => [i.naturalWidth, i.naturalHeight]) : null",
        Duration::from_secs(20),
    );
    assert_eq!(sizes, json!([[48, 36], [48, 36], [48, 36], [48, 36]]));

    // The metrics show and agree with the API.
    let job = get(server.addr, "/v1/jobs/1").json();
    let comparison = &job["result"]["comparison"];
    let shown = session.script(
        "const m = k => document.querySelector(`[data-metric=${k}]`).textContent; \
         return {rmse: m('rmse_srgb8'), flip: m('flip'), gain: m('gain_vs_direct'), tier: m('tier'), reference: m('reference_spp')}",
    );
    assert_eq!(
        shown["rmse"],
        format!("{:.2}", comparison["rmse_srgb8"].as_f64().unwrap())
    );
    assert_eq!(
        shown["flip"],
        format!("{:.4}", comparison["flip"].as_f64().unwrap())
    );
    assert_eq!(
        shown["gain"],
        format!("{:.3}", comparison["gain_vs_direct"].as_f64().unwrap())
    );
    assert!(
        shown["tier"]
            .as_str()
            .unwrap()
            .starts_with("reference on cpu"),
        "{shown}"
    );
    assert!(
        shown["reference"].as_str().unwrap().starts_with("16 spp"),
        "{shown}"
    );
    // The job is in the list of past jobs.
    session.wait_for(
        "return document.querySelector('#jobs tbody tr[data-id=\"1\"]') !== null",
        Duration::from_secs(10),
    );

    let screenshot = decode_base64(session.call("GET", "/screenshot", None).as_str().unwrap());
    assert_eq!(&screenshot[..8], b"\x89PNG\r\n\x1a\n");
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("gi-server-web-page.png");
    std::fs::write(&path, &screenshot).unwrap();
    eprintln!("screenshot of the web page: {}", path.display());

    // The finished job offers Delete (not Cancel), which removes it from the service and the
    // list.
    let buttons = session.script(
        "return [document.getElementById('cancel').hidden, document.getElementById('delete').hidden]",
    );
    assert_eq!(buttons, json!([true, false]));
    session.click("#delete");
    session.wait_for(
        "return document.querySelector('#jobs tbody tr[data-id=\"1\"]') === null && document.getElementById('job').hidden ? true : null",
        Duration::from_secs(10),
    );
    assert_eq!(get(server.addr, "/v1/jobs/1").status, 404);
}

#[test]
fn the_web_page_asks_for_the_api_token_and_sends_it() {
    with_browser(
        "the_web_page_asks_for_the_api_token_and_sends_it",
        asks_for_the_api_token_and_sends_it,
    );
}

fn asks_for_the_api_token_and_sends_it(session: &Session) {
    const TOKEN: &str = "web-page-token";
    let server = TestServer::start(|c| {
        c.no_gpu = true;
        c.api_token = Some(TOKEN.parse().unwrap());
    });
    session.call(
        "POST",
        "/url",
        Some(json!({"url": format!("http://{}/", server.addr)})),
    );
    // Refused without the token, the page asks for it.
    session.wait_for(
        "return !document.getElementById('token-form').hidden",
        Duration::from_secs(20),
    );
    session.type_into("#token", TOKEN);
    session.click("#token-form button");
    session.wait_for(
        "return document.querySelector('#tier option[value=reference]') !== null && \
         document.getElementById('token-form').hidden",
        Duration::from_secs(20),
    );
    session.click("#scene option[value=cornell-box]");
    session.click("#tier option[value=reference]");
    session.type_into("#width", "24");
    session.type_into("#height", "18");
    session.type_into("#spp", "1");
    session.type_into("#reference_spp", "4");
    session.click("#submit");
    let state = session.wait_for(
        "const s = document.getElementById('job').dataset.state; return (s === 'done' || s === 'failed' || s === 'cancelled') ? s : null",
        Duration::from_secs(60),
    );
    assert_eq!(state, "done");
    // The images came through the API with the token too.
    let sizes = session.wait_for(
        "const imgs = ['img-tier', 'img-reference'].map(id => document.getElementById(id)); \
         return imgs.every(i => i.complete && i.naturalWidth > 0) ? imgs.map(i => [i.naturalWidth, i.naturalHeight]) : null",
        Duration::from_secs(20),
    );
    assert_eq!(sizes, json!([[24, 18], [24, 18]]));
}

#[test]
fn base64_decodes_known_text() {
    assert_eq!(decode_base64("aGVsbG8="), b"hello");
    assert_eq!(decode_base64("aGVsbG8h"), b"hello!");
    assert_eq!(decode_base64("aA=="), b"h");
}

//! A headless Chromium driven over WebDriver (plain HTTP + JSON to `chromedriver`), for the
//! tests of the web page. Without `chromium` and `chromedriver` a test prints a loud `SKIPPED`
//! line and passes, unless `GI_REQUIRE_BROWSER=1` (as CI sets) makes their absence a failure.

use std::{
    io::{Read, Write},
    net::{SocketAddr, TcpListener, TcpStream},
    path::PathBuf,
    process::{Child, Command, Stdio},
    time::{Duration, Instant},
};

use serde_json::{Value, json};

use super::request;

pub const REQUIRE_BROWSER_ENV: &str = "GI_REQUIRE_BROWSER";

/// The first of `names` found on the PATH.
fn find_program(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| names.iter().map(move |name| dir.join(name)))
        .find(|candidate| candidate.is_file())
}

/// chromedriver, killed when dropped.
pub struct Driver {
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
    /// Starts chromedriver on a free port and waits until it is ready. Another test may have
    /// taken the port between its choice and chromedriver's bind (the driver then exits):
    /// that start is retried on another port.
    fn start(program: &PathBuf) -> Self {
        for _ in 0..5 {
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
            let mut driver = Self {
                child,
                addr: SocketAddr::from(([127, 0, 0, 1], port)),
            };
            let started = Instant::now();
            loop {
                if driver.ready() {
                    return driver;
                }
                if driver.child.try_wait().ok().flatten().is_some() {
                    break;
                }
                assert!(
                    started.elapsed() < Duration::from_secs(20),
                    "chromedriver is not ready"
                );
                std::thread::sleep(Duration::from_millis(100));
            }
        }
        panic!("chromedriver exited at every start");
    }

    /// Whether chromedriver answers `GET /status` with `"ready": true`. False while it starts,
    /// also when it accepts the connection but answers nothing yet.
    fn ready(&self) -> bool {
        let Ok(mut stream) = TcpStream::connect(self.addr) else {
            return false;
        };
        let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
        let head = format!(
            "GET /status HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
            self.addr
        );
        if stream.write_all(head.as_bytes()).is_err() {
            return false;
        }
        // chromedriver may keep the connection open: read until the answer says ready.
        let mut raw = Vec::new();
        let mut buffer = [0u8; 4096];
        loop {
            let text = String::from_utf8_lossy(&raw).replace(' ', "");
            if text.contains("\"ready\":true") {
                return true;
            }
            match stream.read(&mut buffer) {
                Ok(0) | Err(_) => return false,
                Ok(n) => raw.extend_from_slice(&buffer[..n]),
            }
        }
    }

    /// One WebDriver command; its `value`, after checking it is not an error.
    pub fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
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
pub struct Session<'a> {
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
    pub fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        self.driver
            .call(method, &format!("/session/{}{path}", self.id), body)
    }

    pub fn script(&self, script: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(json!({"script": script, "args": []})),
        )
    }

    pub fn element(&self, css: &str) -> String {
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

    pub fn type_into(&self, css: &str, text: &str) {
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

    pub fn click(&self, css: &str) {
        let element = self.element(css);
        self.call(
            "POST",
            &format!("/element/{element}/click"),
            Some(json!({})),
        );
    }

    /// Submits a small reference job of cornell-box (24 x 18, 1 spp, a 4-spp reference) from
    /// the page's form, with `extra` fields typed in as well, and answers the state it ends in.
    pub fn render_small_job(&self, extra: &[(&str, &str)]) -> Value {
        self.click("#scene option[value=cornell-box]");
        self.click("#tier option[value=reference]");
        for (field, value) in [
            ("#width", "24"),
            ("#height", "18"),
            ("#spp", "1"),
            ("#reference_spp", "4"),
        ]
        .iter()
        .chain(extra)
        {
            self.type_into(field, value);
        }
        self.click("#submit");
        self.wait_for(
            "const s = document.getElementById('job').dataset.state; return (s === 'done' || s === 'failed' || s === 'cancelled') ? s : null",
            Duration::from_secs(60),
        )
    }

    /// Runs `script` until it returns something other than null or false.
    pub fn wait_for(&self, script: &str, timeout: Duration) -> Value {
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

pub fn decode_base64(text: &str) -> Vec<u8> {
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
pub fn with_browser(name: &str, test: impl FnOnce(&Session)) {
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

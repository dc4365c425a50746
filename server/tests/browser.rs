//! The web page in headless Chromium, driven over WebDriver (plain HTTP + JSON to
//! `chromedriver`): submit a job from the form, wait for it, check that the tier image, the
//! reference and the error map load and the metrics show, and save a screenshot; and with an
//! API token, the page asks for it and sends it with every call, images included.
//!
//! Without `chromium` and `chromedriver` the test prints a loud `SKIPPED` line and passes,
//! unless `GI_REQUIRE_BROWSER=1` (as CI sets), which makes their absence a failure.

mod common;

use std::{path::PathBuf, time::Duration};

use common::{browser::*, *};
use serde_json::json;

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
    // A scene of the user's own, uploaded from the page, is offered and selected.
    let glb = tempfile::Builder::new().suffix(".glb").tempfile().unwrap();
    std::fs::write(glb.path(), sample_glb("Box")).unwrap();
    let file_input = session.element("#upload-file");
    session.call(
        "POST",
        &format!("/element/{file_input}/value"),
        Some(json!({"text": glb.path().display().to_string()})),
    );
    session.click("#upload");
    let status = session.wait_for(
        "const t = document.getElementById('upload-status').textContent; return t.includes('selected as') ? t : null",
        Duration::from_secs(30),
    );
    let uploaded = session.script("return document.getElementById('scene').value");
    let uploaded = uploaded.as_str().unwrap();
    assert!(uploaded.starts_with("upload-"), "{status}");
    let listed = get(server.addr, "/v1/scenes").json();
    assert!(
        listed["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["name"] == uploaded),
        "{listed}"
    );
    // The upload has no light: the page says so.
    assert!(status.as_str().unwrap().contains("Warnings"), "{status}");

    session.click("#scene option[value=cornell-box]");
    session.click("#tier option[value=reference]");
    session.type_into("#priority", "3");
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
    assert_eq!(job["request"]["priority"], 3, "{job}");
    let summary = session.script("return document.getElementById('job-summary').textContent");
    assert!(
        summary.as_str().unwrap().contains("priority 3"),
        "{summary}"
    );
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
    assert_eq!(session.render_small_job(&[]), "done");
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

//! The `gi-server` binary's settings from the environment: a bad value stops it at start with
//! one clear error, before it binds or renders anything.

use std::process::Command;

/// Runs the binary over a fresh folder with `env` set; its exit status and stderr.
fn start_with(env: (&str, &str), args: &[&str]) -> (bool, String) {
    let dir = tempfile::tempdir().unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_gi-server"))
        .args(["--bind", "127.0.0.1:0"])
        .args(args)
        .arg("--data-dir")
        .arg(dir.path().join("data"))
        .env(env.0, env.1)
        .env("RUST_LOG", "warn")
        .output()
        .expect("gi-server starts");
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn the_reference_engine_comes_from_the_environment_and_is_checked() {
    let (ok, err) = start_with(("GI_SERVER_REFERENCE_ENGINE", "vulkan"), &[]);
    assert!(!ok);
    assert!(
        err.contains("vulkan") && err.contains("auto, gpu or cpu"),
        "{err}"
    );
    let (ok, err) = start_with(("GI_SERVER_REFERENCE_ENGINE", "gpu"), &["--no-gpu"]);
    assert!(!ok);
    assert!(
        err.contains("--reference-engine gpu") && err.contains("--no-gpu"),
        "{err}"
    );
}

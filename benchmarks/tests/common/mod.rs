//! Running `gi-bench` from the benchmark tests.

use std::process::Command;

/// Runs `gi-bench` with `args` and `--json` into the tests' temporary folder as `json_name`,
/// failing the test with its output when it fails. Returns its stdout and the JSON it wrote.
pub fn gi_bench_json(args: &[&str], json_name: &str) -> (String, serde_json::Value) {
    let json = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(json_name);
    let output = Command::new(env!("CARGO_BIN_EXE_gi-bench"))
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .expect("gi-bench starts");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "gi-bench {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let report = serde_json::from_str(&std::fs::read_to_string(&json).expect("JSON written"))
        .expect("JSON parses");
    (stdout, report)
}

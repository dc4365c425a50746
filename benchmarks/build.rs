//! Embeds the commit the benchmarks were built from, so every results file names the code it
//! measured: `git rev-parse HEAD`, with `-dirty` when tracked files differ from it. Without git
//! (a copy of the tree with no `.git`), `$GI_COMMIT` at build time, else `unknown`; the suite
//! then still reads `$GI_COMMIT` when it runs.

use std::{path::PathBuf, process::Command};

fn git(args: &[&str]) -> Option<String> {
    let output = Command::new("git").args(args).output().ok()?;
    output
        .status
        .success()
        .then(|| String::from_utf8_lossy(&output.stdout).trim().to_owned())
}

fn main() {
    println!("cargo:rerun-if-env-changed=GI_COMMIT");
    let commit = match git(&["rev-parse", "HEAD"]) {
        Some(head) => {
            // Untracked files (outputs such as bench-out/) do not change what is built.
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|status| !status.is_empty());
            watch_git_state();
            if dirty { format!("{head}-dirty") } else { head }
        }
        None => std::env::var("GI_COMMIT").unwrap_or_else(|_| "unknown".to_owned()),
    };
    println!("cargo:rustc-env=GI_BUILD_COMMIT={commit}");
}

/// Reruns this script when HEAD moves, the branch it names moves, or the index changes (a
/// commit or a staged edit). An unstaged edit of a tracked file rebuilds the crate it is in
/// but may leave the `-dirty` mark stale until the next commit or `git add`.
fn watch_git_state() {
    let Some(git_dir) = git(&["rev-parse", "--absolute-git-dir"]).map(PathBuf::from) else {
        return;
    };
    let common_dir = git(&["rev-parse", "--path-format=absolute", "--git-common-dir"])
        .map_or_else(|| git_dir.clone(), PathBuf::from);
    let mut watched = vec![
        git_dir.join("HEAD"),
        git_dir.join("index"),
        common_dir.join("packed-refs"),
    ];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watched.push(common_dir.join(branch));
    }
    for path in watched.into_iter().filter(|path| path.exists()) {
        println!("cargo:rerun-if-changed={}", path.display());
    }
}

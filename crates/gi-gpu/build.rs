//! Embeds every `.wgsl` file under the repository's `shaders/` folder into the crate, so the
//! binary needs no shader files at run time.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn main() {
    let manifest_dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap());
    let shader_dir = manifest_dir.join("../../shaders");
    // Cargo scans a directory given here recursively, so adding, editing or removing any
    // shader reruns this script.
    println!("cargo:rerun-if-changed={}", shader_dir.display());

    let mut files = Vec::new();
    if shader_dir.is_dir() {
        collect_wgsl(&shader_dir, &mut files);
    }
    files.sort();

    let mut table = String::from("&[\n");
    for file in &files {
        let relative = file.strip_prefix(&shader_dir).unwrap();
        let name: Vec<_> = relative.iter().map(|c| c.to_string_lossy()).collect();
        let absolute = file.canonicalize().unwrap();
        writeln!(
            table,
            "    ({:?}, include_str!({:?})),",
            name.join("/"),
            absolute.display().to_string()
        )
        .unwrap();
    }
    table.push(']');

    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap()).join("embedded_shaders.rs");
    std::fs::write(out, table).unwrap();
}

fn collect_wgsl(dir: &Path, files: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            collect_wgsl(&path, files);
        } else if path.extension().is_some_and(|e| e == "wgsl") {
            files.push(path);
        }
    }
}

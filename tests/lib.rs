//! End-to-end tests of the product (no library code): the flows as users run them and the
//! golden images.
//!
//! - `library.rs`: the library as an engine programmer uses it: a glTF file written and
//!   imported from disk, rendered by `Renderer::builder` (`auto`, then the GPU `path` tier)
//!   through a moving camera, a moved node and an edited light, every frame checked against
//!   the CPU reference of the same frame.
//! - `service.rs`: the render service as a client uses it, started in process: a scene
//!   uploaded, a compared job submitted, polled and downloaded, its reported error checked
//!   against the downloads, jobs cancelled.
//! - `golden.rs`: every tier's image against committed golden references (`golden/`, with the
//!   commands that made them in `golden/README.md`).
//!
//! What the two flows share (the scene built in code, the error statistics) is in `common/`.
//! The CLI's end-to-end tests live in `crates/gi-cli/tests`, where Cargo gives a test the
//! binary's path.

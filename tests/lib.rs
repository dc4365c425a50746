//! End-to-end tests of the product (no library code): `golden.rs` renders every tier and
//! checks its image against committed golden references (`golden/`, with the commands that
//! made them in `golden/README.md`).

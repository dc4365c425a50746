//! glTF 2.0 import (.gltf and .glb). (Being written.)
use std::path::Path;

use crate::{Scene, SceneError};

/// A non-fatal problem found while importing (an unsupported feature that was ignored).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportWarning(pub String);

impl std::fmt::Display for ImportWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Imports a `.gltf` or `.glb` file.
pub fn import_gltf(path: &Path) -> Result<(Scene, Vec<ImportWarning>), SceneError> {
    let _ = path;
    todo!()
}

/// Imports glTF or GLB bytes; `base` names the file in errors and resolves relative URIs.
pub fn import_gltf_slice(
    bytes: &[u8],
    base: &Path,
) -> Result<(Scene, Vec<ImportWarning>), SceneError> {
    let _ = (bytes, base);
    todo!()
}

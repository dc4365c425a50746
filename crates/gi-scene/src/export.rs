//! glTF 2.0 export (.gltf JSON + one .bin buffer). (Being written.)
use std::path::Path;

use crate::{Scene, SceneError};

/// Writes `scene` as `path` (.gltf) plus a `.bin` buffer beside it.
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let _ = (scene, path);
    todo!()
}

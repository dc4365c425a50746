//! Generators of the bundled scenes, and of small scenes for tests and tools that are not
//! bundled ([`skinned_arm`]).
//!
//! The bundled scenes are the product's test and benchmark content. They are built here in
//! memory ([`build`]) and written to glTF by `gi generate-scenes` ([`write_all`]); the files in
//! the repository's `scenes/` folder are that output, and `scenes/README.md` describes what each
//! scene is for and what a correct render shows.
//!
//! Conventions: meters, +Y up, right-handed; sun irradiance in W/m^2, point and spot
//! intensities in W/sr, emission as radiance in W/(sr m^2). Everything is deterministic: the
//! same build always yields the same scene and the same bytes on disk.

mod atrium;
mod builder;
mod cornell_box;
mod dynamic;
mod glossy;
mod open_world;
mod shapes;
mod skinned;
mod thin_wall;

use std::path::{Path, PathBuf};

use crate::{BUNDLED_SCENES, Scene, SceneError, export};

pub(crate) use builder::{SUN_COLOR, SUN_IRRADIANCE, daylight_sky, sun_direction};
pub use skinned::{
    ARM_BENT_TIME_S, ARM_HALF_WIDTH, ARM_LENGTH, ARM_NODE_TRANSLATION, skinned_arm, skinned_tube,
};

/// Builds the bundled scene `name` in memory; `None` for an unknown name.
pub fn build(name: &str) -> Option<Scene> {
    let scene = match name {
        "cornell-box" => cornell_box::build(),
        "thin-wall" => thin_wall::build(),
        "atrium" => atrium::build(),
        "open-world" => open_world::build(),
        "glossy" => glossy::build(),
        "dynamic" => dynamic::build(),
        _ => return None,
    };
    Some(scene)
}

/// Writes every bundled scene as `<dir>/<name>.gltf` plus its `<dir>/<name>.bin` buffer,
/// creating `dir` if needed, and returns the paths of all files written.
pub fn write_all(dir: &Path) -> Result<Vec<PathBuf>, SceneError> {
    std::fs::create_dir_all(dir).map_err(|source| SceneError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut written = Vec::new();
    for (name, _) in BUNDLED_SCENES {
        let scene =
            build(name).unwrap_or_else(|| panic!("bundled scene '{name}' has no generator"));
        let path = dir.join(format!("{name}.gltf"));
        written.extend(export::write_gltf_files(&scene, &path)?);
        tracing::info!("wrote {}", path.display());
    }
    Ok(written)
}

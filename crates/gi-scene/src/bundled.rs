//! Scenes addressed by bundled name or by path.

use std::path::{Path, PathBuf};

use crate::{Scene, SceneError, generate, import::import_gltf};

/// The bundled scenes: name and one-line description. Their glTF files live in the
/// repository's `scenes/` folder and are written by `gi generate-scenes`.
pub const BUNDLED_SCENES: &[(&str, &str)] = &[
    (
        "cornell-box",
        "the classic box: red and green walls, a ceiling area light, two boxes",
    ),
    (
        "thin-wall",
        "a closed room beside sunlit outdoors, split by one thin wall (light-leak test)",
    ),
    (
        "atrium",
        "a courtyard with columns, colored cloth and a sun (many bounces)",
    ),
    (
        "open-world",
        "512 x 512 m of terrain and buildings under a sun (far field, streaming)",
    ),
    (
        "glossy",
        "spheres from mirror to rough, metal and dielectric",
    ),
    (
        "dynamic",
        "a box and a light that move along a path over frames",
    ),
];

/// Folder holding the bundled scenes' glTF files: `$GI_SCENES_DIR` if set, else the `scenes/`
/// folder of the source tree this binary was built from, else `scenes/` next to the current
/// directory. `None` when none of them exists.
pub fn bundled_scene_dir() -> Option<PathBuf> {
    let candidates = [
        std::env::var_os("GI_SCENES_DIR").map(PathBuf::from),
        Some(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")),
        Some(PathBuf::from("scenes")),
    ];
    candidates
        .into_iter()
        .flatten()
        .find(|dir| dir.is_dir())
        .map(|dir| dir.canonicalize().unwrap_or(dir))
}

/// Where `name_or_path` points: an existing file, or the glTF file of a bundled scene.
/// Bundled scenes whose file is missing resolve to `None` (see [`load`], which then generates
/// them in memory).
pub fn resolve(name_or_path: &str) -> Result<Option<PathBuf>, SceneError> {
    let path = Path::new(name_or_path);
    if path.is_file() {
        return Ok(Some(path.to_path_buf()));
    }
    if BUNDLED_SCENES.iter().any(|(name, _)| *name == name_or_path) {
        let file = bundled_scene_dir().map(|dir| dir.join(format!("{name_or_path}.gltf")));
        return Ok(file.filter(|f| f.is_file()));
    }
    let looks_like_path = name_or_path.contains(['/', '\\', '.']);
    if looks_like_path {
        return Err(SceneError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    Err(SceneError::UnknownScene {
        name: name_or_path.to_string(),
        available: BUNDLED_SCENES
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
    })
}

/// Loads a scene by bundled name or by path to a `.gltf`/`.glb` file. Import warnings are
/// logged with `tracing::warn!`.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    match resolve(name_or_path)? {
        Some(path) => {
            let (mut scene, warnings) = import_gltf(&path)?;
            for warning in &warnings {
                tracing::warn!("{}: {}", path.display(), warning);
            }
            if BUNDLED_SCENES.iter().any(|(n, _)| *n == name_or_path) {
                scene.name = name_or_path.to_string();
            }
            Ok(scene)
        }
        None => Ok(generate::build(name_or_path).expect("resolve only returns None for bundled")),
    }
}

//! Scenes addressed by bundled name or by path.

use std::path::{Path, PathBuf};

use crate::import::{ImportWarning, import_gltf};
use crate::lighting::{Lighting, lighting_path_for, no_emitter_warning};
use crate::{Scene, SceneError, generate};

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

/// A scene as [`load_with_lighting`] returns it.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    pub scene: Scene,
    /// What the importer ignored or repaired, and whether nothing lights the scene.
    pub warnings: Vec<ImportWarning>,
    /// The lighting file applied to the scene, if any.
    pub lighting: Option<PathBuf>,
}

/// Loads a scene by bundled name or by path to a `.gltf`/`.glb` file, then applies a lighting
/// file ([`Lighting`]): `explicit` if given, else `<stem>.lighting.json` beside the scene file
/// when it exists. The warnings end with [`no_emitter_warning`]'s when nothing lights the
/// result.
pub fn load_with_lighting(
    name_or_path: &str,
    explicit: Option<&Path>,
) -> Result<LoadedScene, SceneError> {
    match resolve(name_or_path)? {
        Some(path) => {
            let mut loaded = import_with_lighting(&path, explicit)?;
            if BUNDLED_SCENES.iter().any(|(n, _)| *n == name_or_path) {
                loaded.scene.name = name_or_path.to_string();
            }
            Ok(loaded)
        }
        None => {
            let scene = generate::build(name_or_path).ok_or_else(|| SceneError::UnknownScene {
                name: name_or_path.to_string(),
                available: String::new(),
            })?;
            finish(scene, Vec::new(), explicit.map(Path::to_path_buf))
        }
    }
}

/// Imports the `.gltf`/`.glb` file at `path` and applies a lighting file as
/// [`load_with_lighting`] does: `explicit`, else `<stem>.lighting.json` beside `path` when it
/// exists.
pub fn import_with_lighting(
    path: &Path,
    explicit: Option<&Path>,
) -> Result<LoadedScene, SceneError> {
    let (scene, warnings) = import_gltf(path)?;
    let lighting = match explicit {
        Some(file) => Some(file.to_path_buf()),
        None => Some(lighting_path_for(path)).filter(|file| file.is_file()),
    };
    finish(scene, warnings, lighting)
}

/// Applies lighting file `lighting` to `scene` and adds the no-emitter warning.
fn finish(
    mut scene: Scene,
    mut warnings: Vec<ImportWarning>,
    lighting: Option<PathBuf>,
) -> Result<LoadedScene, SceneError> {
    if let Some(file) = &lighting {
        Lighting::from_path(file)?
            .apply(&mut scene)
            .map_err(|e| match e {
                SceneError::Lighting { message, .. } => SceneError::Lighting {
                    origin: file.display().to_string(),
                    message,
                },
                other => other,
            })?;
    }
    warnings.extend(no_emitter_warning(&scene).map(ImportWarning));
    Ok(LoadedScene {
        scene,
        warnings,
        lighting,
    })
}

/// Loads a scene by bundled name or by path to a `.gltf`/`.glb` file, with its lighting file
/// when one lies beside it ([`load_with_lighting`]). Warnings are logged with
/// `tracing::warn!`.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    let loaded = load_with_lighting(name_or_path, None)?;
    for warning in &loaded.warnings {
        tracing::warn!("{name_or_path}: {warning}");
    }
    if let Some(file) = &loaded.lighting {
        tracing::info!("{name_or_path}: lighting from {}", file.display());
    }
    Ok(loaded.scene)
}

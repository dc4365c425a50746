//! The scenes jobs may name: the bundled scenes, the `<name>.gltf`/`.glb` files of the
//! configured scene folders, and uploaded `.glb` files. A name is only ever looked up in these
//! places, never used as a path, so no request can reach a file outside them.
//!
//! An upload is a self-contained GLB (no external URI: it could name any file of this
//! machine), imported before it is accepted with a texel budget
//! ([`gi_scene::ImportOptions::max_texels`]): every image of the file, whatever its encoding
//! and wherever it is stored, is counted from its header before any is decoded, so a small,
//! highly compressed image cannot claim gigabytes of memory.

use std::{
    collections::BTreeMap,
    fs,
    path::{Path, PathBuf},
    sync::RwLock,
};

use gi_scene::{ImportOptions, Scene};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::{error::ApiError, job::now_rfc3339, store::Writer};

/// Prefix of uploaded scenes' ids; no bundled or folder scene name may start with it.
pub const UPLOAD_PREFIX: &str = "upload-";

/// Where a scene comes from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SceneSource {
    /// A bundled scene, loaded by name (from its glTF file or generated).
    Bundled(String),
    /// A `.gltf`/`.glb` file of a scene folder or an upload.
    File { name: String, path: PathBuf },
}

impl SceneSource {
    /// Loads the scene, with the `<stem>.lighting.json` beside a scene file when there is one;
    /// its name is the one jobs use for it.
    pub fn load(&self) -> Result<Scene, gi_scene::SceneError> {
        match self {
            SceneSource::Bundled(name) => gi_scene::load(name),
            SceneSource::File { name, path } => {
                let loaded = gi_scene::import_with_lighting(path, None)?;
                for warning in &loaded.warnings {
                    tracing::warn!("{}: {warning}", path.display());
                }
                let mut scene = loaded.scene;
                scene.name = name.clone();
                Ok(scene)
            }
        }
    }
}

/// An uploaded scene, as listed and stored beside its `.glb`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UploadedScene {
    /// `upload-` and the first 16 hex digits of the file's SHA-256: uploading the same file
    /// twice gives the same id.
    pub id: String,
    /// The name given at upload (for people; jobs use the id).
    pub name: String,
    pub bytes: u64,
    pub sha256: String,
    pub triangles: usize,
    pub uploaded_at: String,
    /// What the importer ignored (unsupported features).
    pub warnings: Vec<String>,
}

/// One entry of `GET /v1/scenes`.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    /// What jobs put in their `scene` field.
    pub name: String,
    /// `bundled`, `folder` or `uploaded`.
    pub source: &'static str,
    pub description: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub upload: Option<UploadedScene>,
}

/// The scenes this service renders.
pub struct SceneCatalog {
    /// Canonical scene folders.
    dirs: Vec<PathBuf>,
    uploads_dir: PathBuf,
    uploads: RwLock<BTreeMap<String, UploadedScene>>,
    writer: Writer,
}

/// True for names made only of ASCII letters, digits, `-` and `_` (at most 64, starting with
/// a letter or digit): no separators, no dots, nothing a file system interprets.
pub fn is_valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name.starts_with(|c: char| c.is_ascii_alphanumeric())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

impl SceneCatalog {
    /// The catalog over `dirs` (folders that do not exist are skipped with a warning) and the
    /// uploads stored in `uploads_dir`, which `writer` writes.
    pub fn open(dirs: &[PathBuf], uploads_dir: PathBuf, writer: Writer) -> Self {
        let dirs = dirs
            .iter()
            .filter_map(|dir| match dir.canonicalize() {
                Ok(dir) if dir.is_dir() => Some(dir),
                _ => {
                    tracing::warn!("scene folder {} does not exist; skipped", dir.display());
                    None
                }
            })
            .collect();
        let mut uploads = BTreeMap::new();
        if let Ok(entries) = fs::read_dir(&uploads_dir) {
            for entry in entries.flatten() {
                let path = entry.path();
                if path.extension().is_some_and(|e| e == "json") {
                    match fs::read(&path)
                        .ok()
                        .and_then(|b| serde_json::from_slice::<UploadedScene>(&b).ok())
                    {
                        Some(scene) if uploads_dir.join(format!("{}.glb", scene.id)).is_file() => {
                            uploads.insert(scene.id.clone(), scene);
                        }
                        _ => tracing::warn!("{}: not an uploaded scene; skipped", path.display()),
                    }
                }
            }
        }
        Self {
            dirs,
            uploads_dir,
            uploads: RwLock::new(uploads),
            writer,
        }
    }

    /// Where the scene called `name` comes from, or why there is none.
    pub fn resolve(&self, name: &str) -> Result<SceneSource, ApiError> {
        if !is_valid_name(name) {
            return Err(ApiError::invalid(
                "invalid_scene_name",
                format!(
                    "scene name {name:?} is not valid: use a bundled scene's name, a scene \
                     folder's file name without extension, or an uploaded scene's id"
                ),
            ));
        }
        if name.starts_with(UPLOAD_PREFIX) {
            if self.read_uploads().contains_key(name) {
                return Ok(SceneSource::File {
                    name: name.to_string(),
                    path: self.uploads_dir.join(format!("{name}.glb")),
                });
            }
        } else if gi_scene::BUNDLED_SCENES.iter().any(|(n, _)| *n == name) {
            return Ok(SceneSource::Bundled(name.to_string()));
        } else if let Some(path) = self.folder_scene(name) {
            return Ok(SceneSource::File {
                name: name.to_string(),
                path,
            });
        }
        Err(ApiError::invalid(
            "unknown_scene",
            format!(
                "unknown scene {name:?}; the scenes are listed at /v1/scenes ({})",
                self.names().join(", ")
            ),
        ))
    }

    /// The file of scene `name` in the first folder that has one, if it stays inside that
    /// folder once links are followed.
    fn folder_scene(&self, name: &str) -> Option<PathBuf> {
        self.dirs.iter().find_map(|dir| {
            ["gltf", "glb"].iter().find_map(|ext| {
                let path = dir.join(format!("{name}.{ext}")).canonicalize().ok()?;
                (path.starts_with(dir) && path.is_file()).then_some(path)
            })
        })
    }

    fn folder_scene_names(&self) -> Vec<(String, PathBuf)> {
        let mut names = Vec::new();
        for dir in &self.dirs {
            let Ok(entries) = fs::read_dir(dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let path = entry.path();
                let ext = path.extension().and_then(|e| e.to_str());
                let stem = path.file_stem().and_then(|s| s.to_str());
                if let (Some("gltf" | "glb"), Some(stem)) = (ext, stem)
                    && is_valid_name(stem)
                    && !stem.starts_with(UPLOAD_PREFIX)
                    && !gi_scene::BUNDLED_SCENES.iter().any(|(n, _)| *n == stem)
                    && !names.iter().any(|(n, _)| n == stem)
                {
                    names.push((stem.to_string(), path));
                }
            }
        }
        names.sort();
        names
    }

    /// Every scene name jobs may use.
    pub fn names(&self) -> Vec<String> {
        self.list().into_iter().map(|s| s.name).collect()
    }

    /// Every scene: bundled, then folder scenes, then uploads.
    pub fn list(&self) -> Vec<SceneInfo> {
        let bundled = gi_scene::BUNDLED_SCENES
            .iter()
            .map(|(name, description)| SceneInfo {
                name: name.to_string(),
                source: "bundled",
                description: description.to_string(),
                upload: None,
            });
        let folders = self
            .folder_scene_names()
            .into_iter()
            .map(|(name, path)| SceneInfo {
                name,
                source: "folder",
                description: path.display().to_string(),
                upload: None,
            });
        let uploads: Vec<SceneInfo> = self
            .read_uploads()
            .values()
            .map(|scene| SceneInfo {
                name: scene.id.clone(),
                source: "uploaded",
                description: format!("{} ({} triangles)", scene.name, scene.triangles),
                upload: Some(scene.clone()),
            })
            .collect();
        bundled.chain(folders).chain(uploads).collect()
    }

    fn read_uploads(&self) -> std::sync::RwLockReadGuard<'_, BTreeMap<String, UploadedScene>> {
        // A panic while holding the lock cannot leave the map half-updated (inserts are
        // single calls), so a poisoned lock is still usable.
        self.uploads.read().unwrap_or_else(|e| e.into_inner())
    }

    /// Validates an uploaded `.glb` and stores it. Blocking (it imports the whole scene, with
    /// at most `max_texels` texels in its images). Returns the scene and whether it is new
    /// (false: the same file was uploaded before).
    pub fn upload(
        &self,
        bytes: &[u8],
        name: &str,
        max_texels: u64,
    ) -> Result<(UploadedScene, bool), ApiError> {
        check_glb(bytes).map_err(|message| ApiError::invalid("invalid_scene", message))?;
        let digest = Sha256::digest(bytes);
        let sha256: String = digest.iter().map(|b| format!("{b:02x}")).collect();
        let id = format!("{UPLOAD_PREFIX}{}", &sha256[..16]);
        if let Some(existing) = self.read_uploads().get(&id) {
            return Ok((existing.clone(), false));
        }
        // The importer resolves relative URIs against this path; check_glb already refused any
        // external URI, so nothing is read from it.
        let options = ImportOptions {
            max_texels: Some(max_texels),
        };
        let (scene, warnings) =
            gi_scene::import_gltf_slice_with(bytes, Path::new("upload.glb"), &options)
                .map_err(|e| ApiError::invalid("invalid_scene", e.to_string()))?;
        let triangles = scene.evaluate(0.0, None).triangles.len();
        if triangles == 0 {
            return Err(ApiError::invalid(
                "invalid_scene",
                "the scene has no triangles to render",
            ));
        }
        let display_name: String = name.chars().filter(|c| !c.is_control()).take(128).collect();
        let uploaded = UploadedScene {
            id: id.clone(),
            name: if display_name.is_empty() {
                scene.name.clone()
            } else {
                display_name
            },
            bytes: bytes.len() as u64,
            sha256,
            triangles,
            uploaded_at: now_rfc3339(),
            warnings: warnings
                .iter()
                .map(|w| w.to_string())
                .chain(gi_scene::no_emitter_warning(&scene))
                .collect(),
        };
        let io_error = |e: std::io::Error| ApiError::storage("the scene", &e);
        fs::create_dir_all(&self.uploads_dir).map_err(io_error)?;
        // The file goes in before the description that lists it.
        let glb = self.uploads_dir.join(format!("{id}.glb"));
        self.writer.write(&glb, bytes).map_err(io_error)?;
        let json = serde_json::to_vec_pretty(&uploaded).expect("the scene serializes");
        if let Err(error) = (self.writer).write(&self.uploads_dir.join(format!("{id}.json")), &json)
        {
            // Unlisted, the file would only take space.
            let _ = fs::remove_file(&glb);
            return Err(io_error(error));
        }
        self.uploads
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .insert(id, uploaded.clone());
        Ok((uploaded, true))
    }
}

impl SceneCatalog {
    /// Stores an upload another process checked (the scale-out service's object store holds
    /// it): the file, then its description, as [`SceneCatalog::upload`] stores them.
    pub fn adopt(&self, scene: &UploadedScene, glb: &[u8]) -> Result<(), ApiError> {
        if !scene.id.starts_with(UPLOAD_PREFIX) || !is_valid_name(&scene.id) {
            return Err(ApiError::internal(format!(
                "{:?} is not an uploaded scene's id",
                scene.id
            )));
        }
        let io_error = |e: std::io::Error| ApiError::storage("the scene", &e);
        fs::create_dir_all(&self.uploads_dir).map_err(io_error)?;
        let id = &scene.id;
        self.writer
            .write(&self.uploads_dir.join(format!("{id}.glb")), glb)
            .map_err(io_error)?;
        let json = serde_json::to_vec_pretty(scene).expect("the scene serializes");
        (self.writer)
            .write(&self.uploads_dir.join(format!("{id}.json")), &json)
            .map_err(io_error)?;
        self.uploads
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .insert(id.clone(), scene.clone());
        Ok(())
    }

    /// Deletes uploaded scene `id` (its description first, so a crash leaves at most an
    /// unlisted file). Bundled and folder scenes are refused (409 `scene_not_deletable`).
    pub fn delete(&self, id: &str) -> Result<UploadedScene, ApiError> {
        if !id.starts_with(UPLOAD_PREFIX) {
            let known = self.resolve(id)?;
            return Err(ApiError::new(
                axum::http::StatusCode::CONFLICT,
                "scene_not_deletable",
                format!(
                    "scene {id} is {}; only uploaded scenes can be deleted",
                    match known {
                        SceneSource::Bundled(_) => "bundled with the service",
                        SceneSource::File { .. } => "in a scene folder of the service",
                    }
                ),
            ));
        }
        let mut uploads = self.uploads.write().unwrap_or_else(|e| e.into_inner());
        let Some(scene) = uploads.get(id).cloned() else {
            return Err(scene_not_found(id));
        };
        let io_error = |e: std::io::Error| ApiError::storage(&format!("scene {id}'s deletion"), &e);
        fs::remove_file(self.uploads_dir.join(format!("{id}.json"))).map_err(io_error)?;
        uploads.remove(id);
        if let Err(error) = fs::remove_file(self.uploads_dir.join(format!("{id}.glb"))) {
            tracing::warn!("scenes/{id}.glb: {error}; the file is left unlisted");
        }
        Ok(scene)
    }
}

pub fn scene_not_found(id: &str) -> ApiError {
    ApiError::not_found("scene_not_found", format!("no uploaded scene {id}"))
}

/// Checks the GLB container before anything parses it: header, lengths, a JSON first chunk,
/// and only embedded data (an external URI could name any file of this machine). The images'
/// sizes are the importer's to check ([`ImportOptions::max_texels`]).
fn check_glb(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |offset: usize| {
        bytes
            .get(offset..offset + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    if bytes.len() < 20 || &bytes[0..4] != b"glTF" {
        return Err("not a binary glTF (.glb) file: it must start with the `glTF` magic".into());
    }
    if u32_at(4) != Some(2) {
        return Err(format!(
            "glTF container version {} is not supported (only 2)",
            u32_at(4).unwrap_or(0)
        ));
    }
    if u32_at(8) != Some(bytes.len() as u32) {
        return Err(format!(
            "the GLB header says {} bytes but the upload has {}",
            u32_at(8).unwrap_or(0),
            bytes.len()
        ));
    }
    let json_len = u32_at(12).unwrap_or(0) as usize;
    if u32_at(16) != Some(0x4E4F_534A) || 20 + json_len > bytes.len() {
        return Err("the GLB's first chunk is not a complete JSON chunk".into());
    }
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len])
        .map_err(|e| format!("the GLB's JSON chunk is not valid JSON: {e}"))?;
    for kind in ["buffers", "images"] {
        let items = json.get(kind).and_then(|v| v.as_array());
        for (index, item) in items.into_iter().flatten().enumerate() {
            if let Some(uri) = item.get("uri").and_then(|u| u.as_str())
                && !uri.starts_with("data:")
            {
                return Err(format!(
                    "{kind}[{index}] refers to an external file ({uri:?}); uploads must be \
                     self-contained (embed buffers and images in the .glb)"
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_with_separators_or_dots_are_invalid() {
        for bad in [
            "",
            "../etc/passwd",
            "a/b",
            "a\\b",
            "..",
            ".hidden",
            "x.gltf",
            "a b",
        ] {
            assert!(!is_valid_name(bad), "{bad:?}");
        }
        for good in ["cornell-box", "upload-0123456789abcdef", "Scene_2"] {
            assert!(is_valid_name(good), "{good:?}");
        }
    }

    fn glb(json: &str) -> Vec<u8> {
        let mut json = json.as_bytes().to_vec();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let total = 12 + 8 + json.len();
        let mut bytes = b"glTF".to_vec();
        bytes.extend(2u32.to_le_bytes());
        bytes.extend((total as u32).to_le_bytes());
        bytes.extend((json.len() as u32).to_le_bytes());
        bytes.extend(0x4E4F_534Au32.to_le_bytes());
        bytes.extend(json);
        bytes
    }

    #[test]
    fn glb_containers_are_checked_before_import() {
        assert!(check_glb(&glb(r#"{"asset": {"version": "2.0"}}"#)).is_ok());
        assert!(check_glb(b"not a glb at all, certainly").is_err());
        let mut truncated = glb(r#"{"asset": {"version": "2.0"}}"#);
        truncated.pop();
        assert!(check_glb(&truncated).unwrap_err().contains("header says"));
        let external = glb(
            r#"{"asset": {"version": "2.0"}, "buffers": [{"uri": "../../x.bin", "byteLength": 4}]}"#,
        );
        assert!(check_glb(&external).unwrap_err().contains("external file"));
    }
}

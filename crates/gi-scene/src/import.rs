//! glTF 2.0 import (.gltf with external or embedded data, and .glb).
//!
//! The gltf crate parses and validates the JSON. The importer then reads the validated JSON
//! directly instead of going through the crate's convenience wrappers and accessor iterators:
//! those unwrap values that validation does not fully cover (camera projections, image sources,
//! accessor ranges), and no input file may panic the product. Everything the scene model cannot
//! represent is either converted (strips, fans, cubic splines, missing normals) or skipped with
//! an [`ImportWarning`]. Skins are imported with the nodes that use them: joints, inverse bind
//! matrices, and per-vertex `JOINTS_0`/`WEIGHTS_0` checked against the skin's joint list.
//! Morph targets are imported with their meshes (`POSITION`, `NORMAL` and `TANGENT`
//! displacements), their weights from the mesh, the nodes and `weights` animation channels,
//! each checked against the mesh's number of targets.

mod animation;
mod buffers;
mod dds;
mod extensions;
mod extras;
mod images;
mod material;
mod mesh;
mod morph;
mod nodes;
mod skins;
mod tangents;
mod textures;

use std::cell::Cell;
use std::collections::HashSet;
use std::path::Path;

use gltf::json;
use gltf::json::validation::{Checked, Validate};

use crate::{Animation, Scene, SceneError};
use buffers::Buffers;

/// A non-fatal problem found while importing (an unsupported feature that was ignored).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportWarning(pub String);

impl std::fmt::Display for ImportWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// How an import reads a file. The default reads any file the importer supports, whatever the
/// size of its images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportOptions {
    /// Most texels the import may decode, over all of the file's images; `None`: no limit.
    ///
    /// With a limit, the size of every image of the file (used by a material or not, in a
    /// buffer view of any buffer, a data URI or a file beside a `.gltf`) is read from its
    /// header before anything is decoded, and the import fails with
    /// [`SceneError::Invalid`] naming the image when the sizes add up to more, or when an
    /// image is not a PNG, JPEG or DDS whose header reads. Textures combined from
    /// `AMD_split_roughnessMetallic` maps count too. A small, highly compressed image can
    /// claim a size that takes gigabytes to decode: whoever imports untrusted files bounds
    /// their memory with this (an RGBA8 texel is 4 bytes once decoded, more while decoding),
    /// at the cost of refusing files whose images are all legitimately large.
    pub max_texels: Option<u64>,
}

/// Imports a `.gltf` or `.glb` file; relative URIs resolve against the file's folder.
pub fn import_gltf(path: &Path) -> std::result::Result<(Scene, Vec<ImportWarning>), SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    import_gltf_slice(&bytes, path)
}

/// Imports glTF or GLB bytes; `base` names the file in errors and resolves relative URIs.
pub fn import_gltf_slice(
    bytes: &[u8],
    base: &Path,
) -> std::result::Result<(Scene, Vec<ImportWarning>), SceneError> {
    import_gltf_slice_with(bytes, base, &ImportOptions::default())
}

/// Imports glTF or GLB bytes as [`import_gltf_slice`] does, with `options`.
pub fn import_gltf_slice_with(
    bytes: &[u8],
    base: &Path,
    options: &ImportOptions,
) -> std::result::Result<(Scene, Vec<ImportWarning>), SceneError> {
    let mut warnings = Warnings::default();
    match import(bytes, base, options, &mut warnings) {
        Ok(scene) => Ok((scene, warnings.finish())),
        Err(Failure::Malformed(message)) => Err(SceneError::Gltf {
            path: base.to_path_buf(),
            message,
        }),
        Err(Failure::Unusable(message)) => Err(SceneError::Invalid {
            path: base.to_path_buf(),
            message,
        }),
    }
}

/// Why an import failed, before the file name is attached.
enum Failure {
    /// Not valid glTF: becomes [`SceneError::Gltf`].
    Malformed(String),
    /// Valid glTF the product cannot use: becomes [`SceneError::Invalid`].
    Unusable(String),
}

type Result<T> = std::result::Result<T, Failure>;

fn malformed(message: impl Into<String>) -> Failure {
    Failure::Malformed(message.into())
}

fn unusable(message: impl Into<String>) -> Failure {
    Failure::Unusable(message.into())
}

/// Collects warnings, reporting each unsupported feature once per file.
#[derive(Default)]
struct Warnings {
    list: Vec<ImportWarning>,
    seen: HashSet<String>,
    /// Warnings of one kind that a file may have by the dozen (textures whose images are
    /// missing): per kind, what each single warning ends with, and the items. A kind with more
    /// than [`GROUPED_SINGLY`] items becomes one warning that lists them all.
    groups: Vec<(&'static str, Vec<String>)>,
}

/// Items of one kind reported as warnings of their own; more are listed in one warning.
const GROUPED_SINGLY: usize = 3;

impl Warnings {
    /// Records `message()` unless a warning with the same `key` was recorded before.
    fn once(&mut self, key: &str, message: impl FnOnce() -> String) {
        if self.seen.insert(key.to_string()) {
            self.list.push(ImportWarning(message()));
        }
    }

    /// Records `message()` (unless `key` was seen) as an item of the kind whose warnings end
    /// with `consequence`: up to [`GROUPED_SINGLY`] items, each is a warning `message;
    /// consequence`; with more, the file gets one warning that counts and lists them.
    fn grouped(&mut self, consequence: &'static str, key: &str, message: impl FnOnce() -> String) {
        if !self.seen.insert(key.to_string()) {
            return;
        }
        let message = message();
        match self.groups.iter_mut().find(|(c, _)| *c == consequence) {
            Some((_, items)) => items.push(message),
            None => self.groups.push((consequence, vec![message])),
        }
    }

    /// Every warning, the grouped ones last.
    fn finish(mut self) -> Vec<ImportWarning> {
        for (consequence, items) in self.groups {
            if items.len() <= GROUPED_SINGLY {
                self.list.extend(
                    items
                        .into_iter()
                        .map(|item| ImportWarning(format!("{item}; {consequence}"))),
                );
            } else {
                self.list.push(ImportWarning(format!(
                    "{consequence} ({} times): {}",
                    items.len(),
                    items.join("; ")
                )));
            }
        }
        self.list
    }
}

/// The parsed document, its loaded buffers, the folder its relative URIs start from and the
/// texels it may still decode.
struct Source<'a> {
    root: &'a json::Root,
    buffers: Buffers<'a>,
    dir: &'a Path,
    texel_budget: Option<TexelBudget>,
}

/// The texels an import with [`ImportOptions::max_texels`] has counted so far.
struct TexelBudget {
    max: u64,
    used: Cell<u64>,
}

impl TexelBudget {
    /// Counts `width` x `height` texels more, or refuses the file, naming what brought them
    /// (`what`), when the count passes the limit.
    fn charge(&self, width: u32, height: u32, what: impl FnOnce() -> String) -> Result<()> {
        let used = (self.used.get()).saturating_add(u64::from(width) * u64::from(height));
        if used > self.max {
            return Err(unusable(format!(
                "{} brings the file's textures to {used} texels, more than the {} allowed",
                what(),
                self.max
            )));
        }
        self.used.set(used);
        Ok(())
    }
}

fn import(
    bytes: &[u8],
    base: &Path,
    options: &ImportOptions,
    warnings: &mut Warnings,
) -> Result<Scene> {
    let gltf::Gltf { document, blob } = parse(bytes)?;
    let root = document.as_json();
    extensions::warn_ignored(root, warnings);
    morph::warn_unsupported_attributes(bytes, root, warnings);
    let dir = base.parent().unwrap_or(Path::new(""));
    let source = Source {
        root,
        buffers: Buffers::load(root, blob, dir)?,
        dir,
        texel_budget: options.max_texels.map(|max| TexelBudget {
            max,
            used: Cell::new(0),
        }),
    };
    // Every image is counted before the first one is decoded.
    images::charge_all(&source)?;

    let scene_json = match root.scene {
        Some(index) => Some(
            root.scenes
                .get(index.value())
                .ok_or_else(|| malformed(format!("scene {} does not exist", index.value())))?,
        ),
        None => root.scenes.first(),
    };
    let roots = match scene_json {
        Some(scene) => scene.nodes.iter().map(|n| n.value()).collect(),
        None => nodes::parentless_nodes(root),
    };
    let settings = extras::scene_settings(scene_json.map(|s| &s.extras), warnings)?;

    let mut scene = Scene {
        name: base
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        sky: settings.sky,
        exposure: settings.exposure,
        frame_time_s: settings.frame_time_s,
        camera_path: settings.camera_path,
        ..Scene::default()
    };
    let camera_map = nodes::import_cameras(root, &mut scene, warnings)?;
    let light_map = nodes::import_lights(root, &mut scene, warnings)?;

    // Nodes in depth-first order; `node_map[file index]` is the model index.
    let order = nodes::depth_first(root, &roots)?;
    let mut node_map = vec![None; root.nodes.len()];
    for (model_index, &(file_index, _)) in order.iter().enumerate() {
        node_map[file_index] = Some(model_index);
    }
    let mut mesh_map = vec![None; root.meshes.len()];
    let mut skin_map = vec![None; root.skins.len()];
    let mut materials = material::Materials::new(root.materials.len());
    for &(file_index, parent) in &order {
        let json_node = &root.nodes[file_index];
        let mut node = nodes::import_node(json_node, file_index)?;
        node.parent = parent.and_then(|p| node_map[p]);
        node.camera = match json_node.camera {
            Some(c) => *camera_map.get(c.value()).ok_or_else(|| {
                malformed(format!("nodes[{file_index}]: no camera {}", c.value()))
            })?,
            None => None,
        };
        if let Some(ext) = json_node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
        {
            let light = ext.light.value();
            node.light = Some(
                *light_map
                    .get(light)
                    .ok_or_else(|| malformed(format!("nodes[{file_index}]: no light {light}")))?,
            );
        }
        if let Some(mesh) = json_node.mesh {
            let slot = mesh_map.get_mut(mesh.value()).ok_or_else(|| {
                malformed(format!("nodes[{file_index}]: no mesh {}", mesh.value()))
            })?;
            if slot.is_none() {
                let imported =
                    mesh::import_mesh(&source, mesh.value(), &mut materials, &mut scene, warnings)?;
                scene.meshes.push(imported);
                *slot = Some(scene.meshes.len() - 1);
            }
            node.mesh = *slot;
        }
        if let Some(weights) = &node.weights {
            let mesh = json_node.mesh.and_then(|m| root.meshes.get(m.value()));
            let targets = mesh.map_or(0, morph::target_count);
            morph::check_weights(weights, targets, &format!("nodes[{file_index}].weights"))?;
        }
        if let Some(skin) = json_node.skin {
            let slot = skin_map.get_mut(skin.value()).ok_or_else(|| {
                malformed(format!("nodes[{file_index}]: no skin {}", skin.value()))
            })?;
            if slot.is_none() {
                scene
                    .skins
                    .push(skins::import_skin(&source, skin.value(), &node_map)?);
                *slot = Some(scene.skins.len() - 1);
            }
            node.skin = *slot;
            if let (Some(mesh), Some(skin)) = (node.mesh, *slot) {
                skins::check_skinned_mesh(
                    &scene.meshes[mesh],
                    &scene.skins[skin],
                    &format!("nodes[{file_index}]"),
                    warnings,
                )?;
            }
        }
        scene.nodes.push(node);
    }

    scene.animations = animation::import_animations(&source, &node_map, &scene, warnings)?;
    for (model_index, &(file_index, _)) in order.iter().enumerate() {
        let node = &scene.nodes[model_index];
        let label = if node.name.is_empty() {
            format!("node {file_index}")
        } else {
            node.name.clone()
        };
        if let Some(path) = extras::node_path(
            &root.nodes[file_index].extras,
            &label,
            model_index,
            warnings,
        )? {
            scene.animations.push(Animation {
                name: label,
                channels: vec![path],
            });
        }
    }

    scene.default_camera_node = match &settings.camera {
        Some(name) => Some(
            scene
                .nodes
                .iter()
                .position(|n| &n.name == name && n.camera.is_some())
                .ok_or_else(|| {
                    unusable(format!(
                        "scene extras: gi.camera names \"{name}\", which is not a node with a perspective camera in the scene"
                    ))
                })?,
        ),
        None => scene.nodes.iter().position(|n| n.camera.is_some()),
    };

    let triangles: usize = scene
        .nodes
        .iter()
        .filter_map(|n| n.mesh)
        .flat_map(|m| &scene.meshes[m].primitives)
        .map(|p| p.indices.len() / 3)
        .sum();
    if triangles == 0 {
        return Err(unusable("the scene has no triangles"));
    }
    Ok(scene)
}

/// Parses and validates the document, turning every problem into an error.
fn parse(bytes: &[u8]) -> Result<gltf::Gltf> {
    // Checked here because the gltf crate subtracts the header size from the declared length
    // without a bound check, and reports truncation without numbers.
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 {
            return Err(malformed(format!(
                "GLB header declares an impossible length of {length} bytes"
            )));
        }
        if length as usize > bytes.len() {
            return Err(malformed(format!(
                "GLB is truncated: its header declares a length of {length} bytes, the data has {}",
                bytes.len()
            )));
        }
    }
    let gltf =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| malformed(e.to_string()))?;
    let root = gltf.document.as_json();

    // The crate's validation looks up each POSITION accessor without a bounds check.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive
                .attributes
                .get(&Checked::Valid(json::mesh::Semantic::Positions))
                && index.value() >= root.accessors.len()
            {
                return Err(malformed(format!(
                    "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not exist",
                    index.value()
                )));
            }
        }
    }

    let mut problems = Vec::new();
    root.validate(root, json::Path::new, &mut |path, error| {
        let path = path();
        // Required extensions are checked below against what this importer supports.
        if !path.as_str().starts_with("extensionsRequired") {
            problems.push(format!("{path}: {error}"));
        }
    });
    if !problems.is_empty() {
        let shown = problems.len().min(5);
        let more = if problems.len() > shown {
            format!(" (and {} more)", problems.len() - shown)
        } else {
            String::new()
        };
        return Err(malformed(format!("{}{more}", problems[..shown].join("; "))));
    }
    extensions::check_required(root)?;
    Ok(gltf)
}

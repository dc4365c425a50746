//! glTF 2.0 export: a `.gltf` JSON file, one `.bin` buffer beside it, and one PNG per texture.
//! Skins are written with their joints, inverse bind matrices and the primitives' `JOINTS_0`
//! (16-bit) and `WEIGHTS_0` (float), so an export reads back with the same skinning. Morph
//! targets are written with their displacements, the mesh and node `weights` and `weights`
//! animation channels, so an export reads back with the same shapes.
//!
//! The JSON is built with `serde_json` values, whose objects keep a fixed key order and whose
//! numbers are printed by a fixed algorithm, so the same scene always gives the same bytes.
//! Product settings (sky, exposure, frame time, default camera, camera path) go into the glTF
//! scene's `extras.gi` object as documented in `scenes/README.md`; the importer reads them back.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde_json::{Map, Value, json};

use crate::SceneError;
use crate::model::Scene;

mod items;
mod validate;

use items::{
    animation_json, light_json, material_json, mesh_json, node_json, settings_json, skin_json,
    texture_images, unique_names,
};
use validate::validate;

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const UNSIGNED_SHORT: u32 = 5123;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const LINEAR: u32 = 9729;
const REPEAT: u32 = 10497;
const LIGHTS_PUNCTUAL: &str = "KHR_lights_punctual";
const EMISSIVE_STRENGTH: &str = "KHR_materials_emissive_strength";
const SPECULAR: &str = "KHR_materials_specular";
const IOR: &str = "KHR_materials_ior";
const TEXTURE_TRANSFORM: &str = "KHR_texture_transform";

/// Writes `scene` as `path` (.gltf) plus a `.bin` buffer beside it.
///
/// The buffer is `<stem>.bin` and textures are `<stem>_<index>.png` in the same folder.
/// Fails with [`SceneError::Invalid`] when the scene cannot be expressed as valid glTF
/// (out-of-range indices, missing normals, non-finite numbers...).
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    write_gltf_files(scene, path).map(|_| ())
}

/// [`write_gltf`], returning every file written (the `.gltf` first).
pub(crate) fn write_gltf_files(scene: &Scene, path: &Path) -> Result<Vec<PathBuf>, SceneError> {
    let invalid = |message: String| SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    validate(scene).map_err(invalid)?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty())
        .ok_or_else(|| invalid("output path has no usable file name".into()))?;
    let sibling = |name: &str| path.with_file_name(name);

    let mut writer = Writer::default();
    let pngs = texture_images(scene, stem);
    let mut root = Map::new();
    root.insert(
        "asset".into(),
        json!({ "version": "2.0", "generator": "gi" }),
    );
    let mut extensions_used = Vec::new();
    if !scene.lights.is_empty() {
        extensions_used.push(LIGHTS_PUNCTUAL);
        let lights: Vec<Value> = scene.lights.iter().map(light_json).collect();
        root.insert(
            "extensions".into(),
            json!({ LIGHTS_PUNCTUAL: { "lights": lights } }),
        );
    }
    if scene
        .materials
        .iter()
        .any(|m| m.emissive.max_element() > 1.0)
    {
        extensions_used.push(EMISSIVE_STRENGTH);
    }
    if scene.materials.iter().any(items::has_specular_layer) {
        extensions_used.push(SPECULAR);
    }
    if scene.materials.iter().any(|m| m.ior != 1.5) {
        extensions_used.push(IOR);
    }
    if scene.materials.iter().any(items::has_texture_transform) {
        extensions_used.push(TEXTURE_TRANSFORM);
    }
    if !extensions_used.is_empty() {
        root.insert("extensionsUsed".into(), json!(extensions_used));
    }
    let materials: Vec<Value> = scene.materials.iter().map(material_json).collect();
    let meshes: Vec<Value> = scene
        .meshes
        .iter()
        .map(|m| mesh_json(m, &mut writer))
        .collect();
    let animations: Vec<Value> = scene
        .animations
        .iter()
        .filter(|a| !a.channels.is_empty())
        .map(|a| animation_json(a, &mut writer))
        .collect();
    let skins: Vec<Value> = scene
        .skins
        .iter()
        .map(|s| skin_json(s, &mut writer))
        .collect();
    let names = unique_names(scene);
    let nodes: Vec<Value> = (0..scene.nodes.len())
        .map(|i| node_json(scene, i, &names[i]))
        .collect();
    let cameras: Vec<Value> = scene
        .cameras
        .iter()
        .map(|c| {
            let mut perspective = json!({ "yfov": num(c.yfov), "znear": num(c.znear) });
            if let Some(aspect) = c.aspect_ratio {
                perspective["aspectRatio"] = num(aspect);
            }
            json!({ "name": c.name, "type": "perspective", "perspective": perspective })
        })
        .collect();
    let roots: Vec<usize> = (0..scene.nodes.len())
        .filter(|&i| scene.nodes[i].parent.is_none())
        .collect();
    let mut scene_json =
        json!({ "name": scene.name, "extras": { "gi": settings_json(scene, &names) } });
    if !roots.is_empty() {
        scene_json["nodes"] = json!(roots);
    }
    root.insert("scene".into(), json!(0));
    root.insert("scenes".into(), json!([scene_json]));

    let bin_name = format!("{stem}.bin");
    if !writer.bin.is_empty() {
        root.insert(
            "buffers".into(),
            json!([{ "uri": uri_escape(&bin_name), "byteLength": writer.bin.len() }]),
        );
        root.insert("bufferViews".into(), Value::Array(writer.views));
        root.insert("accessors".into(), Value::Array(writer.accessors));
    }
    for (key, array) in [
        ("nodes", nodes),
        ("meshes", meshes),
        ("materials", materials),
        ("cameras", cameras),
        ("animations", animations),
        ("skins", skins),
    ] {
        if !array.is_empty() {
            root.insert(key.into(), Value::Array(array));
        }
    }
    if !pngs.is_empty() {
        let image_json: Vec<Value> = pngs
            .iter()
            .map(|(name, _)| json!({ "uri": uri_escape(name) }))
            .collect();
        let textures: Vec<Value> = (0..pngs.len())
            .map(|i| json!({ "source": i, "sampler": 0 }))
            .collect();
        root.insert("images".into(), Value::Array(image_json));
        root.insert("textures".into(), Value::Array(textures));
        root.insert(
            "samplers".into(),
            json!([{ "magFilter": LINEAR, "minFilter": LINEAR, "wrapS": REPEAT, "wrapT": REPEAT }]),
        );
    }

    let mut written = Vec::new();
    let mut text = String::new();
    write_json(&Value::Object(root), 0, &mut text);
    text.push('\n');
    write_file(path, text.as_bytes())?;
    written.push(path.to_path_buf());
    if !writer.bin.is_empty() {
        let bin_path = sibling(&bin_name);
        write_file(&bin_path, &writer.bin)?;
        written.push(bin_path);
    }
    for (name, image) in pngs {
        let png_path = sibling(&name);
        image
            .save_with_format(&png_path, image::ImageFormat::Png)
            .map_err(|e| SceneError::Io {
                path: png_path.clone(),
                source: std::io::Error::other(e),
            })?;
        written.push(png_path);
    }
    Ok(written)
}

/// Pretty JSON that keeps arrays of numbers and strings on one line (vectors, index lists),
/// so the committed files stay short and diff well.
fn write_json(value: &Value, indent: usize, out: &mut String) {
    let pad = |out: &mut String, depth: usize| out.extend(std::iter::repeat_n("  ", depth));
    match value {
        Value::Array(items) if items.iter().any(|v| v.is_array() || v.is_object()) => {
            out.push_str("[\n");
            for (i, item) in items.iter().enumerate() {
                pad(out, indent + 1);
                write_json(item, indent + 1, out);
                out.push_str(if i + 1 < items.len() { ",\n" } else { "\n" });
            }
            pad(out, indent);
            out.push(']');
        }
        Value::Object(fields) if !fields.is_empty() => {
            out.push_str("{\n");
            for (i, (key, item)) in fields.iter().enumerate() {
                pad(out, indent + 1);
                out.push_str(&Value::String(key.clone()).to_string());
                out.push_str(": ");
                write_json(item, indent + 1, out);
                out.push_str(if i + 1 < fields.len() { ",\n" } else { "\n" });
            }
            pad(out, indent);
            out.push('}');
        }
        // Flat arrays of scalars (vectors, root lists) stay on one line.
        Value::Array(items) => {
            let items: Vec<String> = items.iter().map(Value::to_string).collect();
            out.push('[');
            out.push_str(&items.join(", "));
            out.push(']');
        }
        // Scalars and empty objects: serde_json's compact form (escaped strings, shortest
        // round-trip numbers).
        _ => out.push_str(&value.to_string()),
    }
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    std::fs::write(path, bytes).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A JSON number holding the shortest decimal that reads back as `x` (an `f32` widened to
/// `f64` directly would print as e.g. 0.10000000149011612).
fn num(x: f32) -> Value {
    let shortest: f64 = x.to_string().parse().unwrap_or(0.0);
    json!(shortest)
}

/// glTF requires unit normals and rotations; values already unit length are written as they
/// are so that a round trip reproduces them bit for bit.
fn unit(v: Vec3) -> Vec3 {
    if (v.length_squared() - 1.0).abs() < 1e-6 {
        v
    } else {
        v.normalize_or(Vec3::Y)
    }
}

fn unit_quat(q: Quat) -> Quat {
    if (q.length_squared() - 1.0).abs() < 1e-6 {
        q
    } else {
        q.normalize()
    }
}

fn vec_json<const N: usize>(v: [f32; N]) -> Value {
    Value::Array(v.into_iter().map(num).collect())
}

/// Accumulates the binary buffer and its views and accessors.
#[derive(Default)]
struct Writer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Writer {
    /// Appends one view of `components` 4-byte words (one 4-byte component each, or two 16-bit
    /// ones); returns the new accessor's index.
    fn accessor(
        &mut self,
        components: impl IntoIterator<Item = [u8; 4]>,
        count: usize,
        kind: &str,
        component_type: u32,
        target: Option<u32>,
    ) -> usize {
        // Every element is made of 4-byte words, so 4-byte view alignment is enough.
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        for bytes in components {
            self.bin.extend_from_slice(&bytes);
        }
        let mut view =
            json!({ "buffer": 0, "byteOffset": offset, "byteLength": self.bin.len() - offset });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.views.push(view);
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1,
            "componentType": component_type,
            "count": count,
            "type": kind,
        }));
        self.accessors.len() - 1
    }

    fn floats<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        kind: &str,
        target: Option<u32>,
    ) -> usize {
        let bytes = data.iter().flatten().map(|x| x.to_le_bytes());
        self.accessor(bytes, data.len(), kind, FLOAT, target)
    }

    /// Float accessor with `min` and `max` (required for positions and animation inputs).
    fn floats_bounded<const N: usize>(
        &mut self,
        data: &[[f32; N]],
        kind: &str,
        target: Option<u32>,
    ) -> usize {
        let index = self.floats(data, kind, target);
        let (mut min, mut max) = ([f32::MAX; N], [f32::MIN; N]);
        for v in data {
            for k in 0..N {
                min[k] = min[k].min(v[k]);
                max[k] = max[k].max(v[k]);
            }
        }
        self.accessors[index]["min"] = vec_json(min);
        self.accessors[index]["max"] = vec_json(max);
        index
    }
}

/// Percent-encodes everything but unreserved URI characters (file names become relative URIs).
fn uri_escape(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

//! glTF 2.0 export: a `.gltf` JSON file, one `.bin` buffer beside it, and one PNG per texture.
//!
//! The JSON is built with `serde_json` values, whose objects keep a fixed key order and whose
//! numbers are printed by a fixed algorithm, so the same scene always gives the same bytes.
//! Product settings (sky, exposure, frame time, default camera, camera path) go into the glTF
//! scene's `extras.gi` object as documented in `scenes/README.md`; the importer reads them back.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec2, Vec3, Vec4};
use serde_json::{Map, Value, json};

use crate::model::{ChannelValues, Interpolation, LightKind, Material, Scene, Sky};
use crate::{SceneError, Texture};

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const LINEAR: u32 = 9729;
const REPEAT: u32 = 10497;
const LIGHTS_PUNCTUAL: &str = "KHR_lights_punctual";
const EMISSIVE_STRENGTH: &str = "KHR_materials_emissive_strength";

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
    let (images, pngs) = texture_images(scene, stem);
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
    if !extensions_used.is_empty() {
        root.insert("extensionsUsed".into(), json!(extensions_used));
    }
    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| material_json(m, &images))
        .collect();
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
    /// Appends one view of `components` 4-byte values; returns the new accessor's index.
    fn accessor(
        &mut self,
        components: impl IntoIterator<Item = [u8; 4]>,
        count: usize,
        kind: &str,
        component_type: u32,
        target: Option<u32>,
    ) -> usize {
        // Every element is made of 4-byte components, so 4-byte view alignment is enough.
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

fn mesh_json(mesh: &crate::model::Mesh, writer: &mut Writer) -> Value {
    let primitives: Vec<Value> = mesh
        .primitives
        .iter()
        .map(|p| {
            let positions: Vec<[f32; 3]> = p.positions.iter().map(|v| v.to_array()).collect();
            let normals: Vec<[f32; 3]> = p.normals.iter().map(|n| unit(*n).to_array()).collect();
            let mut attributes = json!({
                "POSITION": writer.floats_bounded(&positions, "VEC3", Some(ARRAY_BUFFER)),
                "NORMAL": writer.floats(&normals, "VEC3", Some(ARRAY_BUFFER)),
            });
            if !p.uvs.is_empty() {
                let uvs: Vec<[f32; 2]> = p.uvs.iter().map(Vec2::to_array).collect();
                attributes["TEXCOORD_0"] = json!(writer.floats(&uvs, "VEC2", Some(ARRAY_BUFFER)));
            }
            let indices = p.indices.iter().map(|i| i.to_le_bytes());
            let indices = writer.accessor(indices, p.indices.len(), "SCALAR", UNSIGNED_INT, Some(ELEMENT_ARRAY_BUFFER));
            json!({ "attributes": attributes, "indices": indices, "material": p.material, "mode": 4 })
        })
        .collect();
    json!({ "name": mesh.name, "primitives": primitives })
}

fn animation_json(animation: &crate::model::Animation, writer: &mut Writer) -> Value {
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for channel in &animation.channels {
        let times: Vec<[f32; 1]> = channel.times.iter().map(|t| [*t]).collect();
        let input = writer.floats_bounded(&times, "SCALAR", None);
        let (path, output) = match &channel.values {
            ChannelValues::Translation(v) => {
                let data: Vec<[f32; 3]> = v.iter().map(Vec3::to_array).collect();
                ("translation", writer.floats(&data, "VEC3", None))
            }
            ChannelValues::Rotation(v) => {
                let data: Vec<[f32; 4]> = v.iter().map(|q| unit_quat(*q).to_array()).collect();
                ("rotation", writer.floats(&data, "VEC4", None))
            }
            ChannelValues::Scale(v) => {
                let data: Vec<[f32; 3]> = v.iter().map(Vec3::to_array).collect();
                ("scale", writer.floats(&data, "VEC3", None))
            }
        };
        let interpolation = match channel.interpolation {
            Interpolation::Linear => "LINEAR",
            Interpolation::Step => "STEP",
        };
        samplers.push(json!({ "input": input, "output": output, "interpolation": interpolation }));
        channels.push(json!({
            "sampler": samplers.len() - 1,
            "target": { "node": channel.node, "path": path },
        }));
    }
    json!({ "name": animation.name, "samplers": samplers, "channels": channels })
}

fn node_json(scene: &Scene, index: usize, name: &str) -> Value {
    let node = &scene.nodes[index];
    let mut value = json!({ "name": name });
    if node.translation != Vec3::ZERO {
        value["translation"] = vec_json(node.translation.to_array());
    }
    let rotation = unit_quat(node.rotation);
    if rotation != Quat::IDENTITY {
        value["rotation"] = vec_json(rotation.to_array());
    }
    if node.scale != Vec3::ONE {
        value["scale"] = vec_json(node.scale.to_array());
    }
    let children: Vec<usize> = (0..scene.nodes.len())
        .filter(|&i| scene.nodes[i].parent == Some(index))
        .collect();
    if !children.is_empty() {
        value["children"] = json!(children);
    }
    if let Some(mesh) = node.mesh {
        value["mesh"] = json!(mesh);
    }
    if let Some(camera) = node.camera {
        value["camera"] = json!(camera);
    }
    if let Some(light) = node.light {
        value["extensions"] = json!({ LIGHTS_PUNCTUAL: { "light": light } });
    }
    value
}

/// Node names made unique (the scene extras name the default camera's node): empty names
/// become `node<index>`, repeats get a `.<index>` suffix.
fn unique_names(scene: &Scene) -> Vec<String> {
    let mut taken = std::collections::BTreeSet::new();
    let mut names = Vec::with_capacity(scene.nodes.len());
    for (index, node) in scene.nodes.iter().enumerate() {
        let mut name = if node.name.is_empty() {
            format!("node{index}")
        } else {
            node.name.clone()
        };
        while taken.contains(&name) {
            name = format!("{name}.{index}");
        }
        taken.insert(name.clone());
        names.push(name);
    }
    names
}

fn light_json(light: &crate::model::Light) -> Value {
    let mut value = json!({
        "name": light.name,
        "color": vec_json(light.color.to_array()),
        "intensity": num(light.intensity),
    });
    if let Some(range) = light.range {
        value["range"] = num(range);
    }
    match light.kind {
        LightKind::Directional => value["type"] = json!("directional"),
        LightKind::Point => value["type"] = json!("point"),
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            value["type"] = json!("spot");
            value["spot"] = json!({
                "innerConeAngle": num(inner_cone_angle),
                "outerConeAngle": num(outer_cone_angle),
            });
        }
    }
    value
}

/// The glTF texture index of each model texture in each color space, and the PNG images to
/// write: base color and emissive textures are stored sRGB-encoded, metallic-roughness ones
/// linear, as glTF specifies.
struct Images {
    srgb: Vec<Option<usize>>,
    linear: Vec<Option<usize>>,
}

fn texture_images(scene: &Scene, stem: &str) -> (Images, Vec<(String, image::RgbaImage)>) {
    let count = scene.textures.len();
    let (mut srgb_used, mut linear_used) = (vec![false; count], vec![false; count]);
    for m in &scene.materials {
        for t in [m.base_color_texture, m.emissive_texture]
            .into_iter()
            .flatten()
        {
            srgb_used[t] = true;
        }
        if let Some(t) = m.metallic_roughness_texture {
            linear_used[t] = true;
        }
    }
    let mut images = Images {
        srgb: vec![None; count],
        linear: vec![None; count],
    };
    let mut pngs = Vec::new();
    // Model texture i becomes image i in its color space of use; a texture used in both
    // spaces gets a second, linear image after all the others.
    for (i, texture) in scene.textures.iter().enumerate() {
        let srgb = srgb_used[i] || !linear_used[i];
        pngs.push((format!("{stem}_{i}.png"), encode(texture, srgb)));
        if srgb {
            images.srgb[i] = Some(i);
        } else {
            images.linear[i] = Some(i);
        }
    }
    for (i, texture) in scene.textures.iter().enumerate() {
        if srgb_used[i] && linear_used[i] {
            images.linear[i] = Some(pngs.len());
            pngs.push((format!("{stem}_{i}_linear.png"), encode(texture, false)));
        }
    }
    (images, pngs)
}

/// 8-bit RGBA; alpha is always linear.
fn encode(texture: &Texture, srgb: bool) -> image::RgbaImage {
    let quantize = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    let color = |v: f32| {
        let v = v.clamp(0.0, 1.0);
        if !srgb {
            v
        } else if v <= 0.003_130_8 {
            v * 12.92
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        }
    };
    let data = texture
        .texels
        .iter()
        .flat_map(|t: &Vec4| [color(t.x), color(t.y), color(t.z), t.w].map(quantize))
        .collect();
    image::RgbaImage::from_raw(texture.width, texture.height, data).expect("validated texel count")
}

fn material_json(material: &Material, images: &Images) -> Value {
    let mut pbr = json!({
        "baseColorFactor": vec_json(material.base_color.to_array()),
        "metallicFactor": num(material.metallic),
        "roughnessFactor": num(material.roughness),
    });
    if let Some(t) = material.base_color_texture {
        pbr["baseColorTexture"] = json!({ "index": images.srgb[t] });
    }
    if let Some(t) = material.metallic_roughness_texture {
        pbr["metallicRoughnessTexture"] = json!({ "index": images.linear[t] });
    }
    let mut value = json!({ "name": material.name, "pbrMetallicRoughness": pbr });
    let strength = material.emissive.max_element();
    if strength > 1.0 {
        // glTF caps emissiveFactor at 1: the rest goes into the emissive strength extension.
        value["emissiveFactor"] = vec_json((material.emissive / strength).to_array());
        value["extensions"] = json!({ EMISSIVE_STRENGTH: { "emissiveStrength": num(strength) } });
    } else if strength > 0.0 {
        value["emissiveFactor"] = vec_json(material.emissive.to_array());
    }
    if let Some(t) = material.emissive_texture {
        value["emissiveTexture"] = json!({ "index": images.srgb[t] });
    }
    if material.double_sided {
        value["doubleSided"] = json!(true);
    }
    value
}

/// The `extras.gi` object of the glTF scene.
fn settings_json(scene: &Scene, names: &[String]) -> Value {
    let sky = match scene.sky {
        Sky::Constant { radiance } => json!({ "constant": vec_json(radiance.to_array()) }),
        Sky::Gradient {
            zenith,
            horizon,
            ground,
        } => json!({ "gradient": {
            "zenith": vec_json(zenith.to_array()),
            "horizon": vec_json(horizon.to_array()),
            "ground": vec_json(ground.to_array()),
        } }),
    };
    let mut gi = json!({
        "sky": sky,
        "exposure": num(scene.exposure),
        "frame_time_s": num(scene.frame_time_s),
    });
    if let Some(node) = scene.default_camera_node {
        gi["camera"] = json!(names[node]);
    }
    if let Some(path) = &scene.camera_path {
        let keys: Vec<Value> = path
            .keys
            .iter()
            .map(|k| {
                json!({
                    "time_s": num(k.time_s),
                    "position": vec_json(k.position.to_array()),
                    "target": vec_json(k.target.to_array()),
                })
            })
            .collect();
        gi["camera_path"] = json!({ "yfov": num(path.yfov), "keys": keys });
    }
    gi
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

/// Checks what glTF requires and the model does not guarantee; the message names the part
/// at fault.
fn validate(scene: &Scene) -> Result<(), String> {
    fn ensure(ok: bool, message: impl FnOnce() -> String) -> Result<(), String> {
        if ok { Ok(()) } else { Err(message()) }
    }
    let finite = |values: &[f32]| values.iter().all(|v| v.is_finite());
    let n = scene.nodes.len();
    for (i, mesh) in scene.meshes.iter().enumerate() {
        ensure(!mesh.primitives.is_empty(), || {
            format!("mesh {i} has no primitives")
        })?;
        for p in &mesh.primitives {
            let count = p.positions.len();
            let ok = count > 0
                && !p.indices.is_empty()
                && p.indices.len() % 3 == 0
                && p.indices.iter().all(|&k| (k as usize) < count)
                && p.normals.len() == count
                && (p.uvs.is_empty() || p.uvs.len() == count)
                && p.material < scene.materials.len()
                && p.positions.iter().chain(&p.normals).all(|v| v.is_finite())
                && p.uvs.iter().all(|v| v.is_finite());
            ensure(ok, || {
                format!(
                    "mesh {i} '{}': a primitive has no triangles, an index, normal or uv count \
                     that does not match its positions, a bad material or a non-finite value",
                    mesh.name
                )
            })?;
        }
    }
    for (i, m) in scene.materials.iter().enumerate() {
        let textures = [
            m.base_color_texture,
            m.metallic_roughness_texture,
            m.emissive_texture,
        ];
        let ok = m.base_color.is_finite()
            && m.emissive.is_finite()
            && m.emissive.min_element() >= 0.0
            && finite(&[m.metallic, m.roughness])
            && textures
                .into_iter()
                .flatten()
                .all(|t| t < scene.textures.len());
        ensure(ok, || {
            format!(
                "material {i} '{}': non-finite value, negative emission or bad texture",
                m.name
            )
        })?;
    }
    for (i, t) in scene.textures.iter().enumerate() {
        let ok = t.width > 0 && t.height > 0 && t.texels.len() == (t.width * t.height) as usize;
        ensure(ok, || {
            format!(
                "texture {i} '{}': texel count does not match its size",
                t.name
            )
        })?;
    }
    for (i, node) in scene.nodes.iter().enumerate() {
        // Walking up must reach a root within n steps, otherwise the parents form a cycle.
        let mut ancestor = node.parent;
        for _ in 0..=n {
            ancestor = ancestor.and_then(|p| scene.nodes.get(p).and_then(|p| p.parent));
        }
        let ok = node.translation.is_finite()
            && node.scale.is_finite()
            && node.rotation.is_finite()
            && node.rotation.length() > 1e-6
            && node.parent.is_none_or(|p| p < n)
            && ancestor.is_none()
            && node.mesh.is_none_or(|m| m < scene.meshes.len())
            && node.light.is_none_or(|l| l < scene.lights.len())
            && node.camera.is_none_or(|c| c < scene.cameras.len());
        ensure(ok, || {
            format!(
                "node {i} '{}': bad transform, reference or parent cycle",
                node.name
            )
        })?;
    }
    for light in &scene.lights {
        let ok = light.color.is_finite() && finite(&[light.intensity, light.range.unwrap_or(1.0)]);
        ensure(ok, || format!("light '{}': non-finite value", light.name))?;
    }
    for camera in &scene.cameras {
        let ok =
            camera.yfov > 0.0 && camera.znear > 0.0 && camera.aspect_ratio.is_none_or(|a| a > 0.0);
        ensure(ok, || {
            format!(
                "camera '{}': yfov, znear and aspect ratio must be positive",
                camera.name
            )
        })?;
    }
    for animation in &scene.animations {
        for channel in &animation.channels {
            let (count, ok_values) = match &channel.values {
                ChannelValues::Translation(v) | ChannelValues::Scale(v) => {
                    (v.len(), v.iter().all(|v| v.is_finite()))
                }
                ChannelValues::Rotation(v) => (v.len(), v.iter().all(|q| q.is_finite())),
            };
            let ok = channel.node < n
                && !channel.times.is_empty()
                && count == channel.times.len()
                && ok_values
                && finite(&channel.times)
                && channel.times.windows(2).all(|w| w[0] < w[1]);
            ensure(ok, || {
                format!(
                    "animation '{}': a channel has a bad node, key times that are not increasing, \
                     a value count that differs from the key count or a non-finite value",
                    animation.name
                )
            })?;
        }
    }
    let sky = match scene.sky {
        Sky::Constant { radiance } => radiance.is_finite(),
        Sky::Gradient {
            zenith,
            horizon,
            ground,
        } => zenith.is_finite() && horizon.is_finite() && ground.is_finite(),
    };
    let path = scene.camera_path.as_ref().is_none_or(|path| {
        path.yfov.is_finite()
            && (path.keys.iter())
                .all(|k| k.time_s.is_finite() && k.position.is_finite() && k.target.is_finite())
    });
    let ok = sky
        && path
        && finite(&[scene.exposure, scene.frame_time_s])
        && scene.default_camera_node.is_none_or(|c| c < n);
    ensure(ok, || {
        "scene settings: non-finite value or bad default camera node".into()
    })
}

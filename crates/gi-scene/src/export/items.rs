//! The glTF JSON of each part of a scene: meshes, animations, nodes, lights, textures,
//! materials and the product settings in `extras.gi`.

use glam::{Quat, Vec2, Vec3};
use serde_json::{Value, json};

use crate::Texture;
use crate::model::{
    AlphaMode, ChannelValues, Interpolation, LightKind, Material, MorphTarget, Scene, Sky,
    TextureRef, TextureTransform,
};

use super::{
    ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, EMISSIVE_STRENGTH, IOR, LIGHTS_PUNCTUAL, SPECULAR,
    TEXTURE_TRANSFORM, UNSIGNED_INT, UNSIGNED_SHORT, Writer, num, unit, unit_quat, vec_json,
};

pub(super) fn mesh_json(mesh: &crate::model::Mesh, writer: &mut Writer) -> Value {
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
            if !p.uvs1.is_empty() {
                let uvs: Vec<[f32; 2]> = p.uvs1.iter().map(Vec2::to_array).collect();
                attributes["TEXCOORD_1"] = json!(writer.floats(&uvs, "VEC2", Some(ARRAY_BUFFER)));
            }
            if !p.tangents.is_empty() {
                let tangents: Vec<[f32; 4]> = p
                    .tangents
                    .iter()
                    .map(|t| unit(t.truncate()).extend(if t.w < 0.0 { -1.0 } else { 1.0 }).to_array())
                    .collect();
                attributes["TANGENT"] = json!(writer.floats(&tangents, "VEC4", Some(ARRAY_BUFFER)));
            }
            if !p.joints.is_empty() {
                // Two 16-bit joints per 4-byte word; an element is 8 bytes, keeping alignment.
                let joints = p.joints.iter().flat_map(|j| {
                    let b = j.map(u16::to_le_bytes);
                    [[b[0][0], b[0][1], b[1][0], b[1][1]], [b[2][0], b[2][1], b[3][0], b[3][1]]]
                });
                attributes["JOINTS_0"] = json!(writer.accessor(joints, p.joints.len(), "VEC4", UNSIGNED_SHORT, Some(ARRAY_BUFFER)));
                let weights: Vec<[f32; 4]> = p.weights.iter().map(|w| w.to_array()).collect();
                attributes["WEIGHTS_0"] = json!(writer.floats(&weights, "VEC4", Some(ARRAY_BUFFER)));
            }
            let indices = p.indices.iter().map(|i| i.to_le_bytes());
            let indices = writer.accessor(indices, p.indices.len(), "SCALAR", UNSIGNED_INT, Some(ELEMENT_ARRAY_BUFFER));
            let mut primitive = json!({ "attributes": attributes, "indices": indices, "material": p.material, "mode": 4 });
            if !p.targets.is_empty() {
                let targets: Vec<Value> = p.targets.iter().map(|t| target_json(t, p.positions.len(), writer)).collect();
                primitive["targets"] = json!(targets);
            }
            primitive
        })
        .collect();
    let mut value = json!({ "name": mesh.name, "primitives": primitives });
    if !mesh.weights.is_empty() {
        value["weights"] = floats_json(&mesh.weights);
    }
    value
}

/// One morph target's displacement accessors. glTF wants at least one attribute per target,
/// so a target that moves nothing is written as zero position displacements.
fn target_json(target: &MorphTarget, vertex_count: usize, writer: &mut Writer) -> Value {
    let vec3s = |v: &[Vec3]| -> Vec<[f32; 3]> { v.iter().map(Vec3::to_array).collect() };
    let mut value = json!({});
    if !target.positions.is_empty() || (target.normals.is_empty() && target.tangents.is_empty()) {
        let positions = if target.positions.is_empty() {
            vec![[0.0; 3]; vertex_count]
        } else {
            vec3s(&target.positions)
        };
        // glTF requires bounds on morph target positions as on base positions.
        value["POSITION"] = json!(writer.floats_bounded(&positions, "VEC3", Some(ARRAY_BUFFER)));
    }
    if !target.normals.is_empty() {
        value["NORMAL"] = json!(writer.floats(&vec3s(&target.normals), "VEC3", Some(ARRAY_BUFFER)));
    }
    if !target.tangents.is_empty() {
        value["TANGENT"] =
            json!(writer.floats(&vec3s(&target.tangents), "VEC3", Some(ARRAY_BUFFER)));
    }
    value
}

/// A JSON array of floats, each written as its shortest exact decimal.
fn floats_json(values: &[f32]) -> Value {
    Value::Array(values.iter().map(|&w| num(w)).collect())
}

pub(super) fn animation_json(animation: &crate::model::Animation, writer: &mut Writer) -> Value {
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
            ChannelValues::Weights(keys) => {
                let data: Vec<[f32; 1]> = keys.iter().flatten().map(|w| [*w]).collect();
                ("weights", writer.floats(&data, "SCALAR", None))
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

pub(super) fn skin_json(skin: &crate::model::Skin, writer: &mut Writer) -> Value {
    let matrices: Vec<[f32; 16]> = skin
        .inverse_bind_matrices
        .iter()
        .map(|m| m.to_cols_array())
        .collect();
    json!({
        "name": skin.name,
        "joints": skin.joints,
        "inverseBindMatrices": writer.floats(&matrices, "MAT4", None),
    })
}

pub(super) fn node_json(scene: &Scene, index: usize, name: &str) -> Value {
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
    if let Some(skin) = node.skin {
        value["skin"] = json!(skin);
    }
    if let Some(weights) = &node.weights {
        value["weights"] = floats_json(weights);
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
pub(super) fn unique_names(scene: &Scene) -> Vec<String> {
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

pub(super) fn light_json(light: &crate::model::Light) -> Value {
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

/// The PNG image of every model texture (model texture `i` is glTF image and texture `i`),
/// its stored 8-bit values as they are: glTF reads color textures as sRGB and the others as
/// linear, which is the encoding each texture was given for its use.
pub(super) fn texture_images(scene: &Scene, stem: &str) -> Vec<(String, image::RgbaImage)> {
    scene
        .textures
        .iter()
        .enumerate()
        .map(|(i, texture)| (format!("{stem}_{i}.png"), encode(texture)))
        .collect()
}

/// 8-bit RGBA as stored.
pub(super) fn encode(texture: &Texture) -> image::RgbaImage {
    let data = texture.texels.iter().flatten().copied().collect();
    image::RgbaImage::from_raw(texture.width, texture.height, data).expect("validated texel count")
}

/// A `textureInfo`: index, texture coordinate set and `KHR_texture_transform`.
fn texture_json(texture: &TextureRef) -> Value {
    let mut value = json!({ "index": texture.texture });
    if texture.tex_coord != 0 {
        value["texCoord"] = json!(texture.tex_coord);
    }
    let t = texture.transform;
    if t != TextureTransform::IDENTITY {
        value["extensions"] = json!({ TEXTURE_TRANSFORM: {
            "offset": vec_json(t.offset.to_array()),
            "rotation": num(t.rotation),
            "scale": vec_json(t.scale.to_array()),
        } });
    }
    value
}

/// Whether `material` has a texture with `KHR_texture_transform`.
pub(super) fn has_texture_transform(material: &Material) -> bool {
    material
        .texture_refs()
        .any(|t| t.transform != TextureTransform::IDENTITY)
}

/// Whether `material` needs `KHR_materials_specular` (anything but the glTF defaults).
pub(super) fn has_specular_layer(material: &Material) -> bool {
    material.specular != 1.0
        || material.specular_color != Vec3::ONE
        || material.specular_texture.is_some()
        || material.specular_color_texture.is_some()
}

pub(super) fn material_json(material: &Material) -> Value {
    let mut pbr = json!({
        "baseColorFactor": vec_json(material.base_color.to_array()),
        "metallicFactor": num(material.metallic),
        "roughnessFactor": num(material.roughness),
    });
    if let Some(t) = &material.base_color_texture {
        pbr["baseColorTexture"] = texture_json(t);
    }
    if let Some(t) = &material.metallic_roughness_texture {
        pbr["metallicRoughnessTexture"] = texture_json(t);
    }
    let mut value = json!({ "name": material.name, "pbrMetallicRoughness": pbr });
    let strength = material.emissive.max_element();
    if strength > 1.0 {
        // glTF caps emissiveFactor at 1: the rest goes into the emissive strength extension.
        value["emissiveFactor"] = vec_json((material.emissive / strength).to_array());
        value["extensions"][EMISSIVE_STRENGTH] = json!({ "emissiveStrength": num(strength) });
    } else if strength > 0.0 {
        value["emissiveFactor"] = vec_json(material.emissive.to_array());
    }
    if let Some(t) = &material.emissive_texture {
        value["emissiveTexture"] = texture_json(t);
    }
    if let Some(t) = &material.normal_texture {
        value["normalTexture"] = texture_json(t);
        value["normalTexture"]["scale"] = num(material.normal_scale);
    }
    if let Some(t) = &material.occlusion_texture {
        value["occlusionTexture"] = texture_json(t);
        value["occlusionTexture"]["strength"] = num(material.occlusion_strength);
    }
    match material.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask { cutoff } => {
            value["alphaMode"] = json!("MASK");
            value["alphaCutoff"] = num(cutoff);
        }
        AlphaMode::Blend => value["alphaMode"] = json!("BLEND"),
    }
    if material.double_sided {
        value["doubleSided"] = json!(true);
    }
    if has_specular_layer(material) {
        let mut specular = json!({
            "specularFactor": num(material.specular),
            "specularColorFactor": vec_json(material.specular_color.to_array()),
        });
        if let Some(t) = &material.specular_texture {
            specular["specularTexture"] = texture_json(t);
        }
        if let Some(t) = &material.specular_color_texture {
            specular["specularColorTexture"] = texture_json(t);
        }
        value["extensions"][SPECULAR] = specular;
    }
    if material.ior != 1.5 {
        value["extensions"][IOR] = json!({ "ior": num(material.ior) });
    }
    value
}

/// The `extras.gi` object of the glTF scene.
pub(super) fn settings_json(scene: &Scene, names: &[String]) -> Value {
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

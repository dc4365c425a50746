//! What glTF requires and the scene model does not guarantee.

use crate::model::{ChannelValues, Scene, Sky};

/// Checks what glTF requires and the model does not guarantee; the message names the part
/// at fault.
pub(super) fn validate(scene: &Scene) -> Result<(), String> {
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
                && p.joints.len() == p.weights.len()
                && (p.joints.is_empty() || p.joints.len() == count)
                && p.weights
                    .iter()
                    .all(|w| w.is_finite() && w.min_element() >= 0.0)
                && p.material < scene.materials.len()
                && p.positions.iter().chain(&p.normals).all(|v| v.is_finite())
                && p.uvs.iter().all(|v| v.is_finite());
            ensure(ok, || {
                format!(
                    "mesh {i} '{}': a primitive has no triangles, an index, normal, uv, joint or \
                     weight count that does not match its positions, a bad material, a negative \
                     weight or a non-finite value",
                    mesh.name
                )
            })?;
        }
        let targets = mesh.morph_target_count();
        let ok = targets <= crate::model::Mesh::MAX_MORPH_TARGETS
            && (mesh.weights.is_empty() || mesh.weights.len() == targets)
            && finite(&mesh.weights)
            && mesh.primitives.iter().all(|p| {
                let count = p.positions.len();
                p.targets.len() == targets
                    && p.targets.iter().all(|t| {
                        let fits = |v: &[glam::Vec3]| {
                            (v.is_empty() || v.len() == count) && v.iter().all(|d| d.is_finite())
                        };
                        fits(&t.positions)
                            && fits(&t.normals)
                            && fits(&t.tangents)
                            && (t.tangents.is_empty() || !p.tangents.is_empty())
                    })
            });
        ensure(ok, || {
            format!(
                "mesh {i} '{}': too many morph targets, primitives with different numbers of \
                 them, a displacement count that does not match the positions (or tangents \
                 displaced on a primitive without them), weights that are not one per target \
                 or a non-finite value",
                mesh.name
            )
        })?;
    }
    let morph_targets = |node: usize| {
        (scene.nodes.get(node))
            .and_then(|n| scene.meshes.get(n.mesh?))
            .map_or(0, |m| m.morph_target_count())
    };
    for (i, node) in scene.nodes.iter().enumerate() {
        let ok = node
            .weights
            .as_ref()
            .is_none_or(|w| w.len() == morph_targets(i) && finite(w));
        ensure(ok, || {
            format!(
                "node {i} '{}': weights that are not one per morph target of its mesh, or \
                 not finite",
                node.name
            )
        })?;
    }
    for (i, m) in scene.materials.iter().enumerate() {
        let ok = m.base_color.is_finite()
            && m.emissive.is_finite()
            && m.emissive.min_element() >= 0.0
            && finite(&[
                m.metallic,
                m.roughness,
                m.normal_scale,
                m.occlusion_strength,
            ])
            && m.texture_refs().all(|t| {
                t.texture < scene.textures.len()
                    && t.tex_coord <= 1
                    && t.transform.offset.is_finite()
                    && t.transform.rotation.is_finite()
                    && t.transform.scale.is_finite()
            });
        ensure(ok, || {
            format!(
                "material {i} '{}': non-finite value, negative emission or bad texture",
                m.name
            )
        })?;
    }
    for (i, t) in scene.textures.iter().enumerate() {
        let ok = t.is_valid();
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
            && node.camera.is_none_or(|c| c < scene.cameras.len())
            && node.skin.is_none_or(|s| s < scene.skins.len());
        ensure(ok, || {
            format!(
                "node {i} '{}': bad transform, reference or parent cycle",
                node.name
            )
        })?;
    }
    for (i, skin) in scene.skins.iter().enumerate() {
        let ok = !skin.joints.is_empty()
            && skin.joints.len() <= crate::model::Skin::MAX_JOINTS
            && skin.joints.iter().all(|&j| j < n)
            && skin.inverse_bind_matrices.len() == skin.joints.len()
            && skin.inverse_bind_matrices.iter().all(|m| m.is_finite());
        ensure(ok, || {
            format!(
                "skin {i} '{}': no joints, too many, a joint that is not a node, or inverse \
                 bind matrices that do not match the joints or are not finite",
                skin.name
            )
        })?;
    }
    for (i, node) in scene.nodes.iter().enumerate() {
        let (Some(skin), Some(mesh)) = (
            node.skin.and_then(|s| scene.skins.get(s)),
            node.mesh.and_then(|m| scene.meshes.get(m)),
        ) else {
            continue;
        };
        let in_range = |(joints, weights): (&[u16; 4], &glam::Vec4)| {
            (joints.iter().zip(weights.to_array()))
                .all(|(&j, w)| w == 0.0 || (j as usize) < skin.joints.len())
        };
        let ok = (mesh.primitives.iter()).all(|p| p.joints.iter().zip(&p.weights).all(in_range));
        ensure(ok, || {
            format!(
                "node {i} '{}': its mesh names a joint its skin '{}' does not have",
                node.name, skin.name
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
                ChannelValues::Weights(keys) => {
                    let targets = morph_targets(channel.node);
                    let ok = targets > 0 && keys.iter().all(|k| k.len() == targets && finite(k));
                    (keys.len(), ok)
                }
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

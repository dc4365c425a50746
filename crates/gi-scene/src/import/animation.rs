//! Keyframe animations of node translation, rotation, scale and morph target weights.

use glam::{Quat, Vec4};
use gltf::json;
use gltf::json::animation::{Interpolation as FileInterpolation, Property};
use gltf::json::validation::Checked;

use super::{Result, Source, Warnings, malformed};
use crate::{Animation, Channel, ChannelValues, Interpolation, Scene};

/// Imports every animation, keeping the channels that target nodes of the imported scene
/// (`node_map` maps file node indices to model indices; `scene` holds those nodes and their
/// meshes). Animations left without channels are dropped.
pub(super) fn import_animations(
    source: &Source,
    node_map: &[Option<usize>],
    scene: &Scene,
    warnings: &mut Warnings,
) -> Result<Vec<Animation>> {
    let mut animations = Vec::new();
    for (a, animation) in source.root.animations.iter().enumerate() {
        let mut channels = Vec::new();
        for (c, channel) in animation.channels.iter().enumerate() {
            let label = format!("animations[{a}].channels[{c}]");
            // Nodes outside the scene are not imported, so neither is their motion.
            let Some(node) = node_map.get(channel.target.node.value()).copied().flatten() else {
                continue;
            };
            // Weights channels need the number of targets of the node's mesh.
            let targets = scene
                .nodes
                .get(node)
                .and_then(|n| scene.meshes.get(n.mesh?))
                .map_or(0, |m| m.morph_target_count());
            if let Some(imported) =
                import_channel(source, animation, channel, node, targets, &label, warnings)?
            {
                channels.push(imported);
            }
        }
        if !channels.is_empty() {
            animations.push(Animation {
                name: animation
                    .name
                    .clone()
                    .unwrap_or_else(|| format!("animation {a}")),
                channels,
            });
        }
    }
    Ok(animations)
}

/// One channel of model node `node` whose mesh has `targets` morph targets, or `None` for a
/// weights channel of a node without morph targets (warned and ignored). A weights channel's
/// output must hold one weight per target per key (three per target and key for cubic
/// splines).
fn import_channel(
    source: &Source,
    animation: &json::Animation,
    channel: &json::animation::Channel,
    node: usize,
    targets: usize,
    label: &str,
    warnings: &mut Warnings,
) -> Result<Option<Channel>> {
    let property = match channel.target.path {
        Checked::Valid(Property::MorphTargetWeights) if targets == 0 => {
            warnings.once("weights-without-targets", || {
                format!("{label} animates the weights of a node whose mesh has no morph targets; ignored")
            });
            return Ok(None);
        }
        Checked::Valid(property) => property,
        Checked::Invalid => return Err(malformed(format!("{label} has an invalid target path"))),
    };
    let sampler = animation
        .samplers
        .get(channel.sampler.value())
        .ok_or_else(|| malformed(format!("{label}: sampler does not exist")))?;
    let (interpolation, cubic) = match sampler.interpolation {
        Checked::Valid(FileInterpolation::Linear) => (Interpolation::Linear, false),
        Checked::Valid(FileInterpolation::Step) => (Interpolation::Step, false),
        Checked::Valid(FileInterpolation::CubicSpline) => {
            warnings.once("cubic-spline", || {
                format!("{label}: CUBICSPLINE interpolation is approximated as LINEAR between its keyframes")
            });
            (Interpolation::Linear, true)
        }
        Checked::Invalid => return Err(malformed(format!("{label} has an invalid interpolation"))),
    };

    let times = source
        .buffers
        .scalars(sampler.input.value(), &format!("{label} input"))?;
    if times.is_empty() {
        return Err(malformed(format!("{label} has no keyframes")));
    }
    if times.windows(2).any(|w| w[1] < w[0]) {
        return Err(malformed(format!("{label}: keyframe times decrease")));
    }
    let output = sampler.output.value();
    let output_label = format!("{label} output");
    let values = match property {
        Property::Translation => ChannelValues::Translation(keyframe_values(
            source.buffers.vec3s(output, &output_label)?,
            times.len(),
            cubic,
            label,
        )?),
        Property::Scale => ChannelValues::Scale(keyframe_values(
            source.buffers.vec3s(output, &output_label)?,
            times.len(),
            cubic,
            label,
        )?),
        Property::Rotation => {
            let quats: Vec<Vec4> = keyframe_values(
                source.buffers.vec4s(output, &output_label)?,
                times.len(),
                cubic,
                label,
            )?;
            let rotations = quats
                .into_iter()
                .map(|q| (q.length_squared() > 1e-12).then(|| Quat::from_vec4(q).normalize()))
                .collect::<Option<Vec<Quat>>>()
                .ok_or_else(|| {
                    malformed(format!("{label}: a rotation keyframe is a zero quaternion"))
                })?;
            ChannelValues::Rotation(rotations)
        }
        Property::MorphTargetWeights => ChannelValues::Weights(keyframe_weights(
            source.buffers.scalars(output, &output_label)?,
            times.len(),
            targets,
            cubic,
            label,
        )?),
    };
    Ok(Some(Channel {
        node,
        times,
        values,
        interpolation,
    }))
}

/// The keyframe weights of a weights sampler's output for a mesh with `targets` (at least one)
/// morph targets: `targets` per key, or for cubic splines the middle `targets` of each
/// (in-tangents, values, out-tangents) triple of runs.
fn keyframe_weights(
    output: Vec<f32>,
    keys: usize,
    targets: usize,
    cubic: bool,
    label: &str,
) -> Result<Vec<Vec<f32>>> {
    let per_key = if cubic { 3 * targets } else { targets };
    if output.len() != keys * per_key {
        return Err(malformed(format!(
            "{label}: {} output weights for {keys} keyframes of {targets} morph targets (expected {})",
            output.len(),
            keys * per_key
        )));
    }
    Ok(output
        .chunks_exact(per_key)
        .map(|key| {
            let values = if cubic {
                &key[targets..2 * targets]
            } else {
                key
            };
            values.to_vec()
        })
        .collect())
}

/// The keyframe values of a sampler output: one per key, or for cubic splines the middle of
/// each (in-tangent, value, out-tangent) triple.
fn keyframe_values<T: Copy>(
    output: Vec<T>,
    keys: usize,
    cubic: bool,
    label: &str,
) -> Result<Vec<T>> {
    let expected = if cubic { keys * 3 } else { keys };
    if output.len() != expected {
        return Err(malformed(format!(
            "{label}: {} output values for {keys} keyframes (expected {expected})",
            output.len()
        )));
    }
    Ok(if cubic {
        output.chunks_exact(3).map(|triple| triple[1]).collect()
    } else {
        output
    })
}

//! Skins: joint lists and inverse bind matrices, and the check that a skinned node's mesh only
//! names joints its skin has.

use glam::Mat4;

use super::{Result, Source, Warnings, malformed, unusable};
use crate::{Mesh, Skin};

/// Imports file skin `index`, its joints mapped to model nodes through `node_map` (file index
/// to model index). Errors: a joint that is not a node of the imported scene, more than
/// [`Skin::MAX_JOINTS`] joints, no joints, or fewer inverse bind matrices than joints. Without
/// an inverse bind matrix accessor every matrix is the identity.
pub(super) fn import_skin(
    source: &Source,
    index: usize,
    node_map: &[Option<usize>],
) -> Result<Skin> {
    let label = format!("skins[{index}]");
    let json = source
        .root
        .skins
        .get(index)
        .ok_or_else(|| malformed(format!("{label} does not exist")))?;
    if json.joints.is_empty() {
        return Err(malformed(format!("{label} has no joints")));
    }
    if json.joints.len() > Skin::MAX_JOINTS {
        return Err(unusable(format!(
            "{label} has {} joints, more than the {} that 16-bit JOINTS_0 can index",
            json.joints.len(),
            Skin::MAX_JOINTS
        )));
    }
    let joints = json
        .joints
        .iter()
        .enumerate()
        .map(|(k, joint)| {
            node_map
                .get(joint.value())
                .copied()
                .flatten()
                .ok_or_else(|| {
                    malformed(format!(
                        "{label}.joints[{k}]: node {} is not a node of the imported scene",
                        joint.value()
                    ))
                })
        })
        .collect::<Result<Vec<usize>>>()?;
    let inverse_bind_matrices = match json.inverse_bind_matrices {
        Some(accessor) => {
            let what = format!("{label}.inverseBindMatrices");
            let matrices = source.buffers.mat4s(accessor.value(), &what)?;
            if matrices.len() < joints.len() {
                return Err(malformed(format!(
                    "{what} has {} matrices for {} joints",
                    matrices.len(),
                    joints.len()
                )));
            }
            matrices[..joints.len()].to_vec()
        }
        None => vec![Mat4::IDENTITY; joints.len()],
    };
    Ok(Skin {
        name: json.name.clone().unwrap_or_else(|| format!("skin {index}")),
        joints,
        inverse_bind_matrices,
    })
}

/// Checks that every weighted joint of `mesh` indexes `skin`'s joint list (a zero weight's
/// joint index is not read, so it may be anything); warns when the mesh has nothing to skin.
pub(super) fn check_skinned_mesh(
    mesh: &Mesh,
    skin: &Skin,
    node_label: &str,
    warnings: &mut Warnings,
) -> Result<()> {
    if !mesh.primitives.iter().any(|p| p.is_skinned()) {
        warnings.once("skin-without-joints", || {
            format!(
                "{node_label} has a skin but its mesh '{}' has no JOINTS_0/WEIGHTS_0; it is drawn unskinned",
                mesh.name
            )
        });
        return Ok(());
    }
    for (p, primitive) in mesh.primitives.iter().enumerate() {
        for (vertex, (joints, weights)) in
            primitive.joints.iter().zip(&primitive.weights).enumerate()
        {
            for (joint, weight) in joints.iter().zip(weights.to_array()) {
                if weight > 0.0 && *joint as usize >= skin.joints.len() {
                    return Err(malformed(format!(
                        "{node_label}: mesh '{}' primitive {p} vertex {vertex} names joint {joint}, but its skin '{}' has {} joints",
                        mesh.name,
                        skin.name,
                        skin.joints.len()
                    )));
                }
            }
        }
    }
    Ok(())
}

//! Morph targets: the per-primitive displacements of `POSITION`, `NORMAL` and `TANGENT`, and
//! the checks that tie them to the mesh's and nodes' `weights`.

use std::collections::BTreeMap;

use glam::Vec3;
use gltf::json;
use serde::Deserialize;
use serde::de::IgnoredAny;

use super::{Result, Source, Warnings, malformed, unusable};
use crate::{Mesh, MorphTarget};

/// The morph targets of one primitive with `vertex_count` vertices. Errors: more than
/// [`Mesh::MAX_MORPH_TARGETS`] targets, a displacement accessor whose count is not the vertex
/// count, and non-finite displacements. `TANGENT` displacements of a primitive without a
/// `TANGENT` attribute (`has_tangents` false) have nothing to displace and are dropped with a
/// warning. A displacement list of zeros is stored empty, so files that declare every
/// attribute for every target cost nothing for the ones they leave still.
pub(super) fn import_targets(
    source: &Source,
    primitive: &json::mesh::Primitive,
    vertex_count: usize,
    has_tangents: bool,
    label: &str,
    warnings: &mut Warnings,
) -> Result<Vec<MorphTarget>> {
    let Some(targets) = primitive.targets.as_ref() else {
        return Ok(Vec::new());
    };
    check_target_count(targets.len(), label)?;
    let read = |accessor: Option<json::Index<json::Accessor>>, what: String| -> Result<_> {
        let Some(accessor) = accessor else {
            return Ok(Vec::new());
        };
        let deltas = source.buffers.vec3s(accessor.value(), &what)?;
        if deltas.len() != vertex_count {
            return Err(malformed(format!(
                "{what} has {} entries for {vertex_count} positions",
                deltas.len()
            )));
        }
        Ok(if deltas.iter().all(|d| *d == Vec3::ZERO) {
            Vec::new()
        } else {
            deltas
        })
    };
    let mut imported = Vec::with_capacity(targets.len());
    for (t, target) in targets.iter().enumerate() {
        let at = format!("{label}.targets[{t}]");
        if target.tangents.is_some() && !has_tangents {
            warnings.once("morph-tangents-without-tangents", || {
                format!("{at}.TANGENT: the primitive has no TANGENT attribute to displace; ignored")
            });
        }
        imported.push(MorphTarget {
            positions: read(target.positions, format!("{at}.POSITION"))?,
            normals: read(target.normals, format!("{at}.NORMAL"))?,
            tangents: if has_tangents {
                read(target.tangents, format!("{at}.TANGENT"))?
            } else {
                Vec::new()
            },
        });
    }
    Ok(imported)
}

/// Checks that all primitives of file mesh `mesh` have the same number of targets, at most
/// [`Mesh::MAX_MORPH_TARGETS`], and that the mesh's `weights`, if any, are finite and one per
/// target. Returns the weights (empty without).
pub(super) fn mesh_weights(mesh: &json::Mesh, label: &str) -> Result<Vec<f32>> {
    let count = |p: &json::mesh::Primitive| p.targets.as_ref().map_or(0, Vec::len);
    let targets = target_count(mesh);
    check_target_count(targets, label)?;
    if let Some(p) = mesh.primitives.iter().position(|p| count(p) != targets) {
        return Err(malformed(format!(
            "{label}.primitives[{p}] has {} morph targets, primitive 0 has {targets}; all primitives of a mesh must have the same number",
            count(&mesh.primitives[p])
        )));
    }
    let Some(weights) = &mesh.weights else {
        return Ok(Vec::new());
    };
    check_weights(weights, targets, &format!("{label}.weights"))?;
    Ok(weights.clone())
}

/// The number of morph targets of file mesh `mesh`: its first primitive's (all must have the
/// same; see [`mesh_weights`]).
pub(super) fn target_count(mesh: &json::Mesh) -> usize {
    (mesh.primitives.first())
        .and_then(|p| p.targets.as_ref())
        .map_or(0, Vec::len)
}

/// Checks that `weights` (a node's or a mesh's) are finite and one per each of `targets`
/// morph targets.
pub(super) fn check_weights(weights: &[f32], targets: usize, what: &str) -> Result<()> {
    if weights.len() != targets {
        return Err(malformed(format!(
            "{what} has {} entries for {targets} morph targets",
            weights.len()
        )));
    }
    if weights.iter().any(|w| !w.is_finite()) {
        return Err(malformed(format!("{what} has non-finite values")));
    }
    Ok(())
}

fn check_target_count(targets: usize, label: &str) -> Result<()> {
    if targets > Mesh::MAX_MORPH_TARGETS {
        return Err(unusable(format!(
            "{label} has {targets} morph targets, more than the {} supported",
            Mesh::MAX_MORPH_TARGETS
        )));
    }
    Ok(())
}

/// The parts of the document needed to see every attribute name a morph target uses: the
/// parsed glTF keeps only `POSITION`, `NORMAL` and `TANGENT`.
#[derive(Deserialize)]
struct TargetNames {
    #[serde(default)]
    meshes: Vec<MeshTargetNames>,
}

#[derive(Deserialize)]
struct MeshTargetNames {
    #[serde(default)]
    primitives: Vec<PrimitiveTargetNames>,
}

#[derive(Deserialize)]
struct PrimitiveTargetNames {
    #[serde(default)]
    targets: Vec<BTreeMap<String, IgnoredAny>>,
}

/// Warns (once per file) about morph target attributes other than `POSITION`, `NORMAL` and
/// `TANGENT` (`TEXCOORD_n`, `COLOR_n`...), which are ignored. `bytes` is the whole file, glTF
/// JSON or GLB; it is read again only when `root` has morph targets.
pub(super) fn warn_unsupported_attributes(
    bytes: &[u8],
    root: &json::Root,
    warnings: &mut Warnings,
) {
    let has_targets = (root.meshes.iter().flat_map(|m| &m.primitives))
        .any(|p| p.targets.as_ref().is_some_and(|t| !t.is_empty()));
    if !has_targets {
        return;
    }
    let json = if bytes.starts_with(b"glTF") {
        match gltf::binary::Glb::from_slice(bytes) {
            Ok(glb) => glb.json.into_owned(),
            Err(_) => return,
        }
    } else {
        bytes.to_vec()
    };
    // The document parsed once already; a second parse that fails has nothing to report.
    let Ok(names) = serde_json::from_slice::<TargetNames>(&json) else {
        return;
    };
    for (m, mesh) in names.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            for (t, target) in primitive.targets.iter().enumerate() {
                let other = (target.keys())
                    .find(|name| !matches!(name.as_str(), "POSITION" | "NORMAL" | "TANGENT"));
                if let Some(name) = other {
                    warnings.once("morph-other-attributes", || {
                        format!(
                            "meshes[{m}].primitives[{p}].targets[{t}].{name}: morph targets of attributes other than POSITION, NORMAL and TANGENT are not supported; ignored"
                        )
                    });
                }
            }
        }
    }
}

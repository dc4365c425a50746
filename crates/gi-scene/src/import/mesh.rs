//! Mesh primitives: triangle lists, strips and fans become indexed triangle lists with one
//! unit normal per vertex, up to two texture coordinate sets, and tangents where the material
//! has a normal texture (the file's, else MikkTSpace's), and morph targets.

use glam::{Vec3, Vec4};
use gltf::json;
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;

use super::material::Materials;
use super::{Result, Source, Warnings, malformed, morph, tangents, unusable};
use crate::{Mesh, Primitive, Scene};

/// Imports file mesh `index` (its materials go through `materials`). Point and line
/// primitives are skipped with a warning. Morph targets and weights are checked as
/// [`morph::mesh_weights`] describes.
pub(super) fn import_mesh(
    source: &Source,
    index: usize,
    materials: &mut Materials,
    scene: &mut Scene,
    warnings: &mut Warnings,
) -> Result<Mesh> {
    let json = &source.root.meshes[index];
    let mut mesh = Mesh {
        name: json.name.clone().unwrap_or_else(|| format!("mesh {index}")),
        primitives: Vec::new(),
        weights: morph::mesh_weights(json, &format!("meshes[{index}]"))?,
    };
    for (p, primitive) in json.primitives.iter().enumerate() {
        let label = format!("meshes[{index}].primitives[{p}]");
        let Some(mut imported) = import_primitive(source, primitive, &label, warnings)? else {
            continue;
        };
        let material = primitive.material.map(|m| m.value());
        imported.material = materials.resolve(source, material, scene, warnings)?;
        let m = &scene.materials[imported.material];
        let missing_set = m.texture_refs().find_map(|r| {
            let set = if r.tex_coord == 1 {
                &imported.uvs1
            } else {
                &imported.uvs
            };
            set.is_empty().then_some(r.tex_coord)
        });
        if let Some(set) = missing_set {
            warnings.once("missing-uvs", || {
                format!(
                    "{label}: textured material but no TEXCOORD_{set}; textures sample one texel"
                )
            });
        }
        match m.normal_texture {
            Some(normal_texture) if imported.tangents.is_empty() => {
                let set = if normal_texture.tex_coord == 1 {
                    &imported.uvs1
                } else {
                    &imported.uvs
                };
                if set.is_empty() {
                    warnings.once("normal-map-no-uvs", || {
                        format!(
                            "{label}: the material has a normal texture but the primitive has no TEXCOORD_{}; no tangents, so the normal map is not applied",
                            normal_texture.tex_coord
                        )
                    });
                } else {
                    let transformed: Vec<_> =
                        set.iter().map(|&uv| normal_texture.uv(uv, uv)).collect();
                    // A transform that overflows would leave MikkTSpace nothing to work with.
                    let uvs = if transformed.iter().all(|uv| uv.is_finite()) {
                        transformed
                    } else {
                        set.clone()
                    };
                    tangents::generate(&mut imported, &uvs)
                        .map_err(|e| unusable(format!("{label}: {e}")))?;
                }
            }
            _ => {}
        }
        mesh.primitives.push(imported);
    }
    Ok(mesh)
}

/// One primitive as an indexed triangle list, or `None` when it has no triangles.
fn import_primitive(
    source: &Source,
    primitive: &json::mesh::Primitive,
    label: &str,
    warnings: &mut Warnings,
) -> Result<Option<Primitive>> {
    let mode = match primitive.mode {
        Checked::Valid(mode) => mode,
        Checked::Invalid => return Err(malformed(format!("{label} has an invalid mode"))),
    };
    if matches!(
        mode,
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
    ) {
        warnings.once("points-lines", || {
            format!("{label}: point and line primitives are not supported; skipped")
        });
        return Ok(None);
    }
    let attribute = |semantic: Semantic| {
        primitive
            .attributes
            .get(&Checked::Valid(semantic))
            .map(|a| a.value())
    };
    let buffers = &source.buffers;
    let position_label = format!("{label}.attributes.POSITION");
    let position_accessor = attribute(Semantic::Positions)
        .ok_or_else(|| malformed(format!("{position_label} is missing")))?;
    let mut positions = buffers.vec3s(position_accessor, &position_label)?;
    let vertex_count = positions.len();
    if vertex_count == 0 {
        return Ok(None);
    }
    let per_vertex = |what: &str, count: usize| {
        if count == vertex_count {
            Ok(())
        } else {
            Err(malformed(format!(
                "{label}.attributes.{what} has {count} entries for {vertex_count} positions"
            )))
        }
    };
    let normals = match attribute(Semantic::Normals) {
        Some(a) => Some(buffers.vec3s(a, &format!("{label}.attributes.NORMAL"))?),
        None => None,
    };
    if let Some(n) = &normals {
        per_vertex("NORMAL", n.len())?;
    }
    let mut uv_sets = [Vec::new(), Vec::new()];
    for (set, uvs) in uv_sets.iter_mut().enumerate() {
        if let Some(a) = attribute(Semantic::TexCoords(set as u32)) {
            let what = format!("TEXCOORD_{set}");
            *uvs = buffers.vec2s(a, &format!("{label}.attributes.{what}"))?;
            per_vertex(&what, uvs.len())?;
        }
    }
    let [mut uvs, mut uvs1] = uv_sets;
    let mut tangents = match attribute(Semantic::Tangents) {
        Some(a) => {
            let tangents = buffers.tangents(a, &format!("{label}.attributes.TANGENT"))?;
            per_vertex("TANGENT", tangents.len())?;
            tangents
        }
        None => Vec::new(),
    };
    let (mut joints, mut weights) = skin_attributes(source, &attribute, label, warnings)?;
    if !joints.is_empty() {
        per_vertex("JOINTS_0", joints.len())?;
        per_vertex("WEIGHTS_0", weights.len())?;
        if weights.iter().any(|w| w.max_element() <= 0.0) {
            warnings.once("zero-weights", || {
                format!(
                    "{label}.attributes.WEIGHTS_0 has vertices whose weights are all zero; they are placed by the node's own transform, as if unskinned"
                )
            });
        }
    }
    if attribute(Semantic::Colors(0)).is_some() {
        warnings.once("vertex-colors", || {
            format!("{label}: vertex colors (COLOR_0) are not supported; ignored")
        });
    }
    let mut targets = morph::import_targets(
        source,
        primitive,
        vertex_count,
        !tangents.is_empty(),
        label,
        warnings,
    )?;
    if !targets.is_empty() && normals.is_none() {
        warnings.once("morph-computed-normals", || {
            format!(
                "{label} has morph targets but no NORMAL; the normals computed for the base shape are used for every shape"
            )
        });
    }

    let vertices = match primitive.indices {
        Some(accessor) => {
            let indices_label = format!("{label}.indices");
            let indices = buffers.indices(accessor.value(), &indices_label)?;
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(malformed(format!(
                    "{indices_label}: index {bad} is out of range ({vertex_count} vertices)"
                )));
            }
            indices
        }
        None => {
            let count = u32::try_from(vertex_count)
                .map_err(|_| unusable(format!("{label} has too many vertices")))?;
            (0..count).collect()
        }
    };
    let mut indices = triangle_list(mode, &vertices)
        .ok_or_else(|| malformed(format!("{label}: index count is not a multiple of 3")))?;
    if indices.is_empty() {
        return Ok(None);
    }

    // Without an index buffer the file has no notion of shared vertices, so missing normals are
    // flat: give every triangle its own corners first.
    if normals.is_none() && primitive.indices.is_none() {
        positions = indices.iter().map(|&i| positions[i as usize]).collect();
        for attribute in [&mut uvs, &mut uvs1] {
            if !attribute.is_empty() {
                *attribute = indices.iter().map(|&i| attribute[i as usize]).collect();
            }
        }
        if !tangents.is_empty() {
            tangents = indices.iter().map(|&i| tangents[i as usize]).collect();
        }
        if !joints.is_empty() {
            joints = indices.iter().map(|&i| joints[i as usize]).collect();
            weights = indices.iter().map(|&i| weights[i as usize]).collect();
        }
        for target in &mut targets {
            for deltas in [
                &mut target.positions,
                &mut target.normals,
                &mut target.tangents,
            ] {
                if !deltas.is_empty() {
                    *deltas = indices.iter().map(|&i| deltas[i as usize]).collect();
                }
            }
        }
        let corners = u32::try_from(indices.len())
            .map_err(|_| unusable(format!("{label} has too many vertices")))?;
        indices = (0..corners).collect();
    }
    let geometric = vertex_normals(&positions, &indices);
    let normals = match normals {
        Some(file) => file
            .iter()
            .zip(&geometric)
            .map(|(n, g)| n.try_normalize().unwrap_or(*g))
            .collect(),
        None => geometric,
    };
    if tangents::repair(&mut tangents, &normals) > 0 {
        warnings.once("bad-tangents", || {
            format!("{label}.attributes.TANGENT has zero or non-finite tangents; they are replaced by a direction orthogonal to the normal")
        });
    }
    Ok(Some(Primitive {
        positions,
        normals,
        uvs,
        uvs1,
        tangents,
        joints,
        weights,
        targets,
        indices,
        material: 0,
    }))
}

/// `JOINTS_0` and `WEIGHTS_0`, both or neither (one without the other is an error). Further
/// sets (`JOINTS_1`, `WEIGHTS_1`: more than four influences per vertex) are ignored with a
/// warning.
fn skin_attributes(
    source: &Source,
    attribute: &impl Fn(Semantic) -> Option<usize>,
    label: &str,
    warnings: &mut Warnings,
) -> Result<(Vec<[u16; 4]>, Vec<Vec4>)> {
    if attribute(Semantic::Joints(1)).is_some() || attribute(Semantic::Weights(1)).is_some() {
        warnings.once("extra-joint-sets", || {
            format!(
                "{label}: JOINTS_1/WEIGHTS_1 (more than four joints per vertex) are not supported; only the first four influences are used"
            )
        });
    }
    match (
        attribute(Semantic::Joints(0)),
        attribute(Semantic::Weights(0)),
    ) {
        (None, None) => Ok((Vec::new(), Vec::new())),
        (Some(j), Some(w)) => Ok((
            source
                .buffers
                .joints(j, &format!("{label}.attributes.JOINTS_0"))?,
            source
                .buffers
                .weights(w, &format!("{label}.attributes.WEIGHTS_0"))?,
        )),
        _ => Err(malformed(format!(
            "{label}: JOINTS_0 and WEIGHTS_0 must be given together"
        ))),
    }
}

/// Converts a primitive's vertex sequence to a triangle list. Strips and fans drop the
/// degenerate triangles (repeated vertices) that tools insert to join strips. `None` when a
/// triangle list's length is not a multiple of 3.
fn triangle_list(mode: Mode, vertices: &[u32]) -> Option<Vec<u32>> {
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::Triangles => {
            if !vertices.len().is_multiple_of(3) {
                return None;
            }
            return Some(vertices.to_vec());
        }
        // glTF: triangle i is (v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]), keeping the winding.
        Mode::TriangleStrip => vertices
            .windows(3)
            .enumerate()
            .map(|(i, w)| {
                if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[0], w[2], w[1]]
                }
            })
            .collect(),
        // glTF: triangle i is (v[i + 1], v[i + 2], v[0]).
        Mode::TriangleFan => match vertices.split_first() {
            Some((&center, rest)) => rest.windows(2).map(|w| [w[0], w[1], center]).collect(),
            None => Vec::new(),
        },
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => Vec::new(),
    };
    Some(
        triangles
            .into_iter()
            .filter(|[a, b, c]| a != b && b != c && a != c)
            .flatten()
            .collect(),
    )
}

/// Smooth vertex normals: the area-weighted average of the normals of the triangles sharing
/// each vertex. A vertex whose neighbours cancel out takes one neighbour's normal; a vertex in
/// no proper triangle gets +Y.
fn vertex_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    let mut fallback = vec![None; positions.len()];
    for triangle in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| triangle[k] as usize);
        // The cross product's length is twice the triangle's area: the weighting comes free.
        let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        let Some(unit) = face.try_normalize() else {
            continue;
        };
        for v in [a, b, c] {
            sums[v] += face;
            fallback[v].get_or_insert(unit);
        }
    }
    sums.iter()
        .zip(fallback)
        .map(|(sum, fallback)| sum.try_normalize().or(fallback).unwrap_or(Vec3::Y))
        .collect()
}

//! Morph targets (glTF 2.0 blend shapes) on the CPU: a primitive's vertices displaced by its
//! targets in proportion to their weights, and which weights a node has at a time.
//!
//! A morphed vertex is `p + sum_i w_i * dp_i`, its normal `normalize(n + sum_i w_i * dn_i)`
//! and its tangent direction `normalize(t.xyz + sum_i w_i * dt_i)` with the bitangent sign
//! `t.w` kept. Morphing happens in the mesh's local space, before skinning and the node
//! transform, as glTF requires.
//!
//! A node's weights are, in order of precedence: an animation channel's
//! ([`ChannelValues::Weights`](crate::ChannelValues::Weights)), the node's own
//! ([`Node::weights`](crate::Node::weights)), the mesh's ([`Mesh::weights`]); missing entries
//! are zero. Fallbacks, so that no hand-built scene panics: a non-finite weight counts as zero,
//! and a displacement list whose length differs from the positions' is not applied (the
//! importer rejects both).

use std::borrow::Cow;

use glam::{Vec3, Vec4};

use crate::model::{Mesh, Primitive, Scene};

/// A primitive's positions, normals and tangents in its mesh's local space, with its morph
/// targets applied (borrowed from the primitive when no target has a weight):
/// [`Primitive::morphed`].
pub struct MorphedVertices<'a> {
    pub positions: Cow<'a, [Vec3]>,
    pub normals: Cow<'a, [Vec3]>,
    pub tangents: Cow<'a, [Vec4]>,
}

impl Scene {
    /// The mesh of node `node` when it has morph targets.
    pub(crate) fn morphed_mesh(&self, node: usize) -> Option<&Mesh> {
        let mesh = self.meshes.get(self.nodes.get(node)?.mesh?)?;
        (mesh.morph_target_count() > 0).then_some(mesh)
    }

    /// The morph target weights of node `node` without animation: one per target of its mesh,
    /// from the node's weights, else the mesh's (missing entries zero). Empty when the node's
    /// mesh has no targets.
    pub fn rest_morph_weights(&self, node: usize) -> Vec<f32> {
        let Some(mesh) = self.morphed_mesh(node) else {
            return Vec::new();
        };
        let source = self.nodes[node].weights.as_deref().unwrap_or(&mesh.weights);
        let mut weights = vec![0.0; mesh.morph_target_count()];
        for (weight, &value) in weights.iter_mut().zip(source) {
            *weight = value;
        }
        weights
    }

    /// `animated[node]`: the node's mesh has morph targets and an animation channel with keys
    /// sets its weights.
    pub fn morph_animated_nodes(&self) -> Vec<bool> {
        let mut animated = vec![false; self.nodes.len()];
        for channel in self.animations.iter().flat_map(|a| &a.channels) {
            if channel.is_weights()
                && !channel.times.is_empty()
                && self.morphed_mesh(channel.node).is_some()
            {
                animated[channel.node] = true;
            }
        }
        animated
    }

    /// Whether node `node`'s mesh is drawn morphed when nothing animates it: it has a target
    /// whose rest weight ([`Scene::rest_morph_weights`]) is not zero.
    pub fn morphed_at_rest(&self, node: usize) -> bool {
        self.rest_morph_weights(node)
            .iter()
            .any(|&w| w != 0.0 && w.is_finite())
    }
}

impl Primitive {
    /// The primitive's vertices with its morph targets applied at `weights` (one per target,
    /// missing ones zero; a node's are [`SceneFrame::morph_weights`](crate::SceneFrame)), in
    /// its mesh's local space: what skinning or the node's transform then places.
    pub fn morphed(&self, weights: &[f32]) -> MorphedVertices<'_> {
        morph(self, weights)
    }
}

/// `primitive`'s vertices with its targets applied at `weights` (one per target; missing
/// weights count as zero).
pub(crate) fn morph<'a>(primitive: &'a Primitive, weights: &[f32]) -> MorphedVertices<'a> {
    let count = primitive.positions.len();
    let active: Vec<_> = (primitive.targets.iter().zip(weights))
        .filter(|&(_, &w)| w != 0.0 && w.is_finite())
        .collect();
    let mut vertices = MorphedVertices {
        positions: Cow::Borrowed(&primitive.positions),
        normals: Cow::Borrowed(&primitive.normals),
        tangents: Cow::Borrowed(&primitive.tangents),
    };
    if active.is_empty() {
        return vertices;
    }
    // Sum of the weighted displacements of one attribute, or `None` when no active target
    // moves it.
    let displacement = |list: fn(&crate::MorphTarget) -> &[Vec3]| {
        let mut sum: Option<Vec<Vec3>> = None;
        for &(target, &weight) in &active {
            let deltas = list(target);
            if deltas.len() != count {
                continue;
            }
            let sum = sum.get_or_insert_with(|| vec![Vec3::ZERO; count]);
            for (s, d) in sum.iter_mut().zip(deltas) {
                *s += weight * *d;
            }
        }
        sum
    };
    if let Some(delta) = displacement(|t| &t.positions) {
        let positions = primitive.positions.iter().zip(&delta);
        vertices.positions = positions.map(|(p, d)| *p + *d).collect();
    }
    if primitive.normals.len() == count
        && let Some(delta) = displacement(|t| &t.normals)
    {
        let normals = primitive.normals.iter().zip(&delta);
        vertices.normals = normals.map(|(n, d)| (*n + *d).normalize_or(*n)).collect();
    }
    if primitive.tangents.len() == count
        && let Some(delta) = displacement(|t| &t.tangents)
    {
        let tangents = primitive.tangents.iter().zip(&delta);
        vertices.tangents = tangents
            .map(|(t, d)| {
                let xyz = t.truncate();
                (xyz + *d).normalize_or(xyz).extend(t.w)
            })
            .collect();
    }
    vertices
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MorphTarget;

    fn triangle() -> Primitive {
        Primitive {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            tangents: vec![Vec4::new(1.0, 0.0, 0.0, -1.0); 3],
            targets: vec![MorphTarget {
                positions: vec![Vec3::Z, Vec3::ZERO, Vec3::ZERO],
                normals: vec![Vec3::new(2.0, 0.0, -1.0), Vec3::ZERO, Vec3::ZERO],
                tangents: vec![Vec3::new(-1.0, 1.0, 0.0), Vec3::ZERO, Vec3::ZERO],
            }],
            indices: vec![0, 1, 2],
            ..Default::default()
        }
    }

    #[test]
    fn weights_blend_positions_normals_and_tangents() {
        let primitive = triangle();
        let rest = morph(&primitive, &[0.0]);
        assert!(
            matches!(rest.positions, Cow::Borrowed(_)),
            "zero weights copy nothing"
        );
        let full = morph(&primitive, &[1.0]);
        assert_eq!(full.positions[0], Vec3::Z);
        assert_eq!(full.positions[1], Vec3::X);
        assert_eq!(full.normals[0], Vec3::X, "normalize(z + (2, 0, -1))");
        assert_eq!(
            full.tangents[0],
            Vec4::new(0.0, 1.0, 0.0, -1.0),
            "sign kept"
        );
        let half = morph(&primitive, &[0.5]);
        assert_eq!(half.positions[0], Vec3::new(0.0, 0.0, 0.5));
        // Non-finite weights count as zero; a short displacement list is not applied.
        assert_eq!(morph(&primitive, &[f32::NAN]).positions[0], Vec3::ZERO);
        let mut short = triangle();
        short.targets[0].positions.pop();
        assert_eq!(morph(&short, &[1.0]).positions[0], Vec3::ZERO);
    }
}

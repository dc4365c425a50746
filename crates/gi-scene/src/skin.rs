//! Linear blend skinning (glTF 2.0 skins) on the CPU, and which nodes move or deform over time
//! (by their skins or by animated morph target weights).
//!
//! A skinned vertex is placed by the matrix `sum_i w_i * joint_matrix[j_i]`, where
//! `joint_matrix[k] = world_from_node[skin.joints[k]] * skin.inverse_bind_matrices[k]` and the
//! weights are divided by their sum. The skinned node's own transform is ignored, as glTF
//! requires. Normals go through the inverse transpose of that blended matrix (computed as its
//! cofactor matrix, which stays defined where blending makes the matrix singular), tangents
//! through the blended matrix itself, both renormalized.
//!
//! Fallbacks, so that no input panics: a negative or non-finite weight, and a weight whose joint
//! index is outside the skin's joint list or whose joint is not a node, count as zero (the
//! importer rejects all of these); a vertex whose weights are all zero (the importer warns) is
//! placed by the node's own world transform, as an unskinned mesh would be. Weights are
//! divided by their sum, so they need not add up to 1.

use glam::{Mat3, Mat4, Vec3, Vec4};

use crate::SceneFrame;
use crate::frame::par_map_index;
use crate::model::{Primitive, Scene, Skin};
use crate::morph::MorphedVertices;

/// `result[node]`: `flagged` is set for the node or one of its ancestors (`parent_of` walks
/// up). Each node is walked once: a walk stops at the first node already answered and answers
/// every node it passed. A parent index outside the nodes ends a walk unflagged; so does a
/// cycle without a flagged node, after one trip around it (a hand-built hierarchy cannot
/// hang).
fn moves_with_ancestors(flagged: &[bool], parent_of: impl Fn(usize) -> Option<usize>) -> Vec<bool> {
    const UNKNOWN: u8 = 0;
    const STILL: u8 = 1;
    const MOVES: u8 = 2;
    let count = flagged.len();
    let mut state = vec![UNKNOWN; count];
    let mut path = Vec::new();
    for node in 0..count {
        let mut current = Some(node);
        let mut moves = false;
        for _ in 0..=count {
            let Some(index) = current.filter(|&i| i < count) else {
                break;
            };
            if state[index] != UNKNOWN {
                moves = state[index] == MOVES;
                break;
            }
            path.push(index);
            if flagged[index] {
                moves = true;
                break;
            }
            current = parent_of(index);
        }
        for &index in &path {
            state[index] = if moves { MOVES } else { STILL };
        }
        path.clear();
    }
    state.into_iter().map(|s| s == MOVES).collect()
}

/// A primitive's vertices placed in world space by its skin.
pub(crate) struct SkinnedVertices {
    pub positions: Vec<Vec3>,
    /// Unit normals (empty when the primitive has none).
    pub normals: Vec<Vec3>,
    /// Unit tangents with the bitangent sign in w, flipped where the vertex's matrix mirrors.
    pub tangents: Vec<Vec4>,
    /// Per vertex: the vertex's matrix mirrors (negative determinant).
    pub mirrored: Vec<bool>,
}

impl Scene {
    /// `moving[node]`: the node's world transform changes over time (an animation channel whose
    /// keys differ targets the transform of it or one of its ancestors; weights channels do
    /// not), or the caller moves it or an ancestor ([`Node::movable`](crate::Node::movable)).
    pub fn moving_nodes(&self) -> Vec<bool> {
        let mut animated: Vec<bool> = self.nodes.iter().map(|node| node.movable).collect();
        for channel in self.animations.iter().flat_map(|a| &a.channels) {
            if !channel.is_constant()
                && !channel.is_weights()
                && let Some(flag) = animated.get_mut(channel.node)
            {
                *flag = true;
            }
        }
        moves_with_ancestors(&animated, |node| self.nodes[node].parent)
    }

    /// [`Scene::moving_nodes`] and [`Scene::deforming_nodes`] together, the first computed
    /// once (a renderer or the cache asks for both every frame).
    pub fn moving_and_deforming_nodes(&self) -> (Vec<bool>, Vec<bool>) {
        let moving = self.moving_nodes();
        let deforming = self.deforming_given(&moving);
        (moving, deforming)
    }

    /// The skin that deforms node `node`'s mesh: the node has a mesh with at least one skinned
    /// primitive ([`Primitive::is_skinned`]) and a skin that exists.
    pub fn node_skin(&self, node: usize) -> Option<&Skin> {
        let node = self.nodes.get(node)?;
        let mesh = self.meshes.get(node.mesh?)?;
        let skin = self.skins.get(node.skin?)?;
        mesh.primitives
            .iter()
            .any(Primitive::is_skinned)
            .then_some(skin)
    }

    /// `deforming[node]`: the node's triangles change shape from frame to frame, because
    /// - its mesh is skinned ([`Scene::node_skin`]) and one of its joints or the node itself
    ///   moves ([`Scene::moving_nodes`]), or
    /// - an animation sets its morph target weights ([`Scene::morph_animated_nodes`]), or
    /// - it moves and is drawn morphed at rest ([`Scene::morphed_at_rest`]): its shape is not
    ///   its mesh's, so it cannot be placed as a rigid copy of the mesh.
    ///
    /// A skinned node whose joints stand still, and a still node with constant weights, are
    /// static geometry, deformed once by every evaluation.
    pub fn deforming_nodes(&self) -> Vec<bool> {
        self.deforming_given(&self.moving_nodes())
    }

    /// [`Scene::deforming_nodes`] given [`Scene::moving_nodes`].
    fn deforming_given(&self, moving: &[bool]) -> Vec<bool> {
        let moves = |node: usize| moving.get(node).copied().unwrap_or(false);
        let morph_animated = self.morph_animated_nodes();
        (0..self.nodes.len())
            .map(|node| {
                let skinned = self
                    .node_skin(node)
                    .is_some_and(|skin| moves(node) || skin.joints.iter().any(|&j| moves(j)));
                skinned || morph_animated[node] || (moves(node) && self.morphed_at_rest(node))
            })
            .collect()
    }

    /// Whether node `node`'s geometry changed between two evaluations of the scene: its own
    /// transform changed, or, for a skinned node, the transform of one of its joints did, or
    /// its morph target weights did. Frames without geometry
    /// ([`SceneFrame::without_geometry`]) are enough.
    pub fn node_geometry_changed(
        &self,
        node: usize,
        previous: &SceneFrame,
        current: &SceneFrame,
    ) -> bool {
        let (previous_world, current_world) = (&previous.world_from_node, &current.world_from_node);
        let changed = |n: usize| previous_world.get(n) != current_world.get(n);
        changed(node)
            || self
                .node_skin(node)
                .is_some_and(|skin| skin.joints.iter().any(|&j| changed(j)))
            || previous.morph_weights.get(node) != current.morph_weights.get(node)
    }
}

impl Skin {
    /// `world_from_node[joint] * inverse_bind` for every joint; `None` for a joint that is not a
    /// node.
    pub fn joint_matrices(&self, world_from_node: &[Mat4]) -> Vec<Option<Mat4>> {
        self.joints
            .iter()
            .enumerate()
            .map(|(k, &joint)| {
                let inverse_bind = self
                    .inverse_bind_matrices
                    .get(k)
                    .copied()
                    .unwrap_or(Mat4::IDENTITY);
                world_from_node
                    .get(joint)
                    .map(|world| *world * inverse_bind)
            })
            .collect()
    }
}

/// The blended matrix of a vertex with `joints` and `weights`, or `None` when no weight with a
/// valid joint is positive.
pub(crate) fn blend(
    joint_matrices: &[Option<Mat4>],
    joints: [u16; 4],
    weights: Vec4,
) -> Option<Mat4> {
    let mut matrix = Mat4::ZERO;
    let mut total = 0.0;
    for (joint, weight) in joints.into_iter().zip(weights.to_array()) {
        // Negative and non-finite weights count as zero.
        if !weight.is_finite() || weight <= 0.0 {
            continue;
        }
        let Some(Some(joint_matrix)) = joint_matrices.get(joint as usize) else {
            continue;
        };
        matrix += *joint_matrix * weight;
        total += weight;
    }
    if total <= 0.0 || !total.is_finite() {
        return None;
    }
    // A weight sum of exactly 1 leaves the matrix bit for bit as blended.
    Some(if total == 1.0 {
        matrix
    } else {
        matrix * (1.0 / total)
    })
}

/// Inverse transpose of `m`'s linear part up to a positive scale: the cofactor matrix times
/// the sign of the determinant. Unlike the inverse it exists for singular matrices.
fn normal_matrix(m: &Mat4) -> Mat3 {
    let [c0, c1, c2] = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.truncate());
    let cofactor = Mat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
    if m.determinant() < 0.0 {
        -cofactor
    } else {
        cofactor
    }
}

/// The skinned `positions` of `primitive` (its own or morphed) alone (see
/// [`skin_primitive`]).
pub(crate) fn skin_positions(
    primitive: &Primitive,
    positions: &[Vec3],
    joint_matrices: &[Option<Mat4>],
    world_from_node: Mat4,
) -> Vec<Vec3> {
    (positions.iter().enumerate())
        .map(|(i, p)| {
            let joints = primitive.joints.get(i).copied().unwrap_or_default();
            let weights = primitive.weights.get(i).copied().unwrap_or(Vec4::ZERO);
            blend(joint_matrices, joints, weights)
                .unwrap_or(world_from_node)
                .transform_point3(*p)
        })
        .collect()
}

/// Skins `vertices` (`primitive`'s, morphed by its targets) with `joint_matrices` (from
/// [`Skin::joint_matrices`]) and `primitive`'s joints and weights; vertices without a usable
/// weight are placed by `world_from_node`. With `positions_only`, normals and tangents are
/// left empty.
pub(crate) fn skin_primitive(
    primitive: &Primitive,
    vertices: &MorphedVertices,
    joint_matrices: &[Option<Mat4>],
    world_from_node: Mat4,
    positions_only: bool,
) -> SkinnedVertices {
    let matrices: Vec<Mat4> = par_map_index(vertices.positions.len(), |i| {
        let joints = primitive.joints.get(i).copied().unwrap_or_default();
        let weights = primitive.weights.get(i).copied().unwrap_or(Vec4::ZERO);
        blend(joint_matrices, joints, weights).unwrap_or(world_from_node)
    });
    let mirrored: Vec<bool> = par_map_index(matrices.len(), |i| matrices[i].determinant() < 0.0);
    let positions = par_map_index(matrices.len(), |i| {
        matrices[i].transform_point3(vertices.positions[i])
    });
    if positions_only {
        return SkinnedVertices {
            positions,
            normals: Vec::new(),
            tangents: Vec::new(),
            mirrored,
        };
    }
    let normals = par_map_index(vertices.normals.len().min(matrices.len()), |i| {
        (normal_matrix(&matrices[i]) * vertices.normals[i]).normalize_or(Vec3::Y)
    });
    let tangents = par_map_index(vertices.tangents.len().min(matrices.len()), |i| {
        let t = vertices.tangents[i];
        let xyz = matrices[i]
            .transform_vector3(t.truncate())
            .normalize_or_zero();
        let sign = if t.w < 0.0 { -1.0 } else { 1.0 };
        xyz.extend(if mirrored[i] { -sign } else { sign })
    });
    SkinnedVertices {
        positions,
        normals,
        tangents,
        mirrored,
    }
}

#[cfg(test)]
mod tests {
    use super::moves_with_ancestors;

    /// The walk of every node up to the root, as `moving_nodes` did it before answers were
    /// shared: at most one trip around a cycle.
    fn walked(flagged: &[bool], parents: &[Option<usize>]) -> Vec<bool> {
        (0..flagged.len())
            .map(|node| {
                let mut current = Some(node);
                for _ in 0..=flagged.len() {
                    let Some(index) = current.filter(|&i| i < flagged.len()) else {
                        return false;
                    };
                    if flagged[index] {
                        return true;
                    }
                    current = parents[index];
                }
                false
            })
            .collect()
    }

    /// Random forests with cycles, self-parents and parents outside the nodes: the shared
    /// answers equal every node's own walk.
    #[test]
    fn shared_walks_answer_as_each_nodes_own() {
        let mut state = 0x9e37_79b9_u32;
        let mut next = move |below: u32| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state % below
        };
        let mut flagged_total = 0;
        for round in 0..400 {
            let count = 1 + next(40) as usize;
            let parents: Vec<Option<usize>> = (0..count)
                .map(|_| match next(10) {
                    0..=2 => None,
                    3 => Some(count + next(3) as usize),
                    _ => Some(next(count as u32) as usize),
                })
                .collect();
            let flagged: Vec<bool> = (0..count).map(|_| next(8) == 0).collect();
            let shared = moves_with_ancestors(&flagged, |node| parents[node]);
            assert_eq!(
                shared,
                walked(&flagged, &parents),
                "round {round}: {parents:?}"
            );
            flagged_total += shared.iter().filter(|&&m| m).count();
        }
        assert!(flagged_total > 1000, "{flagged_total}");
    }
}

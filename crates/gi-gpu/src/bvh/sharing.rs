//! Which static geometry gets a bottom level shared by its copies instead of being flattened
//! into the world-space static level: repeated node trees first (a building, a prop made of
//! several meshes, a whole tiled scene), then repeated meshes among the nodes left.
//!
//! glTF instancing is many nodes naming one mesh; a node has one parent, so a repeated tree
//! of nodes is a copy of the nodes with equal meshes and local transforms. Two trees are the
//! same shape when their roots name the same mesh and their children, in index order, have
//! bit-identical local transforms and are the same shape in turn. A shape's level is built in
//! its root's space (each triangle moved by the product of the local transforms below the
//! root), and each copy is an instance placed by its root's world transform, so the copies'
//! triangles need not be bit-identical in world space.
//!
//! An instance maps a primitive to frame triangle `triangle_base + primitive`, so a tree is
//! shared only when its mesh nodes, visited depth first (children in index order), emit their
//! frame triangles as one contiguous run in that order. `Scene::evaluate` emits nodes in index
//! order, which tools that copy node trees (and `benchmarks/scale/tile_gltf.py`) preserve.

use std::collections::HashMap;
use std::hash::{DefaultHasher, Hash, Hasher};

use gi_scene::Scene;
use glam::Mat4;

/// Which static geometry placed more than once gets a bottom level of its own, shared by its
/// copies, instead of being flattened into the world-space static level.
///
/// A node tree (or, among the nodes left, a mesh) is shared when a copy has at least
/// [`MeshSharing::min_triangles`] triangles and flattening would store at least
/// [`MeshSharing::min_saved_triangles`] more triangles than sharing does (`(copies - 1) *
/// triangles`). Small pieces stay flattened however often they are placed: entering an
/// instance costs a ray transform and a top-level leaf, and overlapping instances cost more
/// than the triangles they save (measured in `benchmarks/RESULTS-history.md`, "Shared bottom
/// levels"). Skinned nodes, deforming or moving ones, and meshes with morph targets are never
/// shared this way (their frame triangles are not their meshes' positions, or they move).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshSharing {
    /// Fewest triangles a shared tree or mesh has.
    pub min_triangles: usize,
    /// Fewest triangles sharing must save against flattening the copies.
    pub min_saved_triangles: usize,
}

impl MeshSharing {
    /// Every static copy flattened into the static level.
    pub const OFF: Self = Self {
        min_triangles: usize::MAX,
        min_saved_triangles: usize::MAX,
    };

    /// Every tree and mesh placed twice or more shared, however small.
    pub const ALL: Self = Self {
        min_triangles: 1,
        min_saved_triangles: 1,
    };

    fn shares(&self, copies: usize, triangles: usize) -> bool {
        copies >= 2
            && triangles >= self.min_triangles
            && (copies - 1).saturating_mul(triangles) >= self.min_saved_triangles
    }

    /// Per mesh: whether the static copies of it that `counts(node)` says are free share one
    /// level.
    pub(super) fn shared_meshes(&self, scene: &Scene, counts: impl Fn(usize) -> bool) -> Vec<bool> {
        let mut copies = vec![0usize; scene.meshes.len()];
        for (index, node) in scene.nodes.iter().enumerate() {
            if let Some(mesh) = node.mesh
                && counts(index)
                && let Some(count) = copies.get_mut(mesh)
            {
                *count += 1;
            }
        }
        (scene.meshes.iter().zip(copies))
            .map(|(mesh, copies)| {
                mesh.morph_target_count() == 0 && self.shares(copies, mesh_triangles(mesh))
            })
            .collect()
    }
}

impl Default for MeshSharing {
    /// Trees and meshes of at least 512 triangles whose copies would add at least 65,536
    /// triangles. Sponza's own repeated pieces stay flattened (the most any of them would save
    /// is 14k triangles); tiled 4 or 16 times, each copy of it is one instance.
    fn default() -> Self {
        Self {
            min_triangles: 512,
            min_saved_triangles: 65_536,
        }
    }
}

/// A copy of a shared tree: its root node (placed by its world transform), the frame index of
/// its first triangle, and its shape (an index into [`SharedTrees::shapes`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct TreeCopy {
    pub root: usize,
    pub first_triangle: u32,
    pub shape: usize,
}

/// The repeated trees of a scene, and which nodes they cover.
pub(super) struct SharedTrees {
    pub copies: Vec<TreeCopy>,
    /// Per shape, its mesh nodes in preorder (the copies' frame order): each one's mesh and
    /// its transform into the tree root's space.
    pub shapes: Vec<Vec<(usize, Mat4)>>,
    /// Per node: whether a copy's tree contains it.
    pub covered: Vec<bool>,
}

/// Per node: the frame index of its first triangle and its triangle count.
pub(super) fn node_ranges(scene: &Scene, nodes: impl Iterator<Item = u32>) -> Vec<(u32, u32)> {
    let mut ranges = vec![(u32::MAX, 0u32); scene.nodes.len()];
    for (index, node) in nodes.enumerate() {
        if let Some(range) = ranges.get_mut(node as usize) {
            range.0 = range.0.min(index as u32);
            range.1 += 1;
        }
    }
    ranges
}

/// Finds the repeated static trees of `scene` under `sharing`; `plain[node]` says a node may
/// be part of one (static, unskinned, its mesh without morph targets), `ranges` are
/// [`node_ranges`] of the frame.
pub(super) fn shared_trees(
    scene: &Scene,
    plain: &[bool],
    ranges: &[(u32, u32)],
    sharing: MeshSharing,
) -> SharedTrees {
    let count = scene.nodes.len();
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); count];
    let mut roots = Vec::new();
    for (index, node) in scene.nodes.iter().enumerate() {
        match node.parent {
            Some(parent) if parent < count => children[parent].push(index),
            Some(_) => {}
            None => roots.push(index),
        }
    }
    // Depth-first preorder from the roots (children in index order); nodes on a cycle are
    // never reached and never shared.
    let mut order = Vec::with_capacity(count);
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    let mut seen = vec![false; count];
    while let Some(node) = stack.pop() {
        if std::mem::replace(&mut seen[node], true) {
            continue;
        }
        order.push(node);
        stack.extend(children[node].iter().rev());
    }
    // Bottom up: a tree qualifies when every node is plain and its mesh nodes' frame
    // triangles form one run in preorder (a tree without triangles qualifies, never chosen); its key hashes the meshes and the children's local
    // transforms.
    let mut key = vec![0u64; count];
    let mut qualifies = vec![false; count];
    let mut triangles = vec![0u64; count];
    // First frame triangle of the tree's run (u32::MAX when it has none).
    let mut first = vec![u32::MAX; count];
    for &node in order.iter().rev() {
        let mut hasher = DefaultHasher::new();
        scene.nodes[node].mesh.hash(&mut hasher);
        let (own_first, own_count) = ranges.get(node).copied().unwrap_or((u32::MAX, 0));
        let mut ok = plain.get(node).copied().unwrap_or(false);
        // The frame holds every triangle of the node's mesh (a copy maps them one to one).
        if let Some(mesh) = scene.nodes[node].mesh.and_then(|m| scene.meshes.get(m)) {
            ok &= mesh_triangles(mesh) == own_count as usize;
        }
        let mut run_first = if own_count > 0 { own_first } else { u32::MAX };
        let mut next = own_first.saturating_add(own_count);
        let mut total = own_count as u64;
        for &child in &children[node] {
            local_bits(scene, child).hash(&mut hasher);
            key[child].hash(&mut hasher);
            ok &= qualifies[child];
            if triangles[child] > 0 {
                if run_first == u32::MAX {
                    run_first = first[child];
                } else {
                    ok &= first[child] == next;
                }
                next = first[child].saturating_add(triangles[child] as u32);
                total += triangles[child];
            }
        }
        key[node] = hasher.finish();
        qualifies[node] = ok && total <= u32::MAX as u64;
        triangles[node] = total;
        first[node] = run_first;
    }
    let mut occurrences: HashMap<u64, usize> = HashMap::new();
    for node in 0..count {
        if qualifies[node] {
            *occurrences.entry(key[node]).or_default() += 1;
        }
    }
    // Top down: the highest trees that repeat often enough; below a chosen root nothing else.
    let mut chosen = Vec::new();
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    let mut visited = vec![false; count];
    while let Some(node) = stack.pop() {
        if std::mem::replace(&mut visited[node], true) {
            continue;
        }
        let copies = occurrences.get(&key[node]).copied().unwrap_or(0);
        if qualifies[node] && sharing.shares(copies, triangles[node] as usize) {
            chosen.push(node);
        } else {
            stack.extend(children[node].iter().rev());
        }
    }
    // Group by shape: equal keys and equal trees (a hash collision stays flattened); a shape
    // chosen only once (its other copies inside larger trees) is not worth a level.
    let mut shapes_by_key: HashMap<u64, Vec<(usize, Vec<usize>)>> = HashMap::new();
    for &root in &chosen {
        let groups = shapes_by_key.entry(key[root]).or_default();
        match groups
            .iter_mut()
            .find(|(representative, _)| same_tree(scene, &children, *representative, root))
        {
            Some((_, members)) => members.push(root),
            None => groups.push((root, vec![root])),
        }
    }
    let mut result = SharedTrees {
        copies: Vec::new(),
        shapes: Vec::new(),
        covered: vec![false; count],
    };
    let mut groups: Vec<(usize, Vec<usize>)> = shapes_by_key.into_values().flatten().collect();
    groups.sort_unstable_by_key(|(representative, _)| *representative);
    for (representative, members) in groups {
        if members.len() < 2 {
            continue;
        }
        let shape = result.shapes.len();
        result
            .shapes
            .push(tree_shape(scene, &children, representative));
        for root in members {
            result.copies.push(TreeCopy {
                root,
                first_triangle: first[root],
                shape,
            });
            let mut stack = vec![root];
            while let Some(node) = stack.pop() {
                result.covered[node] = true;
                stack.extend(&children[node]);
            }
        }
    }
    result
}

fn mesh_triangles(mesh: &gi_scene::Mesh) -> usize {
    mesh.primitives.iter().map(|p| p.indices.len() / 3).sum()
}

/// The bits of a node's local transform (translation, rotation, scale).
fn local_bits(scene: &Scene, node: usize) -> [u32; 10] {
    let n = &scene.nodes[node];
    let mut bits = [0u32; 10];
    let values = n
        .translation
        .to_array()
        .into_iter()
        .chain(n.rotation.to_array())
        .chain(n.scale.to_array());
    for (slot, value) in bits.iter_mut().zip(values) {
        *slot = value.to_bits();
    }
    bits
}

fn local_matrix(scene: &Scene, node: usize) -> Mat4 {
    let n = &scene.nodes[node];
    Mat4::from_scale_rotation_translation(n.scale, n.rotation, n.translation)
}

/// Whether the trees at `a` and `b` name the same meshes with the same local transforms.
fn same_tree(scene: &Scene, children: &[Vec<usize>], a: usize, b: usize) -> bool {
    let mut stack = vec![(a, b)];
    while let Some((a, b)) = stack.pop() {
        if scene.nodes[a].mesh != scene.nodes[b].mesh || children[a].len() != children[b].len() {
            return false;
        }
        for (&ca, &cb) in children[a].iter().zip(&children[b]) {
            if local_bits(scene, ca) != local_bits(scene, cb) {
                return false;
            }
            stack.push((ca, cb));
        }
    }
    true
}

/// The mesh nodes of the tree at `root` in preorder, children in index order (the frame order
/// of its triangles): each one's mesh and `root_from_node`.
fn tree_shape(scene: &Scene, children: &[Vec<usize>], root: usize) -> Vec<(usize, Mat4)> {
    let mut placements = Vec::new();
    let mut stack = vec![(root, Mat4::IDENTITY)];
    while let Some((node, root_from_node)) = stack.pop() {
        if let Some(mesh) = scene.nodes[node].mesh {
            placements.push((mesh, root_from_node));
        }
        for &child in children[node].iter().rev() {
            stack.push((child, root_from_node * local_matrix(scene, child)));
        }
    }
    placements
}

//! The CPU side of the two-level BVH: bottom levels built once per scene, and the small top
//! level over their instances rebuilt every frame.
//!
//! Static geometry (mesh nodes whose world transform never changes: neither they nor an
//! ancestor have an animation channel) goes into one world-space bottom level, built with
//! `gi_scene::traversal_build` (obvhs's `medium_build`, large triangles pre-split) for the
//! best traversal quality; its primitives carry their frame triangle index and its instance
//! has the identity transform. Each mesh used by a moving node gets one bottom level in the
//! mesh's object space, shared by every moving node that uses it;
//! an instance per moving node carries its `object_from_world` and the first index of its
//! triangle range in the frame. The top level is an obvhs CWBVH over the instances' world
//! boxes: hundreds of moving objects stay logarithmic to traverse, and rebuilding it is a PLOC
//! build over that many boxes, far cheaper than the triangles.
//!
//! Static geometry placed many times (glTF instancing: a node tree or a mesh repeated, from a
//! column to a whole tiled building) gets one level in its own space when [`MeshSharing`]
//! says flattening its copies would cost too much (see the `sharing` module), and one
//! instance per copy, placed by its root node's constant transform. Its copies are then built
//! and stored once, at the price of a top-level leaf and a ray transform per copy a ray
//! enters; a scene without such copies keeps the single flattened static level.
//!
//! Deforming nodes (skinned meshes whose joints move, meshes whose morph target weights are
//! animated; [`Scene::deforming_nodes`]) change shape, so no fixed level can hold them: each
//! gets a world-space level over its frame triangles, placed with the identity and kept after
//! every fixed level in the node and primitive lists. Later frames keep its tree and refit it
//! ([`BottomLevels::refit_deforming`] writes the new vertices into its primitives, in the same
//! leaf order; `shaders/bvh/refit.wgsl` gives its nodes new boxes on the GPU, deepest first),
//! the standard treatment of skinned geometry in real-time ray tracing: the tree's shape stays
//! the one fitted to the pose it was built in, so it is built again (obvhs's `fast_build`) when
//! the boxes of its upper nodes outgrow that pose's by a set factor. Skinning and morphing
//! themselves run on the CPU in `Scene::evaluate`, which every tier's frame reads.

use std::time::{Duration, Instant};

use gi_scene::{Scene, SceneFrame};
use glam::{Mat4, Vec3A};
use obvhs::{BvhBuildParams, aabb::Aabb, cwbvh::CwBvh, triangle::Triangle};
use rayon::prelude::*;

use super::layout::{
    BVH_INSTANCE_IDENTITY, BVH_INSTANCE_MIRRORED, BVH_STACK_SIZE, BVH_TRIANGLE_ALPHA, BvhError,
    GpuBvhInstance, GpuBvhTriangle, GpuCwBvhNode, PackedBvh,
};
use super::sharing::{MeshSharing, node_ranges, shared_trees};

/// One bottom level's place in the concatenated buffers.
#[derive(Clone, Copy, Debug)]
struct Blas {
    /// Index of its root in the concatenated node list.
    root: u32,
    /// Bounds of its primitives in its own space.
    bounds: Aabb,
}

/// Where an instance's transform comes from.
#[derive(Clone, Copy, Debug)]
enum Placement {
    /// The world-space static bottom level: identity, every frame.
    Static,
    /// A moving mesh node: `frame.world_from_node[node]`.
    Node(usize),
}

#[derive(Clone, Copy, Debug)]
struct Instance {
    blas: usize,
    placement: Placement,
    /// Frame index of the instance's first triangle (0 for the static level, whose primitives
    /// carry frame indices).
    triangle_base: u32,
}

/// Every bottom level packed into one node list and one primitive list (child and primitive
/// indices rebased to the concatenation), and the instances that place them.
#[derive(Clone, Debug)]
pub struct BottomLevels {
    /// All bottom-level nodes; each level's root at `Blas::root`. The deforming levels'
    /// nodes keep the boxes of their last build: after a [`DeformUpdate::Refit`] only the
    /// GPU's copy is current.
    pub nodes: Vec<GpuCwBvhNode>,
    /// All bottom-level primitives in leaf order.
    pub triangles: Vec<GpuBvhTriangle>,
    /// Levels below the root of the deepest bottom level.
    pub depth: u32,
    /// Wall time of the CPU builds (all bottom levels) and their packing.
    pub build_time: Duration,
    /// Wall time of the last rebuild of the deforming levels (zero without deforming nodes).
    pub deform_time: Duration,
    blases: Vec<Blas>,
    instances: Vec<Instance>,
    /// The levels built once (static and rigidly moving) come first; the deforming levels
    /// follow them and are replaced by every [`BottomLevels::rebuild_deforming`].
    fixed: FixedPart,
    deforming: Vec<DeformingNode>,
    refit_plan: RefitPlan,
}

/// Sizes of the part of [`BottomLevels`] built once.
#[derive(Clone, Copy, Debug, Default)]
struct FixedPart {
    nodes: usize,
    triangles: usize,
    depth: u32,
    blases: usize,
    instances: usize,
}

/// A node whose triangles change shape every frame: a world-space level of its own.
#[derive(Clone, Debug)]
struct DeformingNode {
    /// Frame index of each of its triangles.
    frame_indices: Vec<u32>,
    /// Per triangle: whether its material is alpha-tested.
    alpha: Vec<bool>,
    /// Its level as last built (`None` for a node without triangles).
    level: Option<DeformingLevel>,
}

/// Where a deforming node's level lies in the concatenated lists, and its size when built.
#[derive(Clone, Debug)]
struct DeformingLevel {
    blas: usize,
    /// Its primitives in [`BottomLevels::triangles`].
    triangles: std::ops::Range<usize>,
    /// The primitives below each of its nodes down to [`WATCHED_DEPTH`] (a subtree's
    /// primitives are contiguous in leaf order), as ranges of [`BottomLevels::triangles`].
    watched: Vec<std::ops::Range<usize>>,
    /// [`watched_area`] when it was built.
    built_area: f32,
}

/// Depth below a deforming level's root down to which its nodes' boxes are watched for the
/// decision to rebuild (root, children, grandchildren: at most 73 boxes).
const WATCHED_DEPTH: u32 = 2;

/// How [`BottomLevels::refit_deforming`] followed a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeformUpdate {
    /// The trees were kept: the primitives hold the frame's vertices in the same leaf order,
    /// and the nodes still hold the boxes of an earlier frame until the GPU refit
    /// (`shaders/bvh/refit.wgsl`) gives them new ones.
    Refit,
    /// The deforming levels were built again over the frame (nodes and primitives replaced).
    Rebuilt,
}

/// The deforming levels' nodes in the order the GPU refit visits them: a node's internal
/// children are always refit by an earlier dispatch than the node itself.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RefitPlan {
    /// Indices into [`BottomLevels::nodes`], deepest first.
    pub order: Vec<u32>,
    /// One dispatch per depth, deepest first: the first index into `order` and the count.
    pub steps: Vec<(u32, u32)>,
}

/// A top level built for one frame: nodes, and the instances in its leaf order.
#[derive(Clone, Debug)]
pub struct TopLevel {
    /// Root first; one childless root when there are no instances.
    pub nodes: Vec<GpuCwBvhNode>,
    /// `instances[i]` is the top level's primitive `i`.
    pub instances: Vec<GpuBvhInstance>,
    /// Levels below the root of the deepest top-level node.
    pub depth: u32,
    /// Wall time of this build (boxes, PLOC, packing).
    pub build_time: Duration,
}

impl BottomLevels {
    /// Builds the static level over the frame's static triangles, one object-space level
    /// per mesh of a moving node or shared by static nodes ([`MeshSharing::default`]) and one
    /// world-space level per deforming node (at `frame`'s shape). `frame` must be an
    /// evaluation of `scene` (any time: static triangles are the same at every time).
    pub fn from_scene(scene: &Scene, frame: &SceneFrame) -> Result<Self, BvhError> {
        Self::from_scene_with(scene, frame, MeshSharing::default())
    }

    /// [`BottomLevels::from_scene`] with the given rule for sharing static meshes.
    pub fn from_scene_with(
        scene: &Scene,
        frame: &SceneFrame,
        sharing: MeshSharing,
    ) -> Result<Self, BvhError> {
        let start = Instant::now();
        let deforming = scene.deforming_nodes();
        // A skinned node is placed by its joints, never rigidly by its own transform: it either
        // deforms or is static.
        let animated = scene.moving_nodes();
        let moving: Vec<bool> = (animated.iter().enumerate())
            .map(|(node, &moving)| moving && scene.node_skin(node).is_none())
            .collect();
        let flag = |flags: &[bool], node: usize| flags.get(node).copied().unwrap_or(false);
        // Static, unskinned nodes whose frame triangles are their meshes' positions placed
        // by their transforms: the ones a shared level may stand for.
        let plain: Vec<bool> = (0..scene.nodes.len())
            .map(|node| {
                !flag(&animated, node)
                    && !flag(&deforming, node)
                    && scene.node_skin(node).is_none()
                    && (scene.nodes[node].mesh)
                        .and_then(|m| scene.meshes.get(m))
                        .is_none_or(|m| m.morph_target_count() == 0)
            })
            .collect();
        let ranges = node_ranges(scene, frame.attributes.iter().map(|a| a.node));
        let trees = shared_trees(scene, &plain, &ranges, sharing);
        let shared_mesh = sharing.shared_meshes(scene, |node| {
            flag(&plain, node) && !flag(&trees.covered, node)
        });
        // Moving nodes, and static ones whose mesh is shared, are placed by their transforms.
        let placed: Vec<bool> = (0..scene.nodes.len())
            .map(|node| {
                flag(&moving, node)
                    || (flag(&plain, node)
                        && !flag(&trees.covered, node)
                        && (scene.nodes[node].mesh).is_some_and(|m| flag(&shared_mesh, m)))
            })
            .collect();
        let mut levels = Self::empty();
        let mut static_indices = Vec::new();
        let mut first_triangle: Vec<Option<u32>> = vec![None; scene.nodes.len()];
        let mut deforming_indices: Vec<Vec<u32>> = vec![Vec::new(); scene.nodes.len()];
        for (index, attributes) in frame.attributes.iter().enumerate() {
            let node = attributes.node as usize;
            if flag(&deforming, node) {
                deforming_indices[node].push(index as u32);
            } else if flag(&trees.covered, node) {
                // Traced through its tree's instance.
            } else if flag(&placed, node) {
                first_triangle[node].get_or_insert(index as u32);
            } else {
                static_indices.push(index as u32);
            }
        }
        let static_triangles: Vec<Triangle> = static_indices
            .iter()
            .map(|&i| frame.triangles[i as usize])
            .collect();
        let alpha_tested: Vec<bool> = scene.materials.iter().map(|m| m.alpha_tested()).collect();
        let material_alpha = |material: usize| alpha_tested.get(material).copied().unwrap_or(false);
        let static_alpha: Vec<bool> = static_indices
            .iter()
            .map(|&i| material_alpha(frame.attributes[i as usize].material as usize))
            .collect();
        if let Some(blas) =
            levels.add_blas(&static_triangles, Some(&static_indices), &static_alpha)?
        {
            levels.instances.push(Instance {
                blas,
                placement: Placement::Static,
                triangle_base: 0,
            });
        }
        // One level per repeated tree, in its root's space, shared by its copies.
        let mut shape_blas = Vec::with_capacity(trees.shapes.len());
        for placements in &trees.shapes {
            let (mut triangles, mut alpha) = (Vec::new(), Vec::new());
            for &(mesh, root_from_node) in placements {
                // The frame's order: a mirroring transform below the root swaps a triangle's
                // last two vertices, as `Scene::evaluate` does (a mirroring root is the
                // instance's flag).
                let flips = root_from_node.determinant() < 0.0;
                let at = |v: Vec3A| Vec3A::from(root_from_node.transform_point3(v.into()));
                triangles.extend(object_triangles(scene, mesh).into_iter().map(|t| {
                    let (v1, v2) = if flips { (t.v2, t.v1) } else { (t.v1, t.v2) };
                    Triangle {
                        v0: at(t.v0),
                        v1: at(v1),
                        v2: at(v2),
                    }
                }));
                alpha.extend(object_alpha(scene, mesh, &material_alpha));
            }
            shape_blas.push(levels.add_blas(&triangles, None, &alpha)?);
        }
        for copy in &trees.copies {
            if let Some(blas) = shape_blas[copy.shape] {
                levels.instances.push(Instance {
                    blas,
                    placement: Placement::Node(copy.root),
                    triangle_base: copy.first_triangle,
                });
            }
        }
        // One level per mesh, shared by the moving (or placed static) nodes that instance it.
        let mut mesh_blas: Vec<Option<Option<usize>>> = vec![None; scene.meshes.len()];
        for (node_index, node) in scene.nodes.iter().enumerate() {
            let (Some(mesh), Some(base)) = (node.mesh, first_triangle[node_index]) else {
                continue;
            };
            let blas = match mesh_blas.get(mesh).copied().flatten() {
                Some(blas) => blas,
                None => {
                    let alpha = object_alpha(scene, mesh, &material_alpha);
                    let blas = levels.add_blas(&object_triangles(scene, mesh), None, &alpha)?;
                    if let Some(slot) = mesh_blas.get_mut(mesh) {
                        *slot = Some(blas);
                    }
                    blas
                }
            };
            if let Some(blas) = blas {
                levels.instances.push(Instance {
                    blas,
                    placement: Placement::Node(node_index),
                    triangle_base: base,
                });
            }
        }
        levels.fixed = FixedPart {
            nodes: levels.nodes.len(),
            triangles: levels.triangles.len(),
            depth: levels.depth,
            blases: levels.blases.len(),
            instances: levels.instances.len(),
        };
        levels.deforming = deforming_indices
            .into_iter()
            .filter(|indices| !indices.is_empty())
            .map(|frame_indices| DeformingNode {
                alpha: (frame_indices.iter())
                    .map(|&i| material_alpha(frame.attributes[i as usize].material as usize))
                    .collect(),
                frame_indices,
                level: None,
            })
            .collect();
        levels.build_deforming(frame)?;
        levels.finish();
        levels.build_time = start.elapsed();
        Ok(levels)
    }

    /// Whether some levels deform and must be rebuilt for every frame.
    pub fn has_deforming(&self) -> bool {
        !self.deforming.is_empty()
    }

    /// Nodes and primitives of the levels built once: the deforming levels start at these
    /// indices of [`BottomLevels::nodes`] and [`BottomLevels::triangles`].
    pub fn fixed_len(&self) -> (usize, usize) {
        (self.fixed.nodes, self.fixed.triangles)
    }

    /// Rebuilds the deforming nodes' levels over `frame`'s triangles (an evaluation of the
    /// scene the levels were built for), replacing the previous ones after the fixed levels.
    /// Cost: an obvhs build over the deforming triangles; nothing without deforming nodes.
    pub fn rebuild_deforming(&mut self, frame: &SceneFrame) -> Result<(), BvhError> {
        if self.deforming.is_empty() {
            return Ok(());
        }
        self.build_deforming(frame)?;
        self.finish();
        Ok(())
    }

    fn build_deforming(&mut self, frame: &SceneFrame) -> Result<(), BvhError> {
        let start = Instant::now();
        self.nodes.truncate(self.fixed.nodes);
        self.triangles.truncate(self.fixed.triangles);
        self.blases.truncate(self.fixed.blases);
        self.instances.truncate(self.fixed.instances);
        self.depth = self.fixed.depth;
        let mut deforming = std::mem::take(&mut self.deforming);
        let mut result = Ok(());
        for node in &mut deforming {
            node.level = None;
            // A frame of another scene cannot panic here: a missing triangle is degenerate.
            let triangles: Vec<Triangle> = (node.frame_indices.iter())
                .map(|&i| {
                    frame
                        .triangles
                        .get(i as usize)
                        .copied()
                        .unwrap_or(DEGENERATE)
                })
                .collect();
            let first = self.triangles.len();
            match self.add_blas_with(
                &triangles,
                Some(&node.frame_indices),
                &node.alpha,
                BvhBuildParams::fast_build(),
            ) {
                Ok(Some(blas)) => {
                    self.instances.push(Instance {
                        blas,
                        placement: Placement::Static,
                        triangle_base: 0,
                    });
                    let watched = self.subtree_ranges(self.blases[blas].root);
                    node.level = Some(DeformingLevel {
                        blas,
                        triangles: first..self.triangles.len(),
                        built_area: watched_area(&self.triangles, &watched),
                        watched,
                    });
                }
                Ok(None) => {}
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
        }
        self.deforming = deforming;
        self.refit_plan = self.plan_refit();
        self.deform_time = start.elapsed();
        result
    }

    /// Follows `frame` (an evaluation of the scene the levels were built for) with the
    /// deforming levels' trees kept: writes its vertices into their primitives and their new
    /// root boxes into the top level's inputs ([`DeformUpdate::Refit`]; the nodes then need
    /// the GPU refit). Builds them again instead ([`DeformUpdate::Rebuilt`]) when a level's
    /// upper nodes (root, children and grandchildren) have grown past `rebuild_growth` times
    /// the summed surface area they had when built: a tree fitted to one pose keeps its groups
    /// in another, where their boxes overlap and traversal slows (`gi-bench deform`: a tube
    /// bent by 90 degrees grows them 2.5x and costs rays aimed at it 1.4-1.7x). Cost: one pass
    /// over the deforming primitives and three over their boxes; a build when rebuilt.
    pub fn refit_deforming(
        &mut self,
        frame: &SceneFrame,
        rebuild_growth: f32,
    ) -> Result<DeformUpdate, BvhError> {
        let start = Instant::now();
        let mut rebuild = false;
        for node in &self.deforming {
            let Some(level) = &node.level else {
                continue;
            };
            let bounds = self.triangles[level.triangles.clone()]
                .par_chunks_mut(PARALLEL_PRIMITIVES)
                .map(|chunk| {
                    let mut bounds = Aabb::empty();
                    for tri in chunk {
                        let t = (frame.triangles.get(tri.triangle as usize))
                            .copied()
                            .unwrap_or(DEGENERATE);
                        (tri.a, tri.b, tri.c) = (t.v0.into(), t.v1.into(), t.v2.into());
                        bounds = bounds.union(&t.aabb());
                    }
                    bounds
                })
                .reduce(Aabb::empty, |a, b| a.union(&b));
            self.blases[level.blas].bounds = bounds;
            let area = watched_area(&self.triangles, &level.watched);
            rebuild |= area > rebuild_growth * level.built_area;
        }
        if rebuild {
            self.rebuild_deforming(frame)?;
            return Ok(DeformUpdate::Rebuilt);
        }
        self.deform_time = start.elapsed();
        Ok(DeformUpdate::Refit)
    }

    /// The growth of each deforming level's watched nodes since it was built: their summed
    /// surface area now over then (1 right after a build).
    pub fn deforming_growth(&self) -> Vec<f32> {
        (self.deforming.iter())
            .filter_map(|node| node.level.as_ref())
            .map(|level| watched_area(&self.triangles, &level.watched) / level.built_area)
            .collect()
    }

    /// The primitive ranges of the subtrees of `root`'s nodes down to [`WATCHED_DEPTH`].
    fn subtree_ranges(&self, root: u32) -> Vec<std::ops::Range<usize>> {
        let mut ranges = Vec::new();
        let mut pending = vec![(root, 0)];
        while let Some((index, depth)) = pending.pop() {
            ranges.push(self.subtree_range(index));
            if depth < WATCHED_DEPTH {
                let node = &self.nodes[index as usize];
                let internal = (node.imask as u32).count_ones();
                pending.extend((0..internal).map(|k| (node.child_base_idx + k, depth + 1)));
            }
        }
        ranges
    }

    /// The primitives below node `index`: from its first leaf primitive to the end of its last
    /// internal child's subtree (obvhs lays a node's leaf primitives out before its children's).
    fn subtree_range(&self, index: u32) -> std::ops::Range<usize> {
        let node = &self.nodes[index as usize];
        let mut end = node.primitive_base_idx as usize;
        for slot in 0..8 {
            let info = node.child_meta[slot];
            if info != 0 && node.imask & (1 << slot) == 0 {
                let first = node.primitive_base_idx as usize + usize::from(info & 0x1f);
                end = end.max(first + (info & 0xe0).count_ones() as usize);
            }
        }
        let internal = (node.imask as u32).count_ones();
        if internal > 0 {
            end = end.max(self.subtree_range(node.child_base_idx + internal - 1).end);
        }
        node.primitive_base_idx as usize..end
    }

    /// The deforming levels' nodes grouped by depth below their roots, deepest first.
    fn plan_refit(&self) -> RefitPlan {
        let mut by_depth: Vec<(u32, u32)> = Vec::new();
        let mut pending: Vec<(u32, u32)> = (self.deforming.iter())
            .filter_map(|node| node.level.as_ref())
            .map(|level| (self.blases[level.blas].root, 0))
            .collect();
        while let Some((index, depth)) = pending.pop() {
            by_depth.push((depth, index));
            // A node's internal children are consecutive from `child_base_idx`.
            let node = &self.nodes[index as usize];
            let internal = (node.imask as u32).count_ones();
            pending.extend((0..internal).map(|k| (node.child_base_idx + k, depth + 1)));
        }
        by_depth.sort_unstable_by_key(|&(depth, index)| (std::cmp::Reverse(depth), index));
        let mut plan = RefitPlan::default();
        for (position, &(depth, index)) in by_depth.iter().enumerate() {
            match plan.steps.last_mut() {
                Some(step) if by_depth[step.0 as usize].0 == depth => step.1 += 1,
                _ => plan.steps.push((position as u32, 1)),
            }
            plan.order.push(index);
        }
        plan
    }

    /// The deforming levels' nodes in refit order (empty without deforming nodes).
    pub fn refit_plan(&self) -> &RefitPlan {
        &self.refit_plan
    }

    /// One world-space level from an already built CWBVH over `frame_triangles`, placed with
    /// the identity: the plain single-BVH case, for tests and benchmarks of traversal alone.
    pub fn single(bvh: &CwBvh, frame_triangles: &[Triangle]) -> Result<Self, BvhError> {
        let start = Instant::now();
        let mut levels = Self::empty();
        if !bvh.nodes.is_empty() {
            let packed = PackedBvh::new(bvh, frame_triangles)?;
            let blas = levels.append(packed, compute_bounds(frame_triangles));
            levels.instances.push(Instance {
                blas,
                placement: Placement::Static,
                triangle_base: 0,
            });
        }
        levels.finish();
        levels.build_time = start.elapsed();
        Ok(levels)
    }

    fn empty() -> Self {
        Self {
            nodes: Vec::new(),
            triangles: Vec::new(),
            depth: 0,
            build_time: Duration::ZERO,
            deform_time: Duration::ZERO,
            blases: Vec::new(),
            instances: Vec::new(),
            fixed: FixedPart::default(),
            deforming: Vec::new(),
            refit_plan: RefitPlan::default(),
        }
    }

    /// Builds and appends a level over `triangles` with `gi_scene::traversal_build`;
    /// `frame_indices[i]` replaces primitive `i`'s stored index when given, `alpha[i]` flags
    /// triangle `i` as alpha-tested. `None` for an empty list.
    fn add_blas(
        &mut self,
        triangles: &[Triangle],
        frame_indices: Option<&[u32]>,
        alpha: &[bool],
    ) -> Result<Option<usize>, BvhError> {
        self.add_blas_with(triangles, frame_indices, alpha, gi_scene::traversal_build())
    }

    /// [`BottomLevels::add_blas`] with the given build parameters.
    fn add_blas_with(
        &mut self,
        triangles: &[Triangle],
        frame_indices: Option<&[u32]>,
        alpha: &[bool],
        params: BvhBuildParams,
    ) -> Result<Option<usize>, BvhError> {
        if triangles.is_empty() {
            return Ok(None);
        }
        // The tree on tie-breaking bounds, the boxes exact but for cut pieces' few ulps (as the
        // CPU's SceneBvh).
        let bvh = gi_scene::build_triangle_cwbvh(triangles, params);
        let mut packed = PackedBvh::new(&bvh, triangles)?;
        for tri in &mut packed.triangles {
            if alpha.get(tri.triangle as usize).copied().unwrap_or(false) {
                tri.flags |= BVH_TRIANGLE_ALPHA;
            }
        }
        if let Some(map) = frame_indices {
            for tri in &mut packed.triangles {
                tri.triangle = map[tri.triangle as usize];
            }
        }
        Ok(Some(self.append(packed, compute_bounds(triangles))))
    }

    fn append(&mut self, packed: PackedBvh, bounds: Aabb) -> usize {
        let node_base = self.nodes.len() as u32;
        let primitive_base = self.triangles.len() as u32;
        self.nodes.extend(packed.nodes.into_iter().map(|mut node| {
            node.child_base_idx += node_base;
            node.primitive_base_idx += primitive_base;
            node
        }));
        self.triangles.extend(packed.triangles);
        self.depth = self.depth.max(packed.depth);
        self.blases.push(Blas {
            root: node_base,
            bounds,
        });
        self.blases.len() - 1
    }

    /// Storage bindings may not be empty: a scene without triangles keeps one childless node
    /// and one unread primitive.
    fn finish(&mut self) {
        if self.nodes.is_empty() {
            self.nodes.push(GpuCwBvhNode::default());
            self.triangles.push(GpuBvhTriangle::default());
        }
    }

    /// Number of instances (the static level counts as one).
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Number of bottom levels.
    pub fn blas_count(&self) -> usize {
        self.blases.len()
    }

    /// Builds the top level over the instances placed with `world_from_node` (a frame's
    /// transforms; ignored by static instances). Fails when the two levels together could
    /// overflow the traversal stack.
    pub fn top_level(&self, world_from_node: &[Mat4]) -> Result<TopLevel, BvhError> {
        let start = Instant::now();
        let mut boxes = Vec::with_capacity(self.instances.len());
        let mut gpu_instances = Vec::with_capacity(self.instances.len());
        for instance in &self.instances {
            let blas = self.blases[instance.blas];
            let world_from_object = match instance.placement {
                Placement::Static => None,
                Placement::Node(node) => {
                    Some(world_from_node.get(node).copied().unwrap_or(Mat4::IDENTITY))
                }
            };
            boxes.push(match world_from_object {
                None => blas.bounds,
                Some(m) => padded(transform_bounds(&blas.bounds, &m)),
            });
            gpu_instances.push(gpu_instance(
                blas.root,
                instance.triangle_base,
                world_from_object,
            ));
        }
        let (nodes, instances, depth) = if boxes.is_empty() {
            (
                vec![GpuCwBvhNode::default()],
                vec![GpuBvhInstance::default()],
                0,
            )
        } else {
            let params = BvhBuildParams {
                // Each instance entered costs a ray transform: one per leaf keeps culling exact.
                max_prims_per_leaf: 1,
                ..BvhBuildParams::fast_build()
            };
            // Coincident instances tie exactly, as coincident triangles do.
            let bvh = gi_scene::build_cwbvh(&boxes, params);
            let depth = gi_scene::cwbvh_depth(&bvh);
            let nodes = bvh.nodes.iter().map(GpuCwBvhNode::from).collect();
            let instances = bvh
                .primitive_indices
                .iter()
                .map(|&i| gpu_instances[i as usize])
                .collect();
            (nodes, instances, depth)
        };
        // Top-level groups, then the leaf and node group pushed on entering an instance, then
        // the bottom level's own groups.
        let combined = depth + 2 + self.depth;
        if combined > BVH_STACK_SIZE {
            return Err(BvhError::TooDeep { depth: combined });
        }
        Ok(TopLevel {
            nodes,
            instances,
            depth,
            build_time: start.elapsed(),
        })
    }
}

/// Summed half surface areas of the boxes of `watched`'s primitive ranges of `triangles`.
fn watched_area(triangles: &[GpuBvhTriangle], watched: &[std::ops::Range<usize>]) -> f32 {
    let areas: Vec<f32> = watched
        .par_iter()
        .map(|range| {
            let mut bounds = Aabb::empty();
            for tri in &triangles[range.clone()] {
                for v in [tri.a, tri.b, tri.c] {
                    bounds.extend(Vec3A::from(v));
                }
            }
            bounds.half_area()
        })
        .collect();
    // Summed in a fixed order, so the decision does not depend on the threads.
    areas.iter().sum()
}

/// Deforming primitives written per task in [`BottomLevels::refit_deforming`].
const PARALLEL_PRIMITIVES: usize = 8192;

/// A triangle standing in for one missing from a frame: a point at the origin, never hit.
const DEGENERATE: Triangle = Triangle {
    v0: Vec3A::ZERO,
    v1: Vec3A::ZERO,
    v2: Vec3A::ZERO,
};

/// The triangles of mesh `mesh` in object space, in the order `Scene::evaluate` emits them
/// (winding as authored: a mirroring instance swaps barycentrics instead).
/// Per triangle of `mesh`, in [`object_triangles`] order: whether its material is
/// alpha-tested.
fn object_alpha(scene: &Scene, mesh: usize, material_alpha: &impl Fn(usize) -> bool) -> Vec<bool> {
    let Some(mesh) = scene.meshes.get(mesh) else {
        return Vec::new();
    };
    mesh.primitives
        .iter()
        .flat_map(|p| std::iter::repeat_n(material_alpha(p.material), p.indices.len() / 3))
        .collect()
}

fn object_triangles(scene: &Scene, mesh: usize) -> Vec<Triangle> {
    let Some(mesh) = scene.meshes.get(mesh) else {
        return Vec::new();
    };
    mesh.primitives
        .iter()
        .flat_map(|primitive| {
            primitive.indices.chunks_exact(3).map(|tri| {
                let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| primitive.positions[i as usize]);
                Triangle {
                    v0: a.into(),
                    v1: b.into(),
                    v2: c.into(),
                }
            })
        })
        .collect()
}

fn gpu_instance(
    blas_root: u32,
    triangle_base: u32,
    world_from_object: Option<Mat4>,
) -> GpuBvhInstance {
    let Some(world_from_object) = world_from_object else {
        return GpuBvhInstance {
            object_from_world: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            blas_root,
            triangle_base,
            flags: BVH_INSTANCE_IDENTITY,
            pad: 0,
        };
    };
    // Rows of the affine part: the shader computes `vec4(p, 1) * object_from_world`.
    let rows = world_from_object.inverse().transpose();
    let mirrored = world_from_object.determinant() < 0.0;
    GpuBvhInstance {
        object_from_world: [rows.x_axis, rows.y_axis, rows.z_axis].map(|r| r.to_array()),
        blas_root,
        triangle_base,
        flags: if mirrored { BVH_INSTANCE_MIRRORED } else { 0 },
        pad: 0,
    }
}

fn compute_bounds(triangles: &[Triangle]) -> Aabb {
    let mut bounds = Aabb::empty();
    for tri in triangles {
        bounds = bounds.union(&tri.aabb());
    }
    bounds
}

/// World box of an object-space box: its eight corners transformed.
fn transform_bounds(bounds: &Aabb, world_from_object: &Mat4) -> Aabb {
    let mut world = Aabb::empty();
    for corner in 0..8 {
        let pick = |bit: usize, axis: usize| {
            if corner & bit == 0 {
                bounds.min[axis]
            } else {
                bounds.max[axis]
            }
        };
        let p = glam::Vec3::new(pick(1, 0), pick(2, 1), pick(4, 2));
        world.extend(Vec3A::from(world_from_object.transform_point3(p)));
    }
    world
}

/// Grows a transformed box by a few ulps of its size and position: the corners went through
/// f32 rounding, and a box a hair too small would cull rays that graze the instance.
fn padded(bounds: Aabb) -> Aabb {
    let scale =
        bounds.max.abs().max(bounds.min.abs()).max_element() + bounds.diagonal().max_element();
    let pad = Vec3A::splat(scale * 1e-5 + f32::MIN_POSITIVE);
    Aabb::new(bounds.min - pad, bounds.max + pad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every primitive a node's subtree reaches by traversal, as a sorted list.
    fn reached(levels: &BottomLevels, index: u32) -> Vec<usize> {
        let node = &levels.nodes[index as usize];
        let mut out = Vec::new();
        let mut rank = 0;
        for slot in 0..8 {
            let info = node.child_meta[slot];
            if info == 0 {
                continue;
            }
            if node.imask & (1 << slot) != 0 {
                out.extend(reached(levels, node.child_base_idx + rank));
                rank += 1;
            } else {
                let first = node.primitive_base_idx as usize + usize::from(info & 0x1f);
                out.extend(first..first + (info & 0xe0).count_ones() as usize);
            }
        }
        out.sort_unstable();
        out
    }

    /// A subtree's primitives are one contiguous range, the one `subtree_range` gives, for
    /// every node of a deforming level; the watched ranges are the top three depths'.
    #[test]
    fn subtree_ranges_are_the_primitives_below_each_node() {
        let scene = gi_scene::generate::skinned_tube(64, 24);
        let frame = scene.evaluate(0.5, None);
        let levels = BottomLevels::from_scene(&scene, &frame).expect("builds");
        let (fixed_nodes, _) = levels.fixed_len();
        assert!(
            levels.nodes.len() - fixed_nodes > 73,
            "a level deeper than the watched part"
        );
        for index in fixed_nodes..levels.nodes.len() {
            let range = levels.subtree_range(index as u32);
            assert_eq!(reached(&levels, index as u32), range.collect::<Vec<_>>());
        }
        let level = levels.deforming[0]
            .level
            .as_ref()
            .expect("the arm has a level");
        assert_eq!(
            level.watched[0], level.triangles,
            "the root's range is the level's"
        );
        assert!(level.watched.len() > 9 && level.watched.len() <= 73);
        assert_eq!(levels.deforming_growth(), vec![1.0]);
    }
}

//! A four-wide BVH for tracing rays one at a time on the CPU: uncompressed f32 child boxes
//! tested four at a time (one SSE register per coordinate on x86-64, glam's portable `Vec4`
//! elsewhere) and leaves of up to four triangles tested together.

use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A, Vec4};
use obvhs::{
    BvhBuildParams,
    bvh2::{Bvh2, builder::build_bvh2},
    ray::Ray,
    triangle::Triangle,
};

use super::canonical_direction;
use super::leaves::{LANES, TriangleLanes, intersect_lanes, triangle_lanes};

/// Children per node: one SIMD lane each.
const WIDTH: usize = 4;

/// Marks a child slot that holds a leaf: bits 0..29 are its index in `WideBvh::leaves` and
/// bits 29..31 its triangle count minus one.
const LEAF_FLAG: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 29;
const LEAF_FIRST_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
/// An unused child slot (its box is empty, so no ray ever enters it).
const EMPTY_CHILD: u32 = u32::MAX;

/// Widening of a box's exit distance so that rounding in the slab test never culls a box the
/// exact ray enters: `1 + 2 * gamma(3)` of Ize's "Robust BVH Ray Traversal" (2013), where
/// `gamma(n) = n * eps / (1 - n * eps)` and `eps` is half an ulp of 1.
const EXIT_SCALE: f32 = 1.0 + 2.0 * (3.0 * 0.5 * f32::EPSILON) / (1.0 - 3.0 * 0.5 * f32::EPSILON);

/// Entries the traversal stack holds without allocating; deeper trees spill to the heap.
const INLINE_STACK: usize = 64;

/// One node: the boxes of up to four children as a structure of arrays (lane `i` is child
/// `i`), and what each child is.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    /// min x, min y, min z, max x, max y, max z of each child's box.
    bounds: [Vec4; 6],
    /// Per child: a node index, a leaf (`LEAF_FLAG`) or [`EMPTY_CHILD`].
    children: [u32; WIDTH],
    /// Bit `i` set when child `i` is a leaf.
    leaves: u32,
}

/// Up to four triangles, tested together.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Leaf {
    lanes: TriangleLanes,
    /// The scene's index of the triangle in each lane.
    triangles: [u32; LANES],
    /// Lanes in use.
    count: u32,
}

/// A four-wide BVH over world-space triangles with closest-hit and any-hit queries.
///
/// Built from obvhs' binary PLOC BVH (one triangle per leaf) by pulling the largest children
/// up until each node has four; any subtree of at most four triangles becomes one leaf.
/// The triangles are tested with the same arithmetic as obvhs' `Triangle::intersect`, so a
/// hit's distance is bit for bit what [`super::SceneBvh`] reports for the same triangle.
pub struct WideBvh {
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
    /// The root when it is a leaf or empty ([`EMPTY_CHILD`]), else 0 (the first node).
    root: u32,
    /// Wall time of the whole build (binary BVH, conversion, leaf triangles).
    pub build_time: Duration,
}

/// A child of a node under construction: a Bvh2 node, its box and triangle count.
#[derive(Clone, Copy)]
struct Child {
    bvh2_node: usize,
    min: Vec3A,
    max: Vec3A,
    triangles: u32,
}

impl Child {
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        (d.x + d.y) * d.z + d.x * d.y
    }
}

/// Per-ray constants of the box test.
struct RayBoxes {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Per axis, which of `Node::bounds` is the near plane (the far one is 3 further along or
    /// back).
    near: [usize; 3],
    far: [usize; 3],
    /// Bit `axis` set when the direction's component along it is zero (or so small that its
    /// inverse overflows): the ray then runs parallel to that axis's slabs and is inside one
    /// for all `t` or never.
    parallel: u32,
}

impl RayBoxes {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let d = [ray.direction.x, ray.direction.y, ray.direction.z];
        let inv_dir = d.map(|d| 1.0 / d);
        let parallel = (0..3)
            .filter(|&axis| !inv_dir[axis].is_finite())
            .fold(0, |mask, axis| mask | 1 << axis);
        let near = inv_dir.map(|i| usize::from(i < 0.0) * 3);
        Self {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z].map(Vec4::splat),
            inv_dir: inv_dir.map(Vec4::splat),
            near: [near[0], near[1] + 1, near[2] + 2],
            far: [3 - near[0], 4 - near[1], 5 - near[2]],
            parallel,
        }
    }

    /// Entry distances of the node's four boxes and a mask of those the segment
    /// `[t_min, t_max]` enters.
    #[inline(always)]
    fn test(&self, node: &Node, t_min: f32, t_max: f32) -> (Vec4, u32) {
        let b = &node.bounds;
        let (near, far) = if self.parallel == 0 {
            let slab =
                |plane: usize, axis: usize| (b[plane] - self.origin[axis]) * self.inv_dir[axis];
            (
                slab(self.near[0], 0)
                    .max(slab(self.near[1], 1))
                    .max(slab(self.near[2], 2)),
                slab(self.far[0], 0)
                    .min(slab(self.far[1], 1))
                    .min(slab(self.far[2], 2)),
            )
        } else {
            self.parallel_slabs(node)
        };
        let near = near.max(Vec4::splat(t_min));
        let far = far.min(Vec4::splat(t_max)) * EXIT_SCALE;
        (near, near.cmple(far).bitmask())
    }

    /// [`RayBoxes::test`]'s entry and exit distances for a ray parallel to some slabs: along
    /// such an axis the box is entered for all `t` when the origin lies within the slab
    /// (boundary included), else never.
    #[cold]
    fn parallel_slabs(&self, node: &Node) -> (Vec4, Vec4) {
        let b = &node.bounds;
        let mut near = Vec4::NEG_INFINITY;
        let mut far = Vec4::INFINITY;
        for axis in 0..3 {
            if self.parallel & (1 << axis) != 0 {
                let o = self.origin[axis];
                let inside = b[axis].cmple(o) & o.cmple(b[3 + axis]);
                near = near.max(Vec4::select(inside, Vec4::NEG_INFINITY, Vec4::INFINITY));
                far = far.min(Vec4::select(inside, Vec4::INFINITY, Vec4::NEG_INFINITY));
            } else {
                let slab = |plane: usize| (b[plane] - self.origin[axis]) * self.inv_dir[axis];
                near = near.max(slab(self.near[axis]));
                far = far.min(slab(self.far[axis]));
            }
        }
        (near, far)
    }
}

/// A traversal stack of (node index, entry distance): inline up to [`INLINE_STACK`] entries,
/// then on the heap.
struct Stack {
    inline: [std::mem::MaybeUninit<(u32, f32)>; INLINE_STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            inline: [const { std::mem::MaybeUninit::uninit() }; INLINE_STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, node: u32, t: f32) {
        if self.len < INLINE_STACK {
            // SAFETY: `len` is in bounds of the inline array.
            unsafe { self.inline.get_unchecked_mut(self.len).write((node, t)) };
            self.len += 1;
        } else {
            self.spill.push((node, t));
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.len == INLINE_STACK
            && let Some(top) = self.spill.pop()
        {
            return Some(top);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: the entries below `len` were written by `push`.
        Some(unsafe { self.inline.get_unchecked(self.len).assume_init() })
    }
}

impl WideBvh {
    /// Builds with obvhs' `medium_build` PLOC settings.
    pub fn build(triangles: &[Triangle]) -> Self {
        let start = Instant::now();
        let params = BvhBuildParams {
            // One triangle per binary leaf: this builder forms its own leaves.
            max_prims_per_leaf: 1,
            ..BvhBuildParams::medium_build()
        };
        let bvh2 = if triangles.is_empty() {
            Bvh2::default()
        } else {
            build_bvh2(
                &super::tie_breaking_bounds(triangles),
                params,
                &mut Default::default(),
            )
        };
        let mut builder = Builder::new(&bvh2, triangles);
        let root = if bvh2.nodes.is_empty() {
            EMPTY_CHILD
        } else {
            builder.entry(builder.subtrees[0])
        };
        let Builder { nodes, leaves, .. } = builder;
        Self {
            nodes,
            leaves,
            root,
            build_time: start.elapsed(),
        }
    }

    /// Bytes of the nodes and leaves.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.leaves.as_slice())
    }

    /// Number of nodes (for reports).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Distance and triangle index of the nearest intersection of the ray
    /// `origin + t * dir`, `t` in `[t_min, t_max]`. Of several triangles at the same distance
    /// it reports the first one tested.
    pub fn closest_triangle(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, u32)> {
        if self.root == EMPTY_CHILD {
            return None;
        }
        let mut ray = leaf_ray(origin, dir, t_min, t_max);
        let mut nearest = None;
        if self.root & LEAF_FLAG != 0 {
            self.nearest_in_leaf(self.root, &mut ray, &mut nearest);
            return nearest.map(|(leaf, lane)| (ray.tmax, self.leaves[leaf].triangles[lane]));
        }
        let boxes = RayBoxes::new(&ray);
        let mut stack = Stack::new();
        let mut node = self.root;
        loop {
            let n = &self.nodes[node as usize];
            let (t_near, hit) = boxes.test(n, ray.tmin, ray.tmax);
            // Leaves are tested at once, nearest first; what they find shortens the ray
            // before the inner children are ordered.
            let leaves = hit & n.leaves;
            if leaves != 0 {
                if leaves & (leaves - 1) != 0 {
                    let mut order = [(0u32, 0.0f32); WIDTH];
                    let count = sort_lanes(leaves, &t_near, &mut order);
                    for &(lane, t) in &order[..count] {
                        if t <= ray.tmax * EXIT_SCALE {
                            self.nearest_in_leaf(n.children[lane as usize], &mut ray, &mut nearest);
                        }
                    }
                } else {
                    let lane = leaves.trailing_zeros() as usize;
                    self.nearest_in_leaf(n.children[lane], &mut ray, &mut nearest);
                }
            }
            let inner =
                hit & !n.leaves & t_near.cmple(Vec4::splat(ray.tmax * EXIT_SCALE)).bitmask();
            if inner != 0 && inner & (inner - 1) == 0 {
                node = n.children[inner.trailing_zeros() as usize];
                continue;
            }
            if inner != 0 {
                // Push the farther children, farthest first, and go on with the nearest.
                let mut order = [(0u32, 0.0f32); WIDTH];
                let count = sort_lanes(inner, &t_near, &mut order);
                for &(lane, t) in &order[1..count] {
                    stack.push(n.children[lane as usize], t);
                }
                node = n.children[order[0].0 as usize];
                continue;
            }
            // Pop the nearest pending node the ray still reaches.
            loop {
                let Some((next, t)) = stack.pop() else {
                    return nearest
                        .map(|(leaf, lane)| (ray.tmax, self.leaves[leaf].triangles[lane]));
                };
                if t <= ray.tmax * EXIT_SCALE {
                    node = next;
                    break;
                }
            }
        }
    }

    /// Tests the triangles of leaf `entry`, shortening `ray` to the nearest one it crosses
    /// before its end (in lane order among equals) and recording it in `nearest`.
    #[inline(always)]
    fn nearest_in_leaf(&self, entry: u32, ray: &mut Ray, nearest: &mut Option<(usize, usize)>) {
        let (leaf, count) = leaf_range(entry);
        let (t, hit) = intersect_lanes(&self.leaves[leaf].lanes, ray);
        let mut hit = hit & ((1 << count) - 1);
        while hit != 0 {
            let lane = hit.trailing_zeros() as usize;
            hit &= hit - 1;
            if t[lane] < ray.tmax {
                ray.tmax = t[lane];
                *nearest = Some((leaf, lane));
            }
        }
    }

    /// Whether leaf `entry` has a triangle crossing `ray` at a `t` in `[tmin, tmax)`.
    #[inline(always)]
    fn leaf_blocks(&self, entry: u32, ray: &Ray) -> bool {
        let (leaf, count) = leaf_range(entry);
        let (t, hit) = intersect_lanes(&self.leaves[leaf].lanes, ray);
        let before_end = t.cmplt(Vec4::splat(ray.tmax)).bitmask();
        hit & before_end & ((1 << count) - 1) != 0
    }

    /// True when any triangle crosses the ray `origin + t * dir` at a `t` in `[t_min, t_max)`
    /// (stops at the first one found).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        if self.root == EMPTY_CHILD {
            return false;
        }
        let ray = leaf_ray(origin, dir, t_min, t_max);
        if self.root & LEAF_FLAG != 0 {
            return self.leaf_blocks(self.root, &ray);
        }
        let boxes = RayBoxes::new(&ray);
        let mut stack = Stack::new();
        let mut node = self.root;
        loop {
            let n = &self.nodes[node as usize];
            let (_, hit) = boxes.test(n, ray.tmin, ray.tmax);
            let mut leaves = hit & n.leaves;
            while leaves != 0 {
                let lane = leaves.trailing_zeros() as usize;
                leaves &= leaves - 1;
                if self.leaf_blocks(n.children[lane], &ray) {
                    return true;
                }
            }
            let mut inner = hit & !n.leaves;
            if inner != 0 {
                let lane = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                node = n.children[lane];
                while inner != 0 {
                    let lane = inner.trailing_zeros() as usize;
                    inner &= inner - 1;
                    stack.push(n.children[lane], 0.0);
                }
                continue;
            }
            match stack.pop() {
                Some((next, _)) => node = next,
                None => return false,
            }
        }
    }
}

/// The lanes of `mask` with their distances in `t`, nearest first (lower lane first among
/// equals) into `order`; returns how many.
#[inline(always)]
fn sort_lanes(mut mask: u32, t: &Vec4, order: &mut [(u32, f32); WIDTH]) -> usize {
    let mut count = 0;
    while mask != 0 {
        let lane = mask.trailing_zeros();
        mask &= mask - 1;
        let item = (lane, t[lane as usize]);
        let mut i = count;
        while i > 0 && order[i - 1].1 > item.1 {
            order[i] = order[i - 1];
            i -= 1;
        }
        order[i] = item;
        count += 1;
    }
    count
}

/// The ray as the triangle test reads it: the direction with its zeros made positive, as
/// [`super::SceneBvh`] gives it (the sign of a zero can decide a hit on an edge). Its inverse
/// direction is left out: the box test computes its own.
#[inline(always)]
fn leaf_ray(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Ray {
    Ray {
        origin: Vec3A::from(origin),
        direction: canonical_direction(dir),
        inv_direction: Vec3A::ZERO,
        tmin: t_min,
        tmax: t_max,
    }
}

/// Index in `WideBvh::leaves` and triangle count of a leaf entry.
#[inline(always)]
fn leaf_range(entry: u32) -> (usize, u32) {
    (
        (entry & LEAF_FIRST_MASK) as usize,
        ((entry >> LEAF_COUNT_SHIFT) & 3) + 1,
    )
}

struct Builder<'a> {
    bvh2: &'a Bvh2,
    /// Per Bvh2 node: the subtree as a child (box and triangle count).
    subtrees: Vec<Child>,
    triangles: &'a [Triangle],
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
}

impl<'a> Builder<'a> {
    fn new(bvh2: &'a Bvh2, triangles: &'a [Triangle]) -> Self {
        let empty = Child {
            bvh2_node: 0,
            min: Vec3A::INFINITY,
            max: Vec3A::NEG_INFINITY,
            triangles: 0,
        };
        let mut subtrees = vec![empty; bvh2.nodes.len()];
        // Nodes in depth-first pre-order, so the reverse sweep below sees every child before
        // its parent.
        let mut preorder = Vec::with_capacity(bvh2.nodes.len());
        let mut pending = if bvh2.nodes.is_empty() {
            vec![]
        } else {
            vec![0usize]
        };
        while let Some(index) = pending.pop() {
            preorder.push(index);
            let node = &bvh2.nodes[index];
            if !node.is_leaf() {
                pending.extend([node.first_index as usize, node.first_index as usize + 1]);
            }
        }
        // The boxes come from the vertices, exact, so the box test's rounding bound holds.
        for &index in preorder.iter().rev() {
            let node = &bvh2.nodes[index];
            let mut child = Child {
                bvh2_node: index,
                ..empty
            };
            if node.is_leaf() {
                let first = node.first_index as usize;
                for &p in &bvh2.primitive_indices[first..first + node.prim_count as usize] {
                    let tri = &triangles[p as usize];
                    child.min = child.min.min(tri.v0).min(tri.v1).min(tri.v2);
                    child.max = child.max.max(tri.v0).max(tri.v1).max(tri.v2);
                }
                child.triangles = node.prim_count;
            } else {
                for side in [0, 1] {
                    let c = &subtrees[node.first_index as usize + side];
                    child.min = child.min.min(c.min);
                    child.max = child.max.max(c.max);
                    child.triangles += c.triangles;
                }
            }
            subtrees[index] = child;
        }
        Self {
            bvh2,
            subtrees,
            triangles,
            nodes: Vec::new(),
            leaves: Vec::new(),
        }
    }

    /// The children of a Bvh2 inner node.
    fn split(&self, child: &Child) -> [Child; 2] {
        let first = self.bvh2.nodes[child.bvh2_node].first_index as usize;
        [self.subtrees[first], self.subtrees[first + 1]]
    }

    /// Whether `child` becomes one leaf.
    fn is_leaf(&self, child: &Child) -> bool {
        child.triangles as usize <= LANES || self.bvh2.nodes[child.bvh2_node].is_leaf()
    }

    /// The entry (node index or leaf) of `child`, emitting its nodes and leaf triangles.
    fn entry(&mut self, child: Child) -> u32 {
        if self.is_leaf(&child) {
            return self.leaf(&child);
        }
        let mut children = self.split(&child).to_vec();
        // Open the largest inner child until the node is full.
        while children.len() < WIDTH {
            let Some(largest) = (0..children.len())
                .filter(|&i| !self.is_leaf(&children[i]))
                .max_by(|&a, &b| children[a].half_area().total_cmp(&children[b].half_area()))
            else {
                break;
            };
            let opened = children.swap_remove(largest);
            children.extend(self.split(&opened));
        }
        let index = self.nodes.len();
        self.nodes.push(Node {
            bounds: [
                Vec4::INFINITY,
                Vec4::INFINITY,
                Vec4::INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::NEG_INFINITY,
            ],
            children: [EMPTY_CHILD; WIDTH],
            leaves: 0,
        });
        for (lane, child) in children.into_iter().enumerate() {
            let entry = self.entry(child);
            let node = &mut self.nodes[index];
            node.children[lane] = entry;
            if entry & LEAF_FLAG != 0 {
                node.leaves |= 1 << lane;
            }
            for axis in 0..3 {
                node.bounds[axis][lane] = child.min[axis];
                node.bounds[3 + axis][lane] = child.max[axis];
            }
        }
        index as u32
    }

    /// Emits the at most four triangles under `child` as one leaf.
    fn leaf(&mut self, child: &Child) -> u32 {
        let mut indices = Vec::with_capacity(LANES);
        self.collect(child.bvh2_node, &mut indices);
        let count = indices.len();
        assert!(
            (1..=LANES).contains(&count),
            "a Bvh2 leaf holds {count} triangles, more than a leaf of the wide BVH"
        );
        let index = self.leaves.len();
        assert!(
            index as u32 <= LEAF_FIRST_MASK,
            "too many leaves for the wide BVH"
        );
        let triangles: Vec<&Triangle> = indices
            .iter()
            .map(|&i| &self.triangles[i as usize])
            .collect();
        let mut lane_triangles = [0; LANES];
        lane_triangles[..count].copy_from_slice(&indices);
        self.leaves.push(Leaf {
            lanes: triangle_lanes(&triangles),
            triangles: lane_triangles,
            count: count as u32,
        });
        LEAF_FLAG | ((count as u32 - 1) << LEAF_COUNT_SHIFT) | index as u32
    }

    /// Appends the triangles under Bvh2 node `index` to `out`.
    fn collect(&self, index: usize, out: &mut Vec<u32>) {
        let node = &self.bvh2.nodes[index];
        if node.is_leaf() {
            let first = node.first_index as usize;
            out.extend(&self.bvh2.primitive_indices[first..first + node.prim_count as usize]);
        } else {
            self.collect(node.first_index as usize, out);
            self.collect(node.first_index as usize + 1, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::SceneBvh;
    use super::*;

    /// A small deterministic generator (no dependency on the sampler of another crate).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }

        fn point(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next()) * (2.0 * scale) - scale
        }

        fn direction(&mut self) -> Vec3 {
            loop {
                let d = self.point(1.0);
                if d.length_squared() > 1e-4 && d.length_squared() <= 1.0 {
                    return d.normalize();
                }
            }
        }
    }

    fn tri(v0: Vec3, v1: Vec3, v2: Vec3) -> Triangle {
        Triangle {
            v0: v0.into(),
            v1: v1.into(),
            v2: v2.into(),
        }
    }

    /// An axis-aligned box of `half` extent about `center` as twelve triangles.
    fn cube(center: Vec3, half: Vec3) -> Vec<Triangle> {
        let corner = |i: usize| {
            center
                + half
                    * Vec3::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { -1.0 } else { 1.0 },
                    )
        };
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        faces
            .iter()
            .flat_map(|f| {
                [
                    tri(corner(f[0]), corner(f[1]), corner(f[2])),
                    tri(corner(f[0]), corner(f[2]), corner(f[3])),
                ]
            })
            .collect()
    }

    /// Scenes: a Cornell-like room of axis-aligned quads with two blocks inside, a cloud of
    /// random triangles, and both with degenerate triangles (a point, a line) mixed in.
    fn scenes() -> Vec<Vec<Triangle>> {
        let mut rng = Lcg(3);
        let mut room = cube(Vec3::ZERO, Vec3::ONE);
        room.extend(cube(Vec3::new(0.3, -0.6, 0.2), Vec3::splat(0.3)));
        room.extend(cube(Vec3::new(-0.4, -0.4, -0.3), Vec3::new(0.3, 0.6, 0.3)));
        let cloud: Vec<Triangle> = (0..500)
            .map(|_| {
                let c = rng.point(4.0);
                tri(c + rng.point(0.5), c + rng.point(0.5), c + rng.point(0.5))
            })
            .collect();
        let mut degenerate = room.clone();
        let p = Vec3::new(0.1, 0.2, 0.3);
        degenerate.push(tri(p, p, p));
        degenerate.push(tri(p, p + Vec3::X, p + 2.0 * Vec3::X));
        degenerate.extend(cloud.iter().take(100).copied());
        vec![
            Vec::new(),
            vec![tri(Vec3::ZERO, Vec3::X, Vec3::Y)],
            cube(Vec3::ZERO, Vec3::ONE)[..3].to_vec(),
            room,
            cloud,
            degenerate,
        ]
    }

    /// Closest hits and occlusion agree with testing every triangle on random rays, on rays
    /// along the axes (both signs of zero in the other components) and on rays running in the
    /// planes of walls and faces; and with the CWBVH traversal of [`SceneBvh`] almost always.
    #[test]
    fn agrees_with_the_cwbvh_traversal() {
        let mut rng = Lcg(11);
        for (s, triangles) in scenes().iter().enumerate() {
            let wide = WideBvh::build(triangles);
            let reference = SceneBvh::build(triangles);
            let mut rays: Vec<(Vec3, Vec3, f32)> = Vec::new();
            for _ in 0..4000 {
                let t_max = if rng.next() < 0.5 {
                    f32::INFINITY
                } else {
                    rng.next() * 4.0
                };
                rays.push((rng.point(1.5), rng.direction(), t_max));
            }
            for axis in [
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
                Vec3::NEG_X,
                Vec3::NEG_Y,
                Vec3::NEG_Z,
                Vec3::new(-0.0, 1.0, -0.0),
                Vec3::new(1.0, -0.0, 0.0),
            ] {
                for _ in 0..300 {
                    rays.push((rng.point(1.5), axis, f32::INFINITY));
                }
                // Along the planes of the room's walls and block faces.
                for plane in [-1.0, 1.0, -0.3, 0.5] {
                    let mut o = rng.point(1.5);
                    o[(axis.abs().max_position() + 1) % 3] = plane;
                    rays.push((o, axis, f32::INFINITY));
                }
            }
            let (mut hits, mut agree) = (0, 0);
            for &(origin, dir, t_max) in &rays {
                // Ground truth: every triangle tested with obvhs' own test.
                let ray = Ray::new(origin.into(), canonical_direction(dir), 0.0, t_max);
                let ts: Vec<f32> = triangles.iter().map(|tri| tri.intersect(&ray)).collect();
                let nearest = ts.iter().copied().fold(f32::INFINITY, f32::min);
                let got = wide.closest_triangle(origin, dir, 0.0, t_max);
                match got {
                    None => assert!(
                        nearest.is_infinite(),
                        "scene {s}: {ray:?}: missed {nearest}"
                    ),
                    Some((t, i)) => {
                        assert_eq!(t.to_bits(), nearest.to_bits(), "scene {s}: {ray:?}");
                        // Of triangles at exactly the same distance any may be reported.
                        assert_eq!(ts[i as usize].to_bits(), t.to_bits(), "scene {s}: {ray:?}");
                        hits += 1;
                    }
                }
                let blocked = ts.iter().any(|&t| t < t_max);
                assert_eq!(
                    wide.occluded(origin, dir, 0.0, t_max),
                    blocked,
                    "scene {s}: {ray:?}"
                );
                // The CWBVH traversal agrees except where its box test rejects a ray running
                // exactly along a flat box's face.
                let reference_hit = reference.closest_triangle(origin, dir, 0.0, t_max);
                if reference_hit.map(|(t, _)| t.to_bits()) == got.map(|(t, _)| t.to_bits())
                    && reference.occluded(triangles, origin, dir, 0.0, t_max) == blocked
                {
                    agree += 1;
                }
            }
            assert!(
                agree * 100 >= rays.len() * 99,
                "scene {s}: {agree} of {}",
                rays.len()
            );
            assert!(
                triangles.len() < 2 || hits > rays.len() / 10,
                "scene {s}: {hits}"
            );
        }
    }

    /// Every triangle appears in exactly one leaf.
    #[test]
    fn leaves_cover_every_triangle_once() {
        for triangles in scenes() {
            let wide = WideBvh::build(&triangles);
            let mut order: Vec<u32> = wide
                .leaves
                .iter()
                .flat_map(|leaf| leaf.triangles[..leaf.count as usize].to_vec())
                .collect();
            order.sort_unstable();
            assert_eq!(order, (0..triangles.len() as u32).collect::<Vec<_>>());
        }
    }
}

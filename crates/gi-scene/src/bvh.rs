//! Ray queries against a [`SceneFrame`] through an obvhs compressed wide BVH (CWBVH).

use std::time::{Duration, Instant};

use glam::{UVec2, Vec2, Vec3, Vec3A};
use leaves::{LANES, LeafTriangles};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    bvh2::reinsertion::ReinsertionOptimizer,
    cwbvh::{CwBvh, bvh2_to_cwbvh::bvh2_to_cwbvh},
    ploc::PlocBuilder,
    ray::Ray,
    splits::split_aabbs_preset,
    traverse,
    triangle::Triangle,
};

mod leaves;
mod wide;

pub use wide::WideBvh;

/// The primitives' bounds to build a BVH over with obvhs' PLOC builder, each grown by a tiny
/// amount of its own.
///
/// PLOC merges two neighbours (in Morton order) when each is the other's cheapest partner. On
/// exact ties (coincident copies of one object, or equal boxes at equal spacing in a row)
/// every node picks the same side, one pair merges per pass and the build turns quadratic: the
/// CPU reference's build of 50,000 boxes in a row (600k triangles) had not finished after two
/// minutes, and 200,000 coincident copies of one box after five. Growing each box by a
/// different amount (from a hash of its index: up to 1e-5 of its size plus about a millionth
/// of its distance from the origin, a few ulps of its coordinates) breaks the ties. The bounds
/// stay conservative, so every traversal stays exact; the trees are as good (the growth is far
/// below any box's size).
///
/// The CPU reference's [`WideBvh`] is built on them. [`SceneBvh`] (the tests' ray-query
/// oracle and `gi info`) and the GPU levels take only their tree from them and store exact
/// bounds ([`build_cwbvh`]): on exact bounds a ray grazing a flat box (its origin a few 1e-5
/// above a floor) misses by rounding where a grown box finds the hit, and those two must
/// answer every ray alike.
pub fn tie_breaking_bounds<T: Boundable>(primitives: &[T]) -> Vec<Aabb> {
    primitives
        .iter()
        .enumerate()
        .map(|(i, primitive)| {
            let aabb = primitive.aabb();
            let size = (aabb.max - aabb.min).max_element();
            let distance = aabb.min.abs().max(aabb.max.abs()).max_element();
            // A fraction in [0.5, 1) from the index (a multiplicative hash's high bits).
            let hash = (i as u32).wrapping_mul(0x9e37_79b9) ^ ((i as u64 >> 32) as u32);
            let fraction = 0.5 + (hash >> 8) as f32 / (1u32 << 25) as f32;
            let grow = (size * 1e-5 + distance * 1e-6 + 1e-12) * fraction;
            Aabb::new(aabb.min - grow, aabb.max + grow)
        })
        .collect()
}

/// obvhs' compressed wide BVH over `primitives`, its tree built on [`tie_breaking_bounds`]
/// (so exact ties cannot make the build quadratic) and its boxes the exact bounds of what they
/// hold: the same boxes as a build on exact bounds that made the same tree. PLOC, reinsertion
/// and the conversion as obvhs' `build_cwbvh` (`params.pre_split` is ignored, as there).
pub fn build_cwbvh<T: Boundable>(primitives: &[T], params: BvhBuildParams) -> CwBvh {
    build_cwbvh_over(primitives, &tie_breaking_bounds(primitives), params)
}

/// The build the traversal-heavy BVHs use (the GPU's static levels and [`SceneBvh`]): obvhs'
/// `medium_build` with large triangles pre-split ([`build_triangle_cwbvh`]).
pub const fn traversal_build() -> BvhBuildParams {
    BvhBuildParams {
        pre_split: true,
        ..BvhBuildParams::medium_build()
    }
}

/// [`build_cwbvh`] over triangles, honouring `params.pre_split`: a triangle whose box is large
/// against the average (a floor, a wall) is cut into pieces along its box's longest axis with
/// obvhs' `split_aabbs_preset` (Dammertz and Keller's early split clipping: each piece's box is
/// the box of the triangle's part on its side of the cut), the tree is built over the pieces,
/// and a leaf names the triangle of each piece it holds. A triangle may then sit in several
/// leaves; a ray tests it whole wherever it meets it, so hits are unchanged and only the boxes
/// are tighter. A cut piece's box is grown by a few ulps of its coordinates, since the points
/// where the cut crosses an edge are rounded.
pub fn build_triangle_cwbvh(triangles: &[Triangle], params: BvhBuildParams) -> CwBvh {
    if !params.pre_split || triangles.is_empty() {
        return build_cwbvh(triangles, params);
    }
    let mut pieces: Vec<Aabb> = triangles.iter().map(Boundable::aabb).collect();
    let half_areas = pieces.iter().map(Aabb::half_area);
    let largest = half_areas.clone().fold(0.0f32, f32::max);
    let average = half_areas.sum::<f32>() / triangles.len() as f32;
    let mut owners: Vec<u32> = (0..triangles.len() as u32).collect();
    split_aabbs_preset(&mut pieces, &mut owners, triangles, average, largest);
    let mut cut = vec![false; triangles.len()];
    for &owner in &owners[triangles.len()..] {
        cut[owner as usize] = true;
    }
    for (piece, &owner) in pieces.iter_mut().zip(&owners) {
        if cut[owner as usize] {
            let distance = piece.min.abs().max(piece.max.abs()).max_element();
            let grow = distance * 1e-6 + 1e-30;
            *piece = Aabb::new(piece.min - grow, piece.max + grow);
        }
    }
    let mut bvh = build_cwbvh_over(&pieces, &tie_breaking_bounds(&pieces), params);
    for index in &mut bvh.primitive_indices {
        *index = owners[*index as usize];
    }
    bvh
}

/// [`build_cwbvh`] with its tree built on `bounds` (one per primitive).
fn build_cwbvh_over<T: Boundable>(
    primitives: &[T],
    bounds: &[Aabb],
    params: BvhBuildParams,
) -> CwBvh {
    if primitives.is_empty() {
        return CwBvh::default();
    }
    let mut bvh2 = PlocBuilder::with_capacity(bounds.len()).build(
        params.ploc_search_distance,
        bounds,
        (0..bounds.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    for node in &mut bvh2.nodes {
        if node.is_leaf() {
            let first = node.first_index as usize;
            let held = &bvh2.primitive_indices[first..first + node.prim_count as usize];
            let exact = held.iter().fold(Aabb::empty(), |aabb, &i| {
                aabb.union(&primitives[i as usize].aabb())
            });
            node.set_aabb(exact);
        }
    }
    bvh2.refit_all();
    bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false)
}

/// Depth of the deepest internal node of `bvh`, walking child links from the root (an
/// explicit stack, so a degenerate BVH cannot overflow the host's).
pub fn cwbvh_depth(bvh: &CwBvh) -> u32 {
    let mut deepest = 0;
    let mut pending = vec![(0usize, 0u32)];
    while let Some((index, depth)) = pending.pop() {
        deepest = deepest.max(depth);
        let node = &bvh.nodes[index];
        for slot in (0..8).filter(|&slot| !node.is_leaf(slot)) {
            pending.push((node.child_node_index(slot) as usize, depth + 1));
        }
    }
    deepest
}

/// A closest-hit result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// Index into the frame's `triangles` and `attributes`.
    pub triangle: u32,
    /// Barycentric weights of v1 and v2 (v0's is `1 - u - v`).
    pub barycentrics: Vec2,
}

/// Barycentric weights of v1 and v2 where the ray's line crosses the triangle's plane
/// (Moller-Trumbore in f64, so thin triangles far from the origin stay accurate). obvhs'
/// own `compute_barycentric` normalizes the face normal and so scales the weights by twice
/// the triangle's area.
fn barycentrics(tri: &Triangle, origin: Vec3, dir: Vec3) -> Vec2 {
    let [v0, v1, v2] = [tri.v0, tri.v1, tri.v2].map(|v| Vec3::from(v).as_dvec3());
    let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return Vec2::ZERO;
    }
    let s = o - v0;
    let u = s.dot(p) / det;
    let v = d.dot(s.cross(e1)) / det;
    Vec2::new(u as f32, v as f32)
}

/// `dir` with negative zeros made positive. obvhs inverts a `-0.0` component to a large
/// negative value but classifies its sign with `< 0.0` (false), so the box test of such a ray
/// uses the wrong slab planes and misses; `-light.direction` of an axis-aligned light produces
/// exactly such directions.
fn canonical_direction(dir: Vec3) -> Vec3A {
    Vec3A::from(Vec3::select(dir.cmpeq(Vec3::ZERO), Vec3::ZERO, dir))
}

/// A CWBVH over world-space triangles, with the time its build took.
pub struct SceneBvh {
    pub bvh: CwBvh,
    /// The triangles in the order of `bvh.primitive_indices`, ready for intersection four at
    /// a time (64 bytes each): the traversal reads them in sequence instead of through the
    /// index.
    leaf_triangles: LeafTriangles,
    /// Wall time of the whole build (AABBs, PLOC, conversion to CWBVH).
    pub build_time: Duration,
}

/// The triangles of a CWBVH node's hit leaves that the `traverse!` macro is about to test one
/// by one, taken from it whole: their first index in leaf order and a mask of which of the
/// next 24 to test. `primitive_id` is the one the macro has just taken off the group.
#[inline(always)]
fn take_group(group: &mut UVec2, primitive_id: u32) -> (u32, u32) {
    let first = group.x;
    let mask = group.y | (1 << (primitive_id - first));
    group.y = 0;
    (first, mask)
}

/// The nearest crossing a traversal found: distance and index into the BVH's leaf order.
struct Nearest {
    t: f32,
    leaf: u32,
}

impl SceneBvh {
    /// Builds with [`traversal_build`] (a good trade-off for static scenes).
    pub fn build(triangles: &[Triangle]) -> Self {
        Self::build_with(triangles, traversal_build())
    }

    /// Builds with explicit obvhs parameters.
    pub fn build_with(triangles: &[Triangle], params: BvhBuildParams) -> Self {
        let start = Instant::now();
        let bvh = build_triangle_cwbvh(triangles, params);
        let leaf_triangles = LeafTriangles::new(triangles, &bvh.primitive_indices);
        Self {
            bvh,
            leaf_triangles,
            build_time: start.elapsed(),
        }
    }

    /// Bytes of the BVH: obvhs' nodes and primitive indices, and the prepared leaf triangles
    /// the traversal reads.
    pub fn memory_bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(self.bvh.nodes.as_slice())
            + size_of_val(self.bvh.primitive_indices.as_slice())
            + self.leaf_triangles.memory_bytes()
    }

    /// Closest crossing of `ray` (obvhs' closest-hit traversal over the prepared triangles).
    #[inline]
    fn nearest(&self, ray: Ray) -> Option<Nearest> {
        if self.leaf_triangles.is_empty() {
            return None;
        }
        let mut ray = ray;
        let mut nearest = None;
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        traverse!(
            self.bvh,
            node,
            state,
            node.intersect_ray(&ray, state.oct_inv4),
            {
                // The macro hands over the group's triangles one at a time, highest bit
                // first; take the whole group and test it four at a time instead, keeping
                // that order so ties go to the same triangle.
                let (first, mut group) = take_group(&mut state.primitive_group, state.primitive_id);
                while group != 0 {
                    let chunk = (31 - group.leading_zeros()) / LANES as u32 * LANES as u32;
                    let lanes = (group >> chunk) & 0xf;
                    group &= !(0xf << chunk);
                    let start = (first + chunk) as usize;
                    let (t, hit) = self.leaf_triangles.intersect4(start, &ray);
                    let hit = hit & lanes;
                    for lane in (0..LANES).rev().filter(|&l| hit & (1 << l) != 0) {
                        if t[lane] < ray.tmax {
                            nearest = Some(Nearest {
                                t: t[lane],
                                leaf: (start + lane) as u32,
                            });
                            ray.tmax = t[lane];
                        }
                    }
                }
            }
        );
        nearest
    }

    /// Nearest intersection of the ray `origin + t * dir`, `t` in `(t_min, t_max)`.
    /// `triangles` are those the BVH was built from (the barycentrics are computed from
    /// them).
    pub fn closest_hit(
        &self,
        triangles: &[Triangle],
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let (t, triangle) = self.closest_triangle(origin, dir, t_min, t_max)?;
        let barycentrics = barycentrics(&triangles[triangle as usize], origin, dir);
        Some(Hit {
            t,
            triangle,
            barycentrics,
        })
    }

    /// Distance and triangle index of the nearest intersection of the ray
    /// `origin + t * dir`, `t` in `(t_min, t_max)`: [`SceneBvh::closest_hit`] without the
    /// barycentrics, for callers that compute their own.
    pub fn closest_triangle(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, u32)> {
        let ray = Ray::new(Vec3A::from(origin), canonical_direction(dir), t_min, t_max);
        let nearest = self.nearest(ray)?;
        Some((nearest.t, self.bvh.primitive_indices[nearest.leaf as usize]))
    }

    /// True when anything blocks the open segment `(t_min, t_max)` of the ray (obvhs'
    /// any-hit traversal: it stops at the first blocker). `triangles` are those the BVH was
    /// built from; it traverses its own prepared copy of them.
    pub fn occluded(
        &self,
        triangles: &[Triangle],
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        // A pre-split build holds some triangles more than once, never fewer than all.
        debug_assert!(
            self.leaf_triangles.is_empty() || self.bvh.primitive_indices.len() >= triangles.len()
        );
        if self.leaf_triangles.is_empty() {
            return false;
        }
        let ray = Ray::new(Vec3A::from(origin), canonical_direction(dir), t_min, t_max);
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        // A plain `break` would only leave the macro's inner loop over a leaf's triangles.
        'traversal: {
            traverse!(
                self.bvh,
                node,
                state,
                node.intersect_ray(&ray, state.oct_inv4),
                {
                    let (first, mut group) =
                        take_group(&mut state.primitive_group, state.primitive_id);
                    while group != 0 {
                        let chunk = group.trailing_zeros() / LANES as u32 * LANES as u32;
                        let lanes = (group >> chunk) & 0xf;
                        group &= !(0xf << chunk);
                        let (t, hit) = self
                            .leaf_triangles
                            .intersect4((first + chunk) as usize, &ray);
                        let hit = hit & lanes;
                        if (0..LANES).any(|l| hit & (1 << l) != 0 && t[l] < ray.tmax) {
                            break 'traversal true;
                        }
                    }
                }
            );
            false
        }
    }

    /// Number of nodes (for reports).
    pub fn node_count(&self) -> usize {
        self.bvh.nodes.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The twelve triangles of a unit box at `x`.
    fn unit_box(x: f32) -> [Triangle; 12] {
        let corner = |c: usize| {
            Vec3A::new(
                x + (c & 1) as f32,
                ((c >> 1) & 1) as f32,
                ((c >> 2) & 1) as f32,
            )
        };
        let faces = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let mut triangles = [Triangle {
            v0: Vec3A::ZERO,
            v1: Vec3A::ZERO,
            v2: Vec3A::ZERO,
        }; 12];
        for (f, [a, b, c, d]) in faces.into_iter().enumerate() {
            triangles[2 * f] = Triangle {
                v0: corner(a),
                v1: corner(b),
                v2: corner(c),
            };
            triangles[2 * f + 1] = Triangle {
                v0: corner(a),
                v1: corner(c),
                v2: corner(d),
            };
        }
        triangles
    }

    /// Coincident copies of one box: on their own bounds PLOC merges about one pair per pass
    /// and builds a chain as deep as there are copies (in quadratic time); on the tie-breaking
    /// bounds the tree is several times shallower. Equal boxes at equal spacing in a row (whose
    /// ties slowed the build 50-fold, measured, without deepening the tree) keep a tree as
    /// good. The bounds contain their triangles and grow by little.
    #[test]
    fn tie_breaking_bounds_keep_ploc_shallow_on_coincident_boxes_and_rows_as_good() {
        let boxes = 400;
        let coincident: Vec<Triangle> = (0..boxes).flat_map(|_| unit_box(0.0)).collect();
        let row: Vec<Triangle> = (0..boxes).flat_map(|i| unit_box(2.0 * i as f32)).collect();
        let params = BvhBuildParams {
            max_prims_per_leaf: 1,
            ..BvhBuildParams::medium_build()
        };
        let depth = |bounds: &[Aabb]| {
            let bvh = obvhs::bvh2::builder::build_bvh2(bounds, params, &mut Duration::default());
            bvh.depth(0)
        };
        let mut depths = Vec::new();
        for (name, triangles) in [("coincident", &coincident), ("row", &row)] {
            let plain: Vec<Aabb> = triangles.iter().map(|t| t.aabb()).collect();
            let broken = tie_breaking_bounds(triangles);
            for (aabb, triangle) in broken.iter().zip(triangles.iter()) {
                for v in [triangle.v0, triangle.v1, triangle.v2] {
                    assert!(aabb.min.cmple(v).all() && aabb.max.cmpge(v).all(), "{name}");
                }
                let grown = (aabb.max - aabb.min).max_element() - 1.0;
                assert!(grown > 0.0 && grown < 0.05, "{name}: grown by {grown}");
            }
            depths.push((depth(&plain), depth(&broken)));
        }
        let [(coincident_tied, coincident_broken), (row_tied, row_broken)] = depths[..] else {
            unreachable!()
        };
        assert!(coincident_tied > boxes * 3 / 4, "{depths:?}");
        assert!(coincident_broken * 3 < coincident_tied, "{depths:?}");
        assert!(row_broken <= row_tied + 2, "{depths:?}");
    }

    /// `build_cwbvh` (the GPU levels' and `SceneBvh`'s build) on coincident boxes: a tree
    /// several times shallower than the same build on the tied exact bounds, holding every
    /// triangle, with exact boxes: the root's frame starts at the boxes' exact corner, not at
    /// a grown one.
    #[test]
    fn build_cwbvh_breaks_ties_and_keeps_exact_bounds() {
        let coincident: Vec<Triangle> = (0..400).flat_map(|_| unit_box(0.0)).collect();
        let params = BvhBuildParams::medium_build();
        // The tree's primitives, each checked inside its leaf's box.
        let held = |bvh: &CwBvh| {
            let mut held = Vec::new();
            for node in &bvh.nodes {
                for slot in (0..8).filter(|&s| node.is_leaf(s) && !node.is_child_empty(s)) {
                    let (first, count) = node.child_primitives(slot);
                    let aabb = node.child_aabb(slot);
                    for &primitive in &bvh.primitive_indices[first as usize..][..count as usize] {
                        let bounds = coincident[primitive as usize].aabb();
                        assert!(aabb.min.cmple(bounds.min).all(), "{primitive}");
                        assert!(aabb.max.cmpge(bounds.max).all(), "{primitive}");
                        held.push(primitive);
                    }
                }
            }
            held.sort_unstable();
            held
        };
        let depth = cwbvh_depth;
        let exact: Vec<Aabb> = coincident.iter().map(Boundable::aabb).collect();
        let tied = build_cwbvh_over(&coincident, &exact, params);
        let broken = build_cwbvh(&coincident, params);
        assert!(
            depth(&broken) * 3 < depth(&tied),
            "{} vs {}",
            depth(&broken),
            depth(&tied)
        );
        let all: Vec<u32> = (0..coincident.len() as u32).collect();
        assert_eq!(held(&broken), all);
        assert_eq!(broken.nodes[0].p, Vec3::ZERO);
        assert_eq!(tied.nodes[0].p, Vec3::ZERO);
    }

    /// `traversal_build` cuts long slivers lying across a row of boxes into pieces: the tree
    /// has more leaf entries than triangles, every triangle is in a leaf whose box holds one
    /// of its pieces, and rays aimed at points of the slivers (near their edges too, where
    /// the cuts' rounded crossings lie) and rays at random find the same nearest triangle and
    /// distance, and the same blockers, as a test of every triangle.
    #[test]
    fn pre_split_builds_find_every_hit_of_a_brute_force_test() {
        let mut triangles: Vec<Triangle> = (0..24).flat_map(|i| unit_box(i as f32 * 2.0)).collect();
        let slivers = triangles.len();
        for k in 0..6 {
            let y = 0.15 * k as f32 + 0.1;
            triangles.push(Triangle {
                v0: Vec3A::new(-1.0, y, -0.5),
                v1: Vec3A::new(48.0, y + 0.8, 1.7),
                v2: Vec3A::new(47.5, y + 0.9, 1.2 + 0.1 * k as f32),
            });
        }
        let bvh = SceneBvh::build(&triangles);
        assert!(
            bvh.bvh.primitive_indices.len() > triangles.len(),
            "no triangle was cut"
        );
        let mut held = vec![false; triangles.len()];
        for &i in &bvh.bvh.primitive_indices {
            held[i as usize] = true;
        }
        assert!(held.iter().all(|&h| h));
        // A small deterministic sequence in [0, 1).
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let brute = |origin: Vec3, dir: Vec3, t_max: f32| {
            let ray = Ray::new(Vec3A::from(origin), canonical_direction(dir), 0.0, t_max);
            let mut hits: Vec<(f32, u32)> = (triangles.iter().enumerate())
                .map(|(i, tri)| (tri.intersect(&ray), i as u32))
                .filter(|&(t, _)| t.is_finite() && t < t_max)
                .collect();
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            hits
        };
        let mut compared = 0;
        for r in 0..3000 {
            let origin = Vec3::new(next() * 60.0 - 6.0, next() * 6.0 - 2.0, next() * 8.0 - 3.0);
            let target = if r % 3 == 0 {
                Vec3::new(next() * 50.0 - 1.0, next() * 2.0, next() * 2.0)
            } else {
                // A point of a sliver, one weight within 1e-3 of zero on every other ray.
                let tri = &triangles[slivers + r % 6];
                let (mut u, mut v) = (next(), next());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                if r % 2 == 0 {
                    v *= 1e-3;
                }
                Vec3::from(tri.v0 + (tri.v1 - tri.v0) * u + (tri.v2 - tri.v0) * v)
            };
            let dir = (target - origin).normalize();
            let expected = brute(origin, dir, 1e3);
            let found = bvh.closest_triangle(origin, dir, 0.0, 1e3);
            match (expected.first(), found) {
                (None, None) => {}
                (Some(&(t, triangle)), Some((found_t, found_triangle))) => {
                    assert!(
                        (found_t - t).abs() <= 1e-4 * t.max(1.0),
                        "ray {r}: {found_t} vs {t}"
                    );
                    // The same triangle unless another lies within rounding of it.
                    let tied = expected
                        .iter()
                        .filter(|h| (h.0 - t).abs() <= 1e-4 * t.max(1.0));
                    assert!(
                        tied.clone().any(|h| h.1 == found_triangle),
                        "ray {r}: {found_triangle} vs {triangle}"
                    );
                    compared += 1;
                    let t_max = t * 1.01;
                    assert!(bvh.occluded(&triangles, origin, dir, 0.0, t_max), "ray {r}");
                }
                (expected, found) => panic!("ray {r}: {found:?} vs {expected:?}"),
            }
        }
        assert!(compared > 1500, "only {compared} rays hit");
    }

    /// A large right triangle (area 8): the weights must not scale with its area, and the hit
    /// must be the nearer of two stacked triangles.
    #[test]
    fn closest_hit_reports_true_barycentrics_and_nearest_triangle() {
        let tri = |z: f32| Triangle {
            v0: Vec3A::new(0.0, 0.0, z),
            v1: Vec3A::new(4.0, 0.0, z),
            v2: Vec3A::new(0.0, 4.0, z),
        };
        let triangles = vec![tri(-5.0), tri(-2.0)];
        let bvh = SceneBvh::build(&triangles);
        let hit = bvh
            .closest_hit(
                &triangles,
                Vec3::new(1.0, 2.0, 0.0),
                Vec3::NEG_Z,
                0.0,
                100.0,
            )
            .expect("the ray crosses both triangles");
        assert_eq!(hit.triangle, 1);
        assert!((hit.t - 2.0).abs() < 1e-5);
        assert!((hit.barycentrics - Vec2::new(0.25, 0.5)).length() < 1e-5);
        assert!(bvh.occluded(&triangles, Vec3::new(1.0, 2.0, 0.0), Vec3::NEG_Z, 0.0, 3.0));
        assert!(!bvh.occluded(&triangles, Vec3::new(1.0, 2.0, 0.0), Vec3::NEG_Z, 0.0, 1.5));
        assert!(
            bvh.closest_hit(
                &triangles,
                Vec3::new(3.5, 3.5, 0.0),
                Vec3::NEG_Z,
                0.0,
                100.0
            )
            .is_none()
        );
    }

    /// Axis-aligned directions with negative zeros (what negating an axis-aligned light
    /// direction gives) must find blockers like any other direction.
    #[test]
    fn negative_zero_directions_find_blockers() {
        let quad = [
            Triangle {
                v0: Vec3A::new(-1.0, 1.0, -1.0),
                v1: Vec3A::new(1.0, 1.0, -1.0),
                v2: Vec3A::new(1.0, 1.0, 1.0),
            },
            Triangle {
                v0: Vec3A::new(-1.0, 1.0, -1.0),
                v1: Vec3A::new(1.0, 1.0, 1.0),
                v2: Vec3A::new(-1.0, 1.0, 1.0),
            },
        ];
        let bvh = SceneBvh::build(&quad);
        let origin = Vec3::new(0.3, 0.0, 0.2);
        for dir in [
            Vec3::new(-0.0, 1.0, -0.0),
            Vec3::new(0.0, 1.0, -0.0),
            -Vec3::NEG_Y,
        ] {
            assert!(bvh.occluded(&quad, origin, dir, 0.0, 10.0), "{dir:?}");
            let hit = bvh
                .closest_hit(&quad, origin, dir, 0.0, 10.0)
                .expect("hits the quad");
            assert!((hit.t - 1.0).abs() < 1e-6);
        }
    }
}

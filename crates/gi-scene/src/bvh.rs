//! Ray queries against a [`SceneFrame`] through an obvhs compressed wide BVH (CWBVH).

use std::time::{Duration, Instant};

use glam::{UVec2, Vec2, Vec3, Vec3A};
use leaves::{LANES, LeafTriangles};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::Ray,
    traverse,
    triangle::Triangle,
};

mod leaves;
mod wide;

pub use wide::WideBvh;

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
    /// Builds with obvhs' `medium_build` preset (a good trade-off for static scenes).
    pub fn build(triangles: &[Triangle]) -> Self {
        Self::build_with(triangles, BvhBuildParams::medium_build())
    }

    /// Builds with explicit obvhs parameters.
    pub fn build_with(triangles: &[Triangle], params: BvhBuildParams) -> Self {
        let start = Instant::now();
        let bvh = if triangles.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh_from_tris(triangles, params, &mut Duration::default())
        };
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
        debug_assert_eq!(triangles.len(), self.leaf_triangles.len());
        if triangles.is_empty() {
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

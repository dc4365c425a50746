//! Ray queries against a [`SceneFrame`] through an obvhs compressed wide BVH (CWBVH).

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::{Ray, RayHit},
    triangle::Triangle,
};

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
    /// Wall time of the whole build (AABBs, PLOC, conversion to CWBVH).
    pub build_time: Duration,
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
        Self {
            bvh,
            build_time: start.elapsed(),
        }
    }

    /// Nearest intersection of the ray `origin + t * dir`, `t` in `(t_min, t_max)`.
    pub fn closest_hit(
        &self,
        triangles: &[Triangle],
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        if triangles.is_empty() {
            return None;
        }
        let ray = Ray::new(Vec3A::from(origin), canonical_direction(dir), t_min, t_max);
        let mut hit = RayHit::none();
        let indices = &self.bvh.primitive_indices;
        if !self.bvh.ray_traverse(ray, &mut hit, |ray, id| {
            triangles[indices[id] as usize].intersect(ray)
        }) {
            return None;
        }
        let triangle = indices[hit.primitive_id as usize];
        let barycentrics = barycentrics(&triangles[triangle as usize], origin, dir);
        Some(Hit {
            t: hit.t,
            triangle,
            barycentrics,
        })
    }

    /// True when anything blocks the open segment `(t_min, t_max)` of the ray.
    pub fn occluded(
        &self,
        triangles: &[Triangle],
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        if triangles.is_empty() {
            return false;
        }
        let ray = Ray::new(Vec3A::from(origin), canonical_direction(dir), t_min, t_max);
        let indices = &self.bvh.primitive_indices;
        !self.bvh.ray_traverse_miss(ray, |ray, id| {
            triangles[indices[id] as usize].intersect(ray)
        })
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

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
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), t_min, t_max);
        let mut hit = RayHit::none();
        let indices = &self.bvh.primitive_indices;
        if !self.bvh.ray_traverse(ray, &mut hit, |ray, id| {
            triangles[indices[id] as usize].intersect(ray)
        }) {
            return None;
        }
        let triangle = indices[hit.primitive_id as usize];
        let hit_ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), t_min, hit.t);
        let barycentrics = triangles[triangle as usize].compute_barycentric(&hit_ray);
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
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), t_min, t_max);
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

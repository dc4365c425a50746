//! The BVH's triangles laid out for testing four at a time.

use glam::Vec4;
use obvhs::{ray::Ray, triangle::Triangle};

/// Triangles per test: one SSE register of f32 lanes.
pub(super) const LANES: usize = 4;

/// The BVH's triangles in leaf order (`CwBvh::primitive_indices`), as a structure of arrays so
/// that any four consecutive ones load as four lanes.
///
/// Each lane computes obvhs' `Triangle::intersect` (Moller-Trumbore) with the triangle's
/// edges and unnormalized normal computed once at build time instead of per test: the same f32
/// operations in the same order on the same values (glam's `Vec3A` cross and dot products,
/// unfused), so every lane returns exactly what `Triangle::intersect` returns.
pub(super) struct LeafTriangles {
    /// x, y and z of `v0`, `e1 = v0 - v1` (obvhs' sign), `e2 = v2 - v0` and `n = e1 x e2`,
    /// each followed by `LANES - 1` zeros so four lanes can be read from any triangle.
    components: [Vec<f32>; 12],
    len: usize,
}

impl LeafTriangles {
    /// The triangles `order` names, in that order.
    pub(super) fn new(triangles: &[Triangle], order: &[u32]) -> Self {
        let mut components: [Vec<f32>; 12] =
            std::array::from_fn(|_| Vec::with_capacity(order.len() + LANES - 1));
        for &i in order {
            let tri = &triangles[i as usize];
            let e1 = tri.v0 - tri.v1;
            let e2 = tri.v2 - tri.v0;
            let n = e1.cross(e2);
            for (k, v) in [tri.v0, e1, e2, n].into_iter().enumerate() {
                components[3 * k].push(v.x);
                components[3 * k + 1].push(v.y);
                components[3 * k + 2].push(v.z);
            }
        }
        for c in &mut components {
            c.resize(order.len() + LANES - 1, 0.0);
        }
        Self {
            components,
            len: order.len(),
        }
    }

    pub(super) fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.components
            .iter()
            .map(|c| std::mem::size_of_val(c.as_slice()))
            .sum()
    }

    /// Distances along `ray` to triangles `first .. first + 4`, and a mask of the lanes whose
    /// crossing lies inside the triangle and within `[ray.tmin, ray.tmax]` (bit `i` for
    /// triangle `first + i`; lanes past the last triangle are padding the caller masks out).
    #[inline(always)]
    pub(super) fn intersect4(&self, first: usize, ray: &Ray) -> (Vec4, u32) {
        let load = |k: usize| Vec4::from_slice(&self.components[k][first..first + LANES]);
        intersect_lanes(&std::array::from_fn(load), ray)
    }
}

/// Four triangles as lanes: x, y and z of `v0`, `e1 = v0 - v1` (obvhs' sign), `e2 = v2 - v0`
/// and `n = e1 x e2`, in that order.
pub(super) type TriangleLanes = [Vec4; 12];

/// The four triangles' `v0`, `e1`, `e2` and `n` as [`TriangleLanes`] (lanes past the end of
/// `triangles` are zero, and never hit).
pub(super) fn triangle_lanes(triangles: &[&Triangle]) -> TriangleLanes {
    let mut lanes = [Vec4::ZERO; 12];
    for (lane, tri) in triangles.iter().enumerate().take(LANES) {
        let e1 = tri.v0 - tri.v1;
        let e2 = tri.v2 - tri.v0;
        let n = e1.cross(e2);
        for (k, v) in [tri.v0, e1, e2, n].into_iter().enumerate() {
            lanes[3 * k][lane] = v.x;
            lanes[3 * k + 1][lane] = v.y;
            lanes[3 * k + 2][lane] = v.z;
        }
    }
    lanes
}

/// obvhs' `Triangle::intersect` on four triangles at once: their distances along `ray`, and a
/// mask of the lanes whose crossing lies inside the triangle and within
/// `[ray.tmin, ray.tmax]` (bit `i` for lane `i`).
#[inline(always)]
pub(super) fn intersect_lanes(c: &TriangleLanes, ray: &Ray) -> (Vec4, u32) {
    let (ox, oy, oz) = (
        Vec4::splat(ray.origin.x),
        Vec4::splat(ray.origin.y),
        Vec4::splat(ray.origin.z),
    );
    let (dx, dy, dz) = (
        Vec4::splat(ray.direction.x),
        Vec4::splat(ray.direction.y),
        Vec4::splat(ray.direction.z),
    );
    let (nx, ny, nz) = (c[9], c[10], c[11]);
    // c = v0 - o, r = d x c.
    let (cx, cy, cz) = (c[0] - ox, c[1] - oy, c[2] - oz);
    let rx = dy * cz - cy * dz;
    let ry = dz * cx - cz * dx;
    let rz = dx * cy - cx * dy;
    let inv_det = Vec4::ONE / (nx * dx + ny * dy + nz * dz);
    let u = (rx * c[6] + ry * c[7] + rz * c[8]) * inv_det;
    let v = (rx * c[3] + ry * c[4] + rz * c[5]) * inv_det;
    let w = Vec4::ONE - u - v;
    let t = (nx * cx + ny * cy + nz * cz) * inv_det;
    // Sign bits, as obvhs tests them: a -0.0 weight misses.
    let negative = u.is_negative_bitmask() | v.is_negative_bitmask() | w.is_negative_bitmask();
    let valid =
        inv_det.cmpne(Vec4::ZERO) & t.cmpge(Vec4::splat(ray.tmin)) & t.cmple(Vec4::splat(ray.tmax));
    (t, valid.bitmask() & !negative)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// Every lane must agree bit for bit with obvhs' own test, hits and misses alike.
    #[test]
    fn lanes_match_obvhs_intersect() {
        let mut s = 7u64;
        let mut rnd = move || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut point = || Vec3A::new(rnd(), rnd(), rnd());
        let triangles: Vec<Triangle> = (0..64)
            .map(|_| Triangle {
                v0: point(),
                v1: point(),
                v2: point(),
            })
            .collect();
        let order: Vec<u32> = (0..64).rev().collect();
        let leaves = LeafTriangles::new(&triangles, &order);
        let mut hits = 0;
        for _ in 0..200 {
            let ray = Ray::new(point() * 2.0, point().normalize(), 0.0, 1.5);
            for first in (0..64).step_by(LANES) {
                let (t, mask) = leaves.intersect4(first, &ray);
                for lane in 0..LANES {
                    let expected = triangles[order[first + lane] as usize].intersect(&ray);
                    let hit = mask & (1 << lane) != 0;
                    assert_eq!(hit, expected.is_finite());
                    if hit {
                        assert_eq!(t[lane].to_bits(), expected.to_bits());
                        hits += 1;
                    }
                }
            }
        }
        assert!(hits > 100, "only {hits} hits");
    }
}

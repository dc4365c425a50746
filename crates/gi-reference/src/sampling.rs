//! Random numbers and the warps from the unit square to directions and triangle points.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;

/// The random numbers of one camera path.
///
/// Each path gets its own generator seeded from (render seed, pixel index, sample index), so
/// the image never depends on which thread ran which pixel, nor on how the samples were split
/// into passes.
pub struct Sampler {
    rng: Pcg32,
}

impl Sampler {
    /// The generator of sample `sample` of pixel `pixel` in a render seeded with `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        // PCG streams with nearby parameters are correlated, so both state and stream come
        // from a full avalanche of all three inputs rather than from the raw indices.
        let h = splitmix64(splitmix64(splitmix64(seed) ^ pixel) ^ sample.rotate_left(32));
        let stream = splitmix64(h ^ 0x5851_f42d_4c95_7f2d);
        Self {
            rng: Pcg32::new(h, stream),
        }
    }

    /// Uniform in `[0, 1)`, with 24 bits so every value is exactly representable.
    pub fn next_f32(&mut self) -> f32 {
        (self.rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform numbers in `[0, 1)`, drawn in order x then y.
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

/// Sebastiano Vigna's splitmix64 finalizer: a bijective 64-bit mix.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Cosine-weighted direction about +Z (pdf `z / pi`), through Shirley's concentric disk map so
/// strata of the square stay compact on the hemisphere.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, PI / 4.0 * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Barycentric weights `(b1, b2)` of a uniformly distributed point on a triangle.
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

/// Veach's power heuristic (exponent 2) for the strategy with pdf `a` against one with pdf `b`,
/// written as `1 / (1 + (b/a)^2)` so huge near-mirror pdfs cannot overflow to `inf / inf`.
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a <= 0.0 {
        return 0.0;
    }
    let r = b / a;
    1.0 / (1.0 + r * r)
}

/// An orthonormal basis whose Z axis is a given unit normal (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Local +X (tangent) in world space.
    pub x: Vec3,
    /// Local +Y (bitangent) in world space.
    pub y: Vec3,
    /// Local +Z: the normal.
    pub z: Vec3,
}

impl Frame {
    /// The frame whose Z axis is the unit normal `n`; the sign of `n.z` is taken from its
    /// sign bit (`copysign`), which the GPU port reproduces.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Self {
            x: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            y: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            z: n,
        }
    }

    /// World-space `v` in the frame's coordinates.
    pub fn to_local(self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    /// Local-frame `v` in world space.
    pub fn to_world(self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_floats_cover_the_unit_interval_evenly() {
        let mut sampler = Sampler::new(7, 3, 0);
        let n = 100_000;
        let mut bins = [0u32; 10];
        for _ in 0..n {
            let x = sampler.next_f32();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
        }
        // Each bin count is binomial(n, 0.1): standard deviation sqrt(n * 0.1 * 0.9).
        let sigma = (n as f64 * 0.09).sqrt();
        for count in bins {
            assert!(
                (count as f64 - n as f64 * 0.1).abs() < 5.0 * sigma,
                "{bins:?}"
            );
        }
    }

    #[test]
    fn nearby_seeds_give_unrelated_sequences() {
        let first = |seed, pixel, sample| Sampler::new(seed, pixel, sample).next_f32();
        let a = first(0, 0, 0);
        assert_ne!(a, first(1, 0, 0));
        assert_ne!(a, first(0, 1, 0));
        assert_ne!(a, first(0, 0, 1));
        assert_eq!(a, first(0, 0, 0));
    }

    #[test]
    fn cosine_hemisphere_matches_its_pdf() {
        // E[z] under pdf z/pi is integral of z^2/pi over the hemisphere = 2/3, variance 1/18.
        let mut sampler = Sampler::new(1, 2, 3);
        let n = 50_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let w = cosine_hemisphere(sampler.next_2d());
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            sum += f64::from(w.z);
        }
        let sigma = (1.0f64 / 18.0 / n as f64).sqrt();
        assert!((sum / n as f64 - 2.0 / 3.0).abs() < 5.0 * sigma);
    }

    #[test]
    fn uniform_triangle_stays_inside_with_the_right_mean() {
        let mut sampler = Sampler::new(4, 5, 6);
        let n = 50_000;
        let mut mean = Vec2::ZERO.as_dvec2();
        for _ in 0..n {
            let b = uniform_triangle(sampler.next_2d());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            mean += b.as_dvec2();
        }
        // Each weight of a uniform point has mean 1/3 and variance 1/18.
        let sigma = (1.0f64 / 18.0 / n as f64).sqrt();
        let mean = mean / n as f64;
        assert!(
            (mean.x - 1.0 / 3.0).abs() < 5.0 * sigma && (mean.y - 1.0 / 3.0).abs() < 5.0 * sigma
        );
    }

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.2).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(f.x.dot(f.y).abs() < 1e-6 && f.x.dot(f.z).abs() < 1e-6);
            assert!((f.x.cross(f.y) - f.z).length() < 1e-5);
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }

    #[test]
    fn power_heuristic_handles_extremes() {
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
    }
}

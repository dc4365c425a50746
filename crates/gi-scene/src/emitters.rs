//! The emissive triangles of a frame and the distribution renderers sample them from.
//!
//! Shared by the CPU reference and the GPU tiers so both pick emitters with the same
//! probabilities: a triangle's weight is its emitted power, `area * luminance(emission) * pi`
//! (doubled when double-sided), with a textured emitter's emission taken at its texture's
//! average.

use std::f32::consts::PI;

use glam::Vec3;

use crate::{Material, SceneFrame, Texture};

/// Rec. 709 relative luminance of linear RGB.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Emissive triangles with non-zero power and their selection probabilities.
#[derive(Clone, Debug, Default)]
pub struct EmitterDistribution {
    /// Frame triangle index of each emitter, in frame order.
    pub triangles: Vec<u32>,
    /// Inclusive cumulative probabilities, one per emitter, summed in f64; the last is exactly
    /// 1 so every `u < 1` finds an emitter.
    pub cdf: Vec<f64>,
    /// Probability of picking each frame triangle (0 for non-emitters), indexed like the
    /// frame's triangles so a hit finds its light pdf in O(1).
    pub selection: Vec<f32>,
}

impl EmitterDistribution {
    /// Per material, the emitted power per unit area that weighs its triangles (0 for a
    /// material that emits nothing): `luminance(emission) * pi`, doubled when double-sided.
    pub fn exitance(materials: &[Material], textures: &[Texture]) -> Vec<f32> {
        materials
            .iter()
            .map(|m| {
                let texture = m
                    .emissive_texture
                    .and_then(|r| textures.get(r.texture))
                    .filter(|t| t.is_valid());
                let emission = m.emissive * texture.map_or(Vec3::ONE, |t| t.average().truncate());
                let sides = if m.double_sided { 2.0 } else { 1.0 };
                luminance(emission).max(0.0) * PI * sides
            })
            .collect()
    }

    /// The distribution of `frame`'s emitters; `materials` and `textures` are the scene's.
    pub fn build(frame: &SceneFrame, materials: &[Material], textures: &[Texture]) -> Self {
        let exitance = Self::exitance(materials, textures);
        let mut triangles = Vec::new();
        let mut power = Vec::new();
        for (index, (tri, attributes)) in frame.triangles.iter().zip(&frame.attributes).enumerate()
        {
            let Some(&exitance) = exitance.get(attributes.material as usize) else {
                continue;
            };
            let area = 0.5 * (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).length();
            let p = f64::from(area) * f64::from(exitance);
            if p > 0.0 && p.is_finite() {
                triangles.push(index as u32);
                power.push(p);
            }
        }
        let total: f64 = power.iter().sum();
        let mut cdf = Vec::with_capacity(power.len());
        let mut selection = vec![0.0f32; frame.triangles.len()];
        let mut running = 0.0;
        for (&triangle, p) in triangles.iter().zip(&power) {
            running += p / total;
            cdf.push(running);
            selection[triangle as usize] = (p / total) as f32;
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self {
            triangles,
            cdf,
            selection,
        }
    }

    /// Number of emitters (triangles with non-zero power).
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when nothing in the frame emits.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}

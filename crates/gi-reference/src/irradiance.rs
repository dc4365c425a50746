//! Irradiance at a surface point with the reference's full light transport: the ground truth
//! for caches that store irradiance (the radiance cache's voxel faces), where a comparison of
//! rendered images would mix the cache's error with the shading of the final image.

use std::f32::consts::PI;

use glam::Vec3;

use crate::integrator::path_radiance;
use crate::lights::shadow_distance;
use crate::sampling::{Frame, Sampler, cosine_hemisphere, power_heuristic};
use crate::scene::{Reference, offset_origin};
use crate::settings::RenderSettings;

impl Reference {
    /// Irradiance `E = integral L_i(w) cos(w, n) dw` that a surface at `point` with unit
    /// normal `normal` receives, in W/m^2 per channel.
    ///
    /// Punctual lights are added exactly (`WorldLight::incident` at `point` times the cosine,
    /// one shadow ray each, as [`crate::Mode::Direct`] evaluates them). Everything else (sky,
    /// emissive triangles, every indirect bounce) is estimated from `samples` cosine-weighted
    /// directions about `normal` (`pi L_i` each), each `L_i` one [`crate::Mode::Full`] path
    /// starting from `point` offset along `normal` with the default depth. Emissive triangles
    /// are also sampled directly, one next-event sample per direction, and the two strategies
    /// are combined with the power heuristic exactly as the path tracer combines them, so a
    /// small bright emitter does not make the estimate noisy. Sample `i` draws from
    /// `Sampler::new(seed, 0, i)`, so the estimate is deterministic for a seed. The standard
    /// error falls as `1 / sqrt(samples)`; a call costs `samples` paths.
    pub fn irradiance(&self, point: Vec3, normal: Vec3, samples: u32, seed: u64) -> Vec3 {
        let origin = offset_origin(point, normal);
        let mut rays = 0u64;
        let mut punctual = Vec3::ZERO;
        for light in &self.frame.lights {
            let (wi, distance, irradiance) = light.incident(point);
            let cos = wi.dot(normal);
            if cos <= 0.0 {
                continue;
            }
            let t_max = if distance.is_finite() {
                shadow_distance(distance)
            } else {
                f32::INFINITY
            };
            if !self.occluded(origin, wi, t_max, &mut rays) {
                punctual += irradiance * cos;
            }
        }
        if samples == 0 {
            return punctual;
        }
        let settings = RenderSettings::default();
        let frame = Frame::from_normal(normal);
        let mut sum = Vec3::ZERO;
        let sample_emitters = !self.emitters.is_empty();
        for i in 0..samples {
            let mut sampler = Sampler::new(seed, 0, u64::from(i));
            let mut estimate = Vec3::ZERO;
            if sample_emitters {
                let u_select = sampler.next_f32();
                let u_point = sampler.next_2d();
                if let Some(light) = self.sample_emitter(origin, u_select, u_point) {
                    let cos = light.wi.dot(normal);
                    if cos > 0.0
                        && !self.occluded(origin, light.wi, light.shadow_distance, &mut rays)
                    {
                        let w = power_heuristic(light.pdf, cos / PI);
                        estimate += light.radiance * (cos * w / light.pdf);
                    }
                }
            }
            let wi = frame.to_world(cosine_hemisphere(sampler.next_2d()));
            let mut l = path_radiance(self, &settings, origin, wi, &mut sampler, &mut rays);
            if sample_emitters {
                // The path counts emission at its first hit fully (a camera ray's weight); keep
                // only the cosine strategy's MIS share of it.
                if let Some(hit) = self.trace(origin, wi, &mut rays) {
                    let emitted = self.surface(origin, wi, &hit).emitted;
                    if emitted != Vec3::ZERO {
                        let pdf_light = self.emitter_pdf(hit.triangle, hit.t, wi);
                        let w = power_heuristic(wi.dot(normal) / PI, pdf_light);
                        l -= emitted * (1.0 - w);
                    }
                }
            }
            estimate += l * PI;
            if estimate.is_finite() {
                sum += estimate;
            }
        }
        punctual + sum / samples as f32
    }
}

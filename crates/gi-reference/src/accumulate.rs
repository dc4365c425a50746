//! Progressive rendering: an [`Accumulator`] adds samples pass by pass over rayon-parallel
//! rows, and [`Reference::render`] drives one to a sample count with a progress callback.

use std::time::Instant;

use gi_image::Image;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::integrator::radiance;
use crate::sampling::Sampler;
use crate::scene::Reference;
use crate::settings::{RenderError, RenderSettings};

/// Camera-path evaluations [`Reference::render`] aims for per pass: enough to amortize the
/// pass overhead on small images, few enough that progress reports stay frequent.
const TARGET_PATHS_PER_PASS: u64 = 1 << 16;

/// Throughput counters of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Camera paths traced (`width * height * samples per pixel`).
    pub samples: u64,
    /// Rays traced: closest-hit rays plus shadow rays.
    pub rays: u64,
    /// Wall time spent rendering, excluding the BVH build.
    pub seconds: f64,
    pub samples_per_second: f64,
    pub rays_per_second: f64,
    /// Wall time of the BVH build (done once in [`Reference::new`]).
    pub bvh_build_seconds: f64,
    /// Path samples that came out NaN or infinite and were counted as black. Always zero
    /// unless something is broken; reported so it can never hide.
    pub nonfinite_samples: u64,
}

/// A finished render: the mean radiance per pixel (linear, exposure not applied) and its stats.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub image: Image,
    pub stats: RenderStats,
}

/// A render in progress. Each [`Accumulator::add_samples`] call traces more paths per pixel;
/// the image so far is available at any time. Sample `i` of pixel `p` always uses the same
/// random numbers, so an accumulator that reached `n` samples per pixel holds exactly the
/// image [`Reference::render`] gives for `spp = n`, however the passes were split.
pub struct Accumulator<'a> {
    reference: &'a Reference,
    settings: RenderSettings,
    /// Per pixel, per channel: sum of samples and sum of squared samples (f64, so millions of
    /// samples add up without rounding drift).
    sum: Vec<DVec3>,
    sum_sq: Vec<DVec3>,
    samples_per_pixel: u32,
    rays: u64,
    nonfinite_samples: u64,
    seconds: f64,
}

impl Reference {
    /// Starts a progressive render with `settings` (its `spp` is not used: the caller decides
    /// how many samples to add).
    pub fn accumulator(&self, settings: &RenderSettings) -> Result<Accumulator<'_>, RenderError> {
        settings.validate()?;
        let pixels = settings.pixel_count() as usize;
        Ok(Accumulator {
            reference: self,
            settings: *settings,
            sum: vec![DVec3::ZERO; pixels],
            sum_sq: vec![DVec3::ZERO; pixels],
            samples_per_pixel: 0,
            rays: 0,
            nonfinite_samples: 0,
            seconds: 0.0,
        })
    }

    /// Renders `settings.spp` samples per pixel, calling `progress` with the samples per pixel
    /// done after every pass.
    pub fn render(
        &self,
        settings: &RenderSettings,
        progress: &(dyn Fn(u32) + Sync),
    ) -> Result<RenderOutput, RenderError> {
        let output = self.render_until(settings, progress, &|| false)?;
        Ok(output.expect("a render that is never cancelled ends"))
    }

    /// [`Reference::render`], stopping between passes (each about
    /// `TARGET_PATHS_PER_PASS` paths) once `cancelled` answers true: then `None`.
    pub fn render_until(
        &self,
        settings: &RenderSettings,
        progress: &(dyn Fn(u32) + Sync),
        cancelled: &dyn Fn() -> bool,
    ) -> Result<Option<RenderOutput>, RenderError> {
        let mut accumulator = self.accumulator(settings)?;
        let pass = (TARGET_PATHS_PER_PASS / settings.pixel_count()).clamp(1, 1 << 16) as u32;
        while accumulator.samples_per_pixel() < settings.spp {
            if cancelled() {
                return Ok(None);
            }
            accumulator.add_samples(pass.min(settings.spp - accumulator.samples_per_pixel()));
            progress(accumulator.samples_per_pixel());
        }
        let stats = accumulator.stats();
        tracing::debug!(?stats, "reference render finished");
        Ok(Some(RenderOutput {
            image: accumulator.image(),
            stats,
        }))
    }
}

impl Accumulator<'_> {
    /// Traces `samples_per_pixel` more paths through every pixel (capped so the total fits in
    /// a `u32`).
    pub fn add_samples(&mut self, samples_per_pixel: u32) {
        let first = self.samples_per_pixel;
        let count = samples_per_pixel.min(u32::MAX - first);
        if count == 0 {
            return;
        }
        let start = Instant::now();
        let width = self.settings.width as usize;
        let reference = self.reference;
        let settings = &self.settings;
        let (rays, nonfinite) = self
            .sum
            .par_chunks_mut(width)
            .zip(self.sum_sq.par_chunks_mut(width))
            .enumerate()
            .map(|(y, (sum_row, sum_sq_row))| {
                let mut rays = 0u64;
                let mut nonfinite = 0u64;
                for (x, (sum, sum_sq)) in sum_row.iter_mut().zip(sum_sq_row).enumerate() {
                    let pixel = (y * width + x) as u64;
                    for sample in first..first + count {
                        let mut sampler = Sampler::new(settings.seed, pixel, u64::from(sample));
                        let value = pixel_sample(
                            reference,
                            settings,
                            x as u32,
                            y as u32,
                            &mut sampler,
                            &mut rays,
                        );
                        let value = if value.is_finite() {
                            value.as_dvec3()
                        } else {
                            nonfinite += 1;
                            DVec3::ZERO
                        };
                        *sum += value;
                        *sum_sq += value * value;
                    }
                }
                (rays, nonfinite)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        self.samples_per_pixel = first + count;
        self.rays += rays;
        self.nonfinite_samples += nonfinite;
        self.seconds += start.elapsed().as_secs_f64();
    }

    /// Samples per pixel accumulated so far.
    pub fn samples_per_pixel(&self) -> u32 {
        self.samples_per_pixel
    }

    /// The settings this accumulator renders with.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Mean radiance per pixel so far (black before any sample).
    pub fn image(&self) -> Image {
        let n = f64::from(self.samples_per_pixel.max(1));
        self.to_image(self.sum.iter().map(|s| *s / n))
    }

    /// Per pixel and channel, the estimated standard error of [`Accumulator::image`]:
    /// `sqrt(sample variance / n)`. Tells how far the image may be from its converged value
    /// (at least two samples per pixel are needed; zero before that).
    pub fn standard_error(&self) -> Image {
        let n = f64::from(self.samples_per_pixel);
        self.to_image(self.sum.iter().zip(&self.sum_sq).map(|(s, sq)| {
            if n < 2.0 {
                return DVec3::ZERO;
            }
            let mean = *s / n;
            let variance = ((*sq - *s * mean) / (n - 1.0)).max(DVec3::ZERO);
            (variance / n).map(f64::sqrt)
        }))
    }

    /// Counters of everything traced so far.
    pub fn stats(&self) -> RenderStats {
        let samples = self.settings.pixel_count() * u64::from(self.samples_per_pixel);
        let per_second = |count: u64| {
            if self.seconds > 0.0 {
                count as f64 / self.seconds
            } else {
                0.0
            }
        };
        RenderStats {
            samples,
            rays: self.rays,
            seconds: self.seconds,
            samples_per_second: per_second(samples),
            rays_per_second: per_second(self.rays),
            bvh_build_seconds: self.reference.bvh_build_seconds(),
            nonfinite_samples: self.nonfinite_samples,
        }
    }

    fn to_image(&self, values: impl Iterator<Item = DVec3>) -> Image {
        Image {
            width: self.settings.width,
            height: self.settings.height,
            pixels: values.map(DVec3::as_vec3).collect(),
        }
    }
}

/// One camera path through pixel `(x, y)`: a pinhole ray through a uniformly jittered point of
/// the pixel (a box filter), with the film's aspect ratio from the image size.
fn pixel_sample(
    reference: &Reference,
    settings: &RenderSettings,
    x: u32,
    y: u32,
    sampler: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    let jitter = sampler.next_2d();
    let u = (x as f32 + jitter.x) / settings.width as f32;
    let v = (y as f32 + jitter.y) / settings.height as f32;
    let aspect = settings.width as f32 / settings.height as f32;
    let camera = &reference.frame.camera;
    let dir = camera.ray_direction(u, v, aspect);
    radiance(reference, settings, camera.position, dir, sampler, rays)
}

//! The radiance estimators: a unidirectional path tracer with next-event estimation and MIS
//! ([`Mode::Full`]), and the direct-only baseline ([`Mode::Direct`]).

use std::f32::consts::PI;

use glam::Vec3;

use crate::lights::shadow_distance;
use crate::sampling::{Sampler, cosine_hemisphere, power_heuristic};
use crate::scene::{Hit, Reference, Surface, offset_origin};
use crate::settings::{Mode, RenderSettings, Strategy};

/// Russian roulette may end a path once it has scattered this many times; shorter paths, which
/// carry most of the energy, are never cut.
pub const RUSSIAN_ROULETTE_START: u32 = 3;

/// Highest survival probability of Russian roulette: even a path with full throughput ends
/// with probability 5% per bounce, which bounds the work of closed, highly reflective scenes.
pub const RUSSIAN_ROULETTE_MAX_SURVIVAL: f32 = 0.95;

/// The BRDF sample that produced the current ray, remembered for the MIS weight of whatever
/// emission the ray finds.
#[derive(Clone, Copy)]
struct Bounce {
    brdf_pdf: f32,
    /// pdf of the sky's next-event sampling (cosine about the shading normal) for the same
    /// direction.
    sky_pdf: f32,
}

impl Reference {
    /// Closest hit along a ray from `origin` (counted in `rays`). Hits where an alpha-tested
    /// surface is absent ([`Reference::covers`]) are skipped: the ray goes on past them.
    pub(crate) fn trace(&self, origin: Vec3, dir: Vec3, rays: &mut u64) -> Option<Hit> {
        *rays += 1;
        // The surface computes its own barycentrics (clamped, in f64), so the BVH's are
        // not asked for.
        let mut t_min = 0.0;
        loop {
            let (t, triangle) = self
                .bvh
                .closest_triangle(origin, dir, t_min, f32::INFINITY)?;
            if self.covers_hit(origin, dir, triangle) {
                return Some(Hit { t, triangle });
            }
            // Past the rejected hit: t grows every round, so the loop ends.
            t_min = next_up(t);
        }
    }

    /// True when the segment `(0, t_max)` of the ray is blocked (counted in `rays`).
    pub(crate) fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32, rays: &mut u64) -> bool {
        *rays += 1;
        if !self.alpha_tested {
            return self.bvh.occluded(origin, dir, 0.0, t_max);
        }
        // With alpha-tested surfaces, blockers are found nearest first and tested.
        let mut t_min = 0.0;
        while let Some((t, triangle)) = self.bvh.closest_triangle(origin, dir, t_min, t_max) {
            if self.covers_hit(origin, dir, triangle) {
                return true;
            }
            t_min = next_up(t);
        }
        false
    }
}

/// The next f32 above non-negative `t`.
fn next_up(t: f32) -> f32 {
    f32::from_bits(t.max(0.0).to_bits() + 1)
}

/// Radiance arriving at `origin` from direction `-dir` for one camera path.
pub(crate) fn radiance(
    reference: &Reference,
    settings: &RenderSettings,
    origin: Vec3,
    dir: Vec3,
    sampler: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    match settings.mode {
        Mode::Full => path_radiance(reference, settings, origin, dir, sampler, rays),
        Mode::Direct => direct_radiance(reference, origin, dir, rays),
    }
}

/// The direct-only baseline: what the camera ray sees, plus every punctual light at the first
/// hit.
fn direct_radiance(reference: &Reference, origin: Vec3, dir: Vec3, rays: &mut u64) -> Vec3 {
    let Some(hit) = reference.trace(origin, dir, rays) else {
        return reference.frame.sky.radiance(dir);
    };
    let surface = reference.surface(origin, dir, &hit);
    let x = offset_origin(surface.p, surface.ng);
    surface.emitted + punctual_lights(reference, &surface, x, rays)
}

pub(crate) fn path_radiance(
    reference: &Reference,
    settings: &RenderSettings,
    mut origin: Vec3,
    mut dir: Vec3,
    sampler: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    let strategy = settings.strategy;
    let sky = reference.frame.sky;
    let sky_emits = !sky.is_black();
    let light_sampling = strategy != Strategy::BsdfOnly;
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut last: Option<Bounce> = None;
    let mut depth = 0u32;
    loop {
        let Some(hit) = reference.trace(origin, dir, rays) else {
            if sky_emits {
                let w = emission_weight(strategy, last, |b| b.sky_pdf);
                l += beta * sky.radiance(dir) * w;
            }
            break;
        };
        let surface = reference.surface(origin, dir, &hit);
        if surface.emitted != Vec3::ZERO {
            let w = emission_weight(strategy, last, |_| {
                reference.emitter_pdf(hit.triangle, hit.t, dir)
            });
            l += beta * surface.emitted * w;
        }
        if depth == settings.max_depth {
            break;
        }
        depth += 1;

        let x = offset_origin(surface.p, surface.ng);
        let mut direct = punctual_lights(reference, &surface, x, rays);
        if light_sampling {
            direct += sample_emitters(reference, strategy, &surface, x, sampler, rays);
            if sky_emits {
                direct += sample_sky(reference, strategy, &surface, x, sampler, rays);
            }
        }
        l += beta * direct;

        let Some(sample) = surface.brdf.sample(sampler.next_f32(), sampler.next_2d()) else {
            break;
        };
        let wi = surface.frame.to_world(sample.wi);
        // Directions below the geometric surface would leak through it (the shading normal
        // can tilt above the real horizon): they carry nothing.
        if wi.dot(surface.ng) <= 0.0 {
            break;
        }
        beta *= sample.f * (sample.wi.z / sample.pdf);
        last = Some(Bounce {
            brdf_pdf: sample.pdf,
            sky_pdf: sample.wi.z / PI,
        });
        origin = x;
        dir = wi;

        if depth >= RUSSIAN_ROULETTE_START {
            let survival = beta.max_element().min(RUSSIAN_ROULETTE_MAX_SURVIVAL);
            if sampler.next_f32() >= survival {
                break;
            }
            beta /= survival;
        }
    }
    l
}

/// MIS weight of emission found by a ray: 1 on camera rays (nothing else could have found
/// it), the power heuristic against the light's next-event pdf under MIS, 0 under LightOnly
/// (next-event estimation already counted it) and 1 under BsdfOnly.
fn emission_weight(
    strategy: Strategy,
    last: Option<Bounce>,
    light_pdf: impl FnOnce(&Bounce) -> f32,
) -> f32 {
    let Some(bounce) = last else {
        return 1.0;
    };
    match strategy {
        Strategy::Mis => power_heuristic(bounce.brdf_pdf, light_pdf(&bounce)),
        Strategy::LightOnly => 0.0,
        Strategy::BsdfOnly => 1.0,
    }
}

/// Reflected radiance from every punctual light (delta lights: no MIS, no randomness), each
/// with its own shadow ray. `x` is the offset shadow-ray origin.
fn punctual_lights(reference: &Reference, surface: &Surface, x: Vec3, rays: &mut u64) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for light in &reference.frame.lights {
        // Falloff is evaluated at the surface point itself, as every GPU tier does.
        let (wi, distance, irradiance) = light.incident(surface.p);
        if wi.dot(surface.ng) <= 0.0 {
            continue;
        }
        let wi_local = surface.frame.to_local(wi);
        let contribution = surface.brdf.eval(wi_local) * wi_local.z * irradiance;
        if contribution == Vec3::ZERO {
            continue;
        }
        let t_max = if distance.is_finite() {
            shadow_distance(distance)
        } else {
            f32::INFINITY
        };
        if !reference.occluded(x, wi, t_max, rays) {
            sum += contribution;
        }
    }
    sum
}

/// One next-event sample of the emissive triangles, MIS-weighted against BRDF sampling.
fn sample_emitters(
    reference: &Reference,
    strategy: Strategy,
    surface: &Surface,
    x: Vec3,
    sampler: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    if reference.emitters.is_empty() {
        return Vec3::ZERO;
    }
    let u_select = sampler.next_f32();
    let u_point = sampler.next_2d();
    let Some(light) = reference.sample_emitter(x, u_select, u_point) else {
        return Vec3::ZERO;
    };
    if light.wi.dot(surface.ng) <= 0.0 {
        return Vec3::ZERO;
    }
    let wi = surface.frame.to_local(light.wi);
    let contribution = surface.brdf.eval(wi) * wi.z * light.radiance;
    if contribution == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let w = match strategy {
        Strategy::Mis => power_heuristic(light.pdf, surface.brdf.pdf(wi)),
        _ => 1.0,
    };
    if reference.occluded(x, light.wi, light.shadow_distance, rays) {
        return Vec3::ZERO;
    }
    contribution * (w / light.pdf)
}

/// One next-event sample of the sky, cosine-weighted about the shading normal, MIS-weighted
/// against BRDF sampling.
fn sample_sky(
    reference: &Reference,
    strategy: Strategy,
    surface: &Surface,
    x: Vec3,
    sampler: &mut Sampler,
    rays: &mut u64,
) -> Vec3 {
    let wi = cosine_hemisphere(sampler.next_2d());
    let pdf = wi.z / PI;
    if pdf <= 0.0 {
        return Vec3::ZERO;
    }
    let wi_world = surface.frame.to_world(wi);
    if wi_world.dot(surface.ng) <= 0.0 {
        return Vec3::ZERO;
    }
    let contribution = surface.brdf.eval(wi) * wi.z * reference.frame.sky.radiance(wi_world);
    if contribution == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let w = match strategy {
        Strategy::Mis => power_heuristic(pdf, surface.brdf.pdf(wi)),
        _ => 1.0,
    };
    if reference.occluded(x, wi_world, f32::INFINITY, rays) {
        return Vec3::ZERO;
    }
    contribution * (w / pdf)
}

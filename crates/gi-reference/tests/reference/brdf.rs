//! The BRDF against closed forms, quadrature and its own sampling routine.

use std::f64::consts::PI;

use gi_reference::brdf::{Brdf, MIN_ALPHA, specular_albedo};
use glam::{DVec3, Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;

use crate::common::{K_SIGMA, directional_albedo, polar};

fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 / 16_777_216.0
}

/// Materials spanning the lobe mixtures: diffuse-dominated, glossy dielectric, coloured rough
/// metal, white metal.
fn materials() -> Vec<Brdf> {
    vec![
        Brdf::new(Vec3::splat(0.8), 0.0, 1.0),
        Brdf::new(Vec3::new(0.2, 0.5, 0.9), 0.0, 0.35),
        Brdf::new(Vec3::new(1.0, 0.8, 0.3), 1.0, 0.5),
        Brdf::new(Vec3::ONE, 1.0, 0.3),
    ]
}

#[test]
fn normal_incidence_matches_closed_form() {
    // At wo = wi = n: D = 1 / (pi alpha^2), G2 = 1 and F = F0.
    for roughness in [0.1f32, 0.5, 1.0] {
        let alpha = f64::from(roughness * roughness);
        let metal = Brdf::new(Vec3::ONE, 1.0, roughness).eval(Vec3::Z, Vec3::Z);
        let expected = 1.0 / (4.0 * PI * alpha * alpha);
        assert!(
            (f64::from(metal.x) / expected - 1.0).abs() < 1e-5,
            "{metal} vs {expected}"
        );
        let dielectric = Brdf::new(Vec3::splat(0.5), 0.0, roughness).eval(Vec3::Z, Vec3::Z);
        let expected = 0.5 / PI + 0.04 / (4.0 * PI * alpha * alpha);
        assert!((f64::from(dielectric.x) / expected - 1.0).abs() < 1e-5);
    }
    assert_eq!(Brdf::new(Vec3::ONE, 0.0, 0.0).alpha, MIN_ALPHA);
}

#[test]
fn brdf_matches_the_textbook_form() {
    // The whole BRDF written out independently in f64: D and Lambda in their tangent forms
    // (Walter et al. 2007), Schlick's Fresnel with F0 = mix(0.04, base, metallic), and the
    // Lambert lobe, for a half-metallic coloured material.
    let (base, metallic, alpha) = (DVec3::new(0.9, 0.6, 0.3), 0.5, 0.4f64);
    let a2 = alpha * alpha;
    let lambda = |cos: f64| {
        let tan2 = (1.0 - cos * cos) / (cos * cos);
        (-1.0 + (1.0 + a2 * tan2).sqrt()) / 2.0
    };
    let f0 = DVec3::splat(0.04).lerp(base, metallic);
    let brdf = Brdf::new(base.as_vec3(), metallic as f32, alpha.sqrt() as f32);
    for (to, ti, phi) in [
        (0.3, 0.9, 0.0),
        (1.2, 0.4, 2.0),
        (0.05, 1.4, 3.0),
        (1.45, 1.45, 0.5),
    ] {
        let wo = DVec3::new(f64::sin(to), 0.0, f64::cos(to));
        let wi = DVec3::new(
            f64::sin(ti) * f64::cos(phi),
            f64::sin(ti) * f64::sin(phi),
            f64::cos(ti),
        );
        let h = (wo + wi).normalize();
        let tan2_h = (1.0 - h.z * h.z) / (h.z * h.z);
        let d = a2 / (PI * h.z.powi(4) * (a2 + tan2_h).powi(2));
        let g2 = 1.0 / (1.0 + lambda(wo.z) + lambda(wi.z));
        let fresnel = f0 + (DVec3::ONE - f0) * (1.0 - wo.dot(h)).powi(5);
        let expected = base * (1.0 - metallic) / PI + fresnel * d * g2 / (4.0 * wo.z * wi.z);
        let got = brdf.eval(wo.as_vec3(), wi.as_vec3()).as_dvec3();
        let error = ((got - expected) / expected).abs().max_element();
        assert!(error < 1e-4, "{got} vs {expected}");
    }
}

#[test]
fn reciprocal_and_zero_below_the_surface() {
    for brdf in materials() {
        for (a, b) in [(0.2, 1.1), (0.9, 0.4), (1.4, 0.7)] {
            let wo = polar(a);
            let wi = Vec3::new(-0.3, 0.5, 0.0) + polar(b);
            let wi = wi.normalize();
            let (f1, f2) = (brdf.eval(wo, wi), brdf.eval(wi, wo));
            assert!((f1 - f2).abs().max_element() <= 1e-5 * f1.max_element());
            assert_eq!(brdf.eval(wo, wi * Vec3::new(1.0, 1.0, -1.0)), Vec3::ZERO);
            assert_eq!(brdf.pdf(wo, wi * Vec3::new(1.0, 1.0, -1.0)), 0.0);
        }
    }
}

#[test]
fn white_metal_never_reflects_more_than_it_receives() {
    // Single-scattering GGX loses energy (up to ~70% at alpha = 1 and grazing view), but never
    // creates any; a smooth one loses almost nothing at normal incidence.
    let (smooth, error) = directional_albedo(&Brdf::new(Vec3::ONE, 1.0, 0.2), Vec3::Z, 256);
    assert!(smooth.x > 0.98 - error, "{smooth}");
    for roughness in [0.2f32, 0.5, 0.8, 1.0] {
        let brdf = Brdf::new(Vec3::ONE, 1.0, roughness);
        for theta in [0.0, 0.5, 1.0, 1.3, 1.5] {
            let (albedo, error) = directional_albedo(&brdf, polar(theta), 256);
            assert!(
                albedo.x <= 1.0 + error,
                "roughness {roughness} theta {theta}: {albedo}"
            );
        }
    }
}

#[test]
fn sampling_weights_integrate_to_the_albedo() {
    // E[f cos / pdf] over the sampling routine must equal the quadrature of f cos: a wrong
    // pdf (a pi, a lobe weight, a Jacobian) biases it.
    let mut rng = Pcg32::new(11, 13);
    let n = 40_000;
    for brdf in materials() {
        for theta in [0.1, 0.8, 1.35] {
            let wo = polar(theta);
            let (expected, quad_error) = directional_albedo(&brdf, wo, 256);
            let (mut sum, mut sum_sq) = (DVec3::ZERO, DVec3::ZERO);
            for _ in 0..n {
                let u_lobe = uniform(&mut rng);
                let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                if let Some(s) = brdf.sample(wo, u_lobe, u) {
                    assert!((brdf.pdf(wo, s.wi) - s.pdf).abs() <= 1e-5 * s.pdf);
                    let w = (s.f * s.wi.z / s.pdf).as_dvec3();
                    sum += w;
                    sum_sq += w * w;
                }
            }
            let mean = sum / n as f64;
            let se = ((sum_sq / n as f64 - mean * mean) / n as f64).map(f64::sqrt);
            for c in 0..3 {
                let tolerance = K_SIGMA * se[c] + quad_error;
                assert!(
                    (mean[c] - expected[c]).abs() <= tolerance,
                    "{brdf:?} theta {theta}: sampled {mean} vs quadrature {expected}"
                );
            }
        }
    }
}

#[test]
fn sampled_directions_follow_the_pdf() {
    // Chi-square test of a histogram of sampled directions against the pdf integrated over
    // each (theta, phi) bin. Bins expecting fewer than 20 samples are pooled into one.
    let (theta_bins, phi_bins, sub) = (16usize, 32usize, 6usize);
    let n = 200_000usize;
    let mut rng = Pcg32::new(5, 7);
    for brdf in materials() {
        for theta_o in [0.3, 1.2] {
            let wo = polar(theta_o);
            let mut counts = vec![0f64; theta_bins * phi_bins];
            for _ in 0..n {
                let u_lobe = uniform(&mut rng);
                let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                if let Some(s) = brdf.sample(wo, u_lobe, u) {
                    let theta = f64::from(s.wi.z).clamp(-1.0, 1.0).acos();
                    let phi = f64::from(s.wi.y)
                        .atan2(f64::from(s.wi.x))
                        .rem_euclid(2.0 * PI);
                    let i = ((theta / (PI / 2.0) * theta_bins as f64) as usize).min(theta_bins - 1);
                    let j = ((phi / (2.0 * PI) * phi_bins as f64) as usize).min(phi_bins - 1);
                    counts[i * phi_bins + j] += 1.0;
                }
            }
            let (dt, dp) = (PI / 2.0 / theta_bins as f64, 2.0 * PI / phi_bins as f64);
            let mut expected = vec![0f64; theta_bins * phi_bins];
            for (bin, e) in expected.iter_mut().enumerate() {
                let (i, j) = (bin / phi_bins, bin % phi_bins);
                for a in 0..sub {
                    let theta = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                    for b in 0..sub {
                        let phi = (j as f64 + (b as f64 + 0.5) / sub as f64) * dp;
                        let wi = DVec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        );
                        let solid_angle = theta.sin() * dt * dp / (sub * sub) as f64;
                        *e += f64::from(brdf.pdf(wo, wi.as_vec3())) * solid_angle * n as f64;
                    }
                }
            }
            let (mut chi2, mut dof, mut pooled_count, mut pooled_expected) =
                (0.0, 0usize, 0.0, 0.0);
            for (count, e) in counts.iter().zip(&expected) {
                if *e < 20.0 {
                    pooled_count += count;
                    pooled_expected += e;
                } else {
                    chi2 += (count - e).powi(2) / e;
                    dof += 1;
                }
            }
            if pooled_expected > 0.0 {
                chi2 += (pooled_count - pooled_expected).powi(2) / pooled_expected.max(1.0);
                dof += 1;
            }
            // Chi-square with `dof` degrees of freedom has mean dof and variance 2 dof.
            let limit = dof as f64 + K_SIGMA * (2.0 * dof as f64).sqrt();
            assert!(
                chi2 < limit,
                "{brdf:?} theta {theta_o}: chi2 {chi2:.1} over {dof} bins"
            );
        }
    }
}

#[test]
fn near_mirrors_reflect_everything_through_sampling() {
    // A white metal with roughness 0 (alpha = MIN_ALPHA) reflects about the normal with
    // weight G2 / G1, which differs from 1 by O(alpha^2 tan^2): every sample must carry ~1.
    let brdf = Brdf::new(Vec3::ONE, 1.0, 0.0);
    let mut rng = Pcg32::new(1, 2);
    let n = 2000;
    for theta in [0.0, 0.7, 1.3] {
        let wo = polar(theta);
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        let mut close = 0;
        for _ in 0..n {
            let u = Vec2::new(uniform(&mut rng), uniform(&mut rng));
            let s = brdf
                .sample(wo, uniform(&mut rng), u)
                .expect("mirror sample");
            let weight = s.f * s.wi.z / s.pdf;
            assert!((weight - Vec3::ONE).abs().max_element() < 1e-3, "{weight}");
            if s.wi.dot(mirror) > 0.05f32.cos() {
                close += 1;
            }
        }
        // GGX half-vector tails: P(theta_h > x) = alpha^2 / (alpha^2 + tan^2 x), 0.16% for the
        // 0.025 rad that deflects wi by 0.05 rad; 2% is far beyond any chance deviation.
        assert!(
            close as f64 >= 0.98 * n as f64,
            "only {close} of {n} near the mirror direction"
        );
    }
}

#[test]
fn split_sum_albedo_follows_the_specular_lobe() {
    // `specular_albedo` against the quadrature of the lobe alone: a black dielectric (f0 0.04,
    // no diffuse lobe) and a white metal (f0 1), from grazing to normal incidence, over the
    // roughness range whose lobes the midpoint rule resolves (at roughness 0.3 and grazing
    // angles only roughly: its error estimate, which widens the bound, is 0.07-0.1 there and
    // under 0.015 elsewhere). The bounds are the fit's documented accuracy: 7% of a
    // dielectric's albedo, 0.017 of a metal's.
    let mut worst = (0.0f64, 0.0f64);
    for roughness in [0.3f32, 0.4, 0.5, 0.6, 0.8, 1.0] {
        for n_dot_v in [0.05f32, 0.1, 0.2, 0.4, 0.7, 1.0] {
            let wo = Vec3::new((1.0 - n_dot_v * n_dot_v).sqrt(), 0.0, n_dot_v);
            let dielectric = Brdf::new(Vec3::ZERO, 0.0, roughness);
            let (expected, error) = directional_albedo(&dielectric, wo, 192);
            let fit = f64::from(specular_albedo(dielectric.f0(), roughness, n_dot_v).x);
            let relative = (fit - expected.x).abs() / expected.x;
            assert!(
                (fit - expected.x).abs() <= 0.07 * expected.x + error,
                "dielectric, roughness {roughness}, n.v {n_dot_v}: fit {fit}, lobe {expected}"
            );
            let metal = Brdf::new(Vec3::ONE, 1.0, roughness);
            let (expected, error) = directional_albedo(&metal, wo, 192);
            let fit = f64::from(specular_albedo(metal.f0(), roughness, n_dot_v).x);
            assert!(
                (fit - expected.x).abs() <= 0.017 + error,
                "metal, roughness {roughness}, n.v {n_dot_v}: fit {fit}, lobe {expected}"
            );
            worst = (worst.0.max(relative), worst.1.max((fit - expected.x).abs()));
        }
    }
    eprintln!(
        "worst: dielectric {:.3} relative, metal {:.4} absolute",
        worst.0, worst.1
    );
}

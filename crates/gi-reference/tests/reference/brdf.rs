//! The BRDF against closed forms, quadrature and its own sampling routine.

use std::f64::consts::PI;

use gi_reference::brdf::{Brdf, DielectricSpecular, MIN_ALPHA, specular_albedo};
use glam::{DVec3, Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;

use crate::common::{K_SIGMA, directional_albedo, lobe_albedo, polar};

fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 / 16_777_216.0
}

/// Materials spanning the lobe mixtures: diffuse-dominated, glossy dielectric, coloured rough
/// metal, white metal, a half-metal, a dielectric with a coloured high-ior specular layer at
/// half weight, and a pure Lambert one (specular 0).
fn materials() -> Vec<Brdf> {
    vec![
        Brdf::new(Vec3::splat(0.8), 0.0, 1.0),
        Brdf::new(Vec3::new(0.2, 0.5, 0.9), 0.0, 0.35),
        Brdf::new(Vec3::new(1.0, 0.8, 0.3), 1.0, 0.5),
        Brdf::new(Vec3::ONE, 1.0, 0.3),
        Brdf::new(Vec3::new(0.9, 0.6, 0.3), 0.5, 0.6),
        Brdf::new(Vec3::new(0.3, 0.6, 0.2), 0.0, 0.45).with_specular(DielectricSpecular::new(
            0.5,
            Vec3::new(1.0, 0.5, 0.2),
            2.4,
        )),
        Brdf::new(Vec3::new(0.7, 0.4, 0.2), 0.0, 0.5).with_specular(DielectricSpecular::new(
            0.0,
            Vec3::ONE,
            1.5,
        )),
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
        let dielectric = Brdf::new(Vec3::splat(0.5), 0.0, roughness);
        let w = f64::from(dielectric.diffuse_weight(1.0));
        let expected = 0.5 * w / PI + 0.04 / (4.0 * PI * alpha * alpha);
        let got = f64::from(dielectric.eval(Vec3::Z, Vec3::Z).x);
        assert!((got / expected - 1.0).abs() < 1e-5, "{got} vs {expected}");
    }
    assert_eq!(Brdf::new(Vec3::ONE, 0.0, 0.0).alpha, MIN_ALPHA);
}

#[test]
fn the_specular_extensions_set_the_dielectric_fresnel_term() {
    // KHR_materials_ior: F0 = ((ior - 1) / (ior + 1))^2; KHR_materials_specular scales it by
    // the specular color and the whole layer (F0 and F90) by the specular weight.
    let default = DielectricSpecular::default();
    assert!(
        (default.reflectance - Vec3::splat(0.04))
            .abs()
            .max_element()
            < 1e-7
    );
    assert_eq!(default.weight, 1.0);
    let glass = DielectricSpecular::new(0.5, Vec3::new(1.0, 0.5, 0.0), 2.0);
    let f0 = (1.0f32 / 3.0).powi(2);
    assert!(
        (glass.reflectance - Vec3::new(f0, 0.5 * f0, 0.0))
            .abs()
            .max_element()
            < 1e-7
    );
    let brdf = Brdf::new(Vec3::new(0.2, 0.4, 0.6), 0.0, 0.5).with_specular(glass);
    assert!((brdf.f0() - glass.reflectance * 0.5).abs().max_element() < 1e-7);
    assert_eq!(brdf.f90(), 0.5);
    // A metal ignores the dielectric layer: F0 = base, F90 = 1.
    let metal = Brdf::new(Vec3::new(0.2, 0.4, 0.6), 1.0, 0.5).with_specular(glass);
    assert_eq!(metal.f0(), Vec3::new(0.2, 0.4, 0.6));
    assert_eq!(metal.f90(), 1.0);
    // ior 0 (allowed by the extension) reflects the color fully; F0 never exceeds 1.
    assert_eq!(
        DielectricSpecular::new(1.0, Vec3::ONE, 0.0).reflectance,
        Vec3::ONE
    );
    assert_eq!(
        DielectricSpecular::new(1.0, Vec3::splat(30.0), 5.0).reflectance,
        Vec3::ONE
    );
}

#[test]
fn specular_zero_is_exactly_lambert() {
    // Specular 0 removes the dielectric's layer: f = base / pi for every pair of directions,
    // the sampler never picks the empty lobe, and the albedo is the base color.
    let base = Vec3::new(0.63, 0.065, 0.05);
    for roughness in [0.0f32, 0.3, 1.0] {
        let brdf = Brdf::new(base, 0.0, roughness).with_specular(DielectricSpecular::new(
            0.0,
            Vec3::ONE,
            1.5,
        ));
        for (a, b, phi) in [
            (0.0, 0.0, 0.0),
            (0.4, 1.2, 2.0),
            (1.5, 0.3, 3.1),
            (1.2, 1.2, 0.0),
        ] {
            let wo = polar(a);
            let wi = Vec3::new(
                (b as f32).sin() * (phi as f32).cos(),
                (b as f32).sin() * (phi as f32).sin(),
                (b as f32).cos(),
            );
            assert_eq!(brdf.eval(wo, wi), base / std::f32::consts::PI);
        }
        for theta in [0.0, 0.8, 1.5] {
            assert_eq!(brdf.specular_probability(polar(theta)), 0.0);
            assert_eq!(brdf.diffuse_albedo(polar(theta).z), base);
        }
    }
}

#[test]
fn brdf_matches_the_textbook_form() {
    // The whole BRDF written out independently in f64: D and Lambda in their tangent forms
    // (Walter et al. 2007), Schlick's Fresnel with F0 = mix(0.04, base, metallic), and the
    // Lambert lobe weighted by the BRDF's albedo scaling (checked on its own by the furnace
    // tests below), for a half-metallic coloured material.
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
        let w = f64::from(brdf.diffuse_weight(wo.z as f32));
        let expected = base * (1.0 - metallic) * w / PI + fresnel * d * g2 / (4.0 * wo.z * wi.z);
        let got = brdf.eval(wo.as_vec3(), wi.as_vec3()).as_dvec3();
        let error = ((got - expected) / expected).abs().max_element();
        assert!(error < 1e-4, "{got} vs {expected}");
    }
}

#[test]
fn zero_below_the_surface_and_reciprocal_without_a_dielectric_layer() {
    // The albedo scaling of the Lambert base depends on wo only, so only the specular layer
    // itself, a metal or a layer-free Lambert surface, is reciprocal.
    for brdf in materials() {
        let reciprocal = brdf.metallic == 1.0 || brdf.specular.weight == 0.0;
        for (a, b) in [(0.2, 1.1), (0.9, 0.4), (1.4, 0.7)] {
            let wo = polar(a);
            let wi = Vec3::new(-0.3, 0.5, 0.0) + polar(b);
            let wi = wi.normalize();
            let (f1, f2) = (brdf.eval(wo, wi), brdf.eval(wi, wo));
            if reciprocal {
                assert!((f1 - f2).abs().max_element() <= 1e-5 * f1.max_element());
            }
            assert_eq!(brdf.eval(wo, wi * Vec3::new(1.0, 1.0, -1.0)), Vec3::ZERO);
            assert_eq!(brdf.pdf(wo, wi * Vec3::new(1.0, 1.0, -1.0)), 0.0);
        }
    }
}

#[test]
fn white_furnace_never_reflects_more_than_it_receives() {
    // A white surface of any roughness, metalness and specular layer, seen from any angle,
    // reflects at most what it receives: its directional albedo (by quadrature over the
    // lobes, whose own error estimate is the tolerance) never exceeds 1. glTF's pointwise
    // fresnel_mix would reach 1.28 here (roughness 0.3, n.v 0.1); the albedo scaling must not.
    let layers = [
        DielectricSpecular::default(),
        DielectricSpecular::new(1.0, Vec3::ONE, 3.0),
        DielectricSpecular::new(0.6, Vec3::new(1.0, 0.2, 0.6), 1.8),
    ];
    let mut highest = (0.0f64, String::new());
    for roughness in [0.0f32, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0] {
        for metallic in [0.0f32, 0.5, 1.0] {
            for layer in layers {
                let brdf = Brdf::new(Vec3::ONE, metallic, roughness).with_specular(layer);
                for theta in [0.0, 0.5, 1.0, 1.3, 1.47, 1.53, 1.56] {
                    let (albedo, error) = lobe_albedo(&brdf, polar(theta), 96);
                    let what = format!(
                        "roughness {roughness} metallic {metallic} {layer:?} theta {theta}"
                    );
                    assert!(
                        albedo.max_element() <= 1.0 + error,
                        "{what}: albedo {albedo} (quadrature error {error:.1e})"
                    );
                    if albedo.max_element() > highest.0 {
                        highest = (albedo.max_element(), what);
                    }
                }
            }
        }
    }
    eprintln!("highest albedo {:.5}: {}", highest.0, highest.1);
}

#[test]
fn white_furnace_albedo_matches_its_layers() {
    // The albedo of the whole BRDF, integrated numerically, against what the model says it
    // is: (1 - metallic) (base w + s E_d) + metallic E_m with E from `specular_albedo` and w
    // the base's weight. `specular_albedo` never under-states the layer (its fit was shifted
    // up) and over-states it by at most 0.008 (the fit script's check), so the integral lies
    // between the model minus that and the model, widened by the quadrature's own error.
    const FIT_EXCESS: f64 = 0.008;
    for roughness in [0.0f32, 0.2, 0.4, 0.7, 1.0] {
        for metallic in [0.0f32, 0.5, 1.0] {
            for base in [Vec3::ONE, Vec3::new(0.8, 0.3, 0.1)] {
                let brdf = Brdf::new(base, metallic, roughness);
                for theta in [0.0, 0.7, 1.2, 1.5] {
                    let wo = polar(theta);
                    let (albedo, error) = lobe_albedo(&brdf, wo, 96);
                    let layer = specular_albedo(brdf.f0(), brdf.f90(), roughness, wo.z);
                    let model = (brdf.diffuse_albedo(wo.z) + layer).as_dvec3();
                    for c in 0..3 {
                        assert!(
                            albedo[c] <= model[c] + error
                                && albedo[c] >= model[c] - FIT_EXCESS - error,
                            "roughness {roughness} metallic {metallic} base {base} theta {theta}: \
                             integral {albedo} vs model {model} (quadrature error {error:.1e})"
                        );
                    }
                }
            }
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
            // A Lambert surface's weights are all equal: the variance rounds to about 0, maybe
            // below it.
            let variance = (sum_sq / n as f64 - mean * mean).max(DVec3::ZERO);
            let se = (variance / n as f64).map(f64::sqrt);
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
    // `specular_albedo` against the quadrature of the lobe alone over its lobes: a black
    // dielectric (F0 0.04, no diffuse lobe), a white metal (F0 1) and a half-weight layer
    // (F0 0.02, F90 0.5), from grazing to normal incidence and from mirrors to roughness 1.
    // The fit may over-state the albedo by at most 0.008 and never under-states it (the fit
    // script's check), up to the quadrature's error.
    let mut worst = (0.0f64, 0.0f64);
    for roughness in [0.0f32, 0.1, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0] {
        for n_dot_v in [0.02f32, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0] {
            let wo = Vec3::new((1.0 - n_dot_v * n_dot_v).sqrt(), 0.0, n_dot_v);
            for brdf in [
                Brdf::new(Vec3::ZERO, 0.0, roughness),
                Brdf::new(Vec3::ONE, 1.0, roughness),
                Brdf::new(Vec3::ZERO, 0.0, roughness).with_specular(DielectricSpecular::new(
                    0.5,
                    Vec3::ONE,
                    1.5,
                )),
            ] {
                let (expected, error) = lobe_albedo(&brdf, wo, 128);
                let fit = f64::from(specular_albedo(brdf.f0(), brdf.f90(), roughness, n_dot_v).x);
                let excess = fit - expected.x;
                assert!(
                    excess >= -error && excess <= 0.008 + error,
                    "{brdf:?}, n.v {n_dot_v}: fit {fit}, lobe {expected} (error {error:.1e})"
                );
                worst = (worst.0.min(excess), worst.1.max(excess));
            }
        }
    }
    eprintln!("fit - lobe in [{:.5}, {:.5}]", worst.0, worst.1);
}

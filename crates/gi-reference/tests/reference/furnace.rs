//! Furnace tests: surfaces under a constant sky, and an enclosure that glows and reflects. Their
//! expected values follow from the BRDF alone (by quadrature), so they check the integrator's
//! sampling, pdfs and MIS weights end to end.

use gi_reference::brdf::Brdf;
use gi_reference::{Reference, Strategy};
use gi_scene::{CameraView, Material, Sky};
use glam::{DVec3, Vec3};

use crate::common::{
    Estimate, K_SIGMA, SceneBuilder, diffuse, directional_albedo, emitter, floor, gauss_legendre,
    image_mean, material, polar, region_mean, render, settings, sphere,
};

const STRATEGIES: [Strategy; 3] = [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly];
const SKY: Vec3 = Vec3::new(1.5, 1.0, 0.5);

fn constant_sky() -> Sky {
    Sky::Constant { radiance: SKY }
}

/// A large plane seen at `theta` from its normal through a camera so narrow (0.01 rad) that
/// every pixel sees it at nearly the same angle.
fn plane_under_sky(material: Material, theta: f64) -> Reference {
    let mut builder = SceneBuilder::new(constant_sky());
    builder.add(floor(Vec3::ZERO, 4.0), material);
    let eye = Vec3::new(theta.sin() as f32, theta.cos() as f32, 0.0) * 20.0;
    builder.reference(CameraView::look_at(eye, Vec3::ZERO, 0.01))
}

#[test]
fn plane_under_a_constant_sky_reflects_its_directional_albedo() {
    // A plane sees only sky above it, so its radiance is L * integral f cos: the directional
    // albedo, computed here by quadrature of the BRDF. Per pixel the view angle varies by at
    // most the half-diagonal of the field of view; the albedo's change over that range is
    // added to the tolerance.
    let cases = [
        (material(Vec3::splat(0.5), 0.0, 1.0), 0),
        (material(Vec3::new(0.2, 0.5, 0.9), 0.0, 0.35), 1),
        (material(Vec3::new(1.0, 0.8, 0.3), 1.0, 0.5), 2),
        (material(Vec3::ONE, 1.0, 0.3), 3),
    ];
    let half_diagonal = (0.005f64.tan() * 2f64.sqrt()).atan();
    for (m, id) in cases {
        let brdf = Brdf::new(m.base_color.truncate(), m.metallic, m.roughness);
        for theta in [0.3, 1.0, 1.4] {
            let (albedo, quad_error) = directional_albedo(&brdf, polar(theta), 256);
            let spread = [theta - half_diagonal, theta + half_diagonal]
                .map(|t| {
                    (directional_albedo(&brdf, polar(t), 256).0 - albedo)
                        .abs()
                        .max_element()
                })
                .into_iter()
                .fold(0.0, f64::max);
            let reference = plane_under_sky(m.clone(), theta);
            for (s, strategy) in STRATEGIES.into_iter().enumerate() {
                let seed = 100 * id + 10 * s as u64 + (theta * 10.0) as u64;
                let r = render(&reference, &settings(16, 256, seed, strategy));
                for c in 0..3 {
                    let sky = f64::from(SKY[c]);
                    let what = format!("material {id} theta {theta} {strategy:?} channel {c}");
                    image_mean(&r, c).assert_near(
                        sky * albedo[c],
                        sky * (quad_error + spread),
                        &what,
                    );
                }
            }
        }
    }
}

#[test]
fn mirror_under_a_constant_sky_reflects_the_sky() {
    // A white metal at the minimum roughness reflects the sky with weight G2/G1, within 1e-5
    // of 1 away from grazing. Light sampling cannot find a 1e-3-wide lobe, so only the
    // strategies that sample the BRDF are checked.
    let reference = plane_under_sky(material(Vec3::ONE, 1.0, 0.0), 0.8);
    for (seed, strategy) in [(1, Strategy::Mis), (2, Strategy::BsdfOnly)] {
        let r = render(&reference, &settings(16, 16, seed, strategy));
        for c in 0..3 {
            let sky = f64::from(SKY[c]);
            image_mean(&r, c).assert_near(sky, sky * 1e-5, &format!("{strategy:?} channel {c}"));
        }
    }
}

/// A convex polyhedron filling the whole view: camera at distance 3 from a unit flat-shaded
/// sphere, 0.4 rad field of view (rays pass within 0.83 of the center, inside every facet).
fn sphere_in_view(material: Material) -> Reference {
    let mut builder = SceneBuilder::new(constant_sky());
    builder.add(sphere(Vec3::ZERO, 1.0, 48, 24, true), material);
    builder.reference(CameraView::look_at(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        0.4,
    ))
}

/// Means and standard errors of 4x4-pixel blocks of a 32x32 render: enough samples per block
/// for its standard error to be accurate and its mean close to normal.
fn blocks(r: &crate::common::Rendered, c: usize) -> Vec<Estimate> {
    (0..64u32)
        .map(|b| region_mean(r, c, |x, y| x / 4 == b % 8 && y / 4 == b / 8))
        .collect()
}

#[test]
fn convex_diffuse_object_under_a_constant_sky_has_albedo_times_sky() {
    // Every point of a convex object sees only sky, so its radiance is L times its directional
    // albedo: exactly a * L for a Lambert surface (a dielectric with specular 0).
    for (i, albedo) in [0.3f32, 0.8].into_iter().enumerate() {
        let lit = sphere_in_view(diffuse(albedo));
        for (s, strategy) in STRATEGIES.into_iter().enumerate() {
            let seed = 1000 + 10 * i as u64 + s as u64;
            let a = render(&lit, &settings(32, 128, seed, strategy));
            for c in 0..3 {
                let expected = f64::from(albedo * SKY[c]);
                let what = format!("albedo {albedo} {strategy:?} channel {c}");
                for block in blocks(&a, c) {
                    block.assert_near(expected, 0.0, &what);
                }
                image_mean(&a, c).assert_near(expected, 0.0, &what);
            }
        }
    }
}

#[test]
fn white_dielectric_under_a_constant_sky_reflects_at_most_the_sky() {
    // The white furnace on whole renders: a white glTF dielectric (the default specular layer)
    // sees only the sky, so no pixel may be brighter than the sky, whatever its roughness and
    // view angle. Before the base was weighted by the specular layer, it rendered 1.6%
    // brighter than the sky at roughness 1.
    for (i, roughness) in [1.0f32, 0.3].into_iter().enumerate() {
        let sphere = sphere_in_view(material(Vec3::ONE, 0.0, roughness));
        let r = render(&sphere, &settings(32, 256, 3000 + i as u64, Strategy::Mis));
        for c in 0..3 {
            let sky = f64::from(SKY[c]);
            for block in blocks(&r, c) {
                assert!(
                    block.mean <= sky + K_SIGMA * block.se,
                    "roughness {roughness} channel {c}: block {} +- {} above the sky {sky}",
                    block.mean,
                    block.se
                );
            }
            let mean = image_mean(&r, c);
            assert!(
                mean.mean <= sky + K_SIGMA * mean.se,
                "roughness {roughness}: {mean:?}"
            );
        }
    }
}
#[test]
fn white_metal_object_never_returns_more_than_the_sky() {
    for (seed, roughness) in [(7u64, 0.15f32), (8, 0.6)] {
        let reference = sphere_in_view(material(Vec3::ONE, 1.0, roughness));
        let r = render(&reference, &settings(32, 128, seed, Strategy::Mis));
        for c in 0..3 {
            let sky = f64::from(SKY[c]);
            for block in blocks(&r, c) {
                assert!(
                    block.mean <= sky + K_SIGMA * block.se,
                    "roughness {roughness}: {block:?} > {sky}"
                );
                assert!(
                    block.mean > 0.3 * sky,
                    "roughness {roughness}: implausibly dark {block:?}"
                );
            }
        }
    }
}

/// Radiance `L(mu)` leaving the inside of a sphere of uniform emission `emission` and BRDF
/// `f(wo, wi)`, at cosine `mu` from the inward normal. By symmetry radiance depends only on
/// `mu`, and a chord leaves and arrives at the same angle, so
/// `L(mu) = E + integral f(mu, mu', phi) L(mu') mu' dmu' dphi`, solved by Nystrom's method on
/// `n` Gauss-Legendre nodes (in `mu'`) and `2n` midpoint azimuths.
fn sphere_interior_radiance(
    f: impl Fn(Vec3, Vec3) -> f64,
    emission: f64,
    n: usize,
    mu: f64,
) -> f64 {
    let nodes = gauss_legendre(n);
    let kernel_row = |mu_o: f64| -> Vec<f64> {
        let wo = DVec3::new((1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o).as_vec3();
        nodes
            .iter()
            .map(|&(mu_i, weight)| {
                let sin_i = (1.0 - mu_i * mu_i).sqrt();
                let dphi = std::f64::consts::PI / n as f64;
                let ring: f64 = (0..2 * n)
                    .map(|k| {
                        let phi = (k as f64 + 0.5) * dphi;
                        let wi = DVec3::new(sin_i * phi.cos(), sin_i * phi.sin(), mu_i);
                        f(wo, wi.as_vec3()) * dphi
                    })
                    .sum();
                ring * mu_i * weight
            })
            .collect()
    };
    let kernel: Vec<Vec<f64>> = nodes.iter().map(|&(m, _)| kernel_row(m)).collect();
    let mut radiance = vec![emission; n];
    for _ in 0..500 {
        radiance = kernel
            .iter()
            .map(|row| emission + row.iter().zip(&radiance).map(|(k, l)| k * l).sum::<f64>())
            .collect();
    }
    emission
        + kernel_row(mu)
            .iter()
            .zip(&radiance)
            .map(|(k, l)| k * l)
            .sum::<f64>()
}

#[test]
fn glowing_enclosure_radiance_is_the_geometric_series() {
    // For a Lambertian kernel the solver must give the geometric series E / (1 - a).
    let lambert = sphere_interior_radiance(|_, _| 0.6 / std::f64::consts::PI, 1.0, 16, 1.0);
    assert!((lambert - 1.0 / 0.4).abs() < 1e-9, "solver: {lambert}");

    // The camera sits at the center of a 64x32 flat-shaded sphere, so every pixel sees
    // L(mu = 1). Facets tilt the view by at most 0.05 rad, which moves mu by 1e-3 and L by
    // well under 1e-4 of itself (L varies with mu only through the few-percent specular
    // albedo); the tolerance is the render's noise plus the solver's quadrature error
    // (the change from halving its grid).
    let emission = 1.0f32;
    for (i, (albedo, strategies)) in [(0.5f32, &STRATEGIES[..]), (0.8, &STRATEGIES[..1])]
        .into_iter()
        .enumerate()
    {
        let brdf = Brdf::new(Vec3::splat(albedo), 0.0, 1.0);
        let f = |wo, wi| f64::from(brdf.eval(wo, wi).x);
        let expected = sphere_interior_radiance(f, emission.into(), 32, 1.0);
        let quad_error = (expected - sphere_interior_radiance(f, emission.into(), 16, 1.0)).abs();
        assert!(
            expected > 1.0 / (1.0 - f64::from(albedo)),
            "the specular lobe adds energy"
        );

        let mut builder = SceneBuilder::new(Sky::default());
        let mut m = emitter(Vec3::splat(emission), true);
        m.base_color = Vec3::splat(albedo).extend(1.0);
        builder.add(sphere(Vec3::ZERO, 1.0, 64, 32, true), m);
        let reference = builder.reference(CameraView::look_at(Vec3::ZERO, Vec3::X, 1.0));
        for (s, &strategy) in strategies.iter().enumerate() {
            let r = render(
                &reference,
                &settings(16, 128, 3000 + 10 * i as u64 + s as u64, strategy),
            );
            for c in 0..3 {
                let what = format!("albedo {albedo} {strategy:?} channel {c}");
                image_mean(&r, c).assert_near(expected, quad_error, &what);
            }
        }
    }
}

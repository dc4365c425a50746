//! Emissive triangles lighting a floor, against the exact irradiance from a rectangle.

use std::f64::consts::PI;

use gi_reference::{Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, Sky, Texture, TextureEncoding, TextureRef};
use glam::{DVec3, Vec2, Vec3};

use crate::common::{SceneBuilder, diffuse, emitter, floor, image_mean, quad, render, settings};

const ALBEDO: f32 = 0.7;

/// A horizontal square emitter: center, half-size, radiance.
#[derive(Clone, Copy)]
struct Square {
    center: Vec3,
    half: f32,
    radiance: f32,
}

/// Form factor from a point to the rectangle `[0, x] x [0, y]` parallel to it at height `h`,
/// one corner straight above (Howell's catalog, B-3); odd in `x` and in `y`, so rectangles
/// anywhere follow by inclusion-exclusion.
fn corner_form_factor(x: f64, y: f64, h: f64) -> f64 {
    let (a, b) = (x / h, y / h);
    let (sa, sb) = ((1.0 + a * a).sqrt(), (1.0 + b * b).sqrt());
    (a / sa * (b / sa).atan() + b / sb * (a / sb).atan()) / (2.0 * PI)
}

/// Irradiance at floor point `p` from the squares (each facing the floor).
fn irradiance(squares: &[Square], p: DVec3) -> f64 {
    squares
        .iter()
        .map(|s| {
            let c = s.center.as_dvec3() - p;
            let half = f64::from(s.half);
            let (x0, x1, z0, z1) = (c.x - half, c.x + half, c.z - half, c.z + half);
            let f = |x, z| corner_form_factor(x, z, c.y);
            PI * f64::from(s.radiance) * (f(x1, z1) - f(x0, z1) - f(x1, z0) + f(x0, z0))
        })
        .sum()
}

fn camera() -> CameraView {
    // Looks at the origin from the side, clear of every emitter, through a 0.05 rad film.
    CameraView::look_at(Vec3::new(2.5, 1.2, 0.8), Vec3::ZERO, 0.05)
}

/// The Lambertian radiance `albedo / pi * E` averaged over the film, by the midpoint rule on an
/// `n x n` film grid; the change from halving the grid (also passed to `irradiance`, which
/// may refine its own quadrature with it) is returned as its error.
fn expected_mean(irradiance: impl Fn(DVec3, usize) -> f64, n: usize) -> (f64, f64) {
    let camera = camera();
    let mean = |n: usize| {
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let (u, v) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let dir = camera.ray_direction(u, v, 1.0).as_dvec3();
                let origin = camera.position.as_dvec3();
                let p = origin + dir * (origin.y / -dir.y);
                sum += f64::from(ALBEDO) / PI * irradiance(p, n);
            }
        }
        sum / (n * n) as f64
    };
    let fine = mean(n);
    (fine, (fine - mean(n / 2)).abs())
}

/// Floor of albedo `albedo` lit by the squares; `facing_up` flips them, `double_sided` makes
/// them emit on both sides.
fn scene(squares: &[Square], albedo: f32, facing_up: bool, double_sided: bool) -> Reference {
    let mut builder = SceneBuilder::new(Sky::default());
    builder.add(floor(Vec3::ZERO, 10.0), diffuse(albedo));
    for s in squares {
        let u = Vec3::X * s.half;
        let v = if facing_up { Vec3::NEG_Z } else { Vec3::Z } * s.half;
        builder.add(
            quad(s.center, u, v),
            emitter(Vec3::splat(s.radiance), double_sided),
        );
    }
    builder.reference(camera())
}

fn direct_lighting(spp: u32, seed: u64, strategy: Strategy) -> RenderSettings {
    RenderSettings {
        max_depth: 1,
        ..settings(16, spp, seed, strategy)
    }
}

/// Renders the floor with albedo `ALBEDO` and 0 (independent seeds) under the same emitters
/// and checks the mean difference, the Lambert term, against `expected` (value, error).
fn check(build: impl Fn(f32) -> Reference, expected: (f64, f64), seed: u64, what: &str) {
    let (lit, black) = (build(ALBEDO), build(0.0));
    for (s, (strategy, spp)) in [
        (Strategy::Mis, 512),
        (Strategy::LightOnly, 512),
        (Strategy::BsdfOnly, 2048),
    ]
    .into_iter()
    .enumerate()
    {
        let seed = seed + 10 * s as u64;
        let a = render(&lit, &direct_lighting(spp, seed, strategy));
        let b = render(&black, &direct_lighting(spp, seed + 1, strategy));
        for c in 0..3 {
            let what = format!("{what} {strategy:?} channel {c}");
            image_mean(&a, c)
                .minus(image_mean(&b, c))
                .assert_near(expected.0, expected.1, &what);
        }
    }
}

/// [`check`] for untextured squares against the exact rectangle irradiance.
fn check_squares(squares: &[Square], facing_up: bool, double_sided: bool, seed: u64, what: &str) {
    let expected = expected_mean(|p, _| irradiance(squares, p), 64);
    check(
        |albedo| scene(squares, albedo, facing_up, double_sided),
        expected,
        seed,
        what,
    );
}

const SMALL: Square = Square {
    center: Vec3::new(0.0, 1.0, 0.0),
    half: 0.1,
    radiance: 20.0,
};

const LARGE: Square = Square {
    center: Vec3::new(-0.5, 1.5, 0.3),
    half: 0.3,
    radiance: 2.0,
};

#[test]
fn small_emitter_gives_the_exact_rectangle_irradiance() {
    // Sanity of the closed form: a small square approaches Le * A * cos^2 / d^2 seen from
    // straight below, and the test's expected value is that of the exact form.
    let e = irradiance(&[SMALL], DVec3::ZERO);
    let small_limit = f64::from(SMALL.radiance) * 0.04;
    assert!((e / small_limit - 1.0).abs() < 0.03, "{e} vs {small_limit}");
    check_squares(&[SMALL], false, false, 10, "small square");
}

#[test]
fn emitters_of_unequal_power_add_up() {
    // Power-proportional selection gives the two squares very different probabilities; a
    // selection pdf that disagrees with the table biases the sum.
    check_squares(&[SMALL, LARGE], false, false, 20, "two squares");
}

#[test]
fn single_sided_emitters_light_only_their_front() {
    let reference = scene(&[SMALL, LARGE], ALBEDO, true, false);
    let r = render(&reference, &direct_lighting(32, 5, Strategy::Mis));
    assert!(
        r.image.pixels.iter().all(|p| *p == Vec3::ZERO),
        "light from a back face"
    );
    // With all bounces, a lone upward emitter lights nothing (with two, the lower one's light
    // would reflect off the upper one's back).
    let lone = scene(&[SMALL], ALBEDO, true, false);
    let full = render(&lone, &settings(16, 32, 6, Strategy::Mis));
    assert!(
        full.image.pixels.iter().all(|p| *p == Vec3::ZERO),
        "light from a back face"
    );
    check_squares(
        &[SMALL, LARGE],
        true,
        true,
        30,
        "double-sided squares facing away",
    );
}

#[test]
fn textured_emitters_emit_their_texture() {
    // A 2x1 texture, white and black texels, wraps bilinearly into a triangle wave across the
    // square. Its irradiance is integrated numerically over the emitter (midpoint rule,
    // `Le(uv) h^2 / r^4 dA` for parallel faces), with the film grid's refinement.
    let texture = Texture {
        name: String::new(),
        width: 2,
        height: 1,
        encoding: TextureEncoding::Srgb,
        texels: vec![[255; 4], [0, 0, 0, 255]],
    };
    let square = Square {
        center: Vec3::new(0.1, 0.8, -0.1),
        half: 0.25,
        radiance: 10.0,
    };
    let textured = texture.clone();
    let irradiance = move |p: DVec3, n: usize| {
        let m = n * 3 / 4;
        let side = 2.0 * f64::from(square.half);
        let c = square.center.as_dvec3();
        let mut sum = 0.0;
        for i in 0..m {
            for j in 0..m {
                let uv = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                let y = c + DVec3::new(
                    (f64::from(uv.x) - 0.5) * side,
                    0.0,
                    (f64::from(uv.y) - 0.5) * side,
                );
                let r2 = (y - p).length_squared();
                let le = f64::from(square.radiance * textured.sample_bilinear(uv).x);
                sum += le * c.y * c.y / (r2 * r2) * side * side / (m * m) as f64;
            }
        }
        sum
    };
    let expected = expected_mean(irradiance, 48);
    let build = |albedo: f32| {
        let mut builder = SceneBuilder::new(Sky::default());
        builder.add(floor(Vec3::ZERO, 10.0), diffuse(albedo));
        let mut light = emitter(Vec3::splat(square.radiance), false);
        light.emissive_texture = Some(TextureRef::new(0));
        builder.add(
            quad(square.center, Vec3::X * square.half, Vec3::Z * square.half),
            light,
        );
        builder.scene.textures.push(texture.clone());
        builder.reference(camera())
    };
    check(build, expected, 40, "textured square");
}

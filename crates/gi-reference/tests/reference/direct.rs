//! Punctual lights in [`Mode::Direct`], against closed forms. Direct mode is deterministic
//! apart from the pixel jitter, so each pixel's value is bounded by the closed form's extremes
//! over that pixel's footprint on the floor, up to f32 rounding.

use std::f64::consts::PI;

use gi_reference::{Mode, Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, LightKind, Sky};
use glam::{DVec2, Vec3};

use crate::common::{SceneBuilder, diffuse, floor, material, quad, render, settings};

const SIZE: u32 = 32;
const ALBEDO: f32 = 0.6;

/// Relative f32 rounding allowance on a radiance made of a few dozen operations.
const ROUNDING: f64 = 1e-5;

fn direct(seed: u64) -> RenderSettings {
    RenderSettings {
        mode: Mode::Direct,
        ..settings(SIZE, 4, seed, Strategy::Mis)
    }
}

/// Camera 10 above `(center_x, 0, 0)` looking straight down: the film is parallel to the
/// floor, so each pixel's footprint is an axis-aligned rectangle.
fn camera(center_x: f32, yfov: f32) -> CameraView {
    CameraView::look_at(
        Vec3::new(center_x, 10.0, 0.0),
        Vec3::new(center_x, 0.0, 0.0),
        yfov,
    )
}

/// The floor rectangle `[min, max]` (in x, z) that pixel `(x, y)` sees.
fn footprint(camera: &CameraView, x: u32, y: u32) -> (DVec2, DVec2) {
    let corners = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)].map(|(cx, cy)| {
        let dir = camera.ray_direction(cx as f32 / SIZE as f32, cy as f32 / SIZE as f32, 1.0);
        let p = camera.position.as_dvec3()
            + dir.as_dvec3() * (f64::from(camera.position.y) / -f64::from(dir.y));
        DVec2::new(p.x, p.z)
    });
    let min = corners.iter().fold(DVec2::INFINITY, |a, b| a.min(*b));
    let max = corners.iter().fold(DVec2::NEG_INFINITY, |a, b| a.max(*b));
    (min, max)
}

/// Nearest and farthest distance from `q` to the rectangle.
fn distance_range(q: DVec2, (min, max): (DVec2, DVec2)) -> (f64, f64) {
    let nearest = q.clamp(min, max).distance(q);
    let farthest = (q - min).abs().max((q - max).abs()).length();
    (nearest, farthest)
}

/// Lambertian radiance from a point light of intensity `i` at height `h`, `r` off its foot.
fn point_lit(i: f64, h: f64, r: f64) -> f64 {
    f64::from(ALBEDO) / PI * i * h / (h * h + r * r).powf(1.5)
}

/// Renders the scene built by `lights` twice, with floor albedo `ALBEDO` and 0, and returns
/// both images. The same seed gives the same jitter, so every pixel of their difference is the
/// Lambert term alone (the floor has no specular layer, and black reflects nothing).
fn lit_and_black(camera: CameraView, lights: impl Fn(&mut SceneBuilder)) -> (Vec<Vec3>, Vec<Vec3>) {
    let build = |albedo: f32| -> Reference {
        let mut builder = SceneBuilder::new(Sky::default());
        builder.add(floor(Vec3::ZERO, 20.0), diffuse(albedo));
        lights(&mut builder);
        builder.reference(camera)
    };
    let a = render(&build(ALBEDO), &direct(9)).image.pixels;
    let b = render(&build(0.0), &direct(9)).image.pixels;
    (a, b)
}

fn assert_between(value: Vec3, black: Vec3, lo: f64, hi: f64, what: &str) {
    for c in 0..3 {
        let diff = f64::from(value[c] - black[c]);
        let slack = ROUNDING * f64::from(value[c] + black[c]) + 1e-9;
        assert!(
            diff >= lo - slack && diff <= hi + slack,
            "{what}: {diff} not in [{lo}, {hi}]"
        );
    }
}

#[test]
fn point_light_follows_the_inverse_square_law() {
    let (i, light) = (5.0, Vec3::new(0.3, 2.0, -0.2));
    let camera = camera(0.0, 0.2);
    let (a, b) = lit_and_black(camera, |s| {
        s.light(LightKind::Point, i, light, Vec3::NEG_Y);
    });
    let foot = DVec2::new(light.x.into(), light.z.into());
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (near, far) = distance_range(foot, footprint(&camera, x, y));
            let k = (y * SIZE + x) as usize;
            let h = f64::from(light.y);
            let what = format!("pixel ({x}, {y})");
            assert_between(
                a[k],
                b[k],
                point_lit(i.into(), h, far),
                point_lit(i.into(), h, near),
                &what,
            );
        }
    }
}

#[test]
fn directional_light_gives_cosine_irradiance() {
    for theta in [0.0f64, 0.7, 1.2] {
        let e = 3.0;
        let direction = Vec3::new(theta.sin() as f32, -theta.cos() as f32, 0.0);
        let (a, b) = lit_and_black(camera(0.0, 0.2), |s| {
            s.light(
                LightKind::Directional,
                e,
                Vec3::new(0.0, 5.0, 0.0),
                direction,
            );
        });
        let expected = f64::from(ALBEDO) / PI * f64::from(e) * theta.cos();
        for (k, (lit, black)) in a.iter().zip(&b).enumerate() {
            assert_between(
                *lit,
                *black,
                expected,
                expected,
                &format!("theta {theta} pixel {k}"),
            );
        }
    }
}

#[test]
fn spot_light_cone() {
    let (i, h, inner, outer) = (4.0f32, 2.0f32, 0.25f32, 0.45f32);
    let camera = camera(0.0, 0.3);
    let (a, b) = lit_and_black(camera, |s| {
        let kind = LightKind::Spot {
            inner_cone_angle: inner,
            outer_cone_angle: outer,
        };
        s.light(kind, i, Vec3::new(0.0, h, 0.0), Vec3::NEG_Y);
    });
    let (r_inner, r_outer) = (f64::from(h * inner.tan()), f64::from(h * outer.tan()));
    let (mut inside, mut outside) = (0, 0);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (near, far) = distance_range(DVec2::ZERO, footprint(&camera, x, y));
            let k = (y * SIZE + x) as usize;
            let point = |r| point_lit(i.into(), h.into(), r);
            let what = format!("pixel ({x}, {y})");
            if near > r_outer * (1.0 + ROUNDING) {
                assert_eq!(a[k], Vec3::ZERO, "{what} outside the outer cone");
                outside += 1;
            } else if far < r_inner * (1.0 - ROUNDING) {
                assert_between(a[k], b[k], point(far), point(near), &what);
                inside += 1;
            } else {
                assert_between(a[k], b[k], 0.0, point(near), &what);
            }
        }
    }
    // The view covers about 9% of pixels inside the inner cone and 68% outside the outer one.
    assert!(
        inside > 40 && outside > 400,
        "{inside} inside, {outside} outside"
    );
}

#[test]
fn occluders_cast_exact_shadows() {
    // A 0.2-wide square halfway between a point light at height 2 and the floor: its umbra is
    // the square scaled by 2 about the light's foot, x in [0.6, 1.0] and z in [-0.2, 0.2].
    let (i, light) = (5.0, Vec3::new(0.0, 2.0, 0.0));
    let camera = camera(0.8, 0.06);
    let (a, b) = lit_and_black(camera, |s| {
        s.light(LightKind::Point, i, light, Vec3::NEG_Y);
        s.add(
            quad(Vec3::new(0.4, 1.0, 0.0), Vec3::X * 0.1, Vec3::NEG_Z * 0.1),
            material(Vec3::ONE, 0.0, 0.5),
        );
    });
    let umbra = (DVec2::new(0.6, -0.2), DVec2::new(1.0, 0.2));
    let (mut shadowed, mut lit) = (0, 0);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (min, max) = footprint(&camera, x, y);
            let k = (y * SIZE + x) as usize;
            let (near, far) = distance_range(DVec2::ZERO, (min, max));
            let what = format!("pixel ({x}, {y})");
            let margin = DVec2::splat(1e-4);
            if min.cmpge(umbra.0 + margin).all() && max.cmple(umbra.1 - margin).all() {
                assert_eq!(a[k], Vec3::ZERO, "{what} inside the umbra");
                shadowed += 1;
            } else if max.cmplt(umbra.0 - margin).any() || min.cmpgt(umbra.1 + margin).any() {
                assert_between(
                    a[k],
                    b[k],
                    point_lit(i.into(), 2.0, far),
                    point_lit(i.into(), 2.0, near),
                    &what,
                );
                lit += 1;
            }
        }
    }
    assert!(
        shadowed > 100 && lit > 100,
        "{shadowed} shadowed, {lit} lit"
    );
}

#[test]
fn full_mode_with_one_bounce_equals_direct_mode_without_other_lights() {
    // With only punctual lights, a black sky and max_depth = 1, the path tracer's estimate is
    // exactly the direct term: same jitter, same first hit, same light loop.
    let mut builder = SceneBuilder::new(Sky::default());
    builder
        .add(
            floor(Vec3::ZERO, 20.0),
            material(Vec3::new(0.7, 0.5, 0.3), 0.3, 0.4),
        )
        .add(
            quad(Vec3::new(0.4, 1.0, 0.0), Vec3::X * 0.3, Vec3::NEG_Z * 0.2),
            diffuse(0.5),
        )
        .light(LightKind::Point, 5.0, Vec3::new(0.0, 2.0, 0.3), Vec3::NEG_Y)
        .light(
            LightKind::Directional,
            1.0,
            Vec3::ZERO,
            Vec3::new(0.3, -1.0, 0.2),
        );
    let reference = builder.reference(CameraView::look_at(
        Vec3::new(2.0, 3.0, 2.0),
        Vec3::ZERO,
        0.9,
    ));
    let direct = render(&reference, &direct(3));
    let full = render(
        &reference,
        &RenderSettings {
            max_depth: 1,
            ..settings(SIZE, 4, 3, Strategy::Mis)
        },
    );
    assert_eq!(direct.image.pixels, full.image.pixels);
    assert!(direct.image.pixels.iter().any(|p| p.x > 0.0));
}

#[test]
fn direct_mode_sees_emitters_and_sky_but_they_light_nothing() {
    // Camera rays return the sky or an emitter's front exactly; neither lights the floor, and
    // an emitter's back face is black.
    let sky = Vec3::new(0.2, 0.3, 0.4);
    let mut builder = SceneBuilder::new(Sky::Constant { radiance: sky });
    builder
        .add(floor(Vec3::ZERO, 1.0), diffuse(0.8))
        .add(
            quad(Vec3::new(-0.5, 0.5, -0.5), Vec3::X * 0.3, Vec3::Y * 0.3),
            crate::common::emitter(Vec3::splat(5.0), false),
        )
        .add(
            quad(Vec3::new(0.5, 0.5, -0.5), Vec3::Y * 0.3, Vec3::X * 0.3),
            crate::common::emitter(Vec3::splat(5.0), false),
        );
    let reference = builder.reference(CameraView::look_at(
        Vec3::new(0.0, 1.5, 2.5),
        Vec3::new(0.0, 0.3, 0.0),
        1.2,
    ));
    let r = render(&reference, &direct(4));
    let count = |value: Vec3| r.image.pixels.iter().filter(|p| **p == value).count();
    let (sky_pixels, emitter_pixels, black_pixels) =
        (count(sky), count(Vec3::splat(5.0)), count(Vec3::ZERO));
    assert!(
        sky_pixels > 100 && emitter_pixels > 10 && black_pixels > 100,
        "{sky_pixels} {emitter_pixels} {black_pixels}"
    );
    // Edge pixels mix those three values: p = a * sky + b * 5 with a, b >= 0 and a + b <= 1
    // (the rest black). Solve for a and b from two channels and check the third.
    for p in &r.image.pixels {
        let a = f64::from(p.z - p.x) / f64::from(sky.z - sky.x);
        let b = (f64::from(p.x) - a * f64::from(sky.x)) / 5.0;
        let y = a * f64::from(sky.y) + b * 5.0;
        let slack = 1e-5;
        assert!(
            a >= -slack && b >= -slack && a + b <= 1.0 + slack,
            "{p} is not a mix"
        );
        assert!(
            (y - f64::from(p.y)).abs() < slack,
            "{p} is not a mix of sky, emitter and black"
        );
    }
}

//! Camera conventions: image orientation, aspect ratio, and the box filter over each pixel.

use gi_reference::{Mode, RenderSettings, Strategy};
use gi_scene::{CameraView, Sky};
use glam::Vec3;

use crate::common::{SceneBuilder, emitter, quad, region_mean, render};

const WIDTH: u32 = 32;
const HEIGHT: u32 = 16;
const YFOV: f32 = 0.6;
const RADIANCE: f32 = 2.0;

/// An emitter facing a camera 5 away, filling the half-plane beyond a straight edge that
/// crosses column (or row) `line` of the film at fraction `fraction` of the pixel. Returns
/// the render.
fn half_plane(vertical_edge: bool, line: u32, fraction: f32) -> crate::common::Rendered {
    let tan_half = (YFOV * 0.5).tan();
    let aspect = WIDTH as f32 / HEIGHT as f32;
    // Film coordinates map linearly onto the plane z = 0: x = (2u - 1) tan_half aspect d and
    // y = (1 - 2v) tan_half d.
    let (center, u, v) = if vertical_edge {
        let x = (2.0 * (line as f32 + fraction) / WIDTH as f32 - 1.0) * tan_half * aspect * 5.0;
        (
            Vec3::new(x + 50.0, 0.0, 0.0),
            Vec3::X * 50.0,
            Vec3::Y * 50.0,
        )
    } else {
        let y = (1.0 - 2.0 * (line as f32 + fraction) / HEIGHT as f32) * tan_half * 5.0;
        (
            Vec3::new(0.0, y + 50.0, 0.0),
            Vec3::X * 50.0,
            Vec3::Y * 50.0,
        )
    };
    let mut builder = SceneBuilder::new(Sky::default());
    builder.add(quad(center, u, v), emitter(Vec3::splat(RADIANCE), false));
    let camera = CameraView::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, YFOV);
    let settings = RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        spp: 128,
        seed: 1,
        mode: Mode::Direct,
        strategy: Strategy::Mis,
        max_depth: 0,
    };
    render(&builder.reference(camera), &settings)
}

#[test]
fn pixels_average_their_whole_area() {
    // Right of a vertical edge 30% into column 20: columns left of it are black, right of it
    // fully lit, and column 20 is 70% covered on average (a box filter over the pixel).
    let r = half_plane(true, 20, 0.3);
    for c in 0..3 {
        let column = |x0: u32, x1: u32| region_mean(&r, c, move |x, _| (x0..x1).contains(&x));
        assert_eq!(column(0, 20).mean, 0.0);
        assert_eq!(column(21, WIDTH).mean, f64::from(RADIANCE));
        column(20, 21).assert_near(0.7 * f64::from(RADIANCE), 0.0, "edge column");
    }
    // Above a horizontal edge 60% into row 5 (v grows downwards, +Y is up): rows 0..5 lit,
    // row 5 is 60% covered.
    let r = half_plane(false, 5, 0.6);
    for c in 0..3 {
        let rows = |y0: u32, y1: u32| region_mean(&r, c, move |_, y| (y0..y1).contains(&y));
        assert_eq!(rows(0, 5).mean, f64::from(RADIANCE));
        assert_eq!(rows(6, HEIGHT).mean, 0.0);
        rows(5, 6).assert_near(0.6 * f64::from(RADIANCE), 0.0, "edge row");
    }
}

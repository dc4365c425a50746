//! What the GPU GI tiers' tests share.

use gi_scene::{Scene, Sky};
use gi_tiers::TierSettings;
use glam::Vec3;

/// `width` x `height` with the direct light's 16 samples per pixel and a fixed seed.
pub fn settings(width: u32, height: u32) -> TierSettings {
    TierSettings {
        width,
        height,
        spp: 16,
        seed: 7,
        textures: gi_tiers::TextureOptions::DEFAULT,
    }
}

/// A grey ground square of half-side `half_m` and `albedo` at y = 0 under a constant sky of
/// radiance 1: with nothing above it, every point's irradiance from the sky is pi.
pub fn open_ground(name: &str, half_m: f32, albedo: f32) -> Scene {
    let mut scene = Scene {
        name: name.into(),
        sky: Sky::Constant {
            radiance: Vec3::ONE,
        },
        exposure: 1.0,
        ..Default::default()
    };
    scene.add_diffuse_quad(Vec3::ZERO, Vec3::Z * half_m, Vec3::X * half_m, albedo);
    scene
}

/// `scene` with every material's `occlusionTexture` a one-texel map of `red` at `strength`: an
/// occlusion factor of `1 + strength * (red - 1)` everywhere (`red` is stored in 8 bits: a
/// multiple of 1/255 gives the factor exactly).
pub fn with_occlusion(mut scene: Scene, red: f32, strength: f32) -> Scene {
    scene.textures.push(gi_scene::Texture::from_linear(
        "occlusion",
        1,
        1,
        gi_scene::TextureEncoding::Linear,
        &[glam::Vec4::new(red, red, red, 1.0)],
    ));
    let texture = Some(gi_scene::TextureRef::new(scene.textures.len() - 1));
    for material in &mut scene.materials {
        material.occlusion_texture = texture;
        material.occlusion_strength = strength;
    }
    scene
}

/// Checks that `occluded` (GI terms with the occlusion factors given, in order) are the GI term
/// `plain` (no occlusion map) with its diffuse part scaled by each factor: every lit pixel is
/// darker, and the summed darkenings are in the ratio of `1 - factor`. `plain_again` is a second
/// render of `plain`: how far two renders of one scene differ (a GPU tier's atomics may order
/// floating-point sums differently) sets the tolerance, 8 times the relative difference (the
/// darkening is about a third of the GI term, so its relative noise is about 3 times the
/// term's) plus rounding. Returns the lit pixels checked.
pub fn check_occlusion_scaling(
    plain: &gi_image::Image,
    plain_again: &gi_image::Image,
    occluded: [(&gi_image::Image, f32); 2],
) -> usize {
    let sum = |image: &gi_image::Image| {
        image
            .pixels
            .iter()
            .map(|p| f64::from(p.element_sum()))
            .sum::<f64>()
    };
    let repeat_difference: f64 = plain
        .pixels
        .iter()
        .zip(&plain_again.pixels)
        .map(|(a, b)| f64::from((*a - *b).abs().element_sum()))
        .sum();
    let noise = repeat_difference / sum(plain);
    let [(a, fa), (b, fb)] = occluded;
    let mut lit = 0;
    let (mut dark_a, mut dark_b) = (0.0, 0.0);
    for ((p, x), y) in plain.pixels.iter().zip(&a.pixels).zip(&b.pixels) {
        if p.max_element() <= 1e-3 {
            continue;
        }
        lit += 1;
        assert!((*p - *x).min_element() > 0.0, "GI {p} not darkened: {x}");
        assert!((*p - *y).min_element() > 0.0, "GI {p} not darkened: {y}");
        dark_a += f64::from((*p - *x).element_sum());
        dark_b += f64::from((*p - *y).element_sum());
    }
    let ratio = dark_a / dark_b;
    let expected = f64::from((1.0 - fa) / (1.0 - fb));
    let bound = 8.0 * noise + 1e-5;
    println!("darkening ratio {ratio:.6} (expected {expected:.6}), bound {bound:.2e} relative");
    assert!(
        (ratio / expected - 1.0).abs() <= bound,
        "darkening ratio {ratio} instead of {expected} (bound {bound})"
    );
    lit
}

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

/// The open ground of [`open_ground`] under a sun, seen from `camera`, with a black, double-sided
/// alpha-`BLEND` square of `alpha` floating half a meter in front of the camera across its
/// view's center. Returns the scene and the frame index of the square's first triangle.
pub fn ground_behind_glass(camera: &gi_scene::CameraView, alpha: f32) -> (Scene, usize) {
    let mut scene = open_ground("glass-over-ground", 20.0, 0.5);
    add_sun(&mut scene, glam::Quat::from_rotation_x(-1.1));
    let first = scene.evaluate(0.0, Some(*camera)).triangles.len();
    scene.add_diffuse_quad(
        camera.position + camera.forward * 0.5,
        camera.right * 0.1,
        camera.up * 0.1,
        0.0,
    );
    let glass = scene.materials.last_mut().expect("the square's material");
    glass.alpha_mode = gi_scene::AlphaMode::Blend;
    glass.base_color.w = alpha;
    glass.double_sided = true;
    (scene, first)
}

/// Checks an image of [`ground_behind_glass`] at alpha one half (`what`: the GI term or the
/// direct light) against `clear`, the same view with alpha 0 (the glass passes every ray):
/// behind the black glass it is half the ground's, give or take the light the glass takes from
/// the ground, and as smooth as without the glass: from one pixel to the next it changes
/// relatively little more than `clear` does there (its noise), where a hashed dither of black
/// glass and ground would change by about its own size. Returns the covered pixels.
pub fn check_glass_blends(
    scene: &Scene,
    first_glass_triangle: usize,
    camera: &gi_scene::CameraView,
    (what, image, clear): (&str, &gi_image::Image, &gi_image::Image),
) -> usize {
    let frame = scene.evaluate(0.0, Some(*camera));
    let bvh = gi_scene::SceneBvh::build(&frame.triangles);
    let (width, height) = (image.width, image.height);
    // Pixels the glass covers whole (all four corners): at its edges the direct light's
    // jittered rays see both glass and ground, which is anti-aliasing, not dither.
    let covered = |x: u32, y: u32| {
        [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|&(dx, dy)| {
            let u = (x + dx) as f32 / width as f32;
            let v = (y + dy) as f32 / height as f32;
            let dir = camera.ray_direction(u, v, width as f32 / height as f32);
            bvh.closest_hit(&frame.triangles, camera.position, dir, 0.0, f32::INFINITY)
                .is_some_and(|hit| hit.triangle as usize >= first_glass_triangle)
        })
    };
    let luminance = |image: &gi_image::Image, x: u32, y: u32| {
        f64::from(image.pixels[(y * width + x) as usize].element_sum()) / 3.0
    };
    let (mut count, mut blended, mut behind) = (0, 0.0, 0.0);
    let (mut steps, mut step_sum, mut clear_step_sum) = (0, 0.0, 0.0);
    for y in 0..height {
        for x in 0..width {
            if !covered(x, y) {
                continue;
            }
            count += 1;
            blended += luminance(image, x, y);
            behind += luminance(clear, x, y);
            if x + 1 < width && covered(x + 1, y) {
                steps += 1;
                step_sum += (luminance(image, x + 1, y) - luminance(image, x, y)).abs();
                clear_step_sum += (luminance(clear, x + 1, y) - luminance(clear, x, y)).abs();
            }
        }
    }
    assert!(
        count > 20 && steps > 10,
        "the glass covers only {count} pixels"
    );
    let (blended, behind) = (blended / count as f64, behind / count as f64);
    let ratio = blended / behind;
    let step = step_sum / steps as f64 / blended;
    let clear_step = clear_step_sum / steps as f64 / behind;
    println!(
        "glass, {what}: {blended:.4} behind it {behind:.4} (ratio {ratio:.3}), mean step \
         {step:.4} of it, {clear_step:.4} without the glass"
    );
    assert!(
        (0.42..=0.52).contains(&ratio),
        "{what} behind the glass {blended} against {behind}"
    );
    assert!(
        step <= 1.5 * clear_step + 0.01,
        "the {what} behind the glass varies by {step} of itself between neighbours, \
         {clear_step} without the glass"
    );
    count
}

/// A black ground of half-size `half_m` under a black sky: what lights it, the test adds.
pub fn unlit_ground(name: &str, half_m: f32) -> Scene {
    let mut scene = open_ground(name, half_m, 0.0);
    scene.sky = Sky::Constant {
        radiance: Vec3::ZERO,
    };
    scene
}

/// A white wall at x = 1 facing -x on an [`unlit_ground`], lit by a sun: -z turned to +x, the
/// light travels along +x, level with the ground, so that it lights the wall square on and not
/// the ground, whose irradiance is then the wall's bounce alone.
pub fn sunlit_wall(name: &str) -> Scene {
    let mut scene = unlit_ground(name, 4.0);
    scene.add_diffuse_quad(Vec3::new(1.0, 1.0, 0.0), Vec3::Z * 1.5, Vec3::Y, 0.8);
    add_sun(
        &mut scene,
        glam::Quat::from_rotation_y(-std::f32::consts::FRAC_PI_2),
    );
    scene
}

/// Adds a sun of intensity 3 to `scene`, shining along `rotation` applied to -z.
pub fn add_sun(scene: &mut Scene, rotation: glam::Quat) {
    scene.lights.push(gi_scene::Light {
        name: "sun".into(),
        kind: gi_scene::LightKind::Directional,
        color: Vec3::ONE,
        intensity: 3.0,
        range: None,
    });
    scene.nodes.push(gi_scene::Node {
        light: Some(scene.lights.len() - 1),
        rotation,
        ..gi_scene::Node::default()
    });
}

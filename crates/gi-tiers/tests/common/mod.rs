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

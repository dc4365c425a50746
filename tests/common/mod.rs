//! What the end-to-end flows share: a small scene built in code as a user would build one, and
//! the per-pixel statistics that compare two renders of it.

#![allow(dead_code)] // each test binary uses its own part

use gi_image::Image;
use gi_scene::{
    Camera, CameraView, Light, LightKind, Node, Scene, Sky, Texture, TextureEncoding, TextureRef,
};
use glam::{Mat3, Quat, Vec2, Vec3, Vec4};

/// Names of the yard's nodes and light, as they travel through the glTF file.
pub const PANEL: &str = "panel";
pub const SUN: &str = "sun";
/// The yard's exposure, kept by its glTF file (`extras.gi`).
pub const EXPOSURE: f32 = 1.0;
/// Triangles of the yard: the ground and the panel, two each.
pub const TRIANGLES: usize = 4;

/// The camera the yard's file names as its default: up and in front, looking at the panel.
pub fn yard_camera() -> CameraView {
    CameraView::look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::new(0.0, 0.5, 0.0), 0.9)
}

/// The yard: an 8 m textured ground (a 4 x 4 sRGB checker of orange and grey, repeated
/// twice), a grey panel standing on it, a sun low enough for the panel to cast a long shadow
/// and catch the ground's orange light, a constant sky, and a camera node. Every surface is
/// Lambertian, so nothing in it makes fireflies that a few samples per pixel cannot average.
pub fn yard() -> Scene {
    let mut scene = Scene {
        name: "yard".into(),
        sky: Sky::Constant {
            radiance: Vec3::splat(0.3),
        },
        exposure: EXPOSURE,
        frame_time_s: 1.0 / 60.0,
        ..Default::default()
    };

    let ground = scene.add_diffuse_quad(Vec3::ZERO, Vec3::Z * 4.0, Vec3::X * 4.0, 1.0);
    scene.nodes[ground].name = "ground".into();
    let orange = Vec4::new(0.8, 0.35, 0.1, 1.0);
    let grey = Vec4::new(0.35, 0.35, 0.35, 1.0);
    let checker: Vec<Vec4> = (0..16)
        .map(|i| {
            if (i % 4 + i / 4) % 2 == 0 {
                orange
            } else {
                grey
            }
        })
        .collect();
    scene.textures.push(Texture::from_linear(
        "checker",
        4,
        4,
        TextureEncoding::Srgb,
        &checker,
    ));
    let mesh = scene.nodes[ground].mesh.expect("a quad has a mesh");
    let primitive = &mut scene.meshes[mesh].primitives[0];
    primitive.uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(2.0, 0.0),
        Vec2::new(2.0, 2.0),
        Vec2::new(0.0, 2.0),
    ];
    let material = primitive.material;
    scene.materials[material].base_color_texture = Some(TextureRef::new(0));

    // 2 m wide, 1.6 m tall, facing +Z (the camera), its bottom edge on the ground.
    let panel = scene.add_diffuse_quad(Vec3::new(0.0, 0.8, 0.0), Vec3::X, Vec3::Y * 0.8, 0.7);
    scene.nodes[panel].name = PANEL.into();

    scene.lights.push(Light {
        name: SUN.into(),
        kind: LightKind::Directional,
        color: Vec3::ONE,
        intensity: 2.0,
        range: None,
    });
    // The light shines down its node's -Z: tilted 0.7 rad below the horizon, from the camera's
    // side and the right.
    scene.nodes.push(Node {
        name: SUN.into(),
        light: Some(0),
        rotation: Quat::from_rotation_y(0.5) * Quat::from_rotation_x(-0.7),
        ..Node::default()
    });

    let view = yard_camera();
    scene.cameras.push(Camera {
        name: "overview".into(),
        yfov: view.yfov,
        aspect_ratio: None,
        znear: 0.05,
    });
    scene.nodes.push(Node {
        name: "overview".into(),
        camera: Some(0),
        translation: view.position,
        rotation: Quat::from_mat3(&Mat3::from_cols(view.right, view.up, -view.forward)),
        ..Node::default()
    });
    scene.default_camera_node = Some(scene.nodes.len() - 1);
    scene
}

/// The index of the node named `name`.
pub fn node(scene: &Scene, name: &str) -> usize {
    (scene.nodes.iter())
        .position(|n| n.name == name)
        .unwrap_or_else(|| panic!("no node '{name}' in {}", scene.name))
}

/// The mean of `terms` and its standard error (sample standard deviation over sqrt(n)).
pub fn mean_and_se(terms: &[f64]) -> (f64, f64) {
    let n = terms.len() as f64;
    let mean = terms.iter().sum::<f64>() / n;
    let var = terms.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Every channel of every pixel of `image`, in linear radiance times `exposure`.
pub fn channels(image: &Image, exposure: f32) -> Vec<f64> {
    (image.pixels.iter())
        .flat_map(|p| (*p * exposure).to_array())
        .map(f64::from)
        .collect()
}

//! A small scene builder and material presets shared by the generators.

use glam::{Mat3, Quat, Vec3};

use super::shapes::MeshData;
use crate::frame::CameraView;
use crate::model::{
    Animation, Camera, CameraKey, CameraPath, Light, LightKind, Material, Mesh, Node, Scene, Sky,
};

/// Seconds between frames of every bundled scene (30 frames per second).
const FRAME_TIME_S: f32 = 1.0 / 30.0;

/// Geometry grouped by material: each group becomes one primitive, in order of first use.
#[derive(Default)]
pub struct Parts(Vec<(usize, MeshData)>);

impl Parts {
    /// The geometry drawn with `material`, created empty on first use.
    pub fn of(&mut self, material: usize) -> &mut MeshData {
        let index = match self.0.iter().position(|(m, _)| *m == material) {
            Some(index) => index,
            None => {
                self.0.push((material, MeshData::default()));
                self.0.len() - 1
            }
        };
        &mut self.0[index].1
    }
}

/// Accumulates a [`Scene`]: materials, mesh, light and camera nodes, animation and settings.
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty scene with its sky and display exposure.
    pub fn new(name: &str, sky: Sky, exposure: f32) -> Self {
        Self {
            scene: Scene {
                name: name.to_string(),
                sky,
                exposure,
                frame_time_s: FRAME_TIME_S,
                ..Scene::default()
            },
        }
    }

    /// Adds a material and returns its index.
    pub fn material(&mut self, material: Material) -> usize {
        self.scene.materials.push(material);
        self.scene.materials.len() - 1
    }

    /// Adds a root node at `translation` holding one mesh made of `parts`; returns the node.
    pub fn mesh_node(&mut self, name: &str, parts: Parts, translation: Vec3) -> usize {
        let primitives = parts
            .0
            .into_iter()
            .filter(|(_, mesh)| !mesh.indices.is_empty())
            .map(|(material, mesh)| mesh.into_primitive(material))
            .collect();
        self.scene.meshes.push(Mesh {
            name: name.to_string(),
            weights: Vec::new(),
            primitives,
        });
        self.node(Node {
            name: name.to_string(),
            translation,
            mesh: Some(self.scene.meshes.len() - 1),
            ..Node::default()
        })
    }

    /// Adds a root node holding one single-material mesh given in world coordinates.
    pub fn single_mesh_node(&mut self, name: &str, mesh: MeshData, material: usize) -> usize {
        let mut parts = Parts::default();
        *parts.of(material) = mesh;
        self.mesh_node(name, parts, Vec3::ZERO)
    }

    /// Adds a punctual light at `position` shining along `direction`; returns its node.
    pub fn light(
        &mut self,
        name: &str,
        kind: LightKind,
        color: Vec3,
        intensity: f32,
        position: Vec3,
        direction: Vec3,
    ) -> usize {
        self.scene.lights.push(Light {
            name: name.to_string(),
            kind,
            color,
            intensity,
            range: None,
        });
        self.node(Node {
            name: name.to_string(),
            translation: position,
            rotation: facing(direction),
            light: Some(self.scene.lights.len() - 1),
            ..Node::default()
        })
    }

    /// Adds the default camera, named "Camera", at `position` looking at `target`.
    pub fn camera(&mut self, position: Vec3, target: Vec3, yfov: f32) -> usize {
        self.scene.cameras.push(Camera {
            name: "Camera".into(),
            yfov,
            aspect_ratio: None,
            znear: 0.05,
        });
        let node = self.node(Node {
            name: "Camera".into(),
            translation: position,
            rotation: facing(target - position),
            camera: Some(self.scene.cameras.len() - 1),
            ..Node::default()
        });
        self.scene.default_camera_node = Some(node);
        node
    }

    /// Sets the camera path from `(time_s, position, target)` keys.
    pub fn camera_path(&mut self, yfov: f32, keys: &[(f32, Vec3, Vec3)]) {
        let keys = keys
            .iter()
            .map(|&(time_s, position, target)| CameraKey {
                time_s,
                position,
                target,
            })
            .collect();
        self.scene.camera_path = Some(CameraPath { keys, yfov });
    }

    /// Adds an animation (the model loops it over its duration).
    pub fn animation(&mut self, animation: Animation) {
        self.scene.animations.push(animation);
    }

    fn node(&mut self, node: Node) -> usize {
        self.scene.nodes.push(node);
        self.scene.nodes.len() - 1
    }

    /// The finished scene.
    pub fn finish(self) -> Scene {
        self.scene
    }
}

/// Rotation that points a node's -Z axis along `forward`, +Y up (as [`CameraView::look_at`]).
fn facing(forward: Vec3) -> Quat {
    let view = CameraView::look_at(Vec3::ZERO, forward, 1.0);
    Quat::from_mat3(&Mat3::from_cols(view.right, view.up, -view.forward)).normalize()
}

/// A dielectric material.
pub fn dielectric(name: &str, color: Vec3, roughness: f32) -> Material {
    Material {
        name: name.to_string(),
        base_color: color.extend(1.0),
        metallic: 0.0,
        roughness,
        ..Material::default()
    }
}

/// A metal; `color` is its specular reflectance at normal incidence.
pub fn metal(name: &str, color: Vec3, roughness: f32) -> Material {
    Material {
        metallic: 1.0,
        ..dielectric(name, color, roughness)
    }
}

/// A single-sided emitter of `radiance` (W/(sr m^2)) on a surface of albedo `color`.
pub fn emitter(name: &str, color: Vec3, radiance: Vec3) -> Material {
    Material {
        emissive: radiance,
        ..dielectric(name, color, 1.0)
    }
}

/// Unit direction towards the sun: `azimuth` in degrees from +X towards +Z, `elevation` in
/// degrees above the horizon.
pub fn sun_direction(azimuth: f32, elevation: f32) -> Vec3 {
    let (azimuth, elevation) = (azimuth.to_radians(), elevation.to_radians());
    Vec3::new(
        elevation.cos() * azimuth.cos(),
        elevation.sin(),
        elevation.cos() * azimuth.sin(),
    )
}

/// Sunlight color and irradiance (W/m^2 on a surface facing the sun) shared by the outdoor
/// scenes, balanced against [`daylight_sky`] so the sun carries about four fifths of the light
/// on open ground, as on a clear day.
pub const SUN_COLOR: Vec3 = Vec3::new(1.0, 0.95, 0.87);
pub const SUN_IRRADIANCE: f32 = 8.0;

/// The clear-day sky of the outdoor scenes (radiance in W/(sr m^2)).
pub fn daylight_sky() -> Sky {
    Sky::Gradient {
        zenith: Vec3::new(0.22, 0.38, 0.80),
        horizon: Vec3::new(0.62, 0.70, 0.82),
        ground: Vec3::new(0.18, 0.16, 0.14),
    }
}

//! The scene model every tier and the reference render from.
//!
//! A [`Scene`] keeps the glTF structure that matters for lighting: a node hierarchy with local
//! transforms, meshes in local space, metallic-roughness materials, punctual lights and cameras
//! attached to nodes, animations of node transforms, and the product's own settings read from the
//! scene `extras` (sky, exposure, camera path; see `scenes/README.md`). [`Scene::evaluate`] turns
//! it into a [`crate::SceneFrame`]: world-space triangles, lights and camera at one time.

use glam::{Quat, Vec2, Vec3, Vec4};

/// A scene: geometry, materials, lights, cameras, animation and render settings.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Human-readable name (the bundled name or the file stem).
    pub name: String,
    pub nodes: Vec<Node>,
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub cameras: Vec<Camera>,
    pub animations: Vec<Animation>,
    /// Radiance arriving from directions where rays escape the scene.
    pub sky: Sky,
    /// Scalar applied to linear radiance before tonemapping (`png = oetf(clamp(exposure * L))`).
    pub exposure: f32,
    /// Node whose camera is the default view; `None` uses [`Scene::fallback_view`].
    pub default_camera_node: Option<usize>,
    /// Optional scripted camera motion for animated renders and benchmarks.
    pub camera_path: Option<CameraPath>,
    /// Seconds between two frames when a render advances time (`time = frame * frame_time_s`).
    pub frame_time_s: f32,
}

impl Scene {
    /// Adds a grey Lambert parallelogram `center +- u +- v` (front face `u x v`) of albedo
    /// `albedo` (a dielectric without specular layer, so its BRDF is exactly `albedo / pi`),
    /// with a material, a mesh and a root node of its own, and returns the node. For scenes
    /// assembled in code (tests, tools).
    pub fn add_diffuse_quad(&mut self, center: Vec3, u: Vec3, v: Vec3, albedo: f32) -> usize {
        let n = u.cross(v).normalize();
        self.materials.push(Material {
            base_color: Vec3::splat(albedo).extend(1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            ..Default::default()
        });
        self.meshes.push(Mesh {
            name: String::new(),
            primitives: vec![Primitive {
                positions: vec![
                    center - u - v,
                    center + u - v,
                    center + u + v,
                    center - u + v,
                ],
                normals: vec![n; 4],
                uvs: vec![Vec2::ZERO; 4],
                indices: vec![0, 1, 2, 0, 2, 3],
                material: self.materials.len() - 1,
            }],
        });
        self.nodes.push(Node {
            mesh: Some(self.meshes.len() - 1),
            ..Default::default()
        });
        self.nodes.len() - 1
    }
}

/// A node of the hierarchy. Its transform is `translation * rotation * scale` relative to its
/// parent, as in glTF.
#[derive(Clone, Debug)]
pub struct Node {
    pub name: String,
    pub parent: Option<usize>,
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
    pub mesh: Option<usize>,
    pub light: Option<usize>,
    pub camera: Option<usize>,
}

impl Default for Node {
    fn default() -> Self {
        Self {
            name: String::new(),
            parent: None,
            translation: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
            mesh: None,
            light: None,
            camera: None,
        }
    }
}

/// A mesh: a list of triangle primitives in the local space of the nodes that use it.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub primitives: Vec<Primitive>,
}

/// Indexed triangles with one material. `normals` always has one entry per position (the importer
/// computes them when the file has none); `uvs` is either empty or one entry per position.
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// glTF metallic-roughness material. All colors are linear RGB.
///
/// BRDF (ARCHITECTURE.md): Lambert `base * (1 - metallic) / pi` plus GGX specular with
/// height-correlated Smith masking and Schlick Fresnel, `F0 = mix(0.04, base, metallic)`.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Linear RGBA factor; multiplied by the base color texture when present.
    pub base_color: Vec4,
    pub base_color_texture: Option<usize>,
    pub metallic: f32,
    /// Perceptual roughness; GGX alpha is `roughness^2`.
    pub roughness: f32,
    /// glTF convention: green channel scales roughness, blue scales metallic.
    pub metallic_roughness_texture: Option<usize>,
    /// Linear emissive factor (already multiplied by KHR_materials_emissive_strength).
    pub emissive: Vec3,
    pub emissive_texture: Option<usize>,
    /// Single-sided surfaces still reflect on both sides (we never cull), but they only emit
    /// on their front side; double-sided emitters emit on both sides.
    pub double_sided: bool,
    /// `KHR_materials_specular`'s `specularFactor`: the weight of the dielectric's specular
    /// layer, in `[0, 1]` (0 makes a dielectric pure Lambert). 1 without the extension.
    pub specular: f32,
    /// Its texture; the alpha channel scales [`Material::specular`].
    pub specular_texture: Option<usize>,
    /// `KHR_materials_specular`'s `specularColorFactor`, linear; scales the dielectric's
    /// Fresnel reflectance at normal incidence. White without the extension.
    pub specular_color: Vec3,
    /// Its texture (sRGB-encoded in the file, linear here); the rgb channels scale
    /// [`Material::specular_color`].
    pub specular_color_texture: Option<usize>,
    /// `KHR_materials_ior`'s index of refraction (1.5 without the extension): the
    /// dielectric's Fresnel reflectance at normal incidence is `((ior - 1) / (ior + 1))^2`.
    pub ior: f32,
}

impl Default for Material {
    fn default() -> Self {
        // The glTF default material.
        Self {
            name: "default".into(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            double_sided: false,
            specular: 1.0,
            specular_texture: None,
            specular_color: Vec3::ONE,
            specular_color_texture: None,
            ior: 1.5,
        }
    }
}

/// A texture decoded to linear RGBA f32 (sRGB-encoded images are decoded on import).
#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Row-major, `width * height` texels, top row first (glTF UV (0,0) is the top-left).
    pub texels: Vec<Vec4>,
}

impl Texture {
    /// Bilinear sample with repeat wrapping; texel centers sit at half-integer coordinates.
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec4 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |ix: i64, iy: i64| {
            let ix = ix.rem_euclid(w) as usize;
            let iy = iy.rem_euclid(h) as usize;
            self.texels[iy * self.width as usize + ix]
        };
        let (ix, iy) = (x0 as i64, y0 as i64);
        let top = texel(ix, iy).lerp(texel(ix + 1, iy), fx);
        let bottom = texel(ix, iy + 1).lerp(texel(ix + 1, iy + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Mean of all texels (used to estimate an emitter's power).
    pub fn average(&self) -> Vec4 {
        let sum: Vec4 = self.texels.iter().copied().sum();
        sum / self.texels.len().max(1) as f32
    }
}

/// KHR_lights_punctual light in the local space of its node, which points it down -Z.
/// Units as glTF: point and spot `intensity` in candela (W/sr here), directional in lux
/// (W/m^2 here); `color` is linear RGB.
#[derive(Clone, Debug)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    pub color: Vec3,
    pub intensity: f32,
    /// Distance where the glTF-recommended smooth window reaches zero; `None` is infinite.
    pub range: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    Directional,
    Point,
    /// Cone angles in radians from the light's axis, `0 <= inner < outer <= pi/2`.
    Spot {
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
}

/// Perspective camera (glTF), looking down -Z of its node with +Y up.
#[derive(Clone, Debug)]
pub struct Camera {
    pub name: String,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Aspect ratio from the file; renders use the output image's aspect instead.
    pub aspect_ratio: Option<f32>,
    pub znear: f32,
}

/// A keyframed camera path from the scene extras: position and look-at target, linearly
/// interpolated, held at the ends.
#[derive(Clone, Debug)]
pub struct CameraPath {
    pub keys: Vec<CameraKey>,
    /// Vertical field of view in radians for the whole path.
    pub yfov: f32,
}

#[derive(Clone, Copy, Debug)]
pub struct CameraKey {
    pub time_s: f32,
    pub position: Vec3,
    pub target: Vec3,
}

/// A keyframed animation of node transforms.
#[derive(Clone, Debug, Default)]
pub struct Animation {
    pub name: String,
    pub channels: Vec<Channel>,
}

/// One animated property of one node.
#[derive(Clone, Debug)]
pub struct Channel {
    pub node: usize,
    /// Non-decreasing key times in seconds (a repeated time makes a jump).
    pub times: Vec<f32>,
    pub values: ChannelValues,
    pub interpolation: Interpolation,
}

#[derive(Clone, Debug)]
pub enum ChannelValues {
    Translation(Vec<Vec3>),
    Rotation(Vec<Quat>),
    Scale(Vec<Vec3>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    Linear,
}

/// Radiance from directions that escape the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sky {
    /// The same radiance from every direction (also the white-furnace test's environment).
    Constant { radiance: Vec3 },
    /// A smooth analytic sky: `horizon` at y = 0 blending linearly in `dir.y` to `zenith` at
    /// y = 1; below the horizon it blends to `ground` at y = -1.
    Gradient {
        zenith: Vec3,
        horizon: Vec3,
        ground: Vec3,
    },
}

impl Default for Sky {
    fn default() -> Self {
        Sky::Constant {
            radiance: Vec3::ZERO,
        }
    }
}

impl Sky {
    /// Radiance arriving from world direction `dir` (unit length).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        match *self {
            Sky::Constant { radiance } => radiance,
            Sky::Gradient {
                zenith,
                horizon,
                ground,
            } => {
                let y = dir.y.clamp(-1.0, 1.0);
                if y >= 0.0 {
                    horizon.lerp(zenith, y)
                } else {
                    horizon.lerp(ground, -y)
                }
            }
        }
    }

    /// True when the sky emits nothing (lets integrators skip sky sampling).
    pub fn is_black(&self) -> bool {
        match *self {
            Sky::Constant { radiance } => radiance == Vec3::ZERO,
            Sky::Gradient {
                zenith,
                horizon,
                ground,
            } => zenith == Vec3::ZERO && horizon == Vec3::ZERO && ground == Vec3::ZERO,
        }
    }
}

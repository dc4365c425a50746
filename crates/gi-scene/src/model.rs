//! The scene model every tier and the reference render from.
//!
//! A [`Scene`] keeps the glTF structure that matters for lighting: a node hierarchy with local
//! transforms, meshes in local space, metallic-roughness materials, punctual lights and cameras
//! attached to nodes, animations of node transforms, and the product's own settings read from the
//! scene `extras` (sky, exposure, camera path; see `scenes/README.md`). [`Scene::evaluate`] turns
//! it into a [`crate::SceneFrame`]: world-space triangles, lights and camera at one time.

use std::sync::LazyLock;

use glam::{Affine2, Mat4, Quat, Vec2, Vec3, Vec4};

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
    /// Skeletons that deform skinned meshes (glTF `skins`), referenced by [`Node::skin`].
    pub skins: Vec<Skin>,
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
            weights: Vec::new(),
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
                ..Default::default()
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
    /// Index into [`Scene::skins`]: the node's mesh is skinned by that skin's joints, and the
    /// node's own transform does not place it (glTF 2.0; see [`Skin`]).
    pub skin: Option<usize>,
    /// glTF node `weights`: the morph target weights of the node's mesh, overriding
    /// [`Mesh::weights`] for this instance (`None`: the mesh's). An animation channel with
    /// [`ChannelValues::Weights`] overrides both.
    pub weights: Option<Vec<f32>>,
    /// The caller moves this node between frames (an engine's dynamic object, moved through
    /// `gi_tiers::Renderer::set_node_transform`): every level treats it and its descendants as
    /// moving, as it treats an animated node ([`Scene::moving_nodes`]). Not part of glTF: set
    /// it before the scene is rendered. A node that is not movable is static geometry, which
    /// the renderers build into their BVH and caches once.
    pub movable: bool,
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
            skin: None,
            weights: None,
            movable: false,
        }
    }
}

/// A mesh: a list of triangle primitives in the local space of the nodes that use it.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub name: String,
    pub primitives: Vec<Primitive>,
    /// Default weight of each morph target (glTF mesh `weights`; every primitive has the same
    /// number of targets). Empty means all zero. See [`MorphTarget`].
    pub weights: Vec<f32>,
}

impl Mesh {
    /// Most morph targets a mesh may have. glTF sets no limit, but every target costs a pass
    /// over the vertices in each evaluation and 36 bytes per vertex; rigs with many shapes
    /// (ARKit faces have 52, film faces a few hundred) fit, while a hostile file cannot ask
    /// for thousands of full-size copies of a mesh.
    pub const MAX_MORPH_TARGETS: usize = 256;

    /// Number of morph targets (the most any primitive has).
    pub fn morph_target_count(&self) -> usize {
        (self.primitives.iter())
            .map(|p| p.targets.len())
            .max()
            .unwrap_or(0)
    }
}

/// Indexed triangles with one material. `normals` always has one entry per position (the importer
/// computes them when the file has none); `uvs`, `uvs1` and `tangents` are each either empty or
/// one entry per position.
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// `TEXCOORD_0`.
    pub uvs: Vec<Vec2>,
    /// `TEXCOORD_1`.
    pub uvs1: Vec<Vec2>,
    /// Unit tangents (xyz) with the bitangent's sign in w (`bitangent = w * normal x tangent`),
    /// as glTF's `TANGENT`. The importer fills them (from the file, else MikkTSpace) for
    /// primitives whose material has a normal texture.
    pub tangents: Vec<Vec4>,
    /// `JOINTS_0`: per vertex, four indices into the joint list of the skin of the node that
    /// draws the primitive. Empty, or one entry per position together with
    /// [`Primitive::weights`].
    pub joints: Vec<[u16; 4]>,
    /// `WEIGHTS_0`: per vertex, the weights of its four joints (non-negative; normalized by
    /// their sum when they do not add up to 1). Empty, or one entry per position.
    pub weights: Vec<Vec4>,
    /// Morph targets (blend shapes): displacements added to the vertices in proportion to
    /// the target weights. Empty for a primitive without targets.
    pub targets: Vec<MorphTarget>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

impl Primitive {
    /// True when the primitive carries joints and weights for every vertex, so a node with a
    /// skin deforms it.
    pub fn is_skinned(&self) -> bool {
        !self.joints.is_empty()
            && self.joints.len() == self.positions.len()
            && self.weights.len() == self.positions.len()
    }
}

/// One morph target of a primitive: per vertex, displacements of its position, normal and
/// tangent. Each list is empty (the target does not move that attribute) or has one entry per
/// position.
///
/// With weights `w`, a vertex is placed at `p + sum_i w_i * positions_i`, its normal is
/// `normalize(n + sum_i w_i * normals_i)` and its tangent direction
/// `normalize(t.xyz + sum_i w_i * tangents_i)` with the sign `t.w` kept (glTF 2.0). Morphing
/// comes before skinning.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTarget {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub tangents: Vec<Vec3>,
}

/// A glTF skin: the joint nodes that deform a skinned mesh and the matrices that take the mesh
/// from its bind pose to each joint's space.
///
/// A vertex with joints `j` and weights `w` (normalized to sum to 1) is placed at
/// `sum_i w_i * world_from_node[joints[j_i]] * inverse_bind_matrices[j_i] * p`; the transform
/// of the skinned node itself is ignored, as glTF 2.0 requires. See `Scene::evaluate` for
/// normals, tangents and the fallbacks.
#[derive(Clone, Debug, Default)]
pub struct Skin {
    pub name: String,
    /// Node index of each joint; a vertex's `JOINTS_0` values index this list. At most
    /// [`Skin::MAX_JOINTS`] entries.
    pub joints: Vec<usize>,
    /// Per joint, the transform from the mesh's bind-pose space to the joint's space (identity
    /// when the file has none). Same length as [`Skin::joints`].
    pub inverse_bind_matrices: Vec<Mat4>,
}

impl Skin {
    /// Most joints a skin may have: `JOINTS_0` holds 16-bit indices.
    pub const MAX_JOINTS: usize = 1 << 16;
}

/// How a material's alpha (base color factor alpha times its texture's alpha) covers the
/// surface, as glTF's `alphaMode`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is solid.
    #[default]
    Opaque,
    /// The surface exists where alpha is at least `cutoff` (`alphaCutoff`, 0.5 by default) and
    /// is absent elsewhere, for every ray.
    Mask { cutoff: f32 },
    /// Stochastic transparency: a ray passes through with probability `1 - alpha`, decided by a
    /// hash of the hit (see [`blend_coverage_hash`]), so averages over samples converge to
    /// alpha blending while each ray sees a solid or absent surface.
    Blend,
}

/// A material's reference to a texture: which texture, which texture coordinate set
/// (`TEXCOORD_0` or `TEXCOORD_1`) and the `KHR_texture_transform` applied to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub texture: usize,
    /// 0 or 1.
    pub tex_coord: u32,
    /// Maps the vertex coordinate to the texture coordinate (identity without the extension).
    pub transform: TextureTransform,
}

impl TextureRef {
    /// A reference to `texture` through `TEXCOORD_0`, untransformed.
    pub fn new(texture: usize) -> Self {
        Self {
            texture,
            tex_coord: 0,
            transform: TextureTransform::IDENTITY,
        }
    }

    /// The texture coordinate of a point whose vertex coordinates are `uv0` and `uv1`.
    pub fn uv(&self, uv0: Vec2, uv1: Vec2) -> Vec2 {
        let uv = if self.tex_coord == 1 { uv1 } else { uv0 };
        if self.transform == TextureTransform::IDENTITY {
            uv
        } else {
            self.transform.matrix().transform_point2(uv)
        }
    }
}

/// `KHR_texture_transform`: offset, rotation (radians) and scale of texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    pub offset: Vec2,
    pub rotation: f32,
    pub scale: Vec2,
}

impl TextureTransform {
    pub const IDENTITY: Self = Self {
        offset: Vec2::ZERO,
        rotation: 0.0,
        scale: Vec2::ONE,
    };

    /// The extension's matrix, `translation * rotation * scale`, its rotation turning the
    /// coordinates counter-clockwise in the image (u right, v down):
    /// `u' = ox + cos(r) sx u + sin(r) sy v`, `v' = oy - sin(r) sx u + cos(r) sy v`.
    pub fn matrix(&self) -> Affine2 {
        let (sin, cos) = self.rotation.sin_cos();
        Affine2::from_cols(
            Vec2::new(cos, -sin) * self.scale.x,
            Vec2::new(sin, cos) * self.scale.y,
            self.offset,
        )
    }
}

impl Default for TextureTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// The hash that decides whether a ray passes through an alpha-[`AlphaMode::Blend`] surface:
/// uniform in `[0, 1)` from the triangle and the hit's barycentric coordinates quantized to
/// 1/4096 of the triangle, so the CPU and GPU decide alike and a surface keeps a stable pattern
/// of holes (hashed alpha). A hit exists where the hash is below the alpha.
pub fn blend_coverage_hash(triangle: u32, b1: f32, b2: f32) -> f32 {
    let q = |b: f32| (b.clamp(0.0, 1.0) * 4096.0) as u32;
    let mut h = triangle.wrapping_mul(0x9e37_79b9) ^ q(b1).wrapping_mul(0x85eb_ca6b);
    h ^= q(b2).wrapping_mul(0xc2b2_ae35);
    // PCG-style output permutation.
    h = h.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    h = ((h >> ((h >> 28) + 4)) ^ h).wrapping_mul(277_803_737);
    h = (h >> 22) ^ h;
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// glTF metallic-roughness material. All colors are linear RGB.
///
/// BRDF (ARCHITECTURE.md): glTF 2.0's `mix(dielectric, metal, metallic)`; see
/// `gi_reference::brdf`.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA factor; multiplied by the base color texture when present. Alpha is the
    /// coverage [`Material::alpha_mode`] reads.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    /// Perceptual roughness; GGX alpha is `roughness^2`.
    pub roughness: f32,
    /// glTF convention: green channel scales roughness, blue scales metallic.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Linear emissive factor (already multiplied by KHR_materials_emissive_strength).
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    /// Tangent-space normal map (`normalTexture`); needs the primitive's tangents.
    pub normal_texture: Option<TextureRef>,
    /// `normalTexture.scale`: scales the map's x and y.
    pub normal_scale: f32,
    /// Ambient occlusion map (`occlusionTexture`, red channel). The real-time tiers darken the
    /// indirect diffuse light they gather by it; the path tracers trace the geometry's
    /// occlusion and do not read it.
    pub occlusion_texture: Option<TextureRef>,
    /// `occlusionTexture.strength`.
    pub occlusion_strength: f32,
    /// How alpha covers the surface.
    pub alpha_mode: AlphaMode,
    /// Single-sided surfaces still reflect on both sides (we never cull), but they only emit
    /// on their front side; double-sided emitters emit on both sides.
    pub double_sided: bool,
    /// `KHR_materials_specular`'s `specularFactor`: the weight of the dielectric's specular
    /// layer, in `[0, 1]` (0 makes a dielectric pure Lambert). 1 without the extension.
    pub specular: f32,
    /// Its texture; the alpha channel scales [`Material::specular`].
    pub specular_texture: Option<TextureRef>,
    /// `KHR_materials_specular`'s `specularColorFactor`, linear; scales the dielectric's
    /// Fresnel reflectance at normal incidence. White without the extension.
    pub specular_color: Vec3,
    /// Its texture (sRGB-encoded); the rgb channels scale [`Material::specular_color`].
    pub specular_color_texture: Option<TextureRef>,
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
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            specular: 1.0,
            specular_texture: None,
            specular_color: Vec3::ONE,
            specular_color_texture: None,
            ior: 1.5,
        }
    }
}

impl Material {
    /// Every texture reference of the material.
    pub fn texture_refs(&self) -> impl Iterator<Item = TextureRef> + '_ {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.emissive_texture,
            self.normal_texture,
            self.occlusion_texture,
            self.specular_texture,
            self.specular_color_texture,
        ]
        .into_iter()
        .flatten()
    }

    /// True when some rays may pass through the surface (alpha `MASK` or `BLEND`).
    pub fn alpha_tested(&self) -> bool {
        self.alpha_mode != AlphaMode::Opaque
    }

    /// Whether `edited` may replace this material in a scene that is being rendered: the
    /// same texture references and the same kind of alpha mode (a renderer built its texture
    /// table and its ray queries' alpha tests from them), and every factor finite and within
    /// glTF's range (what the importer clamps to). The cutoff, colors, emission, roughness,
    /// metallic, the specular layer, the normal and occlusion strengths and double-sidedness
    /// may change. The message names what may not.
    pub fn check_edit(&self, edited: &Material) -> Result<(), String> {
        let textures = |m: &Material| {
            [
                m.base_color_texture,
                m.metallic_roughness_texture,
                m.emissive_texture,
                m.normal_texture,
                m.occlusion_texture,
                m.specular_texture,
                m.specular_color_texture,
            ]
        };
        if textures(self) != textures(edited) {
            return Err(
                "its texture references changed: only factors may be edited; load \
                        the scene again to change textures"
                    .to_string(),
            );
        }
        if std::mem::discriminant(&self.alpha_mode) != std::mem::discriminant(&edited.alpha_mode) {
            return Err(format!(
                "its alpha mode changed from {:?} to {:?}: only the MASK cutoff may be edited",
                self.alpha_mode, edited.alpha_mode
            ));
        }
        let unit = |x: f32| (0.0..=1.0).contains(&x);
        let checks = [
            (
                "base color",
                edited.base_color.to_array().into_iter().all(unit),
                "in [0, 1]",
            ),
            ("metallic", unit(edited.metallic), "in [0, 1]"),
            ("roughness", unit(edited.roughness), "in [0, 1]"),
            ("specular", unit(edited.specular), "in [0, 1]"),
            (
                "occlusion strength",
                unit(edited.occlusion_strength),
                "in [0, 1]",
            ),
            (
                "emissive",
                edited.emissive.is_finite() && edited.emissive.min_element() >= 0.0,
                "finite and not negative",
            ),
            (
                "specular color",
                edited.specular_color.is_finite() && edited.specular_color.min_element() >= 0.0,
                "finite and not negative",
            ),
            ("ior", edited.ior.is_finite(), "finite"),
            ("normal scale", edited.normal_scale.is_finite(), "finite"),
            (
                "alpha cutoff",
                match edited.alpha_mode {
                    AlphaMode::Mask { cutoff } => cutoff.is_finite(),
                    _ => true,
                },
                "finite",
            ),
        ];
        match checks.iter().find(|(_, ok, _)| !ok) {
            Some((what, _, range)) => Err(format!("its {what} must be {range}")),
            None => Ok(()),
        }
    }
}

/// The linear value of texture reference `texture` at a point whose vertex texture coordinates
/// are `uv0` and `uv1`: bilinear, repeating; white where there is no texture or it is invalid
/// (an empty image), as every tier samples.
pub fn sample_texture(
    textures: &[Texture],
    texture: Option<TextureRef>,
    uv0: Vec2,
    uv1: Vec2,
) -> Vec4 {
    texture
        .and_then(|r| Some((r, textures.get(r.texture).filter(|t| t.is_valid())?)))
        .map_or(Vec4::ONE, |(r, t)| t.sample_bilinear(r.uv(uv0, uv1)))
}

/// How a texture's stored values map to linear ones.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureEncoding {
    /// Color channels through the sRGB EOTF (base color, emissive, specular color); alpha
    /// linear.
    Srgb,
    /// Values as stored (metallic-roughness, normal, occlusion, specular weight).
    #[default]
    Linear,
}

/// An 8-bit RGBA texture as stored in the file, with the encoding its use requires.
#[derive(Clone, Debug, Default)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub encoding: TextureEncoding,
    /// Row-major, `width * height` texels, top row first (glTF UV (0,0) is the top-left).
    pub texels: Vec<[u8; 4]>,
}

/// The sRGB EOTF of every 8-bit code.
static SRGB_TO_LINEAR: LazyLock<[f32; 256]> = LazyLock::new(|| {
    std::array::from_fn(|code| {
        let c = code as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
});

/// The linear value of sRGB-encoded 8-bit `code`.
pub fn srgb_to_linear(code: u8) -> f32 {
    SRGB_TO_LINEAR[code as usize]
}

/// The 8-bit sRGB code nearest to linear value `c` (clamped to `[0, 1]`), by the curve.
fn linear_to_srgb_exact(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let encoded = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

/// Per code `k` in 1..=255, the least f32 in `[0, 1]` that [`linear_to_srgb_exact`] takes to
/// `k` or above (the function never decreases), found by bisecting the f32 bit patterns.
static SRGB_THRESHOLDS: LazyLock<[f32; 255]> = LazyLock::new(|| {
    std::array::from_fn(|k| {
        let code = k as u8 + 1;
        // Non-negative f32s order as their bits.
        let (mut below, mut at) = (0u32, 1f32.to_bits());
        while at - below > 1 {
            let mid = below + (at - below) / 2;
            if linear_to_srgb_exact(f32::from_bits(mid)) >= code {
                at = mid;
            } else {
                below = mid;
            }
        }
        f32::from_bits(at)
    })
});

/// The 8-bit sRGB code nearest to linear value `c` (clamped to `[0, 1]`; NaN gives 0): the
/// curve's own result, found among precomputed thresholds (mip levels encode millions of
/// texels).
pub fn linear_to_srgb(c: f32) -> u8 {
    SRGB_THRESHOLDS.partition_point(|&t| t <= c) as u8
}

impl Texture {
    /// A texture of linear values `texels` (row-major), quantized to 8 bits in `encoding`.
    pub fn from_linear(
        name: impl Into<String>,
        width: u32,
        height: u32,
        encoding: TextureEncoding,
        texels: &[Vec4],
    ) -> Self {
        let unorm = |c: f32| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
        let texels = texels
            .iter()
            .map(|t| match encoding {
                TextureEncoding::Srgb => [
                    linear_to_srgb(t.x),
                    linear_to_srgb(t.y),
                    linear_to_srgb(t.z),
                    unorm(t.w),
                ],
                TextureEncoding::Linear => [unorm(t.x), unorm(t.y), unorm(t.z), unorm(t.w)],
            })
            .collect();
        Self {
            name: name.into(),
            width,
            height,
            encoding,
            texels,
        }
    }

    /// True when the texture has texels for its whole size (an empty or inconsistent texture
    /// samples as white).
    pub fn is_valid(&self) -> bool {
        self.width > 0
            && self.height > 0
            && self.texels.len() == self.width as usize * self.height as usize
    }

    /// The linear value of a stored texel.
    pub fn decode(&self, texel: [u8; 4]) -> Vec4 {
        let unorm = |c: u8| f32::from(c) * (1.0 / 255.0);
        match self.encoding {
            TextureEncoding::Srgb => Vec4::new(
                srgb_to_linear(texel[0]),
                srgb_to_linear(texel[1]),
                srgb_to_linear(texel[2]),
                unorm(texel[3]),
            ),
            TextureEncoding::Linear => Vec4::new(
                unorm(texel[0]),
                unorm(texel[1]),
                unorm(texel[2]),
                unorm(texel[3]),
            ),
        }
    }

    /// The linear value of texel `(x, y)` with repeat wrapping.
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        let (w, h) = (self.width as i64, self.height as i64);
        let ix = x.rem_euclid(w) as usize;
        let iy = y.rem_euclid(h) as usize;
        self.decode(self.texels[iy * self.width as usize + ix])
    }

    /// Bilinear sample of the linear values with repeat wrapping; texel centers sit at
    /// half-integer coordinates.
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (ix, iy) = (x0 as i64, y0 as i64);
        let top = self.texel(ix, iy).lerp(self.texel(ix + 1, iy), fx);
        let bottom = self.texel(ix, iy + 1).lerp(self.texel(ix + 1, iy + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Mean of all texels' linear values (used to estimate an emitter's power).
    pub fn average(&self) -> Vec4 {
        let sum: Vec4 = self.texels.iter().map(|&t| self.decode(t)).sum();
        sum / self.texels.len().max(1) as f32
    }

    /// Bytes of the stored texels.
    pub fn bytes(&self) -> u64 {
        self.texels.len() as u64 * 4
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

/// A keyframed animation of node transforms and morph target weights.
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

impl Channel {
    /// True for a channel of morph target weights, which changes the shape of the node's mesh
    /// rather than the node's transform.
    pub fn is_weights(&self) -> bool {
        matches!(self.values, ChannelValues::Weights(_))
    }

    /// True when the channel sets the same value at every time: all its keys hold one value
    /// (bit for bit), or it has no keys and sets nothing.
    pub fn is_constant(&self) -> bool {
        fn same<T: PartialEq>(values: &[T]) -> bool {
            values.windows(2).all(|w| w[0] == w[1])
        }
        self.times.is_empty()
            || match &self.values {
                ChannelValues::Translation(v) | ChannelValues::Scale(v) => same(v),
                ChannelValues::Rotation(v) => same(v),
                ChannelValues::Weights(v) => same(v),
            }
    }
}

#[derive(Clone, Debug)]
pub enum ChannelValues {
    Translation(Vec<Vec3>),
    Rotation(Vec<Quat>),
    Scale(Vec<Vec3>),
    /// Morph target weights of the node's mesh: per key, one weight per target.
    Weights(Vec<Vec<f32>>),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_by_thresholds_is_the_curves_own() {
        let mut values: Vec<f32> = vec![-1.0, 0.0, 1.0, 2.0, f32::NAN, f32::INFINITY];
        // Around every threshold, and every code's decoded value.
        for &t in SRGB_THRESHOLDS.iter() {
            let bits = t.to_bits();
            values.extend([bits - 1, bits, bits + 1].map(f32::from_bits));
        }
        values.extend((0..=255u8).map(srgb_to_linear));
        // A dense sweep of [0, 1].
        values.extend((0..=1_000_000).map(|i| i as f32 / 1_000_000.0));
        for c in values {
            assert_eq!(
                linear_to_srgb(c),
                linear_to_srgb_exact(c),
                "linear value {c}"
            );
        }
        for code in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(code)), code);
        }
    }

    /// A parent node and its child, the parent animated by `channel`.
    fn animated_pair(channel: Channel) -> Scene {
        let mut scene = Scene::default();
        scene.nodes.push(Node::default());
        scene.nodes.push(Node {
            parent: Some(0),
            translation: Vec3::X,
            ..Node::default()
        });
        scene.animations.push(Animation {
            name: "a".into(),
            channels: vec![channel],
        });
        scene
    }

    fn rotation_channel(keys: &[(f32, Quat)]) -> Channel {
        Channel {
            node: 0,
            times: keys.iter().map(|k| k.0).collect(),
            values: ChannelValues::Rotation(keys.iter().map(|k| k.1).collect()),
            interpolation: Interpolation::Linear,
        }
    }

    #[test]
    fn a_channel_whose_keys_agree_poses_the_scene_without_animating_it() {
        let turn = Quat::from_rotation_y(1.0);
        // One key (a pose, as exported by tools that store a take of one frame), and three
        // equal keys.
        for keys in [
            vec![(0.0, turn)],
            vec![(0.0, turn), (1.0, turn), (2.0, turn)],
        ] {
            let scene = animated_pair(rotation_channel(&keys));
            assert!(scene.animations[0].channels[0].is_constant());
            assert!(!scene.is_animated());
            assert_eq!(scene.moving_nodes(), vec![false, false]);
            assert_eq!(scene.deforming_nodes(), vec![false, false]);
            // The pose applies at every time.
            for time_s in [0.0, 0.5, 7.0] {
                let child = scene.world_transforms(time_s)[1].transform_point3(Vec3::ZERO);
                assert!(child.distance(turn * Vec3::X) < 1e-6, "{time_s}: {child}");
            }
        }
        // Keys that differ move the parent and its child.
        let scene = animated_pair(rotation_channel(&[(0.0, Quat::IDENTITY), (1.0, turn)]));
        assert!(!scene.animations[0].channels[0].is_constant());
        assert!(scene.is_animated());
        assert_eq!(scene.moving_nodes(), vec![true, true]);
    }

    #[test]
    fn material_edits_keep_textures_and_alpha_mode_and_stay_in_range() {
        let texture = Some(TextureRef::new(0));
        let material = Material {
            base_color_texture: texture,
            alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
            ..Material::default()
        };
        let edit = |change: &dyn Fn(&mut Material)| {
            let mut edited = material.clone();
            change(&mut edited);
            material.check_edit(&edited)
        };
        // Factors, the cutoff and double-sidedness may change.
        assert_eq!(edit(&|m| m.emissive = Vec3::new(5.0, 0.0, 2.0)), Ok(()));
        assert_eq!(
            edit(&|m| m.base_color = Vec4::new(0.2, 0.3, 0.4, 0.9)),
            Ok(())
        );
        assert_eq!(
            edit(&|m| {
                m.alpha_mode = AlphaMode::Mask { cutoff: 0.8 };
                m.double_sided = true;
                m.roughness = 0.1;
            }),
            Ok(())
        );
        // Textures and the kind of alpha mode may not.
        for refused in [
            edit(&|m| m.base_color_texture = None),
            edit(&|m| m.emissive_texture = texture),
            edit(&|m| m.alpha_mode = AlphaMode::Blend),
            edit(&|m| m.alpha_mode = AlphaMode::Opaque),
        ] {
            assert!(refused.is_err(), "{refused:?}");
        }
        // Nor factors outside glTF's ranges, or not finite.
        type Edit<'a> = &'a dyn Fn(&mut Material);
        let out_of_range: [(&str, Edit); 6] = [
            ("base color", &|m| m.base_color.x = 1.5),
            ("metallic", &|m| m.metallic = -0.1),
            ("roughness", &|m| m.roughness = f32::NAN),
            ("emissive", &|m| m.emissive = Vec3::new(1.0, -1.0, 0.0)),
            ("emissive", &|m| m.emissive = Vec3::splat(f32::INFINITY)),
            ("alpha cutoff", &|m| {
                m.alpha_mode = AlphaMode::Mask { cutoff: f32::NAN }
            }),
        ];
        for (what, change) in out_of_range {
            let message = edit(change).unwrap_err();
            assert!(message.contains(what), "{what}: {message}");
        }
    }
}

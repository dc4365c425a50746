//! The [`Reference`]: a scene frame prepared for path tracing, and what a ray finds when it hits
//! it (position, normals, BRDF, emission).

use gi_scene::{
    AlphaMode, Material, Scene, SceneFrame, Texture, TextureRef, Triangle, TriangleAttributes,
    WideBvh, blend_coverage_hash, sample_texture,
};
use glam::{DVec3, Vec2, Vec3, Vec4};

use crate::brdf::{Brdf, DielectricSpecular, ViewedBrdf};
use crate::lights::EmitterTable;
use crate::sampling::Frame;

/// A scene frame ready to be rendered: the flattened triangles, their BVH, the materials and
/// textures, and the power table of emissive triangles. Build one per frame and render it as
/// often as needed; it is immutable and shared by all render threads.
pub struct Reference {
    pub(crate) frame: SceneFrame,
    pub(crate) bvh: WideBvh,
    pub(crate) materials: Vec<Material>,
    pub(crate) textures: Vec<Texture>,
    pub(crate) emitters: EmitterTable,
    /// Used for triangles whose material index is out of range (hand-built scenes).
    default_material: Material,
    /// Per triangle, what every hit on it needs: f64 vertex and edges, the geometric normal.
    hit_triangles: Vec<HitTriangle>,
    /// Per material, then one for `default_material`: the BRDF and emission when no texture
    /// varies them over the surface.
    constant_shading: Vec<ConstantShading>,
    /// True when some material is alpha-tested: rays then test coverage at every hit on it.
    pub(crate) alpha_tested: bool,
}

/// What a ray found: the distance along its unit direction and the triangle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub(crate) t: f32,
    pub(crate) triangle: u32,
}

/// A triangle's vertex data in the form [`Reference::surface`] uses, computed once per frame
/// with the very operations the surface would repeat per hit (the results are identical).
struct HitTriangle {
    v0: DVec3,
    /// `v1 - v0`, in f64 (exact for f32 vertices of similar magnitude).
    e1: DVec3,
    /// `v2 - v0`.
    e2: DVec3,
    /// [`geometric_normal`]; zero for degenerate triangles.
    ng: Vec3,
}

impl HitTriangle {
    fn new(tri: &Triangle) -> Self {
        let v0 = DVec3::from(Vec3::from(tri.v0));
        Self {
            v0,
            e1: DVec3::from(Vec3::from(tri.v1)) - v0,
            e2: DVec3::from(Vec3::from(tri.v2)) - v0,
            ng: geometric_normal(tri),
        }
    }
}

/// A material's BRDF and emission where they do not depend on the texture coordinate (no
/// texture, or only empty ones), precomputed: `None` where a texture varies them.
#[derive(Clone, Copy)]
struct ConstantShading {
    brdf: Option<Brdf>,
    emission: Option<Vec3>,
}

/// What a path sees at a surface hit, in the conventions of the crate docs: both normals face
/// the side the ray came from, and the shading frame never puts `wo` below its horizon.
pub(crate) struct Surface {
    pub(crate) p: Vec3,
    /// Geometric normal, on the side of `wo`.
    pub(crate) ng: Vec3,
    /// Shading frame: Z is the interpolated vertex normal on the side of `ng`, or `ng` when
    /// `wo` is below the interpolated normal's horizon.
    pub(crate) frame: Frame,
    /// The BRDF at the hit, seen from the direction towards the previous vertex (local to
    /// `frame`).
    pub(crate) brdf: ViewedBrdf,
    /// Radiance emitted towards the previous vertex (zero on the back of single-sided
    /// emitters).
    pub(crate) emitted: Vec3,
}

impl Reference {
    /// Prepares `frame` (an evaluation of `scene`, whose materials and textures it indexes)
    /// and builds its BVH.
    pub fn new(scene: &Scene, frame: SceneFrame) -> Self {
        let bvh = WideBvh::build(&frame.triangles);
        let materials = scene.materials.clone();
        let textures = scene.textures.clone();
        let emitters = EmitterTable::build(&frame, &materials, &textures);
        tracing::debug!(
            triangles = frame.triangles.len(),
            emissive_triangles = emitters.len(),
            punctual_lights = frame.lights.len(),
            bvh_build_seconds = bvh.build_time.as_secs_f64(),
            "reference scene prepared"
        );
        let hit_triangles = frame.triangles.iter().map(HitTriangle::new).collect();
        let mut reference = Self {
            frame,
            bvh,
            materials,
            textures,
            emitters,
            default_material: Material::default(),
            hit_triangles,
            constant_shading: Vec::new(),
            alpha_tested: false,
        };
        reference.alpha_tested = reference.materials.iter().any(Material::alpha_tested);
        reference.constant_shading = reference
            .materials
            .iter()
            .chain([&reference.default_material])
            .map(|material| reference.constant_shading(material))
            .collect();
        reference
    }

    /// What of `material`'s shading does not depend on the texture coordinate.
    fn constant_shading(&self, material: &Material) -> ConstantShading {
        let untextured =
            |textures: &[Option<TextureRef>]| textures.iter().all(|&t| self.texture(t).is_none());
        // Without textures, sampling them gives exactly 1: the values the surface computes.
        let brdf = untextured(&[
            material.base_color_texture,
            material.metallic_roughness_texture,
            material.specular_texture,
            material.specular_color_texture,
        ])
        .then(|| self.brdf(material, Vec2::ZERO, Vec2::ZERO));
        let emission = untextured(&[material.emissive_texture])
            .then(|| self.emission(material, Vec2::ZERO, Vec2::ZERO));
        ConstantShading { brdf, emission }
    }

    /// The frame being rendered (triangles, lights, camera, sky).
    pub fn frame(&self) -> &SceneFrame {
        &self.frame
    }

    /// Wall time of the BVH build, in seconds.
    pub fn bvh_build_seconds(&self) -> f64 {
        self.bvh.build_time.as_secs_f64()
    }

    /// Number of triangles in the emitter table (emissive triangles with non-zero power).
    pub fn emissive_triangle_count(&self) -> usize {
        self.emitters.len()
    }

    /// Bytes of the data this reference holds for rendering: triangles, their attributes,
    /// the BVH, the emitter table and the textures (the accumulation buffer is the caller's).
    pub fn memory_bytes(&self) -> u64 {
        use std::mem::size_of_val;
        let frame = &self.frame;
        let emitters = &self.emitters.distribution;
        let bytes = size_of_val(frame.triangles.as_slice())
            + size_of_val(frame.attributes.as_slice())
            + self.bvh.memory_bytes()
            + size_of_val(self.hit_triangles.as_slice())
            + size_of_val(emitters.triangles.as_slice())
            + size_of_val(emitters.cdf.as_slice())
            + size_of_val(emitters.selection.as_slice())
            + self.emitters.shape_bytes()
            + self
                .textures
                .iter()
                .map(|t| size_of_val(t.texels.as_slice()))
                .sum::<usize>();
        bytes as u64
    }

    pub(crate) fn material(&self, triangle: u32) -> &Material {
        let index = self.frame.attributes[triangle as usize].material as usize;
        self.materials.get(index).unwrap_or(&self.default_material)
    }

    /// The precomputed shading of the material of `triangle` (the default material's for
    /// indices out of range, as [`Reference::material`]).
    fn constant_shading_of(&self, triangle: u32) -> ConstantShading {
        let index = self.frame.attributes[triangle as usize].material as usize;
        self.constant_shading[index.min(self.materials.len())]
    }

    /// The BRDF of `material` at a point with vertex texture coordinates `uv0`, `uv1`.
    fn brdf(&self, material: &Material, uv0: Vec2, uv1: Vec2) -> Brdf {
        let sample = |texture| self.sample_texture(texture, uv0, uv1);
        let base = material.base_color.truncate() * sample(material.base_color_texture).truncate();
        let mr = sample(material.metallic_roughness_texture);
        Brdf::new(base, material.metallic * mr.z, material.roughness * mr.y)
            .with_specular(DielectricSpecular::of_material(material, sample))
    }

    pub(crate) fn texture(&self, texture: Option<TextureRef>) -> Option<&Texture> {
        texture
            .and_then(|r| self.textures.get(r.texture))
            .filter(|t| t.is_valid())
    }

    fn sample_texture(&self, texture: Option<TextureRef>, uv0: Vec2, uv1: Vec2) -> Vec4 {
        sample_texture(&self.textures, texture, uv0, uv1)
    }

    /// Emissive radiance of `material` at a point with vertex texture coordinates `uv0`,
    /// `uv1` (either side).
    pub(crate) fn emission(&self, material: &Material, uv0: Vec2, uv1: Vec2) -> Vec3 {
        if material.emissive == Vec3::ZERO {
            return Vec3::ZERO;
        }
        material.emissive
            * self
                .sample_texture(material.emissive_texture, uv0, uv1)
                .truncate()
    }

    /// True when the surface of `triangle` exists at barycentrics `(b1, b2)` for a ray: always
    /// for opaque materials; where the alpha reaches the cutoff for `MASK`; where the alpha
    /// exceeds [`blend_coverage_hash`] for `BLEND`.
    pub(crate) fn covers(&self, triangle: u32, b1: f32, b2: f32) -> bool {
        let material = self.material(triangle);
        if material.alpha_mode == AlphaMode::Opaque {
            return true;
        }
        let attributes = &self.frame.attributes[triangle as usize];
        let b0 = 1.0 - b1 - b2;
        let (uv0, uv1) = (
            interpolate(attributes.uvs, b0, b1, b2),
            interpolate(attributes.uvs1, b0, b1, b2),
        );
        let alpha =
            material.base_color.w * self.sample_texture(material.base_color_texture, uv0, uv1).w;
        match material.alpha_mode {
            AlphaMode::Opaque => true,
            AlphaMode::Mask { cutoff } => alpha >= cutoff,
            AlphaMode::Blend => blend_coverage_hash(triangle, b1, b2) < alpha,
        }
    }

    /// [`Reference::covers`] at the point where the ray from `origin` along `dir` crosses
    /// `triangle`.
    pub(crate) fn covers_hit(&self, origin: Vec3, dir: Vec3, triangle: u32) -> bool {
        if !self.alpha_tested {
            return true;
        }
        let [b1, b2] = barycentrics(&self.hit_triangles[triangle as usize], origin, dir);
        self.covers(triangle, b1 as f32, b2 as f32)
    }

    /// The surface a ray from `origin` along unit `dir` found at `hit`.
    pub(crate) fn surface(&self, origin: Vec3, dir: Vec3, hit: &Hit) -> Surface {
        let tri = &self.hit_triangles[hit.triangle as usize];
        let attributes = &self.frame.attributes[hit.triangle as usize];
        let [b1, b2] = barycentrics(tri, origin, dir);
        let b0 = 1.0 - b1 - b2;
        // Interpolating the vertices keeps the point on the triangle's plane, which the ray
        // offsets rely on; origin + t * dir drifts off it by t's rounding.
        let p = (tri.v0 + tri.e1 * b1 + tri.e2 * b2).as_vec3();
        let (b0, b1, b2) = (b0 as f32, b1 as f32, b2 as f32);

        let wo = -dir;
        let ng_front = if tri.ng == Vec3::ZERO { wo } else { tri.ng };
        let front_facing = ng_front.dot(wo) >= 0.0;
        let ng = if front_facing { ng_front } else { -ng_front };
        let material = || self.material(hit.triangle);
        let uvs = || {
            (
                interpolate(attributes.uvs, b0, b1, b2),
                interpolate(attributes.uvs1, b0, b1, b2),
            )
        };
        let [n0, n1, n2] = attributes.normals;
        let mut ns = (n0 * b0 + n1 * b1 + n2 * b2).normalize_or(ng);
        if material().normal_texture.is_some() {
            let (uv0, uv1) = uvs();
            ns = self.mapped_normal(material(), attributes, ns, [b0, b1, b2], uv0, uv1);
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        if ns.dot(wo) <= 1e-6 {
            ns = ng;
        }
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo);

        let constant = self.constant_shading_of(hit.triangle);
        let brdf = constant.brdf.unwrap_or_else(|| {
            let (uv0, uv1) = uvs();
            self.brdf(material(), uv0, uv1)
        });
        let emitted = if front_facing || material().double_sided {
            constant.emission.unwrap_or_else(|| {
                let (uv0, uv1) = uvs();
                self.emission(material(), uv0, uv1)
            })
        } else {
            Vec3::ZERO
        };
        Surface {
            p,
            ng,
            frame,
            brdf: brdf.seen_from(wo),
            emitted,
        }
    }

    /// The unit normal `n` (the interpolated vertex normal) perturbed by `material`'s normal
    /// texture in the tangent frame of the triangle's interpolated tangent: the map's xy scaled
    /// by `normal_scale`, the tangent made orthogonal to `n`, the bitangent
    /// `w * n x tangent`. `n` itself where the triangle has no usable tangent.
    fn mapped_normal(
        &self,
        material: &Material,
        attributes: &TriangleAttributes,
        n: Vec3,
        [b0, b1, b2]: [f32; 3],
        uv0: Vec2,
        uv1: Vec2,
    ) -> Vec3 {
        let [t0, t1, t2] = attributes.tangents;
        let t = (t0 * b0 + t1 * b1 + t2 * b2).truncate();
        let tangent = (t - n * n.dot(t)).normalize_or_zero();
        if tangent == Vec3::ZERO || self.texture(material.normal_texture).is_none() {
            return n;
        }
        let sign = if t0.w < 0.0 { -1.0 } else { 1.0 };
        let bitangent = n.cross(tangent) * sign;
        let m = self
            .sample_texture(material.normal_texture, uv0, uv1)
            .truncate()
            * 2.0
            - 1.0;
        let m = m * Vec3::new(material.normal_scale, material.normal_scale, 1.0);
        (tangent * m.x + bitangent * m.y + n * m.z).normalize_or(n)
    }
}

/// `t0 b0 + t1 b1 + t2 b2`.
fn interpolate([t0, t1, t2]: [Vec2; 3], b0: f32, b1: f32, b2: f32) -> Vec2 {
    t0 * b0 + t1 * b1 + t2 * b2
}

/// Unit normal on the triangle's front side, `(v1 - v0) x (v2 - v0)`: the side from which the
/// vertices appear counter-clockwise (glTF's front face). Zero for degenerate triangles.
pub(crate) fn geometric_normal(tri: &Triangle) -> Vec3 {
    Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0)).normalize_or_zero()
}

/// Barycentric weights of v1 and v2 where the ray crosses the triangle's plane, in f64
/// (Möller-Trumbore), clamped onto the triangle. Computed here rather than taken from the BVH
/// hit so the hit point is accurate for triangles of any size.
fn barycentrics(tri: &HitTriangle, origin: Vec3, dir: Vec3) -> [f64; 2] {
    let HitTriangle { v0, e1, e2, .. } = *tri;
    let d = DVec3::from(dir);
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det.abs() < 1e-30 {
        return [1.0 / 3.0; 2];
    }
    let tvec = DVec3::from(origin) - v0;
    let b1 = tvec.dot(pvec) / det;
    let b2 = d.dot(tvec.cross(e1)) / det;
    let (b1, b2) = (b1.clamp(0.0, 1.0), b2.clamp(0.0, 1.0));
    let excess = (b1 + b2 - 1.0).max(0.0) * 0.5;
    [b1 - excess, b2 - excess]
}

/// Offset of a ray origin from its surface along the geometric normal: large enough to escape
/// the f32 rounding of the intersection test for scenes up to about 10^4 units across, small
/// enough not to leak light through contacts.
pub(crate) fn ray_epsilon(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
}

/// `p` pushed off its surface along unit `n` (the side the new ray leaves towards).
pub(crate) fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    p + n * ray_epsilon(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_scene::{CameraView, Mesh, Node, Primitive};
    use glam::Vec3A;

    #[test]
    fn barycentrics_locate_the_crossing_on_large_triangles() {
        let tri = Triangle {
            v0: Vec3A::new(0.0, 0.0, 0.0),
            v1: Vec3A::new(4.0, 0.0, 0.0),
            v2: Vec3A::new(0.0, 4.0, 0.0),
        };
        let [b1, b2] = barycentrics(
            &HitTriangle::new(&tri),
            Vec3::new(1.0, 2.0, 5.0),
            Vec3::NEG_Z,
        );
        assert!((b1 - 0.25).abs() < 1e-12 && (b2 - 0.5).abs() < 1e-12);
    }

    /// One triangle in the plane y = 0, counter-clockwise seen from above (front +Y), with
    /// vertex normals tilted towards +X, and a single-sided emissive material.
    fn tilted_triangle() -> (Reference, Vec3) {
        let tilted = Vec3::new(0.5, 1.0, 0.0).normalize();
        let scene = Scene {
            meshes: vec![Mesh {
                name: String::new(),
                weights: Vec::new(),
                primitives: vec![Primitive {
                    positions: vec![
                        Vec3::ZERO,
                        Vec3::new(0.0, 0.0, 4.0),
                        Vec3::new(4.0, 0.0, 0.0),
                    ],
                    normals: vec![tilted; 3],
                    uvs: Vec::new(),
                    indices: vec![0, 1, 2],
                    material: 0,
                    ..Default::default()
                }],
            }],
            materials: vec![Material {
                emissive: Vec3::ONE,
                ..Material::default()
            }],
            nodes: vec![Node {
                mesh: Some(0),
                ..Node::default()
            }],
            ..Scene::default()
        };
        let camera = CameraView::look_at(Vec3::Y, Vec3::ZERO, 1.0);
        (
            Reference::new(&scene, scene.evaluate(0.0, Some(camera))),
            tilted,
        )
    }

    fn hit_from(reference: &Reference, origin: Vec3, dir: Vec3) -> Surface {
        let hit = reference
            .trace(origin, dir, &mut 0)
            .expect("the ray hits the triangle");
        reference.surface(origin, dir, &hit)
    }

    #[test]
    fn normals_face_the_viewer_and_emission_only_the_front() {
        let (reference, tilted) = tilted_triangle();
        let above = hit_from(&reference, Vec3::new(1.0, 1.0, 1.0), Vec3::NEG_Y);
        assert_eq!(above.ng, Vec3::Y);
        assert!((above.frame.z - tilted).length() < 1e-6);
        assert!((above.p - Vec3::new(1.0, 0.0, 1.0)).length() < 1e-6);
        assert_eq!(above.emitted, Vec3::ONE);

        let below = hit_from(&reference, Vec3::new(1.0, -1.0, 1.0), Vec3::Y);
        assert_eq!(below.ng, Vec3::NEG_Y);
        assert!((below.frame.z + tilted).length() < 1e-6);
        assert_eq!(below.emitted, Vec3::ZERO);

        // Seen from above but below the tilted normal's horizon: the geometric normal shades.
        let origin = Vec3::new(1.0, 0.0, 1.0) + Vec3::new(-1.0, 0.2, 0.0) * 2.0;
        let grazing = hit_from(&reference, origin, Vec3::new(1.0, -0.2, 0.0).normalize());
        assert_eq!(grazing.ng, Vec3::Y);
        assert_eq!(grazing.frame.z, Vec3::Y);
        assert!(grazing.brdf.wo().z > 0.0);
    }
}

//! Sampling emissive triangles: a power table over them and uniform points on each.

use gi_scene::{EmitterDistribution, Material, SceneFrame, Texture};
use glam::{Vec2, Vec3};

use crate::sampling::uniform_triangle;
use crate::scene::{Reference, geometric_normal};

/// Emissive triangles with a discrete distribution proportional to their power
/// ([`EmitterDistribution`], shared with the GPU tiers). Textured emission uses the texture's
/// average, so the table is exact for untextured emitters and a good guess otherwise (the
/// estimate stays unbiased either way: only noise depends on the table).
pub(crate) struct EmitterTable {
    pub(crate) distribution: EmitterDistribution,
    /// Per emitter, in the distribution's order: its shape as sampling reads it.
    shapes: Vec<EmitterShape>,
}

/// An emissive triangle's vertex, edges, area and unit normal, computed once with the very
/// operations [`Reference::sample_emitter`] would otherwise repeat per sample.
#[derive(Clone, Copy)]
struct EmitterShape {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    area: f32,
    normal: Vec3,
}

impl EmitterShape {
    fn new(tri: &gi_scene::Triangle) -> Self {
        let e1 = Vec3::from(tri.v1 - tri.v0);
        let e2 = Vec3::from(tri.v2 - tri.v0);
        Self {
            v0: Vec3::from(tri.v0),
            e1,
            e2,
            area: 0.5 * e1.cross(e2).length(),
            normal: geometric_normal(tri),
        }
    }
}

/// A point drawn on an emitter for next-event estimation, seen from the shading point.
pub(crate) struct EmitterSample {
    /// Unit direction from the shading point to the emitter point.
    pub(crate) wi: Vec3,
    /// Distance along `wi` where the shadow ray must stop (just short of the emitter).
    pub(crate) shadow_distance: f32,
    /// Radiance leaving the emitter towards the shading point.
    pub(crate) radiance: Vec3,
    /// Solid-angle pdf at the shading point (selection * area pdf converted).
    pub(crate) pdf: f32,
}

impl EmitterTable {
    pub(crate) fn build(frame: &SceneFrame, materials: &[Material], textures: &[Texture]) -> Self {
        let distribution = EmitterDistribution::build(frame, materials, textures);
        let shapes = distribution
            .triangles
            .iter()
            .map(|&t| EmitterShape::new(&frame.triangles[t as usize]))
            .collect();
        Self {
            distribution,
            shapes,
        }
    }

    /// Bytes of the precomputed emitter shapes.
    pub(crate) fn shape_bytes(&self) -> usize {
        std::mem::size_of_val(self.shapes.as_slice())
    }

    pub(crate) fn len(&self) -> usize {
        self.distribution.len()
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.distribution.is_empty()
    }

    /// Probability that [`EmitterTable::pick`] returns scene triangle `triangle`.
    pub(crate) fn selection_probability(&self, triangle: u32) -> f32 {
        self.distribution
            .selection
            .get(triangle as usize)
            .copied()
            .unwrap_or(0.0)
    }

    /// An emitter drawn proportionally to power: its index in the table, its scene triangle
    /// index and its probability.
    fn pick(&self, u: f32) -> (usize, u32, f32) {
        let u = f64::from(u);
        let table = &self.distribution;
        let entry = table
            .cdf
            .partition_point(|&c| c <= u)
            .min(table.cdf.len() - 1);
        let triangle = table.triangles[entry];
        (entry, triangle, table.selection[triangle as usize])
    }
}

impl Reference {
    /// Draws a point on an emissive triangle (by power, then uniformly by area) seen from the
    /// shadow-ray origin `p`, or `None` when it cannot contribute: the table is empty, the point
    /// lies on the back of a single-sided emitter, or the geometry is degenerate.
    pub(crate) fn sample_emitter(
        &self,
        p: Vec3,
        u_select: f32,
        u_point: Vec2,
    ) -> Option<EmitterSample> {
        if self.emitters.is_empty() {
            return None;
        }
        let (entry, triangle, selection) = self.emitters.pick(u_select);
        let EmitterShape {
            v0,
            e1,
            e2,
            area,
            normal: n_light,
        } = self.emitters.shapes[entry];
        let b = uniform_triangle(u_point);
        let y = v0 + e1 * b.x + e2 * b.y;
        let to_light = y - p;
        let distance_sq = to_light.length_squared();
        if area <= 0.0 || distance_sq <= 0.0 {
            return None;
        }
        let distance = distance_sq.sqrt();
        let wi = to_light / distance;
        let cos_light = -n_light.dot(wi);
        let material = self.material(triangle);
        if cos_light == 0.0 || (cos_light < 0.0 && !material.double_sided) {
            return None;
        }
        // Where an alpha-tested emitter is absent it emits nothing.
        if material.alpha_tested() && !self.covers(triangle, b.x, b.y) {
            return None;
        }
        let attributes = &self.frame.attributes[triangle as usize];
        let at = |uvs: [Vec2; 3]| uvs[0] * (1.0 - b.x - b.y) + uvs[1] * b.x + uvs[2] * b.y;
        let radiance = self.emission(material, at(attributes.uvs), at(attributes.uvs1));
        let pdf = selection * distance_sq / (area * cos_light.abs());
        (pdf.is_finite() && pdf > 0.0).then_some(EmitterSample {
            wi,
            shadow_distance: shadow_distance(distance),
            radiance,
            pdf,
        })
    }

    /// Solid-angle pdf with which [`Reference::sample_emitter`] would have produced the point
    /// a ray found on `triangle` at `distance`, arriving along unit `dir`.
    pub(crate) fn emitter_pdf(&self, triangle: u32, distance: f32, dir: Vec3) -> f32 {
        let selection = self.emitters.selection_probability(triangle);
        if selection <= 0.0 {
            return 0.0;
        }
        let tri = &self.frame.triangles[triangle as usize];
        let cross = Vec3::from((tri.v1 - tri.v0).cross(tri.v2 - tri.v0));
        let area = 0.5 * cross.length();
        let cos_light = cross.normalize_or_zero().dot(dir).abs();
        if area <= 0.0 || cos_light <= 0.0 {
            return 0.0;
        }
        selection * distance * distance / (area * cos_light)
    }
}

/// Where a shadow ray towards a light at `distance` stops: short of the light by a relative
/// margin that exceeds the f32 error of intersecting the emitter's own plane (about
/// `1e-7 / cos` relative), so an emitter never shadows itself except at grazing angles where
/// its contribution vanishes anyway.
pub(crate) fn shadow_distance(distance: f32) -> f32 {
    distance * (1.0 - 1e-4)
}

#[cfg(test)]
mod tests {
    use gi_scene::{
        CameraView, Material, Mesh, Node, Primitive, Scene, Texture, TextureEncoding, TextureRef,
    };
    use glam::{Vec2, Vec3, Vec4};

    use crate::sampling::Sampler;
    use crate::scene::Reference;

    /// Two textured emitters of different size and orientation (one double-sided).
    fn textured_emitters() -> Reference {
        let texels: Vec<Vec4> = (0..16)
            .map(|i| {
                let c = |n: u32| (i % n) as f32 / (n - 1) as f32;
                Vec4::new(c(5), c(3), c(7), 1.0)
            })
            .collect();
        let triangle = |positions: Vec<Vec3>, uvs: Vec<Vec2>, material| Primitive {
            normals: vec![Vec3::Y; 3],
            positions,
            uvs,
            indices: vec![0, 1, 2],
            material,
            ..Default::default()
        };
        let scene = Scene {
            meshes: vec![Mesh {
                name: String::new(),
                weights: Vec::new(),
                primitives: vec![
                    triangle(
                        vec![
                            Vec3::new(-1.0, 2.0, 0.0),
                            Vec3::new(1.0, 2.5, 0.3),
                            Vec3::new(0.0, 1.8, 1.0),
                        ],
                        vec![
                            Vec2::new(0.1, 0.2),
                            Vec2::new(0.9, 0.1),
                            Vec2::new(0.4, 0.8),
                        ],
                        0,
                    ),
                    triangle(
                        vec![
                            Vec3::new(2.0, 0.5, -1.0),
                            Vec3::new(2.2, 1.5, -1.0),
                            Vec3::new(2.1, 1.0, 0.0),
                        ],
                        vec![
                            Vec2::new(0.7, 0.7),
                            Vec2::new(0.0, 0.3),
                            Vec2::new(1.0, 1.0),
                        ],
                        1,
                    ),
                ],
            }],
            materials: vec![
                Material {
                    emissive: Vec3::new(1.0, 2.0, 3.0),
                    emissive_texture: Some(TextureRef::new(0)),
                    ..Material::default()
                },
                Material {
                    emissive: Vec3::splat(0.5),
                    emissive_texture: Some(TextureRef::new(0)),
                    double_sided: true,
                    ..Material::default()
                },
            ],
            textures: vec![Texture::from_linear(
                "",
                4,
                4,
                TextureEncoding::Srgb,
                &texels,
            )],
            nodes: vec![Node {
                mesh: Some(0),
                ..Node::default()
            }],
            ..Scene::default()
        };
        let camera = CameraView::look_at(Vec3::ZERO, Vec3::X, 1.0);
        Reference::new(&scene, scene.evaluate(0.0, Some(camera)))
    }

    #[test]
    fn light_samples_agree_with_what_rays_find_there() {
        // Next-event estimation and BRDF-sampled hits must see the same radiance and the same
        // light pdf at the same point, or MIS is inconsistent.
        let reference = textured_emitters();
        let p = Vec3::new(0.3, 0.0, 0.2);
        let mut sampler = Sampler::new(3, 0, 0);
        let mut checked = 0;
        for _ in 0..200 {
            let Some(sample) = reference.sample_emitter(p, sampler.next_f32(), sampler.next_2d())
            else {
                continue;
            };
            let hit = reference
                .trace(p, sample.wi, &mut 0)
                .expect("the sampled point is visible");
            assert!(
                hit.t >= sample.shadow_distance,
                "the shadow ray would hit the emitter"
            );
            let surface = reference.surface(p, sample.wi, &hit);
            let relative = (surface.emitted - sample.radiance).abs().max_element()
                / sample.radiance.max_element();
            assert!(
                relative < 1e-4,
                "{} vs {}",
                surface.emitted,
                sample.radiance
            );
            let pdf = reference.emitter_pdf(hit.triangle, hit.t, sample.wi);
            assert!(
                (pdf / sample.pdf - 1.0).abs() < 1e-3,
                "{pdf} vs {}",
                sample.pdf
            );
            checked += 1;
        }
        assert!(checked > 100, "only {checked} samples were usable");
    }
}

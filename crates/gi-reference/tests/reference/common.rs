//! Scene builders, rendering and the statistics every tolerance is derived from.

use std::f64::consts::PI;

use gi_image::Image;
use gi_reference::brdf::Brdf;
use gi_reference::{Reference, RenderSettings, Strategy};
use gi_scene::{CameraView, Light, LightKind, Material, Mesh, Node, Primitive, Scene, Sky};
use glam::{DVec3, Quat, Vec2, Vec3};

/// Tolerances are this many standard errors: with a few hundred comparisons per run, a correct
/// renderer fails one by chance with probability well below 1e-3.
pub const K_SIGMA: f64 = 5.0;

/// A scene assembled in code, one node per mesh or light.
pub struct SceneBuilder {
    pub scene: Scene,
}

impl SceneBuilder {
    pub fn new(sky: Sky) -> Self {
        Self {
            scene: Scene {
                name: "test".into(),
                sky,
                exposure: 1.0,
                ..Default::default()
            },
        }
    }

    pub fn add(&mut self, mut primitive: Primitive, material: Material) -> &mut Self {
        primitive.material = self.scene.materials.len();
        self.scene.materials.push(material);
        self.scene.meshes.push(Mesh {
            name: String::new(),
            weights: Vec::new(),
            primitives: vec![primitive],
        });
        self.scene.nodes.push(Node {
            mesh: Some(self.scene.meshes.len() - 1),
            ..Default::default()
        });
        self
    }

    /// A punctual light at `position` shining along `direction`.
    pub fn light(
        &mut self,
        kind: LightKind,
        intensity: f32,
        position: Vec3,
        direction: Vec3,
    ) -> &mut Self {
        self.scene.lights.push(Light {
            name: String::new(),
            kind,
            color: Vec3::ONE,
            intensity,
            range: None,
        });
        self.scene.nodes.push(Node {
            translation: position,
            rotation: Quat::from_rotation_arc(Vec3::NEG_Z, direction.normalize()),
            light: Some(self.scene.lights.len() - 1),
            ..Default::default()
        });
        self
    }

    pub fn reference(&self, camera: CameraView) -> Reference {
        Reference::new(&self.scene, self.scene.evaluate(0.0, Some(camera)))
    }
}

pub fn material(base: Vec3, metallic: f32, roughness: f32) -> Material {
    Material {
        name: String::new(),
        base_color: base.extend(1.0),
        metallic,
        roughness,
        ..Default::default()
    }
}

/// A grey Lambert surface: a dielectric without specular layer (`KHR_materials_specular`'s
/// factor 0), so its BRDF is exactly `albedo / pi`.
pub fn diffuse(albedo: f32) -> Material {
    Material {
        specular: 0.0,
        ..material(Vec3::splat(albedo), 0.0, 1.0)
    }
}

pub fn emitter(radiance: Vec3, double_sided: bool) -> Material {
    Material {
        emissive: radiance,
        double_sided,
        ..material(Vec3::ZERO, 0.0, 1.0)
    }
}

/// A parallelogram `center +- u +- v` whose front face (counter-clockwise side) is `u x v`,
/// with texture coordinates `((s + 1) / 2, (t + 1) / 2)` at `center + s u + t v`.
pub fn quad(center: Vec3, u: Vec3, v: Vec3) -> Primitive {
    let positions = vec![
        center - u - v,
        center + u - v,
        center + u + v,
        center - u + v,
    ];
    let n = u.cross(v).normalize();
    Primitive {
        normals: vec![n; 4],
        positions,
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
        ..Default::default()
    }
}

/// A horizontal square facing up (`+Y`) of half-size `half` at `center`.
pub fn floor(center: Vec3, half: f32) -> Primitive {
    quad(center, Vec3::X * half, Vec3::NEG_Z * half)
}

/// A UV sphere with counter-clockwise-from-outside triangles. `flat`: each triangle carries its
/// face normal (a convex polyhedron with exact geometric shading); otherwise vertex normals are
/// radial.
pub fn sphere(center: Vec3, radius: f32, segments: u32, rings: u32, flat: bool) -> Primitive {
    let point = |i: u32, j: u32| {
        let phi = 2.0 * std::f32::consts::PI * i as f32 / segments as f32;
        let theta = std::f32::consts::PI * j as f32 / rings as f32;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    };
    let mut primitive = Primitive::default();
    for j in 0..rings {
        for i in 0..segments {
            let corners = [
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            ];
            for tri in [[0, 1, 2], [0, 2, 3]] {
                let mut p = tri.map(|k| corners[k]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                if n.length_squared() < 1e-12 {
                    continue; // the degenerate half of a pole quad
                }
                if n.dot(p[0] + p[1] + p[2]) < 0.0 {
                    p.swap(1, 2);
                }
                let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                for q in p {
                    primitive.indices.push(primitive.positions.len() as u32);
                    primitive.positions.push(center + q * radius);
                    primitive.normals.push(if flat { face } else { q });
                }
            }
        }
    }
    primitive
}

pub fn settings(size: u32, spp: u32, seed: u64, strategy: Strategy) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        seed,
        strategy,
        ..Default::default()
    }
}

/// A finished render with the per-pixel standard error of its mean.
pub struct Rendered {
    pub image: Image,
    pub standard_error: Image,
}

pub fn render(reference: &Reference, settings: &RenderSettings) -> Rendered {
    let mut accumulator = reference.accumulator(settings).expect("valid settings");
    accumulator.add_samples(settings.spp);
    let stats = accumulator.stats();
    assert_eq!(stats.nonfinite_samples, 0, "non-finite path samples");
    assert_eq!(
        stats.samples,
        settings.pixel_count() * u64::from(settings.spp)
    );
    Rendered {
        image: accumulator.image(),
        standard_error: accumulator.standard_error(),
    }
}

/// An estimate with its standard error.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    pub mean: f64,
    pub se: f64,
}

impl Estimate {
    /// Difference of two independent estimates.
    pub fn minus(self, other: Estimate) -> Estimate {
        Estimate {
            mean: self.mean - other.mean,
            se: self.se.hypot(other.se),
        }
    }

    /// Standard errors between the estimate and `value`, which is itself uncertain by
    /// `value_tolerance` (quadrature or geometry), counted in full.
    pub fn assert_near(&self, value: f64, value_tolerance: f64, what: &str) {
        let tolerance = K_SIGMA * self.se + value_tolerance;
        assert!(
            (self.mean - value).abs() <= tolerance,
            "{what}: rendered {:.6} +- {:.2e} (1 sigma), expected {value:.6}, tolerance {tolerance:.2e}",
            self.mean,
            self.se
        );
    }
}

fn channel(v: Vec3, c: usize) -> f64 {
    f64::from(v[c])
}

/// Mean of channel `c` over the pixels selected by `keep(x, y)`, with its standard error
/// (pixels are independent, so variances add).
pub fn region_mean(r: &Rendered, c: usize, keep: impl Fn(u32, u32) -> bool) -> Estimate {
    let (mut sum, mut var, mut n) = (0.0, 0.0, 0.0);
    for y in 0..r.image.height {
        for x in 0..r.image.width {
            if keep(x, y) {
                let i = (y * r.image.width + x) as usize;
                sum += channel(r.image.pixels[i], c);
                var += channel(r.standard_error.pixels[i], c).powi(2);
                n += 1.0;
            }
        }
    }
    assert!(n > 0.0, "empty region");
    Estimate {
        mean: sum / n,
        se: var.sqrt() / n,
    }
}

pub fn image_mean(r: &Rendered, c: usize) -> Estimate {
    region_mean(r, c, |_, _| true)
}

/// `integral f(wo, wi) cos(wi) dwi` over the hemisphere by the midpoint rule on an
/// `n x 2n` (theta, phi) grid, and the change from halving the grid as its error estimate.
pub fn directional_albedo(brdf: &Brdf, wo: Vec3, n: usize) -> (DVec3, f64) {
    let integrate = |n: usize| {
        let (dt, dp) = (PI / 2.0 / n as f64, PI / n as f64);
        let mut sum = DVec3::ZERO;
        for i in 0..n {
            let theta = (i as f64 + 0.5) * dt;
            let (s, c) = theta.sin_cos();
            for j in 0..2 * n {
                let phi = (j as f64 + 0.5) * dp;
                let wi = DVec3::new(s * phi.cos(), s * phi.sin(), c).as_vec3();
                sum += brdf.eval(wo, wi).as_dvec3() * (c * s * dt * dp);
            }
        }
        sum
    };
    let fine = integrate(n);
    let coarse = integrate(n / 2);
    (fine, (fine - coarse).abs().max_element())
}

/// `integral f(wo, wi) cos(wi) dwi` through the BRDF's own lobes: each lobe's primary sample
/// space on an `n x n` midpoint grid, weighted `f cos / pdf` with the mixture pdf, and the
/// lobes mixed by their selection probability. A change of variables that follows the lobes,
/// so it resolves smooth ones the `(theta, phi)` grid of [`directional_albedo`] cannot.
/// Returns the integral and the change from halving the grid (its error estimate).
pub fn lobe_albedo(brdf: &Brdf, wo: Vec3, n: usize) -> (DVec3, f64) {
    let p_specular = f64::from(brdf.specular_probability(wo));
    let integrate = |n: usize| {
        let mut total = DVec3::ZERO;
        for (u_lobe, p) in [
            (p_specular / 2.0, p_specular),
            ((1.0 + p_specular) / 2.0, 1.0 - p_specular),
        ] {
            if p <= 0.0 {
                continue;
            }
            let mut sum = DVec3::ZERO;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new(
                        ((i as f64 + 0.5) / n as f64) as f32,
                        ((j as f64 + 0.5) / n as f64) as f32,
                    );
                    if let Some(s) = brdf.sample(wo, u_lobe as f32, u) {
                        sum += s.f.as_dvec3() * f64::from(s.wi.z) / f64::from(s.pdf);
                    }
                }
            }
            total += sum * (p / (n * n) as f64);
        }
        total
    };
    let fine = integrate(n);
    let coarse = integrate(n / 2);
    (fine, (fine - coarse).abs().max_element())
}

/// Unit direction at polar angle `theta` from +Z in the XZ plane.
pub fn polar(theta: f64) -> Vec3 {
    DVec3::new(theta.sin(), 0.0, theta.cos()).as_vec3()
}

/// Gauss-Legendre nodes and weights on `[0, 1]`.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            // Newton iteration on P_n from Tricomi's initial guess.
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / derivative;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let weight = 2.0 / ((1.0 - x * x) * derivative * derivative);
            (0.5 * (x + 1.0), 0.5 * weight)
        })
        .collect()
}

/// A small scene with every kind of light transport the path tracer handles: a glossy floor,
/// a rough coloured metal wall, a diffuse panel, an area light and a gradient sky.
pub fn showcase() -> Reference {
    let mut builder = SceneBuilder::new(Sky::Gradient {
        zenith: Vec3::new(0.3, 0.4, 0.8),
        horizon: Vec3::new(0.8, 0.8, 0.7),
        ground: Vec3::new(0.2, 0.2, 0.2),
    });
    builder
        .add(
            floor(Vec3::ZERO, 3.0),
            material(Vec3::splat(0.6), 0.0, 0.35),
        )
        .add(
            quad(Vec3::new(0.0, 1.5, -1.5), Vec3::X * 3.0, Vec3::Y * 1.5),
            material(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.3),
        )
        .add(
            quad(
                Vec3::new(0.8, 0.5, 0.0),
                Vec3::new(0.3, 0.0, 0.3),
                Vec3::new(0.0, 0.5, 0.0),
            ),
            diffuse(0.5),
        )
        .add(
            quad(Vec3::new(-0.3, 2.0, -0.2), Vec3::X * 0.4, Vec3::Z * 0.4),
            emitter(Vec3::new(8.0, 7.0, 6.0), false),
        );
    builder.reference(CameraView::look_at(
        Vec3::new(0.0, 1.5, 4.0),
        Vec3::new(0.0, 0.5, 0.0),
        0.9,
    ))
}

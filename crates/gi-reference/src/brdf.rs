//! The product's BRDF and how the reference samples it.
//!
//! All vectors are in the local shading frame: unit length, the shading normal is +Z, `wo`
//! points towards the viewer and `wi` towards the light.
//!
//! # The model: glTF 2.0's metallic-roughness, with its specular and ior extensions
//!
//! The glTF 2.0 specification (Appendix B) defines a material as
//! `mix(dielectric_brdf, metal_brdf, metallic)`, where `metal_brdf` is the GGX specular layer
//! times the conductor Fresnel term (`F0 = base`) and `dielectric_brdf` is `fresnel_mix` of the
//! Lambert base `base / pi` and the same GGX layer. `KHR_materials_specular` and
//! `KHR_materials_ior` give the dielectric's Fresnel term its weight `s` (specular factor x
//! texture alpha) and colour: `F0_d = min(((ior - 1) / (ior + 1))^2 * specular_color, 1)`
//! (0.04 for the defaults, ior 1.5 and white). Both Fresnel terms are Schlick's with
//! `F90 = 1`, so the whole specular layer is one Schlick term with
//!
//! ```text
//! F0  = mix(s * F0_d, base, metallic)        F90 = mix(s, 1, metallic)
//! F(c) = F0 + (F90 - F0) * (1 - c)^5
//! f   = (1 - metallic) * w(wo) * base / pi  +  F(wo.h) * D(h) * G2(wo, wi) / (4 * wi.z * wo.z)
//! D   = alpha^2 / (pi * ((h.z)^2 * (alpha^2 - 1) + 1)^2)                          (GGX)
//! G2  = 1 / (1 + Lambda(wo) + Lambda(wi))                    (height-correlated Smith)
//! alpha = max(roughness^2, MIN_ALPHA)
//! ```
//!
//! # The Fresnel weighting of the diffuse base, and why this form
//!
//! The specification's `fresnel_mix` weights the base by `1 - s * max(F_d(wo.h))`, with the
//! Fresnel term of each pair of directions. That is a pointwise stand-in for "what the
//! specular layer does not reflect", and integrated over the hemisphere it does not conserve
//! energy: a white dielectric of roughness 0.3 seen at `n.v` 0.1 reflects 1.28 times the light
//! it receives (1.34 at `n.v` 0.03), because at grazing views the specular layer's Fresnel
//! term is near 1 only for the few directions near the mirror one while the base keeps most of
//! its weight everywhere else. The product measures every tier against this BRDF, so it must
//! never create light. We therefore use the energy-conserving form of the same mix, *albedo
//! scaling* (as OpenPBR and Autodesk Standard Surface layer a dielectric coat, and as glTF's
//! own `KHR_materials_sheen` layers its sheen): the base is weighted by what the dielectric
//! layer does not reflect in total from `wo`,
//!
//! ```text
//! w(wo) = 1 - s * max_rgb(E_d(wo.z)),   E_d = F0_d * A(wo.z, alpha) + B(wo.z, alpha),
//! ```
//!
//! where `E_d` is the directional albedo of the unweighted dielectric layer and `A`, `B` the
//! albedos of the GGX lobe with the Fresnel weights `1 - (1 - wo.h)^5` and `(1 - wo.h)^5`
//! ([`specular_albedo`]). The total directional albedo is then
//! `(1 - metallic) * (base * w + s * E_d) + metallic * E_m <= 1` for every base color up to
//! white. `A + B` and `B / (A + B)` are fitted polynomials, each shifted up by its largest
//! deficit against the quadrature; the layer's albedo grows with both, so the fit never
//! under-states it and the bound holds for the fit too.
//! For `s = 0` the material is exactly Lambert with albedo `base`; at normal incidence
//! and the default `F0_d` the two forms differ by at most 2.5% of a white base's albedo
//! (roughness 1: 0.972 pointwise, 0.997 here). The weight depends on `wo` only, so the BRDF
//! is not reciprocal; a unidirectional path tracer never needs it to be.
//!
//! There is no multiple-scattering compensation: like the specification's layer, the GGX lobe
//! loses the energy its microfacets shadow (a white metal of roughness 1 reflects 0.31 of the
//! light at normal incidence, 0.76 at `n.v` 0.1).

use std::f32::consts::PI;

use glam::{Vec2, Vec3, Vec4};

use crate::sampling::cosine_hemisphere;

mod albedo_fit;

/// Smallest GGX alpha. Perceptual roughness 0 would make `D` a Dirac delta that neither
/// next-event estimation nor the MIS weights can handle; clamping keeps mirrors finite (a
/// lobe about 0.06 degrees wide) at a visually and numerically negligible cost in sharpness.
pub const MIN_ALPHA: f32 = 1e-3;

/// Index of refraction of a glTF dielectric without `KHR_materials_ior`.
pub const DEFAULT_IOR: f32 = 1.5;

/// Lowest and highest probability of sampling the specular lobe when neither lobe is black:
/// neither lobe is ever starved, which bounds the weight of either technique.
const SPECULAR_PICK_RANGE: (f32, f32) = (0.1, 0.9);

/// Rec. 709 relative luminance: the product's scalar measure of color (lobe selection,
/// emitter power; Russian roulette uses the max component instead).
pub use gi_scene::luminance;

/// The dielectric's specular layer (`KHR_materials_specular`, `KHR_materials_ior`): its
/// weight and its Fresnel reflectance at normal incidence before the weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricSpecular {
    /// `s`: specular factor x specular texture alpha, in `[0, 1]`. 0 makes the dielectric a
    /// pure Lambert surface.
    pub weight: f32,
    /// `F0_d = min(((ior - 1) / (ior + 1))^2 * specular_color, 1)`, in `[0, 1]`: the Fresnel
    /// reflectance at normal incidence before the weight.
    pub reflectance: Vec3,
}

impl Default for DielectricSpecular {
    /// glTF's dielectric without the extensions: weight 1, ior 1.5, white (`F0_d` 0.04).
    fn default() -> Self {
        Self::new(1.0, Vec3::ONE, DEFAULT_IOR)
    }
}

impl DielectricSpecular {
    /// The layer of `material` (`KHR_materials_specular`, `KHR_materials_ior`): its factors
    /// times its textures, which `sample` reads (white where the material has none), as every
    /// tier reads them (`gi::scene::dielectric_specular` on the GPU).
    pub fn of_material(
        material: &gi_scene::Material,
        sample: impl Fn(Option<gi_scene::TextureRef>) -> Vec4,
    ) -> Self {
        let weight = material.specular * sample(material.specular_texture).w;
        let color = material.specular_color * sample(material.specular_color_texture).truncate();
        Self::new(weight, color, material.ior)
    }

    /// From the extensions' values: `weight` (specular factor x texture alpha), the specular
    /// color (factor x texture rgb, linear) and the index of refraction. Out-of-range values are
    /// clamped (weight to `[0, 1]`, color to at least 0, `F0_d` to at most 1); ior 0, which
    /// `KHR_materials_ior` allows, gives `F0_d` = color as the formula does.
    pub fn new(weight: f32, color: Vec3, ior: f32) -> Self {
        let r = (ior - 1.0) / (ior + 1.0);
        let f0 = (r * r * color.max(Vec3::ZERO)).min(Vec3::ONE);
        Self {
            weight: weight.clamp(0.0, 1.0),
            reflectance: if f0.is_finite() { f0 } else { Vec3::ZERO },
        }
    }
}

/// The BRDF at one surface point, after textures were applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brdf {
    /// Linear base color, in `[0, 1]`.
    pub base: Vec3,
    /// In `[0, 1]`.
    pub metallic: f32,
    /// GGX alpha, at least [`MIN_ALPHA`].
    pub alpha: f32,
    /// The dielectric's specular layer.
    pub specular: DielectricSpecular,
}

/// A direction drawn by [`Brdf::sample`] with the BRDF value and the mixture pdf there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    /// Solid-angle pdf of the whole mixture (not of the lobe that happened to be picked), so MIS
    /// weights are right whichever lobe produced the direction.
    pub pdf: f32,
}

impl Brdf {
    /// From glTF parameters with the default dielectric layer (no specular or ior extension):
    /// metallic and perceptual roughness are clamped to `[0, 1]` and
    /// `alpha = max(roughness^2, MIN_ALPHA)`.
    pub fn new(base: Vec3, metallic: f32, roughness: f32) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        Self {
            base,
            metallic: metallic.clamp(0.0, 1.0),
            alpha: (roughness * roughness).max(MIN_ALPHA),
            specular: DielectricSpecular::default(),
        }
    }

    /// This BRDF with the dielectric layer `specular`.
    pub fn with_specular(self, specular: DielectricSpecular) -> Self {
        Self { specular, ..self }
    }

    /// Fresnel reflectance of the whole specular layer at normal incidence,
    /// `mix(s * F0_d, base, metallic)`.
    pub fn f0(&self) -> Vec3 {
        (self.specular.reflectance * self.specular.weight).lerp(self.base, self.metallic)
    }

    /// Fresnel reflectance of the whole specular layer at grazing incidence,
    /// `mix(s, 1, metallic)`.
    pub fn f90(&self) -> f32 {
        self.specular.weight + (1.0 - self.specular.weight) * self.metallic
    }

    /// Weight `w(wo)` of the Lambert base: the share of light the dielectric's specular layer
    /// does not reflect from `n_dot_v = wo.z` (the module docs).
    pub fn diffuse_weight(&self, n_dot_v: f32) -> f32 {
        if self.specular.weight <= 0.0 {
            return 1.0;
        }
        let [a, b] = albedo_terms(self.alpha.sqrt(), n_dot_v);
        1.0 - self.specular.weight * (self.specular.reflectance.max_element() * a + b).min(1.0)
    }

    /// Albedo of the Lambert lobe seen from `n_dot_v`: `base * (1 - metallic) * w(wo)`.
    pub fn diffuse_albedo(&self, n_dot_v: f32) -> Vec3 {
        self.base * ((1.0 - self.metallic) * self.diffuse_weight(n_dot_v))
    }

    /// This BRDF seen from `wo`, with what depends on `wo` alone computed once: what a path
    /// vertex evaluates, samples and takes pdfs of several times.
    pub fn seen_from(&self, wo: Vec3) -> ViewedBrdf {
        let f0 = self.f0();
        let f90 = self.f90();
        let diffuse_albedo = self.diffuse_albedo(wo.z);
        // specular_probability, spelt out so its Fresnel term and albedo are shared.
        let specular = luminance(schlick(f0, f90, wo.z));
        let p_specular = if specular <= 0.0 {
            0.0
        } else {
            let diffuse = luminance(diffuse_albedo);
            if diffuse <= 0.0 {
                1.0
            } else {
                (specular / (specular + diffuse))
                    .clamp(SPECULAR_PICK_RANGE.0, SPECULAR_PICK_RANGE.1)
            }
        };
        ViewedBrdf {
            wo,
            alpha: self.alpha,
            a2: self.alpha * self.alpha,
            f0,
            f90,
            // Schlick's term is exactly zero for these, and so is the whole specular layer.
            specular_layer: f0 != Vec3::ZERO || f90 != 0.0,
            diffuse: diffuse_albedo / PI,
            p_specular,
        }
    }

    /// The BRDF value; zero unless both directions are above the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.seen_from(wo).eval(wi)
    }

    /// Probability that [`Brdf::sample`] picks the specular lobe for `wo`: the luminance of the
    /// Fresnel reflectance at `wo` against that of the diffuse albedo, kept within
    /// `[0.1, 0.9]` unless a lobe is black (metals always sample specular, a dielectric
    /// without specular layer never does).
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        self.seen_from(wo).p_specular
    }

    /// Solid-angle pdf of [`Brdf::sample`] producing `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.seen_from(wo).pdf(wi)
    }

    /// Picks a lobe with `u_lobe`, then draws a cosine-weighted direction (diffuse) or a GGX
    /// visible normal (Heitz 2018) reflected about it (specular). `None` when the direction
    /// falls below the surface (a sample with zero contribution).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        self.seen_from(wo).sample(u_lobe, u)
    }
}

/// A [`Brdf`] with its outgoing direction `wo` fixed ([`Brdf::seen_from`]): its Fresnel
/// terms, diffuse albedo and lobe probability computed once. Evaluates, samples and takes pdfs
/// exactly as the `Brdf` methods with that `wo` do (they are written on top of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewedBrdf {
    wo: Vec3,
    alpha: f32,
    a2: f32,
    f0: Vec3,
    f90: f32,
    /// False when Schlick's term is zero for every angle (`F0 = 0`, `F90 = 0`: a dielectric
    /// without specular layer), so the specular lobe adds exactly nothing and is skipped.
    specular_layer: bool,
    /// The Lambert lobe's value, `diffuse albedo(wo) / pi`.
    diffuse: Vec3,
    /// Probability of sampling the specular lobe ([`Brdf::specular_probability`]).
    p_specular: f32,
}

impl ViewedBrdf {
    /// The outgoing direction it is seen from.
    pub fn wo(&self) -> Vec3 {
        self.wo
    }

    /// The BRDF value towards `wi`; zero unless both directions are above the surface.
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let wo = self.wo;
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        if !self.specular_layer {
            // diffuse + 0 * (a finite specular value): both directions are above the surface,
            // so D, G2 and the cosines are finite and positive.
            return self.diffuse;
        }
        let h = (wo + wi).normalize();
        let specular = ggx_d(h, self.a2) * smith_g2(wo.z, wi.z, self.a2) / (4.0 * wo.z * wi.z);
        self.diffuse + schlick(self.f0, self.f90, wo.dot(h)) * specular
    }

    /// Solid-angle pdf of [`ViewedBrdf::sample`] producing `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_specular = self.p_specular;
        let diffuse = (1.0 - p_specular) * wi.z / PI;
        if p_specular <= 0.0 {
            return diffuse;
        }
        p_specular * self.specular_pdf(wi) + diffuse
    }

    /// [`Brdf::sample`] at this `wo`.
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        let wo = self.wo;
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.p_specular {
            let h = sample_ggx_vndf(wo, self.alpha, u);
            2.0 * wo.dot(h) * h - wo
        } else {
            cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then(|| BrdfSample {
            wi,
            f: self.eval(wi),
            pdf,
        })
    }

    /// pdf of the reflected VNDF sample: `G1(wo) * D(h) / (4 * wo.z)`.
    fn specular_pdf(&self, wi: Vec3) -> f32 {
        let wo = self.wo;
        let h = (wo + wi).normalize();
        smith_g1(wo.z, self.a2) * ggx_d(h, self.a2) / (4.0 * wo.z)
    }
}

/// Directional albedo of the specular layer alone, `integral f_spec(wo, wi) cos(wi) dwi`, for
/// Schlick's Fresnel term with reflectance `f0` at normal and `f90` at grazing incidence,
/// perceptual `roughness` and `n_dot_v = wo.z`: `f0 * A + f90 * B` (the module docs). What the
/// split-sum approximation multiplies a pre-integrated incident radiance by (the tiers that
/// reflect their irradiance or a filtered reflection off the specular lobe), and what weighs
/// the Lambert base.
///
/// `A + B` and `B / (A + B)` are Chebyshev series fitted to a quadrature of the lobe
/// (`benchmarks/brdf/fit_albedo.py` integrates, fits and writes them, for this crate and for
/// `gi::brdf_albedo`, which computes the same numbers on the GPU). Each series is shifted up by
/// its largest deficit against the quadrature, so the result never under-states the layer's
/// albedo; it over-states a dielectric's by 0.003 on average and at most 0.008 (the script prints both).
pub fn specular_albedo(f0: Vec3, f90: f32, roughness: f32, n_dot_v: f32) -> Vec3 {
    let alpha = (roughness.clamp(0.0, 1.0).powi(2)).max(MIN_ALPHA);
    let [a, b] = albedo_terms(alpha.sqrt(), n_dot_v);
    (f0 * a + Vec3::splat(f90 * b)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// `[A, B]` of [`specular_albedo`] at `sqrt(alpha)` (at least `sqrt(MIN_ALPHA)`) and
/// `n_dot_v`.
fn albedo_terms(sqrt_alpha: f32, n_dot_v: f32) -> [f32; 2] {
    let sqrt_alpha = sqrt_alpha.clamp(MIN_ALPHA.sqrt(), 1.0);
    let alpha = sqrt_alpha * sqrt_alpha;
    let mu = n_dot_v.clamp(0.0, 1.0);
    let s = 2.0 * sqrt_alpha - 1.0;
    let m = chebyshev_series(&albedo_fit::M, 1.0 - 2.0 * (mu / (mu + alpha)), s).clamp(0.0, 1.0);
    let r = chebyshev_series(&albedo_fit::R, 1.0 - 2.0 * mu.sqrt().sqrt(), s).clamp(0.0, 1.0);
    [m * (1.0 - r), m * r]
}

/// `sum_i T_i(s) sum_j c[i][j] T_j(u)`, summed in the order `gi::brdf_albedo` sums it.
fn chebyshev_series(c: &[&[f32]], u: f32, s: f32) -> f32 {
    let tu = chebyshev(u, c.len());
    let ts = chebyshev(s, c.len());
    c.iter()
        .zip(ts)
        .map(|(row, ts)| ts * row.iter().zip(&tu).map(|(c, tu)| c * tu).sum::<f32>())
        .sum()
}

/// Chebyshev polynomials `T_0 .. T_{n-1}` at `t` (`n` at most 16).
fn chebyshev(t: f32, n: usize) -> [f32; 16] {
    let mut c = [0.0; 16];
    c[0] = 1.0;
    c[1] = t;
    for k in 2..n {
        c[k] = 2.0 * t * c[k - 1] - c[k - 2];
    }
    c
}

/// GGX normal distribution, normalized so that `integral D(h) h.z dh = 1`. The usual
/// denominator `cos^2 (a2 - 1) + 1` is computed as `sin^2 + a2 cos^2`: the former cancels
/// catastrophically in f32 near the peak of smooth lobes (6% error at `MIN_ALPHA`).
fn ggx_d(h: Vec3, a2: f32) -> f32 {
    let d = (h.x * h.x + h.y * h.y) + a2 * h.z * h.z;
    a2 / (PI * d * d)
}

/// `sqrt(a2 + (1 - a2) cos^2)`; Smith's `Lambda(w) = (s / cos - 1) / 2` for GGX.
fn smith_s(cos: f32, a2: f32) -> f32 {
    (a2 + (1.0 - a2) * cos * cos).sqrt()
}

/// Height-correlated masking-shadowing `1 / (1 + Lambda(wo) + Lambda(wi))`, written without
/// the divisions by the cosines so it stays finite at grazing angles.
fn smith_g2(cos_o: f32, cos_i: f32, a2: f32) -> f32 {
    2.0 * cos_o * cos_i / (smith_s(cos_o, a2) * cos_i + smith_s(cos_i, a2) * cos_o)
}

/// Masking of one direction, `1 / (1 + Lambda(w))`.
fn smith_g1(cos: f32, a2: f32) -> f32 {
    2.0 * cos / (cos + smith_s(cos, a2))
}

/// Schlick's Fresnel term from `f0` at normal to `f90` at grazing incidence.
fn schlick(f0: Vec3, f90: f32, cos: f32) -> Vec3 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::splat(f90) - f0) * m
}
/// A GGX microfacet normal visible from `wo`, distributed as `G1(wo) max(0, wo.h) D(h) / wo.z`
/// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
fn sample_ggx_vndf(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    // Stretch to the hemisphere configuration (alpha = 1).
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let len_sq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len_sq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / len_sq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    // Uniform point on the disk, squeezed onto the visible half-disk plus its projection.
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Unstretch back to the ellipsoid configuration.
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

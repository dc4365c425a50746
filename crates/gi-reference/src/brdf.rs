//! The product's BRDF and how the reference samples it.
//!
//! All vectors are in the local shading frame: unit length, the shading normal is +Z, `wo`
//! points towards the viewer and `wi` towards the light. The BRDF is glTF metallic-roughness:
//!
//! ```text
//! f = base * (1 - metallic) / pi  +  D(h) * G2(wo, wi) * F(wo.h) / (4 * wi.z * wo.z)
//! D  = alpha^2 / (pi * ((h.z)^2 * (alpha^2 - 1) + 1)^2)                       (GGX)
//! G2 = 1 / (1 + Lambda(wo) + Lambda(wi))                 (height-correlated Smith)
//! F  = F0 + (1 - F0) * (1 - wo.h)^5,   F0 = mix(0.04, base, metallic)          (Schlick)
//! alpha = max(roughness^2, MIN_ALPHA)
//! ```
//!
//! There is no energy coupling between the lobes beyond that formula (the diffuse lobe is not
//! scaled by `1 - F`), so a dielectric's total albedo is its diffuse albedo plus the GGX lobe's.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::sampling::cosine_hemisphere;

/// Smallest GGX alpha. Perceptual roughness 0 would make `D` a Dirac delta that neither
/// next-event estimation nor the MIS weights can handle; clamping keeps mirrors finite (a
/// lobe about 0.06 degrees wide) at a visually and numerically negligible cost in sharpness.
pub const MIN_ALPHA: f32 = 1e-3;

/// Lowest and highest probability of sampling the specular lobe when the diffuse lobe is not
/// black: neither lobe is ever starved, which bounds the weight of either technique.
const SPECULAR_PICK_RANGE: (f32, f32) = (0.1, 0.9);

/// Rec. 709 relative luminance: the product's scalar measure of color (lobe selection,
/// emitter power; Russian roulette uses the max component instead).
pub use gi_scene::luminance;

/// The BRDF at one surface point, after textures were applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brdf {
    /// Linear base color.
    pub base: Vec3,
    /// In `[0, 1]`.
    pub metallic: f32,
    /// GGX alpha, at least [`MIN_ALPHA`].
    pub alpha: f32,
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
    /// From glTF parameters: metallic and perceptual roughness are clamped to `[0, 1]` and
    /// `alpha = max(roughness^2, MIN_ALPHA)`.
    pub fn new(base: Vec3, metallic: f32, roughness: f32) -> Self {
        let roughness = roughness.clamp(0.0, 1.0);
        Self {
            base,
            metallic: metallic.clamp(0.0, 1.0),
            alpha: (roughness * roughness).max(MIN_ALPHA),
        }
    }

    /// Albedo of the Lambert lobe, `base * (1 - metallic)`.
    pub fn diffuse_albedo(&self) -> Vec3 {
        self.base * (1.0 - self.metallic)
    }

    /// Fresnel reflectance at normal incidence.
    pub fn f0(&self) -> Vec3 {
        Vec3::splat(0.04).lerp(self.base, self.metallic)
    }

    /// The BRDF value; zero unless both directions are above the surface.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let a2 = self.alpha * self.alpha;
        let specular = ggx_d(h, a2) * smith_g2(wo.z, wi.z, a2) / (4.0 * wo.z * wi.z);
        self.diffuse_albedo() / PI + schlick(self.f0(), wo.dot(h)) * specular
    }

    /// Probability that [`Brdf::sample`] picks the specular lobe for `wo`: the luminance of the
    /// Fresnel reflectance at `wo` against that of the diffuse albedo, kept within
    /// `[0.1, 0.9]` unless the diffuse lobe is black (metals always sample specular).
    pub fn specular_probability(&self, wo: Vec3) -> f32 {
        let diffuse = luminance(self.diffuse_albedo());
        if diffuse <= 0.0 {
            return 1.0;
        }
        let specular = luminance(schlick(self.f0(), wo.z));
        (specular / (specular + diffuse)).clamp(SPECULAR_PICK_RANGE.0, SPECULAR_PICK_RANGE.1)
    }

    /// Solid-angle pdf of [`Brdf::sample`] producing `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_specular = self.specular_probability(wo);
        p_specular * self.specular_pdf(wo, wi) + (1.0 - p_specular) * wi.z / PI
    }

    /// Picks a lobe with `u_lobe`, then draws a cosine-weighted direction (diffuse) or a GGX
    /// visible normal (Heitz 2018) reflected about it (specular). `None` when the direction
    /// falls below the surface (a sample with zero contribution).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.specular_probability(wo) {
            let h = sample_ggx_vndf(wo, self.alpha, u);
            2.0 * wo.dot(h) * h - wo
        } else {
            cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0 && pdf.is_finite()).then(|| BrdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
        })
    }

    /// pdf of the reflected VNDF sample: `G1(wo) * D(h) / (4 * wo.z)`.
    fn specular_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize();
        let a2 = self.alpha * self.alpha;
        smith_g1(wo.z, a2) * ggx_d(h, a2) / (4.0 * wo.z)
    }
}

/// Directional albedo of the specular lobe alone, `integral f_spec(wo, wi) cos(wi) dwi`, for
/// Fresnel reflectance `f0` at normal incidence, perceptual `roughness` and `n_dot_v = wo.z`:
/// what the split-sum approximation multiplies a pre-integrated incident radiance by (the
/// tiers that reflect their irradiance or a filtered reflection off the specular lobe). Not
/// used by the reference itself, which samples the lobe.
///
/// Schlick's Fresnel makes the albedo `f0 * scale + bias`; `scale` and `bias` are weighted
/// least-squares fits of this BRDF's lobe (GGX, height-correlated Smith, Schlick), integrated
/// by stratified visible-normal sampling on a 34 x 33 grid of `sqrt(n_dot_v)` and roughness,
/// as bivariate Chebyshev series of total degree 7 in `1 - 2 sqrt(n_dot_v)` and `2 roughness -
/// 1`. The weights are the relative errors of a dielectric's albedo (`f0` 0.04) for `bias`
/// and of a white metal's for `scale`. Against the quadrature on a 24 x 25 grid: a dielectric
/// is within 7% (1% rms) for roughness 0.6 and above, 6% (2% rms) between 0.3 and 0.6 and 8%
/// (4% rms) below; a metal within 0.017 absolute above roughness 0.3 and 0.05 below, worst
/// at grazing angles. Karis's analytic fit ("Physically Based Shading on Mobile", 2014), fit
/// to a different masking term, was off by up to 0.43 for metals and gave a rough dielectric
/// the same albedo at every angle (0.016 where this lobe reflects 0.012 at normal incidence
/// and 0.054 at `n_dot_v` 0.1). `gi::brdf::specular_albedo` computes the same numbers.
pub fn specular_albedo(f0: Vec3, roughness: f32, n_dot_v: f32) -> Vec3 {
    let s = chebyshev(2.0 * roughness.clamp(0.0, 1.0) - 1.0);
    let u = chebyshev(1.0 - 2.0 * n_dot_v.clamp(0.0, 1.0).sqrt());
    let series = |c: &[[f32; 8]; 8]| -> f32 {
        (0..8)
            .map(|i| s[i] * (0..8).map(|j| c[i][j] * u[j]).sum::<f32>())
            .sum::<f32>()
            .max(0.0)
    };
    (f0 * series(&SPLIT_SUM_SCALE) + Vec3::splat(series(&SPLIT_SUM_BIAS)))
        .clamp(Vec3::ZERO, Vec3::ONE)
}

/// Chebyshev polynomials `T_0 .. T_7` at `t`.
fn chebyshev(t: f32) -> [f32; 8] {
    let mut c = [1.0, t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for k in 2..8 {
        c[k] = 2.0 * t * c[k - 1] - c[k - 2];
    }
    c
}

/// Coefficients of [`specular_albedo`]'s series: row `i` multiplies `T_i` of the roughness,
/// column `j` `T_j` of the angle (zero where `i + j > 7`).
#[rustfmt::skip]
const SPLIT_SUM_SCALE: [[f32; 8]; 8] = [
    [0.695826, -0.0939191, -0.007253255, 0.03258678, 0.01138073, -0.004810217, -0.00235433, 0.0001578477],
    [0.02037893, 0.4753757, 0.06656231, -0.0568239, -0.02645664, 0.005105534, 0.004106875, 0.0],
    [-0.1091826, -0.02628074, -0.0485239, 0.008506081, 0.02066753, 0.005070956, 0.0, 0.0],
    [0.001745045, -0.002336864, 0.0214149, 0.02595344, 0.001481546, 0.0, 0.0, 0.0],
    [0.02069847, 0.01085124, 0.01299602, -0.008473429, 0.0, 0.0, 0.0, 0.0],
    [-0.006833719, -0.009815245, -0.006416843, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0005364465, 0.002162264, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-0.0001088997, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
];
#[rustfmt::skip]
const SPLIT_SUM_BIAS: [[f32; 8]; 8] = [
    [0.1601111, 0.2110313, 0.03034847, -0.03569983, -0.01428187, 0.002558735, 0.001204421, -0.0001726828],
    [-0.1968825, -0.2640488, -0.04160867, 0.04679883, 0.02027525, -0.004149094, -0.002310157, 0.0],
    [0.05821342, 0.08562985, 0.02282378, -0.01480777, -0.01285597, -0.00146033, 0.0, 0.0],
    [0.003291604, -0.001142065, -0.009141448, -0.004767473, 0.001280627, 0.0, 0.0, 0.0],
    [-0.01234614, -0.01677431, -0.003219636, 0.002357659, 0.0, 0.0, 0.0, 0.0],
    [0.004489176, 0.007124086, 0.003201276, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0004320694, 0.0005474531, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.38812e-5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
];

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

fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::ONE - f0) * m
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

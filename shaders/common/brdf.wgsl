// The product's BRDF and how the reference samples it, ported operation for operation from the
// CPU reference's `brdf` module so GPU and CPU agree to f32 rounding.
//
// glTF 2.0 metallic-roughness (Khronos, glTF 2.0 specification, appendix B): Lambert
// `base (1 - metallic) / pi` plus a GGX microfacet lobe (Walter et al. 2007, "Microfacet Models
// for Refraction through Rough Surfaces") with height-correlated Smith masking-shadowing
// (Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs") and
// Schlick's Fresnel (Schlick 1994), `F0 = mix(0.04, base, metallic)`,
// `alpha = max(roughness^2, MIN_ALPHA)`. The specular lobe is sampled through visible normals
// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)), the diffuse lobe
// with a cosine-weighted direction; every pdf is the whole mixture's.
//
// All vectors are in the local shading frame: unit length, the shading normal is +Z, `wo`
// points towards the viewer and `wi` towards the light.
#define_import_path gi::brdf

#import gi::math::{PI, luminance}
#import gi::sampling::cosine_hemisphere

// Smallest GGX alpha. Perceptual roughness 0 would make `D` a Dirac delta that neither
// next-event estimation nor MIS weights can handle; clamping keeps mirrors finite (a lobe
// about 0.06 degrees wide) at a negligible cost in sharpness. The reference's `MIN_ALPHA`.
const MIN_ALPHA: f32 = 1e-3;

// Lowest and highest probability of sampling the specular lobe when the diffuse lobe is not
// black: neither lobe is ever starved, which bounds the weight of either technique.
const SPECULAR_PICK_MIN: f32 = 0.1;
const SPECULAR_PICK_MAX: f32 = 0.9;

// The BRDF at one surface point, after textures were applied.
struct Brdf {
    // Linear base color.
    base: vec3<f32>,
    // In [0, 1].
    metallic: f32,
    // GGX alpha, at least MIN_ALPHA.
    alpha: f32,
}

// A direction drawn by `brdf_sample` with the BRDF value and the mixture pdf there.
struct BrdfSample {
    wi: vec3<f32>,
    f: vec3<f32>,
    // Solid-angle pdf of the whole mixture, so MIS weights are right whichever lobe produced
    // the direction.
    pdf: f32,
    // False when the direction fell below the surface or its pdf is not a positive finite
    // number: a sample with zero contribution (the reference returns `None`).
    valid: bool,
}

// From glTF parameters: metallic and perceptual roughness are clamped to [0, 1] and
// `alpha = max(roughness^2, MIN_ALPHA)`.
fn brdf_new(base: vec3<f32>, metallic: f32, roughness: f32) -> Brdf {
    let r = clamp(roughness, 0.0, 1.0);
    return Brdf(base, clamp(metallic, 0.0, 1.0), max(r * r, MIN_ALPHA));
}

// Albedo of the Lambert lobe, `base * (1 - metallic)`.
fn brdf_diffuse_albedo(brdf: Brdf) -> vec3<f32> {
    return brdf.base * (1.0 - brdf.metallic);
}

// Fresnel reflectance at normal incidence, `mix(0.04, base, metallic)` written out in the
// reference's order of operations.
fn brdf_f0(brdf: Brdf) -> vec3<f32> {
    return vec3<f32>(0.04) * (1.0 - brdf.metallic) + brdf.base * brdf.metallic;
}

// `v / |v|` as the reference computes it (a reciprocal of the square root, then a product),
// rather than `normalize`, whose implementation may round differently.
fn normalize_like_reference(v: vec3<f32>) -> vec3<f32> {
    return v * (1.0 / sqrt(v.x * v.x + v.y * v.y + v.z * v.z));
}

// GGX normal distribution, normalized so that `integral D(h) h.z dh = 1`. The usual
// denominator `cos^2 (a2 - 1) + 1` is computed as `sin^2 + a2 cos^2`: the former cancels
// catastrophically in f32 near the peak of smooth lobes.
fn ggx_d(h: vec3<f32>, a2: f32) -> f32 {
    let d = (h.x * h.x + h.y * h.y) + a2 * h.z * h.z;
    return a2 / (PI * d * d);
}

// `sqrt(a2 + (1 - a2) cos^2)`; Smith's `Lambda(w) = (s / cos - 1) / 2` for GGX.
fn smith_s(cos_theta: f32, a2: f32) -> f32 {
    return sqrt(a2 + (1.0 - a2) * cos_theta * cos_theta);
}

// Height-correlated masking-shadowing `1 / (1 + Lambda(wo) + Lambda(wi))`, written without the
// divisions by the cosines so it stays finite at grazing angles.
fn smith_g2(cos_o: f32, cos_i: f32, a2: f32) -> f32 {
    return 2.0 * cos_o * cos_i / (smith_s(cos_o, a2) * cos_i + smith_s(cos_i, a2) * cos_o);
}

// Masking of one direction, `1 / (1 + Lambda(w))`.
fn smith_g1(cos_theta: f32, a2: f32) -> f32 {
    return 2.0 * cos_theta / (cos_theta + smith_s(cos_theta, a2));
}

// Schlick's Fresnel; `(1 - cos)^5` multiplied out as the reference's `powi(5)` does.
fn schlick(f0: vec3<f32>, cos_theta: f32) -> vec3<f32> {
    let x = 1.0 - clamp(cos_theta, 0.0, 1.0);
    let x2 = x * x;
    let m = x * (x2 * x2);
    return f0 + (vec3<f32>(1.0) - f0) * m;
}

// The GGX specular lobe without Fresnel, `D G2 / (4 cos_o cos_i)`, for half vector `h` and
// the cosines of both directions (both positive).
fn ggx_lobe(h: vec3<f32>, cos_o: f32, cos_i: f32, a2: f32) -> f32 {
    return ggx_d(h, a2) * smith_g2(cos_o, cos_i, a2) / (4.0 * cos_o * cos_i);
}

// The BRDF value; zero unless both directions are above the surface.
fn brdf_eval(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize_like_reference(wo + wi);
    let a2 = brdf.alpha * brdf.alpha;
    let specular = ggx_lobe(h, wo.z, wi.z, a2);
    return brdf_diffuse_albedo(brdf) / PI + schlick(brdf_f0(brdf), dot(wo, h)) * specular;
}

// Probability that `brdf_sample` picks the specular lobe for `wo`: the luminance of the Fresnel
// reflectance at `wo` against that of the diffuse albedo, kept within [0.1, 0.9] unless the
// diffuse lobe is black (metals always sample specular).
fn brdf_specular_probability(brdf: Brdf, wo: vec3<f32>) -> f32 {
    let diffuse = luminance(brdf_diffuse_albedo(brdf));
    if diffuse <= 0.0 {
        return 1.0;
    }
    let specular = luminance(schlick(brdf_f0(brdf), wo.z));
    return clamp(specular / (specular + diffuse), SPECULAR_PICK_MIN, SPECULAR_PICK_MAX);
}

// pdf of the reflected visible-normal sample: `G1(wo) * D(h) / (4 * wo.z)`.
fn brdf_specular_pdf(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let h = normalize_like_reference(wo + wi);
    let a2 = brdf.alpha * brdf.alpha;
    return smith_g1(wo.z, a2) * ggx_d(h, a2) / (4.0 * wo.z);
}

// Solid-angle pdf of `brdf_sample` producing `wi`.
fn brdf_pdf(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let p_specular = brdf_specular_probability(brdf, wo);
    return p_specular * brdf_specular_pdf(brdf, wo, wi) + (1.0 - p_specular) * wi.z / PI;
}

// A GGX microfacet normal visible from `wo`, distributed as `G1(wo) max(0, wo.h) D(h) / wo.z`
// (Heitz 2018, listing 1).
fn sample_ggx_vndf(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    // Stretch to the hemisphere configuration (alpha = 1).
    let vh = normalize_like_reference(vec3<f32>(alpha * wo.x, alpha * wo.y, wo.z));
    let len_sq = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if len_sq > 0.0 {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(len_sq);
    }
    let t2 = cross(vh, t1);
    // Uniform point on the disk, squeezed onto the visible half-disk plus its projection.
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    // Unstretch back to the ellipsoid configuration.
    return normalize_like_reference(vec3<f32>(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
}

// Whether `x` is neither infinite nor NaN, read from its exponent bits: WGSL has no `isinf`, and
// compilers may assume floating-point comparisons never see NaN.
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// Picks a lobe with `u_lobe`, then draws a cosine-weighted direction (diffuse) or a GGX
// visible normal reflected about it (specular), consuming the same random numbers as the
// reference. Invalid when the direction falls below the surface.
fn brdf_sample(brdf: Brdf, wo: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> BrdfSample {
    var bs = BrdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    if wo.z <= 0.0 {
        return bs;
    }
    if u_lobe < brdf_specular_probability(brdf, wo) {
        let h = sample_ggx_vndf(wo, brdf.alpha, u);
        bs.wi = 2.0 * dot(wo, h) * h - wo;
    } else {
        bs.wi = cosine_hemisphere(u);
    }
    if bs.wi.z <= 0.0 {
        return bs;
    }
    bs.pdf = brdf_pdf(brdf, wo, bs.wi);
    bs.valid = bs.pdf > 0.0 && is_finite(bs.pdf);
    if bs.valid {
        bs.f = brdf_eval(brdf, wo, bs.wi);
    }
    return bs;
}

// Not part of the reference's BRDF: for tiers that reflect a pre-integrated irradiance off
// the specular lobe (split-sum), the lobe's directional albedo, `f0 * scale + bias`, with
// `scale` and `bias` fitted to this BRDF's lobe as Chebyshev series of total degree 7 in
// `1 - 2 sqrt(n_dot_v)` and `2 roughness - 1`. The same numbers as
// `gi_reference::brdf::specular_albedo`, whose documentation gives the fit and its accuracy.
fn specular_albedo(f0: vec3<f32>, roughness: f32, n_dot_v: f32) -> vec3<f32> {
    let s = chebyshev8(2.0 * clamp(roughness, 0.0, 1.0) - 1.0);
    let u = chebyshev8(1.0 - 2.0 * sqrt(clamp(n_dot_v, 0.0, 1.0)));
    let scale = max(chebyshev_series(SPLIT_SUM_SCALE, s, u), 0.0);
    let bias = max(chebyshev_series(SPLIT_SUM_BIAS, s, u), 0.0);
    return clamp(f0 * scale + bias, vec3(0.0), vec3(1.0));
}

// Chebyshev polynomials T_0 .. T_3 (column 0) and T_4 .. T_7 (column 1) at `t`.
fn chebyshev8(t: f32) -> mat2x4<f32> {
    let t2 = 2.0 * t * t - 1.0;
    let t3 = 2.0 * t * t2 - t;
    let t4 = 2.0 * t * t3 - t2;
    let t5 = 2.0 * t * t4 - t3;
    let t6 = 2.0 * t * t5 - t4;
    let t7 = 2.0 * t * t6 - t5;
    return mat2x4<f32>(vec4(1.0, t, t2, t3), vec4(t4, t5, t6, t7));
}

// sum over i, j of c_ij T_i(s) T_j(u), the 8 x 8 coefficients given as three 4 x 4 blocks
// (rows i 0-3 with columns j 0-3, rows 0-3 with columns 4-7, rows 4-7 with columns 0-3; the
// fourth block lies beyond total degree 7), each a matrix whose column j holds c_ij for i.
fn chebyshev_series(c: array<mat4x4<f32>, 3>, s: mat2x4<f32>, u: mat2x4<f32>) -> f32 {
    return dot(s[0], c[0] * u[0]) + dot(s[0], c[1] * u[1]) + dot(s[1], c[2] * u[0]);
}

const SPLIT_SUM_SCALE = array<mat4x4<f32>, 3>(
    mat4x4<f32>(
        vec4(0.695826, 0.02037893, -0.1091826, 0.001745045),
        vec4(-0.0939191, 0.4753757, -0.02628074, -0.002336864),
        vec4(-0.007253255, 0.06656231, -0.0485239, 0.0214149),
        vec4(0.03258678, -0.0568239, 0.008506081, 0.02595344),
    ),
    mat4x4<f32>(
        vec4(0.01138073, -0.02645664, 0.02066753, 0.001481546),
        vec4(-0.004810217, 0.005105534, 0.005070956, 0.0),
        vec4(-0.00235433, 0.004106875, 0.0, 0.0),
        vec4(0.0001578477, 0.0, 0.0, 0.0),
    ),
    mat4x4<f32>(
        vec4(0.02069847, -0.006833719, 0.0005364465, -0.0001088997),
        vec4(0.01085124, -0.009815245, 0.002162264, 0.0),
        vec4(0.01299602, -0.006416843, 0.0, 0.0),
        vec4(-0.008473429, 0.0, 0.0, 0.0),
    ),
);
const SPLIT_SUM_BIAS = array<mat4x4<f32>, 3>(
    mat4x4<f32>(
        vec4(0.1601111, -0.1968825, 0.05821342, 0.003291604),
        vec4(0.2110313, -0.2640488, 0.08562985, -0.001142065),
        vec4(0.03034847, -0.04160867, 0.02282378, -0.009141448),
        vec4(-0.03569983, 0.04679883, -0.01480777, -0.004767473),
    ),
    mat4x4<f32>(
        vec4(-0.01428187, 0.02027525, -0.01285597, 0.001280627),
        vec4(0.002558735, -0.004149094, -0.00146033, 0.0),
        vec4(0.001204421, -0.002310157, 0.0, 0.0),
        vec4(-0.0001726828, 0.0, 0.0, 0.0),
    ),
    mat4x4<f32>(
        vec4(-0.01234614, 0.004489176, 0.0004320694, 1.38812e-5),
        vec4(-0.01677431, 0.007124086, 0.0005474531, 0.0),
        vec4(-0.003219636, 0.003201276, 0.0, 0.0),
        vec4(0.002357659, 0.0, 0.0, 0.0),
    ),
);

// The product's BRDF and how the reference samples it, ported operation for operation from the
// CPU reference's `brdf` module so GPU and CPU agree to f32 rounding; that module's docs state
// the model and why its diffuse base is weighted the way it is.
//
// glTF 2.0 metallic-roughness (Khronos, glTF 2.0 specification, appendix B) with
// KHR_materials_specular and KHR_materials_ior: `mix(dielectric, metal, metallic)`, the
// dielectric a Lambert base under a GGX microfacet layer (Walter et al. 2007, "Microfacet
// Models for Refraction through Rough Surfaces") with height-correlated Smith
// masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing Function in
// Microfacet-Based BRDFs") and Schlick's Fresnel (Schlick 1994), the metal the same layer
// with `F0 = base`. The base is weighted by what the dielectric's layer does not reflect from
// `wo` (albedo scaling), so no surface reflects more light than it receives;
// `alpha = max(roughness^2, MIN_ALPHA)`. The specular lobe is sampled through visible normals
// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)), the diffuse lobe
// with a cosine-weighted direction; every pdf is the whole mixture's.
//
// All vectors are in the local shading frame: unit length, the shading normal is +Z, `wo`
// points towards the viewer and `wi` towards the light.
#define_import_path gi::brdf

#import gi::math::{PI, luminance}
#import gi::sampling::cosine_hemisphere
#import gi::brdf_albedo::{albedo_series_m, albedo_series_r}

// Smallest GGX alpha. Perceptual roughness 0 would make `D` a Dirac delta that neither
// next-event estimation nor MIS weights can handle; clamping keeps mirrors finite (a lobe
// about 0.06 degrees wide) at a negligible cost in sharpness. The reference's `MIN_ALPHA`.
const MIN_ALPHA: f32 = 1e-3;

// Lowest and highest probability of sampling the specular lobe when the diffuse lobe is not
// black: neither lobe is ever starved, which bounds the weight of either technique.
const SPECULAR_PICK_MIN: f32 = 0.1;
const SPECULAR_PICK_MAX: f32 = 0.9;

// The dielectric's specular layer (KHR_materials_specular, KHR_materials_ior): its weight and
// its Fresnel reflectance at normal incidence before the weight.
struct DielectricSpecular {
    // Specular factor x texture alpha, in [0, 1]; 0 makes the dielectric pure Lambert.
    weight: f32,
    // `F0_d = min(((ior - 1) / (ior + 1))^2 * specular_color, 1)`: the Fresnel reflectance at
    // normal incidence before the weight.
    reflectance: vec3<f32>,
}

// The BRDF at one surface point, after textures were applied.
struct Brdf {
    // Linear base color.
    base: vec3<f32>,
    // In [0, 1].
    metallic: f32,
    // GGX alpha, at least MIN_ALPHA.
    alpha: f32,
    // The dielectric's specular layer.
    specular: DielectricSpecular,
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

// The reference's `DielectricSpecular::new`: weight clamped to [0, 1], color to at least 0, `F0_d` to at
// most 1 (black if not finite).
fn dielectric_specular_new(weight: f32, color: vec3<f32>, ior: f32) -> DielectricSpecular {
    let r = (ior - 1.0) / (ior + 1.0);
    var f0 = min(r * r * max(color, vec3(0.0)), vec3(1.0));
    if !(is_finite(f0.x) && is_finite(f0.y) && is_finite(f0.z)) {
        f0 = vec3(0.0);
    }
    return DielectricSpecular(clamp(weight, 0.0, 1.0), f0);
}

// glTF's dielectric layer without the extensions: weight 1, ior 1.5, white.
fn dielectric_specular_default() -> DielectricSpecular {
    return dielectric_specular_new(1.0, vec3(1.0), 1.5);
}

// From glTF parameters with the default dielectric layer: metallic and perceptual roughness
// are clamped to [0, 1] and `alpha = max(roughness^2, MIN_ALPHA)`.
fn brdf_new(base: vec3<f32>, metallic: f32, roughness: f32) -> Brdf {
    let r = clamp(roughness, 0.0, 1.0);
    return Brdf(base, clamp(metallic, 0.0, 1.0), max(r * r, MIN_ALPHA), dielectric_specular_default());
}

// `brdf` with the dielectric layer `specular`.
fn brdf_with_specular(brdf: Brdf, specular: DielectricSpecular) -> Brdf {
    var b = brdf;
    b.specular = specular;
    return b;
}

// Fresnel reflectance of the whole specular layer at normal incidence,
// `mix(s * F0_d, base, metallic)` in the reference's order of operations.
fn brdf_f0(brdf: Brdf) -> vec3<f32> {
    return (brdf.specular.reflectance * brdf.specular.weight) * (1.0 - brdf.metallic) + brdf.base * brdf.metallic;
}

// Fresnel reflectance of the whole specular layer at grazing incidence, `mix(s, 1, metallic)`.
fn brdf_f90(brdf: Brdf) -> f32 {
    return brdf.specular.weight + (1.0 - brdf.specular.weight) * brdf.metallic;
}

// `[A, B]` of `specular_albedo` at `sqrt(alpha)` and `n_dot_v` (the reference's
// `albedo_terms`).
fn albedo_terms(sqrt_alpha_in: f32, n_dot_v: f32) -> vec2<f32> {
    let sqrt_alpha = clamp(sqrt_alpha_in, sqrt(MIN_ALPHA), 1.0);
    let alpha = sqrt_alpha * sqrt_alpha;
    let mu = clamp(n_dot_v, 0.0, 1.0);
    let s = 2.0 * sqrt_alpha - 1.0;
    let m = clamp(albedo_series_m(1.0 - 2.0 * (mu / (mu + alpha)), s), 0.0, 1.0);
    let r = clamp(albedo_series_r(1.0 - 2.0 * sqrt(sqrt(mu)), s), 0.0, 1.0);
    return vec2(m * (1.0 - r), m * r);
}

// Weight of the Lambert base from the layer's albedo terms `ab` (`albedo_terms`).
fn diffuse_weight_of(brdf: Brdf, ab: vec2<f32>) -> f32 {
    if brdf.specular.weight <= 0.0 {
        return 1.0;
    }
    let f0 = brdf.specular.reflectance;
    return 1.0 - brdf.specular.weight * min(max(max(f0.x, f0.y), f0.z) * ab.x + ab.y, 1.0);
}

// Weight of the Lambert base: the share of light the dielectric's specular layer does not
// reflect from `n_dot_v`.
fn brdf_diffuse_weight(brdf: Brdf, n_dot_v: f32) -> f32 {
    if brdf.specular.weight <= 0.0 {
        return 1.0;
    }
    return diffuse_weight_of(brdf, albedo_terms(sqrt(brdf.alpha), n_dot_v));
}

// Albedo of the Lambert lobe seen from `n_dot_v`: `base * (1 - metallic) * w(wo)`.
fn brdf_diffuse_albedo(brdf: Brdf, n_dot_v: f32) -> vec3<f32> {
    return brdf.base * ((1.0 - brdf.metallic) * brdf_diffuse_weight(brdf, n_dot_v));
}

// What a split-sum tier reflects from `n_dot_v`: the Lambert lobe's albedo
// (`brdf_diffuse_albedo`) and the specular layer's (`specular_albedo`), from one evaluation
// of the layer's albedo series.
struct SplitSumAlbedos {
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

fn brdf_split_sum_albedos(brdf: Brdf, n_dot_v: f32) -> SplitSumAlbedos {
    let ab = albedo_terms(sqrt(brdf.alpha), n_dot_v);
    let diffuse = brdf.base * ((1.0 - brdf.metallic) * diffuse_weight_of(brdf, ab));
    let specular = clamp(brdf_f0(brdf) * ab.x + vec3(brdf_f90(brdf) * ab.y), vec3(0.0), vec3(1.0));
    return SplitSumAlbedos(diffuse, specular);
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

// Schlick's Fresnel from `f0` at normal to `f90` at grazing incidence; `(1 - cos)^5`
// multiplied out as the reference's `powi(5)` does.
fn schlick(f0: vec3<f32>, f90: f32, cos_theta: f32) -> vec3<f32> {
    let x = 1.0 - clamp(cos_theta, 0.0, 1.0);
    let x2 = x * x;
    let m = x * (x2 * x2);
    return f0 + (vec3<f32>(f90) - f0) * m;
}

// The GGX specular lobe without Fresnel, `D G2 / (4 cos_o cos_i)`, for half vector `h` and
// the cosines of both directions (both positive).
fn ggx_lobe(h: vec3<f32>, cos_o: f32, cos_i: f32, a2: f32) -> f32 {
    return ggx_d(h, a2) * smith_g2(cos_o, cos_i, a2) / (4.0 * cos_o * cos_i);
}

// A `Brdf` with its outgoing direction `wo` fixed (`brdf_seen_from`): its Fresnel terms,
// diffuse albedo and lobe probability computed once, as a path vertex needs them several times
// (the reference's `ViewedBrdf`). The `brdf_*` functions below are written on top of it.
struct ViewedBrdf {
    wo: vec3<f32>,
    alpha: f32,
    // The layer's Fresnel reflectance at normal and at grazing incidence (`brdf_f0`,
    // `brdf_f90`).
    normal_reflectance: vec3<f32>,
    // alpha^2.
    alpha_sq: f32,
    // The Lambert lobe's value, `diffuse albedo(wo) / pi`.
    diffuse: vec3<f32>,
    grazing_reflectance: f32,
    // Probability of sampling the specular lobe (`brdf_specular_probability`).
    p_specular: f32,
    // False when Schlick's term is zero at every angle (F0 = 0, F90 = 0: a dielectric without
    // specular layer), so the specular lobe adds exactly nothing and is skipped.
    specular_layer: bool,
}

// `brdf` seen from `wo`, with what depends on `wo` alone computed once.
fn brdf_seen_from(brdf: Brdf, wo: vec3<f32>) -> ViewedBrdf {
    let f0 = brdf_f0(brdf);
    let f90 = brdf_f90(brdf);
    let diffuse_albedo = brdf_diffuse_albedo(brdf, wo.z);
    // The lobe probability, spelt out so its Fresnel term and albedo are shared: the luminance
    // of the Fresnel reflectance at `wo` against that of the diffuse albedo, kept within
    // [0.1, 0.9] unless a lobe is black (metals always sample specular, a dielectric without
    // specular layer never does).
    let specular = luminance(schlick(f0, f90, wo.z));
    var p_specular = 0.0;
    if specular > 0.0 {
        let diffuse = luminance(diffuse_albedo);
        p_specular = 1.0;
        if diffuse > 0.0 {
            p_specular = clamp(specular / (specular + diffuse), SPECULAR_PICK_MIN, SPECULAR_PICK_MAX);
        }
    }
    let layer = any(f0 != vec3(0.0)) || f90 != 0.0;
    return ViewedBrdf(wo, brdf.alpha, f0, brdf.alpha * brdf.alpha, diffuse_albedo / PI, f90, p_specular, layer);
}

// The BRDF value towards `wi`; zero unless both directions are above the surface.
fn viewed_eval(v: ViewedBrdf, wi: vec3<f32>) -> vec3<f32> {
    let wo = v.wo;
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    if !v.specular_layer {
        return v.diffuse;
    }
    let h = normalize_like_reference(wo + wi);
    let specular = ggx_lobe(h, wo.z, wi.z, v.alpha_sq);
    return v.diffuse + schlick(v.normal_reflectance, v.grazing_reflectance, dot(wo, h)) * specular;
}

// pdf of the reflected visible-normal sample: `G1(wo) * D(h) / (4 * wo.z)`.
fn viewed_specular_pdf(v: ViewedBrdf, wi: vec3<f32>) -> f32 {
    return ggx_visible_pdf(v.wo, wi, v.alpha_sq);
}

// Solid-angle pdf of `viewed_sample` producing `wi`.
fn viewed_pdf(v: ViewedBrdf, wi: vec3<f32>) -> f32 {
    if v.wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let diffuse = (1.0 - v.p_specular) * wi.z / PI;
    if v.p_specular <= 0.0 {
        return diffuse;
    }
    return v.p_specular * viewed_specular_pdf(v, wi) + diffuse;
}

// The BRDF value; zero unless both directions are above the surface.
fn brdf_eval(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    return viewed_eval(brdf_seen_from(brdf, wo), wi);
}

// Probability that `brdf_sample` picks the specular lobe for `wo`.
fn brdf_specular_probability(brdf: Brdf, wo: vec3<f32>) -> f32 {
    return brdf_seen_from(brdf, wo).p_specular;
}

// pdf of the reflected visible-normal sample: `G1(wo) * D(h) / (4 * wo.z)`.
fn brdf_specular_pdf(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    return ggx_visible_pdf(wo, wi, brdf.alpha * brdf.alpha);
}

// `G1(wo) * D(h) / (4 * wo.z)` for GGX `alpha^2 = a2`: the pdf of `wi` reflected about a
// visible normal.
fn ggx_visible_pdf(wo: vec3<f32>, wi: vec3<f32>, a2: f32) -> f32 {
    let h = normalize_like_reference(wo + wi);
    return smith_g1(wo.z, a2) * ggx_d(h, a2) / (4.0 * wo.z);
}

// Solid-angle pdf of `brdf_sample` producing `wi`.
fn brdf_pdf(brdf: Brdf, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    return viewed_pdf(brdf_seen_from(brdf, wo), wi);
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
fn viewed_sample(v: ViewedBrdf, u_lobe: f32, u: vec2<f32>) -> BrdfSample {
    var bs = BrdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    let wo = v.wo;
    if wo.z <= 0.0 {
        return bs;
    }
    if u_lobe < v.p_specular {
        let h = sample_ggx_vndf(wo, v.alpha, u);
        bs.wi = 2.0 * dot(wo, h) * h - wo;
    } else {
        bs.wi = cosine_hemisphere(u);
    }
    if bs.wi.z <= 0.0 {
        return bs;
    }
    bs.pdf = viewed_pdf(v, bs.wi);
    bs.valid = bs.pdf > 0.0 && is_finite(bs.pdf);
    if bs.valid {
        bs.f = viewed_eval(v, bs.wi);
    }
    return bs;
}

// `viewed_sample` of `brdf` seen from `wo`.
fn brdf_sample(brdf: Brdf, wo: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> BrdfSample {
    return viewed_sample(brdf_seen_from(brdf, wo), u_lobe, u);
}

// The dielectric layer as one f32 for a G-buffer channel (`gbuffer.base_color`'s w): the
// weight in 8 bits and the largest channel of `F0_d` in 12, as an integer-valued float (exact
// in f32), plus 1 so a hit never reads 0 (the sky's value). The real-time tiers read the
// layer back with `unpack_dielectric_specular`; a colored `F0_d` becomes grey there.
fn pack_dielectric_specular(d: DielectricSpecular) -> f32 {
    let weight = u32(round(clamp(d.weight, 0.0, 1.0) * 255.0));
    let f0 = u32(round(clamp(max(max(d.reflectance.x, d.reflectance.y), d.reflectance.z), 0.0, 1.0) * 4095.0));
    return f32(weight * 4096u + f0 + 1u);
}

// The layer `pack_dielectric_specular` stored; the default layer for 0 (no hit).
fn unpack_dielectric_specular(packed: f32) -> DielectricSpecular {
    if packed < 1.0 {
        return dielectric_specular_default();
    }
    let code = u32(packed) - 1u;
    return DielectricSpecular(f32(code >> 12u) / 255.0, vec3(f32(code & 4095u) / 4095.0));
}

// The BRDF of a G-buffer pixel: its base color and packed layer (`gbuffer.base_color`) and its
// metallic and perceptual roughness (`gbuffer.metallic_roughness`).
fn gbuffer_brdf(base_color: vec4<f32>, metallic_roughness: vec2<f32>) -> Brdf {
    return brdf_with_specular(
        brdf_new(base_color.xyz, metallic_roughness.x, metallic_roughness.y),
        unpack_dielectric_specular(base_color.w),
    );
}

// The specular layer's directional albedo for Schlick's Fresnel from `f0` to `f90`, perceptual
// `roughness` and `n_dot_v`: `f0 * A + f90 * B`, what split-sum tiers multiply pre-integrated
// light by. The same numbers as `gi_reference::brdf::specular_albedo`, whose documentation
// gives the fit and its accuracy.
fn specular_albedo(f0: vec3<f32>, f90: f32, roughness: f32, n_dot_v: f32) -> vec3<f32> {
    let r = clamp(roughness, 0.0, 1.0);
    let alpha = max(r * r, MIN_ALPHA);
    let ab = albedo_terms(sqrt(alpha), n_dot_v);
    return clamp(f0 * ab.x + vec3(f90 * ab.y), vec3(0.0), vec3(1.0));
}

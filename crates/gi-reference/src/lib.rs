//! The CPU reference path tracer: the ground truth every GI tier's error is measured against.
//!
//! Build a [`Reference`] from a scene and one evaluated frame, then [`Reference::render`] it,
//! or drive an [`Accumulator`] to add samples progressively:
//!
//! ```no_run
//! # fn demo(scene: &gi_scene::Scene) -> Result<(), gi_reference::RenderError> {
//! use gi_reference::{Reference, RenderSettings};
//!
//! let reference = Reference::new(scene, scene.evaluate(0.0, None));
//! let settings = RenderSettings { width: 320, height: 180, spp: 64, ..Default::default() };
//! let output = reference.render(&settings, &|done| eprintln!("{done}/{} spp", settings.spp))?;
//! println!("{:.0} paths/s", output.stats.samples_per_second);
//! # Ok(()) }
//! ```
//!
//! # The light transport contract
//!
//! Every GPU tier replicates these conventions; the reference defines them.
//!
//! **Output.** Linear RGB radiance per pixel, the mean of `spp` samples; exposure and tone
//! mapping are applied later by the image crate. The image depends only on the scene, camera,
//! size, `spp`, `seed`, mode, strategy and depth: sample `i` of pixel `p` draws its random
//! numbers from a PCG32 seeded by `(seed, p, i)`, so neither thread count nor pass splitting
//! changes a single bit.
//!
//! **Camera.** A pinhole at the frame camera's position; the ray of a sample goes through
//! `CameraView::ray_direction(u, v, width / height)` where `(u, v)` is a uniformly jittered
//! point of the pixel (a box filter). There is no near plane: the pinhole sees everything in
//! front of it.
//!
//! **Surfaces.** Triangles are two-sided for reflection; nothing is culled. The geometric
//! normal is `(v1 - v0) x (v2 - v0)` normalized (the side from which the vertices appear
//! counter-clockwise: glTF's front face), flipped towards the incoming ray. The shading normal
//! is the interpolated vertex normal flipped to the geometric normal's side; if the viewer is
//! below its horizon, the geometric normal shades instead. Directions below the geometric
//! surface receive nothing (no light leaks where shading and geometric normals disagree).
//! Secondary rays start `1e-4 * (1 + max |p|)` off the surface along the geometric normal.
//!
//! **Materials.** glTF metallic-roughness with `KHR_materials_specular` and
//! `KHR_materials_ior`: base color = factor x bilinear base-color texture (RGB, alpha
//! ignored); metallic = factor x texture blue, roughness = factor x texture green; specular =
//! factor x specular texture alpha, specular color = factor x texture RGB; emission = emissive
//! factor x emissive texture. The BRDF is in [`brdf`]: glTF 2.0's `mix(dielectric, metal,
//! metallic)`, a GGX layer (height-correlated Smith G2, Schlick Fresnel from
//! `F0 = mix(specular * F0_d, base, metallic)` to `F90 = mix(specular, 1, metallic)`,
//! `F0_d = ((ior - 1) / (ior + 1))^2 * specular color`) over a Lambert base
//! `base (1 - metallic) / pi` weighted by what the dielectric's layer does not reflect from
//! `wo`, so no surface reflects more light than it receives; `alpha = max(roughness^2, 1e-3)`
//! so mirrors stay finite.
//!
//! **Emitters.** A triangle with emission emits on its front face only, unless its material is
//! double-sided (then on both). Emission is constant over directions (Lambertian emitter).
//!
//! **Punctual lights** (KHR_lights_punctual) contribute through `WorldLight::incident`
//! evaluated at the surface point (glTF falloff, range window and spot cone), times the BRDF
//! and the shading cosine, with one shadow ray each. Every light is evaluated at every
//! scattering vertex (no light selection): product scenes have few punctual lights, and it
//! keeps their term free of noise.
//!
//! **[`Mode::Direct`]**, the "None" baseline every tier computes as its direct term: the camera
//! ray's emission (or sky) plus all punctual lights at the first hit with the full BRDF.
//! Nothing else; deterministic apart from pixel jitter.
//!
//! **[`Mode::Full`]** is a unidirectional path tracer. At each hit it adds the surface's
//! emission (MIS-weighted), stops if `max_depth` scatterings happened, then estimates direct
//! light with next-event estimation and continues with a BRDF sample:
//!
//! - punctual lights: all of them, as above (delta lights, no MIS);
//! - emissive triangles: one sample — a triangle drawn from a table proportional to power
//!   (`area * luminance(average emission) * pi`, doubled when double-sided), then a uniform
//!   point on it, its area pdf converted to solid angle (`pdf_area * d^2 / |cos_light|`);
//! - the sky: one cosine-weighted direction about the shading normal (`pdf = cos / pi`),
//!   skipped when the sky is black;
//! - the BRDF sample: the specular lobe (GGX visible normals, Heitz 2018) with probability
//!   `lum(F_schlick(wo)) / (lum(F_schlick(wo)) + lum(diffuse albedo))` clamped to
//!   `[0.1, 0.9]` (1 when the diffuse albedo is black, 0 when the layer is), else the
//!   cosine-weighted diffuse lobe; its pdf is always the whole mixture's.
//!
//! Emission reached by a BRDF-sampled ray (an emissive triangle, or the sky on escape) is
//! weighted by the power heuristic against the pdf its next-event strategy would have had;
//! next-event samples are weighted symmetrically. Camera rays always have weight 1. There is
//! no near-specular special case: the minimum alpha keeps every pdf finite, and the heuristic
//! gives smooth mirrors' BRDF samples weight ~1 by itself. [`Strategy::LightOnly`] and
//! [`Strategy::BsdfOnly`] switch one technique off (weights 1 and 0) for testing.
//!
//! **Russian roulette** starts after [`RUSSIAN_ROULETTE_START`] scatterings: the path survives
//! with probability `min(max component of throughput, 0.95)` and is reweighted by its inverse.
//! Sample values that come out non-finite are counted in
//! [`RenderStats::nonfinite_samples`] and treated as black.

mod accumulate;
pub mod brdf;
pub mod cache;
pub mod engine;
mod integrator;
mod irradiance;
mod lights;
pub mod sampling;
mod scene;
mod settings;

pub use accumulate::{Accumulator, RenderOutput, RenderStats};
pub use integrator::{RUSSIAN_ROULETTE_MAX_SURVIVAL, RUSSIAN_ROULETTE_START};
pub use scene::Reference;
pub use settings::{MAX_PIXELS, MAX_SIDE, Mode, RenderError, RenderSettings, Strategy};

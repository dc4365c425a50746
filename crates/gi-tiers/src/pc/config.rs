//! The PC tier's settings.

use gi_cache::CacheConfig;

use super::denoise::DenoiseConfig;

/// Everything the PC tier can be told. `Default` is the product's configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct PcConfig {
    /// The brick radiance cache the hits read their indirect light from.
    pub cache: CacheConfig,
    /// Full-resolution pixels per trace pixel along each axis: 2 traces one ray per 2 x 2
    /// pixels (HSGI traces at 966 x 542 for a 1932 x 1084 frame), 1 one per pixel.
    pub trace_scale: u32,
    /// What a diffuse ray reads beyond [`PcConfig::probe_ray_m`]: see [`TraceMode`].
    pub trace_mode: TraceMode,
    /// Length of a diffuse ray's BVH segment in [`TraceMode::Probes`], in meters (HSGI: "short
    /// ray = probe size"). Longer segments find more near geometry exactly and cost more BVH
    /// traversal; beyond them the brick cache answers.
    pub probe_ray_m: f32,
    pub restir: RestirConfig,
    pub denoise: DenoiseConfig,
    pub specular: SpecularConfig,
    /// Darken the gathered diffuse light by the material's occlusion map (glTF
    /// `occlusionTexture`: "areas that receive less indirect lighting"). Off by default: the
    /// traced light already holds the occlusion of the geometry the scene has, and a map baked
    /// from that geometry darkens it twice (measured: SheenChair's error against the reference
    /// rose from 1.58 to 3.09 rmse_srgb8 on an H100); on for maps baked from detail the
    /// geometry lacks.
    pub material_occlusion: bool,
    /// Where the diffuse rays' hits get the punctual lights' (the sun's, point and spot
    /// lights') direct light: see [`HitLights`].
    pub hit_lights: HitLights,
    /// Temporal gradients, which shorten the denoiser's histories where the light changed.
    pub gradients: GradientConfig,
}

/// Temporal gradients (Schied, Peters and Dachsbacher 2018, "Gradient Estimation for Real-Time
/// Adaptive Temporal Filtering", A-SVGF): each frame one trace pixel per stratum keeps its
/// diffuse ray, and the next frame draws that ray again (same receiver, direction and random
/// numbers) beside its own, in the same dispatch. The change of what it finds outside the brick cache (the
/// hit's emission and direct light, or the sky) is the change of the scene's light and
/// geometry, free of sampling noise and of the cache's update noise; over the 3 x 3 strata
/// around each, `lambda = min(gain |sum of changes| / sum of the larger luminances, 1)`, and the denoiser
/// blends with `alpha' = mix(alpha, 1, lambda)` instead of its history's alpha. Cost: one more
/// diffuse ray (with its hit's shadow rays) per stratum.
#[derive(Clone, Debug, PartialEq)]
pub struct GradientConfig {
    /// Measure the gradients. Off, the histories follow a change at their own rate only.
    pub enabled: bool,
    /// Trace pixels per side of a stratum (A-SVGF: 3 pixels).
    pub stratum: u32,
    /// Scale of lambda: higher drops more history for a smaller change. A hit's direct light is
    /// typically half of what it sends, so 3 drops all history where a light it saw went out
    /// (measured on lavapipe at 64 x 48, atrium's sun switched off: 51% of the change left
    /// after 4 frames with 1, 37% with 3, 34% with 8, 74% without gradients; the still
    /// camera's flicker 0.92% with 3 as without).
    pub gain: f32,
}

impl Default for GradientConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            stratum: 3,
            gain: 3.0,
        }
    }
}

impl GradientConfig {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=8).contains(&self.stratum) {
            return Err(format!(
                "gradient stratum must be within 1..=8 trace pixels, not {}",
                self.stratum
            ));
        }
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(format!(
                "gradient gain must be positive and finite, not {}",
                self.gain
            ));
        }
        Ok(())
    }
}

/// Where the hits of the PC tier's diffuse rays get the punctual lights' direct light. The
/// emitters are sampled at the hit either way, and the specular rays' hits, which mirrors show
/// sharply, always trace their shadow rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HitLights {
    /// A shadow ray per light at every hit: exact shadows in the bounced light.
    #[default]
    ShadowRays,
    /// The brick cache's direct light at the hit (each voxel side lit with its own shadow ray
    /// by the cache): no rays at the hit, shadows as sharp as the cache's voxels (Lumen's
    /// surface-cache lighting of hits). Cheaper and less accurate: on the H100 at 1920 x 1080
    /// (2026-11-27, `benchmarks/results/h100-2026-11-27-hit-lights/`) `pc/trace` 1.17 against
    /// 1.60 ms on Sponza (PC GI 3.88-3.91 against 4.31-4.33), 0.45 against 0.62 on atrium;
    /// rmse_srgb8 Sponza 6.63 against 6.36, GasStation 6.72 against 6.46, atrium 6.25 against
    /// 5.20, open-world 2.23 against 2.09, dynamic 5.49 against 5.53.
    Cache,
}

impl HitLights {
    /// The names [`HitLights::from_str`](std::str::FromStr) takes.
    pub const NAMES: [&str; 2] = ["rays", "cache"];

    /// `rays` or `cache`.
    pub fn name(self) -> &'static str {
        match self {
            Self::ShadowRays => "rays",
            Self::Cache => "cache",
        }
    }
}

impl std::str::FromStr for HitLights {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rays" => Ok(Self::ShadowRays),
            "cache" => Ok(Self::Cache),
            other => Err(format!(
                "unknown hit lighting '{other}' (expected {})",
                Self::NAMES.join(" or ")
            )),
        }
    }
}

impl Default for PcConfig {
    fn default() -> Self {
        Self {
            // The hits sample the emitters themselves and read the cache's bounced light.
            cache: CacheConfig {
                keep_emitted: true,
                ..CacheConfig::default()
            },
            trace_scale: 2,
            trace_mode: TraceMode::Rays,
            probe_ray_m: 0.5,
            restir: RestirConfig::default(),
            denoise: DenoiseConfig::default(),
            specular: SpecularConfig::default(),
            material_occlusion: false,
            hit_lights: HitLights::ShadowRays,
            gradients: GradientConfig::default(),
        }
    }
}

/// How the diffuse rays find the radiance they carry (HSGI, GDC 2023, "Trace Probe Mode").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TraceMode {
    /// The whole ray through the BVH, its hit shaded with exact direct light plus the cache's
    /// indirect light: the high-quality default.
    #[default]
    Rays,
    /// A short BVH segment ([`PcConfig::probe_ray_m`]); a ray that hits nothing within it
    /// reads the radiance beyond from the brick cache, traced on from the segment's end, the
    /// cache's voxels standing in for HSGI's probes. HSGI switches to it "in critical scenes
    /// for stability" (many bounces, small bright lights): pre-filtered far radiance instead
    /// of far hits shaded one by one, and no BVH traversal of far geometry. What the cache
    /// blurs (thin occluders, light leaking through coarse voxels) comes out softer or
    /// brighter; on the bundled scenes it measured less accurate than `Rays` and no steadier
    /// (benchmarks/RESULTS-history.md). Emitters beyond the segment are left to the emitter
    /// samples, whose MIS weights account for the shorter rays.
    Probes,
}

impl TraceMode {
    /// The names `--pc-trace-mode` takes.
    pub const NAMES: [&str; 2] = ["rays", "probes"];

    pub fn name(self) -> &'static str {
        match self {
            Self::Rays => "rays",
            Self::Probes => "probes",
        }
    }
}

impl std::str::FromStr for TraceMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rays" => Ok(Self::Rays),
            "probes" => Ok(Self::Probes),
            other => Err(format!(
                "unknown PC trace mode '{other}' (modes: {})",
                Self::NAMES.join(", ")
            )),
        }
    }
}

/// The stages [`PcConfig::with`] can switch on, for ablations: off by default because they
/// did not earn their place (see [`RestirConfig::temporal`]).
pub const PC_OPTIONAL_STAGES: [&str; 1] = ["temporal"];

/// The stages [`PcConfig::without`] can switch off, for ablations. Temporal reuse and its
/// boiling filter are off by default ([`PC_OPTIONAL_STAGES`]).
pub const PC_STAGES: [&str; 8] = [
    "gradients",
    "spatial",
    "shadow",
    "multi-sample",
    "svgf",
    "restir",
    "specular",
    "rough-specular",
];

impl PcConfig {
    /// The default with `stage` switched off: one of [`PC_STAGES`]. `restir` switches off all
    /// reuse (spatial, shadow ray, multi-sample shading; temporal reuse is off already): each
    /// pixel is shaded from its own trace pixel's single sample, the plain 1-sample-per-trace-
    /// pixel pipeline with the same denoiser. `svgf` switches off the whole denoiser
    /// (temporal accumulation and the a-trous passes). `specular` traces no specular rays: the
    /// smooth surfaces reflect the irradiance over pi through their split-sum specular albedo.
    /// `rough-specular` does not reuse the diffuse samples for the rough surfaces' reflection:
    /// they reflect the irradiance over pi. `gradients` measures no temporal gradients: the
    /// histories follow a change of the light at their own rate.
    pub fn without(stage: &str) -> Result<Self, String> {
        let mut config = Self::default();
        let r = &mut config.restir;
        match stage {
            "spatial" => r.spatial = false,
            "shadow" => r.shadow_ray = false,
            "multi-sample" => r.multi_sample = false,
            "temporal" | "boiling" => {
                return Err(format!(
                    "PC tier stage '{stage}' is off by default (`PcConfig::with(\"temporal\")`, \
                     `--pc-with temporal`, switches temporal reuse and its boiling filter on)"
                ));
            }
            "svgf" => {
                config.denoise.temporal = false;
                config.denoise.atrous_iterations = 0;
            }
            "specular" => config.specular.traced = false,
            "gradients" => config.gradients.enabled = false,
            "rough-specular" => config.specular.reuse_diffuse = false,
            "restir" => {
                r.spatial = false;
                r.shadow_ray = false;
                r.multi_sample = false;
            }
            other => {
                return Err(format!(
                    "unknown PC tier stage '{other}' (stages: {}; off by default: {})",
                    PC_STAGES.join(", "),
                    PC_OPTIONAL_STAGES.join(", ")
                ));
            }
        }
        Ok(config)
    }

    /// The default with `stage` switched on: one of [`PC_OPTIONAL_STAGES`]. `temporal` turns
    /// on temporal reuse with its boiling filter.
    pub fn with(stage: &str) -> Result<Self, String> {
        let mut config = Self::default();
        match stage {
            "temporal" => {
                config.restir.temporal = true;
                config.restir.boiling_filter = true;
            }
            other if PC_STAGES.contains(&other) => {
                return Err(format!(
                    "PC tier stage '{other}' is on by default (stages off by default: {})",
                    PC_OPTIONAL_STAGES.join(", ")
                ));
            }
            other => {
                return Err(format!(
                    "unknown PC tier stage '{other}' (stages off by default: {})",
                    PC_OPTIONAL_STAGES.join(", ")
                ));
            }
        }
        Ok(config)
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=2).contains(&self.trace_scale) {
            return Err(format!(
                "trace_scale must be 1 or 2, not {}",
                self.trace_scale
            ));
        }
        if !(self.probe_ray_m.is_finite() && self.probe_ray_m > 0.0) {
            return Err(format!(
                "probe_ray_m must be positive and finite, not {}",
                self.probe_ray_m
            ));
        }
        self.restir.validate()?;
        self.denoise.validate()?;
        self.gradients.validate()?;
        self.specular.validate()
    }
}

/// Specular reflections (HSGI, GDC 2023, "Specular Reflection": GGX VNDF rays below
/// roughness 0.4, the diffuse result reused above, a blend toward diffuse above 0.8, here a
/// setting that measured worse).
#[derive(Clone, Debug, PartialEq)]
pub struct SpecularConfig {
    /// Trace specular rays below [`SpecularConfig::max_roughness`]. Off, those surfaces
    /// reflect the diffuse irradiance over pi through their split-sum specular albedo, which
    /// blurs every reflection to the irradiance's.
    pub traced: bool,
    /// Surfaces rougher than this reflect the diffuse result; smoother ones trace one GGX
    /// VNDF ray per trace pixel. Between 0.75 and 1 times it the traced reflection blends to
    /// the irradiance over pi. HSGI traces below 0.4. Higher values trace more surfaces (one
    /// more BVH ray per trace pixel on each) and make wide lobes noisier.
    pub max_roughness: f32,
    /// Reuse the diffuse samples for the rough surfaces' reflection (HSGI's "reuse diffuse
    /// tracing result"): the multi-sample shading weights each reservoir sample it shades a
    /// pixel with by the pixel's specular lobe, and the ratio of that lobe-weighted light to
    /// the irradiance (over the lobe's albedo, so 1 for light from every direction alike)
    /// is accumulated over time like the traced reflection and scales the denoised
    /// irradiance over pi. Off, rough surfaces reflect the irradiance over pi itself: light
    /// the lobe cannot see, such as a ceiling light in a wall's reflection at a grazing view,
    /// then reflects as if it could. H100, 1280 x 720, rmse_srgb8 with / without: glossy
    /// 7.91 / 9.23, cornell-box 3.60 / 3.64, atrium 7.40 / 7.09, thin-wall 19.86 / 19.79, for
    /// about 0.1 ms at 1080p (benchmarks/RESULTS-history.md).
    pub reuse_diffuse: bool,
    /// Roughness above which the reused reflection blends linearly to the irradiance over pi,
    /// reached at roughness 1; 1 never blends. HSGI blends toward diffuse above 0.8; here the
    /// blend only lost: H100, 1280 x 720, rmse_srgb8 at 0.8 / 1: cornell-box 3.64 / 3.60
    /// (seeds 2 and 3: 3.66 / 3.62, 3.65 / 3.61), glossy 7.91 / 7.90, atrium 7.40 / 7.41,
    /// thin-wall 19.86 / 19.87 (benchmarks/RESULTS-history.md).
    pub diffuse_from: f32,
    /// Most frames the specular history averages, from 1 to 127 (its length is kept in 7
    /// bits). Longer histories are smoother on still views and lag more behind moving
    /// reflections (the history follows the surface's motion, not the reflection's).
    pub history: f32,
    /// The history is clamped to the resolved samples' 3 x 3 mean plus or minus this many
    /// standard deviations: smaller values reject stale history sooner and keep more noise.
    pub clamp_sigma: f32,
}

impl Default for SpecularConfig {
    fn default() -> Self {
        Self {
            traced: true,
            max_roughness: 0.4,
            reuse_diffuse: true,
            diffuse_from: 1.0,
            history: 16.0,
            clamp_sigma: 2.0,
        }
    }
}

impl SpecularConfig {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.max_roughness.is_finite() && (0.0..=1.0).contains(&self.max_roughness)) {
            return Err(format!(
                "specular max_roughness must be within 0..=1, not {}",
                self.max_roughness
            ));
        }
        if !(self.diffuse_from.is_finite() && (0.0..=1.0).contains(&self.diffuse_from)) {
            return Err(format!(
                "specular diffuse_from must be within 0..=1, not {}",
                self.diffuse_from
            ));
        }
        if !(self.history.is_finite() && (1.0..=127.0).contains(&self.history)) {
            return Err(format!(
                "specular history must be within 1..=127 frames, not {}",
                self.history
            ));
        }
        if !(self.clamp_sigma.is_finite() && self.clamp_sigma > 0.0) {
            return Err(format!(
                "specular clamp_sigma must be positive and finite, not {}",
                self.clamp_sigma
            ));
        }
        Ok(())
    }
}

/// ReSTIR GI's knobs (Ouyang et al. 2021; HSGI, GDC 2023).
#[derive(Clone, Debug, PartialEq)]
pub struct RestirConfig {
    /// Reuse the previous frame's reservoir of the same surface. Off by default: it halves
    /// the noise of each frame's shaded irradiance but correlates it from frame to frame, and
    /// the denoiser's temporal accumulation averages correlated frames less well. On atrium
    /// (96 x 64, lavapipe, 128 still frames) the frame's variance fell from 1.16 to 0.50 while
    /// the variance of 16-frame means rose from 0.073 to 0.086 (lag-1 autocorrelation 0.29);
    /// after the denoiser it lost on atrium and thin-wall and tied elsewhere (H100, 1280 x 720,
    /// rmse_srgb8 without / with: atrium 7.51 / 7.79, thin-wall 20.11 / 20.87, cornell-box
    /// 3.99 / 3.96, glossy 9.35 / 9.32), also along a moving camera and with every M clamp
    /// tried (benchmarks/RESULTS-history.md).
    pub temporal: bool,
    /// Reuse neighbours' reservoirs.
    pub spatial: bool,
    /// HSGI's visibility ray to the chosen sample, with the fallback to the temporal reservoir
    /// and the shadow condition in the shading's neighbour selection.
    pub shadow_ray: bool,
    /// Shade each pixel from the reservoirs of the trace pixels around it.
    pub multi_sample: bool,
    /// Restart temporal reservoirs much brighter than their neighbourhood (acts only with
    /// temporal reuse).
    pub boiling_filter: bool,
    /// Most samples the temporal history counts. ReSTIR GI and HSGI use 20; here a history of M
    /// frames trails the brick cache by about M frames while the cache still converges (the
    /// reservoir's weight sum keeps its unchosen candidates' old values; only the chosen
    /// sample is refreshed), which darkened thin-wall's mean irradiance by 20% at 20. 5
    /// measured better on every scene tried (lavapipe, 96 x 72 after 64 frames against a
    /// 512-spp reference, with `boil_factor` 50: thin-wall 50.6 -> 36.6 rmse_srgb8, atrium
    /// 16.4 -> 15.6, cornell-box 11.4 -> 11.7, glossy 16.5 -> 16.5; without reuse 41.2, 15.8,
    /// 12.3, 16.4).
    pub m_clamp: f32,
    /// Neighbours the spatial reuse tries.
    pub spatial_samples: u32,
    /// Radius of the spatial reuse's disk, in trace pixels. Each neighbour brings its whole
    /// temporal history (M up to `m_clamp`) but one sample evaluated at this receiver, so
    /// far neighbours, whose cosines and shift Jacobians differ most, add noise: on atrium
    /// (96 x 72, lavapipe) the per-frame relative noise of the shaded irradiance was 0.86 with
    /// 4 neighbours within 8 trace pixels, 0.50 with 3 within 3, 0.40 without spatial reuse
    /// and 1.45 without any reuse.
    pub spatial_radius: f32,
    /// Bound of the reconnection shift's Jacobian (HSGI bounds the maximum).
    pub jacobian_max: f32,
    /// Multi-sample shading's reach r, in trace pixels: a pixel's irradiance comes from the
    /// trace pixels whose centers lie within r of its own center per axis (at trace scale 2
    /// and r = 1, the 2 x 2 nearest it), a rough pixel's reflection ratio from the
    /// (2 r + 1)^2 around its own trace pixel (HSGI's 3 x 3 at r = 1). Measured on the H100
    /// (720p, `RESULTS-history.md`): shading the irradiance from the whole 3 x 3 too read 1.5%
    /// more error on cornell-box and 0.3% on glossy, 0.7% less on atrium and 0.9% on thin-wall.
    pub shade_radius: u32,
    /// Multi-sample shading skips a neighbour's reservoir whose sample lies nearer its own
    /// receiver than this times the distance between the two receivers: near a contact or in
    /// a corner the neighbour's short ray sees a different scene from here, and its estimate,
    /// moved here without a visibility test, blurs the contact shadow and leaks light. 0 keeps
    /// every neighbour. Measured at 0 / 1 / 2 / 4 / 8 (H100, 1280 x 720, rmse_srgb8):
    /// thin-wall 20.88 / 20.90 / 20.49 / 20.10 / 19.75, atrium 7.57 / 7.50 / 7.51 / 7.50 /
    /// 7.46 (but rmse_linear 0.0464 -> 0.0479 at 4), cornell-box 3.97 / 3.98 / 3.98 / 3.99 /
    /// 4.04; 4 takes most of thin-wall's gain for little of cornell-box's loss.
    pub shade_contact_ratio: f32,
    /// Least cosine between two receivers' normals for reuse (cos 25 degrees).
    pub normal_cos: f32,
    /// Most distance of a receiver from another's tangent plane for reuse, relative to depth.
    pub plane_tolerance: f32,
    /// A reservoir whose weight exceeds this times its 8 x 8 neighbourhood's mean restarts.
    /// 10 threw away the rare bright samples that light a room through a door (thin-wall), the
    /// ones reuse is for; 50 keeps them and still stops single fireflies.
    pub boil_factor: f32,
    /// Shadow condition: cosine of the cone around the occluded direction.
    pub shadow_cos: f32,
    /// Shadow condition: a neighbour's sample beyond this times the occluder's distance in
    /// that cone counts as occluded.
    pub shadow_distance_ratio: f32,
}

impl Default for RestirConfig {
    fn default() -> Self {
        Self {
            temporal: false,
            spatial: true,
            shadow_ray: true,
            multi_sample: true,
            boiling_filter: false,
            m_clamp: 5.0,
            spatial_samples: 3,
            spatial_radius: 3.0,
            jacobian_max: 10.0,
            shade_radius: 1,
            shade_contact_ratio: 4.0,
            normal_cos: 0.906,
            plane_tolerance: 0.05,
            boil_factor: 50.0,
            shadow_cos: 0.9,
            shadow_distance_ratio: 1.0,
        }
    }
}

impl RestirConfig {
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("m_clamp", self.m_clamp),
            ("jacobian_max", self.jacobian_max),
            ("plane_tolerance", self.plane_tolerance),
            ("boil_factor", self.boil_factor),
            ("shadow_distance_ratio", self.shadow_distance_ratio),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("{name} must be positive and finite, not {value}"));
            }
        }
        if !(self.shade_contact_ratio.is_finite() && self.shade_contact_ratio >= 0.0) {
            return Err(format!(
                "shade_contact_ratio must be finite and at least 0, not {}",
                self.shade_contact_ratio
            ));
        }
        if !(self.spatial_radius.is_finite() && (0.0..=64.0).contains(&self.spatial_radius)) {
            return Err(format!(
                "spatial_radius must be within 0..=64 trace pixels, not {}",
                self.spatial_radius
            ));
        }
        if self.spatial_samples > 32 {
            return Err(format!(
                "spatial_samples must be at most 32, not {}",
                self.spatial_samples
            ));
        }
        if self.shade_radius > 3 {
            return Err(format!(
                "shade_radius must be at most 3, not {}",
                self.shade_radius
            ));
        }
        for (name, value) in [
            ("normal_cos", self.normal_cos),
            ("shadow_cos", self.shadow_cos),
        ] {
            if !(-1.0..=1.0).contains(&value) {
                return Err(format!("{name} must be within -1..=1, not {value}"));
            }
        }
        Ok(())
    }
}

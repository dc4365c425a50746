//! The mobile tier's configuration: the brick cache it reads, the probe volume, the screen
//! probes and their temporal filter.
//!
//! Every default is justified against the seeds: HSGI (GDC 2023, "Mobile Solution": probe
//! volume of ambient cubes with visibility and relocation, 2 clipmap levels on mobile, one
//! random face per probe and frame; lite deferred G-buffer; 64 x 64-pixel screen tiles with one
//! jittered 4 x 4-texel hemisphere probe; half-resolution gather, temporal filter, bilateral
//! upsample) and SmartGI (SIGGRAPH 2024: 16 x 16-pixel tiles in 2 x 2 virtual groups, one probe
//! recomputed per group per frame, history probes reprojected, mip fallback).

use gi_cache::CacheConfig;

/// Texels per side of a screen probe's hemisphere map (HSGI: 4 x 4). Fixed: the trace and
/// gather shaders run one invocation per texel.
pub const PROBE_TEXELS: u32 = 4;

/// How screen probes are scheduled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScreenProbeMode {
    /// HSGI mobile: every tile gets a freshly traced probe every frame, placed at a jittered
    /// pixel of the tile; tiles whose gather failed get one more probe the next frame.
    Hsgi,
    /// SmartGI: tiles form 2 x 2 virtual groups; one probe per group is traced per frame and the
    /// other three come from the previous frame's probes reprojected to this one (the
    /// geometrically closest history probe wins), with a mip fallback for holes.
    SmartGi,
}

impl ScreenProbeMode {
    pub fn name(self) -> &'static str {
        match self {
            ScreenProbeMode::Hsgi => "hsgi",
            ScreenProbeMode::SmartGi => "smartgi",
        }
    }
}

/// The world-space probe volume (DDGI-style, HSGI's simplified format).
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeConfig {
    /// Clipmap levels (HSGI: 4 on PC, 2 on mobile). Level `k` spaces its probes
    /// `spacing_m * 4^k` apart.
    pub levels: u32,
    /// Probes per level along x, y, z (y is world up), centered on the camera.
    pub probes: [u32; 3],
    /// Distance between neighbouring probes of level 0, meters.
    pub spacing_m: f32,
    /// Rays per active probe per frame, each updating one random face of its ambient cube
    /// (HSGI: 1).
    pub rays_per_probe: u32,
    /// Cap of the temporal weight `1 / min(age, max_age)` of a face's running mean.
    pub max_age: u32,
}

impl Default for VolumeConfig {
    fn default() -> Self {
        Self {
            levels: 2,
            probes: [24, 12, 24],
            spacing_m: 0.5,
            rays_per_probe: 1,
            max_age: 64,
        }
    }
}

/// A probe volume setting the volume cannot run with.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("probe volume setting `{field}` = {value}: {reason}")]
pub struct VolumeConfigError {
    pub field: &'static str,
    pub value: String,
    pub reason: String,
}

impl VolumeConfig {
    /// Most clipmap levels (HSGI's PC tier uses 4).
    pub const MAX_LEVELS: u32 = 4;
    /// Most probe slots over all levels: 2^20 probes of 192 bytes keep every buffer within
    /// the 128 MiB storage binding of the software adapter.
    pub const MAX_SLOTS: u64 = 1 << 20;

    /// Checks every field; the volume refuses a configuration that fails.
    pub fn validate(&self) -> Result<(), VolumeConfigError> {
        let invalid = |field, value: String, reason: &str| {
            Err(VolumeConfigError {
                field,
                value,
                reason: reason.to_string(),
            })
        };
        if self.levels == 0 || self.levels > Self::MAX_LEVELS {
            return invalid(
                "levels",
                self.levels.to_string(),
                &format!("must be 1 to {}", Self::MAX_LEVELS),
            );
        }
        if self.probes.iter().any(|&n| !(2..=256).contains(&n)) {
            return invalid(
                "probes",
                format!("{:?}", self.probes),
                "each must be 2 to 256 (a cell needs two probes per axis)",
            );
        }
        if self.slot_count() > Self::MAX_SLOTS {
            return invalid(
                "probes",
                format!("{:?} x {} levels", self.probes, self.levels),
                &format!("at most {} probes over all levels", Self::MAX_SLOTS),
            );
        }
        if !(self.spacing_m.is_finite() && (1e-3..=1e3).contains(&self.spacing_m)) {
            return invalid(
                "spacing_m",
                self.spacing_m.to_string(),
                "must be between 1 mm and 1 km",
            );
        }
        if !(1..=64).contains(&self.rays_per_probe) {
            return invalid(
                "rays_per_probe",
                self.rays_per_probe.to_string(),
                "must be 1 to 64",
            );
        }
        if !(1..=65_535).contains(&self.max_age) {
            return invalid("max_age", self.max_age.to_string(), "must be 1 to 65535");
        }
        Ok(())
    }

    /// Distance between neighbouring probes of `level`, meters (`spacing_m * 4^level`).
    pub fn spacing_at(&self, level: u32) -> f32 {
        self.spacing_m * 4f32.powi(level as i32)
    }

    /// Probes of one level.
    pub fn probes_per_level(&self) -> u64 {
        self.probes.iter().map(|&n| u64::from(n)).product()
    }

    /// Probe slots of all levels.
    pub fn slot_count(&self) -> u64 {
        self.probes_per_level() * u64::from(self.levels)
    }
}

/// Screen probes, the half-resolution gather, its temporal filter and the upsample.
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenConfig {
    pub mode: ScreenProbeMode,
    /// Pixels per side of a screen tile (one probe per tile). HSGI mobile: 64; SmartGI: 16.
    pub tile_px: u32,
    /// Cap of the per-pixel temporal weight `1 / min(age, max_age)` of the gathered irradiance.
    pub max_age: u32,
    /// Largest distance of a pixel from a probe's tangent plane, as a fraction of the pixel's
    /// distance to the camera, for the probe to count in the gather (depth test).
    pub plane_tolerance: f32,
    /// Least cosine between a pixel's normal and a probe's for the probe to count (normal test).
    pub normal_cos: f32,
    /// Ray origins are offset along the surface normal by this many voxels of the cache level
    /// holding the point, so rays do not hit the voxel of their own surface.
    pub ray_offset_voxels: f32,
    /// Darken the gathered diffuse light by the material's occlusion map (glTF
    /// `occlusionTexture`: "areas that receive less indirect lighting"). Off by default: the
    /// gathered light already holds the occlusion of the geometry the scene has, and a map
    /// baked from that geometry darkens it twice (measured: SheenChair's error against the
    /// reference rose from 1.69 to 2.87 rmse_srgb8 on an H100); on for maps baked from detail
    /// the geometry lacks.
    pub material_occlusion: bool,
    /// After a switch of the lights or materials, read the brick cache's surfels where the
    /// gather reads the probe volume, with short histories, and restart the volume (the tier's
    /// `LightWindow`). On by default; off keeps the volume and the histories as they are (for
    /// comparisons: `gi-bench stability --mobile-without-light-window`).
    pub light_window: bool,
}

impl Default for ScreenConfig {
    fn default() -> Self {
        Self {
            mode: ScreenProbeMode::Hsgi,
            tile_px: 64,
            max_age: 32,
            plane_tolerance: 0.05,
            normal_cos: 0.8,
            ray_offset_voxels: 1.5,
            material_occlusion: false,
            light_window: true,
        }
    }
}

impl ScreenConfig {
    /// SmartGI's economy: 16-pixel tiles in 2 x 2 virtual groups.
    pub fn smartgi() -> Self {
        Self {
            mode: ScreenProbeMode::SmartGi,
            tile_px: 16,
            ..Self::default()
        }
    }
}

/// Everything the mobile tier is made of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MobileConfig {
    pub cache: CacheConfig,
    pub volume: VolumeConfig,
    pub screen: ScreenConfig,
}

impl MobileConfig {
    /// Checks the screen settings (the cache and the volume check their own when created).
    pub fn validate(&self) -> Result<(), String> {
        let screen = &self.screen;
        let check = |ok: bool, field: &str, value: String, reason: &str| {
            if ok {
                Ok(())
            } else {
                Err(format!(
                    "mobile setting `screen.{field}` = {value}: {reason}"
                ))
            }
        };
        check(
            (8..=256).contains(&screen.tile_px),
            "tile_px",
            screen.tile_px.to_string(),
            "must be 8 to 256 pixels",
        )?;
        check(
            (1..=255).contains(&screen.max_age),
            "max_age",
            screen.max_age.to_string(),
            "must be 1 to 255 frames (the history stores it in 8 bits)",
        )?;
        check(
            screen.plane_tolerance.is_finite() && screen.plane_tolerance > 0.0,
            "plane_tolerance",
            screen.plane_tolerance.to_string(),
            "must be a positive fraction of the depth",
        )?;
        check(
            screen.normal_cos.is_finite() && (-1.0..1.0).contains(&screen.normal_cos),
            "normal_cos",
            screen.normal_cos.to_string(),
            "must be a cosine below 1",
        )?;
        check(
            screen.ray_offset_voxels.is_finite() && (0.0..=8.0).contains(&screen.ray_offset_voxels),
            "ray_offset_voxels",
            screen.ray_offset_voxels.to_string(),
            "must be 0 to 8 voxels",
        )
    }
}

//! The cache's configuration: voxel size, levels, window and pool sizes, update budgets.
//!
//! Every number that shapes the cache lives here, with its default justified against the two
//! seeds (HSGI, GDC 2023 "Radiance Cache"; SmartGI, SIGGRAPH 2024 "Bricklizer"). The
//! structural constants that the 64-bit masks impose (4 voxels per brick edge, 4 bricks per
//! group edge) are in [`crate::layout`].

use crate::layout::{BRICK_VOXELS, GROUP_BRICKS, MAX_LEVELS, SIDE_COUNT, VOXELS_PER_BRICK};

/// Most bricks the lighting passes relight in one frame: one workgroup each, along the
/// dispatch's x dimension (at least 65,535 on every adapter).
pub const MAX_LIT_BRICKS: u32 = 65_535;

/// Most hemisphere rays per voxel side per update. `cache/propagate` spreads a side's rays over
/// 4 threads, each ray a walk of at most 2048 cache steps (`CACHE_TRACE_MAX_STEPS`): 64 rays
/// keep one thread within 16 walks, 32,768 steps, half of the 65,535 loop iterations a
/// software Vulkan driver allows an invocation (and a real GPU's watchdog allows a dispatch
/// far more). More rays per update buy less noise than the same rays over more frames.
pub const MAX_GATHER_RAYS_PER_SIDE: u32 = 64;

/// Most updates [`CacheConfig::settle_updates`] may ask for: the lighting schedule keeps a set
/// of brick IDs for each count below it (1.5 KiB each at the default pool), and a brick settled
/// after 255 updates is settled by the round-robin long before.
pub const MAX_SETTLE_UPDATES: u32 = 255;

/// How the cache is shaped and how much work it does per frame.
///
/// Defaults: 7 levels of 32 x 16 x 32 bricks (128 x 64 x 128 voxels) each, finest voxels of
/// 6.25 cm doubling per level, so level 0 covers 8 x 4 x 8 m around the camera and level 6
/// (4 m voxels) covers 512 x 256 x 512 m: the 512 x 512 x 128 m of SmartGI's table with the
/// detail of HSGI's clipmap near the camera (SmartGI's single level of 0.5 m voxels cannot
/// hold a 5 cm wall or a 2 m room). A pool of 12288 bricks keeps the whole cache near 25 MiB,
/// under SmartGI's 28 MB: lighting stored per surfel side (2 per voxel, see
/// [`crate::layout`]) makes a brick cost 2 KiB, half of what 6 axis faces cost, and the
/// bundled scenes need about 10,800 (thin-wall) and 6,800 (atrium) bricks at this shape.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheConfig {
    /// Edge of a level-0 voxel in meters; level `k` voxels are `2^k` times larger. Smaller
    /// voxels hold thinner geometry and sharper lighting at the cost of coverage per level.
    pub voxel_size_m: f32,
    /// Number of clipmap levels (1 to [`MAX_LEVELS`]). Each level doubles the covered extent;
    /// more levels reach further at the cost of one link grid and more bricks each.
    pub levels: u32,
    /// Bricks per level along x, y, z (each a multiple of [`GROUP_BRICKS`]). The window of
    /// every level is this many bricks, centered on the camera; y is world up. Larger windows
    /// keep finer voxels further out at the cost of link-grid memory and more bricks.
    pub level_bricks: [u32; 3],
    /// Bricks the pool can hold (brick IDs `1..=pool_bricks`; 0 means "no brick"). Each costs
    /// [`CacheConfig::bytes_per_brick`] bytes. When the pool runs out, the farthest levels are
    /// left unfilled first.
    pub pool_bricks: u32,
    /// Bricks voxelized per frame at most (the rest wait in a queue, nearest first).
    /// Higher values fill a new view faster at the cost of frame time spikes.
    pub voxelize_bricks_per_frame: u32,
    /// Triangle list entries that binning scans per frame at most: the lists of the grid
    /// cells holding the bricks taken ([`crate::binning::TriangleIndex`]). A brick's binned
    /// triangles, which `cache/voxelize` reads, are among them, so this bounds the CPU's and
    /// the GPU's work per frame where coarse bricks hold tens of thousands of triangles each;
    /// the first cell of a frame is taken whatever its cost, so the fill always advances.
    /// 32,768 by default: flying through Sponza at 1920x1080 on an H100, 65,536 let 13 of 478
    /// frames of the fill's tail spend more than 2 ms of GPU on the cache (up to 2.15 ms);
    /// 32,768 kept every frame within 1.96 ms and drained the queue 12 frames later (46
    /// frames after the first instead of 34; `benchmarks/RESULTS.md`, "Scale").
    pub voxelize_scan_per_frame: u32,
    /// Triangle list entries `cache/voxelize` gives one workgroup at most: a brick's list is
    /// cut into parts of this size, voxelized side by side and merged in list order
    /// ([`crate::voxelize`]). Smaller parts spread a coarse brick's tens of thousands of
    /// triangles over more of the GPU at the cost of 8 KiB of records per part written and
    /// read again; the results do not depend on it beyond the order of f32 sums.
    pub voxelize_part_triangles: u32,
    /// Visible resident bricks `cache/screen_inject` checks against the G-buffer per update at
    /// most, finer levels and nearer bricks first. Higher values correct stale occupancy and
    /// materials further out each frame at the cost of 64 threads per brick, each reading up to
    /// 81 G-buffer pixels.
    pub screen_inject_bricks_per_frame: u32,
    /// Bricks whose lighting (direct and indirect) is updated per frame. The near field
    /// (levels below [`CacheConfig::near_levels`]) gets its share first; HSGI refreshes its
    /// near field every 9 frames and its far field every 121.
    pub light_bricks_per_frame: u32,
    /// Extra bricks relit per frame while some bricks are young (relit fewer than
    /// [`CacheConfig::settle_updates`] times since they were voxelized or the lights last
    /// changed): the near field first, then the fewest-relit, then the finest. Every update of
    /// a brick adds one bounce of light, so after a scene loads, the view jumps or the lights
    /// change the round-robin alone leaves the cache dark or stale for seconds (one update per
    /// brick every 20 frames on a 10,000-brick scene); the extra budget settles it in about a
    /// second and stops costing once every brick is settled. 0 turns it off.
    pub settle_bricks_per_frame: u32,
    /// The settling budget's cap while the young bricks are young because the lights changed
    /// (rather than because they were voxelized): extra bricks relit per frame, at most
    /// [`CacheConfig::settle_bricks_per_frame`]. A scene load or a jump of the view happens
    /// once and may spend more; a light change happens during play, where a frame must stay
    /// within its budget. With the default round-robin budget a relit frame takes 1536 bricks
    /// instead of 2048: a third more frames to settle, a third less extra cost per frame.
    pub relight_bricks_per_frame: u32,
    /// Updates after which a brick counts as settled (see
    /// [`CacheConfig::settle_bricks_per_frame`]). A young brick's updates are also weighed at
    /// least 1/2 ([`crate::lighting::SETTLE_MAX_AGE`]) so that its light follows the bounces it
    /// gains; 0 turns settling off altogether. At most [`MAX_SETTLE_UPDATES`] (the schedule
    /// keeps a set of brick IDs per count).
    pub settle_updates: u32,
    /// Levels counted as near field for the update schedule.
    pub near_levels: u32,
    /// Hemisphere rays per voxel side per indirect update. More rays lower the noise of each
    /// update at a proportional cost; temporal accumulation does the rest.
    pub gather_rays_per_side: u32,
    /// Cap of the temporal accumulation weight `1 / min(age, max_age)`: higher values converge
    /// to a smoother result but follow lighting changes more slowly.
    pub max_age: u32,
    /// How strongly a measured change of the light raises a voxel side's update weight above
    /// `1 / age` ([`crate::lighting`]'s measured change): an update weighs
    /// `max(1 / age, min(change_gain * change, 1))`, where `change` is the share of the light
    /// the side's rays found (or its own direct light) that changed. 0 weighs by age alone; in
    /// a still scene every change is 0 and this has no effect.
    pub change_gain: f32,
    /// Also keep, per voxel side, the part of the indirect irradiance that the emissive
    /// triangles give directly (`cache.emitted`, 512 bytes per brick more), so that a caller
    /// that samples the emitters itself can read the bounced light alone
    /// (`cache_bounced_irradiance` in `shaders/cache/trace.wgsl`). The PC tier does, at its
    /// rays' hits; off, the buffer is a 4-byte placeholder and the lighting does not track it.
    pub keep_emitted: bool,
}

impl Default for CacheConfig {
    fn default() -> Self {
        Self {
            voxel_size_m: 0.0625,
            levels: 7,
            level_bricks: [32, 16, 32],
            pool_bricks: 12288,
            voxelize_bricks_per_frame: 512,
            voxelize_scan_per_frame: 32_768,
            voxelize_part_triangles: 64,
            screen_inject_bricks_per_frame: 2048,
            light_bricks_per_frame: 512,
            settle_bricks_per_frame: 1536,
            relight_bricks_per_frame: 1024,
            settle_updates: 8,
            near_levels: 3,
            gather_rays_per_side: 4,
            max_age: 32,
            change_gain: 3.0,
            keep_emitted: false,
        }
    }
}

/// A configuration the cache cannot run with.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConfigError {
    #[error("cache setting `{field}` = {value}: {reason}")]
    Invalid {
        field: &'static str,
        value: String,
        reason: String,
    },
}

impl CacheConfig {
    /// Checks every field; the cache refuses a configuration that fails.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let invalid = |field, value: String, reason: &str| {
            Err(ConfigError::Invalid {
                field,
                value,
                reason: reason.to_string(),
            })
        };
        if !(self.voxel_size_m.is_finite() && self.voxel_size_m > 1e-4 && self.voxel_size_m < 1e3) {
            return invalid(
                "voxel_size_m",
                self.voxel_size_m.to_string(),
                "must be between 0.1 mm and 1 km",
            );
        }
        if self.levels == 0 || self.levels > MAX_LEVELS {
            return invalid(
                "levels",
                self.levels.to_string(),
                &format!("must be 1 to {MAX_LEVELS}"),
            );
        }
        for (axis, &b) in self.level_bricks.iter().enumerate() {
            if b == 0 || b % GROUP_BRICKS != 0 || b > 256 {
                return invalid(
                    "level_bricks",
                    format!("{:?} (axis {axis})", self.level_bricks),
                    &format!(
                        "each must be a multiple of {GROUP_BRICKS} between {GROUP_BRICKS} and 256"
                    ),
                );
            }
        }
        if self.pool_bricks == 0 || self.pool_bricks > (1 << 22) {
            return invalid(
                "pool_bricks",
                self.pool_bricks.to_string(),
                "must be 1 to 4194304",
            );
        }
        for (field, value) in [
            ("voxelize_bricks_per_frame", self.voxelize_bricks_per_frame),
            ("voxelize_scan_per_frame", self.voxelize_scan_per_frame),
            ("voxelize_part_triangles", self.voxelize_part_triangles),
            (
                "screen_inject_bricks_per_frame",
                self.screen_inject_bricks_per_frame,
            ),
            ("light_bricks_per_frame", self.light_bricks_per_frame),
            ("gather_rays_per_side", self.gather_rays_per_side),
            ("max_age", self.max_age),
        ] {
            if value == 0 {
                return invalid(field, value.to_string(), "must be at least 1");
            }
        }
        if !(self.change_gain.is_finite() && (0.0..=1000.0).contains(&self.change_gain)) {
            return invalid(
                "change_gain",
                self.change_gain.to_string(),
                "must be between 0 and 1000",
            );
        }
        if self.gather_rays_per_side > MAX_GATHER_RAYS_PER_SIDE {
            return invalid(
                "gather_rays_per_side",
                self.gather_rays_per_side.to_string(),
                &format!(
                    "must be at most {MAX_GATHER_RAYS_PER_SIDE} (each update's work per thread is bounded)"
                ),
            );
        }
        if self.settle_updates > MAX_SETTLE_UPDATES {
            return invalid(
                "settle_updates",
                self.settle_updates.to_string(),
                &format!(
                    "must be at most {MAX_SETTLE_UPDATES} (the schedule keeps a set of bricks per count)"
                ),
            );
        }
        if self.max_age > 255 {
            return invalid(
                "max_age",
                self.max_age.to_string(),
                "must fit the 8-bit age",
            );
        }
        let lit = u64::from(self.light_bricks_per_frame) + u64::from(self.settle_bricks_per_frame);
        if lit > u64::from(MAX_LIT_BRICKS) {
            return invalid(
                "settle_bricks_per_frame",
                self.settle_bricks_per_frame.to_string(),
                &format!(
                    "with `light_bricks_per_frame` ({}) must stay within {MAX_LIT_BRICKS} bricks per frame (one workgroup each)",
                    self.light_bricks_per_frame
                ),
            );
        }
        if self.near_levels > self.levels {
            return invalid(
                "near_levels",
                self.near_levels.to_string(),
                "cannot exceed `levels`",
            );
        }
        Ok(())
    }

    /// Edge of a voxel of `level` in meters.
    pub fn voxel_size_at(&self, level: u32) -> f32 {
        self.voxel_size_m * (1u32 << level) as f32
    }

    /// Edge of a brick of `level` in meters.
    pub fn brick_size_at(&self, level: u32) -> f32 {
        self.voxel_size_at(level) * BRICK_VOXELS as f32
    }

    /// Edge of a brick group of `level` in meters (the unit a level's window moves by).
    pub fn group_size_at(&self, level: u32) -> f32 {
        self.brick_size_at(level) * GROUP_BRICKS as f32
    }

    /// Extent in meters (x, y, z) that `level` covers around the camera.
    pub fn level_extent_m(&self, level: u32) -> [f32; 3] {
        self.level_bricks
            .map(|b| b as f32 * self.brick_size_at(level))
    }

    /// Extent in meters of the coarsest level: the cache's coverage.
    pub fn coverage_m(&self) -> [f32; 3] {
        self.level_extent_m(self.levels - 1)
    }

    /// Brick slots of one level's link grid.
    pub fn bricks_per_level(&self) -> u32 {
        self.level_bricks.iter().product()
    }

    /// Brick groups of one level.
    pub fn groups_per_level(&self) -> u32 {
        self.level_bricks.iter().map(|b| b / GROUP_BRICKS).product()
    }

    /// Bytes one pooled brick costs: its 64-bit occupancy mask, 16 bytes of surface per voxel
    /// and two RGB9E5 irradiances (direct, indirect) per voxel side: 8 + 64 x 32 = 2056; with
    /// [`CacheConfig::keep_emitted`] a third (the emitted part): 2568.
    pub fn bytes_per_brick(&self) -> u64 {
        let irradiances = if self.keep_emitted { 3 } else { 2 };
        8 + VOXELS_PER_BRICK as u64 * (16 + irradiances * 4 * SIDE_COUNT as u64)
    }

    /// Bytes of everything the cache allocates on the GPU for this configuration: the pool
    /// (including the unused brick 0), the link grids and the group masks.
    pub fn gpu_bytes(&self) -> u64 {
        let pool = (u64::from(self.pool_bricks) + 1) * self.bytes_per_brick();
        let link = u64::from(self.levels) * u64::from(self.bricks_per_level()) * 4;
        let groups = u64::from(self.levels) * u64::from(self.groups_per_level()) * 8;
        let placeholder = if self.keep_emitted { 0 } else { 4 };
        pool + link + groups + placeholder
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_covers_the_smartgi_volume_within_its_memory() {
        let config = CacheConfig::default();
        config.validate().unwrap();
        let [x, y, z] = config.coverage_m();
        assert!(
            x >= 512.0 && z >= 512.0 && y >= 128.0,
            "coverage {x} x {y} x {z} m"
        );
        assert!(
            config.gpu_bytes() <= 28 * 1024 * 1024,
            "{} bytes",
            config.gpu_bytes()
        );
        assert_eq!(config.level_extent_m(0), [8.0, 4.0, 8.0]);
        assert_eq!(config.bytes_per_brick(), 2056);
        let keeping = CacheConfig {
            keep_emitted: true,
            ..config.clone()
        };
        assert_eq!(keeping.bytes_per_brick(), 2568);
        assert_eq!(config.pool_bricks, 12288);
    }

    #[test]
    fn invalid_settings_name_the_field() {
        let bad = [
            CacheConfig {
                voxel_size_m: 0.0,
                ..Default::default()
            },
            CacheConfig {
                levels: MAX_LEVELS + 1,
                ..Default::default()
            },
            CacheConfig {
                level_bricks: [30, 16, 32],
                ..Default::default()
            },
            CacheConfig {
                pool_bricks: 0,
                ..Default::default()
            },
            CacheConfig {
                max_age: 300,
                ..Default::default()
            },
            CacheConfig {
                gather_rays_per_side: MAX_GATHER_RAYS_PER_SIDE + 1,
                ..Default::default()
            },
            CacheConfig {
                settle_updates: MAX_SETTLE_UPDATES + 1,
                ..Default::default()
            },
        ];
        let fields = [
            "voxel_size_m",
            "levels",
            "level_bricks",
            "pool_bricks",
            "max_age",
            "gather_rays_per_side",
            "settle_updates",
        ];
        for (config, field) in bad.iter().zip(fields) {
            let err = config.validate().unwrap_err().to_string();
            assert!(err.contains(field), "{err}");
        }
    }
}

//! Lighting the cache: which bricks are relit each frame ([`LightSchedule`]) and the passes that
//! relight them ([`CacheLighting`]).
//!
//! - `cache/inject` (`shaders/cache/inject.wgsl`): per voxel side, the irradiance from every
//!   punctual light with an exact BVH shadow ray (HSGI's "Direct Lighting", SmartGI's first
//!   bounce), written to `cache_direct`.
//! - `cache/propagate` (`shaders/cache/propagate.wgsl`): per voxel side,
//!   [`CacheConfig::gather_rays_per_side`] cosine-distributed rays traced through the cache
//!   itself (hits bring the previous frame's reflected side radiance, misses the sky) plus as
//!   many next-event samples of the emissive triangles with BVH shadow rays (emission is
//!   sampled directly rather than found by rare gather hits on small emitters, and never counted
//!   twice). The estimate is accumulated over updates with weight `1 / min(age + 1, max_age)`
//!   (HSGI's hemisphere gather with temporal accumulation, SmartGI's multi bounce), written to
//!   `cache.lighting.scratch`. Every update adds one bounce, so the cache converges to all
//!   bounces.
//! - `cache/propagate_resolve` (`shaders/cache/propagate_resolve.wgsl`): copies the scratch into
//!   `cache_indirect` (and, with `CacheConfig::keep_emitted`, the emitter samples' part of it
//!   into `cache_emitted`) and sets the voxels' ages and measured changes.
//! - `cache/change_age` (`shaders/cache/change_age.wgsl`, first in every update, with a
//!   [`CacheConfig::change_gain`]): counts the frames since each voxel's change was measured.
//!
//! Measured change (temporal gradients for the cache, after A-SVGF, Schied et al. 2018): each
//! voxel's state keeps the share of its reflected light that changed lately (3 bits) and the
//! frames since it was measured (2 bits). `cache/inject` raises it where a side's new direct
//! light differs from the one it had (exact shadow rays: in a still scene the same to the bit,
//! so the change stays 0); `cache/propagate` gathers, with its rays, the changed share g of
//! the light they find, weighs its update `max(1 / age, min(change_gain * max(g, own change),
//! 1))`, lowers the age to match, and passes on half of the larger of its own change and g
//! times the indirect share of its light. A light switched off thus leaves a voxel within a few
//! of its updates however old its history (`a_measured_change_drops_the_old_bounce...` in the
//! tests: 1% of a wall's bounced light left after 4 updates, 12% weighed by age alone). The
//! screen passes that read the cache (the PC tier's gradients, the mobile tier's gather) count a
//! change only in the frame it was measured and the next (`cache_voxel_recent_change`).
//!
//! Propagation gathers from last frame's lighting: `cache/propagate` writes nothing that its own
//! rays read (neither `cache_indirect` nor the ages), so every workgroup sees the cache as the
//! previous update left it and the result does not depend on the order workgroups run in: the
//! same inputs and frames give bit-identical lighting. The direct light it reflects is this
//! frame's, since `cache/inject` is recorded before it (a later pass of the same encoder sees
//! the earlier one's writes); that is deterministic too, and lets a changed light reach the first
//! bounce one update sooner.
//!
//! A voxel's two sides (normals `+n` and `-n`, [`crate::layout`]) are both lit, each at the
//! point half a voxel diagonal off the voxel's center along its normal: beyond the voxel's
//! surface on that side, whatever the normal's direction, and inside the voxel's 3 x 3 x 3
//! neighbourhood. A voxel whose normal is averaged over an edge or corner is lit with that
//! normal from outside the corner; a side facing into solid geometry sees it through its
//! shadow rays and gather. [`side_point`] mirrors `gi::cache::lighting::side_point`.
//!
//! `cache/inject` and `cache/propagate_resolve` run one 64-thread workgroup per scheduled brick
//! (one thread per voxel), on the same list of bricks. `cache/propagate` spends its rays on the
//! occupied voxels only: its first dispatch (`shaders/cache/propagate_list.wgsl`, one workgroup
//! per brick) lists every occupied voxel side, and the second runs 16 listed sides per 64-thread
//! workgroup (eight per brick dispatched; those past the list end at once). Bind group 0 is
//! this module's (uniforms at binding 0, the scene's buffers at `gi::scene`'s bindings 1 to 7,
//! the scheduled bricks at binding 8, the scratch at binding 9, the list at binding 10), group
//! 1 the BVH (not used by `cache/propagate_resolve`; the list's count in
//! `cache/propagate_list`), group 2 the cache.

use bytemuck::{Pod, Zeroable};
use gi_gpu::binding::{buffer_entries, storage_entry, uniform_entry};
use gi_gpu::bvh::GpuBvh;
use gi_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, ShaderLibrary, wgpu};
use gi_scene::{LightKind, Sky, WorldLight};

use crate::buffers::CacheBuffers;
use crate::cache::{CacheFrame, CacheLightingHook, RadianceCache, ResidentBrick};
use crate::config::CacheConfig;
use crate::residency::{IdSet, Residency, bits};

/// How many times more often a near-field brick is relit than a far-field one when the budget
/// is short: HSGI refreshes its near field every 9 frames and its far field every 121
/// (121 / 9 = 13.4).
pub const NEAR_REFRESH_RATIO: u32 = 13;

/// Accumulation cap (the largest age) while the lighting follows a change of the lights or the
/// sky: each update then weighs at least 1/4, so stale light fades by (3/4)^n over n updates,
/// at the cost of 4-update noise while lights keep changing (a moving light).
pub const CHANGED_MAX_AGE: u32 = 4;

/// Accumulation cap of a settling brick's updates ([`LightSchedule::settling`]): every update
/// of a young brick gathers one bounce more than the last, so a long mean would hold it near
/// its first, darkest updates; weighing each new one at least 1/2 follows the rising light, and
/// once settled the ages grow back by one per update towards [`CacheConfig::max_age`].
pub const SETTLE_MAX_AGE: u32 = 2;

/// The lighting counts as converging ([`CacheLightingHook::converging`]) while at least one
/// resident brick in `CONVERGING_FRACTION` is young (fewer than
/// [`CacheConfig::settle_updates`] updates).
pub const CONVERGING_FRACTION: usize = 16;

/// Surfel sides per voxel, one `cache/propagate` list entry each.
const CACHE_SIDES: u64 = crate::layout::SIDE_COUNT as u64;

/// A cache update that voxelizes at least one brick for every `FILL_FRACTION` resident ones is
/// (re)filling the cache: a first fill, or a jump to a new place. Rays traced then pass through
/// space whose bricks are still queued and see the sky where walls will be, so lighting computed
/// during a fill must not be kept as history: those updates store age 0 (weight 1, and the first
/// update after the fill replaces their result).
pub const FILL_FRACTION: usize = 16;

/// Whether an update that voxelized `new_bricks` of `resident_bricks` is a fill (see
/// [`FILL_FRACTION`]); temporal filters that read the cache restart their history then too.
pub fn is_filling(new_bricks: usize, resident_bricks: usize) -> bool {
    new_bricks > 0 && new_bricks * FILL_FRACTION >= resident_bricks
}

/// Seed of the gather's random sequences (each side's sequence is indexed by the update count).
const GATHER_SEED: u32 = 0x6c69_6768;

/// Distance from a voxel's center to the point its sides are lit at, in voxel edges: half the
/// voxel's diagonal, the farthest a plane crossing the voxel lies from its center, so the point
/// is beyond the voxel's surface on that side whatever the normal (`SIDE_OFFSET_VOXELS` in
/// `shaders/cache/lighting.wgsl`).
pub const SIDE_OFFSET_VOXELS: f32 = 0.866_025_4;

/// The point side normal `side_n` of a voxel of edge `size_m` centered at `center` is lit at,
/// as `gi::cache::lighting::side_point` computes it: along `side_n` by
/// [`SIDE_OFFSET_VOXELS`] edges plus a margin that escapes f32 rounding, clamped to the
/// voxel's 3 x 3 x 3 neighbourhood (a guard against a degenerate normal).
pub fn side_point(center: glam::Vec3, size_m: f32, side_n: glam::Vec3) -> glam::Vec3 {
    let margin = (1e-3 * size_m).max(1e-4 * (1.0 + center.abs().max_element()));
    let p = center + side_n * (SIDE_OFFSET_VOXELS * size_m + margin);
    p.clamp(center - size_m, center + size_m)
}

/// The scene's sky as the lighting passes read it (`gi::sky::Sky`, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSky {
    /// Radiance towards +y (gradient), or the constant sky's radiance; w unused.
    pub zenith: [f32; 4],
    /// Radiance at the horizon (gradient only).
    pub horizon: [f32; 4],
    /// Radiance towards -y (gradient only).
    pub ground: [f32; 4],
    /// 0 constant, 1 gradient.
    pub kind: u32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

impl GpuSky {
    /// `sky` for the GPU; the WGSL `sky_radiance` then equals [`Sky::radiance`].
    pub fn new(sky: &Sky) -> Self {
        let rgba = |v: glam::Vec3| v.extend(0.0).to_array();
        match *sky {
            Sky::Constant { radiance } => Self {
                zenith: rgba(radiance),
                ..Self::default()
            },
            Sky::Gradient {
                zenith,
                horizon,
                ground,
            } => Self {
                zenith: rgba(zenith),
                horizon: rgba(horizon),
                ground: rgba(ground),
                kind: 1,
                ..Self::default()
            },
        }
    }
}

/// Uniforms of the lighting passes (`gi::cache::lighting::LightingUniforms`, 112 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLightingUniforms {
    /// What rays leaving the cache see.
    pub sky: GpuSky,
    /// Scheduled bricks this frame (workgroups dispatched).
    pub brick_count: u32,
    /// Punctual lights in the scene's light buffer.
    pub light_count: u32,
    /// [`CacheConfig::gather_rays_per_side`].
    pub rays_per_side: u32,
    /// [`CacheConfig::max_age`], [`CHANGED_MAX_AGE`] while following a lighting change, or 0
    /// during a fill ([`FILL_FRACTION`]: each update replaces and stores age 0).
    pub max_age: u32,
    /// Lighting updates so far (the sample index of every side's random sequence).
    pub frame_index: u32,
    /// Seed of the gather's random sequences.
    pub seed: u32,
    /// Entries of the scene's emitter table.
    pub emitter_count: u32,
    /// Index of the default material in the scene's materials.
    pub default_material: u32,
    /// [`CacheConfig::change_gain`].
    pub change_gain: f32,
    pub pad_a: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// One brick to relight (`gi::cache::lighting::ScheduledBrick`, 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuScheduledBrick {
    /// World brick coordinate at `level`.
    pub brick: [i32; 3],
    pub level: u32,
    /// Pool ID.
    pub brick_id: u32,
    /// Cap of its voxels' ages in this update: the uniforms' `max_age`, at most
    /// [`SETTLE_MAX_AGE`] while the brick settles ([`LightSchedule::settling`]).
    pub max_age: u32,
    pub pad_b: u32,
    pub pad_c: u32,
}

/// The GPU entry of a brick scheduled with age cap `max_age`.
fn scheduled_brick(b: &ResidentBrick, max_age: u32) -> GpuScheduledBrick {
    GpuScheduledBrick {
        brick: b.brick.to_array(),
        level: b.level,
        brick_id: b.brick_id,
        max_age,
        ..Default::default()
    }
}

/// How one frame's lighting budget was spent.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduleCounts {
    /// Bricks voxelized this frame, lit first.
    pub new: u32,
    /// Resident near-field bricks (levels below [`CacheConfig::near_levels`]) relit.
    pub near: u32,
    /// Resident far-field bricks relit.
    pub far: u32,
    /// Young bricks relit from the settling budget
    /// ([`CacheConfig::settle_bricks_per_frame`]).
    pub settle: u32,
    /// Resident bricks still young after this frame (fewer than
    /// [`CacheConfig::settle_updates`] updates); not part of [`ScheduleCounts::total`].
    pub young: u32,
}

impl ScheduleCounts {
    /// Bricks relit this frame.
    pub fn total(&self) -> u32 {
        self.new + self.near + self.far + self.settle
    }
}

/// What [`LightSchedule::pick`] may spend in one frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScheduleBudget {
    /// Bricks relit in every frame: new ones first, then the round-robin
    /// ([`CacheConfig::light_bricks_per_frame`]).
    pub bricks: u32,
    /// Levels below this are the near field ([`CacheConfig::near_levels`]).
    pub near_levels: u32,
    /// Extra bricks for young ones ([`CacheConfig::settle_bricks_per_frame`]).
    pub settle_bricks: u32,
    /// Updates after which a brick is settled ([`CacheConfig::settle_updates`]).
    pub settle_updates: u32,
}

impl ScheduleBudget {
    pub fn new(config: &CacheConfig) -> Self {
        Self {
            bricks: config.light_bricks_per_frame,
            near_levels: config.near_levels,
            settle_bricks: config.settle_bricks_per_frame,
            settle_updates: config.settle_updates,
        }
    }

    /// The budget while the young bricks are young because the lights changed: the settling
    /// budget capped at [`CacheConfig::relight_bricks_per_frame`].
    pub fn relighting(config: &CacheConfig) -> Self {
        Self {
            settle_bricks: config
                .settle_bricks_per_frame
                .min(config.relight_bricks_per_frame),
            ..Self::new(config)
        }
    }

    /// Most bricks one frame relights.
    pub fn max_bricks(&self) -> u32 {
        self.bricks.saturating_add(self.settle_bricks)
    }
}

/// Picks the bricks relit each frame: the newly voxelized bricks first (they have no lighting
/// yet), then a round-robin over the resident near-field and far-field bricks, up to
/// [`ScheduleBudget::bricks`]; then, from a budget of its own, young bricks.
///
/// The budget left after new bricks is split so that a near brick comes round
/// [`NEAR_REFRESH_RATIO`] times as often as a far brick: with `N_near` and `N_far` resident
/// bricks and `B` bricks to spend, the far field gets `B N_far / (13 N_near + N_far)` per frame
/// (kept as a fractional credit, so a small share still comes round), the near field the rest,
/// and whatever a field cannot use (it has fewer bricks than its share) goes to the other. Each
/// field's round-robin walks its bricks in pool-ID order from where the last frame stopped, so
/// bricks that come and go between frames neither reset nor stall it.
///
/// Settling: the schedule counts each brick's updates since it was voxelized or the lights
/// last changed ([`LightSchedule::unsettle`]), up to [`ScheduleBudget::settle_updates`]. Every
/// update adds a bounce, so a brick with few updates still misses light that a converged one
/// has; up to [`ScheduleBudget::settle_bricks`] such young bricks are relit on top of the
/// round-robin: near-field ones first, then the fewest-updated, then finer levels (whose
/// lighting the tiers read near the camera), then by pool ID. Updates during a fill do not
/// count, since the next update replaces their lighting (see [`FILL_FRACTION`]), but they do
/// spend the settling budget: each of their gathers still carries the light one bounce further
/// for the next.
///
/// Cost: the schedule keeps, besides the counts, the IDs of each count below
/// `settle_updates` as a bitset ([`IdSet`]), and reads the resident bricks through the
/// [`Residency`]'s bitsets of levels, so a frame costs a few passes of a word per 64 pool IDs
/// and the bricks it picks, not passes over every resident brick (12,288 at the default pool).
#[derive(Clone, Debug, Default)]
pub struct LightSchedule {
    near_cursor: Option<u32>,
    far_cursor: Option<u32>,
    far_credit: f64,
    /// Updates of each brick, by pool ID, since it was voxelized or the lights last changed,
    /// up to `settle_updates`. A released ID keeps its count until it is voxelized anew
    /// (every pass reads the counts through the residency's levels).
    updates: Vec<u32>,
    /// `young[n]`: the IDs whose count is `n`, for each `n` below `settled`.
    young: Vec<IdSet>,
    /// Members of each of `young`.
    young_counts: Vec<usize>,
    /// The `settle_updates` that `young` was made for.
    settled: u32,
    /// The IDs of the last [`LightSchedule::pick`] that were young when picked.
    settling: IdSet,
    /// Scratch of [`LightSchedule::pick`]: the new bricks picked first, and every pick.
    fresh: IdSet,
    picked: IdSet,
}

impl LightSchedule {
    /// This frame's bricks: `new_bricks` (voxelized this frame) first, then bricks of
    /// `resident` (every allocated brick; new ones are skipped there), at most
    /// `budget.bricks`, then up to `budget.settle_bricks` young ones; none twice. While
    /// `filling` the updates are not counted.
    pub fn pick(
        &mut self,
        budget: &ScheduleBudget,
        new_bricks: &[ResidentBrick],
        resident: &Residency,
        filling: bool,
    ) -> (Vec<ResidentBrick>, ScheduleCounts) {
        let total = budget.bricks as usize;
        let ids = new_bricks
            .iter()
            .map(|b| b.brick_id as usize + 1)
            .max()
            .unwrap_or(0)
            .max(resident.id_bound())
            .max(self.updates.len());
        self.updates.resize(ids, 0);
        let settled = budget.settle_updates;
        if settled != self.settled || self.young.len() != settled as usize {
            self.rebuild_young(settled);
        }

        let mut picked: Vec<ResidentBrick> = new_bricks.iter().take(total).copied().collect();
        for b in new_bricks {
            self.set_updates(b.brick_id, 0);
        }
        // The fields hold the resident bricks not picked as new.
        let near_levels = budget.near_levels.min(resident.levels());
        let (mut near_fresh, mut far_fresh) = (0, 0);
        self.fresh.clear();
        for b in &picked {
            if self.fresh.contains(b.brick_id) {
                continue;
            }
            self.fresh.insert(b.brick_id);
            match resident.get(b.brick_id) {
                Some(r) if r.level < near_levels => near_fresh += 1,
                Some(_) => far_fresh += 1,
                None => {}
            }
        }
        let field_len = |levels: std::ops::Range<u32>| -> usize {
            levels.map(|level| resident.level_len(level)).sum()
        };
        let near_len = field_len(0..near_levels) - near_fresh;
        let far_len = field_len(near_levels..resident.levels()) - far_fresh;

        let remaining = total - picked.len();
        let near_demand = f64::from(NEAR_REFRESH_RATIO) * near_len as f64;
        let far_demand = far_len as f64;
        let mut far_count = 0;
        if far_len == 0 {
            self.far_credit = 0.0;
        } else if remaining > 0 {
            self.far_credit += remaining as f64 * far_demand / (near_demand + far_demand);
            far_count = (self.far_credit.floor() as usize).min(far_len);
            self.far_credit = (self.far_credit - far_count as f64).min(far_len as f64);
        }
        let near_count = (remaining - far_count).min(near_len);
        far_count = (remaining - near_count).min(far_len);

        let mut counts = ScheduleCounts {
            new: picked.len() as u32,
            near: near_count as u32,
            far: far_count as u32,
            settle: 0,
            young: 0,
        };
        let fields = [0..near_levels, near_levels..resident.levels()];
        let field = Field {
            resident,
            levels: fields[0].clone(),
            skip: &self.fresh,
        };
        field.round_robin(&mut self.near_cursor, near_count, &mut picked);
        let field = Field {
            levels: fields[1].clone(),
            ..field
        };
        field.round_robin(&mut self.far_cursor, far_count, &mut picked);

        let words = resident.id_bound().div_ceil(64);
        if budget.settle_bricks > 0 && settled > 0 {
            self.picked.clear();
            for b in &picked {
                self.picked.insert(b.brick_id);
            }
            // Near field first, then fewest updates, finest level, pool ID. The words where a
            // count has unpicked members are found once per count, and each level reads those.
            let mut left = budget.settle_bricks as usize;
            let mut candidates: Vec<(usize, u64)> = Vec::new();
            'fields: for levels in fields {
                for (young, &members) in self.young.iter().zip(&self.young_counts) {
                    if members == 0 {
                        continue;
                    }
                    candidates.clear();
                    candidates.extend((0..words).filter_map(|w| {
                        let word = young.word(w) & !self.picked.word(w);
                        (word != 0).then_some((w, word))
                    }));
                    for level in levels.clone() {
                        let set = resident.level(level);
                        for &(w, young_word) in &candidates {
                            let word = set.word(w) & young_word;
                            for id in bits(word, w) {
                                picked.push(resident.get(id).expect("a member of a level"));
                                counts.settle += 1;
                                left -= 1;
                                if left == 0 {
                                    break 'fields;
                                }
                            }
                        }
                    }
                }
            }
        }
        self.settling.clear();
        for b in &picked {
            let id = b.brick_id;
            let n = self.updates[id as usize];
            if n < settled {
                self.settling.insert(id);
                if !filling {
                    self.set_updates(id, n + 1);
                }
            }
        }
        // Resident bricks with fewer than `settled` updates.
        if settled > 0 {
            counts.young = (0..words)
                .map(|w| {
                    let all =
                        (0..resident.levels()).fold(0, |all, l| all | resident.level(l).word(w));
                    self.young
                        .iter()
                        .map(|young| (young.word(w) & all).count_ones())
                        .sum::<u32>()
                })
                .sum();
        }
        (picked, counts)
    }

    /// Makes every brick young again, as if none had had an update: after the lights change,
    /// the indirect light of every brick holds bounces of the old lights, and as a young brick
    /// each gets the settling budget and weighs its next `settle_updates` updates at least
    /// 1/2 ([`SETTLE_MAX_AGE`]), so the old light fades as `(1/2)^n` rather than with the
    /// round-robin's visits at `1/age`.
    pub fn unsettle(&mut self) {
        self.updates.fill(0);
        self.rebuild_young(self.settled);
    }

    /// Whether brick `brick_id` was young (fewer than `settle_updates` updates) when the last
    /// [`LightSchedule::pick`] picked it.
    pub fn settling(&self, brick_id: u32) -> bool {
        self.settling.contains(brick_id)
    }

    /// Sets the count of `id` (below `updates.len()`), moving it between the young sets.
    fn set_updates(&mut self, id: u32, n: u32) {
        let old = std::mem::replace(&mut self.updates[id as usize], n);
        if let Some(set) = self.young.get_mut(old as usize) {
            set.remove(id);
            self.young_counts[old as usize] -= 1;
        }
        if let Some(set) = self.young.get_mut(n as usize) {
            set.insert(id);
            self.young_counts[n as usize] += 1;
        }
    }

    /// Makes the young sets anew from the counts, for `settled` updates to settle.
    fn rebuild_young(&mut self, settled: u32) {
        self.settled = settled;
        let ids = self.updates.len();
        self.young = vec![IdSet::with_ids(ids); settled as usize];
        self.young_counts = vec![0; settled as usize];
        for (id, &n) in self.updates.iter().enumerate() {
            if let Some(set) = self.young.get_mut(n as usize) {
                set.insert(id as u32);
                self.young_counts[n as usize] += 1;
            }
        }
    }

    /// Resident bricks (of `resident`) relit fewer than `settle_updates` times since they were
    /// voxelized.
    #[cfg(test)]
    fn young_bricks(&self, resident: &[ResidentBrick], settle_updates: u32) -> usize {
        resident
            .iter()
            .filter(|b| {
                self.updates.get(b.brick_id as usize).copied().unwrap_or(0) < settle_updates
            })
            .count()
    }
}

/// The resident bricks of some levels, less those in `skip`: one of the schedule's fields.
#[derive(Clone)]
struct Field<'a> {
    resident: &'a Residency,
    levels: std::ops::Range<u32>,
    skip: &'a IdSet,
}

impl Field<'_> {
    /// The members of pool-ID word `w`.
    fn word(&self, w: usize) -> u64 {
        let members = self
            .levels
            .clone()
            .fold(0, |all, level| all | self.resident.level(level).word(w));
        members & !self.skip.word(w)
    }

    /// Appends `count` bricks (at most the field's) in pool-ID order, starting after the ID
    /// `cursor` and wrapping around, and moves the cursor to the last one taken.
    fn round_robin(&self, cursor: &mut Option<u32>, count: usize, out: &mut Vec<ResidentBrick>) {
        let words = self.resident.id_bound().div_ceil(64);
        if count == 0 || words == 0 {
            return;
        }
        let mut start = cursor.map_or(0, |c| c as usize + 1);
        if start >= words * 64 {
            start = 0;
        }
        let (start_word, start_bit) = (start / 64, start % 64);
        let mut taken = 0;
        // The start word's IDs from the start on first, its IDs before it last.
        for step in 0..=words {
            let w = (start_word + step) % words;
            let mut word = self.word(w);
            if step == 0 {
                word &= !0 << start_bit;
            } else if step == words {
                word &= (1 << start_bit) - 1;
            }
            for id in bits(word, w) {
                out.push(self.resident.get(id).expect("a member of a level"));
                *cursor = Some(id);
                taken += 1;
                if taken == count {
                    return;
                }
            }
        }
    }
}

/// What one frame of lighting needs.
pub struct LightingInputs<'a> {
    /// The scene's sky (rays that leave the cache see it).
    pub sky: &'a Sky,
    /// The frame's punctual lights (the same as `scene.lights`); a change from the previous
    /// update shortens the accumulation for a while (see [`CHANGED_MAX_AGE`]).
    pub lights: &'a [WorldLight],
    /// The frame's scene on the GPU: its punctual lights (`scene.lights`, `light_count`).
    pub scene: &'a GpuScene,
    /// The BVH that shadow rays are traced through (bind group 1).
    pub bvh: &'a GpuBvh,
    /// The cache's bind group (`gi::cache::data`, group 2).
    pub cache_bind_group: &'a wgpu::BindGroup,
    /// Bricks voxelized this frame (relit first, whatever their level).
    pub new_bricks: &'a [ResidentBrick],
    /// Every allocated brick.
    pub resident: &'a Residency,
}

impl<'a> LightingInputs<'a> {
    /// The lighting inputs of one cache update, as [`RadianceCache`]
    /// hands it to its lighting hook.
    pub fn from_frame(frame: &CacheFrame<'a>) -> Self {
        Self {
            sky: &frame.inputs.frame.sky,
            lights: &frame.inputs.frame.lights,
            scene: frame.inputs.gpu_scene,
            bvh: &frame.inputs.gpu_scene.bvh,
            cache_bind_group: &frame.buffers.bind_group,
            new_bricks: frame.new_bricks,
            resident: frame.resident,
        }
    }
}

/// Bytes of `cache.lighting.scratch` per scheduled brick: 64 voxels x 2 sides, each an RGB9E5
/// irradiance and its new age and measured change (one u32 each); with
/// [`CacheConfig::keep_emitted`] a third u32 per side, the emitted part
/// ([`scratch_bytes_per_brick`]).
pub const SCRATCH_BYTES_PER_BRICK: u64 = 64 * 2 * 2 * 4;

/// Bytes of `cache.lighting.scratch` per scheduled brick for a cache of `config`.
pub fn scratch_bytes_per_brick(config: &CacheConfig) -> u64 {
    if config.keep_emitted {
        SCRATCH_BYTES_PER_BRICK / 2 * 3
    } else {
        SCRATCH_BYTES_PER_BRICK
    }
}

/// Bytes of `cache.lighting.list` per scheduled brick: an entry (u32) per voxel side.
pub const LIST_BYTES_PER_BRICK: u64 = 64 * CACHE_SIDES * 4;

/// `cache/propagate` workgroups per scheduled brick (`PROPAGATE_ROWS` in
/// `shaders/cache/propagate.wgsl`): 16 of its at most 128 listed voxel sides each.
const PROPAGATE_ROWS: u32 = 8;

/// Storage buffers `cache/propagate` binds: the lighting's ten (seven of the scene), the BVH's
/// four, the cache's seven.
const LIGHTING_STORAGE_BUFFERS: u32 = 21;

/// The cache's lighting technique: the `cache/inject`, `cache/propagate` and
/// `cache/propagate_resolve` pipelines, the schedule, the per-frame brick list and the
/// propagation's scratch. Memory: the uniforms (112 bytes) and, per brick of the schedule's
/// largest frame ([`ScheduleBudget::max_bricks`]: [`CacheConfig::light_bricks_per_frame`] plus
/// the settling budget), 32 bytes of brick list, [`SCRATCH_BYTES_PER_BRICK`] (1024; 1536 with
/// [`CacheConfig::keep_emitted`]) of scratch and [`LIST_BYTES_PER_BRICK`] (512) of propagation
/// list, counted under `cache.lighting.*` (the default 2048 bricks: 3.2 MB; 4.3 MB keeping
/// the emitted part).
pub struct CacheLighting {
    /// Entry point `inject` of `cache/inject.wgsl`.
    inject: wgpu::ComputePipeline,
    /// Entry point `change_age` of `cache/change_age.wgsl` (with a change gain only).
    change_age: wgpu::ComputePipeline,
    /// Entry point `propagate_list` of `cache/propagate_list.wgsl`.
    propagate_list: wgpu::ComputePipeline,
    /// Entry point `propagate` of `cache/propagate.wgsl`.
    propagate: wgpu::ComputePipeline,
    /// Entry point `propagate_resolve` of `cache/propagate_resolve.wgsl`.
    propagate_resolve: wgpu::ComputePipeline,
    lighting_layout: wgpu::BindGroupLayout,
    /// `cache.lighting.uniforms`: [`GpuLightingUniforms`].
    uniforms: wgpu::Buffer,
    /// `cache.lighting.bricks`: [`GpuScheduledBrick`] per scheduled brick.
    bricks: wgpu::Buffer,
    /// `cache.lighting.scratch`: per scheduled brick, voxel and side, the new RGB9E5 indirect
    /// irradiance `cache/propagate` computed (and its emitted part, when the cache keeps it),
    /// stored by `cache/propagate_resolve`.
    scratch: wgpu::Buffer,
    /// `cache.lighting.list`: the occupied voxel sides of the scheduled bricks
    /// (`cache/propagate_list`), [`LIST_BYTES_PER_BRICK`] per brick of the largest frame.
    list: wgpu::Buffer,
    /// `cache.lighting.list_count`: the entries listed so far, and its bind group (group 1 of
    /// `cache/propagate_list`).
    list_count: wgpu::Buffer,
    list_count_group: wgpu::BindGroup,
    /// `cache.lighting.all_uniforms` and `cache.lighting.all_bricks`: the uniforms and brick
    /// list of `cache/inject_all`, which relights every resident brick's direct light in the
    /// update where the lights change (the list grows with the resident bricks).
    all_uniforms: wgpu::Buffer,
    all_bricks: wgpu::Buffer,
    schedule: LightSchedule,
    config: CacheConfig,
    /// Lighting updates recorded so far.
    updates: u32,
    /// The schedule of the last update.
    last_counts: ScheduleCounts,
    /// Wall-clock milliseconds the last update's schedule took on the CPU.
    last_schedule_ms: f64,
    /// Whether the last update left the lighting converging
    /// ([`CacheLightingHook::converging`]).
    converging: bool,
    /// The lights, sky and material revision of the last update, as bits ([`light_key`]).
    light_key: Vec<u32>,
    /// Updates left with the accumulation capped at [`CHANGED_MAX_AGE`].
    fast_updates_left: u32,
    /// Whether the last update's lights or sky differed from the one's before.
    lights_were_changing: bool,
    /// Whether the bricks were made young by a change of the lights and some still are: the
    /// settling budget is then [`ScheduleBudget::relighting`]'s.
    relighting: bool,
}

impl CacheLighting {
    /// Compiles the passes against the cache's bind group layout `cache_layout`
    /// (`CacheBuffers::bind_group_layout`) and allocates the brick list for `config`.
    pub fn new(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        config: &CacheConfig,
        cache_layout: &wgpu::BindGroupLayout,
    ) -> Result<Self, GpuError> {
        let mut entries = vec![uniform_entry(0)];
        entries.extend(GpuScene::layout_entries());
        entries.extend([
            storage_entry(8, true),
            storage_entry(9, false),
            storage_entry(10, false),
        ]);
        let available = ctx.limits.max_storage_buffers_per_shader_stage;
        if available < LIGHTING_STORAGE_BUFFERS {
            return Err(GpuError::LimitTooSmall {
                limit: "max_storage_buffers_per_shader_stage",
                needed: LIGHTING_STORAGE_BUFFERS.into(),
                available: available.into(),
            });
        }
        let max_bricks = u64::from(ScheduleBudget::new(config).max_bricks().max(1));
        let list_bytes = max_bricks * LIST_BYTES_PER_BRICK;
        let binding_limit = ctx.limits.max_storage_buffer_binding_size;
        if list_bytes > binding_limit {
            return Err(GpuError::LimitTooSmall {
                limit: "max_storage_buffer_binding_size",
                needed: list_bytes,
                available: binding_limit,
            });
        }
        let lighting_layout =
            ctx.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("cache.lighting.layout"),
                    entries: &entries,
                });
        let bvh_layout = GpuBvh::bind_group_layout(ctx);
        let texture_layout = GpuScene::texture_layout(ctx);
        let pipeline = |name: &str, file: &str, groups: &[Option<&wgpu::BindGroupLayout>]| {
            let module = shaders.create_module(ctx, file, &[gi_gpu::ALPHA_TEST])?;
            Ok::<_, GpuError>(ctx.create_compute_pipeline_with_layouts(
                &format!("cache/{name}"),
                &module,
                name,
                groups,
            ))
        };
        let inject = pipeline(
            "inject",
            "cache/inject.wgsl",
            &[
                Some(&lighting_layout),
                Some(&bvh_layout),
                Some(cache_layout),
                Some(&texture_layout),
            ],
        )?;
        let list_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("cache.lighting.list_count_layout"),
                entries: &[storage_entry(0, false)],
            });
        let propagate_list = pipeline(
            "propagate_list",
            "cache/propagate_list.wgsl",
            &[
                Some(&lighting_layout),
                Some(&list_layout),
                Some(cache_layout),
            ],
        )?;
        let propagate = pipeline(
            "propagate",
            "cache/propagate.wgsl",
            &[
                Some(&lighting_layout),
                Some(&bvh_layout),
                Some(cache_layout),
                Some(&texture_layout),
            ],
        )?;
        let change_age = pipeline(
            "change_age",
            "cache/change_age.wgsl",
            &[None, None, Some(cache_layout)],
        )?;
        let propagate_resolve = pipeline(
            "propagate_resolve",
            "cache/propagate_resolve.wgsl",
            &[
                Some(&lighting_layout),
                None,
                Some(cache_layout),
                Some(&texture_layout),
            ],
        )?;
        let uniforms = ctx.create_buffer(
            "cache.lighting.uniforms",
            size_of::<GpuLightingUniforms>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let bricks = ctx.create_buffer(
            "cache.lighting.bricks",
            u64::from(ScheduleBudget::new(config).max_bricks().max(1))
                * size_of::<GpuScheduledBrick>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let scratch = ctx.create_buffer(
            "cache.lighting.scratch",
            u64::from(ScheduleBudget::new(config).max_bricks().max(1))
                * scratch_bytes_per_brick(config),
            wgpu::BufferUsages::STORAGE,
        );
        let list = ctx.create_buffer(
            "cache.lighting.list",
            list_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let list_count = ctx.create_buffer(
            "cache.lighting.list_count",
            4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let list_count_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache.lighting.list_count_bind_group"),
            layout: &list_layout,
            entries: &buffer_entries(0, [&list_count]),
        });
        let all_uniforms = ctx.create_buffer(
            "cache.lighting.all_uniforms",
            size_of::<GpuLightingUniforms>() as u64,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let all_bricks = ctx.create_buffer(
            "cache.lighting.all_bricks",
            size_of::<GpuScheduledBrick>() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        Ok(Self {
            inject,
            change_age,
            propagate_list,
            propagate,
            propagate_resolve,
            lighting_layout,
            uniforms,
            bricks,
            scratch,
            list,
            list_count,
            list_count_group,
            all_uniforms,
            all_bricks,
            schedule: LightSchedule::default(),
            config: config.clone(),
            updates: 0,
            last_counts: ScheduleCounts::default(),
            last_schedule_ms: 0.0,
            converging: false,
            light_key: Vec::new(),
            fast_updates_left: 0,
            lights_were_changing: false,
            relighting: false,
        })
    }

    /// Builds the lighting for `cache`'s configuration and installs it as the cache's
    /// lighting hook, so every cache update ([`RadianceCache`]'s `Technique::record`) relights bricks after voxelizing.
    pub fn attach(
        ctx: &GpuContext,
        shaders: &ShaderLibrary,
        cache: &mut RadianceCache,
    ) -> Result<(), GpuError> {
        let layout = CacheBuffers::bind_group_layout(ctx);
        let lighting = Self::new(ctx, shaders, cache.config(), &layout)?;
        cache.lighting = Some(Box::new(lighting));
        Ok(())
    }

    /// Picks this frame's bricks and records `cache/inject`, `cache/propagate` and
    /// `cache/propagate_resolve` on them into `encoder`, each timed under its name. Records nothing when there is no brick to light.
    /// The brick list and uniforms are written with `queue.write_buffer`, so `encoder` must be
    /// submitted before the next call.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        inputs: &LightingInputs<'_>,
    ) -> ScheduleCounts {
        // A change of the lights or the sky caps the accumulation for `max_age` updates, so
        // history that no longer holds fades within a few updates; ages then grow back by one
        // per update, and so does the smoothing.
        if self.config.change_gain > 0.0 {
            self.record_change_age(ctx, timer, encoder, inputs.cache_bind_group);
        }
        let key = light_key(inputs.lights, inputs.sky, inputs.scene.material_revision());
        let lights_changed = key != self.light_key && self.updates > 0;
        if lights_changed {
            self.fast_updates_left = self.config.max_age;
        }
        // Once the lights hold still after a change, every brick settles again
        // ([`LightSchedule::unsettle`]): the round-robin alone reaches a brick every
        // resident / budget updates, and most had no update within the capped ones above.
        if self.lights_were_changing && !lights_changed {
            self.schedule.unsettle();
            self.relighting = true;
        }
        self.lights_were_changing = lights_changed;
        self.light_key = key;
        let filling = is_filling(inputs.new_bricks.len(), inputs.resident.len());
        let budget = if self.relighting {
            ScheduleBudget::relighting(&self.config)
        } else {
            ScheduleBudget::new(&self.config)
        };
        let clock = std::time::Instant::now();
        let (bricks, counts) =
            self.schedule
                .pick(&budget, inputs.new_bricks, inputs.resident, filling);
        self.last_schedule_ms = clock.elapsed().as_secs_f64() * 1e3;
        self.relighting &= counts.young > 0;
        self.last_counts = counts;
        self.converging = filling
            || self.fast_updates_left > 0
            || counts.young as usize * CONVERGING_FRACTION >= inputs.resident.len().max(1);
        if bricks.is_empty() {
            return counts;
        }
        let max_age = if filling {
            0
        } else if self.fast_updates_left > 0 {
            self.fast_updates_left -= 1;
            CHANGED_MAX_AGE.min(self.config.max_age)
        } else {
            self.config.max_age
        };
        let gpu_bricks: Vec<GpuScheduledBrick> = bricks
            .iter()
            .map(|b| {
                let young = self.schedule.settling(b.brick_id);
                scheduled_brick(
                    b,
                    if young {
                        max_age.min(SETTLE_MAX_AGE)
                    } else {
                        max_age
                    },
                )
            })
            .collect();
        ctx.queue
            .write_buffer(&self.bricks, 0, bytemuck::cast_slice(&gpu_bricks));
        let uniforms = GpuLightingUniforms {
            sky: GpuSky::new(inputs.sky),
            brick_count: bricks.len() as u32,
            light_count: inputs.scene.light_count,
            rays_per_side: self.config.gather_rays_per_side,
            max_age,
            frame_index: self.updates,
            seed: GATHER_SEED,
            emitter_count: inputs.scene.emitter_count,
            default_material: inputs.scene.default_material,
            change_gain: self.config.change_gain,
            ..Default::default()
        };
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        self.updates = self.updates.wrapping_add(1);
        if lights_changed {
            self.record_inject_all(ctx, timer, encoder, inputs, uniforms);
        }

        // Uniforms, the scene's seven buffers (bindings 1..=7), the brick list, the scratch.
        let mut entries = buffer_entries(0, [&self.uniforms]);
        entries.extend(inputs.scene.bind_group_entries());
        entries.extend(buffer_entries(8, [&self.bricks, &self.scratch, &self.list]));
        let lighting_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache.lighting.bind_group"),
            layout: &self.lighting_layout,
            entries: &entries,
        });
        let workgroups = bricks.len() as u32;
        timer.compute_pass(ctx, encoder, "cache/inject", |pass| {
            pass.set_pipeline(&self.inject);
            pass.set_bind_group(0, &lighting_group, &[]);
            pass.set_bind_group(1, &inputs.bvh.bind_group, &[]);
            pass.set_bind_group(2, inputs.cache_bind_group, &[]);
            inputs.scene.set_texture_bind_group(pass);
            pass.dispatch_workgroups(workgroups, 1, 1);
        });
        // The list of occupied voxel sides is made anew: its tail past this frame's entries
        // must read as none, and the count starts at zero.
        let list_bytes = u64::from(workgroups) * LIST_BYTES_PER_BRICK;
        encoder.clear_buffer(&self.list, 0, Some(list_bytes.min(self.list.size())));
        ctx.queue
            .write_buffer(&self.list_count, 0, bytemuck::bytes_of(&0u32));
        timer.compute_pass(ctx, encoder, "cache/propagate", |pass| {
            pass.set_pipeline(&self.propagate_list);
            pass.set_bind_group(0, &lighting_group, &[]);
            pass.set_bind_group(1, &self.list_count_group, &[]);
            pass.set_bind_group(2, inputs.cache_bind_group, &[]);
            pass.dispatch_workgroups(workgroups, 1, 1);
            pass.set_pipeline(&self.propagate);
            pass.set_bind_group(0, &lighting_group, &[]);
            pass.set_bind_group(1, &inputs.bvh.bind_group, &[]);
            pass.set_bind_group(2, inputs.cache_bind_group, &[]);
            inputs.scene.set_texture_bind_group(pass);
            // As many workgroups as the bricks could fill; those past the list stop at once
            // (cheaper than an indirect dispatch and its validation).
            pass.dispatch_workgroups(workgroups, PROPAGATE_ROWS, 1);
        });
        // A pass of its own: the next compute pass sees everything `cache/propagate` wrote.
        timer.compute_pass(ctx, encoder, "cache/propagate_resolve", |pass| {
            pass.set_pipeline(&self.propagate_resolve);
            pass.set_bind_group(0, &lighting_group, &[]);
            pass.set_bind_group(2, inputs.cache_bind_group, &[]);
            inputs.scene.set_texture_bind_group(pass);
            pass.dispatch_workgroups(workgroups, 1, 1);
        });
        counts
    }

    /// Records `cache/change_age` over every brick ID of the pool (`shaders/cache/change_age.wgsl`).
    fn record_change_age(
        &self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        cache_bind_group: &wgpu::BindGroup,
    ) {
        const ROW: u32 = 65_535;
        let bricks = self.config.pool_bricks;
        timer.compute_pass(ctx, encoder, "cache/change_age", |pass| {
            pass.set_pipeline(&self.change_age);
            pass.set_bind_group(2, cache_bind_group, &[]);
            pass.dispatch_workgroups(bricks.min(ROW), bricks.div_ceil(ROW), 1);
        });
    }

    /// Records `cache/inject_all`: the direct light of every resident brick (up to
    /// [`MAX_LIT_BRICKS`](crate::config::MAX_LIT_BRICKS), one dispatch row), so a light that moved or switched shows in the whole cache at once
    /// rather than over the schedule's cycle (HSGI relights its far field every 121 frames).
    /// Direct injection is cheap next to propagation (one shadow ray per light and side); the
    /// indirect light follows through the schedule, its ages pulled down by the change.
    fn record_inject_all(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        inputs: &LightingInputs<'_>,
        mut uniforms: GpuLightingUniforms,
    ) {
        let all: Vec<GpuScheduledBrick> = inputs
            .resident
            .iter()
            .take(crate::config::MAX_LIT_BRICKS as usize)
            .map(|b| scheduled_brick(&b, uniforms.max_age))
            .collect();
        if all.is_empty() {
            return;
        }
        ctx.write_growing(
            &mut self.all_bricks,
            "cache.lighting.all_bricks",
            bytemuck::cast_slice(&all),
        );
        uniforms.brick_count = all.len() as u32;
        ctx.queue
            .write_buffer(&self.all_uniforms, 0, bytemuck::bytes_of(&uniforms));
        let mut entries = buffer_entries(0, [&self.all_uniforms]);
        entries.extend(inputs.scene.bind_group_entries());
        entries.extend(buffer_entries(
            8,
            [&self.all_bricks, &self.scratch, &self.list],
        ));
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cache.lighting.all_bind_group"),
            layout: &self.lighting_layout,
            entries: &entries,
        });
        timer.compute_pass(ctx, encoder, "cache/inject_all", |pass| {
            pass.set_pipeline(&self.inject);
            pass.set_bind_group(0, &group, &[]);
            pass.set_bind_group(1, &inputs.bvh.bind_group, &[]);
            pass.set_bind_group(2, inputs.cache_bind_group, &[]);
            inputs.scene.set_texture_bind_group(pass);
            pass.dispatch_workgroups(all.len() as u32, 1, 1);
        });
    }

    /// How the last update spent its budget.
    pub fn last_counts(&self) -> ScheduleCounts {
        self.last_counts
    }

    /// Lighting updates recorded so far.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// Bytes of the buffers this technique owns.
    pub fn bytes(&self) -> u64 {
        self.uniforms.size()
            + self.bricks.size()
            + self.scratch.size()
            + self.list.size()
            + self.list_count.size()
            + self.all_uniforms.size()
            + self.all_bricks.size()
    }

    /// Stops counting and destroys the buffers.
    pub fn release(self, ctx: &GpuContext) {
        ctx.release_buffer(&self.uniforms);
        ctx.release_buffer(&self.bricks);
        ctx.release_buffer(&self.scratch);
        ctx.release_buffer(&self.list);
        ctx.release_buffer(&self.list_count);
        ctx.release_buffer(&self.all_uniforms);
        ctx.release_buffer(&self.all_bricks);
    }
}

/// Every number that defines what the lights and the sky deliver, as bits: equal keys mean
/// unchanged lighting.
fn light_key(lights: &[WorldLight], sky: &Sky, material_revision: u64) -> Vec<u32> {
    let mut key = Vec::new();
    for light in lights {
        let (kind, inner, outer) = match light.kind {
            LightKind::Directional => (0.0, 0.0, 0.0),
            LightKind::Point => (1.0, 0.0, 0.0),
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => (2.0, inner_cone_angle, outer_cone_angle),
        };
        let values = [kind, inner, outer, light.range.unwrap_or(-1.0)]
            .into_iter()
            .chain(light.position.to_array())
            .chain(light.direction.to_array())
            .chain(light.intensity.to_array());
        key.extend(values.map(f32::to_bits));
    }
    key.extend(bytemuck::cast_slice::<GpuSky, u32>(&[GpuSky::new(sky)]));
    // An edited material may have switched an emitter on or off, or changed what surfaces
    // reflect: a change of the light as much as a lamp's.
    key.extend(bytemuck::cast_slice::<u64, u32>(&[material_revision]));
    key
}

/// The cache's lighting hook: relights this update's bricks with the frame's lights and sky.
impl CacheLightingHook for CacheLighting {
    fn record(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        frame: &CacheFrame<'_>,
    ) {
        CacheLighting::record(
            self,
            ctx,
            timer,
            encoder,
            &LightingInputs::from_frame(frame),
        );
    }

    fn converging(&self) -> bool {
        self.converging
    }

    fn lights_changed(&self) -> bool {
        self.lights_were_changing
    }

    fn schedule_ms(&self) -> f64 {
        self.last_schedule_ms
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use glam::IVec3;

    use super::*;

    /// `bricks` per frame, levels 0 to 2 near, no settling budget.
    fn round_robin_only(bricks: u32) -> ScheduleBudget {
        ScheduleBudget {
            bricks,
            near_levels: 3,
            settle_bricks: 0,
            settle_updates: 8,
        }
    }

    fn bricks(levels: &[(u32, u32)]) -> Vec<ResidentBrick> {
        let mut out = Vec::new();
        let mut id = 1;
        for &(level, count) in levels {
            for i in 0..count {
                out.push(ResidentBrick {
                    level,
                    brick: IVec3::new(i as i32, 0, 0),
                    brick_id: id,
                });
                id += 1;
            }
        }
        out
    }

    #[test]
    fn new_bricks_come_first_and_nothing_repeats_within_a_frame() {
        let resident = bricks(&[(0, 10), (4, 10)]);
        let pool = Residency::from_bricks(8, &resident);
        let new = vec![resident[3], resident[15]];
        let mut schedule = LightSchedule::default();
        let (picked, counts) = schedule.pick(&round_robin_only(8), &new, &pool, false);
        println!("{counts:?}");
        assert_eq!(&picked[..2], &new[..]);
        assert_eq!(picked.len(), 8);
        assert_eq!(counts.total(), 8);
        let unique: HashSet<u32> = picked.iter().map(|b| b.brick_id).collect();
        assert_eq!(unique.len(), picked.len());
        // A budget larger than the cache lights everything once.
        let (all, _) = schedule.pick(&round_robin_only(100), &[], &pool, false);
        assert_eq!(all.len(), resident.len());
    }

    #[test]
    fn near_bricks_come_round_thirteen_times_as_often_as_far_bricks() {
        // 100 near and 1000 far bricks, 40 per frame: every brick is visited, and the refresh
        // periods keep HSGI's near/far ratio.
        let resident = bricks(&[(0, 50), (2, 50), (3, 500), (6, 500)]);
        let pool = Residency::from_bricks(8, &resident);
        let mut schedule = LightSchedule::default();
        let mut visits = vec![0u32; resident.len() + 1];
        let frames = 2000;
        for _ in 0..frames {
            let (picked, counts) = schedule.pick(&round_robin_only(40), &[], &pool, false);
            assert_eq!(counts.total(), 40);
            for b in picked {
                visits[b.brick_id as usize] += 1;
            }
        }
        let mean = |range: std::ops::Range<usize>| {
            let n = range.len() as f64;
            range.map(|i| f64::from(visits[i])).sum::<f64>() / n
        };
        let (near, far) = (mean(1..101), mean(101..1101));
        let ratio = near / far;
        println!(
            "near period {:.1} frames, far period {:.1} frames, ratio {ratio:.2}",
            frames as f64 / near,
            frames as f64 / far
        );
        assert!(
            (ratio - f64::from(NEAR_REFRESH_RATIO)).abs() < 0.5,
            "{ratio}"
        );
        assert!(visits[1..].iter().all(|&v| v > 0));
    }

    /// The schedule written plainly over a list of the resident bricks, sorting where
    /// [`LightSchedule`] walks bitsets: the oracle of `picks_match_a_plain_sort`.
    #[derive(Default)]
    struct ListSchedule {
        near_cursor: Option<u32>,
        far_cursor: Option<u32>,
        far_credit: f64,
        updates: Vec<u32>,
        settling: HashSet<u32>,
    }

    impl ListSchedule {
        fn pick(
            &mut self,
            budget: &ScheduleBudget,
            new: &[ResidentBrick],
            resident: &[ResidentBrick],
            filling: bool,
        ) -> (Vec<ResidentBrick>, ScheduleCounts) {
            let total = budget.bricks as usize;
            let settled = budget.settle_updates;
            let mut picked: Vec<ResidentBrick> = new.iter().take(total).copied().collect();
            let fresh: HashSet<u32> = picked.iter().map(|b| b.brick_id).collect();
            let resident_ids: HashSet<u32> = resident.iter().map(|b| b.brick_id).collect();
            self.updates.resize(1000, 0);
            for b in new {
                self.updates[b.brick_id as usize] = 0;
            }
            for id in 0..1000u32 {
                if !resident_ids.contains(&id) && !fresh.contains(&id) {
                    self.updates[id as usize] = 0;
                }
            }
            let mut sorted = resident.to_vec();
            sorted.sort_by_key(|b| b.brick_id);
            let field = |near: bool| -> Vec<ResidentBrick> {
                sorted
                    .iter()
                    .filter(|b| !fresh.contains(&b.brick_id))
                    .filter(|b| (b.level < budget.near_levels) == near)
                    .copied()
                    .collect()
            };
            let (near, far) = (field(true), field(false));
            let remaining = total - picked.len();
            let mut far_count = 0;
            if far.is_empty() {
                self.far_credit = 0.0;
            } else if remaining > 0 {
                let near_demand = f64::from(NEAR_REFRESH_RATIO) * near.len() as f64;
                self.far_credit +=
                    remaining as f64 * far.len() as f64 / (near_demand + far.len() as f64);
                far_count = (self.far_credit.floor() as usize).min(far.len());
                self.far_credit = (self.far_credit - far_count as f64).min(far.len() as f64);
            }
            let near_count = (remaining - far_count).min(near.len());
            far_count = (remaining - near_count).min(far.len());
            let mut counts = ScheduleCounts {
                new: picked.len() as u32,
                near: near_count as u32,
                far: far_count as u32,
                ..Default::default()
            };
            for (list, cursor, count) in [
                (&near, &mut self.near_cursor, near_count),
                (&far, &mut self.far_cursor, far_count),
            ] {
                if count == 0 {
                    continue;
                }
                let start = cursor.map_or(0, |c| list.partition_point(|b| b.brick_id <= c));
                for i in 0..count {
                    let b = list[(start + i) % list.len()];
                    picked.push(b);
                    *cursor = Some(b.brick_id);
                }
            }
            let taken: HashSet<u32> = picked.iter().map(|b| b.brick_id).collect();
            let mut young: Vec<ResidentBrick> = near
                .iter()
                .chain(&far)
                .filter(|b| self.updates[b.brick_id as usize] < settled)
                .filter(|b| !taken.contains(&b.brick_id))
                .copied()
                .collect();
            young.sort_by_key(|b| {
                (
                    b.level >= budget.near_levels,
                    self.updates[b.brick_id as usize],
                    b.level,
                    b.brick_id,
                )
            });
            young.truncate(budget.settle_bricks as usize);
            counts.settle = young.len() as u32;
            picked.extend(young);
            self.settling.clear();
            for b in &picked {
                let n = &mut self.updates[b.brick_id as usize];
                if *n < settled {
                    self.settling.insert(b.brick_id);
                    if !filling {
                        *n += 1;
                    }
                }
            }
            if settled > 0 {
                counts.young = resident
                    .iter()
                    .filter(|b| self.updates[b.brick_id as usize] < settled)
                    .count() as u32;
            }
            (picked, counts)
        }
    }

    /// The schedule picks, counts and marks as settling exactly what the plain sort does,
    /// frame after frame, while bricks are released and voxelized anew, a fill runs, the
    /// lights change and the budgets change.
    #[test]
    fn picks_match_a_plain_sort() {
        let all = bricks(&[(0, 40), (1, 25), (2, 40), (4, 60), (6, 30)]);
        let (mut fast, mut plain) = (LightSchedule::default(), ListSchedule::default());
        for frame in 0..120usize {
            let budget = ScheduleBudget {
                bricks: [12, 30, 5][frame % 3],
                near_levels: if frame < 60 { 3 } else { 2 },
                settle_bricks: if frame % 11 == 5 {
                    0
                } else {
                    9 + frame as u32 % 4
                },
                settle_updates: if frame < 90 { 3 } else { 5 },
            };
            // Every seventh frame a different tenth of the bricks is away (released), and
            // comes back voxelized anew the frame after.
            let away = |b: &ResidentBrick| frame % 7 == 0 && b.brick_id as usize % 10 == frame % 10;
            let resident: Vec<ResidentBrick> = all.iter().filter(|b| !away(b)).copied().collect();
            let new: Vec<ResidentBrick> = if frame % 7 == 1 {
                all.iter()
                    .filter(|b| b.brick_id as usize % 10 == (frame - 1) % 10)
                    .copied()
                    .collect()
            } else {
                Vec::new()
            };
            if frame == 40 {
                fast.unsettle();
                plain.updates.fill(0);
            }
            let filling = frame < 2;
            let pool = Residency::from_bricks(8, &resident);
            let (a, counts_a) = fast.pick(&budget, &new, &pool, filling);
            let (b, counts_b) = plain.pick(&budget, &new, &resident, filling);
            assert_eq!(a, b, "frame {frame}");
            assert_eq!(counts_a, counts_b, "frame {frame}");
            for brick in &all {
                assert_eq!(
                    fast.settling(brick.brick_id),
                    plain.settling.contains(&brick.brick_id),
                    "frame {frame}"
                );
            }
        }
    }

    #[test]
    fn young_bricks_get_the_settling_budget_until_settled() {
        // 100 near and 100 far bricks, 10 per frame and 30 more for young ones, settled after
        // 3 updates: 600 updates settle them all, which takes 20 frames from the settling
        // budget alone and no fewer than 15 with the round-robin's help.
        let resident = bricks(&[(0, 50), (2, 50), (4, 100)]);
        let pool = Residency::from_bricks(8, &resident);
        let budget = ScheduleBudget {
            bricks: 10,
            near_levels: 3,
            settle_bricks: 30,
            settle_updates: 3,
        };
        let mut schedule = LightSchedule::default();
        // A fill spends the settling budget, but its updates do not count.
        let (picked, counts) = schedule.pick(&budget, &resident[..10], &pool, true);
        assert_eq!((picked.len(), counts.new, counts.settle), (40, 10, 30));
        assert_eq!(schedule.young_bricks(&resident, 3), 200);
        assert_eq!(counts.young, 200);

        let mut updates = vec![0u32; resident.len() + 1];
        let mut frames = 0;
        while schedule.young_bricks(&resident, 3) > 0 {
            let (picked, counts) = schedule.pick(&budget, &[], &pool, false);
            frames += 1;
            assert!(frames <= 20, "still young after {frames} frames");
            assert_eq!(counts.young as usize, schedule.young_bricks(&resident, 3));
            assert_eq!(picked.len() as u32, counts.total());
            let unique: HashSet<u32> = picked.iter().map(|b| b.brick_id).collect();
            assert_eq!(
                unique.len(),
                picked.len(),
                "a brick twice in frame {frames}"
            );
            if frames == 1 {
                // The fewest-updated first, then the finer levels: level 0 before level 2.
                let settling = &picked[counts.total() as usize - counts.settle as usize..];
                assert_eq!(counts.settle, 30);
                assert!(settling.iter().all(|b| b.level == 0), "{settling:?}");
            }
            for b in picked {
                updates[b.brick_id as usize] += 1;
            }
        }
        assert!(frames >= 15, "{frames}");
        assert!(updates[1..].iter().all(|&n| n >= 3), "{updates:?}");
        // Settled: only the round-robin's budget is spent.
        let (picked, counts) = schedule.pick(&budget, &[], &pool, false);
        assert_eq!((picked.len(), counts.settle), (10, 0));

        // A brick voxelized again (a dynamic object moved) is young again: lit as new, then
        // from the settling budget until it has its 3 updates.
        let moved = [resident[150]];
        let (_, counts) = schedule.pick(&budget, &moved, &pool, false);
        assert_eq!((counts.new, counts.settle), (1, 0));
        for expected in [1, 1, 0] {
            let (picked, counts) = schedule.pick(&budget, &[], &pool, false);
            assert_eq!(counts.settle, expected);
            if expected == 1 {
                assert_eq!(picked.last(), Some(&moved[0]));
            }
        }

        // After a change of the lights every brick is young again and is relit from the
        // settling budget until it has its 3 updates, as after the fill.
        schedule.unsettle();
        assert_eq!(schedule.young_bricks(&resident, 3), 200);
        let (picked, counts) = schedule.pick(&budget, &[], &pool, false);
        assert_eq!((picked.len(), counts.settle, counts.young), (40, 30, 200));
        assert!(picked.iter().all(|b| schedule.settling(b.brick_id)));
    }
}

//! [`RadianceCache`]: the cache's resources and its per-frame update.
//!
//! Each update ([`RadianceCache`]'s [`gi_gpu::Technique::record`]):
//! 0. keeps its triangle index while the frame's geometry revision is the same (a static
//!    scene's frames cost no pass over its triangles);
//! 1. re-centers the level windows on the camera; bricks of the slabs that leave are released
//!    (link cleared, ID freed), the slabs that enter are queued (toroidal addressing: nothing
//!    else moves in memory);
//! 2. queues the bricks around every dynamic node that moved (its old and new bounds), to be
//!    voxelized again in place or released when empty; a skinned node moves when one of its
//!    joints does, even where its own transform stays put; and the allocated bricks that the
//!    triangles of an edited material touch ([`SceneFrame::material_revision`]), so their
//!    albedo and emission are voxelized again;
//! 3. queues again bricks that were dropped for lack of pool, when IDs are free;
//! 4. takes up to [`CacheConfig::voxelize_bricks_per_frame`] queued bricks, finer levels and
//!    nearer bricks first, as long as binning them scans at most
//!    [`CacheConfig::voxelize_scan_per_frame`] triangle list entries (the rest wait: a frame's
//!    CPU and `cache/voxelize` work stay bounded where coarse bricks hold tens of thousands of
//!    triangles), bins the frame's triangles to them, allocates IDs (evicting the
//!    farthest brick of a coarser level when the pool is full), links them and records
//!    `cache/voxelize` (lists cut into parts of [`CacheConfig::voxelize_part_triangles`]
//!    voxelized side by side);
//! 5. uploads the changed link and group-mask slots and the uniforms;
//! 6. when [`CacheInputs::gbuffer`] is set, records `cache/screen_inject` over the visible
//!    resident bricks not voxelized in this update ([`crate::screen_inject`]);
//! 7. records the lighting passes, when a [`CacheLightingHook`] is set.
//!
//! The allocated bricks are kept in a [`Residency`] (each pool ID's brick, a bitset of IDs per
//! level) as they are allocated and released, so no step lists or scans the whole pool: the
//! lighting's schedule walks the bitsets, screen injection the windows' group masks, eviction
//! the coarsest levels' members.

use foldhash::{HashSet, HashSetExt};

use gi_gpu::{GpuContext, GpuError, GpuScene, GpuTimer, Recorder, ShaderLibrary, Technique, wgpu};
use gi_scene::{Scene, SceneFrame};
use glam::{IVec3, Vec3};

use crate::alloc::BrickAllocator;
use crate::binning::{CacheScene, FillKey, TriangleIndex, fill_key};
use crate::buffers::{CacheBuffers, cache_uniforms};
use crate::clipmap::{BrickBox, ClipmapWindows};
use crate::config::{CacheConfig, ConfigError};
use crate::fill_queue::FillQueue;
use crate::layout::NO_BRICK;
use crate::residency::Residency;
use crate::screen_inject::{ScreenInjectCounts, ScreenInjector, ScreenInputs, select_bricks};
use crate::structure::CacheStructure;
use crate::voxelize::{VoxelizeJob, Voxelizer};

/// Why a cache could not be created.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A buffer exceeds the device's largest storage binding.
    #[error(
        "cache buffer `{label}` needs {bytes} bytes but the device binds at most {limit}: lower `pool_bricks` (or `levels` / `level_bricks`)"
    )]
    BufferTooLarge {
        label: &'static str,
        bytes: u64,
        limit: u64,
    },
    /// The voxelization pass binds more storage buffers than the device allows per stage.
    #[error(
        "the cache's passes bind {needed} storage buffers per stage; the device allows {available}"
    )]
    TooManyStorageBuffers { needed: u32, available: u32 },
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// What one cache update reads.
pub struct CacheInputs<'a> {
    pub scene: &'a Scene,
    /// `scene` evaluated at this frame's time.
    pub frame: &'a SceneFrame,
    /// `frame` on the GPU: its triangles and materials are read by `cache/voxelize`, its BVH
    /// traced by the lighting passes.
    pub gpu_scene: &'a GpuScene,
    /// Where the level windows are centered.
    pub camera_position: Vec3,
    /// This frame's G-buffer, to correct visible bricks from (`cache/screen_inject`); `None`
    /// skips the pass.
    pub gbuffer: Option<ScreenInputs<'a>>,
}

/// What one cache update produced.
pub struct CacheOutputs<'a> {
    /// What the update did (and whether the cache is filling or converging).
    pub stats: CacheUpdateStats,
    /// The cache's buffers and the bind group that readers bind.
    pub buffers: &'a CacheBuffers,
}

impl Technique for RadianceCache {
    type Inputs<'i> = CacheInputs<'i>;
    type Outputs<'o> = CacheOutputs<'o>;

    /// Updates the cache for one frame (see the module docs) and records its passes. Uploads
    /// go through the queue, so submit what `rec` holds before the next update.
    fn record<'o>(
        &'o mut self,
        rec: &mut Recorder<'_>,
        inputs: &CacheInputs<'_>,
    ) -> CacheOutputs<'o> {
        let (ctx, timer, encoder) = rec.parts();
        self.frame_index = self.frame_index.wrapping_add(1);
        let mut stats = CacheUpdateStats::default();
        let mut clock = StepClock::start();
        let scene = CacheScene::new(inputs.scene, inputs.frame);
        let mut index = match self.triangle_index.take() {
            Some(mut index) => {
                index.update(&self.config, &scene);
                index
            }
            None => TriangleIndex::new(&self.config, &scene),
        };
        stats.cpu.index_ms = clock.lap();
        self.move_windows(&mut index, inputs.camera_position, &mut stats);
        stats.cpu.windows_ms = clock.lap();
        self.queue_moved_dynamic_nodes(&scene, &mut index, &mut stats);
        self.queue_edited_materials(&scene, &mut stats);
        self.requeue_dropped(inputs.camera_position, &mut stats);
        stats.cpu.dynamic_ms = clock.lap();
        let (jobs, new_bricks) =
            self.fill_from_queue(&mut index, inputs.camera_position, &mut stats);
        self.triangle_index = Some(index);
        clock.lap();
        if !self.voxelize_reserved && !self.queue.is_empty() {
            // Bricks wait: full batches follow, so the voxelization's buffers grow to a full
            // batch now rather than step by step in later frames (a buffer created while
            // flying cost a frame 4-6 ms of CPU). A scene that fills at once keeps them small.
            // Counted in the record step.
            self.voxelizer.reserve(
                ctx,
                self.config.voxelize_bricks_per_frame.into(),
                self.config.voxelize_scan_per_frame.into(),
            );
            self.voxelize_reserved = true;
        }

        self.buffers.upload_structure(ctx, &mut self.structure);
        let windows = self.windows.as_ref().expect("placed by move_windows");
        self.buffers.write_uniforms(
            ctx,
            &cache_uniforms(&self.config, windows, self.frame_index),
        );
        let plan =
            self.voxelizer
                .record(ctx, encoder, timer, inputs.gpu_scene, &self.buffers, &jobs);
        stats.voxelize_parts = plan.parts.len() as u32;
        stats.cpu.record_ms = clock.lap();
        stats.filling = crate::lighting::is_filling(new_bricks.len(), self.residency.len());
        if let Some(screen) = &inputs.gbuffer {
            let budget = self.config.screen_inject_bricks_per_frame.min(65_535);
            let bricks = select_bricks(
                &self.config,
                &self.structure,
                windows,
                &screen.camera,
                &new_bricks,
                budget,
            );
            stats.cpu.screen_select_ms = clock.lap();
            stats.screen_injected = bricks.len() as u32;
            self.screen_injector
                .record(ctx, encoder, timer, &self.buffers, screen, &bricks);
        }
        stats.cpu.screen_ms = clock.lap();

        // The lighting passes run here, after voxelization, on the updated cache.
        if let Some(mut lighting) = self.lighting.take() {
            let frame = CacheFrame {
                config: &self.config,
                buffers: &self.buffers,
                inputs,
                new_bricks: &new_bricks,
                resident: &self.residency,
                frame_index: self.frame_index,
            };
            lighting.record(ctx, timer, encoder, &frame);
            stats.converging = stats.filling || lighting.converging();
            stats.lights_changed = lighting.lights_changed();
            self.lighting = Some(lighting);
        }
        stats.cpu.lighting_ms = clock.lap();
        if let Some(lighting) = &self.lighting {
            stats.cpu.schedule_ms = lighting.schedule_ms().min(stats.cpu.lighting_ms);
            stats.cpu.lighting_ms -= stats.cpu.schedule_ms;
        }
        stats.queued_remaining = self.queue.len() as u32;
        CacheOutputs {
            stats,
            buffers: &self.buffers,
        }
    }
}

/// An allocated brick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ResidentBrick {
    pub level: u32,
    /// World brick coordinate at `level`.
    pub brick: IVec3,
    /// Pool ID.
    pub brick_id: u32,
}

/// What the lighting passes get each update.
pub struct CacheFrame<'a> {
    pub config: &'a CacheConfig,
    pub buffers: &'a CacheBuffers,
    pub inputs: &'a CacheInputs<'a>,
    /// Bricks voxelized by this update (their sides' lighting was reset to 0).
    pub new_bricks: &'a [ResidentBrick],
    /// Every allocated brick.
    pub resident: &'a Residency,
    /// Updates so far, this one included.
    pub frame_index: u32,
}

/// Passes recorded after voxelization in every update: the cache's lighting
/// (`lighting.rs` implements it for its `CacheLighting`).
pub trait CacheLightingHook: Send {
    /// Records the passes into `encoder`, timed by `timer`.
    fn record(
        &mut self,
        ctx: &GpuContext,
        timer: &mut GpuTimer,
        encoder: &mut wgpu::CommandEncoder,
        frame: &CacheFrame<'_>,
    );

    /// Whether the lighting is still converging after the last update: many bricks young
    /// (each update adds a bounce) or the lights just changed. Temporal filters that read
    /// the cache should keep short histories then, or they average its darker, staler
    /// updates. False unless the hook says otherwise.
    fn converging(&self) -> bool {
        false
    }

    /// Whether the last update found the lights, the sky or the materials changed since the
    /// one before: what was gathered from the cache before holds light that is gone. False
    /// unless the hook says otherwise.
    fn lights_changed(&self) -> bool {
        false
    }

    /// Wall-clock milliseconds of the last `record` spent choosing what to record (for
    /// [`CpuSteps::schedule_ms`]); 0 unless the hook says otherwise.
    fn schedule_ms(&self) -> f64 {
        0.0
    }
}

/// What one update did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheUpdateStats {
    /// Levels whose window moved.
    pub levels_moved: u32,
    /// Bricks released because their slab left the window.
    pub released_leaving: u32,
    /// Bricks released because their re-voxelization found no triangle.
    pub released_empty: u32,
    /// Bricks queued by entering slabs and the first fill.
    pub queued_entering: u32,
    /// Bricks queued around moved dynamic nodes.
    pub queued_dynamic: u32,
    /// Bricks queued because the material of some of their triangles was edited.
    pub queued_edited: u32,
    /// Bricks voxelized.
    pub voxelized: u32,
    /// Triangle list entries binning scanned for them ([`CacheConfig::voxelize_scan_per_frame`]).
    pub scanned_triangles: u64,
    /// Triangle references binned to them, which `cache/voxelize` reads.
    pub voxelized_triangles: u64,
    /// Parts their lists were cut into (`cache/voxelize` workgroups per part-wise dispatch;
    /// [`CacheConfig::voxelize_part_triangles`]).
    pub voxelize_parts: u32,
    /// Bricks of coarser levels evicted to make room for finer ones.
    pub evicted: u32,
    /// Bricks with geometry left unfilled because the pool was full.
    pub dropped_for_pool: u32,
    /// Bricks dropped for lack of pool (or evicted) earlier and queued again because pool
    /// space was free at this update.
    pub requeued_dropped: u32,
    /// Bricks still queued after this update.
    pub queued_remaining: u32,
    /// Visible bricks checked against the G-buffer (`cache/screen_inject` workgroups).
    pub screen_injected: u32,
    /// The update was a fill ([`crate::lighting::is_filling`]): its lighting keeps no history,
    /// and temporal filters that read the cache should restart theirs.
    pub filling: bool,
    /// The lighting is still converging after a fill or a change of the lights
    /// ([`CacheLightingHook::converging`]): temporal filters that read the cache should keep
    /// short histories.
    pub converging: bool,
    /// The lights, the sky or the materials changed at this update
    /// ([`CacheLightingHook::lights_changed`]): temporal filters that read the cache should
    /// restart what they averaged from it (the cache follows within a few updates).
    pub lights_changed: bool,
    /// Wall-clock milliseconds of the update's CPU steps.
    pub cpu: CpuSteps,
}

/// Wall-clock milliseconds of the CPU steps of one update (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuSteps {
    /// Keeping or rebuilding the triangle index (step 0).
    pub index_ms: f64,
    /// Moving the windows and queuing entering slabs (step 1).
    pub windows_ms: f64,
    /// Queuing around moved dynamic nodes, edited materials and dropped bricks (steps 2 and
    /// 3).
    pub dynamic_ms: f64,
    /// Choosing the bricks to fill within the budgets (step 4).
    pub select_ms: f64,
    /// Binning their triangles (step 4).
    pub binning_ms: f64,
    /// Allocating and linking them (step 4).
    pub allocate_ms: f64,
    /// Uploading the structure and recording `cache/voxelize` (step 5).
    pub record_ms: f64,
    /// Choosing the bricks `cache/screen_inject` corrects (step 6).
    pub screen_select_ms: f64,
    /// Recording `cache/screen_inject` (step 6).
    pub screen_ms: f64,
    /// The lighting's schedule: choosing the bricks relit (step 7).
    pub schedule_ms: f64,
    /// Recording the lighting passes (step 7).
    pub lighting_ms: f64,
}

/// The cache's state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CacheStats {
    pub allocated_bricks: u32,
    pub free_bricks: u32,
    pub queued_bricks: u32,
    /// Allocated bricks per level.
    pub bricks_per_level: Vec<u32>,
    /// Bricks dropped for lack of pool over the cache's life.
    pub dropped_for_pool: u64,
}

/// The radiance cache: its GPU buffers, the CPU structure that places bricks, the fill queue
/// and the voxelization pass.
pub struct RadianceCache {
    config: CacheConfig,
    buffers: CacheBuffers,
    voxelizer: Voxelizer,
    screen_injector: ScreenInjector,
    structure: CacheStructure,
    allocator: BrickAllocator,
    /// `None` until the first update places the windows.
    windows: Option<ClipmapWindows>,
    /// Level and brick of each allocated ID, and the IDs of each level.
    residency: Residency,
    queue: FillQueue,
    /// Bricks with geometry that lost their place for lack of pool (dropped or evicted), queued
    /// again in fill order when IDs are free (`requeue_dropped`).
    dropped: FillQueue,
    /// Node transforms and morph weights of the previous update (its frame without geometry),
    /// to find moved and reshaped dynamic nodes.
    previous_frame: Option<SceneFrame>,
    /// World bounds of each node's triangles at the previous update.
    previous_node_bounds: Vec<Option<(Vec3, Vec3)>>,
    /// The geometry revision those were taken from (0: none).
    previous_revision: u64,
    /// The scene's materials at the last update, and the frame's material revision then: an
    /// edit shows as another revision, and the materials that differ are the edited ones.
    materials: Vec<gi_scene::Material>,
    material_revision: u64,
    /// The previous update's triangles and grids, reused while the triangles stand still.
    triangle_index: Option<TriangleIndex>,
    frame_index: u32,
    dropped_for_pool: u64,
    /// The queue's fill keys, kept between updates so that their memory (hundreds of
    /// kilobytes at a full pool) is not mapped anew.
    keyed: Vec<(FillKey, (u32, IVec3))>,
    /// Whether the voxelization's buffers were grown to a full batch ([`Voxelizer::reserve`]).
    voxelize_reserved: bool,
    /// The lighting passes, recorded after voxelization (see [`CacheLightingHook`]).
    pub lighting: Option<Box<dyn CacheLightingHook>>,
}

/// Storage buffers `cache/voxelize` binds: seven of the scene, four of its own, seven of the cache.
const VOXELIZE_STORAGE_BUFFERS: u32 = 18;

impl RadianceCache {
    /// Validates `config` against itself and the device, creates the buffers (counted under
    /// `cache.*`) and compiles `cache/voxelize`. The cache is empty until the first update.
    pub fn new(ctx: &GpuContext, config: &CacheConfig) -> Result<Self, CacheError> {
        config.validate()?;
        let limit = ctx.limits.max_storage_buffer_binding_size;
        let labels = [
            "cache.uniforms",
            "cache.link",
            "cache.group_masks",
            "cache.brick_masks",
            "cache.voxels",
            "cache.direct",
            "cache.indirect",
            "cache.emitted",
        ];
        for (label, bytes) in labels.into_iter().zip(CacheBuffers::sizes(config)) {
            if bytes > limit {
                return Err(CacheError::BufferTooLarge {
                    label,
                    bytes,
                    limit,
                });
            }
        }
        let available = ctx.limits.max_storage_buffers_per_shader_stage;
        if available < VOXELIZE_STORAGE_BUFFERS {
            return Err(CacheError::TooManyStorageBuffers {
                needed: VOXELIZE_STORAGE_BUFFERS,
                available,
            });
        }
        let shaders = ShaderLibrary::new();
        let voxelizer = Voxelizer::new(ctx, &shaders, config.voxelize_part_triangles)?;
        let screen_injector = ScreenInjector::new(ctx, &shaders)?;
        Ok(Self {
            config: config.clone(),
            buffers: CacheBuffers::new(ctx, config),
            voxelizer,
            screen_injector,
            structure: CacheStructure::new(config),
            allocator: BrickAllocator::new(config.pool_bricks),
            windows: None,
            residency: Residency::new(config.pool_bricks, config.levels),
            queue: FillQueue::new(config.levels),
            dropped: FillQueue::new(config.levels),
            previous_frame: None,
            previous_node_bounds: Vec::new(),
            previous_revision: 0,
            materials: Vec::new(),
            material_revision: 0,
            triangle_index: None,
            frame_index: 0,
            dropped_for_pool: 0,
            lighting: None,
            keyed: Vec::new(),
            voxelize_reserved: false,
        })
    }

    /// The GPU buffers and bind group 2.
    pub fn buffers(&self) -> &CacheBuffers {
        &self.buffers
    }

    pub fn config(&self) -> &CacheConfig {
        &self.config
    }

    /// The CPU mirror of link grids and group masks (brick masks are the GPU's).
    pub fn structure(&self) -> &CacheStructure {
        &self.structure
    }

    /// The level windows (`None` before the first update).
    pub fn windows(&self) -> Option<&ClipmapWindows> {
        self.windows.as_ref()
    }

    /// Bytes of the buffers the context counts under `cache.*` (the bind group's buffers and
    /// the voxelization pass's upload buffers; not the lighting's, which it counts itself).
    pub fn memory_bytes(&self, ctx: &GpuContext) -> u64 {
        let report = ctx.memory();
        report.bytes_with_prefix("cache.") - report.bytes_with_prefix("cache.lighting")
    }

    /// Every allocated brick, in ID order.
    pub fn resident_bricks(&self) -> Vec<ResidentBrick> {
        self.residency.iter().collect()
    }

    pub fn stats(&self) -> CacheStats {
        let bricks_per_level = (0..self.config.levels)
            .map(|level| self.residency.level_len(level) as u32)
            .collect();
        CacheStats {
            allocated_bricks: self.allocator.allocated_count(),
            free_bricks: self.allocator.free_count(),
            queued_bricks: self.queue.len() as u32,
            bricks_per_level,
            dropped_for_pool: self.dropped_for_pool,
        }
    }

    /// Places the windows on the first update (queuing every brick with geometry), else
    /// re-centers them: releases the leaving slabs' bricks and queues the entering slabs'.
    fn move_windows(
        &mut self,
        index: &mut TriangleIndex,
        camera: Vec3,
        stats: &mut CacheUpdateStats,
    ) {
        let Some(windows) = self.windows.as_mut() else {
            let windows = ClipmapWindows::new(&self.config, camera);
            for level in 0..self.config.levels {
                let window = windows.window(level);
                stats.queued_entering += self.queue_geometry(index, level, &window, &window);
            }
            self.windows = Some(windows);
            return;
        };
        let shifts = windows.recenter(&self.config, camera);
        stats.levels_moved = shifts.len() as u32;
        for shift in shifts {
            for slab in &shift.leaving {
                for brick in slab.bricks() {
                    if self.release(shift.level, brick) {
                        stats.released_leaving += 1;
                    }
                }
            }
            for slab in &shift.entering {
                for brick in index.candidate_bricks(shift.level, slab) {
                    stats.queued_entering += u32::from(self.enqueue(shift.level, brick));
                }
            }
        }
    }

    /// Queues every brick of `region` at `level` (inside `window`, the level's window) that
    /// some triangle touches ([`TriangleIndex::candidate_bricks`]); returns how many were
    /// newly queued.
    fn queue_geometry(
        &mut self,
        index: &mut TriangleIndex,
        level: u32,
        region: &BrickBox,
        window: &BrickBox,
    ) -> u32 {
        index
            .candidate_bricks(level, &region.intersection(window))
            .into_iter()
            .map(|brick| u32::from(self.enqueue(level, brick)))
            .sum()
    }

    fn enqueue(&mut self, level: u32, brick: IVec3) -> bool {
        self.queue.push((level, brick))
    }

    /// Empties the slot of `brick` and frees its ID; false when it held none.
    fn release(&mut self, level: u32, brick: IVec3) -> bool {
        let id = self.structure.clear_brick(level, brick);
        if id == NO_BRICK {
            return false;
        }
        self.residency.remove(id);
        // The structure and the allocator change together, so the ID is allocated here.
        self.allocator
            .free(id)
            .expect("a linked brick ID is allocated");
        true
    }

    /// Queues, at every level, the bricks inside the old and the new bounds of each dynamic
    /// node whose geometry moved (its transform changed, for a skinned node one of its joints'
    /// transforms did, or its morph target weights did): allocated ones are voxelized again
    /// (or released when empty), new ones filled.
    fn queue_moved_dynamic_nodes(
        &mut self,
        scene: &CacheScene<'_>,
        index: &mut TriangleIndex,
        stats: &mut CacheUpdateStats,
    ) {
        // Nothing can have moved in the same geometry, and a scene without dynamic nodes has
        // nothing to follow: both skip the pass over every triangle that the bounds take.
        let revision = scene.frame.geometry_revision;
        if revision != 0 && revision == self.previous_revision {
            return;
        }
        if !scene.dynamic_node.contains(&true) {
            self.previous_frame = None;
            self.previous_node_bounds.clear();
            self.previous_revision = 0;
            return;
        }
        let world = &scene.frame.world_from_node;
        let bounds = scene.node_bounds();
        let comparable = |previous: &SceneFrame| {
            previous.world_from_node.len() == world.len()
                && self.previous_node_bounds.len() == bounds.len()
        };
        if let Some(previous_frame) = self.previous_frame.take().filter(comparable) {
            let windows = self.windows.clone().expect("placed by move_windows");
            for (node, &current_bounds) in bounds.iter().enumerate() {
                let moved = (scene.scene).node_geometry_changed(node, &previous_frame, scene.frame);
                if !scene.dynamic_node[node] || !moved {
                    continue;
                }
                for (lo, hi) in [self.previous_node_bounds[node], current_bounds]
                    .into_iter()
                    .flatten()
                {
                    for level in 0..self.config.levels {
                        let window = windows.window(level);
                        let region = BrickBox::from_world(lo, hi, self.config.brick_size_at(level))
                            .intersection(&window);
                        for brick in region.bricks() {
                            // Allocated bricks may have become empty; empty ones may now be hit.
                            if self.structure.brick_id(level, brick) != NO_BRICK {
                                stats.queued_dynamic += u32::from(self.enqueue(level, brick));
                            }
                        }
                        stats.queued_dynamic += self.queue_geometry(index, level, &region, &window);
                    }
                }
            }
        }
        self.previous_frame = Some(scene.frame.without_geometry());
        self.previous_node_bounds = bounds;
        self.previous_revision = revision;
    }

    /// Queues, at every level, the allocated bricks that the triangles of each material edited
    /// since the last update touch (their boxes padded by half a voxel), to be voxelized again
    /// with the material's new albedo and emission. Bricks not allocated read the materials
    /// when they are filled. A pass over the frame's triangles, in the update after an edit
    /// only.
    fn queue_edited_materials(&mut self, scene: &CacheScene<'_>, stats: &mut CacheUpdateStats) {
        let materials = &scene.scene.materials;
        let revision = scene.frame.material_revision;
        if self.materials.len() != materials.len() {
            // The first update (or another scene): what it voxelizes reads these materials.
            self.materials = materials.clone();
            self.material_revision = revision;
            return;
        }
        if revision == self.material_revision {
            return;
        }
        self.material_revision = revision;
        let edited: Vec<bool> = (self.materials.iter().zip(materials))
            .map(|(before, now)| before != now)
            .collect();
        self.materials.clone_from(materials);
        if !edited.contains(&true) {
            return;
        }
        let windows = self.windows.clone().expect("placed by move_windows");
        for (index, attributes) in scene.frame.attributes.iter().enumerate() {
            // Indices out of range take the default material, which is never edited.
            if !edited
                .get(attributes.material as usize)
                .copied()
                .unwrap_or(false)
            {
                continue;
            }
            let [a, b, c] = scene.vertices(index as u32);
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            for level in 0..self.config.levels {
                let size = self.config.brick_size_at(level);
                let pad = Vec3::splat(size / 8.0);
                let region = BrickBox::from_world(lo - pad, hi + pad, size)
                    .intersection(&windows.window(level));
                for brick in region.bricks() {
                    if self.structure.brick_id(level, brick) != NO_BRICK {
                        stats.queued_edited += u32::from(self.enqueue(level, brick));
                    }
                }
            }
        }
    }

    /// Queues again, finest levels and nearest bricks first, as many bricks that lost their place
    /// for lack of pool as there are free IDs (freed by window shifts or empty re-voxelizations);
    /// forgets those whose window moved away (their slab is queued again when it re-enters).
    fn requeue_dropped(&mut self, camera: Vec3, stats: &mut CacheUpdateStats) {
        let windows = self.windows.as_ref().expect("placed by move_windows");
        if stats.levels_moved > 0 {
            self.dropped.retain_inside(windows);
        }
        let free = self.allocator.free_count() as usize;
        if free == 0 || self.dropped.is_empty() {
            return;
        }
        // The first in fill order, keyed from the finest levels only. One queued already (a
        // dynamic node's move queued it before it was evicted) stays queued and takes a place.
        let batch = self
            .dropped
            .take_first(&self.config, camera, free, &mut self.keyed);
        for (level, brick) in batch {
            stats.requeued_dropped += u32::from(self.enqueue(level, brick));
        }
    }

    /// Takes the budget's worth of queued bricks in fill order and prepares their
    /// voxelization: bins, allocates (evicting coarser bricks when the pool is full) and links.
    fn fill_from_queue(
        &mut self,
        index: &mut TriangleIndex,
        camera: Vec3,
        stats: &mut CacheUpdateStats,
    ) -> (Vec<VoxelizeJob>, Vec<ResidentBrick>) {
        let mut clock = StepClock::start();
        let windows = self.windows.clone().expect("placed by move_windows");
        // Bricks whose window moved away are dropped from the queue. Everything queued lies in
        // the windows it was queued in, so only a move leaves bricks outside.
        if stats.levels_moved > 0 {
            self.queue.retain_inside(&windows);
        }
        let take = (self.config.voxelize_bricks_per_frame as usize).min(self.voxelizer.max_jobs());
        let batch = self
            .queue
            .take_first(&self.config, camera, take, &mut self.keyed);
        // Nearest first, then within the scan budget: a cell's list is scanned once for all of
        // its bricks taken, and bricks whose cell does not fit go back to the queue.
        let budget = self.config.voxelize_scan_per_frame as usize;
        let mut scanned = 0usize;
        let mut cells_taken: HashSet<(u32, IVec3)> = HashSet::new();
        let mut kept = Vec::with_capacity(batch.len());
        let mut returned = Vec::new();
        for (level, brick) in batch {
            let cell = (level, index.cell_of(level, brick));
            if cells_taken.contains(&cell) {
                kept.push((level, brick));
                continue;
            }
            let cost = index.scan_cost(level, brick);
            if !cells_taken.is_empty() && scanned + cost > budget {
                returned.push((level, brick));
                continue;
            }
            scanned += cost;
            cells_taken.insert(cell);
            kept.push((level, brick));
        }
        stats.scanned_triangles = scanned as u64;
        self.queue.put_back(returned);
        let batch = kept;

        stats.cpu.select_ms = clock.lap();
        let wanted = batch.len();
        let mut victims = None;
        let mut jobs = Vec::new();
        let mut new_bricks = Vec::new();
        for level in 0..self.config.levels {
            let bricks: Vec<IVec3> = batch
                .iter()
                .filter(|(l, _)| *l == level)
                .map(|(_, b)| *b)
                .collect();
            if bricks.is_empty() {
                continue;
            }
            clock.lap();
            let bins = index.bin_bricks(level, &bricks);
            stats.cpu.binning_ms += clock.lap();
            for (brick, triangles) in bricks.into_iter().zip(bins) {
                if triangles.is_empty() {
                    if self.release(level, brick) {
                        stats.released_empty += 1;
                    }
                    continue;
                }
                let mut id = self.structure.brick_id(level, brick);
                if id == NO_BRICK {
                    id = match self.allocate(level, camera, &mut victims, wanted, stats) {
                        Some(id) => id,
                        None => {
                            if self.dropped_for_pool == 0 {
                                // Once per cache: the GI then misses geometry, and rays
                                // through the holes see the sky (over-bright far walls).
                                tracing::warn!(
                                    "the brick cache's pool of {} bricks is full: bricks with \
                                     geometry are left out from level {level} on, so the GI \
                                     misses that geometry and its rays may see the sky through \
                                     it; raise `CacheConfig::pool_bricks` (`gi render \
                                     --cache-pool-bricks`)",
                                    self.config.pool_bricks
                                );
                            }
                            stats.dropped_for_pool += 1;
                            self.dropped_for_pool += 1;
                            self.dropped.push((level, brick));
                            continue;
                        }
                    };
                    self.structure.set_brick(level, brick, id);
                    self.residency.insert(ResidentBrick {
                        level,
                        brick,
                        brick_id: id,
                    });
                    self.dropped.remove(&(level, brick));
                }
                new_bricks.push(ResidentBrick {
                    level,
                    brick,
                    brick_id: id,
                });
                jobs.push(VoxelizeJob {
                    level,
                    brick,
                    id,
                    triangles,
                });
            }
            stats.cpu.allocate_ms += clock.lap();
        }
        stats.voxelized = jobs.len() as u32;
        stats.voxelized_triangles = jobs.iter().map(|job| job.triangles.len() as u64).sum();
        (jobs, new_bricks)
    }

    /// A free ID, or the ID of the farthest brick of the coarsest level above `level` (evicted
    /// so finer levels are kept), or `None`.
    ///
    /// `victims` holds this update's candidates, last in fill order at the end, made on the
    /// first eviction: the `wanted` last resident bricks in fill order, found in linear time
    /// (a pass over the pool for every eviction cost tens of milliseconds when a frame evicted
    /// hundreds). Fill order goes by level first, so the last resident brick is the victim
    /// when it is coarser than `level`, and no brick is otherwise; the bricks allocated during
    /// the update are never coarser than the one being allocated (levels go in order).
    fn allocate(
        &mut self,
        level: u32,
        camera: Vec3,
        victims: &mut Option<Vec<(u32, IVec3)>>,
        wanted: usize,
        stats: &mut CacheUpdateStats,
    ) -> Option<u32> {
        if let Some(id) = self.allocator.alloc() {
            return Some(id);
        }
        let mut rebuilt = false;
        loop {
            let config = &self.config;
            let residency = &self.residency;
            let list = victims
                .get_or_insert_with(|| eviction_candidates(config, camera, residency, wanted));
            let Some(&victim) = list.last() else {
                // Candidates used up (some were released as empty): look again once.
                if rebuilt {
                    return None;
                }
                rebuilt = true;
                *victims = None;
                continue;
            };
            if victim.0 <= level {
                return None;
            }
            list.pop();
            // A candidate released since (found empty in this update) frees no ID now.
            if self.release(victim.0, victim.1) {
                self.dropped.push(victim);
                stats.evicted += 1;
                return self.allocator.alloc();
            }
        }
    }

    /// What the last `cache/screen_inject` did (stalls; for tests and tools).
    pub fn screen_inject_counts(&self, ctx: &GpuContext) -> ScreenInjectCounts {
        self.screen_injector.read_counts(ctx)
    }

    /// Stops counting and destroys the cache's buffers.
    pub fn release_buffers(self, ctx: &GpuContext) {
        self.buffers.release(ctx);
        self.voxelizer.release(ctx);
        self.screen_injector.release(ctx);
    }
}

/// The `wanted` last resident bricks in fill order ([`fill_key`] from `camera`),
/// the very last at the end: the eviction candidates of an update.
fn eviction_candidates(
    config: &CacheConfig,
    camera: Vec3,
    residency: &Residency,
    wanted: usize,
) -> Vec<(u32, IVec3)> {
    // Fill order goes by level first, so the `wanted` last bricks lie in the coarsest levels
    // that hold that many: only those are keyed, each once.
    let mut finest = residency.levels();
    let mut held = 0;
    while finest > 0 && held < wanted {
        finest -= 1;
        held += residency.level_len(finest);
    }
    let mut keyed: Vec<(FillKey, (u32, IVec3))> = (finest..residency.levels())
        .flat_map(|level| residency.iter_level(level))
        .map(|b| {
            let entry = (b.level, b.brick);
            (fill_key(config, camera, entry), entry)
        })
        .collect();
    let first = keyed.len().saturating_sub(wanted);
    if first > 0 && first < keyed.len() {
        keyed.select_nth_unstable_by_key(first, |(key, _)| *key);
    }
    let mut last = keyed.split_off(first);
    last.sort_unstable_by_key(|(key, _)| *key);
    last.into_iter().map(|(_, entry)| entry).collect()
}

/// Milliseconds between laps.
struct StepClock(std::time::Instant);

impl StepClock {
    fn start() -> Self {
        Self(std::time::Instant::now())
    }

    /// Milliseconds since the last lap (or the start).
    fn lap(&mut self) -> f64 {
        let now = std::time::Instant::now();
        let ms = (now - self.0).as_secs_f64() * 1e3;
        self.0 = now;
        ms
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The candidates keyed from the coarsest levels only are the last bricks of a full sort
    /// in fill order, whichever level the count ends in.
    #[test]
    fn eviction_candidates_are_the_last_in_fill_order() {
        let config = CacheConfig::default();
        let camera = Vec3::new(0.3, -0.2, 1.7);
        let mut bricks = Vec::new();
        let mut id = 1;
        for level in 0..4u32 {
            for i in 0..(40 - 7 * level as i32) {
                bricks.push(ResidentBrick {
                    level,
                    brick: IVec3::new(i % 5 - 2, i / 5 % 3 - 1, i / 15 - 1),
                    brick_id: id,
                });
                // Some IDs free between them.
                id += if i % 4 == 0 { 2 } else { 1 };
            }
        }
        let residency = Residency::from_bricks(config.levels, &bricks);
        let mut all: Vec<(u32, IVec3)> = bricks.iter().map(|b| (b.level, b.brick)).collect();
        all.sort_by_key(|&entry| fill_key(&config, camera, entry));
        for wanted in [0, 1, 5, 19, 20, 45, 60, all.len(), all.len() + 3] {
            let expected = all[all.len() - wanted.min(all.len())..].to_vec();
            assert_eq!(
                eviction_candidates(&config, camera, &residency, wanted),
                expected,
                "wanted {wanted}"
            );
        }
    }
}

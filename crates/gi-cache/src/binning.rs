//! Which triangles touch which bricks: the CPU side of voxelization.
//!
//! Before a brick is voxelized (on the GPU or by [`crate::cpu_voxelize`]), the CPU collects the
//! triangles overlapping its box with the same exact test the voxelizer applies per voxel
//! ([`triangle_box_overlap`]), so a brick gets a pool ID only when some triangle touches it.
//! Triangles are referenced by their index in [`SceneFrame::triangles`] (the order `GpuScene`
//! uploads them in), with bit 31 set when the triangle belongs to a dynamic node.

use foldhash::{HashMap, HashMapExt, HashSet};

use gi_scene::{Scene, SceneFrame};
use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::clipmap::BrickBox;
use crate::config::CacheConfig;
use crate::cpu_voxelize::triangle_box_overlap;
use crate::layout::GROUP_BRICKS;

/// Bit of a binned triangle reference marking a dynamic node's triangle.
pub const TRIANGLE_DYNAMIC_BIT: u32 = 1 << 31;

/// `dynamic[node]`: the node or one of its ancestors is moved by an animation channel, or the
/// node deforms (skinned with a moving joint, or morphed by animated weights;
/// [`Scene::deforming_nodes`]), so its triangles may move from frame to frame.
pub fn dynamic_nodes(scene: &Scene) -> Vec<bool> {
    let (moving, deforming) = scene.moving_and_deforming_nodes();
    moving
        .into_iter()
        .zip(deforming)
        .map(|(moving, deforming)| moving || deforming)
        .collect()
}

/// `dynamic[triangle]` for each triangle of `frame`: its node is moved by an animation or
/// deformed by animated joints or weights ([`dynamic_nodes`]).
pub fn dynamic_triangles(scene: &Scene, frame: &SceneFrame) -> Vec<bool> {
    let dynamic = dynamic_nodes(scene);
    frame
        .attributes
        .iter()
        .map(|a| dynamic.get(a.node as usize).copied().unwrap_or(false))
        .collect()
}

/// A scene frame as the cache sees it: the triangles with their dynamic flags.
pub struct CacheScene<'a> {
    pub scene: &'a Scene,
    pub frame: &'a SceneFrame,
    /// Per node, see [`dynamic_nodes`].
    pub dynamic_node: Vec<bool>,
}

impl<'a> CacheScene<'a> {
    /// `frame` (an evaluation of `scene`) with its dynamic nodes.
    pub fn new(scene: &'a Scene, frame: &'a SceneFrame) -> Self {
        Self {
            scene,
            frame,
            dynamic_node: dynamic_nodes(scene),
        }
    }

    /// Vertices of frame triangle `index`.
    pub fn vertices(&self, index: u32) -> [Vec3; 3] {
        let t = &self.frame.triangles[index as usize];
        [t.v0.into(), t.v1.into(), t.v2.into()]
    }

    /// The binned reference of triangle `index`: the index with [`TRIANGLE_DYNAMIC_BIT`] set
    /// when its node is dynamic.
    pub fn reference(&self, index: u32) -> u32 {
        let node = self.frame.attributes[index as usize].node as usize;
        let dynamic = self.dynamic_node.get(node).copied().unwrap_or(false);
        index | if dynamic { TRIANGLE_DYNAMIC_BIT } else { 0 }
    }

    /// World bounds of the triangles of every node (`None` for nodes without triangles).
    pub fn node_bounds(&self) -> Vec<Option<(Vec3, Vec3)>> {
        let mut bounds: Vec<Option<(Vec3, Vec3)>> = vec![None; self.scene.nodes.len()];
        for (index, attributes) in self.frame.attributes.iter().enumerate() {
            let [a, b, c] = self.vertices(index as u32);
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            if let Some(slot) = bounds.get_mut(attributes.node as usize) {
                *slot = Some(match *slot {
                    Some((l, h)) => (l.min(lo), h.max(hi)),
                    None => (lo, hi),
                });
            }
        }
        bounds
    }
}

/// Triangle lists per brick: what binning returns ([`bin_triangles`], [`TriangleIndex`]).
pub type Bins = HashMap<IVec3, Vec<u32>>;

/// Box of world brick `brick` at `level`: center and half edge in meters.
pub fn brick_box(config: &CacheConfig, level: u32, brick: IVec3) -> (Vec3, f32) {
    let brick_size = config.brick_size_at(level);
    let center = (brick.as_vec3() + 0.5) * brick_size;
    (center, 0.5 * brick_size)
}

/// The triangles (binned references) overlapping each brick of `region` at `level`, for the
/// triangles `indices` of the frame. Bricks no triangle touches are absent. Each list keeps the
/// order of `indices`.
pub fn bin_triangles(
    config: &CacheConfig,
    scene: &CacheScene<'_>,
    level: u32,
    region: &BrickBox,
    indices: impl IntoIterator<Item = u32>,
) -> Bins {
    let brick_size = config.brick_size_at(level);
    let mut bins = Bins::new();
    for index in indices {
        let [a, b, c] = scene.vertices(index);
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            continue;
        }
        let bounds =
            BrickBox::from_world(a.min(b).min(c), a.max(b).max(c), brick_size).intersection(region);
        if bounds.is_empty() {
            continue;
        }
        let reference = scene.reference(index);
        for brick in bounds.bricks() {
            let (center, half) = brick_box(config, level, brick);
            if triangle_box_overlap([a, b, c], center, half) {
                bins.entry(brick).or_default().push(reference);
            }
        }
    }
    bins
}

/// List entries from which [`TriangleIndex::bin_bricks`] bins cells on all cores; below it,
/// sharing the work costs more than it saves.
const PARALLEL_BIN_ENTRIES: usize = 32_768;

/// The place of a binned reference in frame order: its triangle index, without the dynamic
/// flag.
fn frame_order(reference: u32) -> u32 {
    reference & !TRIANGLE_DYNAMIC_BIT
}

/// The references of `a` and `b`, both in frame order, merged in frame order (`a`'s first
/// among equals).
fn merge_in_frame_order(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut merged = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if frame_order(b[j]) < frame_order(a[i]) {
            merged.push(b[j]);
            j += 1;
        } else {
            merged.push(a[i]);
            i += 1;
        }
    }
    merged.extend_from_slice(&a[i..]);
    merged.extend_from_slice(&b[j..]);
    merged
}

/// The rank of bit `bit` among the set bits of `mask`: how many lower bits are set.
fn rank_of(mask: u64, bit: u32) -> usize {
    (mask & ((1u64 << bit) - 1)).count_ones() as usize
}

/// Calls `f` with every set bit of `mask`, lowest first.
fn for_each_bit(mut mask: u64, mut f: impl FnMut(u32)) {
    while mask != 0 {
        f(mask.trailing_zeros());
        mask &= mask - 1;
    }
}

/// Fill order of bricks: finer levels first, then nearer bricks (distance from the camera to
/// the brick center in bricks of its level). Smaller keys fill first; when the pool runs out,
/// what is left unfilled is the coarse and far end of this order. Bricks at the same distance
/// tie here: [`fill_key`] breaks the ties.
pub fn fill_priority(
    config: &CacheConfig,
    level: u32,
    brick: IVec3,
    camera_position: Vec3,
) -> (u32, f32) {
    let (center, _) = brick_box(config, level, brick);
    (
        level,
        (center - camera_position).length() / config.brick_size_at(level),
    )
}

/// The key of `entry` in the fill order: [`fill_priority`]'s order as a total order. Ties
/// (bricks at the same distance, which a symmetric view has many of) go by brick coordinates,
/// z, then y, then x. The fill order decides which pool ID a brick gets and so when the lighting
/// schedule's round-robin reaches it: with ties left to the order the entries arrived in (hash
/// order, which differs from run to run) the same scene lit the same way gave different
/// images. One key per entry: sorting many entries computes each distance once.
pub fn fill_key(config: &CacheConfig, camera_position: Vec3, entry: (u32, IVec3)) -> FillKey {
    let (level, distance) = fill_priority(config, entry.0, entry.1, camera_position);
    FillKey {
        level,
        distance,
        brick: entry.1,
    }
}

/// A brick's place in the fill order ([`fill_key`]).
#[derive(Clone, Copy, Debug)]
pub struct FillKey {
    level: u32,
    distance: f32,
    brick: IVec3,
}

impl Ord for FillKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        let zyx = |b: IVec3| (b.z, b.y, b.x);
        self.level
            .cmp(&other.level)
            .then(self.distance.total_cmp(&other.distance))
            .then_with(|| zyx(self.brick).cmp(&zyx(other.brick)))
    }
}

impl PartialOrd for FillKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for FillKey {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other).is_eq()
    }
}

impl Eq for FillKey {}

/// A frame's triangles prepared for binning, with a grid of triangle lists per level so a
/// region or brick is tested only against the triangles near it, not the whole frame.
///
/// Built once per frame geometry ([`TriangleIndex::update`]): the triangles' vertices, bounds
/// and references are read once, and every level gets a world-space grid of cells of about
/// 2 m (`cell_bricks`: up to [`GROUP_BRICKS`] bricks per axis at fine levels, one brick at
/// coarse ones), built for all levels at once on all cores. The
/// grids do not depend on the clipmap windows, so a window that moves costs only the lookups of
/// the cells its entering bricks lie in, whatever the scene's size. A cell lists every triangle
/// that overlaps one of its bricks (the exact test of [`bin_triangles`]), in frame order, with
/// the bricks it overlaps as a mask, so the bins are exactly [`bin_triangles`]'s, lists in the
/// same order, and binning a brick tests no triangle again: the tests were run once, when the
/// grid was built. Memory: 12 bytes per (triangle, cell) pair at levels whose cells hold
/// several bricks, 4 bytes where a cell is one brick (the mask is then implied).
pub struct TriangleIndex {
    /// Brick edge in meters per level.
    brick_size_m: Vec<f32>,
    /// The frame's triangles as given, the revision of the frame's geometry and the scene's
    /// dynamic-node flags, which [`TriangleIndex::update`] compares with the next frame's
    /// before preparing anything.
    source: Vec<obvhs::triangle::Triangle>,
    revision: u64,
    dynamic_node: Vec<bool>,
    /// The frame's triangles with finite vertices, in frame order.
    triangles: Vec<PreparedTriangle>,
    /// Per level, the grid of triangle lists.
    grids: Vec<LevelGrid>,
}

/// One triangle as binning reads it.
#[derive(Clone, PartialEq)]
struct PreparedTriangle {
    vertices: [Vec3; 3],
    lo: Vec3,
    hi: Vec3,
    /// See [`CacheScene::reference`].
    reference: u32,
}

/// [`triangle_box_overlap`] of a prepared triangle and the brick of center `center` and half
/// edge `half`, with a shortcut for the common case at coarse levels: a triangle of nonzero
/// area whose bounds lie inside the box, a thousandth of its edge from every face, overlaps it,
/// and the exact test would say so too (every separating-axis projection is then smaller
/// than the box's radius by far more than rounding), so it is not run.
fn overlaps_brick(triangle: &PreparedTriangle, center: Vec3, half: f32) -> bool {
    let inner = Vec3::splat(half * (1.0 - 1e-3));
    if (triangle.lo - center).cmpgt(-inner).all() && (triangle.hi - center).cmplt(inner).all() {
        let [v0, v1, v2] = triangle.vertices.map(|p| p - center);
        if (v1 - v0).cross(v2 - v1) != Vec3::ZERO {
            return true;
        }
    }
    triangle_box_overlap(triangle.vertices, center, half)
}

/// Triangles per part of a level's grid built on one core ([`LevelGrid::build`]).
const BUILD_CHUNK: usize = 1 << 15;

/// Triangles whose brick bounds span more grid cells than this are kept in their level's
/// `large` list (and listed per block of cells), which queries test, instead of being listed
/// in each cell, unless they are wide ([`WIDE_TRIANGLE_CELLS`]): a few huge triangles (a
/// ground plane under a city) would otherwise fill millions of cells.
const LARGE_TRIANGLE_CELLS: u64 = 64;

/// Triangles spanning more than [`LARGE_TRIANGLE_CELLS`] cells but at most this many are
/// still listed in their cells while the level's budget of such (triangle, cell) pairs
/// ([`WIDE_PAIRS_PER_LEVEL`]) lasts: a floor or wall then costs binning no test at all,
/// whereas a large triangle is tested in every cell binned near it (Sponza has 540 at the
/// finest level).
const WIDE_TRIANGLE_CELLS: u64 = 1024;

/// (triangle, cell) pairs per level that triangles wider than [`LARGE_TRIANGLE_CELLS`] may
/// add to the cell lists (12 bytes each: 48 MiB at most), shared evenly by the parts of the
/// grid's build, so that the grid is the same however its parts are scheduled.
const WIDE_PAIRS_PER_LEVEL: u64 = 1 << 22;

/// Cells per block edge of [`LevelGrid::large_blocks`].
const LARGE_BLOCK_CELLS: i32 = 8;

/// Brick coordinates beyond this magnitude are not gridded (their triangles go to the
/// `large` list): the integer brick arithmetic stays far from overflow.
const MAX_GRID_BRICK: f32 = (1 << 28) as f32;

/// Triangle lists per world-space cell of `cell_bricks`³ bricks at one level.
struct LevelGrid {
    /// Bricks per cell edge ([`cell_bricks`]).
    cell_bricks: i32,
    /// Per cell, the triangles overlapping its bricks.
    cells: HashMap<IVec3, CellList>,
    /// Triangles too large for the cells (see [`LARGE_TRIANGLE_CELLS`]), in frame order.
    large: Vec<u32>,
    /// The large triangles again, listed per block of [`LARGE_BLOCK_CELLS`]³ cells whose
    /// cells their brick bounds touch, so binning a cell reads its block's list rather than
    /// every large triangle (Sponza's floors and walls make hundreds at the finest level).
    large_blocks: HashMap<IVec3, Vec<u32>>,
    /// The large triangles whose bounds span more than [`LARGE_TRIANGLE_CELLS`] blocks (or
    /// are not gridded), which binning any cell tests.
    huge: Vec<u32>,
}

/// The triangles of one grid cell that overlap at least one of its bricks.
#[derive(Default)]
struct CellList {
    /// The triangles' references ([`CacheScene::reference`]), in frame order: binning reads
    /// them here rather than from the frame's triangles, scattered over memory.
    references: Vec<u32>,
    /// Per entry, the bricks it overlaps ([`LevelGrid::brick_bit`]); empty when the cell is
    /// one brick, which every entry then overlaps.
    masks: Vec<u64>,
    /// The bricks that some entry overlaps (the exact test of the bins), read without
    /// testing a triangle again.
    occupied: u64,
}

impl CellList {
    /// Appends `other`, whose entries come after this list's in frame order.
    fn extend(&mut self, other: CellList) {
        self.references.extend(other.references);
        self.masks.extend(other.masks);
        self.occupied |= other.occupied;
    }

    /// The bricks entry `i` overlaps.
    fn mask(&self, i: usize) -> u64 {
        self.masks.get(i).copied().unwrap_or(1)
    }
}

/// Bricks per cell edge at bricks of `brick_size_m`: cells of about 2 m (at most
/// [`GROUP_BRICKS`] bricks, at least one). Binning a brick scans its cell's whole list, so
/// coarse levels, whose bricks hold many triangles, get one brick per cell; fine levels group
/// bricks so that a floor triangle does not have to be listed in hundreds of cells.
fn cell_bricks(brick_size_m: f32) -> i32 {
    ((2.0 / brick_size_m).floor() as i32).clamp(1, GROUP_BRICKS as i32)
}

/// The blocks of [`LevelGrid::large_blocks`] holding the cells of `cells`.
fn blocks_of(cells: &BrickBox) -> BrickBox {
    let block = IVec3::splat(LARGE_BLOCK_CELLS);
    BrickBox {
        min: cells.min.div_euclid(block),
        max: (cells.max - IVec3::ONE).div_euclid(block) + IVec3::ONE,
    }
}

impl LevelGrid {
    /// The cells (as a box of cell coordinates) that the bricks of `bricks` lie in.
    fn cells_of(&self, bricks: &BrickBox) -> BrickBox {
        let cell = IVec3::splat(self.cell_bricks);
        BrickBox {
            min: bricks.min.div_euclid(cell),
            max: (bricks.max - IVec3::ONE).div_euclid(cell) + IVec3::ONE,
        }
    }

    /// The cell holding `brick`.
    fn cell_of(&self, brick: IVec3) -> IVec3 {
        brick.div_euclid(IVec3::splat(self.cell_bricks))
    }

    /// The mask of the bricks of cell `cell` inside `region`.
    fn region_mask(&self, cell: IVec3, region: &BrickBox) -> u64 {
        self.cell_box(cell)
            .intersection(region)
            .bricks()
            .fold(0, |mask, brick| mask | 1 << self.brick_bit(cell, brick))
    }

    /// The brick of bit `bit` of cell `cell`.
    fn brick_of_bit(&self, cell: IVec3, bit: u32) -> IVec3 {
        let n = self.cell_bricks as u32;
        let local = IVec3::new(
            (bit % n) as i32,
            (bit / n % n) as i32,
            (bit / (n * n)) as i32,
        );
        cell * self.cell_bricks + local
    }

    /// Bit of `brick` (in cell `cell`) in a 64-bit mask of the cell's bricks.
    fn brick_bit(&self, cell: IVec3, brick: IVec3) -> u32 {
        let local = brick - cell * self.cell_bricks;
        (local.x + self.cell_bricks * (local.y + self.cell_bricks * local.z)) as u32
    }

    /// The bricks of cell `cell`.
    fn cell_box(&self, cell: IVec3) -> BrickBox {
        let min = cell * self.cell_bricks;
        BrickBox {
            min,
            max: min + IVec3::splat(self.cell_bricks),
        }
    }

    /// The grid of `triangles` at bricks of `brick_size_m`: parts of [`BUILD_CHUNK`]
    /// triangles are gridded on all cores, then joined in frame order.
    fn build(brick_size_m: f32, triangles: &[PreparedTriangle]) -> Self {
        Self::build_within(brick_size_m, triangles, WIDE_PAIRS_PER_LEVEL)
    }

    /// [`LevelGrid::build`] with a budget of `wide_budget` pairs for wide triangles.
    fn build_within(brick_size_m: f32, triangles: &[PreparedTriangle], wide_budget: u64) -> Self {
        let empty = || Self {
            cell_bricks: cell_bricks(brick_size_m),
            cells: HashMap::new(),
            large: Vec::new(),
            large_blocks: HashMap::new(),
            huge: Vec::new(),
        };
        let chunks = triangles.len().div_ceil(BUILD_CHUNK).max(1) as u64;
        let parts: Vec<Self> = triangles
            .par_chunks(BUILD_CHUNK)
            .enumerate()
            .map(|(chunk, part)| {
                let mut grid = empty();
                let mut wide_pairs = wide_budget / chunks;
                grid.add(brick_size_m, chunk * BUILD_CHUNK, part, &mut wide_pairs);
                grid
            })
            .collect();
        let mut parts = parts.into_iter();
        let mut grid = parts.next().unwrap_or_else(empty);
        for part in parts {
            for (cell, list) in part.cells {
                grid.cells.entry(cell).or_default().extend(list);
            }
            grid.large.extend(part.large);
            for (block, entries) in part.large_blocks {
                grid.large_blocks.entry(block).or_default().extend(entries);
            }
            grid.huge.extend(part.huge);
        }
        grid
    }

    /// Grids `triangles`, the first of which is triangle `first` of the index.
    /// `wide_pairs` is what is left of the part's budget of [`WIDE_PAIRS_PER_LEVEL`].
    fn add(
        &mut self,
        brick_size_m: f32,
        first: usize,
        triangles: &[PreparedTriangle],
        wide_pairs: &mut u64,
    ) {
        for (offset, t) in triangles.iter().enumerate() {
            let index = (first + offset) as u32;
            let (lo, hi) = (t.lo / brick_size_m, t.hi / brick_size_m);
            let gridded =
                lo.abs().max_element() < MAX_GRID_BRICK && hi.abs().max_element() < MAX_GRID_BRICK;
            let cells =
                gridded.then(|| self.cells_of(&BrickBox::from_world(t.lo, t.hi, brick_size_m)));
            let listed = cells.filter(|range| {
                let volume = range.volume();
                if volume <= LARGE_TRIANGLE_CELLS {
                    return true;
                }
                let wide = volume <= WIDE_TRIANGLE_CELLS && volume <= *wide_pairs;
                if wide {
                    *wide_pairs -= volume;
                }
                wide
            });
            let Some(range) = listed else {
                self.large.push(index);
                match cells
                    .map(|cells| blocks_of(&cells))
                    .filter(|blocks| blocks.volume() <= LARGE_TRIANGLE_CELLS)
                {
                    Some(blocks) => {
                        for block in blocks.bricks() {
                            self.large_blocks.entry(block).or_default().push(index);
                        }
                    }
                    None => self.huge.push(index),
                }
                continue;
            };
            let bricks = BrickBox::from_world(t.lo, t.hi, brick_size_m);
            for cell in range.bricks() {
                let mut mask = 0;
                for brick in bricks.intersection(&self.cell_box(cell)).bricks() {
                    let center = (brick.as_vec3() + 0.5) * brick_size_m;
                    if overlaps_brick(t, center, 0.5 * brick_size_m) {
                        mask |= 1 << self.brick_bit(cell, brick);
                    }
                }
                if mask == 0 {
                    continue;
                }
                let list = self.cells.entry(cell).or_default();
                list.references.push(t.reference);
                if self.cell_bricks > 1 {
                    list.masks.push(mask);
                }
                list.occupied |= mask;
            }
        }
    }

    /// The large triangles that may touch cell `cell`: its block's and the huge ones.
    fn large_near(&self, cell: IVec3) -> [&[u32]; 2] {
        let block = cell.div_euclid(IVec3::splat(LARGE_BLOCK_CELLS));
        let listed = self.large_blocks.get(&block).map_or(&[][..], Vec::as_slice);
        [listed, &self.huge]
    }

    /// The large triangles that may touch `region` (bricks), each once, in frame order: those
    /// listed in the blocks of its cells and the huge ones.
    fn large_in(&self, region: &BrickBox) -> Vec<u32> {
        if self.large.is_empty() || region.is_empty() {
            return Vec::new();
        }
        let blocks = blocks_of(&self.cells_of(region));
        if blocks.volume() > self.large_blocks.len() as u64 {
            // A region wider than the blocks that list anything: every large triangle.
            return self.large.clone();
        }
        let mut near = self.huge.clone();
        for block in blocks.bricks() {
            if let Some(listed) = self.large_blocks.get(&block) {
                near.extend_from_slice(listed);
            }
        }
        near.sort_unstable();
        near.dedup();
        near
    }

    /// Entries that binning a brick of cell `cell` scans: the cell's list and the large
    /// triangles near it.
    fn scan_cost(&self, cell: IVec3) -> usize {
        let [listed, huge] = self.large_near(cell);
        self.cells
            .get(&cell)
            .map_or(0, |list| list.references.len())
            + listed.len()
            + huge.len()
    }
}

impl TriangleIndex {
    /// Prepares the triangles of `scene` for binning at the levels of `config`.
    pub fn new(config: &CacheConfig, scene: &CacheScene<'_>) -> Self {
        // On all cores, like the grids: 4.2 million triangles took 0.1 s on one.
        let triangles: Vec<PreparedTriangle> = (0..scene.frame.triangles.len() as u32)
            .into_par_iter()
            .filter_map(|index| {
                let vertices = scene.vertices(index);
                let [a, b, c] = vertices;
                (a.is_finite() && b.is_finite() && c.is_finite()).then(|| PreparedTriangle {
                    vertices,
                    lo: a.min(b).min(c),
                    hi: a.max(b).max(c),
                    reference: scene.reference(index),
                })
            })
            .collect();
        let brick_size_m: Vec<f32> = (0..config.levels)
            .map(|level| config.brick_size_at(level))
            .collect();
        // The copy kept to find changed geometry (hundreds of megabytes at millions of
        // triangles) is made beside the grids.
        let (grids, source) = rayon::join(
            || {
                brick_size_m
                    .par_iter()
                    .map(|&size| LevelGrid::build(size, &triangles))
                    .collect()
            },
            || scene.frame.triangles.clone(),
        );
        Self {
            brick_size_m,
            source,
            revision: scene.frame.geometry_revision,
            dynamic_node: scene.dynamic_node.clone(),
            triangles,
            grids,
        }
    }

    /// Prepares the triangles of `scene` again when any changed since the last preparation,
    /// else keeps everything, grids included (a static scene, or one whose dynamic nodes stand
    /// still). A frame of the same nonzero [`SceneFrame::geometry_revision`] is the same
    /// geometry and costs nothing; another one is compared byte for byte, which costs far less
    /// than preparing it (a tenth of a millisecond for open-world's 43k triangles).
    pub fn update(&mut self, config: &CacheConfig, scene: &CacheScene<'_>) {
        let same_levels = (0..config.levels)
            .map(|level| config.brick_size_at(level))
            .eq(self.brick_size_m.iter().copied());
        if !same_levels || self.dynamic_node != scene.dynamic_node {
            *self = Self::new(config, scene);
            return;
        }
        let revision = scene.frame.geometry_revision;
        if revision != 0 && revision == self.revision {
            return;
        }
        if bytemuck::cast_slice::<_, u8>(&self.source)
            == bytemuck::cast_slice::<_, u8>(&scene.frame.triangles)
        {
            self.revision = revision;
        } else {
            *self = Self::new(config, scene);
        }
    }

    /// Tests `triangle` against the bricks of `region` its bounds touch; pushes its reference
    /// to the bins of those it overlaps.
    fn bin_one(brick_size_m: f32, triangle: &PreparedTriangle, region: &BrickBox, bins: &mut Bins) {
        let bounds =
            BrickBox::from_world(triangle.lo, triangle.hi, brick_size_m).intersection(region);
        for brick in bounds.bricks() {
            let center = (brick.as_vec3() + 0.5) * brick_size_m;
            if overlaps_brick(triangle, center, 0.5 * brick_size_m) {
                bins.entry(brick).or_default().push(triangle.reference);
            }
        }
    }

    /// Bins the large triangles of `level` (those kept out of the grid's cells) in `region`.
    fn bin_large(&self, level: u32, region: &BrickBox, bins: &mut Bins) {
        let brick_size_m = self.brick_size_m[level as usize];
        for entry in self.grids[level as usize].large_in(region) {
            Self::bin_one(brick_size_m, &self.triangles[entry as usize], region, bins);
        }
    }

    /// The bins of `region` at `level`: for every brick of the region that some triangle
    /// overlaps, the references of those triangles in frame order (exactly what
    /// [`bin_triangles`] returns over every triangle).
    pub fn bin_region(&self, level: u32, region: &BrickBox) -> Bins {
        let grid = &self.grids[level as usize];
        let mut bins = HashMap::new();
        if region.is_empty() {
            return bins;
        }
        // Cells partition the bricks, so each (triangle, brick) pair is read once and each
        // brick's list keeps the cell's frame order.
        for cell in grid.cells_of(region).bricks() {
            let Some(list) = grid.cells.get(&cell) else {
                continue;
            };
            let inside = grid.region_mask(cell, region);
            for (i, &reference) in list.references.iter().enumerate() {
                for_each_bit(list.mask(i) & inside, |bit| {
                    let brick = grid.brick_of_bit(cell, bit);
                    bins.entry(brick).or_default().push(reference);
                });
            }
        }
        if !grid.large.is_empty() {
            self.bin_large(level, region, &mut bins);
            // The large triangles went last; frame order is reference order without the flag.
            for list in bins.values_mut() {
                list.sort_unstable_by_key(|reference| reference & !TRIANGLE_DYNAMIC_BIT);
            }
        }
        bins
    }

    /// The triangle lists of `bricks` at `level`, one per brick in the order given (empty for
    /// a brick no triangle touches; a brick given twice gets its list twice): what
    /// [`bin_triangles`] returns for a region holding them, restricted to them. Each cell's list
    /// is scanned once for all of its bricks among `bricks`.
    pub fn bin_bricks(&self, level: u32, bricks: &[IVec3]) -> Vec<Vec<u32>> {
        let grid = &self.grids[level as usize];
        // The cells in order of first appearance, each with a mask of the bricks wanted (a
        // cell has at most 4³ bricks), and each brick's cell and bit.
        let mut slots: HashMap<IVec3, usize> = HashMap::with_capacity(bricks.len());
        let mut cells: Vec<(IVec3, u64)> = Vec::new();
        let places: Vec<(usize, u32)> = bricks
            .iter()
            .map(|&brick| {
                let cell = grid.cell_of(brick);
                let bit = grid.brick_bit(cell, brick);
                let slot = *slots.entry(cell).or_insert_with(|| {
                    cells.push((cell, 0));
                    cells.len() - 1
                });
                cells[slot].1 |= 1 << bit;
                (slot, bit)
            })
            .collect();
        let work: usize = cells.iter().map(|(cell, _)| grid.scan_cost(*cell)).sum();
        let bin_cell = |&(cell, wanted): &(IVec3, u64)| self.bin_cell(level, cell, wanted);
        // Cells are binned side by side on all cores when there is enough work to share.
        let mut per_cell: Vec<Vec<Vec<u32>>> = if work >= PARALLEL_BIN_ENTRIES {
            cells.par_iter().map(bin_cell).collect()
        } else {
            cells.iter().map(bin_cell).collect()
        };
        let mut taken = vec![0u64; cells.len()];
        let mut lists: Vec<Vec<u32>> = Vec::with_capacity(bricks.len());
        for (i, &(slot, bit)) in places.iter().enumerate() {
            if taken[slot] & (1 << bit) != 0 {
                // A brick given again (rare): its list once more.
                let first = places[..i]
                    .iter()
                    .position(|&place| place == (slot, bit))
                    .expect("a taken brick was given before");
                lists.push(lists[first].clone());
                continue;
            }
            taken[slot] |= 1 << bit;
            let rank = rank_of(cells[slot].1, bit);
            lists.push(std::mem::take(&mut per_cell[slot][rank]));
        }
        lists
    }

    /// The lists of the bricks `wanted` (a mask of [`LevelGrid::brick_bit`]s) of cell `cell`
    /// at `level`, by the rank of their bit among the wanted ones ([`rank_of`]), empty where
    /// no triangle touches: the cell's list read through its masks, then the large triangles
    /// near it, tested, each list in frame order.
    fn bin_cell(&self, level: u32, cell: IVec3, wanted: u64) -> Vec<Vec<u32>> {
        let brick_size_m = self.brick_size_m[level as usize];
        let grid = &self.grids[level as usize];
        // A list per wanted brick, by the rank of its bit among the wanted ones, looked up in
        // a table: the scan below asks for a rank per entry, and the baseline x86-64 target
        // has no popcount instruction.
        let mut ranks = [0u8; 64];
        let mut next = 0u8;
        for_each_bit(wanted, |bit| {
            ranks[bit as usize] = next;
            next += 1;
        });
        let rank = |bit: u32| usize::from(ranks[bit as usize & 63]);
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); wanted.count_ones() as usize];
        if let Some(list) = grid.cells.get(&cell) {
            if list.masks.is_empty() {
                // A cell of one brick: every entry overlaps it.
                lists[0].extend_from_slice(&list.references);
            } else {
                // Sized first, so that long lists are not grown (and copied) push by push.
                let mut counts = vec![0usize; lists.len()];
                for &mask in &list.masks {
                    for_each_bit(mask & wanted, |bit| counts[rank(bit)] += 1);
                }
                for (list, count) in lists.iter_mut().zip(counts) {
                    list.reserve_exact(count);
                }
                for (&reference, &mask) in list.references.iter().zip(&list.masks) {
                    for_each_bit(mask & wanted, |bit| lists[rank(bit)].push(reference));
                }
            }
        }
        // The large triangles' hits per wanted brick, merged into the lists in frame order
        // afterwards: sorting whole lists of thousands for a few large hits cost more than the
        // scan.
        let mut large_hits: Vec<Vec<u32>> = Vec::new();
        let cell_box = grid.cell_box(cell);
        for large in grid.large_near(cell) {
            for &entry in large {
                let triangle = &self.triangles[entry as usize];
                let bounds = BrickBox::from_world(triangle.lo, triangle.hi, brick_size_m)
                    .intersection(&cell_box);
                for brick in bounds.bricks() {
                    let bit = grid.brick_bit(cell, brick);
                    if wanted & (1 << bit) == 0 {
                        continue;
                    }
                    let center = (brick.as_vec3() + 0.5) * brick_size_m;
                    if overlaps_brick(triangle, center, 0.5 * brick_size_m) {
                        if large_hits.is_empty() {
                            large_hits.resize(lists.len(), Vec::new());
                        }
                        large_hits[rank(bit)].push(triangle.reference);
                    }
                }
            }
        }
        for (list, mut hits) in lists.iter_mut().zip(large_hits) {
            if !hits.is_empty() {
                hits.sort_unstable_by_key(|&reference| frame_order(reference));
                *list = merge_in_frame_order(list, &hits);
            }
        }
        lists
    }

    /// Entries [`TriangleIndex::bin_bricks`] scans for a brick at `level` whose cell it has
    /// not scanned yet: the work per-frame budgets count.
    pub fn scan_cost(&self, level: u32, brick: IVec3) -> usize {
        let grid = &self.grids[level as usize];
        grid.scan_cost(grid.cell_of(brick))
    }

    /// The bricks of `region` at `level` that some triangle overlaps: the keys of
    /// [`TriangleIndex::bin_region`]'s bins, read from per-cell masks made with the grid (only
    /// the few large triangles are tested again), so queuing the bricks of a window or an
    /// entering slab costs a lookup per cell instead of a pass over its triangles.
    pub fn candidate_bricks(&self, level: u32, region: &BrickBox) -> Vec<IVec3> {
        let grid = &self.grids[level as usize];
        let mut bricks = Vec::new();
        if region.is_empty() {
            return bricks;
        }
        for cell in grid.cells_of(region).bricks() {
            let Some(mask) = grid.cells.get(&cell).map(|list| list.occupied) else {
                continue;
            };
            for brick in grid.cell_box(cell).intersection(region).bricks() {
                if mask & (1 << grid.brick_bit(cell, brick)) != 0 {
                    bricks.push(brick);
                }
            }
        }
        if !grid.large.is_empty() {
            // Large triangles are tested exactly: their bounds may span the whole region.
            let mut bins = HashMap::new();
            self.bin_large(level, region, &mut bins);
            let listed: HashSet<IVec3> = bricks.iter().copied().collect();
            bricks.extend(bins.into_keys().filter(|brick| !listed.contains(brick)));
        }
        bricks
    }

    /// The cell `brick` at `level` lies in: bricks of one cell share one scan.
    pub fn cell_of(&self, level: u32, brick: IVec3) -> IVec3 {
        self.grids[level as usize].cell_of(brick)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Wide triangles are listed in their cells while the budget lasts and tested as large
    /// ones past it; the bins are the same either way, and those of a scan of every triangle.
    #[test]
    fn wide_triangles_past_the_budget_bin_the_same() {
        let brick = 0.25;
        let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
        // Floors and ramps of 6 to 20 m at bricks of 0.25 m (cells of 1 m): 36 to 400 cells.
        let triangles: Vec<PreparedTriangle> = (0..40)
            .map(|i| {
                let c = Vec3::new(
                    rng.random_range(-15.0..15.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-15.0..15.0),
                );
                let r = rng.random_range(3.0..10.0);
                let tilt = rng.random_range(-0.04..0.04);
                let vertices = [
                    c + Vec3::new(-r, -tilt * r, -r),
                    c + Vec3::new(r, tilt * r, -r * 0.5),
                    c + Vec3::new(0.2 * r, 0.5 * tilt * r, r),
                ];
                let [a, b, d] = vertices;
                PreparedTriangle {
                    vertices,
                    lo: a.min(b).min(d),
                    hi: a.max(b).max(d),
                    reference: i,
                }
            })
            .collect();
        let index = |wide_budget: u64| TriangleIndex {
            brick_size_m: vec![brick],
            source: Vec::new(),
            revision: 0,
            dynamic_node: Vec::new(),
            triangles: triangles.clone(),
            grids: vec![LevelGrid::build_within(brick, &triangles, wide_budget)],
        };
        let (all, some, none) = (index(WIDE_PAIRS_PER_LEVEL), index(1500), index(0));
        let large = |index: &TriangleIndex| index.grids[0].large.len();
        assert_eq!(large(&all), 0);
        assert!(
            large(&some) > 0 && large(&some) < large(&none),
            "{}",
            large(&some)
        );
        assert!(large(&none) > 20, "{}", large(&none));

        let region = BrickBox {
            min: IVec3::new(-60, -20, -60),
            max: IVec3::new(60, 20, 60),
        };
        let mut scan: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for t in &triangles {
            let bounds = BrickBox::from_world(t.lo, t.hi, brick).intersection(&region);
            for b in bounds.bricks() {
                let center = (b.as_vec3() + 0.5) * brick;
                if triangle_box_overlap(t.vertices, center, 0.5 * brick) {
                    scan.entry(b).or_default().push(t.reference);
                }
            }
        }
        assert!(scan.len() > 1000, "{}", scan.len());
        // Every fifth occupied brick and some empty ones, each list in the order asked.
        let mut chosen: Vec<IVec3> = scan.keys().copied().step_by(5).collect();
        let empty: Vec<IVec3> = region
            .bricks()
            .filter(|b| !scan.contains_key(b))
            .step_by(97)
            .take(50)
            .collect();
        assert_eq!(empty.len(), 50);
        chosen.extend(empty);
        // A brick asked twice gets its list twice.
        chosen.push(chosen[0]);
        chosen.sort_by_key(|b| (b.x * 7 + b.y * 13 + b.z * 3, b.x));
        let wanted: Vec<Vec<u32>> = chosen
            .iter()
            .map(|b| scan.get(b).cloned().unwrap_or_default())
            .collect();
        for (name, index) in [("all", &all), ("some", &some), ("none", &none)] {
            assert_eq!(index.bin_region(0, &region), scan, "{name}: region");
            assert_eq!(
                index.bin_bricks(0, &chosen),
                wanted,
                "{name}: chosen bricks"
            );
        }
    }

    /// The shortcut of [`overlaps_brick`] never disagrees with the exact test: random
    /// triangles inside, across and just inside the faces of a box, slivers and points.
    #[test]
    fn the_inside_shortcut_agrees_with_the_exact_test() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let (center, half) = (Vec3::new(3.0, -1.5, 1000.25), 2.0);
        let mut inside = 0;
        for i in 0..200_000 {
            let spread = [0.5, 1.0, 1.999, 2.5][i % 4] * half;
            let mut point = || {
                let unit = Vec3::new(rng.random(), rng.random(), rng.random());
                center + (2.0 * unit - 1.0) * spread
            };
            let mut vertices = [point(), point(), point()];
            match i % 7 {
                // A sliver: two equal vertices, or three on a line.
                0 => vertices[1] = vertices[0],
                1 => vertices[2] = vertices[0] + (vertices[1] - vertices[0]) * 0.5,
                _ => {}
            }
            let [a, b, c] = vertices;
            let triangle = PreparedTriangle {
                vertices,
                lo: a.min(b).min(c),
                hi: a.max(b).max(c),
                reference: 0,
            };
            let exact = triangle_box_overlap(vertices, center, half);
            assert_eq!(
                overlaps_brick(&triangle, center, half),
                exact,
                "{vertices:?}"
            );
            inside += usize::from(exact);
        }
        assert!(inside > 50_000, "{inside}");
    }
}

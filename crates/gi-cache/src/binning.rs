//! Which triangles touch which bricks: the CPU side of voxelization.
//!
//! Before a brick is voxelized (on the GPU or by [`crate::cpu_voxelize`]), the CPU collects the
//! triangles overlapping its box with the same exact test the voxelizer applies per voxel
//! ([`triangle_box_overlap`]), so a brick gets a pool ID only when some triangle touches it.
//! Triangles are referenced by their index in [`SceneFrame::triangles`] (the order `GpuScene`
//! uploads them in), with bit 31 set when the triangle belongs to a dynamic node.

use std::collections::HashMap;

use gi_scene::{Scene, SceneFrame};
use glam::{IVec3, Vec3};

use crate::clipmap::BrickBox;
use crate::config::CacheConfig;
use crate::cpu_voxelize::triangle_box_overlap;
use crate::layout::GROUP_BRICKS;

/// Bit of a binned triangle reference marking a dynamic node's triangle.
pub const TRIANGLE_DYNAMIC_BIT: u32 = 1 << 31;

/// `dynamic[node]`: the node or one of its ancestors is moved by an animation channel, or the
/// node is skinned and one of its joints moves ([`Scene::deforming_nodes`]), so its triangles
/// may move from frame to frame.
pub fn dynamic_nodes(scene: &Scene) -> Vec<bool> {
    let deforming = scene.deforming_nodes();
    scene
        .moving_nodes()
        .into_iter()
        .zip(deforming)
        .map(|(moving, deforming)| moving || deforming)
        .collect()
}

/// `dynamic[triangle]` for each triangle of `frame`: its node is moved by an animation or
/// deformed by animated joints ([`dynamic_nodes`]).
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
) -> HashMap<IVec3, Vec<u32>> {
    let brick_size = config.brick_size_at(level);
    let mut bins: HashMap<IVec3, Vec<u32>> = HashMap::new();
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

/// Fill order of bricks: finer levels first, then nearer bricks (distance from the camera to
/// the brick center in bricks of its level). Smaller keys fill first; when the pool runs out,
/// what is left unfilled is the coarse and far end of this order. Bricks at the same distance
/// tie here: [`fill_order`] breaks the ties.
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

/// [`fill_priority`]'s order of `(level, brick)` entries as a total order: ties (bricks at the
/// same distance, which a symmetric view has many of) go by brick coordinates, z, then y, then
/// x. The fill order decides which pool ID a brick gets and so when the lighting schedule's
/// round-robin reaches it: with ties left to the order the entries arrived in (hash order, which
/// differs from run to run) the same scene lit the same way gave different images.
pub fn fill_order(
    config: &CacheConfig,
    camera_position: Vec3,
    a: (u32, IVec3),
    b: (u32, IVec3),
) -> std::cmp::Ordering {
    let (ka, kb) = (
        fill_priority(config, a.0, a.1, camera_position),
        fill_priority(config, b.0, b.1, camera_position),
    );
    ka.0.cmp(&kb.0)
        .then(ka.1.total_cmp(&kb.1))
        .then_with(|| (a.1.z, a.1.y, a.1.x).cmp(&(b.1.z, b.1.y, b.1.x)))
}

/// A frame's triangles prepared for binning, with a grid of triangle lists per level so a
/// region or brick is tested only against the triangles near it, not the whole frame.
///
/// Built once per update: the triangles' vertices, bounds and references are read once, and
/// the grid of a level is built the first time that level is binned, over its window, at
/// group resolution ([`GROUP_BRICKS`] bricks per cell and axis). A cell lists every triangle
/// whose brick bounds (as [`bin_triangles`] computes them) touch it, in frame order, so the
/// bins are exactly [`bin_triangles`]'s, lists in the same order. The cost is one pass over
/// the triangles per level binned, and four bytes per (triangle, cell) pair.
pub struct TriangleIndex {
    /// Brick edge in meters per level.
    brick_size_m: Vec<f32>,
    /// The frame's triangles as given and the scene's dynamic-node flags, which
    /// [`TriangleIndex::update`] compares with the next frame's before preparing anything.
    source: Vec<obvhs::triangle::Triangle>,
    dynamic_node: Vec<bool>,
    /// The frame's triangles with finite vertices, in frame order.
    triangles: Vec<PreparedTriangle>,
    /// Per level, the grid over the window it was last built for.
    grids: Vec<Option<LevelGrid>>,
}

/// One triangle as binning reads it.
#[derive(PartialEq)]
struct PreparedTriangle {
    vertices: [Vec3; 3],
    lo: Vec3,
    hi: Vec3,
    /// See [`CacheScene::reference`].
    reference: u32,
}

/// Triangle lists per cell of `GROUP_BRICKS`³ bricks over one level's window.
struct LevelGrid {
    window: BrickBox,
    /// Cells along x, y, z.
    cells: IVec3,
    /// Entries of cell `c` are `entries[cell_start[c]..cell_start[c + 1]]`.
    cell_start: Vec<u32>,
    /// Indices into [`TriangleIndex::triangles`].
    entries: Vec<u32>,
}

const CELL_BRICKS: i32 = GROUP_BRICKS as i32;

impl LevelGrid {
    fn build(window: BrickBox, brick_size_m: f32, triangles: &[PreparedTriangle]) -> Self {
        let cells = (window.max - window.min + (CELL_BRICKS - 1)) / CELL_BRICKS;
        let cell_count = (cells.x * cells.y * cells.z).max(0) as usize;
        let cell_range = |t: &PreparedTriangle| {
            let bounds = BrickBox::from_world(t.lo, t.hi, brick_size_m).intersection(&window);
            (!bounds.is_empty()).then(|| BrickBox {
                min: (bounds.min - window.min) / CELL_BRICKS,
                max: (bounds.max - IVec3::ONE - window.min) / CELL_BRICKS + IVec3::ONE,
            })
        };
        // Triangles more than a brick outside the window are skipped before the exact test.
        let reach_lo = (window.min - IVec3::ONE).as_vec3() * brick_size_m;
        let reach_hi = (window.max + IVec3::ONE).as_vec3() * brick_size_m;
        let near = |t: &&PreparedTriangle| t.hi.cmpge(reach_lo).all() && t.lo.cmple(reach_hi).all();
        let cell_range = |t: &PreparedTriangle| near(&t).then(|| cell_range(t)).flatten();
        let cell_index = |c: IVec3| (c.x + cells.x * (c.y + cells.y * c.z)) as usize;
        // Counting pass, then a fill pass in frame order (a compressed-row layout).
        let mut cell_start = vec![0u32; cell_count + 1];
        for range in triangles.iter().filter_map(cell_range) {
            for cell in range.bricks() {
                cell_start[cell_index(cell) + 1] += 1;
            }
        }
        for i in 0..cell_count {
            cell_start[i + 1] += cell_start[i];
        }
        let mut cursor = cell_start.clone();
        let mut entries = vec![0u32; cell_start[cell_count] as usize];
        for (index, triangle) in triangles.iter().enumerate() {
            let Some(range) = cell_range(triangle) else {
                continue;
            };
            for cell in range.bricks() {
                let slot = &mut cursor[cell_index(cell)];
                entries[*slot as usize] = index as u32;
                *slot += 1;
            }
        }
        Self {
            window,
            cells,
            cell_start,
            entries,
        }
    }

    /// The cell holding `brick` (inside the window).
    fn cell_of(&self, brick: IVec3) -> IVec3 {
        (brick - self.window.min) / CELL_BRICKS
    }

    /// The bricks of cell `cell`.
    fn cell_box(&self, cell: IVec3) -> BrickBox {
        let min = self.window.min + cell * CELL_BRICKS;
        BrickBox {
            min,
            max: min + IVec3::splat(CELL_BRICKS),
        }
        .intersection(&self.window)
    }

    /// Triangle indices listed in cell `cell`.
    fn cell_entries(&self, cell: IVec3) -> &[u32] {
        let c = (cell.x + self.cells.x * (cell.y + self.cells.y * cell.z)) as usize;
        &self.entries[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }
}

impl TriangleIndex {
    /// Prepares the triangles of `scene` for binning at the levels of `config`.
    pub fn new(config: &CacheConfig, scene: &CacheScene<'_>) -> Self {
        let triangles = (0..scene.frame.triangles.len() as u32)
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
        Self {
            brick_size_m: (0..config.levels)
                .map(|level| config.brick_size_at(level))
                .collect(),
            source: scene.frame.triangles.clone(),
            dynamic_node: scene.dynamic_node.clone(),
            triangles,
            grids: (0..config.levels).map(|_| None).collect(),
        }
    }

    /// Prepares the triangles of `scene` again when any changed since the last preparation,
    /// else keeps everything, grids included (a scene whose dynamic nodes stand still, or a
    /// static scene: its grids are rebuilt only when a level's window moves). The check
    /// compares the frame's triangles byte for byte, which costs far less than preparing them
    /// (a tenth of a millisecond for open-world's 43k triangles).
    pub fn update(&mut self, config: &CacheConfig, scene: &CacheScene<'_>) {
        let same = bytemuck::cast_slice::<_, u8>(&self.source)
            == bytemuck::cast_slice::<_, u8>(&scene.frame.triangles)
            && self.dynamic_node == scene.dynamic_node
            && (0..config.levels)
                .map(|level| config.brick_size_at(level))
                .eq(self.brick_size_m.iter().copied());
        if !same {
            *self = Self::new(config, scene);
        }
    }

    /// Builds the grid of `level` over `window` when missing or built for another window.
    fn prepare_grid(&mut self, level: u32, window: &BrickBox) {
        let brick_size_m = self.brick_size_m[level as usize];
        let slot = &mut self.grids[level as usize];
        if slot.as_ref().is_none_or(|grid| grid.window != *window) {
            *slot = Some(LevelGrid::build(*window, brick_size_m, &self.triangles));
        }
    }

    /// Tests `triangle` against the bricks of `region` its bounds touch; pushes its reference
    /// to the bins of those it overlaps.
    fn bin_one(
        brick_size_m: f32,
        triangle: &PreparedTriangle,
        region: &BrickBox,
        bins: &mut HashMap<IVec3, Vec<u32>>,
    ) {
        let bounds =
            BrickBox::from_world(triangle.lo, triangle.hi, brick_size_m).intersection(region);
        for brick in bounds.bricks() {
            let center = (brick.as_vec3() + 0.5) * brick_size_m;
            if triangle_box_overlap(triangle.vertices, center, 0.5 * brick_size_m) {
                bins.entry(brick).or_default().push(triangle.reference);
            }
        }
    }

    /// What [`bin_triangles`] returns for `region` at `level` over every triangle of the
    /// frame. `window` is the level's window: the grid covers it, and parts of `region`
    /// outside it are binned by a scan of every triangle.
    pub fn bin_region(
        &mut self,
        level: u32,
        region: &BrickBox,
        window: &BrickBox,
    ) -> HashMap<IVec3, Vec<u32>> {
        let brick_size_m = self.brick_size_m[level as usize];
        let mut bins = HashMap::new();
        for outside in region.difference(window) {
            for triangle in &self.triangles {
                Self::bin_one(brick_size_m, triangle, &outside, &mut bins);
            }
        }
        let inside = region.intersection(window);
        if inside.is_empty() {
            return bins;
        }
        self.prepare_grid(level, window);
        let grid = self.grids[level as usize].as_ref().expect("prepared above");
        let cells = BrickBox {
            min: grid.cell_of(inside.min),
            max: grid.cell_of(inside.max - IVec3::ONE) + IVec3::ONE,
        };
        // Cells partition the bricks, so each (triangle, brick) pair is tested once and each
        // brick's list keeps the cell's frame order.
        for cell in cells.bricks() {
            let part = grid.cell_box(cell).intersection(&inside);
            for &entry in grid.cell_entries(cell) {
                Self::bin_one(
                    brick_size_m,
                    &self.triangles[entry as usize],
                    &part,
                    &mut bins,
                );
            }
        }
        bins
    }

    /// The bins of `bricks` at `level` (bricks no triangle touches are absent): what
    /// [`bin_triangles`] returns for a region holding them, restricted to them.
    pub fn bin_bricks(
        &mut self,
        level: u32,
        bricks: &[IVec3],
        window: &BrickBox,
    ) -> HashMap<IVec3, Vec<u32>> {
        let mut bins = HashMap::new();
        for &brick in bricks {
            let single = BrickBox::new(brick, glam::UVec3::ONE);
            bins.extend(self.bin_region(level, &single, window));
        }
        bins
    }
}

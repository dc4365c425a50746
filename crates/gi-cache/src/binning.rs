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

/// Bit of a binned triangle reference marking a dynamic node's triangle.
pub const TRIANGLE_DYNAMIC_BIT: u32 = 1 << 31;

/// `dynamic[node]`: the node or one of its ancestors is moved by an animation channel, so its
/// triangles may move from frame to frame.
pub fn dynamic_nodes(scene: &Scene) -> Vec<bool> {
    let mut animated = vec![false; scene.nodes.len()];
    for channel in scene.animations.iter().flat_map(|a| &a.channels) {
        if !channel.times.is_empty()
            && let Some(flag) = animated.get_mut(channel.node)
        {
            *flag = true;
        }
    }
    (0..scene.nodes.len())
        .map(|mut node| {
            // The depth bound stops parent cycles, which hand-built scenes could contain.
            for _ in 0..=scene.nodes.len() {
                if animated[node] {
                    return true;
                }
                match scene.nodes[node].parent {
                    Some(parent) if parent < scene.nodes.len() => node = parent,
                    _ => return false,
                }
            }
            false
        })
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
/// what is left unfilled is the coarse and far end of this order.
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

//! Clipmap windows: where each level's window of bricks sits around the camera, and what
//! changes when it moves.
//!
//! A window is `level_bricks` bricks starting at `origin_brick`, centered on the camera and
//! snapped to group boundaries (multiples of [`GROUP_BRICKS`] bricks) so groups move as units
//! and the group masks stay valid. With toroidal addressing a move touches only the slabs that
//! leave and enter the window (HSGI, "Volume World Shift": only the newly exposed zone is
//! cleared); everything else keeps its link slot.

use glam::{IVec3, UVec3, Vec3};

use crate::config::CacheConfig;
use crate::layout::GROUP_BRICKS;

/// An axis-aligned box of world brick coordinates, `min` inclusive, `max` exclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BrickBox {
    pub min: IVec3,
    pub max: IVec3,
}

impl BrickBox {
    /// The box of `size` bricks starting at `min`.
    pub fn new(min: IVec3, size: UVec3) -> Self {
        Self {
            min,
            max: min + size.as_ivec3(),
        }
    }

    /// True when the box holds no brick.
    pub fn is_empty(&self) -> bool {
        self.min.cmpge(self.max).any()
    }

    /// Number of bricks inside.
    pub fn volume(&self) -> u64 {
        if self.is_empty() {
            return 0;
        }
        let d = (self.max - self.min).as_u64vec3();
        d.x * d.y * d.z
    }

    /// True when `brick` is inside.
    pub fn contains(&self, brick: IVec3) -> bool {
        brick.cmpge(self.min).all() && brick.cmplt(self.max).all()
    }

    /// The bricks both boxes hold.
    pub fn intersection(&self, other: &BrickBox) -> BrickBox {
        BrickBox {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    /// `self` minus `other` as at most six disjoint slabs: first the parts below and above
    /// `other` along x, then, within `other`'s x range, along y, then along z.
    pub fn difference(&self, other: &BrickBox) -> Vec<BrickBox> {
        let overlap = self.intersection(other);
        if overlap.is_empty() {
            return if self.is_empty() { vec![] } else { vec![*self] };
        }
        let mut slabs = Vec::new();
        let mut rest = *self;
        for axis in 0..3 {
            let mut below = rest;
            below.max[axis] = overlap.min[axis];
            let mut above = rest;
            above.min[axis] = overlap.max[axis];
            slabs.extend([below, above].into_iter().filter(|b| !b.is_empty()));
            rest.min[axis] = overlap.min[axis];
            rest.max[axis] = overlap.max[axis];
        }
        slabs
    }

    /// Every brick inside, x fastest.
    pub fn bricks(&self) -> impl Iterator<Item = IVec3> + '_ {
        let (min, max) = (self.min, self.max);
        (min.z..max.z).flat_map(move |z| {
            (min.y..max.y).flat_map(move |y| (min.x..max.x).map(move |x| IVec3::new(x, y, z)))
        })
    }

    /// The smallest brick box holding the world-space box `[lo, hi]` at bricks of
    /// `brick_size_m`.
    pub fn from_world(lo: Vec3, hi: Vec3, brick_size_m: f32) -> BrickBox {
        BrickBox {
            min: (lo / brick_size_m).floor().as_ivec3(),
            max: (hi / brick_size_m).floor().as_ivec3() + IVec3::ONE,
        }
    }
}

/// The window origin (world brick coordinate of its lowest corner) of `level` for a camera at
/// `camera_position`: the window's center is the group boundary nearest to the camera, so the
/// camera is at most half a group (2 bricks) from the center along each axis when a window is
/// placed; between moves it may stray further ([`window_needs_move`]).
pub fn window_origin(config: &CacheConfig, level: u32, camera_position: Vec3) -> IVec3 {
    let group = GROUP_BRICKS as f32;
    let camera_brick = camera_position / config.brick_size_at(level);
    let half = UVec3::from(config.level_bricks).as_vec3() * 0.5;
    ((camera_brick - half) / group).round().as_ivec3() * GROUP_BRICKS as i32
}

/// How far past one group the camera may stray from a window's center before the window
/// moves, in groups. Without it a camera moving back and forth over a group boundary would
/// move the window, and refill a slab, every frame; with it such a camera moves the window
/// once. The cost is reach: the camera may sit up to `1 + WINDOW_HYSTERESIS_GROUPS` groups
/// off center, so the window reaches that much less far ahead on one side.
pub const WINDOW_HYSTERESIS_GROUPS: f32 = 0.25;

/// True when the window of `level` starting at `origin` should move for a camera at
/// `camera_position`: the camera is more than `1 + WINDOW_HYSTERESIS_GROUPS` groups from the
/// window's center along some axis.
pub fn window_needs_move(
    config: &CacheConfig,
    level: u32,
    origin: IVec3,
    camera_position: Vec3,
) -> bool {
    let brick_size = config.brick_size_at(level);
    let center = (origin.as_vec3() + UVec3::from(config.level_bricks).as_vec3() * 0.5) * brick_size;
    let limit = config.group_size_at(level) * (1.0 + WINDOW_HYSTERESIS_GROUPS);
    (camera_position - center).abs().max_element() > limit
}

/// How one level's window changed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WindowShift {
    pub level: u32,
    /// Slabs of the old window outside the new one: their bricks are released.
    pub leaving: Vec<BrickBox>,
    /// Slabs of the new window outside the old one: their bricks are queued for filling.
    pub entering: Vec<BrickBox>,
}

/// The windows of every level.
#[derive(Clone, Debug, PartialEq)]
pub struct ClipmapWindows {
    /// `origin_brick` per level, finest first.
    pub origins: Vec<IVec3>,
    /// Bricks per window along x, y, z.
    pub level_bricks: UVec3,
}

impl ClipmapWindows {
    /// The windows of every level of `config` centered on `camera_position`.
    pub fn new(config: &CacheConfig, camera_position: Vec3) -> Self {
        Self {
            origins: (0..config.levels)
                .map(|level| window_origin(config, level, camera_position))
                .collect(),
            level_bricks: UVec3::from(config.level_bricks),
        }
    }

    /// The window of `level` as a brick box.
    pub fn window(&self, level: u32) -> BrickBox {
        BrickBox::new(self.origins[level as usize], self.level_bricks)
    }

    /// Re-centers on `camera_position` every level whose window the camera has strayed too far
    /// from ([`window_needs_move`]: hysteresis of [`WINDOW_HYSTERESIS_GROUPS`]) and returns the
    /// levels that moved, with the slabs that left and entered.
    pub fn recenter(&mut self, config: &CacheConfig, camera_position: Vec3) -> Vec<WindowShift> {
        let mut shifts = Vec::new();
        for level in 0..self.origins.len() as u32 {
            let old = self.window(level);
            if !window_needs_move(config, level, old.min, camera_position) {
                continue;
            }
            let origin = window_origin(config, level, camera_position);
            if origin == old.min {
                continue;
            }
            self.origins[level as usize] = origin;
            let new = self.window(level);
            shifts.push(WindowShift {
                level,
                leaving: old.difference(&new),
                entering: new.difference(&old),
            });
        }
        shifts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_partitions_the_box() {
        let a = BrickBox::new(IVec3::ZERO, UVec3::new(8, 4, 8));
        let b = BrickBox::new(IVec3::new(4, -4, 2), UVec3::new(8, 4, 8));
        let slabs = a.difference(&b);
        let total: u64 = slabs.iter().map(BrickBox::volume).sum();
        assert_eq!(total + a.intersection(&b).volume(), a.volume());
        for brick in a.bricks() {
            let in_slabs = slabs.iter().filter(|s| s.contains(brick)).count();
            assert_eq!(in_slabs, usize::from(!b.contains(brick)), "{brick}");
        }
        assert_eq!(a.difference(&a), vec![]);
    }

    #[test]
    fn a_camera_oscillating_over_a_group_boundary_moves_the_window_once() {
        let config = CacheConfig {
            levels: 2,
            level_bricks: [16, 8, 16],
            ..Default::default()
        };
        let group = config.group_size_at(0);
        // A group boundary of level 0 along x (the window center sits on one).
        let boundary = Vec3::new(3.0 * group, 0.5, 0.25);
        let mut windows = ClipmapWindows::new(&config, boundary + Vec3::X * 0.05 * group);
        let mut moves = 0;
        for step in 0..40 {
            let side = if step % 2 == 0 { -0.05 } else { 0.05 };
            let camera = boundary + Vec3::X * (side * group + step as f32 * 1e-3 * group);
            moves += windows.recenter(&config, camera).len();
        }
        assert_eq!(moves, 0, "oscillation by a tenth of a group moved a window");
        // Inside the band no move, beyond it a move that puts the camera near the center.
        let origin = windows.origins[0];
        assert!(
            windows
                .recenter(&config, boundary + Vec3::X * 1.2 * group)
                .is_empty()
        );
        let shifts = windows.recenter(&config, boundary + Vec3::X * 6.0 * group);
        assert_eq!(shifts.len(), 2, "a long move shifts both levels");
        assert_eq!(
            windows.origins[0],
            origin + IVec3::X * 6 * GROUP_BRICKS as i32
        );
        assert!(!window_needs_move(
            &config,
            0,
            windows.origins[0],
            boundary + Vec3::X * 6.0 * group
        ));
    }
}

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
/// camera is at most half a group (2 bricks) from the center along each axis.
pub fn window_origin(config: &CacheConfig, level: u32, camera_position: Vec3) -> IVec3 {
    let group = GROUP_BRICKS as f32;
    let camera_brick = camera_position / config.brick_size_at(level);
    let half = UVec3::from(config.level_bricks).as_vec3() * 0.5;
    ((camera_brick - half) / group).round().as_ivec3() * GROUP_BRICKS as i32
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

    /// Re-centers every level on `camera_position` and returns the levels that moved, with the
    /// slabs that left and entered.
    pub fn recenter(&mut self, config: &CacheConfig, camera_position: Vec3) -> Vec<WindowShift> {
        let mut shifts = Vec::new();
        for level in 0..self.origins.len() as u32 {
            let old = self.window(level);
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
}

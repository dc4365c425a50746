//! The CPU mirror of the cache's hierarchy: per level the link grid and the group masks, and
//! per pooled brick its occupancy mask, with the ranges changed since the last upload.
//!
//! The CPU owns the link grid and the group masks (it decides where bricks live); uploads
//! copy only the changed slot ranges. Brick masks are mirrored for caches filled on the CPU
//! ([`crate::CpuCache`]); when the GPU voxelizes, it writes them itself and the CPU never marks
//! them dirty.

use std::ops::Range;

use glam::{IVec3, UVec3};

use crate::config::CacheConfig;
use crate::layout::{GROUP_BRICKS, NO_BRICK, brick_slot, group_of_brick, group_slot, mask_bit};

/// A range of element indices changed since the last upload (empty when `start >= end`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DirtyRange {
    start: usize,
    end: usize,
}

impl DirtyRange {
    fn mark(&mut self, index: usize) {
        if self.start >= self.end {
            (self.start, self.end) = (index, index + 1);
        } else {
            self.start = self.start.min(index);
            self.end = self.end.max(index + 1);
        }
    }

    /// The changed indices, or `None`; resets the range.
    pub fn take(&mut self) -> Option<Range<usize>> {
        let range = self.start..self.end;
        *self = Self::default();
        (!range.is_empty()).then_some(range)
    }

    /// The changed indices without resetting.
    pub fn peek(&self) -> Option<Range<usize>> {
        let range = self.start..self.end;
        (!range.is_empty()).then_some(range)
    }
}

/// Link grids, group masks and brick masks of every level, as the GPU buffers hold them
/// (level-major, toroidal slots from [`brick_slot`] and [`group_slot`]).
#[derive(Clone, Debug)]
pub struct CacheStructure {
    level_bricks: UVec3,
    bricks_per_level: usize,
    groups_per_level: usize,
    /// Brick ID per level and brick slot (`cache_link`).
    pub link: Vec<u32>,
    /// Occupied-brick mask per level and group slot (`cache_group_masks`).
    pub group_masks: Vec<u64>,
    /// Voxel occupancy per brick ID (`cache_brick_masks`), entry 0 unused.
    pub brick_masks: Vec<u64>,
    /// Slots of `link` changed since the last upload.
    pub dirty_link: DirtyRange,
    /// Slots of `group_masks` changed since the last upload.
    pub dirty_group_masks: DirtyRange,
    /// Entries of `brick_masks` changed since the last upload.
    pub dirty_brick_masks: DirtyRange,
}

impl CacheStructure {
    /// An empty structure (every link 0) sized for `config`.
    pub fn new(config: &CacheConfig) -> Self {
        let levels = config.levels as usize;
        let bricks_per_level = config.bricks_per_level() as usize;
        let groups_per_level = config.groups_per_level() as usize;
        Self {
            level_bricks: UVec3::from(config.level_bricks),
            bricks_per_level,
            groups_per_level,
            link: vec![NO_BRICK; levels * bricks_per_level],
            group_masks: vec![0; levels * groups_per_level],
            brick_masks: vec![0; config.pool_bricks as usize + 1],
            dirty_link: DirtyRange::default(),
            dirty_group_masks: DirtyRange::default(),
            dirty_brick_masks: DirtyRange::default(),
        }
    }

    /// Index in `link` of world brick `brick` at `level`.
    pub fn link_index(&self, level: u32, brick: IVec3) -> usize {
        level as usize * self.bricks_per_level + brick_slot(brick, self.level_bricks) as usize
    }

    /// Index in `group_masks` of the group holding world brick `brick` at `level`.
    pub fn group_index(&self, level: u32, brick: IVec3) -> usize {
        level as usize * self.groups_per_level
            + group_slot(group_of_brick(brick), self.level_bricks) as usize
    }

    /// Brick ID at the slot of world brick `brick` (the caller checks the window).
    pub fn brick_id(&self, level: u32, brick: IVec3) -> u32 {
        self.link[self.link_index(level, brick)]
    }

    /// Points the slot of `brick` at `id` (or empties it with [`NO_BRICK`]) and keeps the
    /// group mask bit equal to "link is non-zero". Returns the ID the slot held.
    pub fn set_brick(&mut self, level: u32, brick: IVec3, id: u32) -> u32 {
        let link_index = self.link_index(level, brick);
        let previous = std::mem::replace(&mut self.link[link_index], id);
        if previous != id {
            self.dirty_link.mark(link_index);
        }
        let group_index = self.group_index(level, brick);
        let bit = 1u64 << mask_bit((brick & (GROUP_BRICKS as i32 - 1)).as_uvec3());
        let mask = &mut self.group_masks[group_index];
        let updated = if id == NO_BRICK {
            *mask & !bit
        } else {
            *mask | bit
        };
        if updated != *mask {
            *mask = updated;
            self.dirty_group_masks.mark(group_index);
        }
        previous
    }

    /// Empties the slot of `brick`; returns the ID it held ([`NO_BRICK`] if none).
    pub fn clear_brick(&mut self, level: u32, brick: IVec3) -> u32 {
        self.set_brick(level, brick, NO_BRICK)
    }

    /// Sets the voxel occupancy of brick `id`.
    pub fn set_brick_mask(&mut self, id: u32, mask: u64) {
        if self.brick_masks[id as usize] != mask {
            self.brick_masks[id as usize] = mask;
            self.dirty_brick_masks.mark(id as usize);
        }
    }

    /// Voxel occupancy of brick `id` as the CPU knows it.
    pub fn brick_mask(&self, id: u32) -> u64 {
        self.brick_masks[id as usize]
    }

    /// Group mask of the group holding world brick `brick`.
    pub fn group_mask(&self, level: u32, brick: IVec3) -> u64 {
        self.group_masks[self.group_index(level, brick)]
    }

    /// Marks every slot dirty (after creating the GPU buffers, so the first upload writes all).
    pub fn mark_all_dirty(&mut self) {
        for (range, len) in [
            (&mut self.dirty_link, self.link.len()),
            (&mut self.dirty_group_masks, self.group_masks.len()),
            (&mut self.dirty_brick_masks, self.brick_masks.len()),
        ] {
            if len > 0 {
                range.mark(0);
                range.mark(len - 1);
            }
        }
    }

    /// Checks the invariant "group bit set exactly where the link is non-zero" over every
    /// level; returns the first violation's level and group slot.
    pub fn check_group_masks(&self) -> Result<(), (usize, usize)> {
        let levels = self.link.len() / self.bricks_per_level.max(1);
        let mut expected = vec![0u64; self.group_masks.len()];
        let dims = self.level_bricks;
        for level in 0..levels {
            for slot in 0..self.bricks_per_level {
                if self.link[level * self.bricks_per_level + slot] == NO_BRICK {
                    continue;
                }
                let s = slot as u32;
                let cell = UVec3::new(s % dims.x, (s / dims.x) % dims.y, s / (dims.x * dims.y));
                let brick = cell.as_ivec3();
                let index = self.group_index(level as u32, brick);
                expected[index] |= 1u64 << mask_bit(cell % GROUP_BRICKS);
            }
        }
        match expected
            .iter()
            .zip(&self.group_masks)
            .position(|(a, b)| a != b)
        {
            Some(index) => Err((index / self.groups_per_level, index % self.groups_per_level)),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn group_masks_follow_the_links_and_dirty_ranges_cover_changes() {
        let config = CacheConfig {
            levels: 2,
            level_bricks: [8, 4, 8],
            pool_bricks: 16,
            ..Default::default()
        };
        let mut s = CacheStructure::new(&config);
        let brick = IVec3::new(-3, 5, 9);
        assert_eq!(s.set_brick(1, brick, 7), NO_BRICK);
        assert_eq!(s.brick_id(1, brick), 7);
        assert_ne!(s.group_mask(1, brick), 0);
        let link = s.dirty_link.take().unwrap();
        assert!(link.contains(&s.link_index(1, brick)));
        assert!(s.dirty_link.take().is_none());
        s.check_group_masks().unwrap();
        assert_eq!(s.clear_brick(1, brick), 7);
        assert_eq!(s.group_mask(1, brick), 0);
        s.check_group_masks().unwrap();
    }
}

//! [`FillQueue`]: the bricks waiting to be voxelized, kept per level so that choosing a
//! frame's batch reads only the levels it takes from.

use foldhash::{HashMap, HashMapExt};
use glam::{IVec3, Vec3};

use crate::binning::{FillKey, fill_key};
use crate::clipmap::ClipmapWindows;
use crate::config::CacheConfig;

/// A queued brick: its level and world brick coordinate.
pub type QueuedBrick = (u32, IVec3);

/// The bricks waiting to be voxelized, each once, in no order.
///
/// The fill order ([`fill_key`]) goes by level first, so the first bricks in it lie in the
/// finest levels that hold that many: [`FillQueue::take_first`] keys only those. While the
/// camera flies the queue holds thousands of bricks over every level and the batch comes
/// from the finest one or two, so keying the whole queue every frame (a distance each) was
/// most of the choice's cost.
pub struct FillQueue {
    /// Per level, its queued bricks.
    levels: Vec<Vec<IVec3>>,
    /// Every queued brick and its place in its level's list, where `placed` says the places
    /// are current.
    members: HashMap<QueuedBrick, u32>,
    /// Per level, whether its places in `members` are current: taking and retaining reorder a
    /// list without updating them, and the first removal after that places its level anew
    /// (a queue that never removes never pays for them).
    placed: Vec<bool>,
}

impl FillQueue {
    /// An empty queue for `levels` levels.
    pub fn new(levels: u32) -> Self {
        Self {
            levels: vec![Vec::new(); levels as usize],
            members: HashMap::new(),
            placed: vec![true; levels as usize],
        }
    }

    /// Number of queued bricks.
    pub fn len(&self) -> usize {
        self.members.len()
    }

    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    /// Whether `entry` is queued.
    pub fn contains(&self, entry: &QueuedBrick) -> bool {
        self.members.contains_key(entry)
    }

    /// Queues `entry`; false when it was queued already (or its level is out of range).
    pub fn push(&mut self, entry: QueuedBrick) -> bool {
        let Some(list) = self.levels.get_mut(entry.0 as usize) else {
            return false;
        };
        if self.members.contains_key(&entry) {
            return false;
        }
        self.members.insert(entry, list.len() as u32);
        list.push(entry.1);
        true
    }

    /// Removes `entry`; false when it was not queued.
    pub fn remove(&mut self, entry: &QueuedBrick) -> bool {
        if !self.members.contains_key(entry) {
            return false;
        }
        let level = entry.0 as usize;
        let list = &mut self.levels[level];
        if !self.placed[level] {
            for (place, &brick) in list.iter().enumerate() {
                if let Some(slot) = self.members.get_mut(&(entry.0, brick)) {
                    *slot = place as u32;
                }
            }
            self.placed[level] = true;
        }
        let place = self.members.remove(entry).expect("queued");
        list.swap_remove(place as usize);
        if let Some(&moved) = list.get(place as usize) {
            self.members.insert((entry.0, moved), place);
        }
        true
    }

    /// Queues every brick of `entries` (bricks taken but not voxelized after all).
    pub fn put_back(&mut self, entries: impl IntoIterator<Item = QueuedBrick>) {
        for entry in entries {
            self.push(entry);
        }
    }

    /// Drops the bricks outside their level's window.
    pub fn retain_inside(&mut self, windows: &ClipmapWindows) {
        for (level, list) in self.levels.iter_mut().enumerate() {
            let window = windows.window(level as u32);
            let members = &mut self.members;
            let before = list.len();
            list.retain(|&brick| {
                let inside = window.contains(brick);
                if !inside {
                    members.remove(&(level as u32, brick));
                }
                inside
            });
            if list.len() != before {
                self.placed[level] = false;
            }
        }
    }

    /// Removes and returns the first `count` queued bricks in fill order from `camera` (all of
    /// them when fewer are queued), in that order: whole finer levels, then the nearest of the
    /// level where the count ends, selected in linear time. Coarser levels are not keyed.
    /// `scratch` is reused memory for the keys.
    pub fn take_first(
        &mut self,
        config: &CacheConfig,
        camera: Vec3,
        count: usize,
        scratch: &mut Vec<(FillKey, QueuedBrick)>,
    ) -> Vec<QueuedBrick> {
        let mut batch = Vec::with_capacity(count.min(self.len()));
        for (level, list) in self.levels.iter_mut().enumerate() {
            let wanted = count - batch.len();
            if wanted == 0 {
                break;
            }
            let level = level as u32;
            scratch.clear();
            scratch.extend(list.drain(..).map(|brick| {
                let entry = (level, brick);
                (fill_key(config, camera, entry), entry)
            }));
            if wanted < scratch.len() {
                // The order is total, so the batch does not depend on the queue's order.
                scratch.select_nth_unstable_by_key(wanted, |(key, _)| *key);
                list.extend(scratch[wanted..].iter().map(|(_, (_, brick))| *brick));
                scratch.truncate(wanted);
                self.placed[level as usize] = false;
            }
            scratch.sort_unstable_by_key(|(key, _)| *key);
            for &(_, entry) in scratch.iter() {
                self.members.remove(&entry);
                batch.push(entry);
            }
        }
        batch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The batch is the first bricks of a sort of the whole queue in fill order, whichever
    /// level the count ends in, and the rest stay queued; removed bricks are not taken.
    #[test]
    fn takes_the_first_bricks_of_a_full_sort() {
        let config = CacheConfig::default();
        let camera = Vec3::new(0.3, 1.7, -2.2);
        let windows = ClipmapWindows::new(&config, camera);
        let mut entries = Vec::new();
        let mut state = 12345u32;
        let mut next = |n: i32| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as i32 % n
        };
        for level in 0..4u32 {
            let window = windows.window(level);
            for _ in 0..(40 + 30 * level) {
                let size = window.max - window.min;
                let brick = window.min + IVec3::new(next(size.x), next(size.y), next(size.z));
                entries.push((level, brick));
            }
        }
        for count in [0, 1, 25, 40, 41, 100, 1000] {
            let mut queue = FillQueue::new(config.levels);
            let mut unique = Vec::new();
            for &entry in &entries {
                if queue.push(entry) {
                    unique.push(entry);
                }
            }
            assert!(
                !queue.push(entries[0]),
                "a queued brick is not queued twice"
            );
            // Removed bricks leave the queue, whatever their place in their level.
            let removed: Vec<QueuedBrick> = unique.iter().step_by(7).copied().collect();
            for entry in &removed {
                assert!(queue.remove(entry));
                assert!(!queue.remove(entry), "removed twice");
            }
            unique.retain(|entry| !removed.contains(entry));
            assert_eq!(queue.len(), unique.len());
            unique.sort_by_key(|&entry| fill_key(&config, camera, entry));
            let batch = queue.take_first(&config, camera, count, &mut Vec::new());
            let expected = &unique[..count.min(unique.len())];
            assert_eq!(batch, expected, "count {count}");
            assert_eq!(queue.len(), unique.len() - batch.len());
            for entry in &unique {
                assert_eq!(queue.contains(entry), !batch.contains(entry));
            }
            // What stays can still be removed one by one, each from its place.
            let left: Vec<QueuedBrick> = unique
                .iter()
                .filter(|entry| !batch.contains(entry))
                .copied()
                .collect();
            for entry in left.iter().rev() {
                assert!(queue.remove(entry), "count {count}");
            }
            assert!(queue.is_empty());
            assert!(
                queue
                    .take_first(&config, camera, 10, &mut Vec::new())
                    .is_empty()
            );
        }
    }
}

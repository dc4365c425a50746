//! The allocated bricks, kept as they are allocated and released: each pool ID's level and
//! brick, and one set of IDs per level.
//!
//! The passes that run every frame over the resident bricks (the lighting schedule, the
//! choice of bricks for screen injection, the eviction candidates) read these sets instead of
//! listing the pool: a level's IDs are a bitset of 64 IDs a word, so walking them in pool-ID
//! order, skipping levels, or intersecting them with another set of IDs costs a word per 64
//! IDs, 192 words for the default pool of 12,288 bricks.

use glam::IVec3;

use crate::cache::ResidentBrick;

/// A set of pool IDs as bits, 64 IDs a word; grows as IDs are inserted.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IdSet {
    words: Vec<u64>,
}

impl IdSet {
    /// An empty set with room for the IDs below `ids` without growing.
    pub fn with_ids(ids: usize) -> Self {
        Self {
            words: vec![0; ids.div_ceil(64)],
        }
    }

    pub fn insert(&mut self, id: u32) {
        let word = id as usize / 64;
        if word >= self.words.len() {
            self.words.resize(word + 1, 0);
        }
        self.words[word] |= 1 << (id % 64);
    }

    pub fn remove(&mut self, id: u32) {
        if let Some(word) = self.words.get_mut(id as usize / 64) {
            *word &= !(1 << (id % 64));
        }
    }

    pub fn contains(&self, id: u32) -> bool {
        self.word(id as usize / 64) & (1 << (id % 64)) != 0
    }

    /// Word `index` (IDs `64 index ..`), 0 past the end.
    pub fn word(&self, index: usize) -> u64 {
        self.words.get(index).copied().unwrap_or(0)
    }

    /// Words held (IDs below `64 words` can be members).
    pub fn words(&self) -> usize {
        self.words.len()
    }

    pub fn clear(&mut self) {
        self.words.fill(0);
    }

    /// Members.
    pub fn len(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.words.iter().all(|&w| w == 0)
    }

    /// Members in ascending order.
    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.words
            .iter()
            .enumerate()
            .flat_map(|(index, &word)| bits(word, index))
    }
}

/// The IDs of the set bits of `word`, word `index` of a set, ascending.
pub fn bits(mut word: u64, index: usize) -> impl Iterator<Item = u32> {
    std::iter::from_fn(move || {
        (word != 0).then(|| {
            let bit = word.trailing_zeros();
            word &= word - 1;
            index as u32 * 64 + bit
        })
    })
}

/// Each allocated pool ID's level and brick, and the IDs of each level.
#[derive(Clone, Debug)]
pub struct Residency {
    /// Level and brick of each allocated ID (`owner[id]`).
    owner: Vec<Option<(u32, IVec3)>>,
    /// The allocated IDs of each level.
    levels: Vec<IdSet>,
    /// Members of each of `levels`.
    level_counts: Vec<u32>,
    count: usize,
}

impl Residency {
    /// No brick resident, room for pool IDs up to `pool_bricks` in `levels` levels.
    pub fn new(pool_bricks: u32, levels: u32) -> Self {
        let ids = pool_bricks as usize + 1;
        Self {
            owner: vec![None; ids],
            levels: vec![IdSet::with_ids(ids); levels as usize],
            level_counts: vec![0; levels as usize],
            count: 0,
        }
    }

    /// The residency of `bricks` (distinct pool IDs, levels below `levels`).
    pub fn from_bricks(levels: u32, bricks: &[ResidentBrick]) -> Self {
        let ids = bricks.iter().map(|b| b.brick_id).max().unwrap_or(0);
        let mut residency = Self::new(ids, levels);
        for b in bricks {
            residency.insert(*b);
        }
        residency
    }

    /// Makes `b.brick_id` hold `b` (in place of what it held).
    pub fn insert(&mut self, b: ResidentBrick) {
        self.remove(b.brick_id);
        let id = b.brick_id as usize;
        if id >= self.owner.len() {
            self.owner.resize(id + 1, None);
        }
        self.owner[id] = Some((b.level, b.brick));
        self.levels[b.level as usize].insert(b.brick_id);
        self.level_counts[b.level as usize] += 1;
        self.count += 1;
    }

    /// Releases `id`; what it held, if anything.
    pub fn remove(&mut self, id: u32) -> Option<ResidentBrick> {
        let (level, brick) = self.owner.get_mut(id as usize)?.take()?;
        self.levels[level as usize].remove(id);
        self.level_counts[level as usize] -= 1;
        self.count -= 1;
        Some(ResidentBrick {
            level,
            brick,
            brick_id: id,
        })
    }

    /// What `id` holds.
    pub fn get(&self, id: u32) -> Option<ResidentBrick> {
        let (level, brick) = (*self.owner.get(id as usize)?)?;
        Some(ResidentBrick {
            level,
            brick,
            brick_id: id,
        })
    }

    /// Resident bricks.
    pub fn len(&self) -> usize {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Levels.
    pub fn levels(&self) -> u32 {
        self.levels.len() as u32
    }

    /// One more than the largest pool ID this residency has room for.
    pub fn id_bound(&self) -> usize {
        self.owner.len()
    }

    /// The IDs resident at `level` (empty past the last level).
    pub fn level(&self, level: u32) -> &IdSet {
        static EMPTY: IdSet = IdSet { words: Vec::new() };
        self.levels.get(level as usize).unwrap_or(&EMPTY)
    }

    /// Bricks resident at `level`.
    pub fn level_len(&self, level: u32) -> usize {
        self.level_counts.get(level as usize).copied().unwrap_or(0) as usize
    }

    /// Every resident brick in pool-ID order.
    pub fn iter(&self) -> impl Iterator<Item = ResidentBrick> + '_ {
        (0..self.owner.len() as u32).filter_map(|id| self.get(id))
    }

    /// The resident bricks of `level` in pool-ID order.
    pub fn iter_level(&self, level: u32) -> impl Iterator<Item = ResidentBrick> + '_ {
        self.level(level)
            .iter()
            .map(|id| self.get(id).expect("a member of a level is resident"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brick(level: u32, x: i32, id: u32) -> ResidentBrick {
        ResidentBrick {
            level,
            brick: IVec3::new(x, 0, 0),
            brick_id: id,
        }
    }

    #[test]
    fn sets_follow_insertions_and_releases() {
        let mut set = IdSet::with_ids(10);
        for id in [3, 64, 9, 200, 63] {
            set.insert(id);
        }
        set.remove(9);
        set.remove(1000);
        assert_eq!(set.iter().collect::<Vec<_>>(), [3, 63, 64, 200]);
        assert_eq!(set.len(), 4);
        assert!(set.contains(200) && !set.contains(9) && !set.contains(5000));
        set.clear();
        assert!(set.is_empty());
    }

    #[test]
    fn levels_hold_what_the_ids_hold() {
        let mut residency = Residency::new(130, 3);
        for b in [
            brick(0, 1, 5),
            brick(2, 2, 70),
            brick(0, 3, 130),
            brick(1, 4, 1),
        ] {
            residency.insert(b);
        }
        // An ID given another brick moves to its level; a free ID releases nothing.
        residency.insert(brick(2, 9, 5));
        assert_eq!(residency.remove(70), Some(brick(2, 2, 70)));
        assert_eq!(residency.remove(70), None);
        assert_eq!(residency.remove(9999), None);
        assert_eq!(residency.len(), 3);
        assert_eq!(
            residency.iter().collect::<Vec<_>>(),
            [brick(1, 4, 1), brick(2, 9, 5), brick(0, 3, 130)]
        );
        assert_eq!(
            (0..3).map(|l| residency.level_len(l)).collect::<Vec<_>>(),
            [1, 1, 1]
        );
        assert_eq!(
            residency.iter_level(2).collect::<Vec<_>>(),
            [brick(2, 9, 5)]
        );
        assert_eq!(residency.get(130), Some(brick(0, 3, 130)));
        assert_eq!(residency.get(70), None);
        assert!(residency.level(7).is_empty());
    }
}

//! [`PingPong`]: a temporal pass's two copies of a resource, this frame's and the previous
//! frame's.

/// Two resources of which one is this frame's ([`PingPong::current`]) and the other the
/// previous frame's ([`PingPong::history`]); [`PingPong::swap`] ends a frame, so the one just
/// written becomes the history of the next.
#[derive(Debug)]
pub struct PingPong<T> {
    pair: [T; 2],
    current: usize,
}

impl<T> PingPong<T> {
    /// The pair, the first of them current.
    pub fn new(pair: [T; 2]) -> Self {
        Self { pair, current: 0 }
    }

    /// Two resources made by `make` (called with 0 and 1).
    pub fn from_fn(make: impl FnMut(usize) -> T) -> Self {
        Self::new(std::array::from_fn(make))
    }

    /// This frame's.
    pub fn current(&self) -> &T {
        &self.pair[self.current]
    }

    /// The previous frame's.
    pub fn history(&self) -> &T {
        &self.pair[1 - self.current]
    }

    /// Ends a frame: the current one becomes the history.
    pub fn swap(&mut self) {
        self.current = 1 - self.current;
    }

    /// For the one of index `write` (0 or 1, as [`PingPong::from_fn`] made them): the other
    /// one and it, `(read, write)`: what a frame that writes it reads as its history. For
    /// resources made per side, such as the bind groups of a ping-pong of buffers.
    pub fn read_write(&self, write: usize) -> (&T, &T) {
        let write = write.min(1);
        (&self.pair[1 - write], &self.pair[write])
    }

    /// Both, in creation order.
    pub fn both(&self) -> impl Iterator<Item = &T> {
        self.pair.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_swap_makes_the_current_one_the_history() {
        let mut pair = PingPong::from_fn(|i| i * 10);
        assert_eq!((*pair.current(), *pair.history()), (0, 10));
        pair.swap();
        assert_eq!((*pair.current(), *pair.history()), (10, 0));
        pair.swap();
        assert_eq!(*pair.current(), 0);
        assert_eq!(pair.both().copied().collect::<Vec<_>>(), [0, 10]);
        assert_eq!(pair.read_write(1), (&0, &10));
    }
}

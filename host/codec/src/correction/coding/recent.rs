//! Recently used vertices, most recent first, with the next id never seen and the last one
//! used: how the corner coders name a vertex that no edge predicts.

/// A move-to-front list of at most `capacity` vertex ids. A long list can keep a membership
/// flag per id, so that a vertex not in it (most often a new one) is known without a scan.
pub(crate) struct RecentVertices {
    list: Vec<u32>,
    capacity: usize,
    /// Per vertex id below a bound fixed at creation: whether it is in `list`. Ids past it
    /// (and all ids without flags) are looked for by scanning, so untrusted ids never make
    /// this grow.
    listed: Vec<bool>,
    next_new: u32,
    last: u32,
}

impl RecentVertices {
    /// A list found by scanning: for short ones.
    pub(crate) fn new(capacity: usize) -> Self {
        Self::flagged(capacity, 0)
    }

    /// A list with membership flags for ids below `vertex_count`.
    pub(crate) fn flagged(capacity: usize, vertex_count: usize) -> Self {
        Self {
            list: Vec::with_capacity(capacity),
            capacity,
            listed: vec![false; vertex_count],
            next_new: 0,
            last: 0,
        }
    }

    /// Forgets the list; `first_new` is the lowest id no vertex from now on can have used.
    pub(crate) fn restart(&mut self, first_new: u32) {
        for v in std::mem::take(&mut self.list) {
            self.set_listed(v, false);
        }
        self.next_new = first_new;
        self.last = first_new.saturating_sub(1);
    }

    /// `v`'s place in the list, 0 for the most recent.
    pub(crate) fn rank(&self, v: u32) -> Option<usize> {
        if self.listed.get(v as usize) == Some(&false) {
            return None;
        }
        self.list.iter().position(|&x| x == v)
    }

    /// The vertex at `rank`.
    pub(crate) fn get(&self, rank: usize) -> Option<u32> {
        self.list.get(rank).copied()
    }

    /// The lowest id above every id seen (or `restart`'s `first_new`).
    pub(crate) fn next_new(&self) -> u32 {
        self.next_new
    }

    /// The vertex seen last, the base of explicit deltas.
    pub(crate) fn last(&self) -> u32 {
        self.last
    }

    /// Moves `v` to the front, dropping the oldest entry when full.
    pub(crate) fn saw(&mut self, v: u32) {
        match self.rank(v) {
            Some(i) => self.list[..=i].rotate_right(1),
            None => {
                if self.list.len() == self.capacity
                    && let Some(oldest) = self.list.pop()
                {
                    self.set_listed(oldest, false);
                }
                self.list.insert(0, v);
                self.set_listed(v, true);
            }
        }
        self.next_new = self.next_new.max(v.saturating_add(1));
        self.last = v;
    }

    fn set_listed(&mut self, v: u32, listed: bool) {
        if let Some(flag) = self.listed.get_mut(v as usize) {
            *flag = listed;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn most_recent_first_oldest_dropped_and_restart_forgets() {
        // Flags for ids below 10 only: 11 and the huge id are found by scanning.
        for mut recent in [RecentVertices::new(3), RecentVertices::flagged(3, 10)] {
            for v in [5, 7, 9, 7] {
                recent.saw(v);
            }
            assert_eq!(
                [recent.rank(7), recent.rank(9), recent.rank(5)],
                [Some(0), Some(1), Some(2)]
            );
            recent.saw(11);
            let state = |r: &RecentVertices| (r.rank(5), r.get(0), r.next_new(), r.last());
            assert_eq!(state(&recent), (None, Some(11), 12, 11));
            recent.saw(u32::MAX);
            assert_eq!((recent.rank(u32::MAX), recent.rank(11)), (Some(0), Some(1)));
            recent.restart(40);
            assert_eq!((recent.rank(11), state(&recent)), (None, (None, None, 40, 39)));
        }
    }
}

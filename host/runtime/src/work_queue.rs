//! Items of one run handed out one at a time to workers that each hold a run slot: what a
//! run on partitions and several checks on one mesh share. The caller works with the slot
//! it already holds; helpers join only with slots that free up while items are left, so a
//! run never makes others wait for more than the items its helpers hold.

use std::ops::Range;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use super::{Runtime, permits::Permit};

/// Items `0..len`, each taken once, from the front or from the back, until all are taken or
/// the queue is stopped.
pub(crate) struct WorkQueue {
    left: Mutex<Range<usize>>,
    stopped: AtomicBool,
}

/// Which end of a [`WorkQueue`] a worker takes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum End {
    Front,
    Back,
}

impl WorkQueue {
    pub(crate) fn new(len: usize) -> Self {
        Self { left: Mutex::new(0..len), stopped: AtomicBool::new(false) }
    }

    /// The next item from `end`, unless every item is taken or the queue was stopped.
    pub(crate) fn take(&self, end: End) -> Option<usize> {
        if self.stopped.load(Ordering::Relaxed) {
            return None;
        }
        let mut left = self.left.lock().unwrap_or_else(|e| e.into_inner());
        match end {
            End::Front => left.next(),
            End::Back => left.next_back(),
        }
    }

    /// Hands out nothing more (an item failed: the run has failed).
    pub(crate) fn stop(&self) {
        self.stopped.store(true, Ordering::Relaxed);
    }

    /// Whether an item is still to be taken.
    pub(crate) fn has_more(&self) -> bool {
        !self.stopped.load(Ordering::Relaxed)
            && !self.left.lock().unwrap_or_else(|e| e.into_inner()).is_empty()
    }
}

impl Runtime {
    /// Workers for `items` items: as many as run slots and cores allow (more would only
    /// hold more memory), at least one.
    pub(crate) fn workers_for(&self, items: usize) -> usize {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.limits.concurrent_runs.min(cores).clamp(1, items.max(1))
    }

    /// Runs `work` on this thread with `slot`, and on up to `workers - 1` helper threads,
    /// each with a slot it waits for only while `queue` has items left; returns when all
    /// have returned. `work` takes its items from `queue`, from the end it is given: this
    /// thread's is the front, the helpers' the back.
    pub(crate) fn with_helpers(
        &self,
        slot: &Permit<'_>,
        workers: usize,
        queue: &WorkQueue,
        work: impl Fn(&Permit<'_>, End) + Sync,
    ) {
        std::thread::scope(|scope| {
            for _ in 1..workers {
                scope.spawn(|| {
                    if let Some(slot) = self.permits.acquire_while(|| queue.has_more()) {
                        work(&slot, End::Back);
                    }
                });
            }
            work(slot, End::Front);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_taken_once_until_the_queue_stops() {
        let queue = WorkQueue::new(4);
        assert_eq!([queue.take(End::Front), queue.take(End::Back)], [Some(0), Some(3)]);
        assert_eq!(queue.take(End::Front), Some(1));
        assert!(queue.has_more());
        assert_eq!(queue.take(End::Back), Some(2));
        assert!(!queue.has_more());
        assert_eq!([queue.take(End::Front), queue.take(End::Back)], [None, None]);
        let queue = WorkQueue::new(3);
        queue.stop();
        assert!(!queue.has_more());
        assert_eq!(queue.take(End::Front), None);
    }
}

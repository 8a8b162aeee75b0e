//! A counting semaphore bounding the runs in flight, so a busy host queues instead of
//! oversubscribing memory, with a bound on the queue: beyond it a run is refused at once
//! ([`Full`]) rather than parking one more thread for an unknown time.

use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

pub(crate) struct Permits {
    counts: Mutex<Counts>,
    released: Condvar,
    count: usize,
}

struct Counts {
    free: usize,
    waiting: usize,
}

/// A run slot, held until dropped.
pub(crate) struct Permit<'a>(&'a Permits);

/// Every slot is taken and the queue is full.
#[derive(Debug)]
pub(crate) struct Full;

impl Permits {
    pub(crate) fn new(count: usize) -> Self {
        Self {
            counts: Mutex::new(Counts { free: count.max(1), waiting: 0 }),
            released: Condvar::new(),
            count: count.max(1),
        }
    }

    /// Slots held now.
    pub(crate) fn in_use(&self) -> usize {
        self.count - self.counts.lock().unwrap_or_else(|e| e.into_inner()).free
    }

    /// A slot, after waiting in line behind at most `max_waiting` others (`None`: no bound),
    /// and how long the wait took.
    pub(crate) fn acquire(
        &self,
        max_waiting: Option<usize>,
    ) -> Result<(Permit<'_>, Duration), Full> {
        let started = Instant::now();
        let mut counts = self.counts.lock().unwrap_or_else(|e| e.into_inner());
        if counts.free == 0 && max_waiting.is_some_and(|max| counts.waiting >= max) {
            return Err(Full);
        }
        counts.waiting += 1;
        while counts.free == 0 {
            counts = self.released.wait(counts).unwrap_or_else(|e| e.into_inner());
        }
        counts.waiting -= 1;
        counts.free -= 1;
        Ok((Permit(self), started.elapsed()))
    }
}

impl Permits {
    /// A slot, waited for (with no bound on the queue) only as long as `keep_waiting`
    /// holds, which is asked again every [`RECHECK`]; `None` once it does not.
    pub(crate) fn acquire_while(&self, keep_waiting: impl Fn() -> bool) -> Option<Permit<'_>> {
        let mut counts = self.counts.lock().unwrap_or_else(|e| e.into_inner());
        counts.waiting += 1;
        while counts.free == 0 {
            if !keep_waiting() {
                counts.waiting -= 1;
                return None;
            }
            counts =
                self.released.wait_timeout(counts, RECHECK).unwrap_or_else(|e| e.into_inner()).0;
        }
        counts.waiting -= 1;
        counts.free -= 1;
        Some(Permit(self))
    }
}

/// How often a waiter of [`Permits::acquire_while`] asks whether it still wants a slot.
const RECHECK: Duration = Duration::from_millis(20);

impl Drop for Permit<'_> {
    fn drop(&mut self) {
        self.0.counts.lock().unwrap_or_else(|e| e.into_inner()).free += 1;
        self.0.released.notify_one();
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;

    #[test]
    fn beyond_the_slots_and_the_queue_a_run_is_refused_and_a_queued_one_waits() {
        let permits = Arc::new(Permits::new(1));
        let (held, waited) = permits.acquire(Some(1)).unwrap();
        assert!(waited < Duration::from_millis(100));
        let queued = {
            let permits = permits.clone();
            std::thread::spawn(move || permits.acquire(Some(1)).map(|(_, waited)| waited).ok())
        };
        // Wait until the second run is in line; a third finds slot and queue full.
        while permits.counts.lock().unwrap().waiting == 0 {
            std::thread::yield_now();
        }
        assert!(permits.acquire(Some(1)).is_err());
        std::thread::sleep(Duration::from_millis(50));
        drop(held);
        assert!(queued.join().unwrap().unwrap() >= Duration::from_millis(50));
        // With no bound (plugin loads), a caller always gets in line.
        assert!(permits.acquire(None).is_ok());
    }

    #[test]
    fn a_waiter_that_no_longer_wants_a_slot_stops_waiting() {
        let permits = Permits::new(1);
        let (held, _) = permits.acquire(None).unwrap();
        let started = Instant::now();
        let wanted_until = started + Duration::from_millis(60);
        assert!(permits.acquire_while(|| Instant::now() < wanted_until).is_none());
        assert!(started.elapsed() < Duration::from_secs(2));
        assert_eq!(permits.counts.lock().unwrap().waiting, 0, "it left the queue");
        drop(held);
        assert!(permits.acquire_while(|| true).is_some());
    }
}

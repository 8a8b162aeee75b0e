//! Run slots per client: each API token (all anonymous clients together count as one) may
//! have [`MAX_ACTIVE_RUNS_PER_CLIENT`] runs executing and [`MAX_QUEUED_RUNS_PER_CLIENT`]
//! waiting; beyond that a submission is refused, so one client cannot occupy every host.

use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::limits::{MAX_ACTIVE_RUNS_PER_CLIENT, MAX_QUEUED_RUNS_PER_CLIENT};

#[derive(Default)]
pub struct Admission {
    clients: Mutex<HashMap<String, Arc<Slots>>>,
}

struct Slots {
    running: Arc<Semaphore>,
    /// Runs admitted and not yet ended, running or waiting.
    admitted: AtomicUsize,
}

/// A client already has as many runs going and waiting as allowed.
#[derive(Debug, thiserror::Error)]
#[error(
    "too many runs: {MAX_ACTIVE_RUNS_PER_CLIENT} may run and {MAX_QUEUED_RUNS_PER_CLIENT} wait \
     per client; try again when some have finished"
)]
pub struct Busy;

/// An admitted run's place; it frees the place when dropped.
pub struct Ticket(Arc<Slots>);

impl Admission {
    /// Admits a run of `client`, or refuses it when the client's queue is full.
    pub fn admit(&self, client: &str) -> Result<Ticket, Busy> {
        let slots = self
            .clients
            .lock()
            .unwrap()
            .entry(client.to_owned())
            .or_insert_with(|| {
                Arc::new(Slots {
                    running: Arc::new(Semaphore::new(MAX_ACTIVE_RUNS_PER_CLIENT)),
                    admitted: AtomicUsize::new(0),
                })
            })
            .clone();
        let limit = MAX_ACTIVE_RUNS_PER_CLIENT + MAX_QUEUED_RUNS_PER_CLIENT;
        slots
            .admitted
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < limit).then_some(n + 1))
            .map_err(|_| Busy)?;
        Ok(Ticket(slots))
    }
}

impl Ticket {
    /// Waits for one of the client's run slots.
    pub async fn slot(&self) -> OwnedSemaphorePermit {
        self.0.running.clone().acquire_owned().await.expect("the semaphore is never closed")
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        self.0.admitted.fetch_sub(1, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_client_beyond_its_slots_and_queue_is_refused_while_others_are_not() {
        let admission = Admission::default();
        let limit = MAX_ACTIVE_RUNS_PER_CLIENT + MAX_QUEUED_RUNS_PER_CLIENT;
        let tickets: Vec<Ticket> = (0..limit).map(|_| admission.admit("a").unwrap()).collect();
        assert!(admission.admit("a").is_err());
        assert!(admission.admit("b").is_ok(), "another client has its own slots");
        let mut permits = Vec::new();
        for ticket in &tickets[..MAX_ACTIVE_RUNS_PER_CLIENT] {
            permits.push(ticket.slot().await);
        }
        let waiting = tokio::time::timeout(
            std::time::Duration::from_millis(50),
            tickets[MAX_ACTIVE_RUNS_PER_CLIENT].slot(),
        );
        assert!(waiting.await.is_err(), "a queued run waits for a slot");
        drop(tickets);
        assert!(admission.admit("a").is_ok(), "ended runs free their places");
    }
}

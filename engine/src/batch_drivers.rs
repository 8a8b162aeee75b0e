//! The batches this engine is driving, so that one can be cancelled (`POST
//! /batches/{id}/cancel`) and a user's active batches counted against
//! [`MAX_ACTIVE_BATCHES_PER_USER`](crate::limits::MAX_ACTIVE_BATCHES_PER_USER). A batch counts
//! from its submission until its driver has started (or refused) every input and all its runs
//! have ended.

use std::collections::HashMap;
use std::sync::Mutex;

use tokio_util::sync::CancellationToken;

/// What an input not started when its batch was cancelled records as its error.
pub const CANCELLED_ENTRY: &str = "cancelled before it started";

#[derive(Clone)]
pub struct Driver {
    pub user: String,
    /// Cancelled to stop the batch: no more runs start, the driver cancels the ones going.
    pub cancel: CancellationToken,
    /// Cancelled by the driver as it ends (every entry started, refused or marked cancelled,
    /// and stored).
    pub done: CancellationToken,
}

#[derive(Default)]
pub struct Drivers {
    by_batch: Mutex<HashMap<String, Driver>>,
}

impl Drivers {
    /// Registers batch `id` of `user`, unless the user has `limit` active already.
    pub fn add(&self, id: &str, user: &str, limit: usize) -> Option<Driver> {
        let mut table = self.by_batch.lock().expect("batch drivers lock");
        if table.values().filter(|d| d.user == user).count() >= limit {
            return None;
        }
        let driver = Driver {
            user: user.to_owned(),
            cancel: CancellationToken::new(),
            done: CancellationToken::new(),
        };
        table.insert(id.to_owned(), driver.clone());
        Some(driver)
    }

    /// Registers a batch resumed after a restart (no limit: it was admitted before).
    pub fn resume(&self, id: &str, user: &str) -> Driver {
        self.add(id, user, usize::MAX).expect("no limit")
    }

    pub fn get(&self, id: &str) -> Option<Driver> {
        self.by_batch.lock().expect("batch drivers lock").get(id).cloned()
    }

    pub fn remove(&self, id: &str) {
        self.by_batch.lock().expect("batch drivers lock").remove(id);
    }
}

//! [`Assignments`]: which worker holds which episodes of the current iteration.
//!
//! Live workers (by slot and incarnation) with their outstanding episodes, and a queue of
//! unassigned ones. Work is dealt round-robin over the live workers whenever there is queued
//! work; a lost worker's outstanding episodes go back to the queue.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use envpg_protocol::EpisodeId;
use envpg_transport::{LearnerEnd, TransportError};
use iceoryx2::prelude::Service;

#[derive(Debug)]
struct Slot {
    incarnation: u64,
    last_seen: Instant,
    outstanding: BTreeSet<EpisodeId>,
}

/// Episode assignments of the current iteration.
#[derive(Debug)]
pub struct Assignments {
    timeout: Duration,
    k: u64,
    slots: BTreeMap<u32, Slot>,
    queue: BTreeSet<EpisodeId>,
    /// Every worker slot each episode of this iteration was handed to: only those may deliver
    /// it (a late delivery from a worker presumed dead is still welcome, since episodes are
    /// deterministic; a message claiming any other worker is refused).
    handed: BTreeMap<EpisodeId, BTreeSet<u32>>,
}

impl Assignments {
    /// No workers yet; `timeout` of silence means dead.
    pub fn new(timeout: Duration) -> Self {
        Self { timeout, k: 0, slots: BTreeMap::new(), queue: BTreeSet::new(), handed: BTreeMap::new() }
    }

    /// Live workers.
    pub fn live(&self) -> usize {
        self.slots.len()
    }

    /// A new iteration: every episode is queued, nobody holds anything.
    pub fn start_iteration(&mut self, k: u64, ids: &[EpisodeId]) {
        self.k = k;
        self.queue = ids.iter().copied().collect();
        self.handed.clear();
        for s in self.slots.values_mut() {
            s.outstanding.clear();
        }
    }

    /// A worker joined (or rejoined with a new incarnation); returns 1 if it replaced a live
    /// predecessor whose work was requeued.
    pub fn join(&mut self, id: u32, incarnation: u64, reassigned: &mut u64) -> u64 {
        let mut lost = 0;
        if let Some(old) = self.slots.get(&id) {
            if old.incarnation == incarnation {
                self.heartbeat(id, incarnation);
                return 0;
            }
            lost = self.drop_slot(id, reassigned);
        }
        self.slots.insert(id, Slot { incarnation, last_seen: Instant::now(), outstanding: BTreeSet::new() });
        lost
    }

    /// A heartbeat. A worker presumed dead that heartbeats again (its link came back, e.g. a
    /// remote worker behind a bridge) rejoins; its old episodes were already requeued.
    pub fn heartbeat(&mut self, id: u32, incarnation: u64) {
        match self.slots.get_mut(&id) {
            Some(s) if s.incarnation == incarnation => s.last_seen = Instant::now(),
            Some(_) => {}
            None => {
                tracing::info!("worker {id} is back: it rejoins");
                self.slots.insert(id, Slot { incarnation, last_seen: Instant::now(), outstanding: BTreeSet::new() });
            }
        }
    }

    /// A worker left cleanly; returns 1 if it left work behind.
    pub fn leave(&mut self, id: u32, incarnation: u64, reassigned: &mut u64) -> u64 {
        match self.slots.get(&id) {
            Some(s) if s.incarnation == incarnation => self.drop_slot(id, reassigned),
            _ => 0,
        }
    }

    fn drop_slot(&mut self, id: u32, reassigned: &mut u64) -> u64 {
        let Some(s) = self.slots.remove(&id) else { return 0 };
        let had_work = !s.outstanding.is_empty();
        *reassigned += s.outstanding.len() as u64;
        self.queue.extend(s.outstanding);
        u64::from(had_work)
    }

    /// Workers silent for longer than the timeout are dropped; returns how many.
    pub fn expire(&mut self, reassigned: &mut u64) -> u64 {
        let dead: Vec<u32> =
            self.slots.iter().filter(|(_, s)| s.last_seen.elapsed() > self.timeout).map(|(&id, _)| id).collect();
        for &id in &dead {
            tracing::warn!(
                "worker {id} silent for more than {:?}: presumed dead, its episodes go to others",
                self.timeout
            );
            self.drop_slot(id, reassigned);
        }
        dead.len() as u64
    }

    /// Whether episode `id` of this iteration was ever handed to worker slot `worker`.
    pub fn was_handed(&self, id: &EpisodeId, worker: u32) -> bool {
        self.handed.get(id).is_some_and(|w| w.contains(&worker))
    }

    /// An episode arrived (from one of the workers it was handed to).
    pub fn completed(&mut self, id: &EpisodeId) {
        self.queue.remove(id);
        for s in self.slots.values_mut() {
            s.outstanding.remove(id);
        }
    }

    /// Hands queued episodes round-robin to live workers and publishes the tasks.
    pub fn dispatch<S: Service>(&mut self, end: &LearnerEnd<S>) -> Result<(), TransportError> {
        if self.queue.is_empty() || self.slots.is_empty() {
            return Ok(());
        }
        let ids: Vec<u32> = self.slots.keys().copied().collect();
        let mut batches: BTreeMap<u32, Vec<EpisodeId>> = BTreeMap::new();
        for (i, e) in std::mem::take(&mut self.queue).into_iter().enumerate() {
            batches.entry(ids[i % ids.len()]).or_default().push(e);
        }
        for (id, eps) in batches {
            let slot = self.slots.get_mut(&id).expect("live");
            end.assign(id, slot.incarnation, self.k, &eps)?;
            for e in &eps {
                self.handed.entry(*e).or_default().insert(id);
            }
            slot.outstanding.extend(eps);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(n: u32) -> Vec<EpisodeId> {
        (0..n).map(|index| EpisodeId { kind: 0, index }).collect()
    }

    #[test]
    fn an_expired_worker_that_heartbeats_again_rejoins_without_its_old_work() {
        let mut a = Assignments::new(Duration::from_millis(1));
        let mut reassigned = 0;
        a.join(7, 1, &mut reassigned);
        a.start_iteration(0, &ids(4));
        a.slots.get_mut(&7).unwrap().outstanding = ids(4).into_iter().collect();
        a.queue.clear();
        std::thread::sleep(Duration::from_millis(5));
        assert_eq!(a.expire(&mut reassigned), 1);
        assert_eq!((a.live(), a.queue.len(), reassigned), (0, 4, 4));
        a.heartbeat(7, 1);
        assert_eq!(a.live(), 1);
        assert!(a.slots[&7].outstanding.is_empty(), "its old episodes stay queued for dispatch");
        // A heartbeat of an old incarnation does not displace the live one.
        a.join(7, 2, &mut reassigned);
        a.heartbeat(7, 1);
        assert_eq!(a.slots[&7].incarnation, 2);
    }
}

//! [`TickRecordRing`]: a preallocated ring of per-tick records, for tests and
//! post-mortems that need individual ticks rather than histograms.

use serde::{Deserialize, Serialize};

/// One tick as kept in a [`TickRecordRing`]. All times ns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TickRecord {
    /// The tick number ([`TickInfo::tick`](crate::TickInfo::tick)).
    pub tick: u64,
    /// When the loop woke for this tick, ns.
    pub wake_ns: u64,
    /// Wake-up lateness, ns.
    pub lateness_ns: u64,
    /// Time spent in the body, ns.
    pub compute_ns: u64,
    /// Time the body reported spending in sends during this tick
    /// ([`SendProbe`](crate::SendProbe)), ns; 0 if none.
    pub send_ns: u64,
}

/// A fixed-capacity ring of [`TickRecord`]s: keeps the newest `capacity`
/// ticks, overwriting the oldest. All memory is allocated in
/// [`with_capacity`](Self::with_capacity); [`push`](Self::push) never allocates.
#[derive(Debug, Clone, Default)]
pub struct TickRecordRing {
    slots: Vec<TickRecord>,
    /// Index the next push writes to.
    head: usize,
    len: usize,
    pushed: u64,
}

impl TickRecordRing {
    /// A ring holding up to `capacity` records (0 = keeps nothing).
    pub fn with_capacity(capacity: usize) -> Self {
        Self { slots: vec![TickRecord::default(); capacity], head: 0, len: 0, pushed: 0 }
    }

    /// Maximum number of records kept.
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    /// Number of records kept now.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` if no record is kept.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Records pushed since creation or the last [`clear`](Self::clear),
    /// including those since overwritten.
    pub fn pushed(&self) -> u64 {
        self.pushed
    }

    /// Appends a record, overwriting the oldest when full. Never allocates.
    pub fn push(&mut self, record: TickRecord) {
        self.pushed += 1;
        let cap = self.slots.len();
        if cap == 0 {
            return;
        }
        self.slots[self.head] = record;
        self.head = (self.head + 1) % cap;
        self.len = (self.len + 1).min(cap);
    }

    /// The kept records, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &TickRecord> {
        let (older, newer) = if self.len < self.slots.len() {
            (&self.slots[..self.len], &self.slots[..0])
        } else {
            let (before, after) = self.slots.split_at(self.head);
            (after, before)
        };
        older.iter().chain(newer)
    }

    /// Forgets all records (keeps the memory).
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.pushed = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(tick: u64) -> TickRecord {
        TickRecord { tick, ..TickRecord::default() }
    }

    #[test]
    fn tick_record_ring_wraps_oldest_first_works() {
        let mut ring = TickRecordRing::with_capacity(3);
        for t in 0..2 {
            ring.push(rec(t));
        }
        assert_eq!(ring.iter().map(|r| r.tick).collect::<Vec<_>>(), [0, 1]);
        for t in 2..7 {
            ring.push(rec(t));
        }
        assert_eq!(ring.iter().map(|r| r.tick).collect::<Vec<_>>(), [4, 5, 6]);
        assert_eq!(ring.pushed(), 7);
    }

    #[test]
    fn tick_record_ring_zero_capacity_works() {
        let mut ring = TickRecordRing::with_capacity(0);
        ring.push(rec(1));
        assert!(ring.is_empty());
        assert_eq!(ring.iter().count(), 0);
    }
}

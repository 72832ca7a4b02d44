//! [`WorstTicks`]: the N worst ticks seen, in a fixed-size array.

use std::fmt;

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// How many worst ticks a [`DeadlineMonitor`](crate::DeadlineMonitor) keeps: 8.
pub const WORST_TICKS: usize = 8;

/// One of the worst ticks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct WorstTick {
    /// The tick number ([`TickInfo::tick`](crate::TickInfo::tick)).
    pub tick: u64,
    /// Wake-up lateness, ns.
    pub lateness_ns: u64,
    /// Compute time, ns.
    pub compute_ns: u64,
}

impl WorstTick {
    /// The ranking key: `lateness_ns + compute_ns`, i.e. how long after its
    /// scheduled time the tick finished, ns.
    pub const fn response_ns(&self) -> u64 {
        self.lateness_ns.saturating_add(self.compute_ns)
    }
}

/// The [`WORST_TICKS`] worst ticks, worst first, ranked by
/// [`WorstTick::response_ns`]; on a tie the earlier tick ranks first.
///
/// A fixed array plus a length: inserting never allocates. Compares, prints
/// and serialises (as a JSON array) the kept entries only.
#[derive(Clone, Copy, Default)]
pub struct WorstTicks {
    entries: [WorstTick; WORST_TICKS],
    len: usize,
}

impl WorstTicks {
    /// No ticks yet.
    pub const fn new() -> Self {
        Self { entries: [WorstTick { tick: 0, lateness_ns: 0, compute_ns: 0 }; WORST_TICKS], len: 0 }
    }

    /// Offers a tick; keeps it if it is among the worst [`WORST_TICKS`].
    pub fn offer(&mut self, candidate: WorstTick) {
        let key = candidate.response_ns();
        // First position whose entry is strictly better than the candidate.
        let pos = self.entries[..self.len].iter().position(|e| e.response_ns() < key).unwrap_or(self.len);
        if pos >= WORST_TICKS {
            return;
        }
        let last = self.len.min(WORST_TICKS - 1);
        self.entries.copy_within(pos..last, pos + 1);
        self.entries[pos] = candidate;
        self.len = (self.len + 1).min(WORST_TICKS);
    }

    /// The kept ticks, worst first.
    pub fn as_slice(&self) -> &[WorstTick] {
        &self.entries[..self.len]
    }

    /// Number of kept ticks (at most [`WORST_TICKS`]).
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` if no tick was offered.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Forgets all ticks.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl PartialEq for WorstTicks {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl Eq for WorstTicks {}

impl fmt::Debug for WorstTicks {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.as_slice()).finish()
    }
}

impl Serialize for WorstTicks {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.len))?;
        for entry in self.as_slice() {
            seq.serialize_element(entry)?;
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for WorstTicks {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct WorstVisitor;

        impl<'de> Visitor<'de> for WorstVisitor {
            type Value = WorstTicks;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "an array of at most {WORST_TICKS} worst ticks")
            }

            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<WorstTicks, A::Error> {
                let mut out = WorstTicks::new();
                while let Some(entry) = seq.next_element::<WorstTick>()? {
                    if out.len == WORST_TICKS {
                        return Err(serde::de::Error::invalid_length(WORST_TICKS + 1, &self));
                    }
                    out.entries[out.len] = entry;
                    out.len += 1;
                }
                Ok(out)
            }
        }

        deserializer.deserialize_seq(WorstVisitor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wt(tick: u64, compute_ns: u64) -> WorstTick {
        WorstTick { tick, lateness_ns: 0, compute_ns }
    }

    #[test]
    fn worst_ticks_keeps_largest_sorted_works() {
        let mut w = WorstTicks::new();
        for (tick, c) in [5u64, 1, 9, 3, 7, 2, 8, 6, 4, 10, 0].into_iter().enumerate() {
            w.offer(wt(tick as u64, c));
        }
        let got: Vec<u64> = w.as_slice().iter().map(|e| e.compute_ns).collect();
        assert_eq!(got, [10, 9, 8, 7, 6, 5, 4, 3]);
        assert_eq!(w.as_slice()[0].tick, 9);
    }

    #[test]
    fn worst_ticks_tie_keeps_earlier_first_works() {
        let mut w = WorstTicks::new();
        for tick in 0..20 {
            w.offer(wt(tick, 100));
        }
        let ticks: Vec<u64> = w.as_slice().iter().map(|e| e.tick).collect();
        assert_eq!(ticks, [0, 1, 2, 3, 4, 5, 6, 7]);
    }

    #[test]
    fn worst_ticks_json_round_trip_works() {
        let mut w = WorstTicks::new();
        w.offer(wt(3, 30));
        w.offer(wt(4, 40));
        let json = serde_json::to_string(&w).unwrap();
        assert_eq!(json.matches("\"tick\"").count(), 2);
        let back: WorstTicks = serde_json::from_str(&json).unwrap();
        assert_eq!(back, w);
    }
}

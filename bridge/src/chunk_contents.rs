//! What a node publisher knows of its shared-memory chunks' contents, so that a frame which
//! differs from an earlier one in a few nodes rewrites only those.
//!
//! iceoryx2 lends the publisher the chunks its subscribers have released, and with one
//! frame kept as history for late joiners the same two chunks take turns (measured with a
//! subscriber taking every frame, and without one). A chunk keeps the bytes last written
//! into it: when it last carried a frame of the same *epoch* (the caller's count of the
//! times nodes outside its `changed` list moved), only the changed nodes need writing.

use core::cell::Cell;

/// Chunks remembered; more than the two or three a publisher cycles through.
const REMEMBERED: usize = 8;

/// One chunk's content as last written by this publisher.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Content {
    /// The payload's address in this process (0: an empty slot).
    address: usize,
    /// Nodes in the frame written there.
    nodes: usize,
    /// The epoch of that frame.
    epoch: u64,
}

/// The last complete, finite frames written per chunk, by payload address.
#[derive(Debug, Default)]
pub(crate) struct ChunkContents {
    slots: Cell<[Content; REMEMBERED]>,
    /// The slot the next unknown chunk takes (round robin).
    next: Cell<usize>,
}

impl ChunkContents {
    /// Whether the chunk at `address` holds a complete frame of `nodes` nodes written in
    /// `epoch`.
    pub(crate) fn holds(&self, address: usize, nodes: usize, epoch: u64) -> bool {
        let wanted = Content { address, nodes, epoch };
        address != 0 && self.slots.get().contains(&wanted)
    }

    /// Records that the chunk at `address` now holds a complete frame of `nodes` nodes of
    /// `epoch`.
    pub(crate) fn remember(&self, address: usize, nodes: usize, epoch: u64) {
        let mut slots = self.slots.get();
        let at = match slots.iter().position(|c| c.address == address) {
            Some(i) => i,
            None => {
                let i = self.next.get();
                self.next.set((i + 1) % REMEMBERED);
                i
            }
        };
        slots[at] = Content { address, nodes, epoch };
        self.slots.set(slots);
    }

    /// Forgets the chunk at `address`: its content is about to be written by other means, or
    /// was left incomplete.
    pub(crate) fn forget(&self, address: usize) {
        let mut slots = self.slots.get();
        for c in slots.iter_mut().filter(|c| c.address == address) {
            *c = Content::default();
        }
        self.slots.set(slots);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chunk_holds_what_was_last_remembered_of_it_works() {
        let c = ChunkContents::default();
        assert!(!c.holds(0x1000, 10, 0), "nothing known at first");
        c.remember(0x1000, 10, 3);
        assert!(c.holds(0x1000, 10, 3));
        assert!(!c.holds(0x1000, 10, 4), "another epoch");
        assert!(!c.holds(0x1000, 11, 3), "another node count");
        assert!(!c.holds(0x2000, 10, 3), "another chunk");
        c.remember(0x1000, 10, 4);
        assert!(c.holds(0x1000, 10, 4) && !c.holds(0x1000, 10, 3), "one record per chunk");
        c.forget(0x1000);
        assert!(!c.holds(0x1000, 10, 4));
    }

    #[test]
    fn more_chunks_than_slots_drop_the_oldest_works() {
        let c = ChunkContents::default();
        for a in 1..=REMEMBERED + 2 {
            c.remember(a * 0x100, 5, 1);
        }
        assert!(!c.holds(0x100, 5, 1) && !c.holds(0x200, 5, 1), "the two oldest went");
        assert!((3..=REMEMBERED + 2).all(|a| c.holds(a * 0x100, 5, 1)));
    }
}

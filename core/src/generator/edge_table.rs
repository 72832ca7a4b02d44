//! The paper's edge table: each node pair becomes at most one spring.

use super::families::SpringFamily;
use std::collections::HashMap;

/// A spring of the topology, before geometry: two model node indices, its family and
/// its layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TopologySpring {
    /// First node (model index).
    pub a: u32,
    /// Second node (model index).
    pub b: u32,
    /// Family it was created in.
    pub family: SpringFamily,
    /// Layer index (see [`layers`](super::layers)).
    pub layer: u16,
}

/// Springs in insertion order, with every unordered node pair at most once.
#[derive(Clone, Debug, Default)]
pub struct EdgeTable {
    index: HashMap<(u32, u32), u32>,
    springs: Vec<TopologySpring>,
    repeats: usize,
}

impl EdgeTable {
    /// An empty table with room for `capacity` springs.
    pub fn with_capacity(capacity: usize) -> Self {
        Self { index: HashMap::with_capacity(capacity), springs: Vec::with_capacity(capacity), repeats: 0 }
    }

    /// Adds the spring `a`–`b` unless the pair is already present (then counts a repeat).
    /// Returns whether it was added.
    pub fn insert(&mut self, a: u32, b: u32, family: SpringFamily, layer: u16) -> bool {
        debug_assert_ne!(a, b, "a spring needs two nodes");
        let key = (a.min(b), a.max(b));
        if self.index.contains_key(&key) {
            self.repeats += 1;
            return false;
        }
        self.index.insert(key, self.springs.len() as u32);
        self.springs.push(TopologySpring { a, b, family, layer });
        true
    }

    /// Whether the pair `a`–`b` is present.
    pub fn contains(&self, a: u32, b: u32) -> bool {
        self.index.contains_key(&(a.min(b), a.max(b)))
    }

    /// Insertions refused because the pair was present.
    pub fn repeats(&self) -> usize {
        self.repeats
    }

    /// The springs, in insertion order.
    pub fn into_springs(self) -> Vec<TopologySpring> {
        self.springs
    }
}

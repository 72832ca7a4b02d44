//! The springs cut so far, in cut order, shared by the thread that cuts with the threads
//! that build simulations from the cut model (a multirate region and its bulk).
//!
//! One thread appends ([`CutLog::push`]); any thread reads the first [`CutLog::len`]
//! entries, which never change once written. Preallocated for every spring of the model:
//! appending allocates nothing and cannot run out (a spring is cut once).

use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

/// Model springs cut, in cut order.
pub(crate) struct CutLog {
    order: Box<[AtomicU32]>,
    len: AtomicUsize,
}

impl CutLog {
    /// An empty log with room for `springs` cuts (the model's spring count).
    pub(crate) fn with_capacity(springs: usize) -> Self {
        Self { order: (0..springs).map(|_| AtomicU32::new(0)).collect(), len: AtomicUsize::new(0) }
    }

    /// Appends `spring`; `false` when the log is full (more cuts than springs: a caller that
    /// cuts a spring twice). One thread only appends. Allocates nothing.
    pub(crate) fn push(&self, spring: u32) -> bool {
        let k = self.len.load(Ordering::Relaxed);
        let Some(slot) = self.order.get(k) else { return false };
        slot.store(spring, Ordering::Relaxed);
        self.len.store(k + 1, Ordering::Release);
        true
    }

    /// Cuts appended so far.
    pub(crate) fn len(&self) -> usize {
        self.len.load(Ordering::Acquire)
    }

    /// The springs of cuts `from..to` (`to` at most a [`CutLog::len`] read before), in cut order.
    pub(crate) fn springs(&self, from: usize, to: usize) -> impl Iterator<Item = usize> + '_ {
        self.order[from.min(to)..to].iter().map(|s| s.load(Ordering::Relaxed) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_keeps_cut_order_and_refuses_more_cuts_than_springs_works() {
        let log = CutLog::with_capacity(3);
        assert!(log.push(7) && log.push(2) && log.push(9));
        assert!(!log.push(4), "a fourth cut of a three-spring model is refused");
        assert_eq!(log.len(), 3);
        assert_eq!(log.springs(0, 3).collect::<Vec<_>>(), [7, 2, 9]);
        assert_eq!(log.springs(1, 2).collect::<Vec<_>>(), [2]);
    }

    #[test]
    fn a_reader_on_another_thread_sees_every_cut_written_before_the_length_works() {
        let log = std::sync::Arc::new(CutLog::with_capacity(10_000));
        let reader = {
            let log = std::sync::Arc::clone(&log);
            std::thread::spawn(move || {
                let mut seen = 0;
                while seen < 10_000 {
                    let len = log.len();
                    for (k, s) in log.springs(seen, len).enumerate() {
                        assert_eq!(s, 3 * (seen + k) % 10_000);
                    }
                    seen = len;
                }
            })
        };
        for k in 0..10_000 {
            assert!(log.push((3 * k % 10_000) as u32));
        }
        reader.join().unwrap();
    }
}

//! Which ticks write a node frame: one falls due every `node_frame_every` ticks, and a tick
//! that is already late leaves it for the next.
//!
//! A node frame is a copy of the positions into shared memory (195 KB for 16,224 nodes,
//! 10-20 µs of a tick at p50 written whole). When the host slows the loop's CPU 5-10 times for a burst of
//! ticks, that copy is what pushes a slow tick past its deadline. The haptic feedback is not
//! gated: it goes out every tick.

/// Decides, tick by tick, whether the core writes a node frame.
///
/// A frame falls due on every tick that is a multiple of `every`. A tick that has used more
/// than `cutoff_ns` since its scheduled start does not write it: the frame stays due and goes
/// out on the first later tick within the cutoff. A frame still due when the next one falls
/// due is shed (the next one carries newer positions).
///
/// With `every` 4 and a cutoff of 500 µs, the frame due on tick 4, a tick that had used 700 µs
/// by then, goes out on tick 5 if tick 5 is within the cutoff (one deferred), and is shed if
/// ticks 5 to 7 are late too (tick 8's frame replaces it).
#[derive(Clone, Copy, Debug)]
pub struct NodeFrameGate {
    every: u64,
    cutoff_ns: u64,
    /// The tick the frame still to be written fell due on.
    due_since: Option<u64>,
    deferred: u64,
    shed: u64,
}

impl NodeFrameGate {
    /// A frame every `every` ticks (at least 1), written only by a tick that has used at most
    /// `cutoff_ns` since its scheduled start.
    pub fn new(every: u32, cutoff_ns: u64) -> Self {
        Self { every: u64::from(every.max(1)), cutoff_ns, due_since: None, deferred: 0, shed: 0 }
    }

    /// Whether tick `tick` writes a node frame now; `elapsed_ns` gives the time since the
    /// tick's scheduled start, ns, and is called only on a tick with a frame due. Call it once
    /// per tick, ticks in increasing order.
    pub fn write_now(&mut self, tick: u64, elapsed_ns: impl FnOnce() -> u64) -> bool {
        if tick.is_multiple_of(self.every) && self.due_since.replace(tick).is_some() {
            self.shed += 1;
        }
        let Some(due) = self.due_since else { return false };
        if elapsed_ns() > self.cutoff_ns {
            return false;
        }
        if due != tick {
            self.deferred += 1;
        }
        self.due_since = None;
        true
    }

    /// Frames written on a later tick than the one they fell due on.
    pub fn deferred(&self) -> u64 {
        self.deferred
    }

    /// Frames never written: the next fell due first, or the run ended with one still due.
    pub fn shed(&self) -> u64 {
        self.shed + u64::from(self.due_since.is_some())
    }

    /// The cutoff, ns after a tick's scheduled start.
    pub fn cutoff_ns(&self) -> u64 {
        self.cutoff_ns
    }
}

#[cfg(test)]
mod tests {
    use super::NodeFrameGate;

    const ON_TIME: u64 = 80_000;
    const LATE: u64 = 700_000;

    #[test]
    fn frames_on_time_go_out_on_their_ticks_works() {
        let mut gate = NodeFrameGate::new(5, 500_000);
        let written: Vec<u64> = (0..23).filter(|&t| gate.write_now(t, || ON_TIME)).collect();
        assert_eq!(written, [0, 5, 10, 15, 20]);
        assert_eq!((gate.deferred(), gate.shed()), (0, 0));
    }

    #[test]
    fn a_late_tick_defers_its_frame_to_the_first_tick_on_time_works() {
        let mut gate = NodeFrameGate::new(5, 500_000);
        // Ticks 5, 6 and 7 late: frame 5 goes out on tick 8.
        let late = |t: u64| (5..=7).contains(&t);
        let written: Vec<u64> =
            (0..12).filter(|&t| gate.write_now(t, || if late(t) { LATE } else { ON_TIME })).collect();
        assert_eq!(written, [0, 8, 10]);
        assert_eq!((gate.deferred(), gate.shed()), (1, 0));
    }

    #[test]
    fn a_frame_still_due_when_the_next_falls_due_is_shed_works() {
        // Every tick: a late tick's frame is superseded by the next tick's.
        let mut gate = NodeFrameGate::new(1, 500_000);
        let late = [2u64, 3, 7];
        let written: Vec<u64> =
            (0..10).filter(|&t| gate.write_now(t, || if late.contains(&t) { LATE } else { ON_TIME })).collect();
        assert_eq!(written, [0, 1, 4, 5, 6, 8, 9]);
        assert_eq!((gate.deferred(), gate.shed()), (0, 3));
        // Every 4th: ticks 4 to 8 late, frame 4 never written, frame 8 written on tick 9.
        let mut gate = NodeFrameGate::new(4, 500_000);
        let written: Vec<u64> =
            (0..13).filter(|&t| gate.write_now(t, || if (4..=8).contains(&t) { LATE } else { ON_TIME })).collect();
        assert_eq!(written, [0, 9, 12]);
        assert_eq!((gate.deferred(), gate.shed()), (1, 1));
    }

    #[test]
    fn a_frame_due_at_the_end_counts_as_shed_works() {
        let mut gate = NodeFrameGate::new(3, 500_000);
        let written: Vec<u64> = (0..5).filter(|&t| gate.write_now(t, || if t >= 3 { LATE } else { ON_TIME })).collect();
        assert_eq!(written, [0]);
        assert_eq!(gate.shed(), 1);
        // Published plus shed is every frame that fell due.
        assert_eq!(written.len() as u64 + gate.shed(), 2);
    }

    #[test]
    fn the_time_is_asked_only_on_ticks_with_a_frame_due_works() {
        // Every 4th tick, tick 4 late: the time is asked on ticks 0, 4, 5 and 8 only.
        let mut gate = NodeFrameGate::new(4, 500_000);
        let mut asked = Vec::new();
        for t in 0..10u64 {
            gate.write_now(t, || {
                asked.push(t);
                if t == 4 { LATE } else { ON_TIME }
            });
        }
        assert_eq!(asked, [0, 4, 5, 8]);
    }

    #[test]
    fn the_cutoff_itself_is_on_time_works() {
        let mut gate = NodeFrameGate::new(1, 500_000);
        assert!(gate.write_now(0, || 500_000));
        assert!(!gate.write_now(1, || 500_001));
    }
}

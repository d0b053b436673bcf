//! The segments segment prep has handed out lately, so a stop or a speed change can take back the
//! ones still waiting in the kernel's queue and re-plan from where the kernel really will be.
//!
//! The kernel's owner keeps at most a few segments queued (the emulator 8, the firmware 15). When
//! a jog stops, a feed hold begins or a jog changes speed, the owner drops the newest queued
//! segments the kernel has not started ([`crate::board::Board::drop_queued`]) and prep rewinds to
//! its state after the last segment kept: the exact step position (its own position minus the
//! dropped segments' steps), the block and the dominant step reached in it, and the speed there.
//! It then decelerates (or re-profiles) from that point at once instead of after the queue.
//!
//! Prep only rewinds inside the block it is working on, or back to the end of the block before it;
//! [`History::droppable`] says how many of the newest segments that allows. Dwell segments are
//! never taken back.

use crate::units::MAX_AXES;
use heapless::Deque;

/// Segments remembered: at least the deepest kernel queue an owner keeps (the firmware's 15).
pub(crate) const SEGMENT_HISTORY: usize = 16;

/// Where prep stood after a segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stand {
    /// Inside a line block.
    Inside,
    /// At the end of a line block or a dwell (the next block not started).
    BlockEnd,
    /// Inside a dwell (never a place to rewind to).
    Dwelling,
    /// At rest with nothing prepared before (power-up, abort, reset).
    Rest,
}

/// Prep's state after one segment it handed out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Handed {
    /// Signed steps the segment made per axis.
    pub steps: [i32; MAX_AXES],
    /// Sequence number of the segment's block.
    pub seq: u32,
    /// Dominant steps done in the block after the segment.
    pub done: u32,
    /// Path speed at the segment's end, nm/s.
    pub speed: u32,
    pub stand: Stand,
}

impl Handed {
    /// At rest, nothing before.
    pub(crate) const REST: Handed = Handed {
        steps: [0; MAX_AXES],
        seq: 0,
        done: 0,
        speed: 0,
        stand: Stand::Rest,
    };
}

/// The last [`SEGMENT_HISTORY`] segments handed out, and prep's state before the oldest of them.
#[derive(Clone, Debug)]
pub(crate) struct History {
    /// Prep's state before the oldest remembered segment (the base), then the state after each
    /// remembered segment, oldest first; empty at rest with nothing remembered. The base is the
    /// front entry rather than a field of its own, so recording a segment once the history is
    /// full drops the old base and writes the new segment, one copy instead of three.
    states: Deque<Handed, { SEGMENT_HISTORY + 1 }>,
}

impl Default for History {
    fn default() -> Self {
        Self::new()
    }
}

impl History {
    /// Empty, at rest.
    pub const fn new() -> Self {
        History {
            states: Deque::new(),
        }
    }

    /// Remembers a segment just handed out (forgetting the oldest when full).
    pub fn record(&mut self, h: Handed) {
        if self.states.is_empty() {
            let _ = self.states.push_back(Handed::REST);
        } else if self.states.is_full() {
            // The oldest segment's state becomes the base.
            self.states.pop_front();
        }
        let _ = self.states.push_back(h);
    }

    /// How many segments are remembered.
    fn segments(&self) -> usize {
        self.states.len().saturating_sub(1)
    }

    /// Prep's state after the segment `k` places before the newest (`k` = count: the base).
    fn kept(&self, k: usize) -> Handed {
        let n = self.segments();
        self.states
            .get(n - k.min(n))
            .copied()
            .unwrap_or(Handed::REST)
    }

    /// How many of the newest segments prep can take back while it works on the block numbered
    /// `active` (`None`: no block in progress): only segments of that line block, and only back
    /// to a place inside it or to the end of the block before it.
    pub(crate) fn droppable(&self, active: Option<u32>) -> usize {
        let Some(seq) = active else {
            return 0;
        };
        let n = self.segments();
        let mut k = 0;
        while k < n {
            let dropped = self.kept(k);
            if dropped.seq != seq || !matches!(dropped.stand, Stand::Inside | Stand::BlockEnd) {
                break;
            }
            let target = self.kept(k + 1);
            let ok = match target.stand {
                Stand::Inside => target.seq == seq,
                Stand::BlockEnd | Stand::Rest => true,
                Stand::Dwelling => false,
            };
            if !ok {
                break;
            }
            k += 1;
        }
        k
    }

    /// The block of the newest segment ends with it (a move cut short where prep stands).
    pub(crate) fn end_block(&mut self) {
        if self.segments() == 0 {
            return;
        }
        if let Some(h) = self.states.back_mut() {
            if h.stand == Stand::Inside {
                h.stand = Stand::BlockEnd;
            }
        }
    }

    /// Forgets the newest `k` segments (at most [`Self::droppable`]); returns prep's state after
    /// the last one kept and the signed steps the forgotten ones would have made.
    pub(crate) fn take_back(&mut self, k: usize) -> (Handed, [i64; MAX_AXES]) {
        let mut steps = [0i64; MAX_AXES];
        for _ in 0..k.min(self.segments()) {
            let Some(h) = self.states.pop_back() else {
                break;
            };
            for (s, d) in steps.iter_mut().zip(h.steps) {
                *s += i64::from(d);
            }
        }
        (self.kept(0), steps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(seq: u32, done: u32, stand: Stand) -> Handed {
        Handed {
            steps: [10, -5, 0, 0, 0, 0],
            seq,
            done,
            speed: done * 100,
            stand,
        }
    }

    #[test]
    fn takes_back_inside_the_active_block_and_to_the_end_of_the_one_before() {
        let mut h = History::new();
        h.record(seg(1, 10, Stand::Inside));
        h.record(seg(1, 20, Stand::Inside));
        h.record(seg(1, 30, Stand::BlockEnd));
        h.record(seg(2, 10, Stand::Inside));
        h.record(seg(2, 20, Stand::Inside));
        // Block 2 active: back to its first segment, or to the end of block 1; not into block 1.
        assert_eq!(h.droppable(Some(2)), 2);
        assert_eq!(h.droppable(None), 0);
        // Block 3 active (nothing of it handed out yet): nothing to take back.
        assert_eq!(h.droppable(Some(3)), 0);
        let (at, steps) = h.take_back(2);
        assert_eq!((at.seq, at.done, at.stand), (1, 30, Stand::BlockEnd));
        assert_eq!(steps, [20, -10, 0, 0, 0, 0]);
        assert_eq!(h.droppable(Some(2)), 0);
    }

    #[test]
    fn dwells_are_never_taken_back_and_the_base_follows_the_oldest() {
        let mut h = History::new();
        h.record(seg(1, 0, Stand::Dwelling));
        h.record(seg(2, 5, Stand::Inside));
        assert_eq!(h.droppable(Some(2)), 0);
        let mut h = History::new();
        for i in 1..=SEGMENT_HISTORY as u32 + 3 {
            h.record(seg(7, i, Stand::Inside));
        }
        // The base is the state after the last forgotten segment: everything remembered can go.
        assert_eq!(h.droppable(Some(7)), SEGMENT_HISTORY);
        let (at, _) = h.take_back(SEGMENT_HISTORY);
        assert_eq!(at.done, 3);
        // From power-up rest the first block can be taken back entirely.
        let mut h = History::new();
        h.record(seg(0, 4, Stand::Inside));
        assert_eq!(h.droppable(Some(0)), 1);
        assert_eq!(h.take_back(1).0.stand, Stand::Rest);
    }
}

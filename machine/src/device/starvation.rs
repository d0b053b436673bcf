//! Time lost to starvation: machine time beyond the planned time because the planner held too
//! little of a program that had more lines (docs/ports.md "Starvation"). The main loop samples
//! it once per pass (machine/src/device/main_loop.rs); the status report carries the current or
//! last job's total (`Status::starved_ms`).
//!
//! A pass *starves* when the job has moved, runs on its path with lines to come
//! ([`Board::lines_to_come`]), and its planner holds fewer blocks than it can and too short a
//! path to keep the head block's cruise speed: `√(2·a·D) < v_cruise`, `D` the queued path
//! length, `a` the head block's acceleration. The speed a full planner of such blocks would allow
//! is `v_full = min(v_cruise, √(2·a·D·capacity/blocks))` (the planned speed); the interval since
//! the last pass is lost in the share the measured speed fell short of it,
//! `(v_full − v) / v_full`, all of it when the planner is empty. The pass that hands out the
//! job's first segments starts the count.

use crate::arith::isqrt_u64;
use crate::board::{Board, PLANNER_BLOCKS};

/// Where the job stands for the count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum JobClock {
    /// No job; the last job's count stays readable.
    NoJob,
    /// A job started and has not moved yet: nothing counts (its first lines are on their way).
    Started,
    /// The job has moved.
    Moving,
}

/// What one pass saw of the planner against the measured speed. Speeds here are in units of
/// 1.024 µm/s (nm/s shifted right by 10: every product below fits 64 bits without checks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Sample {
    /// The planner held enough (or the job does not run with lines to come).
    Fed,
    /// It held too little: the speed a full planner would allow (0: it was empty).
    Starved { full_speed: u32 },
}

impl Sample {
    /// What `board`'s planner holds now.
    pub fn of(board: &Board) -> Sample {
        if !board.lines_to_come() {
            return Sample::Fed;
        }
        let planner = board.motion().planner();
        let Some(head) = planner.get(0) else {
            return Sample::Starved { full_speed: 0 };
        };
        let blocks = planner.len();
        if blocks >= PLANNER_BLOCKS {
            return Sample::Fed;
        }
        // The queued path and the head's acceleration in 1.024 µm (/s²) units.
        let mut queued = 0u64;
        for i in 0..blocks {
            queued += planner.get(i).map_or(0, |b| b.length >> 10);
        }
        let cruise = u64::from(head.nominal >> 10);
        let reach_sq = 2 * (head.accel >> 10) * queued;
        if reach_sq >= cruise * cruise {
            return Sample::Fed;
        }
        // Below cruise² (< 2^45), so the product stays far inside 64 bits.
        let full = isqrt_u64(reach_sq * PLANNER_BLOCKS as u64 / blocks as u64).min(cruise);
        Sample::Starved {
            full_speed: full as u32,
        }
    }
}

/// The current (or last) job's time lost to starvation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Starvation {
    clock: JobClock,
    /// Lost time, ms × 1000.
    lost: u64,
    last_pass_ms: u32,
}

impl Starvation {
    pub const fn new() -> Self {
        Starvation {
            clock: JobClock::NoJob,
            lost: 0,
            last_pass_ms: 0,
        }
    }

    /// The pass at `now_ms`: a job is running or holding (`in_job`), segments went to the kernel
    /// in this pass (`moved`), the path speed measured (`speed`, the units of [`Sample`]) and
    /// what the planner held (`sample`). A new job starts the count from 0.
    pub fn pass(&mut self, now_ms: u32, in_job: bool, moved: bool, speed: u32, sample: Sample) {
        let since_last = now_ms.wrapping_sub(self.last_pass_ms);
        self.last_pass_ms = now_ms;
        self.clock = match self.clock {
            _ if !in_job => JobClock::NoJob,
            JobClock::NoJob => {
                self.lost = 0;
                JobClock::Started
            }
            clock => clock,
        };
        if moved && self.clock == JobClock::Started {
            self.clock = JobClock::Moving;
            return;
        }
        if let (JobClock::Moving, Sample::Starved { full_speed }) = (self.clock, sample) {
            // The share of the interval the speed fell short, thousandths.
            let short = (full_speed.saturating_sub(speed) * 1000)
                .checked_div(full_speed)
                .unwrap_or(1000);
            self.lost += u64::from(since_last) * u64::from(short);
        }
    }

    /// Milliseconds the current or last job lost to starvation.
    pub fn starved_ms(&self) -> u32 {
        (self.lost / 1000) as u32
    }
}

impl Default for Starvation {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EMPTY: Sample = Sample::Starved { full_speed: 0 };

    #[test]
    fn counts_after_the_first_motion_only() {
        let mut s = Starvation::new();
        // A job starts and waits 3 ms for its lines (not counted), then moves.
        s.pass(10, true, false, 0, EMPTY);
        s.pass(13, true, false, 0, EMPTY);
        s.pass(14, true, true, 0, Sample::Fed);
        assert_eq!(s.starved_ms(), 0);
        // Empty planner for 2 ms: all lost; then 4 ms at a quarter of the full planner's speed:
        // three quarters lost.
        s.pass(16, true, false, 0, EMPTY);
        s.pass(20, true, true, 100, Sample::Starved { full_speed: 400 });
        s.pass(21, true, true, 500, Sample::Fed);
        assert_eq!(s.starved_ms(), 5);
        // Faster than the full planner's speed: nothing lost.
        s.pass(30, true, true, 500, Sample::Starved { full_speed: 400 });
        assert_eq!(s.starved_ms(), 5);
    }

    #[test]
    fn a_job_keeps_its_count_until_the_next_starts() {
        let mut s = Starvation::new();
        s.pass(0, true, true, 0, Sample::Fed);
        s.pass(7, true, false, 0, EMPTY);
        // A hold: the job goes on.
        s.pass(500, true, false, 0, Sample::Fed);
        s.pass(501, true, true, 0, EMPTY);
        assert_eq!(s.starved_ms(), 8);
        s.pass(502, false, false, 0, EMPTY);
        s.pass(600, false, false, 0, EMPTY);
        assert_eq!(s.starved_ms(), 8);
        s.pass(601, true, true, 0, Sample::Fed);
        assert_eq!(s.starved_ms(), 0);
        s.pass(603, true, true, 0, EMPTY);
        assert_eq!(s.starved_ms(), 2);
    }
}

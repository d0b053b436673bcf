//! Underruns as the machine feels them, counted once for both boards by the main loop
//! (`device/main_loop.rs`): the step kernel found its queue empty in Run after the job had moved,
//! while the main loop's pass before left motion queued or the planner empty before the
//! program's end (lines not interpreted or not received yet), not at a sync point, a hold, a
//! program stop or the job's start and end. One per time the kernel ran dry
//! ([`crate::step::kernel::StepKernel::dry_runs`]), however long it stood.

/// The main loop's underrun account.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Underruns {
    /// Gaps in the motion so far.
    gaps: u32,
    /// The kernel's dry-run count at the last pass.
    dry_seen: u16,
    /// A segment reached the kernel since the job entered Run.
    moved: bool,
    /// The last pass left the job running with motion to come (a dry kernel would be a gap).
    gap_possible: bool,
}

impl Underruns {
    pub const fn new() -> Self {
        Underruns {
            gaps: 0,
            dry_seen: 0,
            moved: false,
            gap_possible: false,
        }
    }

    /// Gaps in the motion so far.
    pub fn gaps(&self) -> u32 {
        self.gaps
    }

    /// The kernel's dry-run count at the start of a pass: one that ran dry since the last pass
    /// while that pass left motion to come is a gap.
    pub fn kernel_seen(&mut self, dry_runs: u16) {
        if dry_runs != self.dry_seen && self.moved && self.gap_possible {
            self.gaps += 1;
        }
        self.dry_seen = dry_runs;
    }

    /// A segment went to the kernel.
    pub fn segment_handed_out(&mut self) {
        self.moved = true;
    }

    /// The end of a pass: the job is `running` (in Run), and `motion_to_come` (motion queued,
    /// or the program not at its end).
    pub fn pass_done(&mut self, running: bool, motion_to_come: bool) {
        if !running {
            self.moved = false;
        }
        self.gap_possible = running && motion_to_come;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_gap_per_dry_run_while_motion_is_to_come() {
        let mut u = Underruns::new();
        // Dry before the job moved: no gap.
        u.pass_done(true, true);
        u.kernel_seen(1);
        assert_eq!(u.gaps(), 0);
        u.segment_handed_out();
        u.pass_done(true, true);
        // Still the same dry run over many passes: one gap.
        u.kernel_seen(2);
        u.kernel_seen(2);
        assert_eq!(u.gaps(), 1);
        // The job's end: nothing to come, no gap.
        u.pass_done(true, false);
        u.kernel_seen(3);
        assert_eq!(u.gaps(), 1);
        // Out of Run (a hold): no gap even with motion queued, until a segment moves again.
        u.pass_done(false, true);
        u.pass_done(true, true);
        u.kernel_seen(4);
        assert_eq!(u.gaps(), 1);
        // The count wraps.
        u.segment_handed_out();
        u.kernel_seen(u16::MAX);
        u.kernel_seen(0);
        assert_eq!(u.gaps(), 3);
    }
}

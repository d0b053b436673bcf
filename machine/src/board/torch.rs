//! The plasma torch's rules on the board (docs/laser-plasma.md "Plasma"): the wait for arc-OK
//! after the torch fires (at `M3`'s sync point, and after a cycle start that re-fires it when the
//! arc was lost), the arc lost while cutting, and when torch height control may act (after
//! `thc_delay_ms` of arc, while cutting). The height correction itself is made by segment prep
//! (`motion/thc.rs`); this module only says when.

use super::mode::{HoldWhy, JobPhase};
use super::Board;
use crate::board::inputs::Signal;
use crate::board::state::AlarmCode;
use crate::canon::Spindle;
use crate::motion::pipeline::MotionState;
use crate::motion::thc::ThcCommand;

/// Where the torch's arc stands, as far as the board knows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum Arc {
    /// Torch off (or not a torch machine).
    #[default]
    Off,
    /// Fired at `since` (ms): the motion waits for arc-OK.
    Waiting { since: u32 },
    /// Arc-OK came at `at` (ms).
    Established { at: u32 },
}

/// What one look at the arc-OK input during a wait found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ArcCheck {
    /// Still waiting.
    Waiting,
    /// Arc-OK is on: the motion may go.
    Established,
    /// `arc_ok_timeout_ms` passed without it.
    NoArc,
}

impl Arc {
    /// Waits for arc-OK (`arc_ok`, the debounced input) at time `now`: starts the wait when none
    /// runs, and ends it when the input is on or `timeout_ms` have passed.
    pub(super) fn wait(&mut self, now: u32, arc_ok: bool, timeout_ms: u16) -> ArcCheck {
        let since = match *self {
            Arc::Established { .. } => return ArcCheck::Established,
            Arc::Waiting { since } => since,
            Arc::Off => {
                *self = Arc::Waiting { since: now };
                now
            }
        };
        if arc_ok {
            *self = Arc::Established { at: now };
            ArcCheck::Established
        } else if now.wrapping_sub(since) >= u32::from(timeout_ms) {
            *self = Arc::Off;
            ArcCheck::NoArc
        } else {
            ArcCheck::Waiting
        }
    }
}

impl Board {
    /// A plasma torch machine (`[spindle] torch`).
    pub(super) fn torch(&self) -> bool {
        self.setup.outputs.torch.on
    }

    /// `code` is `M62 P2` / `M63 P2` on a torch machine (the interpreter takes M62/M63 only
    /// with P2), unless a user M code list of the setup claims it.
    pub(super) fn thc_switch(&self, code: u16) -> bool {
        self.torch() && matches!(code, 62 | 63) && !self.setup.program.user_mcodes.contains(&code)
    }

    /// The torch is switched on (M3 performed, not stopped).
    pub(super) fn torch_firing(&self) -> bool {
        self.torch() && self.outputs.program().spindle != Spindle::Off
    }

    /// The torch at `M3`'s sync point (the machine at rest): fires it and holds the sync point
    /// until arc-OK; true once the motion may go on. Without arc-OK within the timeout the torch
    /// goes off and the job ends in alarm 22 at `line`.
    pub(super) fn torch_on_at_sync(&mut self, state: Spindle, rpm: u32, line: u32) -> bool {
        if self.outputs.program().spindle == Spindle::Off {
            // A new pierce: the height correction of the last cut is gone (taken out before this
            // sync point, `Board::next_segment`), and the wait starts now.
            self.arc = Arc::Off;
        }
        self.outputs.set_spindle(state, rpm);
        let t = self.setup.outputs.torch;
        let arc_ok = self.sensed.levels.get(Signal::ArcOk);
        match self
            .arc
            .wait(self.sensed.now_ms, arc_ok, t.arc_ok_timeout_ms)
        {
            ArcCheck::Waiting => false,
            ArcCheck::Established => true,
            ArcCheck::NoArc => {
                self.no_arc(line);
                false
            }
        }
    }

    /// No arc within the timeout: torch off now, the job ends in alarm 22 at rest.
    fn no_arc(&mut self, line: u32) {
        let rpm = self.outputs.program().rpm;
        self.outputs.set_spindle(Spindle::Off, rpm);
        self.stop_job(Some((AlarmCode::NoArc, line)));
    }

    /// The arc-OK input fell: while the torch cuts (a running job moving, not waiting for its
    /// arc) that is an arc loss: a feed hold on the path with the torch off, until the operator's
    /// cycle start re-fires it ([`Board::torch_resume`]).
    pub(super) fn arc_ok_fell(&mut self) {
        let cutting = matches!(self.arc, Arc::Established { .. })
            && self.torch_firing()
            && self.motion.state() == MotionState::Running;
        let Some(JobPhase::Running(ending)) = self.machine_job() else {
            return;
        };
        if !cutting {
            return;
        }
        self.motion.feed_hold();
        self.outputs.toggle_spindle_stop();
        self.arc = Arc::Off;
        self.set_phase(JobPhase::Hold {
            why: HoldWhy::ArcLost,
            ending,
        });
    }

    /// Cycle start after an arc loss: the torch fires again and the motion stays held until
    /// arc-OK ([`Board::poll_arc_wait`]).
    pub(super) fn torch_resume(&mut self) {
        if let Some(JobPhase::Hold { ending, .. }) = self.machine_job() {
            self.outputs.restore_stopped_spindle();
            self.arc = Arc::Waiting {
                since: self.sensed.now_ms,
            };
            self.set_phase(JobPhase::Hold {
                why: HoldWhy::ArcWait,
                ending,
            });
        }
    }

    /// While a resumed job waits for its arc: arc-OK resumes the held motion; the timeout ends
    /// the job in alarm 22.
    pub(super) fn poll_arc_wait(&mut self) {
        let Some(JobPhase::Hold {
            why: HoldWhy::ArcWait,
            ending,
        }) = self.machine_job()
        else {
            return;
        };
        let t = self.setup.outputs.torch;
        let arc_ok = self.sensed.levels.get(Signal::ArcOk);
        match self
            .arc
            .wait(self.sensed.now_ms, arc_ok, t.arc_ok_timeout_ms)
        {
            ArcCheck::Waiting => {}
            ArcCheck::Established => {
                self.motion.resume();
                self.set_phase(JobPhase::Running(ending));
            }
            ArcCheck::NoArc => {
                let line = self.progress.line;
                self.no_arc(line);
            }
        }
    }

    /// What torch height control asks of segment prep now: raise or lower Z while the torch
    /// cuts with its arc established for `thc_delay_ms` in a running job (prep itself applies it
    /// only at cruise speed, above the anti-dive speed, on moves without Z motion).
    pub(super) fn thc_command(&self) -> ThcCommand {
        let t = self.setup.outputs.torch;
        let Arc::Established { at } = self.arc else {
            return ThcCommand::Hold;
        };
        let settled = self.sensed.now_ms.wrapping_sub(at) >= u32::from(t.thc_delay_ms);
        if !(t.thc && settled && self.torch_firing() && self.job_running()) {
            return ThcCommand::Hold;
        }
        let levels = self.sensed.levels;
        match (levels.get(Signal::ThcUp), levels.get(Signal::ThcDown)) {
            (true, false) => ThcCommand::Up,
            (false, true) => ThcCommand::Down,
            _ => ThcCommand::Hold,
        }
    }

    /// The machine position the status reports for kernel step position `steps`: Z where the
    /// program put it, the torch height correction left out (it is reported beside it).
    pub(crate) fn reported_position(
        &self,
        steps: &[i64; crate::units::MAX_AXES],
    ) -> crate::units::Pos {
        let mut p = self.machine_position(steps);
        if self.torch() {
            p[crate::motion::thc::THC_AXIS] -= i64::from(self.thc_correction_nm());
        }
        p
    }

    /// The torch height correction now, nm (+ = up).
    pub(crate) fn thc_correction_nm(&self) -> i32 {
        let z = &self.motion.config().axes[crate::motion::thc::THC_AXIS];
        z.steps_to_nm(i64::from(self.motion.thc_correction())) as i32
    }

    /// The arc's state for the status: (firing, waiting for arc-OK, held for a lost arc).
    pub(crate) fn torch_status(&self) -> Option<(bool, bool, bool)> {
        if !self.torch() {
            return None;
        }
        let lost = matches!(
            self.machine_job(),
            Some(JobPhase::Hold {
                why: HoldWhy::ArcLost,
                ..
            })
        );
        let waiting = self.torch_firing() && matches!(self.arc, Arc::Waiting { .. });
        Some((self.torch_firing(), waiting, lost))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wait_ends_on_arc_ok_or_the_timeout() {
        let mut a = Arc::Off;
        assert_eq!(a.wait(100, false, 50), ArcCheck::Waiting);
        assert_eq!(a.wait(149, false, 50), ArcCheck::Waiting);
        assert_eq!(a.wait(149, true, 50), ArcCheck::Established);
        assert_eq!(a, Arc::Established { at: 149 });
        assert_eq!(a.wait(500, false, 50), ArcCheck::Established);
        let mut a = Arc::Off;
        assert_eq!(a.wait(u32::MAX - 10, false, 50), ArcCheck::Waiting);
        assert_eq!(a.wait(38, false, 50), ArcCheck::Waiting);
        assert_eq!(a.wait(39, false, 50), ArcCheck::NoArc);
        assert_eq!(a, Arc::Off);
    }
}

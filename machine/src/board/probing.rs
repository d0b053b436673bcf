//! G38.2-G38.5 probe moves in a job (docs/probing.md).
//!
//! The interpreter hands out a probe move as [`Action::Probe`]; the board queues it as a sync
//! point and interprets nothing more (later blocks may read the result, #5061-#5070). At rest the
//! sync point checks the probe's start state (already in the state the move looks for: alarm 4),
//! arms the step kernel's probe latch ([`Board::probe_arm`], the raw pin level that trips it) and
//! queues the move as a feed. The kernel latches its exact step position on the tick that sees
//! the pin change; the main loop hands that to [`Board::probe_tripped`], which stops the move
//! with a planned deceleration on the path (like an abort of the move alone). Once at rest the
//! interpreter gets the stopped position and the results ([`crate::gcode::Interpreter::probe_done`])
//! and the job continues; a G38.2/G38.4 that reached its end without a change ends the job in
//! alarm 5.

use super::mode::{Job, JobPhase};
use super::{Board, Mode};
use crate::board::inputs::Signal;
use crate::board::state::AlarmCode;
use crate::canon::{Action, Canon, ProbeMode};
use crate::motion::pipeline::{MotionState, PushError};
use crate::units::{Pos, MAX_AXES};

/// Where a probe move of the job stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum ProbeCycle {
    /// No probe move.
    #[default]
    Off,
    /// The probe move waits at its sync point; nothing after it is interpreted.
    Queued,
    /// Moving with the kernel's latch armed for the raw pin level `trips_at`.
    Moving {
        mode: ProbeMode,
        line: u32,
        trips_at: bool,
    },
    /// The probe changed state with the machine at `at` (nm): decelerating to rest.
    Stopping { line: u32, at: Pos },
}

/// The result of the last probe move, for status reports (grbl's `[PRB:x,y,z:ok]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeResult {
    /// Machine position (nm) where the probe changed state, or where the move ended without.
    pub position: Pos,
    /// The probe changed state.
    pub success: bool,
    /// Counts probe moves since power-up (wrapping): tells a new result from an equal old one.
    pub number: u16,
}

/// The job's probe move and the last result.
pub(super) struct Probing {
    cycle: ProbeCycle,
    result: Option<ProbeResult>,
}

impl Probing {
    /// No probe move, no result yet.
    #[inline(always)]
    pub(super) const fn new() -> Self {
        Probing {
            cycle: ProbeCycle::Off,
            result: None,
        }
    }

    /// A probe move reached the motion queue: it waits at its sync point.
    pub(super) fn queue(&mut self) {
        self.cycle = ProbeCycle::Queued;
    }

    /// No probe move any more (a new job, a stop, an alarm).
    pub(super) fn cancel(&mut self) {
        self.cycle = ProbeCycle::Off;
    }

    /// Records a finished probe move's result, numbered on from the last one.
    fn record(&mut self, position: Pos, success: bool) {
        let number = self.result.map_or(1, |p| p.number.wrapping_add(1));
        self.result = Some(ProbeResult {
            position,
            success,
            number,
        });
    }
}

impl Board {
    /// The result of the last probe move since power-up.
    pub fn probe_result(&self) -> Option<ProbeResult> {
        self.probing.result
    }

    /// A probe move of the job waits at its sync point, moves or decelerates: its result is not
    /// known yet (the grbl front end holds the probe line's `ok` until then).
    pub(crate) fn probing(&self) -> bool {
        !matches!(self.probing.cycle, ProbeCycle::Off)
    }

    /// The raw probe pin level that must trip the step kernel's probe latch now (`None`: the
    /// latch stays off). The main loop arms the kernel with it before handing out segments.
    pub(crate) fn probe_arm(&self) -> Option<bool> {
        match self.probing.cycle {
            ProbeCycle::Moving { trips_at, .. } => Some(trips_at),
            _ => None,
        }
    }

    /// The step kernel latched the probe at `kernel_steps`: stop the move with a planned
    /// deceleration (the kernel keeps stepping what the stop needs).
    pub(crate) fn probe_tripped(&mut self, kernel_steps: &[i64; MAX_AXES]) {
        if let ProbeCycle::Moving { line, .. } = self.probing.cycle {
            let at = self.motion.config().to_nm(kernel_steps);
            self.probing.cycle = ProbeCycle::Stopping { line, at };
            self.motion.abort();
        }
    }

    /// The probe move's sync point, reached at rest: refuse it (alarm 4) when the probe already
    /// reads what the move looks for, else arm and queue the move.
    pub(super) fn start_probe(&mut self, canon: &Canon) {
        let Action::Probe { to, feed, mode } = canon.action else {
            return;
        };
        self.motion.release_sync();
        // Logical level the move looks for: touching (active) toward, clear away.
        if self.sensed.levels.get(Signal::Probe) == mode.toward {
            self.probing.cycle = ProbeCycle::Off;
            self.stop_job(Some((AlarmCode::ProbeFailInitial, canon.line)));
            return;
        }
        let invert = self.setup.inputs.invert & (1 << Signal::Probe as u32) != 0;
        let feed_move = Canon {
            line: canon.line,
            action: Action::Feed { to, feed },
        };
        match self.motion.push(&feed_move) {
            Ok(()) => {
                self.probing.cycle = ProbeCycle::Moving {
                    mode,
                    line: canon.line,
                    trips_at: mode.toward ^ invert,
                };
            }
            // Only a travel error can happen: the queue was empty at the sync point, so it is
            // never full here (handled the same way, without a panic path for it).
            Err(PushError::Travel { .. } | PushError::Full) => {
                self.probing.cycle = ProbeCycle::Off;
                self.soft_limit(canon.line);
            }
        }
    }

    /// Ends a probe move once the machine is at rest: results to the interpreter, then the job
    /// continues, or alarm 5 for a G38.2/G38.4 without a change.
    pub(super) fn poll_probe(&mut self, kernel_drained: bool) {
        if !matches!(
            self.probing.cycle,
            ProbeCycle::Moving { .. } | ProbeCycle::Stopping { .. }
        ) || !kernel_drained
            || self.motion.state() != MotionState::Idle
        {
            return;
        }
        let here = self.motion.queued_position();
        match self.probing.cycle {
            ProbeCycle::Stopping { line, at } => {
                self.progress.line = line;
                self.interp.probe_done(here, Some(at));
                self.probing.record(at, true);
            }
            ProbeCycle::Moving { mode, line, .. } => {
                self.progress.line = line;
                self.interp.probe_done(here, None);
                self.probing.record(here, false);
                if mode.must_trip {
                    self.probing.cycle = ProbeCycle::Off;
                    self.stop_job(Some((AlarmCode::ProbeFailContact, line)));
                    return;
                }
            }
            _ => {}
        }
        self.probing.cycle = ProbeCycle::Off;
    }

    /// The interpreter must wait: a probe move is queued or under way.
    pub(super) fn probe_busy(&self) -> bool {
        !matches!(self.probing.cycle, ProbeCycle::Off)
            && matches!(
                self.mode,
                Mode::Job(Job {
                    phase: JobPhase::Running(_) | JobPhase::Hold { .. },
                    ..
                })
            )
    }
}

//! grbl 1.1's safety door (realtime byte 0x84; docs/grbl.md). The Black Pill F411 has no free
//! GPIO for a door switch (boards/README.md), so there is no door input: the door is the sender's byte alone and counts
//! as closed once the machine has stopped: a running job decelerates to a feed hold (`Door:2`),
//! then spindle and coolant switch off at rest (`Door:0`); a jog is cancelled; in idle the
//! outputs switch off at once and no job starts. `~` switches spindle and coolant back on as the
//! door found them; with the spindle on, motion waits the setup's spin-up time (`Door:3`,
//! `grbl.door_spin_up_ms`) as grbl does, then the job resumes. A soft reset, an abort or an
//! alarm forget the door (the outputs stay off).

use super::report;
use crate::board::State;
use crate::board::{Board, DoorOutputs};
use crate::canon::Spindle;
use crate::device::kernel_view::KernelView;

/// Where the door stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Door {
    /// No door opened (or it was resumed).
    Closed,
    /// Opened: the machine decelerates (`Door:2`).
    Stopping,
    /// At rest with spindle and coolant off (`Door:0`), waiting for `~`; `held` when a job's
    /// feed hold waits to resume.
    Parked { outputs: DoorOutputs, held: bool },
    /// `~` switched spindle and coolant back on at `since_ms` (board time); the spindle spins up
    /// before anything moves (`Door:3`).
    SpinningUp { since_ms: u32, held: bool },
}

impl Door {
    /// The byte 0x84.
    pub fn open(&mut self, board: &mut Board) {
        match *self {
            Door::Closed => {}
            // Opened again while the spindle spins up: at rest already, so the outputs go off
            // again at the next poll (`Door:0`), as grbl does.
            Door::SpinningUp { .. } => {
                *self = Door::Stopping;
                return;
            }
            Door::Stopping | Door::Parked { .. } => return,
        }
        match board.state() {
            State::Run => board.feed_hold(),
            State::Hold if board.feed_held() => {}
            State::Jog => board.jog_stop(),
            State::Idle => {}
            // Homing, alarm, check mode, an M0 or M6 stop (outputs off already): nothing moves
            // on the door's account.
            _ => return,
        }
        *self = Door::Stopping;
    }

    /// Once per service: at rest, spindle and coolant off; forgets the door when the job ended
    /// some other way; holds a job a cycle-start input resumed behind the door's back; once the
    /// spindle has spun up, resumes the job.
    pub fn poll(&mut self, board: &mut Board, view: &KernelView) {
        match *self {
            Door::Closed => {}
            Door::Stopping => match board.state() {
                State::Run | State::Hold | State::Jog | State::Idle => {
                    if view.feed_um_min == 0 && board.state() != State::Jog {
                        if let Some(outputs) = board.door_outputs_off() {
                            let held = board.state() == State::Hold;
                            *self = Door::Parked { outputs, held };
                        } else if board.state() == State::Run {
                            // Resumed while stopping (a cycle-start input): hold again.
                            board.feed_hold();
                        }
                    }
                }
                _ => *self = Door::Closed,
            },
            Door::Parked { held, .. } | Door::SpinningUp { held, .. } => match board.state() {
                State::Hold if held => self.spun_up(board),
                State::Idle if !held => self.spun_up(board),
                State::Run if held => board.feed_hold(),
                _ => *self = Door::Closed,
            },
        }
    }

    /// The spin-up wait over: the door closes and the held job resumes.
    fn spun_up(&mut self, board: &mut Board) {
        if let Door::SpinningUp { since_ms, .. } = *self {
            let wait = u32::from(board.setup().grbl.door_spin_up_ms);
            if board.now_ms().wrapping_sub(since_ms) >= wait {
                *self = Door::Closed;
                board.cycle_start();
            }
        }
    }

    /// `~`: spindle and coolant back on, the held job resumes (`true`: the caller starts the
    /// cycle now), or waits for the spindle to spin up first ([`Door::SpinningUp`], resumed by
    /// [`Door::poll`]). `false` too while the door has not parked yet or the spindle spins up
    /// (the byte is ignored, as grbl ignores it then).
    pub fn resume(&mut self, board: &mut Board) -> bool {
        match *self {
            Door::Closed => true,
            Door::Stopping | Door::SpinningUp { .. } => false,
            Door::Parked { outputs, held } => {
                board.door_restore(outputs);
                if board.setup().grbl.door_spin_up_ms > 0 && board.outputs().spindle != Spindle::Off
                {
                    *self = Door::SpinningUp {
                        since_ms: board.now_ms(),
                        held,
                    };
                    return false;
                }
                *self = Door::Closed;
                true
            }
        }
    }

    /// No job may start while the door is open.
    pub(crate) fn blocks_start(&self) -> bool {
        *self != Door::Closed
    }

    /// The status state to show instead of the board's, while the door is open.
    pub fn state_name(&self, board: &Board, view: &KernelView, check_mode: bool) -> &'static str {
        match self {
            Door::Closed => report::state_name(board, view, check_mode),
            Door::Stopping => "Door:2",
            Door::Parked { .. } => "Door:0",
            Door::SpinningUp { .. } => "Door:3",
        }
    }
}

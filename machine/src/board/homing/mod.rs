//! The homing cycle on the board: lists, fast seek, pull-off, slow locate, retract and set home,
//! axis by axis (docs/controller.md "Homing"). The pure parts (order, targets, switch bits) are in [`plan`].

pub(crate) mod plan;

use super::mode::{HomingCycle, HomingPhase, Mode};
use super::{Board, MotionState, Pos, MAX_AXES};
use crate::board::outputs::lists::{ListRunner, ListStatus};
use crate::board::state::AlarmCode;
use crate::canon::{Action, Canon};
use crate::setup::Setup;
use plan::{Homing, Phase};

/// Which axes are homed, and whether the machine position can be trusted at all.
pub(super) struct PositionTrust {
    /// The board reset during motion (alarm 3) and nothing has re-established the position yet:
    /// homing is required, where homing is set up, until every axis with a homing priority is
    /// homed again; else an unlock clears it.
    lost: bool,
    /// Axes whose home is known (bit 0 = X).
    homed: u8,
    /// Step position the kernel's owner must load (homing set a new home).
    reset: Option<[i64; MAX_AXES]>,
}

impl PositionTrust {
    /// Nothing homed; `lost` after a reset during motion.
    #[inline(always)]
    pub(super) const fn new(lost: bool) -> Self {
        PositionTrust {
            lost,
            homed: 0,
            reset: None,
        }
    }

    /// The position was lost in a reset during motion and is not re-established yet.
    pub(super) fn lost(&self) -> bool {
        self.lost
    }

    /// Axes whose home is known (bit 0 = X).
    pub(super) fn homed(&self) -> u8 {
        self.homed
    }

    /// Homing is required (`setup`, or the position was lost in a reset) and some axis with a
    /// homing priority is not homed.
    pub(super) fn homing_missing(&self, setup: &Setup) -> bool {
        (setup.homing.required || self.lost) && self.some_axis_unhomed(setup)
    }

    /// Some axis with a homing priority is not homed.
    fn some_axis_unhomed(&self, setup: &Setup) -> bool {
        plan::order(setup, 0)
            .iter()
            .any(|&a| self.homed & (1 << a) == 0)
    }

    /// The axes of `axes` (bit mask) lose their home.
    pub(super) fn unhome(&mut self, axes: u8) {
        self.homed &= !axes;
    }

    /// `axis` has been homed.
    fn homed_axis(&mut self, axis: usize) {
        self.homed |= 1 << axis;
    }

    /// A homing cycle ended: once every axis with a homing priority is homed, the position is
    /// known again (after alarm 3).
    fn cycle_done(&mut self, setup: &Setup) {
        if !self.some_axis_unhomed(setup) {
            self.lost = false;
        }
    }

    /// The operator takes the position as it is (an unlock).
    pub(super) fn trust(&mut self) {
        self.lost = false;
    }

    /// Homing set a new home: the kernel's owner must load `steps`.
    fn reset_to(&mut self, steps: [i64; MAX_AXES]) {
        self.reset = Some(steps);
    }

    /// The step position the kernel's owner must load, once.
    pub(super) fn take_reset(&mut self) -> Option<[i64; MAX_AXES]> {
        self.reset.take()
    }
}

impl Board {
    /// Starts a homing cycle of `axes` (bit mask, 0 = every axis with a homing priority), from
    /// idle or alarm with the machine at rest. False when refused.
    pub fn home(&mut self, axes: u8) -> bool {
        self.try_home(axes).is_ok()
    }

    /// [`Board::home`] for a host request that is answered: the refusal's code (902 busy, 903
    /// no axis to home).
    pub(crate) fn try_home(&mut self, axes: u8) -> Result<(), u16> {
        if !matches!(self.mode, Mode::Idle | Mode::Alarm(_))
            || self.motion.state() != MotionState::Idle
        {
            return Err(super::ERROR_BUSY);
        }
        let Some(h) = Homing::new(&self.setup, axes) else {
            return Err(super::ERROR_INVALID_REQUEST);
        };
        // A pressed switch other than a seek switch of the cycle would trip it at once (or,
        // disarmed, not stop an axis driven into it): the operator jogs off it first
        // (`board/pressed_switch.rs`). A seek that starts on its own switch stops at once and
        // pulls off, as homing does.
        let seeks = h.order.iter().fold(0u32, |m, &a| {
            let a = usize::from(a);
            m | 1 << plan::switch_bit(a, &self.setup.homing.axes[a])
        });
        if self.pressed_limits() & !seeks != 0 {
            return Err(super::ERROR_LIMIT_PRESSED);
        }
        let steps = self.motion.prepared_steps();
        self.rebuild_motion(false, &steps);
        for &a in &h.order {
            self.position.unhome(1 << a);
        }
        self.mode = Mode::Homing {
            phase: HomingPhase::Cycle(HomingCycle {
                homing: h,
                list: None,
            }),
        };
        Ok(())
    }

    pub(super) fn poll_homing(&mut self, drained: bool) {
        let idle = drained && self.motion.state() == MotionState::Idle;
        let Mode::Homing { phase } = &mut self.mode else {
            return;
        };
        if !idle {
            return;
        }
        // Taken out for this step and put back at the end unless the cycle ends (the phase
        // meanwhile reads `Aborting`; nothing below looks at it).
        let HomingPhase::Cycle(HomingCycle {
            homing: mut h,
            list: mut homing_list,
        }) = core::mem::replace(phase, HomingPhase::Aborting)
        else {
            // An aborted cycle raises its alarm once the seek has decelerated to rest.
            self.enter_alarm(AlarmCode::HomingAborted, 0);
            return;
        };
        let axis = h.axis();
        let ha = self.setup.homing.axes[axis];
        let at = self.motion.queued_position();
        if h.list_seek {
            // A list's seek ran its whole length without meeting the switch.
            self.enter_alarm(AlarmCode::HomingSwitchNotFound, 0);
            return;
        }
        match h.phase {
            Phase::BeforeSeek | Phase::BeforeRetract | Phase::AfterRetract => {
                let list = match h.phase {
                    Phase::BeforeSeek => &self.setup.homing.before_seek,
                    Phase::BeforeRetract => &self.setup.homing.before_retract,
                    _ => &self.setup.homing.after_retract,
                };
                let runner = homing_list.get_or_insert_with(|| ListRunner::new(list));
                match runner.step(
                    self.sensed.now_ms,
                    self.sensed.levels,
                    self.outputs.user_mut(),
                ) {
                    ListStatus::Running => {}
                    ListStatus::Seek => {
                        self.push_seek(axis, &at, false);
                        h.list_seek = true;
                    }
                    ListStatus::Timeout => {
                        self.enter_alarm(AlarmCode::ListInputTimeout, 0);
                        return;
                    }
                    ListStatus::Done => {
                        homing_list = None;
                        match h.phase {
                            Phase::BeforeSeek => {
                                self.push_seek(axis, &at, true);
                                h.phase = Phase::Seek;
                            }
                            Phase::BeforeRetract => {
                                let mut to = at;
                                to[axis] = plan::retract_target(&ha, at[axis]);
                                let _ = self.motion.push(&Canon {
                                    line: 0,
                                    action: Action::Rapid { to },
                                });
                                h.phase = Phase::Retract;
                            }
                            _ => {
                                h.done |= 1 << axis;
                                self.position.homed_axis(axis);
                                h.index += 1;
                                if h.index == h.order.len() {
                                    self.position.cycle_done(&self.setup);
                                    let steps = self.motion.prepared_steps();
                                    self.rebuild_motion(true, &steps);
                                    self.sync_interpreter_position();
                                    self.mode = Mode::Idle;
                                    return;
                                }
                                h.phase = Phase::BeforeSeek;
                            }
                        }
                    }
                }
            }
            Phase::Seek | Phase::Locate => {
                // The seek ran its whole length without meeting the switch.
                self.enter_alarm(AlarmCode::HomingSwitchNotFound, 0);
                return;
            }
            Phase::SeekStopped => {
                let mut to = at;
                to[axis] = plan::retract_target(&ha, at[axis]);
                let _ = self.motion.push(&Canon {
                    line: 0,
                    action: Action::Rapid { to },
                });
                h.phase = Phase::PullOff;
            }
            Phase::PullOff => {
                if self.sensed.levels.0 & (1 << plan::switch_bit(axis, &ha)) != 0 {
                    self.enter_alarm(AlarmCode::HomingPullOffFailed, 0);
                    return;
                }
                let mut to = at;
                to[axis] = plan::locate_target(&ha, at[axis]);
                let _ = self.motion.push(&Canon {
                    line: 0,
                    action: Action::Feed {
                        to,
                        feed: ha.locate_rate,
                    },
                });
                h.phase = Phase::Locate;
            }
            Phase::Retract => {
                if self.sensed.levels.0 & (1 << plan::switch_bit(axis, &ha)) != 0 {
                    self.enter_alarm(AlarmCode::HomingPullOffFailed, 0);
                    return;
                }
                if ha.set_home {
                    let mut steps = self.motion.prepared_steps();
                    steps[axis] = self.motion.config().axes[axis].nm_to_steps(ha.home_position);
                    self.rebuild_motion(false, &steps);
                    self.position.reset_to(steps);
                }
                h.phase = Phase::AfterRetract;
            }
        }
        self.mode = Mode::Homing {
            phase: HomingPhase::Cycle(HomingCycle {
                homing: h,
                list: homing_list,
            }),
        };
    }

    /// Queues a seek of `axis` toward its homing switch over the travel + retract: the fast seek
    /// at `seek_rate`, a list's `seek` (squaring: where it stops counts) at `locate_rate`.
    fn push_seek(&mut self, axis: usize, at: &Pos, fast: bool) {
        let mut to = *at;
        to[axis] = plan::seek_target(&self.setup, axis, at[axis]);
        let h = &self.setup.homing.axes[axis];
        let feed = if fast { h.seek_rate } else { h.locate_rate };
        let _ = self.motion.push(&Canon {
            line: 0,
            action: Action::Feed { to, feed },
        });
    }
}

#[cfg(test)]
mod tests {
    //! The cycle's phase as the core holds it (`Mode::Homing { phase }`), on the core alone: a
    //! stand-in kernel runs every segment the moment it is handed out. The scenarios on the
    //! emulated board's switches and kernel are in tests/tests/controller_homing.rs.
    use super::plan::Phase;
    use super::*;
    use crate::board::inputs::AdcReadings;
    use crate::board::inputs::{InputBits, LIMIT_MIN_BIT};
    use crate::board::state::State;
    use crate::setup::Setup;
    use crate::units::{MAX_AXES, NM_PER_MM};

    const X_MIN: u32 = 1 << LIMIT_MIN_BIT;

    /// X homes to its min switch; hard limits off, so only the cycle arms the switch.
    fn board() -> Board {
        let mut s = Setup::default();
        s.inputs.limit_min = 0b001;
        s.inputs.hard_limits = false;
        s.inputs.debounce_ms = 1;
        s.homing.axes[0].priority = 1;
        s.homing.axes[0].retract = 2 * NM_PER_MM;
        s.homing.axes[0].home_position = 0;
        Board::new(s)
    }

    /// One pass with `levels`; the stand-in kernel runs at most one segment of it.
    fn pass(b: &mut Board, now: u32, levels: u32, steps: &mut [i64; MAX_AXES]) {
        b.on_inputs(now, InputBits(levels), 0, AdcReadings::default());
        b.poll(true);
        b.drop_queued(|_| 0);
        if let Some(seg) = b.next_segment() {
            for (i, s) in steps.iter_mut().enumerate() {
                let n = i64::from(seg.steps[i]);
                *s += if seg.dir & (1 << i) != 0 { -n } else { n };
            }
        }
    }

    fn phase(b: &Board) -> Option<Phase> {
        b.homing_cycle().map(|c| c.homing.phase)
    }

    #[test]
    fn the_cycle_steps_through_its_phases_inside_the_mode() {
        let mut b = board();
        let mut steps = [0i64; MAX_AXES];
        assert_eq!(b.limit_arm() & X_MIN, 0, "nothing armed while idle");
        assert!(b.home(0));
        assert_eq!(phase(&b), Some(Phase::BeforeSeek));
        let mut now = 0;
        while phase(&b) != Some(Phase::Seek) || steps[0] > -100 {
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 1_000, "the seek never started");
        }
        assert_eq!(b.limit_arm() & X_MIN, X_MIN, "the seek arms its switch");
        // The fast seek's stop: a pull-off of the retract distance, switch ignored.
        let seek_stop = steps[0];
        b.limit_stop(InputBits(X_MIN), &steps);
        assert_eq!(phase(&b), Some(Phase::SeekStopped));
        assert_eq!(b.limit_arm() & X_MIN, 0, "the pull-off ignores its switch");
        // The pass that starts the locate also runs its first segment: the pull-off ended where
        // the machine stood before that pass.
        let mut pulled_off = steps[0];
        while phase(&b) != Some(Phase::Locate) {
            pulled_off = steps[0];
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 100_000, "the locate never started");
        }
        assert_eq!(pulled_off - seek_stop, 2 * 640, "pulled off 2 mm");
        assert!(
            steps[0] < pulled_off,
            "the locate moves back toward the switch"
        );
        assert_eq!(b.limit_arm() & X_MIN, X_MIN, "the locate arms its switch");
        // The slow locate goes back toward the switch; the switch closes 1 mm off the pull-off.
        while steps[0] > seek_stop + 640 {
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 100_000, "the locate never moved");
        }
        let on_switch = steps[0];
        b.limit_stop(InputBits(X_MIN), &steps);
        assert_eq!(phase(&b), Some(Phase::BeforeRetract));
        assert_eq!(b.limit_arm() & X_MIN, 0, "the retract ignores its switch");
        while b.state() == State::Homing {
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 100_000, "the cycle never ended");
        }
        assert_eq!(b.state(), State::Idle);
        assert_eq!(b.homed(), 0b001);
        // Retracted 2 mm (640 steps per mm) off the switch step.
        assert_eq!(steps[0] - on_switch, 2 * 640);
        assert!(b.homing_cycle().is_none());
    }

    #[test]
    fn an_abort_drops_the_cycle_at_once_and_alarms_at_rest() {
        let mut b = board();
        let mut steps = [0i64; MAX_AXES];
        assert!(b.home(0));
        let mut now = 0;
        while steps[0] > -100 {
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 10_000, "the seek never moved");
        }
        b.abort();
        assert!(matches!(
            b.mode,
            Mode::Homing {
                phase: HomingPhase::Aborting
            }
        ));
        assert_eq!(b.limit_arm() & X_MIN, 0, "no seek: its switch is not armed");
        assert_eq!(b.alarm(), None, "alarm 6 waits for rest");
        while b.state() == State::Homing {
            now += 1;
            pass(&mut b, now, 0, &mut steps);
            assert!(now < 10_000, "the abort never came to rest");
        }
        assert_eq!(b.alarm(), Some(AlarmCode::HomingAborted));
        assert_eq!(b.homed(), 0);
    }
}

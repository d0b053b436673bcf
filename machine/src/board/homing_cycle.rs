//! The homing cycle on the board: lists, seek, retract and set home, axis by axis (docs/controller.md
//! "Homing"). The pure parts (order, targets, switch bits) are in [`crate::controller::homing`].

use super::mode::{HomingRun, Mode};
use super::{Board, MotionState, Pos};
use crate::canon::{Action, Canon};
use crate::controller::homing::{self, Homing, Phase};
use crate::controller::lists::{ListRunner, ListStatus};
use crate::controller::AlarmCode;

impl Board {
    /// Starts a homing cycle of `axes` (bit mask, 0 = every axis with a homing priority), from
    /// idle or alarm with the machine at rest. False when refused.
    pub fn home(&mut self, axes: u8) -> bool {
        if !matches!(self.mode, Mode::Idle | Mode::Alarm(_))
            || self.motion.state() != MotionState::Idle
        {
            return false;
        }
        let Some(h) = Homing::new(&self.setup, axes) else {
            return false;
        };
        let steps = self.motion.prepared_steps();
        self.rebuild_motion(false, &steps);
        for &a in &h.order {
            self.homed &= !(1 << a);
        }
        self.homing = Some(h);
        self.homing_list = None;
        self.mode = Mode::Homing(HomingRun::Cycle);
        true
    }

    pub(super) fn poll_homing(&mut self, drained: bool) {
        let idle = drained && self.motion.state() == MotionState::Idle;
        let Some(mut h) = self.homing.take() else {
            // An aborted cycle raises its alarm once the seek has decelerated to rest.
            if idle && self.mode == Mode::Homing(HomingRun::Aborting) {
                self.enter_alarm(AlarmCode::HomingAborted, 0);
            }
            return;
        };
        let axis = h.axis();
        let ha = self.setup.homing.axes[axis];
        if !idle {
            self.homing = Some(h);
            return;
        }
        let at = self.motion.queued_position();
        if h.list_seek {
            // A list's seek ran its whole length without meeting the switch.
            self.homing_list = None;
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
                let runner = self
                    .homing_list
                    .get_or_insert_with(|| ListRunner::new(list));
                match runner.step(self.now_ms, self.levels, &mut self.user_outputs) {
                    ListStatus::Running => {}
                    ListStatus::Seek => {
                        self.push_seek(axis, &at);
                        h.list_seek = true;
                    }
                    ListStatus::Timeout => {
                        self.homing_list = None;
                        self.enter_alarm(AlarmCode::ListInputTimeout, 0);
                        return;
                    }
                    ListStatus::Done => {
                        self.homing_list = None;
                        match h.phase {
                            Phase::BeforeSeek => {
                                self.push_seek(axis, &at);
                                h.phase = Phase::Seek;
                            }
                            Phase::BeforeRetract => {
                                let mut to = at;
                                to[axis] = homing::retract_target(&ha, at[axis]);
                                let _ = self.motion.push(&Canon {
                                    line: 0,
                                    action: Action::Rapid { to },
                                });
                                h.phase = Phase::Retract;
                            }
                            _ => {
                                h.done |= 1 << axis;
                                self.homed |= 1 << axis;
                                h.index += 1;
                                if h.index == h.order.len() {
                                    if !self.some_axis_unhomed() {
                                        // Every homed axis is known again (after alarm 3).
                                        self.position_lost = false;
                                    }
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
            Phase::Seek => {
                // The seek ran its whole length without meeting the switch.
                self.enter_alarm(AlarmCode::HomingSwitchNotFound, 0);
                return;
            }
            Phase::Retract => {
                if self.levels.0 & (1 << homing::switch_bit(axis, &ha)) != 0 {
                    self.enter_alarm(AlarmCode::HomingPullOffFailed, 0);
                    return;
                }
                if ha.set_home {
                    let mut steps = self.motion.prepared_steps();
                    steps[axis] = self.motion.config().axes[axis].nm_to_steps(ha.home_position);
                    self.rebuild_motion(false, &steps);
                    self.position_reset = Some(steps);
                }
                h.phase = Phase::AfterRetract;
            }
        }
        self.homing = Some(h);
    }

    /// Queues a constant-rate seek of `axis` toward its homing switch, over the travel + retract.
    fn push_seek(&mut self, axis: usize, at: &Pos) {
        let mut to = *at;
        to[axis] = homing::seek_target(&self.setup, axis, at[axis]);
        let feed = self.setup.homing.axes[axis].seek_rate;
        let _ = self.motion.push(&Canon {
            line: 0,
            action: Action::Feed { to, feed },
        });
    }
}

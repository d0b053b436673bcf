//! Jogging on the board: host jogs and the joystick (switches, modes, Mark/Release, analog
//! stick), docs/controller.md "Jogging". Targets and stick mapping are in [`plan`].

pub(crate) mod plan;

use super::mode::{Jogging, Mode};
use super::{
    Board, BoardEvent, MarkEvent, MotionState, ERROR_BUSY, ERROR_HOMING_REQUIRED,
    ERROR_INVALID_REQUEST, ERROR_JOG_DEADMAN, ERROR_LIMIT_PRESSED, ERROR_SOFT_LIMIT,
};
use crate::board::inputs::AdcReadings;
use crate::board::inputs::{InputBits, Signal};
use crate::board::state::State;
use crate::canon::{Action, Canon};
use crate::motion::pipeline::PushError;
use crate::units::{Pos, MAX_AXES};
use plan::{Deadman, JogMode};

/// Why [`Board::jog_to`] refused a jog.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JogRefused {
    /// Another motion (a job, homing, a jog not yet at rest) runs: try again later.
    Busy,
    /// Homing is required first.
    HomingRequired,
    /// The target leaves the soft-limit box.
    Travel,
    /// No feed.
    Invalid,
    /// Toward a limit switch still pressed (or, in the alarm, anything but a jog off it).
    LimitPressed,
}

/// What a joystick jog is doing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct StickMove {
    /// Direction weights per axis (±1 for switches, nm/min for the analog stick).
    dirs: [i64; MAX_AXES],
    /// Instantaneous/analog feed (nm/min); 0 = rapid (Accelerated mode).
    feed: i64,
    /// From the analog stick (its speed and direction change without stopping).
    analog: bool,
}

/// Where jog motion stands (host jogs and the joystick).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum JogMotion {
    /// No stick move planned and no stop under way (a host jog or a nudge may be moving).
    #[default]
    Free,
    /// The stick move now planned (also kept at the travel edge, so it is not retried every
    /// millisecond).
    Stick(StickMove),
    /// Decelerating and flushing for a stick change, a jog stop or an abort: nothing new starts
    /// until the motion is at rest.
    Stopping,
}

impl JogMotion {
    /// The stick move now planned, if any.
    fn stick(self) -> Option<StickMove> {
        match self {
            JogMotion::Stick(m) => Some(m),
            _ => None,
        }
    }
}

/// Jog bookkeeping (host jogs and the joystick).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct JogState {
    motion: JogMotion,
    /// An analog move to bend into once the kernel's queue has been taken back.
    bend: Option<StickMove>,
    /// Nudge: the switches' directions at the last nudge and when the next one is due.
    nudge_dirs: [i8; MAX_AXES],
    next_nudge: u32,
    marks: u32,
    /// The dead-man of the continuous host jog under way (`None`: none, or a stepped jog, a grbl
    /// `$J=` jog or the joystick, which need none).
    deadman: Option<Deadman>,
}

impl JogState {
    /// Every jog ends (an alarm, a new setup): nothing planned, stopping or due; the Mark count
    /// goes on (ids count since power-up).
    pub(super) fn end_all(&mut self) {
        *self = JogState {
            marks: self.marks,
            ..JogState::default()
        };
    }

    /// The analog move waiting to bend in once the kernel's queue has been taken back.
    pub(super) fn take_bend(&mut self) -> Option<StickMove> {
        self.bend.take()
    }
}

impl Board {
    /// Host jog of one axis at `velocity_um_min` (sign = direction): `distance_nm` far, or
    /// (0) toward the soft limit until [`Board::jog_stop`]. From idle, or after the previous jog
    /// has stopped; false when refused (an increment beyond the soft limits reports error 900,
    /// a jog without the required homing error 901).
    pub fn jog(&mut self, axis: u8, velocity_um_min: i32, distance_nm: u64) -> bool {
        match self.try_jog(axis, velocity_um_min, distance_nm) {
            Ok(()) => true,
            Err(code) => {
                if code == ERROR_HOMING_REQUIRED || (code == ERROR_SOFT_LIMIT && distance_nm > 0) {
                    self.emit(BoardEvent::Error {
                        line: 0,
                        code,
                        column: 0,
                    });
                }
                false
            }
        }
    }

    /// [`Board::jog`] for a host request that is answered: the refusal's code instead of an
    /// error event (902 busy, 903 no such axis or no feed, 901 homing required, 900 beyond the
    /// travel or already at its end).
    pub(crate) fn try_jog(
        &mut self,
        axis: u8,
        velocity_um_min: i32,
        distance_nm: u64,
    ) -> Result<(), u16> {
        let at_rest = self.motion.state() == MotionState::Idle;
        let free = matches!(self.mode, Mode::Idle | Mode::Alarm(_))
            || (matches!(self.mode, Mode::Jog(Jogging::Moves | Jogging::OffSwitch(_)))
                && !matches!(self.jog.motion, JogMotion::Stopping)
                && at_rest);
        if !free {
            return Err(ERROR_BUSY);
        }
        if axis >= self.setup.axis_count || velocity_um_min == 0 {
            return Err(ERROR_INVALID_REQUEST);
        }
        let mut dirs = [0i64; MAX_AXES];
        // In range: `axis < axis_count <= MAX_AXES` (checked above, and by the setup).
        if let Some(d) = dirs.get_mut(usize::from(axis)) {
            *d = i64::from(velocity_um_min.signum());
        }
        let distance = (distance_nm > 0).then(|| distance_nm.min(i64::MAX as u64 / 4) as i64);
        let from = self.motion.queued_position();
        let probe = {
            let mut p = from;
            p[usize::from(axis).min(MAX_AXES - 1)] += dirs[usize::from(axis).min(MAX_AXES - 1)];
            p
        };
        let jogging = self.jog_mode_for(&from, &probe)?;
        if jogging == Jogging::Moves && self.homing_missing() {
            return Err(ERROR_HOMING_REQUIRED);
        }
        let Some(to) = plan::jog_target(self.motion.config(), &from, &dirs, distance) else {
            return Err(ERROR_SOFT_LIMIT);
        };
        let feed = i64::from(velocity_um_min.unsigned_abs()) * 1000;
        if self
            .motion
            .push(&Canon {
                line: 0,
                action: Action::Feed { to, feed },
            })
            .is_err()
        {
            return Err(ERROR_BUSY);
        }
        self.mode = Mode::Jog(jogging);
        self.jogging_off(&from, &to);
        // Only a continuous jog runs on its host's word; a distance ends by itself.
        self.jog.deadman = (distance_nm == 0).then(|| Deadman::armed(self.sensed.now_ms));
        Ok(())
    }

    /// The host's keepalive for its continuous jog (`HostMessage::JogKeepalive`): the jog goes
    /// on for another [`plan::JOG_DEADMAN_MS`]. Without a continuous host jog it does nothing.
    pub fn jog_keepalive(&mut self) {
        let now = self.sensed.now_ms;
        if let Some(d) = &mut self.jog.deadman {
            d.heard(now);
        }
    }

    /// Host jog of several axes to the machine position `to` at `feed` nm/min (grbl's `$J=`,
    /// `machine/src/device/grbl/jog.rs`): from idle, or queued behind the host jogs still moving (grbl's
    /// jogging.md: a stream of jogs is planned together, so a jog wheel or a held key moves
    /// smoothly, and one jog cancel stops them all); refused while a cancel is stopping them.
    /// A target beyond the soft limits is refused as a whole (grbl error 15), never clipped.
    pub(crate) fn jog_to(&mut self, to: Pos, feed: i64) -> Result<(), JogRefused> {
        let free = matches!(self.mode, Mode::Idle | Mode::Alarm(_))
            || (matches!(self.mode, Mode::Jog(Jogging::Moves | Jogging::OffSwitch(_)))
                && matches!(self.jog.motion, JogMotion::Free));
        if !free {
            return Err(JogRefused::Busy);
        }
        let from = self.motion.queued_position();
        let jogging = match self.jog_mode_for(&from, &to) {
            Ok(j) => j,
            Err(ERROR_LIMIT_PRESSED) => return Err(JogRefused::LimitPressed),
            Err(_) => return Err(JogRefused::Busy),
        };
        if jogging == Jogging::Moves && self.homing_missing() {
            return Err(JogRefused::HomingRequired);
        }
        if feed <= 0 {
            return Err(JogRefused::Invalid);
        }
        if self.motion.config().travel_violation(&to).is_some() {
            return Err(JogRefused::Travel);
        }
        match self.motion.push(&Canon {
            line: 0,
            action: Action::Feed { to, feed },
        }) {
            Ok(()) => {
                self.mode = Mode::Jog(jogging);
                self.jogging_off(&from, &to);
                Ok(())
            }
            Err(PushError::Travel { .. }) => Err(JogRefused::Travel),
            Err(PushError::Full) => Err(JogRefused::Busy),
        }
    }

    /// How a host jog from `from` toward `to` may run: as a plain jog (from Idle or behind host
    /// jogs), or off a pressed limit switch from alarm 1 or 11 (and behind such a jog); refused
    /// toward a pressed switch (905: it is disarmed, nothing would stop the axis), and in any
    /// other alarm (902, as before).
    fn jog_mode_for(&self, from: &Pos, to: &Pos) -> Result<Jogging, u16> {
        match self.mode {
            Mode::Jog(Jogging::OffSwitch(code)) => {
                // Behind a jog off the switch: still off it, or the switch has released.
                match self.jog_off_from(from, to) {
                    Some(_) => Ok(Jogging::OffSwitch(code)),
                    None if self.pressed_limits() == 0 => Ok(Jogging::OffSwitch(code)),
                    None => Err(ERROR_LIMIT_PRESSED),
                }
            }
            Mode::Alarm(_) => match self.jog_off_from(from, to) {
                Some(code) => Ok(Jogging::OffSwitch(code)),
                None if self.pressed_limits() != 0 => Err(ERROR_LIMIT_PRESSED),
                None => Err(ERROR_BUSY),
            },
            _ if self.toward_pressed(from, to) => Err(ERROR_LIMIT_PRESSED),
            _ => Ok(Jogging::Moves),
        }
    }

    /// Stops a jog within its deceleration distance and drops what was queued of it.
    pub fn jog_stop(&mut self) {
        self.jog.deadman = None;
        if self.state() != State::Jog {
            return;
        }
        if self.motion.state() != MotionState::Idle {
            self.motion.abort();
            self.jog.motion = JogMotion::Stopping;
        } else if let JogMotion::Stick(_) = self.jog.motion {
            self.jog.motion = JogMotion::Free;
        }
    }

    pub(super) fn poll_jog(&mut self, drained: bool) {
        if self
            .jog
            .deadman
            .is_some_and(|d| d.expired(self.sensed.now_ms))
        {
            // The host went silent (killed, stopped, cut off): a controlled stop, as a jog stop.
            self.jog_stop();
            self.emit(BoardEvent::Error {
                line: 0,
                code: ERROR_JOG_DEADMAN,
                column: 0,
            });
        }
        if self.motion.state() == MotionState::Idle
            && matches!(self.jog.motion, JogMotion::Stopping)
        {
            self.jog.motion = JogMotion::Free;
        }
        let at_rest = drained && self.motion.state() == MotionState::Idle;
        match self.mode {
            Mode::Jog(Jogging::Moves) if at_rest => {
                self.mode = Mode::Idle;
                self.jog.deadman = None;
                self.sync_interpreter_position();
            }
            // Off the switch: the alarm stays until the operator unlocks.
            Mode::Jog(Jogging::OffSwitch(code)) if at_rest => {
                self.mode = Mode::Alarm(code);
                self.jog.deadman = None;
                self.sync_interpreter_position();
            }
            _ => {}
        }
    }

    /// Joystick handling of one input sample (docs/controller.md "Jogging").
    pub(super) fn joystick(&mut self, prev: InputBits, levels: InputBits, adc: AdcReadings) {
        let both = |l: InputBits| l.get(Signal::Mark) && l.get(Signal::Release);
        if both(levels) && !both(prev) {
            if matches!(self.mode, Mode::Idle) && !self.refuse_unhomed() {
                self.jog.nudge_dirs = [0; MAX_AXES];
                self.mode = Mode::Jog(Jogging::Joystick);
            } else if matches!(self.mode, Mode::Jog(Jogging::Joystick)) {
                self.mode = Mode::Jog(Jogging::Moves);
                self.jog_stop();
            }
            return;
        }
        if !matches!(self.mode, Mode::Jog(Jogging::Joystick)) {
            return;
        }
        if levels.get(Signal::Mark) && !prev.get(Signal::Mark) && !levels.get(Signal::Release) {
            self.jog.marks += 1;
            let position = self.motion.config().to_nm(&self.motion.prepared_steps());
            self.outbox.mark(MarkEvent {
                id: self.jog.marks,
                position,
            });
        }
        let mode = plan::mode_of(levels);
        let dirs = plan::stick_directions(levels, &self.setup.jog);
        let mut want = None;
        if let Some(m) = self.analog_request(adc) {
            want = Some(m);
        } else if mode != JogMode::Nudge && dirs.iter().any(|&d| d != 0) {
            want = Some(StickMove {
                dirs: dirs.map(i64::from),
                feed: if mode == JogMode::Accelerated {
                    0
                } else {
                    self.setup.jog.instant_speed
                },
                analog: false,
            });
        }
        if matches!(self.jog.motion, JogMotion::Stopping) {
            if self.motion.state() != MotionState::Idle {
                return;
            }
            self.jog.motion = JogMotion::Free;
        }
        if want != self.jog.motion.stick() {
            if self.motion.state() != MotionState::Idle {
                if let (JogMotion::Stick(run), Some(new)) = (self.jog.motion, want) {
                    if run.analog && new.analog {
                        if plan::same_direction(&run.dirs, &new.dirs) {
                            // Only the speed changes: ramp to it without stopping.
                            self.motion.change_speed(new.feed);
                            self.jog.motion = JogMotion::Stick(new);
                        } else {
                            // A new direction: bend into it from the end of the kernel's
                            // running segment ([`Board::drop_queued`]).
                            self.motion.request_drop();
                            self.jog.bend = want;
                        }
                        return;
                    }
                }
                if let JogMotion::Stick(_) = self.jog.motion {
                    self.motion.abort();
                    self.jog.motion = JogMotion::Stopping;
                }
                return;
            }
            self.jog.motion = JogMotion::Free;
            if let Some(m) = want {
                self.start_stick_move(m);
            }
        }
        if mode == JogMode::Nudge && want.is_none() {
            let any = dirs.iter().any(|&d| d != 0);
            let due = dirs != self.jog.nudge_dirs
                || self.sensed.now_ms.wrapping_sub(self.jog.next_nudge) < u32::MAX / 2;
            // A nudge still moving delays the next one: nothing queues up behind the stick.
            if any && due && self.motion.state() == MotionState::Idle {
                self.nudge(&dirs);
                self.jog.next_nudge = self
                    .sensed
                    .now_ms
                    .wrapping_add(u32::from(self.setup.jog.nudge_interval_ms));
            }
            self.jog.nudge_dirs = dirs;
        } else {
            self.jog.nudge_dirs = [0; MAX_AXES];
        }
    }

    /// The analog stick's request: proportional speeds on its two axes.
    fn analog_request(&self, adc: AdcReadings) -> Option<StickMove> {
        let stick = adc.stick?;
        let j = &self.setup.jog;
        let mut dirs = [0i64; MAX_AXES];
        for (ch, &axis) in j.analog_axes.iter().enumerate() {
            if axis < self.setup.axis_count {
                if let (Some(d), Some(&s)) = (dirs.get_mut(usize::from(axis)), stick.get(ch)) {
                    *d = plan::analog_speed(s, self.setup.inputs.adc_max, j);
                }
            }
        }
        let sq: u128 = dirs
            .iter()
            .map(|&v| crate::arith::mul_i128(v as i128, v as i128) as u128)
            .sum();
        (sq != 0).then(|| StickMove {
            dirs,
            feed: plan::isqrt(sq) as i64,
            analog: true,
        })
    }

    /// Bends the analog jog into its new direction without stopping (after the queued segments
    /// were taken back); where it cannot (too close to the travel edge, nothing in progress), it
    /// stops and the new direction starts from rest.
    pub(super) fn bend_stick_move(&mut self, m: StickMove) {
        if !matches!(self.mode, Mode::Jog(Jogging::Joystick))
            || matches!(self.jog.motion, JogMotion::Stopping)
        {
            return;
        }
        let cfg = *self.motion.config();
        if self
            .motion
            .bend(m.feed, |from| plan::jog_target(&cfg, from, &m.dirs, None))
        {
            self.jog.motion = JogMotion::Stick(m);
        } else if self.motion.state() != MotionState::Idle {
            self.motion.abort();
            self.jog.motion = JogMotion::Stopping;
        } else {
            self.jog.motion = JogMotion::Free;
        }
    }

    fn start_stick_move(&mut self, m: StickMove) {
        let from = self.motion.queued_position();
        // At the edge already: remember the request so it is not retried every millisecond.
        self.jog.motion = JogMotion::Stick(m);
        let Some(to) = plan::jog_target(self.motion.config(), &from, &m.dirs, None) else {
            return;
        };
        let action = if m.feed == 0 {
            Action::Rapid { to }
        } else {
            Action::Feed { to, feed: m.feed }
        };
        let _ = self.motion.push(&Canon { line: 0, action });
    }

    /// One nudge increment (skipped when it would leave the soft-limit box).
    fn nudge(&mut self, dirs: &[i8; MAX_AXES]) {
        let from = self.motion.queued_position();
        let d = self.setup.jog.nudge_distance;
        let w = dirs.map(i64::from);
        if let Some(to) = plan::jog_target(self.motion.config(), &from, &w, Some(d)) {
            let feed = self.setup.jog.instant_speed;
            let _ = self.motion.push(&Canon {
                line: 0,
                action: Action::Feed { to, feed },
            });
        }
    }
}

//! Jogging (docs/controller.md "Jogging"): joystick switches S1-S4 → up to four axes through the stage-pair
//! selector, an analog stick → proportional speed, and the targets a jog may reach inside the
//! soft-limit box.
//!
//! The board turns a jog into one planned move toward the travel edge (continuous jogs) or one
//! increment (nudges and host distance jogs); releasing the stick stops it on its deceleration
//! ramp from the end of the kernel's running segment and drops the rest
//! ([`crate::motion::pipeline::Motion::abort`] with the queue taken back), so nothing queued
//! overruns. A new analog deflection along the same direction only changes the move's speed
//! ([`crate::motion::pipeline::Motion::change_speed`]) and a new direction bends the path
//! ([`crate::motion::pipeline::Motion::bend`]), so the velocity follows the stick without
//! stopping.

use crate::arith::{div_i128, mul_i128};
use crate::board::inputs::{InputBits, Signal};
use crate::motion::config::MotionConfig;
use crate::setup::JogSetup;
use crate::units::{Nm, Pos, MAX_AXES};

/// Speed steps of the analog stick: the deflection is quantised so noise does not restart jogs.
pub(crate) const ANALOG_LEVELS: i64 = 8;

/// The dead-man of a continuous host jog: the board ends it with a controlled stop when no
/// keepalive (or the jog itself) arrived for this long, on the board's clock. Senders keep it
/// alive at least every 100 ms (docs/controller.md "Jogging"), so a lost frame or two, or a
/// host stalled for a scheduler tick, does not stop a held jog, and a host that is killed,
/// stopped or cut off stops the axis within a quarter of a second plus its deceleration.
pub const JOG_DEADMAN_MS: u32 = 250;

/// When a continuous host jog last heard from its host (board milliseconds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Deadman {
    heard_ms: u32,
}

impl Deadman {
    /// Armed at `now_ms` (the jog request itself counts as the first keepalive).
    pub fn armed(now_ms: u32) -> Deadman {
        Deadman { heard_ms: now_ms }
    }

    /// A keepalive arrived at `now_ms`.
    pub fn heard(&mut self, now_ms: u32) {
        self.heard_ms = now_ms;
    }

    /// True once [`JOG_DEADMAN_MS`] passed since the last keepalive (wrapping clock).
    pub fn expired(&self, now_ms: u32) -> bool {
        now_ms.wrapping_sub(self.heard_ms) >= JOG_DEADMAN_MS
    }
}

/// Jog mode selected by the joystick's selector switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum JogMode {
    /// Rapid rates with acceleration.
    Accelerated,
    /// Constant jog speed (`jog.instant_speed`), no ramp.
    Instantaneous,
    /// One `jog.nudge_distance` every `jog.nudge_interval_ms` while a switch is held.
    Nudge,
}

/// The mode the selector switches choose.
pub(crate) fn mode_of(levels: InputBits) -> JogMode {
    if levels.get(Signal::Nudge) {
        JogMode::Nudge
    } else if levels.get(Signal::Accelerated) {
        JogMode::Accelerated
    } else {
        JogMode::Instantaneous
    }
}

/// Direction (-1, 0, +1) per axis the stick's switches ask for. S1 down / S4 up drive the pair's
/// first axis, S2 left / S3 right its second; opposite switches together cancel.
pub(crate) fn stick_directions(levels: InputBits, jog: &JogSetup) -> [i8; MAX_AXES] {
    let pair = jog.pairs[levels.get(Signal::PairSelect) as usize];
    let mut d = [0i8; MAX_AXES];
    let mut add = |axis: u8, minus: Signal, plus: Signal| {
        if (axis as usize) < MAX_AXES {
            d[axis as usize] += levels.get(plus) as i8 - levels.get(minus) as i8;
        }
    };
    add(pair[0], Signal::JogS1, Signal::JogS4);
    add(pair[1], Signal::JogS2, Signal::JogS3);
    d
}

/// Signed speed (nm/min) of an analog channel: neutral within the deadband around the centre,
/// then [`ANALOG_LEVELS`] equal steps up to `analog_max_speed` at full deflection.
pub(crate) fn analog_speed(reading: u16, adc_max: u16, jog: &JogSetup) -> i64 {
    let centre = i64::from(adc_max) / 2;
    let dev = i64::from(reading) - centre;
    let db = i64::from(jog.analog_deadband);
    let range = (centre - db).max(1);
    let mag = dev.abs() - db;
    if mag <= 0 {
        return 0;
    }
    let level = ((mag * ANALOG_LEVELS + range - 1) / range).min(ANALOG_LEVELS);
    dev.signum() * jog.analog_max_speed * level / ANALOG_LEVELS
}

/// End point of a jog from `from` along the direction weights `dirs` (±1 per switch axis, or the
/// analog stick's signed speeds): `distance` on every moving axis, or (distance `None`) as far
/// along `dirs` as the soft-limit box allows. `None` when the jog cannot move (no direction,
/// already at the edge, or the increment leaves the box).
pub(crate) fn jog_target(
    cfg: &MotionConfig,
    from: &Pos,
    dirs: &[i64; MAX_AXES],
    distance: Option<Nm>,
) -> Option<Pos> {
    // (`min`: the config never has more; it lets the compiler drop the bounds checks below.)
    let n = (cfg.axis_count as usize).min(MAX_AXES);
    if dirs.iter().take(n).all(|&d| d == 0) {
        return None;
    }
    let mut to = *from;
    match distance {
        Some(d) => {
            for i in 0..n {
                to[i] += dirs[i].signum() * d;
            }
        }
        None => {
            // The axis that reaches its edge first (smallest room / weight) limits the move.
            let mut best: Option<(i128, i128)> = None;
            for i in 0..n {
                let a = &cfg.axes[i];
                let room = match dirs[i].signum() {
                    0 => continue,
                    1 if cfg.soft_limits => a.travel_max - from[i],
                    -1 if cfg.soft_limits => from[i] - a.travel_min,
                    // Without soft limits a continuous jog runs one travel span at most.
                    _ => a.travel_max - a.travel_min,
                };
                let (r, w) = (i128::from(room.max(0)), i128::from(dirs[i].abs()));
                if best.is_none_or(|(br, bw)| mul_i128(r, bw) < mul_i128(br, w)) {
                    best = Some((r, w));
                }
            }
            let (room, weight) = best?;
            for i in 0..n {
                to[i] += div_i128(mul_i128(i128::from(dirs[i]), room), weight) as i64;
            }
        }
    }
    if to == *from || (cfg.soft_limits && cfg.travel_violation(&to).is_some()) {
        return None;
    }
    Some(to)
}

/// True when the direction weights `a` and `b` point the same way (parallel, same sense): an
/// analog deflection that changes only the speed.
pub(crate) fn same_direction(a: &[i64; MAX_AXES], b: &[i64; MAX_AXES]) -> bool {
    let wide = |x: i64, y: i64| mul_i128(i128::from(x), i128::from(y));
    let dot: i128 = a.iter().zip(b).map(|(&x, &y)| wide(x, y)).sum();
    if dot <= 0 {
        return false;
    }
    (0..MAX_AXES).all(|i| (i + 1..MAX_AXES).all(|j| wide(a[i], b[j]) == wide(a[j], b[i])))
}

/// Integer square root (floor) of a u128, for path speeds of the analog stick (the motion
/// core's, one copy in flash for every caller).
pub(crate) fn isqrt(v: u128) -> u128 {
    crate::arith::isqrt_u128(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::setup::Setup;
    use crate::units::NM_PER_MM;

    #[test]
    fn switches_map_through_the_pair_selector() {
        let jog = Setup::default().jog; // pair 0: S1/S4 → Y, S2/S3 → X; pair 1: S1/S4 → Z
        let mut l = InputBits(0);
        l.set(Signal::JogS3, true);
        l.set(Signal::JogS1, true);
        assert_eq!(stick_directions(l, &jog), [1, -1, 0, 0, 0, 0]);
        l.set(Signal::PairSelect, true);
        assert_eq!(stick_directions(l, &jog), [0, 0, -1, 0, 0, 0]);
        l.set(Signal::JogS4, true);
        assert_eq!(stick_directions(l, &jog), [0; MAX_AXES]);
    }

    #[test]
    fn continuous_jogs_end_on_the_soft_limit_and_increments_stay_inside() {
        let cfg = MotionConfig::from_setup(&Setup::default());
        let from = [290 * NM_PER_MM, 0, 0, 0, 0, 0];
        let to = jog_target(&cfg, &from, &[1, 1, 0, 0, 0, 0], None).unwrap();
        assert_eq!(&to[..2], &[300 * NM_PER_MM, 10 * NM_PER_MM]);
        assert!(jog_target(&cfg, &from, &[1, 0, 0, 0, 0, 0], Some(11 * NM_PER_MM)).is_none());
        assert!(jog_target(&cfg, &to, &[1, 0, 0, 0, 0, 0], None).is_none());
        // Analog weights: X twice as fast as -Y; X has 10 mm of room, Y 200 mm.
        let to = jog_target(&cfg, &from, &[2000, -1000, 0, 0, 0, 0], None).unwrap();
        assert_eq!(&to[..2], &[300 * NM_PER_MM, -5 * NM_PER_MM]);
        assert_eq!(isqrt(1_000_000_000_000), 1_000_000);
        assert_eq!(isqrt(99), 9);
    }

    #[test]
    fn a_speed_change_keeps_the_direction_and_a_reversal_does_not() {
        let a = [4000, -2000, 0, 0, 0, 0];
        assert!(same_direction(&a, &[2000, -1000, 0, 0, 0, 0]));
        assert!(!same_direction(&a, &[-2000, 1000, 0, 0, 0, 0]));
        assert!(!same_direction(&a, &[4000, -1000, 0, 0, 0, 0]));
        assert!(!same_direction(&a, &[0; MAX_AXES]));
    }

    #[test]
    fn the_deadman_expires_250_ms_after_the_last_keepalive() {
        // Near the wrap of the board's millisecond clock.
        let t0 = u32::MAX - 100;
        let mut d = Deadman::armed(t0);
        assert!(!d.expired(t0.wrapping_add(249)));
        d.heard(t0.wrapping_add(200));
        assert!(!d.expired(t0.wrapping_add(449)));
        assert!(d.expired(t0.wrapping_add(450)));
    }

    #[test]
    fn analog_deflection_gives_quantised_speed() {
        let jog = Setup::default().jog; // deadband 100, 1000 mm/min
        assert_eq!(analog_speed(2047, 4095, &jog), 0);
        assert_eq!(analog_speed(2047 + 100, 4095, &jog), 0);
        assert_eq!(analog_speed(4095, 4095, &jog), 1000 * NM_PER_MM);
        assert_eq!(analog_speed(0, 4095, &jog), -1000 * NM_PER_MM);
        assert_eq!(analog_speed(2047 + 101, 4095, &jog), 125 * NM_PER_MM);
    }
}

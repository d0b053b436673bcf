//! grbl's numbered settings (`$$`, `$n=value`) as views of the Gantry setup keys that mean the
//! same thing (table in docs/grbl.md). `$10` (status report mask) and `$13` (report in inches)
//! belong to the grbl front end itself (the setup's `grbl` section, [`Prefs`]); settings Gantry has no key for are shown with
//! the value Gantry behaves as and accept only that value.

use super::codes;
use crate::board::LIMIT_BITS;
use crate::setup::table::{NO_GRBL, ROWS};
use crate::setup::{Key, Reason, Setup, SetupError};
use crate::units::MAX_AXES;

/// The front end's report preferences (`$10`, `$13`), read from the setup's grbl section.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prefs {
    /// `$10`: bit 0 machine position (else work position), bit 1 buffer state.
    pub status_mask: u8,
    /// `$13`: report positions and feeds in inches.
    pub inches: bool,
}

impl Prefs {
    pub fn of(setup: &Setup) -> Prefs {
        Prefs {
            status_mask: setup.grbl.status_mask,
            inches: setup.grbl.inches,
        }
    }
}

/// grbl numbers with no row of their own in the settings table (machine/src/setup/table.rs):
/// settings Gantry has no key for (shown with the value it behaves as), `$22` (read from the
/// homing priorities).
const NOT_IN_TABLE: [u16; 6] = [1, 2, 4, 6, 20, 22];
/// Axis setting groups: steps/mm, max rate, acceleration, travel.
pub(crate) const AXIS_GROUPS: [u16; 4] = [100, 110, 120, 130];

/// The `$$` numbers, in order: the global settings ascending (the table's grbl numbers below
/// 100 and [`NOT_IN_TABLE`]), then the table's per-axis groups (`$100`+i…) for each axis in use.
pub fn numbers(axis_count: u8) -> heapless::Vec<u16, 48> {
    let mut v = heapless::Vec::new();
    for n in 0..100 {
        if NOT_IN_TABLE.contains(&n) || ROWS.iter().any(|r| r.grbl == n) {
            let _ = v.push(n);
        }
    }
    for r in ROWS.iter().filter(|r| (100..NO_GRBL).contains(&r.grbl)) {
        for a in 0..u16::from(axis_count) {
            let _ = v.push(r.grbl + a);
        }
    }
    v
}

/// The grbl error for a setup `$x=` would leave invalid (table in docs/grbl.md): grbl's
/// "step rate too high" (12) and "step pulse too short" (6) where they fit, else "invalid
/// statement" (3), grbl 1.1 having no number for an out-of-range value.
pub(crate) fn refusal(e: &SetupError) -> u16 {
    match (e.key, e.reason) {
        (_, Reason::StepRateTooHigh { .. }) => 12,
        (Key::StepPulse, _) => 6,
        _ => codes::INVALID_STATEMENT,
    }
}

/// A setting's value: `milli` thousandths, shown with 3 decimals or as an integer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Value {
    pub milli: i64,
    pub decimals: bool,
}

const fn int(v: i64) -> Value {
    Value {
        milli: v * 1000,
        decimals: false,
    }
}

const fn dec(milli: i64) -> Value {
    Value {
        milli,
        decimals: true,
    }
}

/// nm as a 3-decimal mm value.
fn mm_value(nm: i64) -> Value {
    dec(div_round(nm, 1000))
}

fn div_round(a: i64, b: i64) -> i64 {
    // `b` is positive (1000, or a valid setup's `units_nm`); `max(1)` leaves no division-by-zero
    // panic path.
    let b = (b as u64).max(1);
    let (q, r) = (a.unsigned_abs() / b, a.unsigned_abs() % b);
    let q = (q + u64::from(2 * r >= b)) as i64;
    if a < 0 {
        -q
    } else {
        q
    }
}

/// The setup's axis count (`min`: a valid setup never has more than `MAX_AXES`; it lets the
/// compiler drop the bounds checks of the per-axis indexing below).
fn axis_count(setup: &Setup) -> usize {
    usize::from(setup.axis_count).min(MAX_AXES)
}

/// The setting's axis and group for `$100`-`$13x`.
fn axis_of(n: u16, setup: &Setup) -> Option<(usize, u16)> {
    let group = n / 10 * 10;
    let axis = usize::from(n % 10);
    (AXIS_GROUPS.contains(&group) && axis < axis_count(setup)).then_some((axis, group))
}

fn bits(setup: &Setup, f: impl Fn(usize) -> bool) -> i64 {
    (0..axis_count(setup))
        .filter(|&i| f(i))
        .fold(0, |m, i| m | 1 << i)
}

/// The value of setting `n`, `None` when there is no such setting.
pub fn read(n: u16, setup: &Setup) -> Option<Value> {
    if let Some((a, group)) = axis_of(n, setup) {
        let ax = setup.axes.get(a)?;
        return Some(match group {
            // steps per mm = steps / (units_nm / 1e6), in thousandths.
            100 => dec(div_round(i64::from(ax.steps) * 1_000_000_000, ax.units_nm)),
            110 => mm_value(ax.max_rate),
            120 => mm_value(ax.accel),
            _ => mm_value(ax.travel_max - ax.travel_min),
        });
    }
    let h = &setup.homing.axes[0];
    Some(match n {
        0 => int(i64::from(setup.drivers.step_pulse_ns / 1000)),
        1 => int(255),
        2 | 4 | 6 => int(0),
        3 => int(bits(setup, |i| setup.axes[i].invert_dir)),
        5 => int(i64::from(setup.inputs.invert & LIMIT_BITS != 0)),
        10 => int(i64::from(setup.grbl.status_mask)),
        11 => mm_value(setup.path.junction_deviation),
        12 => mm_value(setup.path.chord_tolerance),
        13 => int(i64::from(setup.grbl.inches)),
        20 => int(1),
        21 => int(i64::from(setup.inputs.hard_limits)),
        22 => int(i64::from(
            setup
                .homing
                .axes
                .iter()
                .take(axis_count(setup))
                .any(|h| h.priority > 0),
        )),
        23 => int(bits(setup, |i| setup.homing.axes[i].seek_low)),
        24 => mm_value(h.locate_rate),
        25 => mm_value(h.seek_rate),
        26 => int(i64::from(setup.inputs.debounce_ms)),
        27 => mm_value(h.retract),
        30 => int(i64::from(setup.outputs.spindle_max_rpm)),
        31 => int(i64::from(setup.outputs.spindle_min_rpm)),
        32 => int(i64::from(setup.outputs.laser)),
        _ => return None,
    })
}

/// Writes `milli` (thousandths) to setting `n` of `setup`; `Err` is the grbl error number.
pub fn write(n: u16, milli: i64, setup: &mut Setup) -> Result<(), u16> {
    let nm = milli * 1000;
    let whole = milli / 1000;
    let flag = match whole {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    };
    let positive = |v: i64| {
        if v > 0 {
            Ok(v)
        } else {
            Err(codes::NEGATIVE_VALUE)
        }
    };
    if let Some((a, group)) = axis_of(n, setup) {
        let ax = setup.axes.get_mut(a).ok_or(codes::INVALID_STATEMENT)?;
        match group {
            100 => {
                // steps per metre over 1 m of nm, reduced.
                let steps = positive(milli)?;
                let (s, u) = reduce(steps, 1_000_000_000);
                ax.steps = u32::try_from(s).map_err(|_| codes::BAD_NUMBER)?;
                ax.units_nm = u;
            }
            110 => ax.max_rate = positive(nm)?,
            120 => ax.accel = positive(nm)?,
            _ => ax.travel_max = ax.travel_min + positive(nm)?,
        }
        return Ok(());
    }
    if milli < 0 {
        return Err(codes::NEGATIVE_VALUE);
    }
    let axes = axis_count(setup);
    match n {
        0 => {
            if whole < 1 {
                return Err(6);
            }
            setup.drivers.step_pulse_ns =
                u32::try_from(whole * 1000).map_err(|_| codes::BAD_NUMBER)?;
        }
        3 => {
            for i in 0..axes {
                setup.axes[i].invert_dir = whole & 1 << i != 0;
            }
        }
        5 => match flag {
            Some(true) => setup.inputs.invert |= LIMIT_BITS,
            Some(false) => setup.inputs.invert &= !LIMIT_BITS,
            None => return Err(codes::INVALID_STATEMENT),
        },
        // grbl keeps a byte (only bits 0 and 1 mean anything in 1.1): a larger value is out of
        // range rather than cut to its low bits.
        10 if whole > 255 => return Err(codes::INVALID_STATEMENT),
        10 => setup.grbl.status_mask = u8::try_from(whole & 3).unwrap_or(1),
        11 => setup.path.junction_deviation = positive(nm)?,
        12 => setup.path.chord_tolerance = positive(nm)?,
        13 => setup.grbl.inches = flag.ok_or(codes::INVALID_STATEMENT)?,
        21 => setup.inputs.hard_limits = flag.ok_or(codes::INVALID_STATEMENT)?,
        23 => {
            for i in 0..axes {
                setup.homing.axes[i].seek_low = whole & 1 << i != 0;
            }
        }
        24 => {
            let rate = positive(nm)?;
            for h in &mut setup.homing.axes[..axes] {
                h.locate_rate = rate;
            }
        }
        25 => {
            let rate = positive(nm)?;
            for h in &mut setup.homing.axes[..axes] {
                h.seek_rate = rate;
            }
        }
        26 => setup.inputs.debounce_ms = u8::try_from(whole).map_err(|_| codes::BAD_NUMBER)?,
        27 => {
            for h in &mut setup.homing.axes[..axes] {
                h.retract = nm;
            }
        }
        30 => {
            setup.outputs.spindle_max_rpm = u32::try_from(whole).map_err(|_| codes::BAD_NUMBER)?
        }
        31 => {
            setup.outputs.spindle_min_rpm = u32::try_from(whole).map_err(|_| codes::BAD_NUMBER)?
        }
        32 => setup.outputs.laser = flag.ok_or(codes::INVALID_STATEMENT)?,
        // Settings Gantry has no key for: only the value it behaves as.
        1 | 2 | 4 | 6 | 20 | 22 => {
            let shown = read(n, setup).ok_or(codes::INVALID_STATEMENT)?;
            if shown.milli != whole * 1000 {
                return Err(codes::INVALID_STATEMENT);
            }
        }
        _ => return Err(codes::INVALID_STATEMENT),
    }
    Ok(())
}

/// `a / b` in lowest terms.
fn reduce(a: i64, b: i64) -> (i64, i64) {
    let (mut x, mut y) = (a, b);
    while y != 0 {
        (x, y) = (y, x % y);
    }
    (a / x, b / x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_per_mm_round_trip_through_the_exact_ratio() {
        let mut s = Setup::default();
        write(100, 80_000, &mut s).unwrap();
        assert_eq!((s.axes[0].steps, s.axes[0].units_nm), (1, 12_500));
        write(101, 314_159, &mut s).unwrap();
        assert_eq!(read(101, &s), Some(dec(314_159)));
        assert_eq!(write(102, -5_000, &mut s), Err(codes::NEGATIVE_VALUE));
        assert_eq!(read(32, &s), Some(int(0)));
        write(32, 1000, &mut s).unwrap();
        assert!(s.outputs.laser);
        assert_eq!(read(32, &s), Some(int(1)));
        assert_eq!(write(32, 2000, &mut s), Err(codes::INVALID_STATEMENT));
        assert_eq!(write(1, 25_000, &mut s), Err(codes::INVALID_STATEMENT));
        assert_eq!(write(1, 255_000, &mut s), Ok(()));
        write(110, 5_000_000, &mut s).unwrap();
        assert_eq!(s.axes[0].max_rate, 5_000 * crate::units::NM_PER_MM);
        write(130, 250_000, &mut s).unwrap();
        assert_eq!(
            s.axes[0].travel_max - s.axes[0].travel_min,
            250 * crate::units::NM_PER_MM
        );
        assert_eq!(read(199, &s), None);
    }

    #[test]
    fn the_listing_is_grbls_order_from_the_table() {
        let listed = numbers(2);
        assert_eq!(
            listed.as_slice(),
            [
                0, 1, 2, 3, 4, 5, 6, 10, 11, 12, 13, 20, 21, 22, 23, 24, 25, 26, 27, 30, 31, 32,
                100, 101, 110, 111, 120, 121, 130, 131
            ]
        );
        // Every number listed has a value.
        let s = Setup::default();
        assert!(listed.iter().all(|&n| read(n, &s).is_some()));
    }
}

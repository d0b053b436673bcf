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
/// Axis setting groups: steps/mm, max rate, acceleration, travel, jerk (grblHAL's `$800`+i,
/// mm/s³).
pub(crate) const AXIS_GROUPS: [u16; 5] = [100, 110, 120, 130, 800];

/// The plasma torch's numbers (the table's rows of 200 and up): grblHAL's plasma plugin numbers
/// where it has the setting (`$350` mode, `$351` THC delay, `$356` anti-dive, `$358` arc-OK
/// timeout), Gantry's own in grblHAL's block for settings no public plugin uses (`$450` THC
/// rate, `$451` THC travel). docs/grbl.md lists them.
const TORCH_FIRST: u16 = 200;

/// The `$$` numbers, in order: the global settings ascending (the table's grbl numbers below
/// 100 and [`NOT_IN_TABLE`]), then the table's per-axis groups below the torch's (`$100`+i…)
/// for each axis in use, then the torch's (`$350`…, [`TORCH_FIRST`]) ascending, then the per-axis
/// groups above them (jerk's `$800`+i).
pub fn numbers(axis_count: u8) -> heapless::Vec<u16, 72> {
    let mut v = heapless::Vec::new();
    for n in 0..100 {
        if NOT_IN_TABLE.contains(&n) || ROWS.iter().any(|r| r.grbl == n) {
            let _ = v.push(n);
        }
    }
    let axis_group = |v: &mut heapless::Vec<u16, 72>, g: u16| {
        if ROWS.iter().any(|r| r.grbl == g) {
            for a in 0..u16::from(axis_count) {
                let _ = v.push(g + a);
            }
        }
    };
    for g in AXIS_GROUPS.into_iter().filter(|&g| g < TORCH_FIRST) {
        axis_group(&mut v, g);
    }
    // The torch's numbers ascending, found row by row: the next one is the least above the last
    // (a handful of passes over the table, not one probe per number up to `NO_GRBL`).
    let mut last = TORCH_FIRST - 1;
    while let Some(n) = ROWS
        .iter()
        .map(|r| r.grbl)
        .filter(|&g| g > last && g != NO_GRBL && !AXIS_GROUPS.contains(&g))
        .min()
    {
        let _ = v.push(n);
        last = n;
    }
    for g in AXIS_GROUPS.into_iter().filter(|&g| g >= TORCH_FIRST) {
        axis_group(&mut v, g);
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
            800 => mm_value(ax.jerk),
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
        350 => int(torch_mode(setup)),
        351 => dec(i64::from(setup.outputs.torch.thc_delay_ms)),
        356 => int(i64::from(setup.outputs.torch.thc_anti_dive)),
        358 => dec(i64::from(setup.outputs.torch.arc_ok_timeout_ms)),
        450 => mm_value(setup.outputs.torch.thc_rate),
        451 => mm_value(setup.outputs.torch.thc_travel),
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
            // 0 turns jerk limiting off.
            800 if nm < 0 => return Err(codes::NEGATIVE_VALUE),
            800 => ax.jerk = nm,
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
        350 => {
            let t = &mut setup.outputs.torch;
            match whole {
                0 => t.on = false,
                2 | 3 => (t.on, t.thc) = (true, whole == 2),
                // 1: grblHAL's arc-voltage THC (no such input here).
                _ => return Err(codes::INVALID_STATEMENT),
            }
        }
        // Seconds with ms resolution (`milli`: ms).
        351 => {
            setup.outputs.torch.thc_delay_ms =
                u16::try_from(milli).map_err(|_| codes::INVALID_STATEMENT)?
        }
        356 => {
            setup.outputs.torch.thc_anti_dive =
                u8::try_from(whole).map_err(|_| codes::INVALID_STATEMENT)?
        }
        358 => {
            setup.outputs.torch.arc_ok_timeout_ms =
                u16::try_from(milli).map_err(|_| codes::INVALID_STATEMENT)?
        }
        450 => setup.outputs.torch.thc_rate = positive(nm)?,
        451 => setup.outputs.torch.thc_travel = nm,
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

/// `$350` as grblHAL's plasma plugin numbers its modes: 0 off, 2 arc-OK with up/down THC, 3
/// arc-OK only (1, arc-voltage THC, does not exist here).
fn torch_mode(setup: &Setup) -> i64 {
    let t = &setup.outputs.torch;
    match (t.on, t.thc) {
        (false, _) => 0,
        (true, true) => 2,
        (true, false) => 3,
    }
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
        // Jerk, grblHAL's `$800`+i in mm/s³: 0 is off, a negative value is refused.
        assert_eq!(read(801, &s), Some(dec(0)));
        write(801, 5_000_000, &mut s).unwrap();
        assert_eq!(s.axes[1].jerk, 5_000 * crate::units::NM_PER_MM);
        assert_eq!(read(801, &s), Some(dec(5_000_000)));
        assert_eq!(write(800, -1_000, &mut s), Err(codes::NEGATIVE_VALUE));
        write(801, 0, &mut s).unwrap();
        assert_eq!(s.axes[1].jerk, 0);
        assert_eq!(read(803, &s), None);
    }

    #[test]
    fn the_listing_is_grbls_order_from_the_table() {
        let listed = numbers(2);
        assert_eq!(
            listed.as_slice(),
            [
                0, 1, 2, 3, 4, 5, 6, 10, 11, 12, 13, 20, 21, 22, 23, 24, 25, 26, 27, 30, 31, 32,
                100, 101, 110, 111, 120, 121, 130, 131, 350, 351, 356, 358, 450, 451, 800, 801
            ]
        );
        // Every number listed has a value.
        let s = Setup::default();
        assert!(listed.iter().all(|&n| read(n, &s).is_some()));
        // Every axis of the most the board has fits the listing.
        assert_eq!(numbers(MAX_AXES as u8).len(), 22 + 5 * MAX_AXES + 6);
    }

    #[test]
    fn the_torch_mode_is_grblhals_plasma_mode_number() {
        let mut s = Setup::default();
        assert_eq!(read(350, &s), Some(int(0)));
        write(350, 2000, &mut s).unwrap();
        assert!(s.outputs.torch.on && s.outputs.torch.thc);
        assert_eq!(read(350, &s), Some(int(2)));
        write(350, 3000, &mut s).unwrap();
        assert!(s.outputs.torch.on && !s.outputs.torch.thc);
        assert_eq!(read(350, &s), Some(int(3)));
        assert_eq!(write(350, 1000, &mut s), Err(codes::INVALID_STATEMENT));
        assert_eq!(write(350, 4000, &mut s), Err(codes::INVALID_STATEMENT));
        write(350, 0, &mut s).unwrap();
        assert!(!s.outputs.torch.on);
        // Seconds with ms resolution; mm/min and mm as the axis settings.
        write(351, 1_250, &mut s).unwrap();
        write(358, 800, &mut s).unwrap();
        assert_eq!(
            (
                s.outputs.torch.thc_delay_ms,
                s.outputs.torch.arc_ok_timeout_ms
            ),
            (1250, 800)
        );
        assert_eq!(read(358, &s), Some(dec(800)));
        write(450, 600_000, &mut s).unwrap();
        write(451, 2_500, &mut s).unwrap();
        assert_eq!(s.outputs.torch.thc_rate, 600 * crate::units::NM_PER_MM);
        assert_eq!(s.outputs.torch.thc_travel, 2_500_000);
        assert_eq!(read(451, &s), Some(dec(2_500)));
        assert_eq!(write(450, 0, &mut s), Err(codes::NEGATIVE_VALUE));
        assert_eq!(
            write(351, 70_000_000, &mut s),
            Err(codes::INVALID_STATEMENT)
        );
    }
}

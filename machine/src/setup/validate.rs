//! The one validation of a setup ([`Setup::validate`]): every range of the settings table
//! (machine/src/setup/table.rs) and the rules between settings. `gantry setup check`/`push`
//! (host-sender/src/setup_file.rs), the board's setup push (`Setup::from_blob`) and grbl `$x=`
//! writes (machine/src/device/grbl/mod.rs) all refuse a setup through it, with the same [`SetupError`].

use super::table::{Key, Section, Unit, ROWS};
use super::Setup;
use crate::step::timing::{StepTiming, KERNEL_TIMER_HZ};

/// Why a setting is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Outside the row's `min..=max`.
    OutOfRange,
    /// `start_speed` above the axis's `max_rate` (`limit`).
    StartAboveMaxRate,
    /// The low half of a `[low, high]` pair above its high half (`limit`); for `rpm_range` at
    /// or above it.
    Reversed,
    /// `jog.analog_deadband` not below half of `inputs.adc_max` (`limit`).
    DeadbandTooWide,
    /// The axis's `max_rate` needs more steps per second than the drivers' step pulse allows
    /// ([`Setup::step_rate_fits`]); the figures for the message.
    StepRateTooHigh {
        steps: u32,
        units_nm: i64,
        pulse_ns: u32,
        min_period: u32,
    },
    /// A grbl startup line with a character that is not printable ASCII, or a `$`.
    NotPrintable,
    /// `torch` with `laser`: one spindle output cannot be both.
    TorchWithLaser,
    /// An orient done input or dwell without the orient output it belongs to.
    OrientWithoutOutput,
    /// A limit switch on an axis that is not in use.
    NotAnAxis,
    /// A jerk limit on a build without jerk-limited motion (gantry-machine's `jerk` feature).
    JerkNotBuilt,
}

impl Reason {
    /// A short text (grbl's `[MSG:…]` on the board, the end of the host's message).
    pub fn text(&self) -> &'static str {
        match self {
            Reason::OutOfRange => "out of range",
            Reason::StartAboveMaxRate => "start speed above max rate",
            Reason::Reversed => "low above high",
            Reason::DeadbandTooWide => "deadband not below half of adc_max",
            Reason::StepRateTooHigh { .. } => "step rate too high for the drivers",
            Reason::NotPrintable => "not printable G-code",
            Reason::TorchWithLaser => "torch and laser are exclusive",
            Reason::OrientWithoutOutput => "orient input or dwell without an orient output",
            Reason::NotAnAxis => "an axis not in use",
            Reason::JerkNotBuilt => "no jerk-limited motion in this firmware",
        }
    }
}

/// A refused setting: its key, which axis (tool, line) of a repeated section, its value in core
/// units, the other value it was compared with, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SetupError {
    pub key: Key,
    pub index: u8,
    pub value: i64,
    pub limit: i64,
    pub reason: Reason,
}

fn err(key: Key, index: usize, value: i64, limit: i64, reason: Reason) -> SetupError {
    SetupError {
        key,
        index: index as u8,
        value,
        limit,
        reason,
    }
}

impl Setup {
    /// Checks every setting of the table against its range, then the rules between settings;
    /// the first refusal, in table order.
    pub fn validate(&self) -> Result<(), SetupError> {
        // The axis count first: the per-axis rows index by it.
        let axes = Key::Axes;
        axes.check(0, axes.value(self, 0))?;
        for r in ROWS.iter().filter(|r| r.unit != Unit::Text) {
            for i in 0..r.section.count(self) {
                r.key.check(i, r.key.value(self, i))?;
            }
        }
        let n = Section::Axis.count(self);
        for (i, a) in self.axes[..n].iter().enumerate() {
            if a.start_speed > a.max_rate {
                let e = Reason::StartAboveMaxRate;
                return Err(err(Key::StartSpeed, i, a.start_speed, a.max_rate, e));
            }
            if a.travel_min > a.travel_max {
                let e = Reason::Reversed;
                return Err(err(Key::TravelMin, i, a.travel_min, a.travel_max, e));
            }
            if !cfg!(feature = "jerk") && a.jerk != 0 {
                return Err(err(Key::Jerk, i, a.jerk, 0, Reason::JerkNotBuilt));
            }
        }
        for key in [Key::LimitsMin, Key::LimitsMax] {
            let extra = key.value(self, 0) >> n;
            if extra != 0 {
                return Err(err(key, 0, extra << n, 0, Reason::NotAnAxis));
            }
        }
        let pairs = [
            (Key::FroLow, self.operator.fro_low > self.operator.fro_high),
            (
                Key::RpmMin,
                self.outputs.spindle_min_rpm >= self.outputs.spindle_max_rpm,
            ),
            (Key::PwmMin, self.outputs.pwm_min > self.outputs.pwm_max),
        ];
        for (key, reversed) in pairs {
            if reversed {
                let (lo, hi) = (key.value(self, 0), key.next().value(self, 0));
                return Err(err(key, 0, lo, hi, Reason::Reversed));
            }
        }
        if self.outputs.torch.on && self.outputs.laser {
            return Err(err(Key::Torch, 0, 1, 1, Reason::TorchWithLaser));
        }
        let o = &self.outputs.orient;
        if !o.present() && (o.done_input != super::OrientSetup::NONE || o.dwell_ms != 0) {
            let e = Reason::OrientWithoutOutput;
            return Err(err(Key::OrientDwellMs, 0, o.dwell_ms.into(), 0, e));
        }
        let (band, adc) = (self.jog.analog_deadband, self.inputs.adc_max);
        if u32::from(band) * 2 >= u32::from(adc) {
            let e = Reason::DeadbandTooWide;
            return Err(err(Key::AnalogDeadband, 0, band.into(), adc.into(), e));
        }
        for (i, a) in self.axes[..n].iter().enumerate() {
            if !self.step_rate_fits(a) {
                let e = Reason::StepRateTooHigh {
                    steps: a.steps,
                    units_nm: a.units_nm,
                    pulse_ns: self.drivers.step_pulse_ns,
                    min_period: StepTiming::from_setup(&self.drivers).min_period,
                };
                return Err(err(Key::MaxRate, i, a.max_rate, 0, e));
            }
        }
        for (i, l) in self.grbl.startup.iter().enumerate() {
            if !l.bytes().all(|c| (b' '..=b'~').contains(&c) && c != b'$') {
                return Err(err(Key::StartupLines, i, 0, 0, Reason::NotPrintable));
            }
        }
        Ok(())
    }
}

/// `v` core units as file units (`scale` per unit), exact, without trailing zeros.
struct Scaled(i64, i64);

impl core::fmt::Display for Scaled {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (v, scale) = (self.0, self.1.max(1) as u64);
        let sign = if v < 0 { "-" } else { "" };
        let (int, mut frac) = (v.unsigned_abs() / scale, v.unsigned_abs() % scale);
        write!(f, "{sign}{int}")?;
        if frac == 0 {
            return Ok(());
        }
        f.write_str(".")?;
        let mut unit = scale / 10;
        while frac > 0 && unit > 0 {
            write!(f, "{}", frac / unit)?;
            frac %= unit;
            unit /= 10;
        }
        Ok(())
    }
}

/// The full key of a row: `axis.X.max_rate`, `tool[2].length`, `grbl.status_mask`.
pub struct KeyName(pub Key, pub usize);

impl core::fmt::Display for KeyName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (key, i) = (self.0, self.1);
        let letter = crate::units::AXIS_LETTERS.get(i).copied().unwrap_or('?');
        match key.row().section {
            Section::Top => Ok(()),
            Section::Axis => write!(f, "axis.{letter}."),
            Section::HomingAxis => write!(f, "homing.axis.{letter}."),
            Section::Tool => write!(f, "tool[{i}]."),
            Section::Mcode => write!(f, "mcode[{i}]."),
            s => write!(f, "{}.", section_name(s)),
        }?;
        f.write_str(key.text().name)
    }
}

/// A section's table name (`path`, `program`…).
pub fn section_name(s: Section) -> &'static str {
    match s {
        Section::Top => "",
        Section::Axis => "axis",
        Section::Path => "path",
        Section::Program => "program",
        Section::Tool => "tool",
        Section::Operator => "operator",
        Section::Inputs => "inputs",
        Section::Homing => "homing",
        Section::HomingAxis => "homing.axis",
        Section::Jog => "jog",
        Section::Spindle => "spindle",
        Section::Mcode => "mcode",
        Section::Link => "link",
        Section::Drivers => "drivers",
        Section::Grbl => "grbl",
    }
}

/// A value of `key` in file units (`3000`, `2.5`).
pub fn file_value(key: Key, v: i64) -> impl core::fmt::Display {
    Scaled(v, key.row().unit.scale())
}

/// The host keeps the refusal itself as its error (`anyhow::Error::new`), so a test can compare
/// it with the one the board gives.
impl core::error::Error for SetupError {}

/// The host's message: the key, the value in file units and what is allowed.
impl core::fmt::Display for SetupError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (key, i) = (self.key, usize::from(self.index));
        let row = key.row();
        let unit = row.unit.suffix();
        let name = KeyName(key, i);
        let value = file_value(key, self.value);
        match self.reason {
            Reason::OutOfRange => write!(
                f,
                "{name} = {value}: must be between {} and {}{unit}",
                file_value(key, row.min()),
                file_value(key, row.max())
            ),
            Reason::JerkNotBuilt => write!(
                f,
                "{name} = {value}: this firmware has no jerk-limited motion (set 0)"
            ),
            Reason::OrientWithoutOutput => write!(
                f,
                "spindle.orient_done_input/orient_dwell_ms: set spindle.orient_output first"
            ),
            Reason::TorchWithLaser => write!(
                f,
                "{name} = true: not with {} = true (one spindle output is a torch or a laser)",
                KeyName(Key::Laser, 0)
            ),
            Reason::StartAboveMaxRate => write!(
                f,
                "{name} = {value}: must not exceed {} ({})",
                KeyName(Key::MaxRate, i),
                file_value(Key::MaxRate, self.limit)
            ),
            Reason::Reversed => write!(
                f,
                "{name} = {value}: must {} {} ({}{unit})",
                if key == Key::RpmMin {
                    "be below"
                } else {
                    "not exceed"
                },
                KeyName(key.next(), i),
                file_value(key, self.limit)
            ),
            Reason::DeadbandTooWide => write!(
                f,
                "{name} = {value}: must be below half of inputs.adc_max ({})",
                self.limit
            ),
            Reason::StepRateTooHigh {
                steps,
                units_nm,
                pulse_ns,
                min_period,
            } => {
                // steps/s = max_rate · steps / (units · 60), rounded; allowed = timer Hz / period.
                let num = self.value.max(0) as u128 * u128::from(steps);
                let den = units_nm.max(1) as u128 * 60;
                let rate = (2 * num + den) / (2 * den);
                let allowed = KERNEL_TIMER_HZ / min_period.max(1);
                write!(
                    f,
                    "{name} = {value} mm/min is {rate} steps/s, but the drivers' step pulse \
                     ({} µs, then low as long again) allows at most {allowed} steps/s: lower \
                     max_rate or drivers.step_pulse_us",
                    Scaled(i64::from(pulse_ns), 1000)
                )
            }
            Reason::NotAnAxis => write!(f, "{name}: a limit switch on an axis not in use"),
            Reason::NotPrintable => write!(f, "{name}[{i}]: printable ASCII G-code, no $ command"),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn a_limit_switch_on_an_axis_not_in_use_is_refused() {
        let mut s = Setup::default();
        s.inputs.limit_max = 0b0100;
        assert_eq!(s.validate(), Ok(()));
        s.axis_count = 2;
        let e = s.validate().unwrap_err();
        assert_eq!(
            (e.key, e.value, e.reason),
            (Key::LimitsMax, 0b0100, Reason::NotAnAxis)
        );
        assert_eq!(
            e.to_string(),
            "inputs.limits_max: a limit switch on an axis not in use"
        );
    }
}

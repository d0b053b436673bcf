//! The machine setup file: a commented TOML in everyday units (mm, mm/min, mm/s²), read into the
//! core's exact [`Setup`] and written back out. Every validation error names the key and the range.
//!
//! Decimal values are converted to integer nanometres with rounding to the nearest nm; the file is
//! the only place where a float ever touches a setting.

use anyhow::{bail, Context};
use gantry_machine::setup::{
    AxisSetup, Dialect, DwellUnits, Setup, Tool, MAX_TOOLS, MAX_USER_MCODES,
};
use gantry_machine::units::{Nm, AXIS_LETTERS, MAX_AXES, NM_PER_MM};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The file as written by users: every field optional, defaults from [`Setup::default`].
#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SetupFile {
    /// Axes in use, a prefix of X Y Z A B C.
    pub axes: Option<Vec<String>>,
    #[serde(default)]
    pub axis: BTreeMap<String, AxisFile>,
    #[serde(default)]
    pub path: PathFile,
    #[serde(default)]
    pub program: ProgramFile,
    #[serde(default)]
    pub tool: Vec<ToolFile>,
    #[serde(default)]
    pub work_offsets: BTreeMap<String, Vec<f64>>,
    #[serde(default)]
    pub operator: OperatorFile,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AxisFile {
    /// `[steps, units]`: this many motor steps move the axis this many mm (or degrees).
    pub steps_per: Option<(u32, f64)>,
    pub max_rate: Option<f64>,
    pub accel: Option<f64>,
    pub start_speed: Option<f64>,
    /// `[min, max]` in machine coordinates.
    pub travel: Option<(f64, f64)>,
    pub invert_dir: Option<bool>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PathFile {
    pub junction_deviation: Option<f64>,
    pub feed_shift: Option<f64>,
    pub chord_tolerance: Option<f64>,
    pub arc_segment_angle: Option<f64>,
    pub arc_max_segments: Option<u32>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramFile {
    pub dialect: Option<String>,
    pub dwell_units: Option<String>,
    pub peck_clearance: Option<f64>,
    pub chip_break_retract: Option<f64>,
    pub user_mcodes: Option<Vec<u16>>,
    pub g28_home: Option<Vec<f64>>,
    pub g30_home: Option<Vec<f64>>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ToolFile {
    pub number: u32,
    #[serde(default)]
    pub length: f64,
    #[serde(default)]
    pub diameter: f64,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OperatorFile {
    pub resume_needs_cycle_start: Option<bool>,
    pub two_hand_start: Option<bool>,
    pub fro_range: Option<(u16, u16)>,
    pub dry_run_feed: Option<f64>,
}

/// Work coordinate system names in offset-table order.
pub const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// Largest length accepted anywhere in the file, mm (the core is exact to 1 nm over far more).
const MAX_LENGTH_MM: f64 = 100_000.0;

/// Converts a value in mm to nm, checking `lo..=hi` (in mm) and naming `key` on error.
fn nm(key: &str, v: f64, lo: f64, hi: f64) -> anyhow::Result<Nm> {
    if !v.is_finite() || v < lo || v > hi {
        bail!("{key} = {v}: must be between {lo} and {hi}");
    }
    Ok((v * NM_PER_MM as f64).round() as Nm)
}

fn position(key: &str, values: &[f64], axis_count: usize) -> anyhow::Result<[Nm; MAX_AXES]> {
    if values.len() > axis_count {
        bail!(
            "{key}: {} values given but only {axis_count} axes are in use",
            values.len()
        );
    }
    let mut pos = [0; MAX_AXES];
    for (i, &v) in values.iter().enumerate() {
        pos[i] = nm(&format!("{key}[{i}]"), v, -MAX_LENGTH_MM, MAX_LENGTH_MM)?;
    }
    Ok(pos)
}

impl SetupFile {
    /// Reads and validates a setup file.
    pub fn load(path: &Path) -> anyhow::Result<Setup> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read setup file {}", path.display()))?;
        Self::parse(&text).with_context(|| format!("in setup file {}", path.display()))
    }

    /// Parses and validates setup text.
    pub fn parse(text: &str) -> anyhow::Result<Setup> {
        let file: SetupFile = toml::from_str(text)?;
        file.into_setup()
    }

    /// Applies the file's values over the defaults, validating each one.
    pub fn into_setup(self) -> anyhow::Result<Setup> {
        let mut s = Setup::default();
        if let Some(axes) = &self.axes {
            if axes.is_empty() || axes.len() > MAX_AXES {
                bail!("axes: between 1 and {MAX_AXES} axes, a prefix of X Y Z A B C");
            }
            for (i, name) in axes.iter().enumerate() {
                if !name.eq_ignore_ascii_case(&AXIS_LETTERS[i].to_string()) {
                    bail!(
                        "axes[{i}] = {name:?}: expected {:?} (axes are a prefix of X Y Z A B C)",
                        AXIS_LETTERS[i].to_string()
                    );
                }
            }
            s.axis_count = axes.len() as u8;
        }
        let count = s.axis_count as usize;
        for (name, a) in &self.axis {
            let Some(i) = AXIS_LETTERS[..count]
                .iter()
                .position(|l| name.eq_ignore_ascii_case(&l.to_string()))
            else {
                bail!(
                    "axis.{name}: not an axis in use (axes in use: {:?})",
                    &AXIS_LETTERS[..count]
                );
            };
            apply_axis(&format!("axis.{name}"), a, &mut s.axes[i])?;
        }
        let p = &self.path;
        if let Some(v) = p.junction_deviation {
            s.path.junction_deviation = nm("path.junction_deviation", v, 0.0, 10.0)?;
        }
        if let Some(v) = p.feed_shift {
            s.path.feed_shift = nm("path.feed_shift", v, 0.0, 100_000.0)?;
        }
        if let Some(v) = p.chord_tolerance {
            s.path.chord_tolerance = nm("path.chord_tolerance", v, 0.000_1, 1.0)?;
        }
        if let Some(v) = p.arc_segment_angle {
            if !(0.0..=90.0).contains(&v) {
                bail!("path.arc_segment_angle = {v}: must be between 0 (off) and 90 degrees");
            }
            s.path.arc_segment_angle_mdeg = (v * 1000.0).round() as u32;
        }
        if let Some(v) = p.arc_max_segments {
            s.path.arc_max_segments = v;
        }
        let g = &self.program;
        if let Some(d) = &g.dialect {
            s.program.dialect = match d.as_str() {
                "ngc" => Dialect::Ngc,
                "gixa" => Dialect::Gixa,
                other => bail!("program.dialect = {other:?}: must be \"ngc\" or \"gixa\""),
            };
        }
        if let Some(d) = &g.dwell_units {
            s.program.dwell_units = match d.as_str() {
                "seconds" => DwellUnits::Seconds,
                "milliseconds" => DwellUnits::Milliseconds,
                other => {
                    bail!(
                        "program.dwell_units = {other:?}: must be \"seconds\" or \"milliseconds\""
                    )
                }
            };
        }
        if let Some(v) = g.peck_clearance {
            s.program.peck_clearance = nm("program.peck_clearance", v, 0.0, 100.0)?;
        }
        if let Some(v) = g.chip_break_retract {
            s.program.chip_break_retract = nm("program.chip_break_retract", v, 0.0, 100.0)?;
        }
        if let Some(codes) = &g.user_mcodes {
            for &c in codes {
                if (0..=9).contains(&c) || c == 30 || c == 98 || c == 99 || c > 999 {
                    bail!("program.user_mcodes: M{c} is reserved or out of range (allowed 10-999 except 30, 98, 99)");
                }
                s.program.user_mcodes.push(c).map_err(|_| {
                    anyhow::anyhow!("program.user_mcodes: at most {MAX_USER_MCODES} codes")
                })?;
            }
        }
        if let Some(v) = &g.g28_home {
            s.program.g28_home = position("program.g28_home", v, count)?;
        }
        if let Some(v) = &g.g30_home {
            s.program.g30_home = position("program.g30_home", v, count)?;
        }
        for (i, t) in self.tool.iter().enumerate() {
            if t.number == 0 {
                bail!("tool[{i}].number: must be 1 or more (T0 is the empty spindle)");
            }
            if s.program.tools.iter().any(|x| x.number == t.number) {
                bail!("tool[{i}].number = {}: tool defined twice", t.number);
            }
            let tool = Tool {
                number: t.number,
                length: nm(&format!("tool[{i}].length"), t.length, -1000.0, 1000.0)?,
                diameter: nm(&format!("tool[{i}].diameter"), t.diameter, 0.0, 1000.0)?,
            };
            s.program
                .tools
                .push(tool)
                .map_err(|_| anyhow::anyhow!("tool: at most {MAX_TOOLS} tools"))?;
        }
        for (name, v) in &self.work_offsets {
            let Some(i) = WORK_SYSTEMS
                .iter()
                .position(|w| w.eq_ignore_ascii_case(name))
            else {
                bail!("work_offsets.{name}: must be one of {WORK_SYSTEMS:?}");
            };
            s.program.work_offsets[i] = position(&format!("work_offsets.{name}"), v, count)?;
        }
        let o = &self.operator;
        if let Some(v) = o.resume_needs_cycle_start {
            s.operator.resume_needs_cycle_start = v;
        }
        if let Some(v) = o.two_hand_start {
            s.operator.two_hand_start = v;
        }
        if let Some((lo, hi)) = o.fro_range {
            if !(10..=200).contains(&lo) || !(10..=200).contains(&hi) || lo > hi {
                bail!("operator.fro_range = [{lo}, {hi}]: both within 10-200 % and low ≤ high");
            }
            s.operator.fro_low = lo;
            s.operator.fro_high = hi;
        }
        if let Some(v) = o.dry_run_feed {
            s.operator.dry_run_feed = nm("operator.dry_run_feed", v, 1.0, 100_000.0)?;
        }
        Ok(s)
    }
}

fn apply_axis(key: &str, a: &AxisFile, axis: &mut AxisSetup) -> anyhow::Result<()> {
    if let Some((steps, units)) = a.steps_per {
        if steps == 0 {
            bail!("{key}.steps_per: the step count must be 1 or more");
        }
        axis.steps = steps;
        axis.units_nm = nm(&format!("{key}.steps_per"), units, 0.000_001, 10_000.0)?;
        if axis.units_nm == 0 {
            bail!("{key}.steps_per: the distance must be at least 0.000001 (1 nm)");
        }
    }
    if let Some(v) = a.max_rate {
        axis.max_rate = nm(&format!("{key}.max_rate"), v, 1.0, 200_000.0)?;
    }
    if let Some(v) = a.accel {
        axis.accel = nm(&format!("{key}.accel"), v, 1.0, 100_000.0)?;
    }
    if let Some(v) = a.start_speed {
        axis.start_speed = nm(&format!("{key}.start_speed"), v, 0.0, 200_000.0)?;
    }
    if axis.start_speed > axis.max_rate {
        bail!("{key}.start_speed: must not exceed {key}.max_rate");
    }
    if let Some((lo, hi)) = a.travel {
        axis.travel_min = nm(
            &format!("{key}.travel[0]"),
            lo,
            -MAX_LENGTH_MM,
            MAX_LENGTH_MM,
        )?;
        axis.travel_max = nm(
            &format!("{key}.travel[1]"),
            hi,
            -MAX_LENGTH_MM,
            MAX_LENGTH_MM,
        )?;
        if axis.travel_min > axis.travel_max {
            bail!("{key}.travel = [{lo}, {hi}]: min must not exceed max");
        }
    }
    if let Some(v) = a.invert_dir {
        axis.invert_dir = v;
    }
    Ok(())
}

fn mm(v: Nm) -> String {
    let sign = if v < 0 { "-" } else { "" };
    let a = v.unsigned_abs();
    let (int, frac) = (a / NM_PER_MM as u64, a % NM_PER_MM as u64);
    let frac = format!("{frac:06}");
    let frac = frac.trim_end_matches('0');
    if frac.is_empty() {
        format!("{sign}{int}.0")
    } else {
        format!("{sign}{int}.{frac}")
    }
}

fn mm_list(p: &[Nm]) -> String {
    let items: Vec<String> = p.iter().map(|&v| mm(v)).collect();
    format!("[{}]", items.join(", "))
}

/// Writes a setup as a commented setup file that [`SetupFile::parse`] reads back exactly.
pub fn to_toml(s: &Setup) -> String {
    let n = s.axis_count as usize;
    let mut t = String::new();
    let axes: Vec<String> = AXIS_LETTERS[..n]
        .iter()
        .map(|l| format!("\"{l}\""))
        .collect();
    let _ = writeln!(
        t,
        "# Gantry machine setup. Lengths in mm (degrees for A/B/C), speeds in mm/min,"
    );
    let _ = writeln!(
        t,
        "# accelerations in mm/s². See docs/settings.md for every key and its range."
    );
    let _ = writeln!(t, "axes = [{}]", axes.join(", "));
    for (i, a) in s.axes[..n].iter().enumerate() {
        let _ = writeln!(t, "\n[axis.{}]", AXIS_LETTERS[i]);
        let _ = writeln!(
            t,
            "steps_per = [{}, {}]   # motor steps : distance, an exact ratio",
            a.steps,
            mm(a.units_nm)
        );
        let _ = writeln!(t, "max_rate = {}         # rapid rate", mm(a.max_rate));
        let _ = writeln!(t, "accel = {}", mm(a.accel));
        let _ = writeln!(
            t,
            "start_speed = {}      # reachable instantly from rest",
            mm(a.start_speed)
        );
        let _ = writeln!(
            t,
            "travel = [{}, {}]     # soft limits, machine coordinates",
            mm(a.travel_min),
            mm(a.travel_max)
        );
        let _ = writeln!(t, "invert_dir = {}", a.invert_dir);
    }
    let p = &s.path;
    let _ = writeln!(t, "\n[path]");
    let _ = writeln!(t, "junction_deviation = {}", mm(p.junction_deviation));
    let _ = writeln!(
        t,
        "feed_shift = {}        # largest speed jump at a corner",
        mm(p.feed_shift)
    );
    let _ = writeln!(
        t,
        "chord_tolerance = {}   # arcs are cut into lines within this error",
        mm(p.chord_tolerance)
    );
    let _ = writeln!(
        t,
        "arc_segment_angle = {}.{:03}   # degrees, 0 = no limit",
        p.arc_segment_angle_mdeg / 1000,
        p.arc_segment_angle_mdeg % 1000
    );
    let _ = writeln!(
        t,
        "arc_max_segments = {}    # 0 = no limit",
        p.arc_max_segments
    );
    let g = &s.program;
    let _ = writeln!(t, "\n[program]");
    let _ = writeln!(
        t,
        "dialect = \"{}\"",
        match g.dialect {
            Dialect::Ngc => "ngc",
            Dialect::Gixa => "gixa",
        }
    );
    let _ = writeln!(
        t,
        "dwell_units = \"{}\"",
        match g.dwell_units {
            DwellUnits::Seconds => "seconds",
            DwellUnits::Milliseconds => "milliseconds",
        }
    );
    let _ = writeln!(t, "peck_clearance = {}", mm(g.peck_clearance));
    let _ = writeln!(t, "chip_break_retract = {}", mm(g.chip_break_retract));
    let codes: Vec<String> = g.user_mcodes.iter().map(|c| c.to_string()).collect();
    let _ = writeln!(t, "user_mcodes = [{}]", codes.join(", "));
    let _ = writeln!(t, "g28_home = {}", mm_list(&g.g28_home[..n]));
    let _ = writeln!(t, "g30_home = {}", mm_list(&g.g30_home[..n]));
    for tool in &g.tools {
        let _ = writeln!(
            t,
            "\n[[tool]]\nnumber = {}\nlength = {}\ndiameter = {}",
            tool.number,
            mm(tool.length),
            mm(tool.diameter)
        );
    }
    let _ = writeln!(t, "\n[work_offsets]");
    for (name, off) in WORK_SYSTEMS.iter().zip(&g.work_offsets) {
        let _ = writeln!(t, "\"{name}\" = {}", mm_list(&off[..n]));
    }
    let o = &s.operator;
    let _ = writeln!(t, "\n[operator]");
    let _ = writeln!(
        t,
        "resume_needs_cycle_start = {}",
        o.resume_needs_cycle_start
    );
    let _ = writeln!(t, "two_hand_start = {}", o.two_hand_start);
    let _ = writeln!(t, "fro_range = [{}, {}]", o.fro_low, o.fro_high);
    let _ = writeln!(t, "dry_run_feed = {}", mm(o.dry_run_feed));
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_round_trip_through_the_file() {
        let s = Setup::default();
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
    }

    #[test]
    fn values_convert_exactly_to_nanometres() {
        let s = SetupFile::parse(
            "axes = [\"X\", \"Y\", \"Z\", \"A\"]\n[axis.a]\nsteps_per = [4000, 360.0]\n[path]\nchord_tolerance = 0.002\n[[tool]]\nnumber = 3\nlength = 25.4001\n",
        )
        .unwrap();
        assert_eq!(s.axis_count, 4);
        assert_eq!((s.axes[3].steps, s.axes[3].units_nm), (4000, 360_000_000));
        assert_eq!(s.path.chord_tolerance, 2_000);
        assert_eq!(s.program.tools[0].length, 25_400_100);
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
    }

    #[test]
    fn errors_name_the_key_and_the_range() {
        let e = SetupFile::parse("[axis.X]\nmax_rate = -5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.X.max_rate = -5: must be between 1 and 200000"
        );
        let e = SetupFile::parse("[axis.A]\nmax_rate = 5\n").unwrap_err();
        assert!(
            e.to_string().starts_with("axis.A: not an axis in use"),
            "{e}"
        );
        let e = SetupFile::parse("[path]\nwobble = 1\n").unwrap_err();
        assert!(e.to_string().contains("unknown field `wobble`"), "{e}");
        let e = SetupFile::parse("[operator]\nfro_range = [150, 100]\n").unwrap_err();
        assert!(
            e.to_string().starts_with("operator.fro_range = [150, 100]"),
            "{e}"
        );
        let e = SetupFile::parse("[program]\nuser_mcodes = [3]\n").unwrap_err();
        assert!(e.to_string().contains("M3 is reserved"), "{e}");
    }
}

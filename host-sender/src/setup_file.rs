//! The machine setup file: a commented TOML in everyday units (mm, mm/min, mm/s²), read into the
//! core's exact [`Setup`] and written back out. Every validation error names the key and the range.
//!
//! Decimal values are converted to integer nanometres with rounding to the nearest nm; the file is
//! the only place where a float ever touches a setting.

use anyhow::{bail, Context};
use gantry_machine::controller::inputs::INPUT_NAMES;
use gantry_machine::gcode::RetractMode;
use gantry_machine::setup::{
    AxisSetup, Dialect, DwellUnits, Key, KeyName, ListCommand, McodeList, OrientSetup, Setup, Tool,
    ToolChangePosition, MAX_TOOLS, MAX_USER_MCODES, STARTUP_LINE_LEN, USER_OUTPUTS,
};
use gantry_machine::units::{Nm, AXIS_LETTERS, MAX_AXES, NM_PER_MM};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// A `[a, b]` value read as exactly two elements: the `toml` reader fills a pair from a longer
/// list and drops the rest silently (`travel = [-300.0, 300.0, 5]` was accepted).
fn exact_pair<'de, D, A, B>(d: D) -> Result<Option<(A, B)>, D::Error>
where
    D: serde::Deserializer<'de>,
    A: Deserialize<'de>,
    B: Deserialize<'de>,
{
    use serde::de::{Error, IgnoredAny, SeqAccess, Visitor};
    struct Pair<A, B>(std::marker::PhantomData<(A, B)>);
    impl<'de, A: Deserialize<'de>, B: Deserialize<'de>> Visitor<'de> for Pair<A, B> {
        type Value = (A, B);
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a list of exactly two values")
        }
        fn visit_seq<S: SeqAccess<'de>>(self, mut seq: S) -> Result<(A, B), S::Error> {
            let a = seq
                .next_element()?
                .ok_or_else(|| S::Error::invalid_length(0, &self))?;
            let b = seq
                .next_element()?
                .ok_or_else(|| S::Error::invalid_length(1, &self))?;
            let mut extra = 0;
            while seq.next_element::<IgnoredAny>()?.is_some() {
                extra += 1;
            }
            if extra > 0 {
                return Err(S::Error::invalid_length(2 + extra, &self));
            }
            Ok((a, b))
        }
    }
    d.deserialize_seq(Pair(std::marker::PhantomData)).map(Some)
}

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
    #[serde(default)]
    pub inputs: InputsFile,
    #[serde(default)]
    pub homing: HomingFile,
    #[serde(default)]
    pub jog: JogFile,
    #[serde(default)]
    pub spindle: SpindleFile,
    #[serde(default)]
    pub mcode: Vec<McodeFile>,
    #[serde(default)]
    pub link: LinkFile,
    #[serde(default)]
    pub drivers: DriversFile,
    #[serde(default)]
    pub grbl: GrblFile,
}

/// The grbl front end's stored settings (docs/grbl.md): `$10`, `$13`, `$N0`/`$N1`, the safety
/// door's spindle spin-up wait.
#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GrblFile {
    /// `$10`: bit 0 machine position (else work position), bit 1 buffer state (0-3).
    pub status_mask: Option<u8>,
    /// `$13`: positions and feeds in inches.
    pub report_inches: Option<bool>,
    /// `$N0`, `$N1`: at most two G-code lines run after the banner.
    pub startup_lines: Option<Vec<String>>,
    /// Seconds motion waits for the spindle to spin up after `~` closes the safety door (0-60,
    /// ms resolution; 0 = no wait).
    pub door_spin_up_s: Option<f64>,
    /// `M6` stops for a manual tool change (true), or answers grbl's `error:20` (false).
    pub m6_stop: Option<bool>,
}

/// Step and direction signal timing of the stepper drivers, in µs (see their datasheets).
#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DriversFile {
    /// Width of every step pulse, µs (1-50).
    pub step_pulse_us: Option<f64>,
    /// Least time from a direction change to the next step pulse, µs (0-50).
    pub dir_setup_us: Option<f64>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinkFile {
    /// Seconds a job held by host loss waits for the host before it is ended (0 = forever).
    pub host_lost_stop_s: Option<u16>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InputsFile {
    /// Inputs whose pin is active low, by name (`feed_hold`, `x_min`, `in20`, …).
    pub active_low: Option<Vec<String>>,
    pub debounce_ms: Option<u8>,
    /// Axes with a min / max limit switch.
    pub limits_min: Option<Vec<String>>,
    pub limits_max: Option<Vec<String>>,
    pub hard_limits: Option<bool>,
    pub feed_hold: Option<bool>,
    pub abort: Option<bool>,
    pub fro_pot: Option<bool>,
    pub adc_max: Option<u16>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HomingFile {
    pub required: Option<bool>,
    pub before_seek: Option<Vec<String>>,
    pub before_retract: Option<Vec<String>>,
    pub after_retract: Option<Vec<String>>,
    #[serde(default)]
    pub axis: BTreeMap<String, HomingAxisFile>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HomingAxisFile {
    pub priority: Option<u8>,
    /// `"low"` or `"high"`.
    pub seek: Option<String>,
    pub seek_rate: Option<f64>,
    pub locate_rate: Option<f64>,
    pub retract: Option<f64>,
    pub set_home: Option<bool>,
    pub home_position: Option<f64>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct JogFile {
    /// `[down/up axis, left/right axis]` per selector position; `"-"` = none.
    #[serde(default, deserialize_with = "exact_pair")]
    pub pair0: Option<(String, String)>,
    #[serde(default, deserialize_with = "exact_pair")]
    pub pair1: Option<(String, String)>,
    pub instant_speed: Option<f64>,
    pub nudge_distance: Option<f64>,
    pub nudge_interval_ms: Option<u16>,
    #[serde(default, deserialize_with = "exact_pair")]
    pub analog_axes: Option<(String, String)>,
    pub analog_deadband: Option<u16>,
    pub analog_max_speed: Option<f64>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleFile {
    #[serde(default, deserialize_with = "exact_pair")]
    pub rpm_range: Option<(u32, u32)>,
    #[serde(default, deserialize_with = "exact_pair")]
    pub pwm_range: Option<(u16, u16)>,
    /// Laser mode (docs/laser-plasma.md).
    #[serde(default)]
    pub laser: Option<bool>,
    /// G76's oriented stop: user output, done input, dwell or timeout (docs/settings.md).
    pub orient_output: Option<u8>,
    pub orient_done_input: Option<String>,
    pub orient_dwell_ms: Option<u16>,
    /// Plasma torch mode and its height control (docs/laser-plasma.md "Plasma").
    #[serde(default)]
    pub torch: Option<bool>,
    pub arc_ok_timeout_ms: Option<u16>,
    pub thc: Option<bool>,
    pub thc_rate: Option<f64>,
    pub thc_travel: Option<f64>,
    pub thc_anti_dive: Option<u8>,
    pub thc_delay_ms: Option<u16>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct McodeFile {
    pub code: u16,
    #[serde(default)]
    pub dry_run_disabled: bool,
    #[serde(default)]
    pub commands: Vec<String>,
}

/// The settings of a parsed setup, each with its key path: a value that is not a table, and an
/// array of tables (`[[tool]]`, `[[mcode]]`) as one setting (its entries are checked together).
fn setting_leaves(
    table: &toml::Table,
    path: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, toml::Value)>,
) {
    for (k, v) in table {
        path.push(k.clone());
        match v {
            toml::Value::Table(t) => setting_leaves(t, path, out),
            _ => out.push((path.clone(), v.clone())),
        }
        path.pop();
    }
}

/// Removes the setting at `path` from `table`.
fn remove_path(table: &mut toml::Table, path: &[String]) {
    match path {
        [] => {}
        [last] => {
            table.remove(last);
        }
        [first, rest @ ..] => {
            if let Some(toml::Value::Table(t)) = table.get_mut(first) {
                remove_path(t, rest);
            }
        }
    }
}

/// The 1-based line of byte `offset` in `text`.
fn line_at(text: &str, offset: usize) -> u32 {
    text[..offset.min(text.len())].matches('\n').count() as u32 + 1
}

/// The line that sets the dotted key `key` (`axis.X.max_rate`, `tool`), 0 if none is found:
/// under its `[section]` (or `[[section]]`) header, or as a dotted key.
fn line_of_key(text: &str, key: &str) -> u32 {
    let clean = |s: &str| s.replace(['"', '\'', ' '], "");
    let mut section = String::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if let Some(h) = line.strip_prefix('[') {
            section = clean(h.trim_start_matches('[').trim_end_matches(']'));
            if section == key {
                return i as u32 + 1;
            }
        } else if let Some((k, _)) = line.split_once('=') {
            let k = clean(k);
            let full = if section.is_empty() {
                k
            } else {
                format!("{section}.{k}")
            };
            if full.eq_ignore_ascii_case(key) {
                return i as u32 + 1;
            }
        }
    }
    0
}

fn input_name(bit: u8) -> String {
    INPUT_NAMES
        .get(bit as usize)
        .map_or_else(|| format!("in{bit}"), |n| n.to_string())
}

fn input_bit(key: &str, name: &str) -> anyhow::Result<u8> {
    if let Some(i) = INPUT_NAMES
        .iter()
        .position(|n| n.eq_ignore_ascii_case(name))
    {
        return Ok(i as u8);
    }
    match name.strip_prefix("in").and_then(|n| n.parse::<u8>().ok()) {
        Some(b) if b < 32 => Ok(b),
        _ => bail!("{key}: unknown input {name:?} (a name such as \"feed_hold\" or \"x_min\", or in0-in31)"),
    }
}

/// Axis letter → index among the axes in use (`"-"` → 255 = none).
fn axis_index(key: &str, name: &str, count: usize, allow_none: bool) -> anyhow::Result<u8> {
    if allow_none && name == "-" {
        return Ok(255);
    }
    AXIS_LETTERS[..count]
        .iter()
        .position(|l| name.eq_ignore_ascii_case(&l.to_string()))
        .map(|i| i as u8)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{key} = {name:?}: not an axis in use (axes in use: {:?}{})",
                &AXIS_LETTERS[..count],
                if allow_none {
                    ", or \"-\" for none"
                } else {
                    ""
                }
            )
        })
}

fn axis_mask(key: &str, names: &[String], count: usize) -> anyhow::Result<u8> {
    let mut m = 0;
    for n in names {
        m |= 1 << axis_index(key, n, count, false)?;
    }
    Ok(m)
}

fn axis_names(mask: u8, count: usize) -> String {
    let v: Vec<String> = (0..count)
        .filter(|i| mask & (1 << i) != 0)
        .map(|i| format!("\"{}\"", AXIS_LETTERS[i]))
        .collect();
    format!("[{}]", v.join(", "))
}

/// Parses a list command: `set N`, `clear N`, `dwell MS`, `wait INPUT high|low [TIMEOUT_MS]`,
/// `disable_limit_report`.
fn list_command(key: &str, text: &str) -> anyhow::Result<ListCommand> {
    let w: Vec<&str> = text.split_whitespace().collect();
    let num = |v: &str, max: u32| -> anyhow::Result<u32> {
        match v.parse::<u32>() {
            Ok(n) if n <= max => Ok(n),
            _ => bail!("{key}: {text:?}: {v:?} must be a whole number 0-{max}"),
        }
    };
    Ok(match w.as_slice() {
        ["set", n] => ListCommand::Set(num(n, u32::from(USER_OUTPUTS) - 1)? as u8),
        ["clear", n] => ListCommand::Clear(num(n, u32::from(USER_OUTPUTS) - 1)? as u8),
        ["dwell", ms] => ListCommand::DwellMs(num(ms, 65_535)? as u16),
        ["wait", input, level, rest @ ..] if rest.len() <= 1 => ListCommand::WaitInput {
            bit: input_bit(key, input)?,
            level: match *level {
                "high" => true,
                "low" => false,
                _ => bail!("{key}: {text:?}: the level must be \"high\" or \"low\""),
            },
            timeout_ms: match rest.first() {
                Some(t) => num(t, 65_535)? as u16,
                None => 0,
            },
        },
        ["disable_limit_report"] => ListCommand::DisableLimitReport,
        ["seek"] => ListCommand::Seek,
        _ => bail!(
            "{key}: {text:?}: expected \"set N\", \"clear N\", \"dwell MS\", \"wait INPUT high|low [TIMEOUT_MS]\", \"seek\" or \"disable_limit_report\""
        ),
    })
}

fn list_text(c: &ListCommand) -> String {
    match *c {
        ListCommand::Set(n) => format!("set {n}"),
        ListCommand::Clear(n) => format!("clear {n}"),
        ListCommand::DwellMs(ms) => format!("dwell {ms}"),
        ListCommand::WaitInput {
            bit,
            level,
            timeout_ms,
        } => format!(
            "wait {} {} {timeout_ms}",
            input_name(bit),
            if level { "high" } else { "low" }
        ),
        ListCommand::DisableLimitReport => "disable_limit_report".into(),
        ListCommand::Seek => "seek".into(),
    }
}

fn list_toml(list: &[ListCommand]) -> String {
    let v: Vec<String> = list
        .iter()
        .map(|c| format!("\"{}\"", list_text(c)))
        .collect();
    format!("[{}]", v.join(", "))
}

fn commands<const N: usize>(
    key: &str,
    texts: &[String],
) -> anyhow::Result<heapless::Vec<ListCommand, N>> {
    let mut v = heapless::Vec::new();
    for (i, t) in texts.iter().enumerate() {
        let c = list_command(&format!("{key}[{i}]"), t)?;
        if c == ListCommand::DisableLimitReport && i != 0 {
            bail!("{key}[{i}]: \"disable_limit_report\" must be the first entry of its list");
        }
        v.push(c)
            .map_err(|_| anyhow::anyhow!("{key}: at most {N} commands"))?;
    }
    Ok(v)
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AxisFile {
    /// `[steps, units]`: this many motor steps move the axis this many mm (or degrees).
    #[serde(default, deserialize_with = "exact_pair")]
    pub steps_per: Option<(u32, f64)>,
    pub max_rate: Option<f64>,
    pub accel: Option<f64>,
    pub start_speed: Option<f64>,
    /// `[min, max]` in machine coordinates.
    #[serde(default, deserialize_with = "exact_pair")]
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
    pub blend_tolerance: Option<f64>,
}

#[derive(Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramFile {
    pub dialect: Option<String>,
    pub dwell_units: Option<String>,
    pub peck_clearance: Option<f64>,
    pub chip_break_retract: Option<f64>,
    /// Canned-cycle retract when the program sets neither G98 nor G99: "g98" or "g99".
    pub default_retract: Option<String>,
    pub user_mcodes: Option<Vec<u16>>,
    pub g28_home: Option<Vec<f64>>,
    pub g30_home: Option<Vec<f64>>,
    /// Where M6 moves before the tool change: axis letter → machine position, mm (Z first).
    pub tool_change_position: Option<BTreeMap<String, f64>>,
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
    #[serde(default, deserialize_with = "exact_pair")]
    pub fro_range: Option<(u16, u16)>,
    pub dry_run_feed: Option<f64>,
}

/// Work coordinate system names in offset-table order.
pub const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// Largest length accepted anywhere in the file, mm (the core is exact to 1 nm over far more).
const MAX_LENGTH_MM: f64 = 100_000.0;

/// A file value of setting `key` (axis or tool `index`) in the core's integer units, checked
/// against the settings table's range by the core's own check (machine/src/setup/table.rs), so
/// the refusal is the one the board and grbl `$x=` give.
fn num(key: Key, index: usize, v: f64) -> anyhow::Result<i64> {
    let scaled = if v.is_nan() {
        i64::MIN
    } else {
        (v * key.row().unit.scale() as f64).round() as i64
    };
    key.check(index, scaled).map_err(anyhow::Error::new)?;
    Ok(scaled)
}

/// `text` as the index of one of `key`'s choices.
fn choice(key: Key, text: &str) -> anyhow::Result<usize> {
    let choices = key.text().choices;
    choices.iter().position(|c| *c == text).ok_or_else(|| {
        let names: Vec<String> = choices.iter().map(|c| format!("{c:?}")).collect();
        anyhow::anyhow!(
            "{} = {text:?}: must be {}",
            KeyName(key, 0),
            names.join(" or ")
        )
    })
}

/// Converts a value in mm to nm, checking `lo..=hi` (in mm) and naming `key` on error (the
/// positions of lists, which have no row of their own in the settings table).
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

/// `program.tool_change_position`: each axis named must be in use and its position inside that
/// axis's travel (the moves of every M6 would otherwise hit the soft limit).
fn tool_change_position(
    place: &BTreeMap<String, f64>,
    s: &Setup,
) -> anyhow::Result<ToolChangePosition> {
    let count = s.axis_count as usize;
    let mut out = ToolChangePosition::default();
    for (name, &v) in place {
        let key = format!("program.tool_change_position.{name}");
        let Some(i) = AXIS_LETTERS[..count]
            .iter()
            .position(|l| name.eq_ignore_ascii_case(&l.to_string()))
        else {
            bail!(
                "{key}: not an axis in use (axes in use: {:?})",
                &AXIS_LETTERS[..count]
            );
        };
        let a = &s.axes[i];
        let (lo, hi) = (a.travel_min, a.travel_max);
        let at = nm(&key, v, -MAX_LENGTH_MM, MAX_LENGTH_MM)?;
        if at < lo || at > hi {
            bail!(
                "{key} = {v}: outside the {} travel [{}, {}] (soft limits)",
                AXIS_LETTERS[i],
                mm_toml(lo),
                mm_toml(hi)
            );
        }
        out.axes |= 1 << i;
        out.at[i] = at;
    }
    Ok(out)
}

/// The largest setup file read, bytes (a full setup with every tool and list is about 10 KiB).
pub const SETUP_FILE_LIMIT: u64 = 1024 * 1024;

impl SetupFile {
    /// Reads and validates a setup file.
    pub fn load(path: &Path) -> anyhow::Result<Setup> {
        let text = Self::read_bounded(path)?;
        Self::parse(&text).with_context(|| format!("in setup file {}", path.display()))
    }

    /// [`SetupFile::load`] for a push to a board whose setup is `board`: the work offsets, the
    /// G28/G30 positions and the tool table are the board's (the operator set them with G10,
    /// G28.1, G30.1 and the board keeps them in flash) unless the file names them, so a push never
    /// clears them by accident (docs/controller.md "Work offsets").
    pub fn load_for_push(path: &Path, board: &Setup) -> anyhow::Result<Setup> {
        Self::load_keeping(path, board).map(|(s, _)| s)
    }

    /// [`SetupFile::load_for_push`], and what of `stored` it kept that holds anything (for a
    /// message: "work offsets G54 G55", "G28 position", "tool table (2 tools)"); `gantry emulate
    /// --setup F --state S` starts from it with S's setup as `stored`.
    pub fn load_keeping(path: &Path, stored: &Setup) -> anyhow::Result<(Setup, Vec<String>)> {
        let text = Self::read_bounded(path)?;
        Self::parse_keeping(&text, stored)
            .with_context(|| format!("in setup file {}", path.display()))
    }

    /// [`SetupFile::load_for_push`] on setup text (the console's editor; the one push path,
    /// `crate::session::Session::push_setup_text`).
    pub fn parse_for_push(text: &str, board: &Setup) -> anyhow::Result<Setup> {
        Self::parse_keeping(text, board).map(|(s, _)| s)
    }

    /// [`SetupFile::load_keeping`] on setup text. An empty setup (no setting at all: an empty
    /// editor, only comments) is refused: pushed, it would set every default (travel, steps per
    /// mm, switch polarity, homing) on the machine.
    pub fn parse_keeping(text: &str, stored: &Setup) -> anyhow::Result<(Setup, Vec<String>)> {
        let table: toml::Table = toml::from_str(text)?;
        anyhow::ensure!(
            !table.is_empty(),
            "an empty setup (no setting in it): nothing was pushed (`gantry setup pull` or the \
             console's \"Show the board's\" gives the board's setup to edit)"
        );
        let file: SetupFile = toml::from_str(text)?;
        let (work, g28, g30, tools) = (
            !file.work_offsets.is_empty(),
            file.program.g28_home.is_some(),
            file.program.g30_home.is_some(),
            !file.tool.is_empty(),
        );
        let mut s = file.into_setup()?;
        let (from, to) = (&stored.program, &mut s.program);
        let mut kept = Vec::new();
        if !work {
            to.work_offsets = from.work_offsets;
            let set: Vec<&str> = WORK_SYSTEMS
                .iter()
                .zip(&from.work_offsets)
                .filter(|(_, o)| o.iter().any(|v| *v != 0))
                .map(|(n, _)| *n)
                .collect();
            if !set.is_empty() {
                kept.push(format!("work offsets {}", set.join(" ")));
            }
        }
        for (named, name, at, stored_at) in [
            (g28, "G28", &mut to.g28_home, &from.g28_home),
            (g30, "G30", &mut to.g30_home, &from.g30_home),
        ] {
            if !named {
                *at = *stored_at;
                if stored_at.iter().any(|v| *v != 0) {
                    kept.push(format!("{name} position"));
                }
            }
        }
        if !tools {
            to.tools = from.tools.clone();
            match from.tools.len() {
                0 => {}
                1 => kept.push("tool table (1 tool)".into()),
                n => kept.push(format!("tool table ({n} tools)")),
            }
        }
        Ok((s, kept))
    }

    /// The file's text, refused beyond [`SETUP_FILE_LIMIT`].
    pub fn read_bounded(path: &Path) -> anyhow::Result<String> {
        use std::io::Read;
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(SETUP_FILE_LIMIT + 1).read_to_string(&mut text))
            .with_context(|| format!("cannot read setup file {}", path.display()))?;
        anyhow::ensure!(
            text.len() as u64 <= SETUP_FILE_LIMIT,
            "setup file {}: longer than {} KiB, not a setup file (a full setup is about 10 KiB)",
            path.display(),
            SETUP_FILE_LIMIT / 1024
        );
        Ok(text)
    }

    /// Parses and validates setup text.
    pub fn parse(text: &str) -> anyhow::Result<Setup> {
        let file: SetupFile = toml::from_str(text)?;
        file.into_setup()
    }

    /// Every error of setup text (`gantry setup check`), each with its line (0: unknown) and a
    /// message naming its key: each setting is validated on its own (with `axes`, which decides
    /// what the others may name), so one bad key does not hide the next; the rules between
    /// settings are checked once every setting is valid on its own. Empty: the text is valid.
    pub fn check_all(text: &str) -> Vec<(u32, String)> {
        let table: toml::Table = match toml::from_str(text) {
            Ok(t) => t,
            Err(e) => {
                let line = e.span().map_or(0, |r| line_at(text, r.start));
                return vec![(line, e.message().trim().to_owned())];
            }
        };
        let mut leaves = Vec::new();
        setting_leaves(&table, &mut Vec::new(), &mut leaves);
        let mut errors = Vec::new();
        let mut valid = table.clone();
        for (path, value) in leaves {
            let mut t = toml::Table::new();
            if let Some(axes) = table.get("axes") {
                t.insert("axes".into(), axes.clone());
            }
            let mut at = &mut t;
            for seg in &path[..path.len() - 1] {
                at = at
                    .entry(seg.clone())
                    .or_insert_with(|| toml::Value::Table(Default::default()))
                    .as_table_mut()
                    .expect("a table on the way to a setting");
            }
            at.insert(path[path.len() - 1].clone(), value.clone());
            let applied = toml::Value::Table(t)
                .try_into::<SetupFile>()
                .map_err(anyhow::Error::from)
                .and_then(|f| f.apply());
            if let Err(e) = applied {
                remove_path(&mut valid, &path);
                let dotted = path.join(".");
                // (toml's messages run over lines: one line each here.)
                let msg = format!("{e:#}")
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" ");
                let msg = if msg.contains(path[path.len() - 1].as_str()) {
                    msg
                } else {
                    format!("{dotted}: {msg}")
                };
                errors.push((line_of_key(text, &dotted), msg));
            }
        }
        // The rules between settings, on the settings that are valid on their own.
        let whole = toml::Value::Table(valid)
            .try_into::<SetupFile>()
            .map_err(anyhow::Error::from)
            .and_then(|f| f.into_setup());
        if let Err(e) = whole {
            let msg = format!("{e:#}");
            // The key the rule names first (`spindle.rpm_range[0] …`), for its line.
            let key = msg
                .split([':', ' ', '=', '['])
                .next()
                .unwrap_or_default()
                .to_owned();
            errors.push((line_of_key(text, &key), msg));
        }
        // In file order; one without a line last.
        errors.sort_by_key(|&(line, _)| if line == 0 { u32::MAX } else { line });
        errors
    }

    /// Applies the file's values over the defaults, validating each one, then the rules
    /// between settings.
    pub fn into_setup(self) -> anyhow::Result<Setup> {
        let s = self.apply()?;
        // The rules between settings (start speed, pairs, step rate…): the core's own check.
        s.validate().map_err(anyhow::Error::new)?;
        Ok(s)
    }

    /// [`SetupFile::into_setup`] without the rules between settings.
    fn apply(self) -> anyhow::Result<Setup> {
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
            apply_axis(i, a, &mut s.axes[i])?;
        }
        let p = &self.path;
        if let Some(v) = p.junction_deviation {
            s.path.junction_deviation = num(Key::JunctionDeviation, 0, v)?;
        }
        if let Some(v) = p.feed_shift {
            s.path.feed_shift = num(Key::FeedShift, 0, v)?;
        }
        if let Some(v) = p.chord_tolerance {
            s.path.chord_tolerance = num(Key::ChordTolerance, 0, v)?;
        }
        if let Some(v) = p.arc_segment_angle {
            s.path.arc_segment_angle_mdeg = num(Key::ArcSegmentAngle, 0, v)? as u32;
        }
        if let Some(v) = p.arc_max_segments {
            s.path.arc_max_segments = v;
        }
        if let Some(v) = p.blend_tolerance {
            s.path.blend_tolerance = num(Key::BlendTolerance, 0, v)?;
        }
        let g = &self.program;
        if let Some(d) = &g.dialect {
            s.program.dialect = match choice(Key::Dialect, d)? {
                0 => Dialect::Rs274,
                _ => Dialect::Gixa,
            };
        }
        if let Some(d) = &g.dwell_units {
            s.program.dwell_units = match choice(Key::DwellUnits, d)? {
                0 => DwellUnits::Seconds,
                _ => DwellUnits::FanucIntegerMillis,
            };
        }
        if let Some(v) = g.peck_clearance {
            s.program.peck_clearance = num(Key::PeckClearance, 0, v)?;
        }
        if let Some(v) = g.chip_break_retract {
            s.program.chip_break_retract = num(Key::ChipBreakRetract, 0, v)?;
        }
        if let Some(r) = &g.default_retract {
            s.program.default_retract = match choice(Key::DefaultRetract, &r.to_ascii_lowercase())?
            {
                0 => RetractMode::InitialLevel,
                _ => RetractMode::RPlane,
            };
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
        if let Some(place) = &g.tool_change_position {
            s.program.tool_change_position = tool_change_position(place, &s)?;
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
                length: num(Key::ToolLength, i, t.length)?,
                diameter: num(Key::ToolDiameter, i, t.diameter)?,
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
            s.operator.fro_low = num(Key::FroLow, 0, lo.into())? as u16;
            s.operator.fro_high = num(Key::FroHigh, 0, hi.into())? as u16;
        }
        if let Some(v) = o.dry_run_feed {
            s.operator.dry_run_feed = num(Key::DryRunFeed, 0, v)?;
        }
        self.apply_controller(&mut s)?;
        if let Some(v) = self.link.host_lost_stop_s {
            s.link.host_lost_stop_s = v;
        }
        self.apply_drivers(&mut s)?;
        self.apply_grbl(&mut s)?;
        Ok(s)
    }

    /// The `[grbl]` section: startup lines are stored as grbl stores them (upper case, no
    /// blanks) and checked as the board checks `$N0=` (parsed as a block, no `$` command).
    fn apply_grbl(&self, s: &mut Setup) -> anyhow::Result<()> {
        let g = &self.grbl;
        if let Some(v) = g.status_mask {
            s.grbl.status_mask = num(Key::StatusMask, 0, v.into())? as u8;
        }
        if let Some(v) = g.report_inches {
            s.grbl.inches = v;
        }
        if let Some(v) = g.m6_stop {
            s.grbl.m6_stop = v;
        }
        if let Some(v) = g.door_spin_up_s {
            s.grbl.door_spin_up_ms = num(Key::DoorSpinUp, 0, v)? as u16;
        }
        if let Some(lines) = &g.startup_lines {
            if lines.len() > 2 {
                bail!("grbl.startup_lines: at most 2 lines ($N0, $N1)");
            }
            for (i, line) in lines.iter().enumerate() {
                let text: String = line
                    .chars()
                    .filter(|c| !c.is_ascii_whitespace())
                    .map(|c| c.to_ascii_uppercase())
                    .collect();
                if !text.bytes().all(|c| (b' '..=b'~').contains(&c)) || text.starts_with('$') {
                    bail!(
                        "grbl.startup_lines[{i}] = {line:?}: printable ASCII G-code, no $ command"
                    );
                }
                let mut lexer = gantry_machine::gcode::lexer::Lexer::new(text.as_bytes(), true);
                lexer.start();
                let cfg = s.interp_config();
                if let Err((e, _)) = gantry_machine::gcode::block::parse_block(&mut lexer, &cfg) {
                    bail!(
                        "grbl.startup_lines[{i}] = {line:?}: error {}: {e:?}",
                        e.number()
                    );
                }
                s.grbl.startup[i] = heapless::String::try_from(text.as_str()).map_err(|_| {
                    anyhow::anyhow!(
                        "grbl.startup_lines[{i}]: at most {STARTUP_LINE_LEN} characters without blanks"
                    )
                })?;
            }
        }
        Ok(())
    }

    /// The `[drivers]` section (the step rate each axis's max rate needs is checked with the
    /// rest by [`Setup::validate`]).
    fn apply_drivers(&self, s: &mut Setup) -> anyhow::Result<()> {
        let d = &self.drivers;
        if let Some(v) = d.step_pulse_us {
            s.drivers.step_pulse_ns = num(Key::StepPulse, 0, v)? as u32;
        }
        if let Some(v) = d.dir_setup_us {
            s.drivers.dir_setup_ns = num(Key::DirSetup, 0, v)? as u32;
        }
        Ok(())
    }

    /// The `[inputs]`, `[homing]`, `[jog]`, `[spindle]` and `[[mcode]]` sections.
    fn apply_controller(&self, s: &mut Setup) -> anyhow::Result<()> {
        let count = s.axis_count as usize;
        let i = &self.inputs;
        if let Some(names) = &i.active_low {
            s.inputs.invert = 0;
            for n in names {
                s.inputs.invert |= 1 << input_bit("inputs.active_low", n)?;
            }
        }
        if let Some(v) = i.debounce_ms {
            s.inputs.debounce_ms = num(Key::DebounceMs, 0, v.into())? as u8;
        }
        if let Some(v) = &i.limits_min {
            s.inputs.limit_min = axis_mask("inputs.limits_min", v, count)?;
        }
        if let Some(v) = &i.limits_max {
            s.inputs.limit_max = axis_mask("inputs.limits_max", v, count)?;
        }
        if let Some(v) = i.hard_limits {
            s.inputs.hard_limits = v;
        }
        if let Some(v) = i.feed_hold {
            s.inputs.feed_hold = v;
        }
        if let Some(v) = i.abort {
            s.inputs.abort = v;
        }
        if let Some(v) = i.fro_pot {
            s.inputs.fro_pot = v;
        }
        if let Some(v) = i.adc_max {
            s.inputs.adc_max = num(Key::AdcMax, 0, v.into())? as u16;
        }
        let h = &self.homing;
        if let Some(v) = h.required {
            s.homing.required = v;
        }
        if let Some(v) = &h.before_seek {
            s.homing.before_seek = commands("homing.before_seek", v)?;
        }
        if let Some(v) = &h.before_retract {
            s.homing.before_retract = commands("homing.before_retract", v)?;
        }
        if let Some(v) = &h.after_retract {
            s.homing.after_retract = commands("homing.after_retract", v)?;
        }
        for (name, a) in &h.axis {
            let key = format!("homing.axis.{name}");
            let idx = axis_index(&key, name, count, false)? as usize;
            let ha = &mut s.homing.axes[idx];
            if let Some(v) = a.priority {
                ha.priority = v;
            }
            if let Some(v) = &a.seek {
                ha.seek_low = choice(Key::Seek, v).map_err(|_| {
                    anyhow::anyhow!("{key}.seek = {v:?}: must be \"low\" or \"high\"")
                })? == 1;
            }
            if let Some(v) = a.seek_rate {
                ha.seek_rate = num(Key::SeekRate, idx, v)?;
            }
            if let Some(v) = a.locate_rate {
                ha.locate_rate = num(Key::LocateRate, idx, v)?;
            }
            if let Some(v) = a.retract {
                ha.retract = num(Key::Retract, idx, v)?;
            }
            if let Some(v) = a.set_home {
                ha.set_home = v;
            }
            if let Some(v) = a.home_position {
                ha.home_position = num(Key::HomePosition, idx, v)?;
            }
        }
        let j = &self.jog;
        for (k, pair) in [(0, &j.pair0), (1, &j.pair1)] {
            if let Some((a, b)) = pair {
                let key = format!("jog.pair{k}");
                s.jog.pairs[k] = [
                    axis_index(&key, a, count, true)?,
                    axis_index(&key, b, count, true)?,
                ];
            }
        }
        if let Some(v) = j.instant_speed {
            s.jog.instant_speed = num(Key::InstantSpeed, 0, v)?;
        }
        if let Some(v) = j.nudge_distance {
            s.jog.nudge_distance = num(Key::NudgeDistance, 0, v)?;
        }
        if let Some(v) = j.nudge_interval_ms {
            s.jog.nudge_interval_ms = num(Key::NudgeIntervalMs, 0, v.into())? as u16;
        }
        if let Some((a, b)) = &j.analog_axes {
            s.jog.analog_axes = [
                axis_index("jog.analog_axes", a, count, true)?,
                axis_index("jog.analog_axes", b, count, true)?,
            ];
        }
        if let Some(v) = j.analog_deadband {
            s.jog.analog_deadband = num(Key::AnalogDeadband, 0, v.into())? as u16;
        }
        if let Some(v) = j.analog_max_speed {
            s.jog.analog_max_speed = num(Key::AnalogMaxSpeed, 0, v)?;
        }
        if let Some((lo, hi)) = self.spindle.rpm_range {
            s.outputs.spindle_min_rpm = num(Key::RpmMin, 0, lo.into())? as u32;
            s.outputs.spindle_max_rpm = num(Key::RpmMax, 0, hi.into())? as u32;
        }
        if let Some((lo, hi)) = self.spindle.pwm_range {
            s.outputs.pwm_min = num(Key::PwmMin, 0, lo.into())? as u16;
            s.outputs.pwm_max = num(Key::PwmMax, 0, hi.into())? as u16;
        }
        if let Some(v) = self.spindle.laser {
            s.outputs.laser = v;
        }
        let o = &mut s.outputs.orient;
        if let Some(n) = self.spindle.orient_output {
            if n >= USER_OUTPUTS {
                bail!(
                    "spindle.orient_output = {n}: a user output 0-{}",
                    USER_OUTPUTS - 1
                );
            }
            o.output = n;
        }
        if let Some(name) = &self.spindle.orient_done_input {
            o.done_input = input_bit("spindle.orient_done_input", name)?;
        }
        if let Some(ms) = self.spindle.orient_dwell_ms {
            o.dwell_ms = ms;
        }
        if !o.present() && (o.done_input != OrientSetup::NONE || o.dwell_ms != 0) {
            bail!("spindle.orient_done_input/orient_dwell_ms: set spindle.orient_output first");
        }
        let (sp, t) = (&self.spindle, &mut s.outputs.torch);
        if let Some(v) = sp.torch {
            t.on = v;
        }
        if let Some(v) = sp.arc_ok_timeout_ms {
            t.arc_ok_timeout_ms = num(Key::ArcOkTimeoutMs, 0, v.into())? as u16;
        }
        if let Some(v) = sp.thc {
            t.thc = v;
        }
        if let Some(v) = sp.thc_rate {
            t.thc_rate = num(Key::ThcRate, 0, v)?;
        }
        if let Some(v) = sp.thc_travel {
            t.thc_travel = num(Key::ThcTravel, 0, v)?;
        }
        if let Some(v) = sp.thc_anti_dive {
            t.thc_anti_dive = num(Key::ThcAntiDive, 0, v.into())? as u8;
        }
        if let Some(v) = sp.thc_delay_ms {
            t.thc_delay_ms = num(Key::ThcDelayMs, 0, v.into())? as u16;
        }
        for (k, m) in self.mcode.iter().enumerate() {
            let key = format!("mcode[{k}]");
            if !s.program.user_mcodes.contains(&m.code) {
                bail!(
                    "{key}.code = {}: not in program.user_mcodes (define the M code there first)",
                    m.code
                );
            }
            if s.outputs.mcode_lists.iter().any(|l| l.code == m.code) {
                bail!("{key}.code = {}: list defined twice", m.code);
            }
            let list = McodeList {
                code: m.code,
                dry_run_disabled: m.dry_run_disabled,
                commands: commands(&format!("{key}.commands"), &m.commands)?,
            };
            s.outputs.mcode_lists.push(list).map_err(|_| {
                anyhow::anyhow!(
                    "mcode: at most {} lists",
                    gantry_machine::setup::MAX_MCODE_LISTS
                )
            })?;
        }
        Ok(())
    }
}

/// One `[axis.X]` table (axis `i`); start speed and travel order are checked with the rest by
/// [`Setup::validate`].
fn apply_axis(i: usize, a: &AxisFile, axis: &mut AxisSetup) -> anyhow::Result<()> {
    if let Some((steps, units)) = a.steps_per {
        axis.steps = num(Key::Steps, i, steps.into())? as u32;
        axis.units_nm = num(Key::StepUnits, i, units)?;
    }
    if let Some(v) = a.max_rate {
        axis.max_rate = num(Key::MaxRate, i, v)?;
    }
    if let Some(v) = a.accel {
        axis.accel = num(Key::Accel, i, v)?;
    }
    if let Some(v) = a.start_speed {
        axis.start_speed = num(Key::StartSpeed, i, v)?;
    }
    if let Some((lo, hi)) = a.travel {
        axis.travel_min = num(Key::TravelMin, i, lo)?;
        axis.travel_max = num(Key::TravelMax, i, hi)?;
    }
    if let Some(v) = a.invert_dir {
        axis.invert_dir = v;
    }
    Ok(())
}

/// Millimetres (from nm) as a TOML float: up to 6 decimals, at least one (`5.0`).
fn mm_toml(v: Nm) -> String {
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

/// Nanoseconds as µs with exact decimals.
fn us_text(ns: u32) -> String {
    let frac = format!("{:03}", ns % 1000);
    let frac = frac.trim_end_matches('0');
    if frac.is_empty() {
        format!("{}.0", ns / 1000)
    } else {
        format!("{}.{frac}", ns / 1000)
    }
}

fn mm_list(p: &[Nm]) -> String {
    let items: Vec<String> = p.iter().map(|&v| mm_toml(v)).collect();
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
            mm_toml(a.units_nm)
        );
        let _ = writeln!(t, "max_rate = {}         # rapid rate", mm_toml(a.max_rate));
        let _ = writeln!(t, "accel = {}", mm_toml(a.accel));
        let _ = writeln!(
            t,
            "start_speed = {}      # reachable instantly from rest",
            mm_toml(a.start_speed)
        );
        let _ = writeln!(
            t,
            "travel = [{}, {}]     # soft limits, machine coordinates",
            mm_toml(a.travel_min),
            mm_toml(a.travel_max)
        );
        let _ = writeln!(t, "invert_dir = {}", a.invert_dir);
    }
    let p = &s.path;
    let _ = writeln!(t, "\n[path]");
    let _ = writeln!(t, "junction_deviation = {}", mm_toml(p.junction_deviation));
    let _ = writeln!(
        t,
        "feed_shift = {}        # largest speed jump at a corner",
        mm_toml(p.feed_shift)
    );
    let _ = writeln!(
        t,
        "chord_tolerance = {}   # arcs are cut into lines within this error",
        mm_toml(p.chord_tolerance)
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
    let _ = writeln!(
        t,
        "blend_tolerance = {}   # G64 without P: path tolerance, 0 = off",
        mm_toml(p.blend_tolerance)
    );
    let g = &s.program;
    let _ = writeln!(t, "\n[program]");
    let _ = writeln!(
        t,
        "dialect = \"{}\"",
        match g.dialect {
            Dialect::Rs274 => "ngc",
            Dialect::Gixa => "gixa",
        }
    );
    let _ = writeln!(
        t,
        "dwell_units = \"{}\"",
        match g.dwell_units {
            DwellUnits::Seconds => "seconds",
            DwellUnits::FanucIntegerMillis => "milliseconds",
        }
    );
    let _ = writeln!(t, "peck_clearance = {}", mm_toml(g.peck_clearance));
    let _ = writeln!(t, "chip_break_retract = {}", mm_toml(g.chip_break_retract));
    let _ = writeln!(
        t,
        "default_retract = \"{}\"",
        match g.default_retract {
            RetractMode::InitialLevel => "g98",
            RetractMode::RPlane => "g99",
        }
    );
    let codes: Vec<String> = g.user_mcodes.iter().map(|c| c.to_string()).collect();
    let _ = writeln!(t, "user_mcodes = [{}]", codes.join(", "));
    let _ = writeln!(t, "g28_home = {}", mm_list(&g.g28_home[..n]));
    let _ = writeln!(t, "g30_home = {}", mm_list(&g.g30_home[..n]));
    let place = &g.tool_change_position;
    let set: Vec<String> = (0..n)
        .filter(|&i| place.axes & (1 << i) != 0)
        .map(|i| format!("{} = {}", AXIS_LETTERS[i], mm_toml(place.at[i])))
        .collect();
    if set.is_empty() {
        let _ = writeln!(
            t,
            "# tool_change_position = {{ Z = 0.0 }}  # M6 moves there first (machine coordinates, Z first)"
        );
    } else {
        let _ = writeln!(
            t,
            "tool_change_position = {{ {} }}  # M6 moves there first (machine coordinates, Z first)",
            set.join(", ")
        );
    }
    for tool in &g.tools {
        let _ = writeln!(
            t,
            "\n[[tool]]\nnumber = {}\nlength = {}\ndiameter = {}",
            tool.number,
            mm_toml(tool.length),
            mm_toml(tool.diameter)
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
    let _ = writeln!(t, "dry_run_feed = {}", mm_toml(o.dry_run_feed));
    controller_toml(s, &mut t);
    let _ = writeln!(t, "\n[link]");
    let _ = writeln!(
        t,
        "host_lost_stop_s = {}   # a job standing still with the host gone ends (alarm 20) after this; 0 = never",
        s.link.host_lost_stop_s
    );
    let _ = writeln!(t, "\n[drivers]");
    let _ = writeln!(
        t,
        "step_pulse_us = {}   # step pulse width (datasheet minimum: DM542 2.5, DRV8825 1.9)",
        us_text(s.drivers.step_pulse_ns)
    );
    let _ = writeln!(
        t,
        "dir_setup_us = {}   # direction change to next step pulse, at least (DM542 5)",
        us_text(s.drivers.dir_setup_ns)
    );
    let g = &s.grbl;
    let _ = writeln!(t, "\n[grbl]");
    let _ = writeln!(
        t,
        "status_mask = {}   # $10: 1 machine position (0 work position), +2 buffer state",
        g.status_mask
    );
    let _ = writeln!(t, "report_inches = {}   # $13", g.inches);
    let _ = writeln!(
        t,
        "startup_lines = [{:?}, {:?}]   # $N0, $N1: run after the banner unless in alarm",
        g.startup[0].as_str(),
        g.startup[1].as_str()
    );
    let _ = writeln!(
        t,
        "door_spin_up_s = {}   # after ~ closes the safety door, the spindle spins up this long before motion; 0 = no wait",
        us_text(u32::from(g.door_spin_up_ms)) // thousandths, as for µs
    );
    let _ = writeln!(
        t,
        "m6_stop = {}   # M6 stops for a manual tool change; false: grbl's error:20",
        g.m6_stop
    );
    t
}

fn controller_toml(s: &Setup, t: &mut String) {
    let n = s.axis_count as usize;
    let i = &s.inputs;
    let _ = writeln!(t, "\n[inputs]");
    let low: Vec<String> = (0..32u8)
        .filter(|b| i.invert & (1 << b) != 0)
        .map(|b| format!("\"{}\"", input_name(b)))
        .collect();
    let _ = writeln!(
        t,
        "active_low = [{}]   # active while the switch is open: the normally-closed switches",
        low.join(", ")
    );
    let _ = writeln!(t, "debounce_ms = {}", i.debounce_ms);
    let _ = writeln!(t, "limits_min = {}", axis_names(i.limit_min, n));
    let _ = writeln!(t, "limits_max = {}", axis_names(i.limit_max, n));
    let _ = writeln!(t, "hard_limits = {}", i.hard_limits);
    let _ = writeln!(t, "feed_hold = {}", i.feed_hold);
    let _ = writeln!(t, "abort = {}", i.abort);
    let _ = writeln!(t, "fro_pot = {}", i.fro_pot);
    let _ = writeln!(t, "adc_max = {}", i.adc_max);
    let h = &s.homing;
    let _ = writeln!(t, "\n[homing]");
    let _ = writeln!(t, "required = {}", h.required);
    let _ = writeln!(t, "before_seek = {}", list_toml(&h.before_seek));
    let _ = writeln!(t, "before_retract = {}", list_toml(&h.before_retract));
    let _ = writeln!(t, "after_retract = {}", list_toml(&h.after_retract));
    for (k, a) in h.axes[..n].iter().enumerate() {
        let _ = writeln!(t, "\n[homing.axis.{}]", AXIS_LETTERS[k]);
        let _ = writeln!(t, "priority = {}   # 0 = not homed", a.priority);
        let _ = writeln!(t, "seek = \"{}\"", if a.seek_low { "low" } else { "high" });
        let _ = writeln!(t, "seek_rate = {}", mm_toml(a.seek_rate));
        let _ = writeln!(t, "locate_rate = {}", mm_toml(a.locate_rate));
        let _ = writeln!(t, "retract = {}", mm_toml(a.retract));
        let _ = writeln!(t, "set_home = {}", a.set_home);
        let _ = writeln!(t, "home_position = {}", mm_toml(a.home_position));
    }
    let j = &s.jog;
    let name = |a: u8| {
        if (a as usize) < n {
            AXIS_LETTERS[a as usize].to_string()
        } else {
            "-".to_string()
        }
    };
    let _ = writeln!(t, "\n[jog]");
    for (k, p) in j.pairs.iter().enumerate() {
        let _ = writeln!(
            t,
            "pair{k} = [\"{}\", \"{}\"]   # [down/up, left/right]",
            name(p[0]),
            name(p[1])
        );
    }
    let _ = writeln!(t, "instant_speed = {}", mm_toml(j.instant_speed));
    let _ = writeln!(t, "nudge_distance = {}", mm_toml(j.nudge_distance));
    let _ = writeln!(t, "nudge_interval_ms = {}", j.nudge_interval_ms);
    let _ = writeln!(
        t,
        "analog_axes = [\"{}\", \"{}\"]",
        name(j.analog_axes[0]),
        name(j.analog_axes[1])
    );
    let _ = writeln!(t, "analog_deadband = {}", j.analog_deadband);
    let _ = writeln!(t, "analog_max_speed = {}", mm_toml(j.analog_max_speed));
    let o = &s.outputs;
    let _ = writeln!(t, "\n[spindle]");
    let _ = writeln!(
        t,
        "rpm_range = [{}, {}]",
        o.spindle_min_rpm, o.spindle_max_rpm
    );
    let _ = writeln!(t, "pwm_range = [{}, {}]", o.pwm_min, o.pwm_max);
    let _ = writeln!(
        t,
        "laser = {}   # laser mode: S travels with each move, M4 power follows the speed",
        o.laser
    );
    if o.orient.present() {
        let _ = writeln!(
            t,
            "orient_output = {}   # G76's oriented stop",
            o.orient.output
        );
        if o.orient.done_input != OrientSetup::NONE {
            let _ = writeln!(
                t,
                "orient_done_input = \"{}\"",
                input_name(o.orient.done_input)
            );
        }
        let _ = writeln!(t, "orient_dwell_ms = {}", o.orient.dwell_ms);
    }
    let p = &o.torch;
    let _ = writeln!(
        t,
        "torch = {}   # plasma: M3 waits for arc-OK, THC from the up/down inputs\n\
         arc_ok_timeout_ms = {}\nthc = {}\nthc_rate = {}\nthc_travel = {}\n\
         thc_anti_dive = {}\nthc_delay_ms = {}",
        p.on,
        p.arc_ok_timeout_ms,
        p.thc,
        mm_toml(p.thc_rate),
        mm_toml(p.thc_travel),
        p.thc_anti_dive,
        p.thc_delay_ms
    );
    for l in &o.mcode_lists {
        let _ = writeln!(
            t,
            "\n[[mcode]]\ncode = {}\ndry_run_disabled = {}\ncommands = {}{}",
            l.code,
            l.dry_run_disabled,
            list_toml(&l.commands),
            if l.on_the_fly().is_some() {
                "   # one output command: switched on the fly, the motion does not stop"
            } else {
                "   # runs at rest"
            }
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_takes_exactly_two_values() {
        for text in [
            "[axis.X]\nsteps_per = [3200, 5.0, 7]\n",
            "[axis.X]\ntravel = [-300.0, 300.0, 5.0]\n",
            "[axis.X]\ntravel = [-300.0]\n",
            "[operator]\nfro_range = [10, 200, 300]\n",
            "[jog]\npair0 = [\"Y\", \"X\", \"Z\"]\n",
        ] {
            let e = format!("{:#}", SetupFile::parse(text).unwrap_err());
            assert!(
                e.contains("expected a list of exactly two values"),
                "{text}: {e}"
            );
        }
        let s = SetupFile::parse("[axis.X]\ntravel = [-250.0, 250.0]\n").unwrap();
        assert_eq!(
            (s.axes[0].travel_min, s.axes[0].travel_max),
            (-250 * NM_PER_MM, 250 * NM_PER_MM)
        );
    }

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
    fn the_tool_change_position_reads_writes_and_stays_inside_the_travel() {
        let s = SetupFile::parse(
            "[axis.Z]\ntravel = [-80.0, 20.0]\n[program]\ntool_change_position = { x = -12.5, Z = 20.0 }\n",
        )
        .unwrap();
        let place = s.program.tool_change_position;
        assert_eq!(place.axes, 0b101);
        assert_eq!(place.at, [-12_500_000, 0, 20_000_000, 0, 0, 0]);
        let text = to_toml(&s);
        assert!(
            text.contains("tool_change_position = { X = -12.5, Z = 20.0 }"),
            "{text}"
        );
        assert_eq!(SetupFile::parse(&text).unwrap(), s);
        let e = SetupFile::parse(
            "[axis.Z]\ntravel = [-80.0, 20.0]\n[program]\ntool_change_position = { Z = 25.0 }\n",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.tool_change_position.Z = 25: outside the Z travel [-80.0, 20.0] (soft limits)"
        );
        let e = SetupFile::parse("[program]\ntool_change_position = { A = 1.0 }\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.tool_change_position.A: not an axis in use (axes in use: ['X', 'Y', 'Z'])"
        );
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
        assert_eq!(
            e.to_string(),
            "operator.fro_range[0] = 150: must not exceed operator.fro_range[1] (100 %)"
        );
        // Rules between settings come from the core's validation (machine/src/setup/validate.rs).
        let e = SetupFile::parse(
            "[axis.Y]
max_rate = 10
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.Y.start_speed = 60: must not exceed axis.Y.max_rate (10)"
        );
        let e = SetupFile::parse(
            "[axis.Z]
travel = [5.0, -5.0]
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.Z.travel[0] = 5: must not exceed axis.Z.travel[1] (-5)"
        );
        let e = SetupFile::parse(
            "[jog]
analog_deadband = 2048
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "jog.analog_deadband = 2048: must be below half of inputs.adc_max (4095)"
        );
        let e = SetupFile::parse(
            "[program]
dialect = \"fanuc\"
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.dialect = \"fanuc\": must be \"ngc\" or \"gixa\""
        );
        let e = SetupFile::parse(
            "[[tool]]
number = 1
diameter = -1
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "tool[0].diameter = -1: must be between 0 and 1000"
        );
        let e = SetupFile::parse("[program]\nuser_mcodes = [3]\n").unwrap_err();
        assert!(e.to_string().contains("M3 is reserved"), "{e}");
        let e = SetupFile::parse("[inputs]\ndebounce_ms = 0\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "inputs.debounce_ms = 0: must be between 1 and 100"
        );
        let e = SetupFile::parse("[homing.axis.X]\nseek_rate = 0\n").unwrap_err();
        assert!(
            e.to_string().starts_with("homing.axis.X.seek_rate = 0"),
            "{e}"
        );
        let e = SetupFile::parse("[homing]\nbefore_seek = [\"set 99\"]\n").unwrap_err();
        assert!(e.to_string().starts_with("homing.before_seek[0]"), "{e}");
        let e = SetupFile::parse("[inputs]\nlimits_min = [\"A\"]\n").unwrap_err();
        assert!(e.to_string().starts_with("inputs.limits_min"), "{e}");
        let e = SetupFile::parse("[[mcode]]\ncode = 100\n").unwrap_err();
        assert!(e.to_string().contains("not in program.user_mcodes"), "{e}");
        let e = SetupFile::parse("[spindle]\nrpm_range = [5000, 100]\n").unwrap_err();
        assert!(e.to_string().starts_with("spindle.rpm_range"), "{e}");
        let e = SetupFile::parse("[spindle]\norient_output = 16\n").unwrap_err();
        assert!(
            e.to_string().starts_with("spindle.orient_output = 16"),
            "{e}"
        );
        let e = SetupFile::parse("[spindle]\norient_dwell_ms = 100\n").unwrap_err();
        assert!(
            e.to_string().contains("set spindle.orient_output first"),
            "{e}"
        );
        let e = SetupFile::parse("[spindle]\norient_output = 1\norient_done_input = \"in40\"\n")
            .unwrap_err();
        assert!(
            e.to_string().starts_with("spindle.orient_done_input"),
            "{e}"
        );
    }

    #[test]
    fn controller_sections_round_trip() {
        let text = r#"
[program]
user_mcodes = [100, 101]
[inputs]
active_low = ["cycle_start1", "x_min", "in30"]
debounce_ms = 3
limits_min = ["X", "Y"]
limits_max = ["Z"]
hard_limits = true
fro_pot = true
[homing]
required = true
before_seek = ["set 1"]
before_retract = ["disable_limit_report", "dwell 250", "seek"]
after_retract = ["wait in30 high 2000", "clear 1"]
[homing.axis.X]
priority = 2
seek = "low"
seek_rate = 120.0
retract = 1.5
home_position = -3.25
[homing.axis.Z]
priority = 1
seek = "high"
[jog]
pair0 = ["Y", "X"]
pair1 = ["Z", "-"]
instant_speed = 50.0
nudge_distance = 0.005
analog_axes = ["X", "-"]
[spindle]
rpm_range = [6000, 24000]
pwm_range = [10, 999]
orient_output = 7
orient_done_input = "in21"
orient_dwell_ms = 1500
[[mcode]]
code = 101
dry_run_disabled = true
commands = ["set 4", "wait feed_hold low 100", "clear 4"]
[[mcode]]
code = 100
commands = ["clear 2"]
[link]
host_lost_stop_s = 0
"#;
        let s = SetupFile::parse(text).unwrap();
        assert_eq!(s.inputs.invert, (1 << 2) | (1 << 16) | (1 << 30));
        assert_eq!((s.inputs.limit_min, s.inputs.limit_max), (0b011, 0b100));
        assert_eq!(s.homing.axes[0].home_position, -3_250_000);
        assert_eq!(s.homing.axes[0].seek_rate, 120_000_000);
        assert!(!s.homing.axes[2].seek_low);
        assert_eq!(s.jog.pairs, [[1, 0], [2, 255]]);
        assert_eq!(s.jog.analog_axes, [0, 255]);
        assert_eq!(
            s.outputs.mcode_lists[0].commands[1],
            ListCommand::WaitInput {
                bit: 0,
                level: false,
                timeout_ms: 100
            }
        );
        assert_eq!(s.homing.before_retract[0], ListCommand::DisableLimitReport);
        assert_eq!(s.link.host_lost_stop_s, 0);
        assert_eq!(
            s.outputs.orient,
            gantry_machine::setup::OrientSetup {
                output: 7,
                done_input: 21,
                dwell_ms: 1500
            }
        );
        assert!(s.interp_config().spindle_orient);
        assert!(s.is_valid());
        let shown = to_toml(&s);
        assert_eq!(SetupFile::parse(&shown).unwrap(), s);
        // `setup show` says which lists switch on the fly.
        assert!(
            shown.contains("commands = [\"clear 2\"]   # one output command: switched on the fly")
        );
        assert!(shown.contains("\"clear 4\"]   # runs at rest"));
    }

    #[test]
    fn the_limit_report_directive_must_come_first_and_the_host_timeout_is_bounded() {
        let e =
            SetupFile::parse("[homing]\nbefore_retract = [\"seek\", \"disable_limit_report\"]\n")
                .unwrap_err();
        assert_eq!(
            e.to_string(),
            "homing.before_retract[1]: \"disable_limit_report\" must be the first entry of its list"
        );
        assert_eq!(Setup::default().link.host_lost_stop_s, 60);
        let s = SetupFile::parse("[link]\nhost_lost_stop_s = 600\n").unwrap();
        assert_eq!(s.link.host_lost_stop_s, 600);
        assert!(SetupFile::parse("[link]\nhost_lost_stop_s = 70000\n").is_err());
        assert!(SetupFile::parse("[link]\nhost_timeout = 1\n").is_err());
    }

    #[test]
    fn driver_timing_is_read_in_microseconds_and_checked_against_the_step_rates() {
        assert_eq!(
            (
                Setup::default().drivers.step_pulse_ns,
                Setup::default().drivers.dir_setup_ns
            ),
            (2_500, 5_000)
        );
        let s = SetupFile::parse("[drivers]\nstep_pulse_us = 2.5\ndir_setup_us = 0.65\n").unwrap();
        assert_eq!(
            (s.drivers.step_pulse_ns, s.drivers.dir_setup_ns),
            (2_500, 650)
        );
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        assert!(to_toml(&s).contains("step_pulse_us = 2.5 "));
        let e = SetupFile::parse("[drivers]\nstep_pulse_us = 0.5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "drivers.step_pulse_us = 0.5: must be between 1 and 50 µs"
        );
        assert!(SetupFile::parse("[drivers]\ndir_setup_us = 51\n").is_err());
        assert!(SetupFile::parse("[drivers]\nstep_pulse = 5\n").is_err());
        // 3200 steps per 5 mm at 3000 mm/min is 32 000 steps/s (31.25 µs, 375 counts): a 15.5
        // µs pulse (186 counts) with as long a low time needs 31 µs and fits, whatever the dir
        // set-up (only a reversal waits for it); 15.6 µs (188 counts, 376) does not.
        assert!(SetupFile::parse("[drivers]\nstep_pulse_us = 15.5\ndir_setup_us = 50\n").is_ok());
        let e = SetupFile::parse("[drivers]\nstep_pulse_us = 15.6\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.X.max_rate = 3000 mm/min is 32000 steps/s, but the drivers' step pulse \
             (15.6 µs, then low as long again) allows at most 31914 steps/s: lower max_rate or \
             drivers.step_pulse_us"
        );
    }

    #[test]
    fn the_door_spin_up_is_read_in_seconds_and_bounded() {
        assert_eq!(Setup::default().grbl.door_spin_up_ms, 4_000);
        assert!(to_toml(&Setup::default()).contains("door_spin_up_s = 4.0 "));
        let s = SetupFile::parse("[grbl]\ndoor_spin_up_s = 2.5\n").unwrap();
        assert_eq!(s.grbl.door_spin_up_ms, 2_500);
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        let s = SetupFile::parse("[grbl]\ndoor_spin_up_s = 0\n").unwrap();
        assert_eq!(s.grbl.door_spin_up_ms, 0);
        assert!(s.is_valid());
        let e = SetupFile::parse("[grbl]\ndoor_spin_up_s = 60.5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "grbl.door_spin_up_s = 60.5: must be between 0 and 60 s"
        );
        assert!(SetupFile::parse("[grbl]\ndoor_spin_up_s = -1\n").is_err());
    }
}

//! The setup file's text-valued rows (the axes in use, M codes, positions, list commands, startup
//! lines), the work offsets and the `[[tool]]`/`[[mcode]]` items: what the settings table
//! (machine/src/setup/table.rs) cannot read or write by its unit alone; and the names (axis
//! letters, inputs) the walk's value kinds use, and the TOML value helpers both walks share
//! (a table, a pair, exact decimals).

use anyhow::{bail, Context};
use gantry_machine::board::inputs::INPUT_NAMES;
use gantry_machine::setup::table::Section;
use gantry_machine::setup::{
    Key, KeyName, ListCommand, McodeList, Setup, ToolChangePosition, MAX_MCODE_LISTS, MAX_TOOLS,
    MAX_USER_MCODES, STARTUP_LINE_LEN, USER_OUTPUTS,
};
use gantry_machine::units::{Nm, AXIS_LETTERS, MAX_AXES};
use std::fmt::Write as _;
use toml::{Table, Value};

/// Work coordinate system names in offset-table order.
pub(super) const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// Largest length accepted in a position, mm (the core is exact to 1 nm over far more).
const MAX_LENGTH_MM: f64 = 100_000.0;

/// Reads text row `key` (item `i`) from `v` into `s`.
pub(super) fn read(key: Key, i: usize, v: &Value, s: &mut Setup) -> anyhow::Result<()> {
    let at = KeyName(key, i).to_string();
    let n = usize::from(s.axis_count);
    match key {
        Key::Axes => {
            let names = strings(&at, v)?;
            if names.is_empty() || names.len() > MAX_AXES {
                bail!("axes: between 1 and {MAX_AXES} axes, a prefix of X Y Z A B C");
            }
            for (i, name) in names.iter().enumerate() {
                if !name.eq_ignore_ascii_case(&AXIS_LETTERS[i].to_string()) {
                    bail!(
                        "axes[{i}] = {name:?}: expected {:?} (axes are a prefix of X Y Z A B C)",
                        AXIS_LETTERS[i].to_string()
                    );
                }
            }
            key.set(s, 0, names.len() as i64);
        }
        Key::UserMcodes => {
            for c in array(&at, v)? {
                let c = c
                    .as_integer()
                    .with_context(|| format!("{at}: expected whole numbers"))?;
                if (0..=9).contains(&c) || c == 30 || c == 98 || c == 99 || !(0..=999).contains(&c)
                {
                    bail!(
                        "{at}: M{c} is reserved or out of range (allowed 10-999 except 30, 98, 99)"
                    );
                }
                let c = c as u16;
                s.program
                    .user_mcodes
                    .push(c)
                    .ok()
                    .with_context(|| format!("{at}: at most {MAX_USER_MCODES} codes"))?;
            }
        }
        Key::G28Home => s.program.g28_home = position(&at, v, n)?,
        Key::G30Home => s.program.g30_home = position(&at, v, n)?,
        Key::ToolChangePosition => {
            s.program.tool_change_position = tool_change_position(&at, v, s)?
        }
        Key::BeforeSeek => s.homing.before_seek = commands(&at, v)?,
        Key::BeforeRetract => s.homing.before_retract = commands(&at, v)?,
        Key::AfterRetract => s.homing.after_retract = commands(&at, v)?,
        Key::McodeCommands => s.outputs.mcode_lists[i].commands = commands(&at, v)?,
        Key::StartupLines => startup_lines(&at, v, s)?,
        _ => bail!("{at}: not a text setting"),
    }
    Ok(())
}

/// Text row `key` (item `i`) of `s` as its line in the file (no newline).
pub(super) fn write(key: Key, i: usize, s: &Setup) -> String {
    let (name, note) = (key.text().name, key.text().note);
    let n = usize::from(s.axis_count);
    let value = match key {
        Key::Axes => quoted(AXIS_LETTERS[..n].iter()),
        Key::UserMcodes => format!("{:?}", s.program.user_mcodes.as_slice()),
        Key::G28Home => mm_list(&s.program.g28_home[..n]),
        Key::G30Home => mm_list(&s.program.g30_home[..n]),
        Key::ToolChangePosition => {
            let place = &s.program.tool_change_position;
            let set: Vec<String> = (0..n)
                .filter(|&i| place.axes & (1 << i) != 0)
                .map(|i| format!("{} = {}", AXIS_LETTERS[i], mm(place.at[i])))
                .collect();
            if set.is_empty() {
                return format!("# {name} = {{ Z = 0.0 }}{note}");
            }
            format!("{{ {} }}", set.join(", "))
        }
        Key::BeforeSeek => list_toml(&s.homing.before_seek),
        Key::BeforeRetract => list_toml(&s.homing.before_retract),
        Key::AfterRetract => list_toml(&s.homing.after_retract),
        Key::McodeCommands => {
            let l = &s.outputs.mcode_lists[i];
            let note = if l.on_the_fly().is_some() {
                "   # one output command: switched on the fly, the motion does not stop"
            } else {
                "   # runs at rest"
            };
            return format!("{name} = {}{note}", list_toml(&l.commands));
        }
        Key::StartupLines => {
            let g = &s.grbl;
            format!("[{:?}, {:?}]", g.startup[0].as_str(), g.startup[1].as_str())
        }
        _ => String::new(),
    };
    format!("{name} = {value}{note}")
}

/// A new `[[tool]]` or `[[mcode]]` item for the rows to fill.
pub(super) fn push_item(section: Section, s: &mut Setup) -> anyhow::Result<()> {
    let full = match section {
        Section::Tool => s.program.tools.push(Default::default()).is_err(),
        _ => s.outputs.mcode_lists.push(McodeList::default()).is_err(),
    };
    let (name, most) = match section {
        Section::Tool => ("tool", format!("{MAX_TOOLS} tools")),
        _ => ("mcode", format!("{MAX_MCODE_LISTS} lists")),
    };
    anyhow::ensure!(!full, "{name}: at most {most}");
    Ok(())
}

/// The rules of item `k` of a `[[tool]]` or `[[mcode]]` array (`t`, as read into `s`): its
/// number is given and unique, an M code is one of `program.user_mcodes`.
pub(super) fn check_item(section: Section, k: usize, t: &Table, s: &Setup) -> anyhow::Result<()> {
    let tools = s.program.tools.iter().map(|x| x.number);
    let codes = s.outputs.mcode_lists.iter().map(|l| u32::from(l.code));
    let (name, field, what, numbers): (_, _, _, Vec<u32>) = match section {
        Section::Tool => ("tool", "number", "tool", tools.collect()),
        _ => ("mcode", "code", "list", codes.collect()),
    };
    anyhow::ensure!(
        t.contains_key(field),
        "{name}[{k}]: missing field `{field}`"
    );
    let number = numbers[k];
    if section == Section::Mcode && !s.program.user_mcodes.contains(&(number as u16)) {
        bail!("mcode[{k}].code = {number}: not in program.user_mcodes (define the M code there first)");
    }
    if numbers[..k].contains(&number) {
        bail!("{name}[{k}].{field} = {number}: {what} defined twice");
    }
    Ok(())
}

/// Does the file set any work offset?
pub(super) fn has_work_offsets(root: &Table) -> bool {
    root.get("work_offsets")
        .and_then(Value::as_table)
        .is_some_and(|t| !t.is_empty())
}

/// The `[work_offsets]` table: `"G54" = [x, y, …]`.
pub(super) fn read_work_offsets(root: &Table, s: &mut Setup) -> anyhow::Result<()> {
    let Some(v) = root.get("work_offsets") else {
        return Ok(());
    };
    for (name, v) in table(v, "work_offsets")? {
        let Some(i) = WORK_SYSTEMS
            .iter()
            .position(|w| w.eq_ignore_ascii_case(name))
        else {
            bail!("work_offsets.{name}: must be one of {WORK_SYSTEMS:?}");
        };
        s.program.work_offsets[i] = position(
            &format!("work_offsets.{name}"),
            v,
            usize::from(s.axis_count),
        )?;
    }
    Ok(())
}

pub(super) fn write_work_offsets(s: &Setup, t: &mut String) {
    let _ = writeln!(t, "\n[work_offsets]");
    for (name, off) in WORK_SYSTEMS.iter().zip(&s.program.work_offsets) {
        let _ = writeln!(
            t,
            "\"{name}\" = {}",
            mm_list(&off[..usize::from(s.axis_count)])
        );
    }
}

/// `v` as exactly two values: a `[low, high]` pair.
pub(super) fn pair<'a>(at: &str, v: &'a Value) -> anyhow::Result<[&'a Value; 2]> {
    match v.as_array().map(Vec::as_slice) {
        Some([a, b]) => Ok([a, b]),
        Some(a) => bail!(
            "{at}: invalid length {}, expected a list of exactly two values",
            a.len()
        ),
        None => bail!(
            "{at}: invalid type: {}, expected a list of exactly two values",
            v.type_str()
        ),
    }
}

fn array<'a>(at: &str, v: &'a Value) -> anyhow::Result<impl Iterator<Item = &'a Value>> {
    Ok(v.as_array()
        .with_context(|| format!("{at}: expected a list, found {}", v.type_str()))?
        .iter())
}

pub(super) fn strings<'a>(at: &str, v: &'a Value) -> anyhow::Result<Vec<&'a str>> {
    array(at, v)?
        .map(|x| {
            x.as_str()
                .with_context(|| format!("{at}: expected a list of strings"))
        })
        .collect()
}

pub(super) fn quoted<T: std::fmt::Display>(items: impl Iterator<Item = T>) -> String {
    let v: Vec<String> = items.map(|x| format!("\"{x}\"")).collect();
    format!("[{}]", v.join(", "))
}

fn mm_list(p: &[Nm]) -> String {
    let items: Vec<String> = p.iter().map(|&v| mm(v)).collect();
    format!("[{}]", items.join(", "))
}

/// Axis letter `name` as the index of an axis in use (`at` names the table).
pub(super) fn axis_in_use(at: &str, name: &str, count: usize) -> anyhow::Result<usize> {
    let axes = &AXIS_LETTERS[..count];
    let i = axes
        .iter()
        .position(|l| name.eq_ignore_ascii_case(&l.to_string()));
    i.with_context(|| format!("{at}: not an axis in use (axes in use: {axes:?})"))
}

/// Axis letter `name` of setting `at` as the index of an axis in use (`none`: or `"-"`, 255).
pub(super) fn axis_index(at: &str, name: &str, count: usize, none: bool) -> anyhow::Result<u8> {
    let axes = &AXIS_LETTERS[..count];
    match axes
        .iter()
        .position(|l| name.eq_ignore_ascii_case(&l.to_string()))
    {
        Some(i) => Ok(i as u8),
        None if none && name == "-" => Ok(255),
        None => {
            let or = if none { ", or \"-\" for none" } else { "" };
            bail!("{at} = {name:?}: not an axis in use (axes in use: {axes:?}{or})")
        }
    }
}

pub(super) fn input_name(bit: u8) -> String {
    INPUT_NAMES
        .get(usize::from(bit))
        .map_or_else(|| format!("in{bit}"), |n| n.to_string())
}

pub(super) fn input_bit(key: &str, name: &str) -> anyhow::Result<u8> {
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

/// Converts a value in mm to nm, checking ±[`MAX_LENGTH_MM`] and naming `key` on error (the
/// positions of lists, which have no row of their own in the settings table).
fn nm(key: &str, v: f64) -> anyhow::Result<Nm> {
    if !v.is_finite() || !(-MAX_LENGTH_MM..=MAX_LENGTH_MM).contains(&v) {
        bail!(
            "{key} = {v}: must be between {} and {MAX_LENGTH_MM}",
            -MAX_LENGTH_MM
        );
    }
    Ok((v * 1e6).round() as Nm)
}

fn float(key: &str, v: &Value) -> anyhow::Result<f64> {
    match v {
        Value::Integer(n) => Ok(*n as f64),
        Value::Float(f) => Ok(*f),
        _ => bail!("{key}: expected a number, found {}", v.type_str()),
    }
}

fn position(key: &str, v: &Value, axis_count: usize) -> anyhow::Result<[Nm; MAX_AXES]> {
    let values: Vec<&Value> = array(key, v)?.collect();
    if values.len() > axis_count {
        bail!(
            "{key}: {} values given but only {axis_count} axes are in use",
            values.len()
        );
    }
    let mut pos = [0; MAX_AXES];
    for (i, v) in values.into_iter().enumerate() {
        let key = format!("{key}[{i}]");
        pos[i] = nm(&key, float(&key, v)?)?;
    }
    Ok(pos)
}

/// `program.tool_change_position`: each axis named must be in use and its position inside that
/// axis's travel (the moves of every M6 would otherwise hit the soft limit).
fn tool_change_position(key: &str, v: &Value, s: &Setup) -> anyhow::Result<ToolChangePosition> {
    let mut out = ToolChangePosition::default();
    for (name, v) in table(v, key)? {
        let key = format!("{key}.{name}");
        let i = axis_in_use(&key, name, usize::from(s.axis_count))?;
        let (lo, hi) = (s.axes[i].travel_min, s.axes[i].travel_max);
        let v = float(&key, v)?;
        let at = nm(&key, v)?;
        if at < lo || at > hi {
            bail!(
                "{key} = {v}: outside the {} travel [{}, {}] (soft limits)",
                AXIS_LETTERS[i],
                mm(lo),
                mm(hi)
            );
        }
        out.axes |= 1 << i;
        out.at[i] = at;
    }
    Ok(out)
}

/// Parses a list command: `set N`, `clear N`, `dwell MS`, `wait INPUT high|low [TIMEOUT_MS]`,
/// `seek`, `disable_limit_report`.
fn list_command(key: &str, text: &str) -> anyhow::Result<ListCommand> {
    let w: Vec<&str> = text.split_whitespace().collect();
    let num = |v: &str, max: u32| -> anyhow::Result<u32> {
        match v.parse::<u32>() {
            Ok(n) if n <= max => Ok(n),
            _ => bail!("{key}: {text:?}: {v:?} must be a whole number 0-{max}"),
        }
    };
    let output = u32::from(USER_OUTPUTS) - 1;
    Ok(match w.as_slice() {
        ["set", n] => ListCommand::Set(num(n, output)? as u8),
        ["clear", n] => ListCommand::Clear(num(n, output)? as u8),
        ["dwell", ms] => ListCommand::DwellMs(num(ms, 65_535)? as u16),
        ["wait", input, level, rest @ ..] if rest.len() <= 1 => ListCommand::WaitInput {
            bit: input_bit(key, input)?,
            level: match *level {
                "high" => true,
                "low" => false,
                _ => bail!("{key}: {text:?}: the level must be \"high\" or \"low\""),
            },
            timeout_ms: rest.first().map_or(Ok(0), |t| num(t, 65_535))? as u16,
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
        } => {
            format!(
                "wait {} {} {timeout_ms}",
                input_name(bit),
                if level { "high" } else { "low" }
            )
        }
        ListCommand::DisableLimitReport => "disable_limit_report".into(),
        ListCommand::Seek => "seek".into(),
    }
}

fn list_toml(list: &[ListCommand]) -> String {
    quoted(list.iter().map(list_text))
}

fn commands<const N: usize>(key: &str, v: &Value) -> anyhow::Result<heapless::Vec<ListCommand, N>> {
    let mut out = heapless::Vec::new();
    for (i, t) in strings(key, v)?.into_iter().enumerate() {
        let c = list_command(&format!("{key}[{i}]"), t)?;
        if c == ListCommand::DisableLimitReport && i != 0 {
            bail!("{key}[{i}]: \"disable_limit_report\" must be the first entry of its list");
        }
        out.push(c)
            .map_err(|_| anyhow::anyhow!("{key}: at most {N} commands"))?;
    }
    Ok(out)
}

/// `grbl.startup_lines`: stored as grbl stores them (upper case, no blanks) and checked as the
/// board checks `$N0=` (parsed as a block, no `$` command).
fn startup_lines(key: &str, v: &Value, s: &mut Setup) -> anyhow::Result<()> {
    let lines = strings(key, v)?;
    if lines.len() > 2 {
        bail!("{key}: at most 2 lines ($N0, $N1)");
    }
    for (i, line) in lines.into_iter().enumerate() {
        let text: String = line
            .chars()
            .filter(|c| !c.is_ascii_whitespace())
            .map(|c| c.to_ascii_uppercase())
            .collect();
        if !text.bytes().all(|c| (b' '..=b'~').contains(&c)) || text.starts_with('$') {
            bail!("{key}[{i}] = {line:?}: printable ASCII G-code, no $ command");
        }
        let mut lexer = gantry_machine::gcode::lexer::Lexer::new(text.as_bytes(), true);
        lexer.start();
        let cfg = s.interp_config();
        if let Err((e, _)) = gantry_machine::gcode::block::parse_block(&mut lexer, &cfg) {
            bail!("{key}[{i}] = {line:?}: error {}: {e:?}", e.number());
        }
        s.grbl.startup[i] = heapless::String::try_from(text.as_str()).map_err(|_| {
            anyhow::anyhow!("{key}[{i}]: at most {STARTUP_LINE_LEN} characters without blanks")
        })?;
    }
    Ok(())
}

/// `v` as a table, `at` naming it in the error.
pub(super) fn table<'a>(v: &'a Value, at: &str) -> anyhow::Result<&'a Table> {
    v.as_table()
        .with_context(|| format!("{at}: expected a table, found {}", v.type_str()))
}

/// A value of `scale` units per file unit as a TOML float: exact decimals, at least one (`5.0`).
pub(super) fn decimal(v: i64, scale: i64) -> String {
    let sign = if v < 0 { "-" } else { "" };
    let scale = scale.unsigned_abs();
    let (int, frac) = (v.unsigned_abs() / scale, v.unsigned_abs() % scale);
    let width = scale.ilog10() as usize;
    let frac = format!("{frac:0width$}");
    let frac = frac.trim_end_matches('0');
    format!("{sign}{int}.{}", if frac.is_empty() { "0" } else { frac })
}

/// Millimetres (from nm) as a TOML float.
pub(super) fn mm(v: Nm) -> String {
    decimal(v, 1_000_000)
}

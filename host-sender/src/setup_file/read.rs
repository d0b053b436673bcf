//! The reader: a walk over the settings table (machine/src/setup/table.rs), section by section,
//! each value converted by its row's unit, range-checked by the core and set.

use super::codec::{self, table};
use super::layout::{place, rows, tables, OUTPUT_MAX};
use anyhow::{bail, Context};
use gantry_machine::setup::table::{Section, Unit, SECTIONS};
use gantry_machine::setup::{section_name, Key, KeyName, Setup, USER_OUTPUTS};
use toml::{Table, Value};

/// Reads the file over the defaults, then the core's rules between settings.
pub(super) fn read(root: &Table) -> anyhow::Result<Setup> {
    let s = apply(root)?;
    // The rules between settings (start speed, pairs, step rate…): the core's own check.
    s.validate().map_err(anyhow::Error::new)?;
    Ok(s)
}

/// Reads the file over the defaults, section by section in the table's order (the axes before
/// what is per axis, the program's M codes before the M-code lists), each value checked on its
/// own; [`read`] adds the rules between settings.
pub(super) fn apply(root: &Table) -> anyhow::Result<Setup> {
    let mut s = Setup::default();
    for section in SECTIONS {
        let name = section_name(section);
        match section {
            Section::Top => read_rows(root, section, 0, &mut s)?,
            Section::Axis | Section::HomingAxis => {
                let parent = match section {
                    Section::Axis => Some(root),
                    _ => root.get("homing").and_then(Value::as_table),
                };
                let axes = parent.and_then(|p| p.get("axis")).map(|a| table(a, name));
                for (letter, v) in axes.transpose()?.into_iter().flatten() {
                    let at = format!("{name}.{letter}");
                    let i = codec::axis_in_use(&at, letter, usize::from(s.axis_count))?;
                    read_rows(table(v, &at)?, section, i, &mut s)?;
                }
            }
            Section::Tool | Section::Mcode => {
                let items = root.get(name).map(|v| {
                    v.as_array()
                        .with_context(|| format!("{name}: expected an array of tables [[{name}]]"))
                });
                for (k, v) in items.transpose()?.into_iter().flatten().enumerate() {
                    let t = table(v, &format!("{name}[{k}]"))?;
                    codec::push_item(section, &mut s)?;
                    read_rows(t, section, k, &mut s)?;
                    codec::check_item(section, k, t, &s)?;
                }
            }
            _ => {
                if let Some(v) = root.get(name) {
                    read_rows(table(v, name)?, section, 0, &mut s)?;
                }
            }
        }
        if section == Section::Tool {
            codec::read_work_offsets(root, &mut s)?;
        }
    }
    Ok(s)
}

/// One table of `section` (item `i`): every key must be a row's (or a table below), each value
/// is converted by the row's unit, range-checked by the core and set.
fn read_rows(t: &Table, section: Section, i: usize, s: &mut Setup) -> anyhow::Result<()> {
    let at = place(section, i);
    let below: Vec<&str> = match section {
        Section::Top => tables().collect(),
        Section::Homing => vec!["axis"],
        _ => vec![],
    };
    let known = |k: &str| below.contains(&k) || rows(section).any(|(_, n)| n == k);
    if let Some(name) = t.keys().find(|k| !known(k)) {
        let names = rows(section).map(|(_, n)| n).chain(below.iter().copied());
        let names: Vec<String> = names.map(|n| format!("`{n}`")).collect();
        let names = names.join(", ");
        bail!("{at}{name}: unknown field `{name}`, expected one of {names}");
    }
    for (key, name) in rows(section) {
        let Some(v) = t.get(name) else {
            continue;
        };
        if key.row().unit == Unit::Text {
            codec::read(key, i, v, s)?;
            continue;
        }
        // A `[low, high]` pair sets its two rows.
        let values = match name != key.text().name {
            true => codec::pair(&format!("{at}{name}"), v)?.to_vec(),
            false => vec![v],
        };
        for (key, v) in [key, key.next()].into_iter().zip(values) {
            let value = read_value(key, i, v, s)?;
            key.set(s, i, value);
        }
    }
    Ok(())
}

/// A file value of setting `key` (axis or tool `index`) in the core's integer units, by the
/// row's unit: scaled units read decimals, counts whole numbers, names (axis letters in use,
/// inputs) their index. The table's range is checked by the core's own check, so the refusal
/// is the one the board and grbl `$x=` give.
fn read_value(key: Key, index: usize, v: &Value, s: &Setup) -> anyhow::Result<i64> {
    let (unit, at) = (key.row().unit, KeyName(key, index).to_string());
    let n = usize::from(s.axis_count);
    let scale = unit.scale();
    let scaled = |v: f64| match v.is_nan() {
        true => i64::MIN,
        false => (v * scale as f64).round() as i64,
    };
    let expected = |what: &str| anyhow::anyhow!("{at}: expected {what}, found {}", v.type_str());
    let value = match (unit, v) {
        (Unit::Bool, Value::Boolean(b)) => i64::from(*b),
        (Unit::Bool, _) => return Err(expected("true or false")),
        (Unit::Choice, Value::String(text)) => choice(key, index, text)?,
        (Unit::Choice, _) => return Err(expected("a string")),
        (Unit::AxisMask, _) => codec::strings(&at, v)?.iter().try_fold(0, |m, name| {
            anyhow::Ok(m | 1 << codec::axis_index(&at, name, n, false)?)
        })?,
        (Unit::InputMask, _) => codec::strings(&at, v)?.iter().try_fold(0, |m, name| {
            anyhow::Ok(m | 1 << codec::input_bit(&at, name)?)
        })?,
        (Unit::AxisPair, _) => {
            let letter = |v: &Value| match v.as_str() {
                Some(name) => codec::axis_index(&at, name, n, true).map(i64::from),
                None => bail!("{at}: expected axis letters"),
            };
            let [a, b] = codec::pair(&at, v)?;
            letter(a)? | letter(b)? << 8
        }
        (Unit::Input, Value::String(name)) => i64::from(codec::input_bit(&at, name)?),
        (Unit::Input, _) => bail!("{at}: expected an input name"),
        (Unit::Output, Value::Integer(o)) if (0..i64::from(USER_OUTPUTS)).contains(o) => *o,
        (Unit::Output, Value::Integer(o)) => bail!("{at} = {o}: a user output 0-{}", OUTPUT_MAX),
        (Unit::Output, _) => bail!("{at}: expected a user output number 0-{OUTPUT_MAX}"),
        (_, Value::Integer(n)) if scale == 1 => *n,
        (_, Value::Integer(n)) => scaled(*n as f64),
        (_, Value::Float(f)) if scale > 1 => scaled(*f),
        _ if scale > 1 => return Err(expected("a number")),
        _ => return Err(expected("a whole number")),
    };
    key.check(index, value).map_err(anyhow::Error::new)?;
    Ok(value)
}

/// `text` as the index of one of `key`'s choices (any case).
fn choice(key: Key, index: usize, text: &str) -> anyhow::Result<i64> {
    let choices = key.text().choices;
    match choices.iter().position(|c| c.eq_ignore_ascii_case(text)) {
        Some(i) => Ok(i as i64),
        None => {
            let names: Vec<String> = choices.iter().map(|c| format!("{c:?}")).collect();
            bail!(
                "{} = {text:?}: must be {}",
                KeyName(key, index),
                names.join(" or ")
            )
        }
    }
}

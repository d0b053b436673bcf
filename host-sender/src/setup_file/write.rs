//! The writer: a walk over the settings table (machine/src/setup/table.rs), each row's
//! `key = value` and its comment, in the table's order.

use super::codec::{self, decimal};
use super::layout::{place, rows, OUTPUT_MAX};
use gantry_machine::setup::table::{Section, Unit, SECTIONS};
use gantry_machine::setup::{section_name, Key, OrientSetup, Setup};
use gantry_machine::units::AXIS_LETTERS;
use std::fmt::Write as _;

/// One value of a row as the file writes it (`n` axes in use).
fn value_text(key: Key, v: i64, n: usize) -> String {
    let letter = |a: i64| match AXIS_LETTERS.get(a as usize).filter(|_| (a as usize) < n) {
        Some(l) => l.to_string(),
        None => "-".into(),
    };
    let bits = |count: usize| (0..count).filter(move |b| v & (1 << b) != 0);
    match key.row().unit {
        Unit::Bool => (v != 0).to_string(),
        Unit::Choice => format!("\"{}\"", key.text().choices[v as usize]),
        // Degrees keep their three decimals (`0.000`): the file has always written them so.
        Unit::Degrees => format!("{}.{:03}", v / 1000, v % 1000),
        Unit::AxisMask => codec::quoted(bits(n).map(|a| AXIS_LETTERS[a])),
        Unit::InputMask => codec::quoted(bits(32).map(|b| codec::input_name(b as u8))),
        Unit::AxisPair => codec::quoted([v & 0xff, v >> 8].into_iter().map(letter)),
        Unit::Input => format!("{:?}", codec::input_name(v as u8)),
        u if u.scale() > 1 => decimal(v, u.scale()),
        _ => v.to_string(),
    }
}

/// An output or input row set to none: the example its commented-out line shows.
fn unset(key: Key, v: i64) -> Option<&'static str> {
    match key.row().unit {
        Unit::Output if v > i64::from(OUTPUT_MAX) => Some("0"),
        Unit::Input if v == i64::from(OrientSetup::NONE) => Some("\"in20\""),
        _ => None,
    }
}
/// Writes a setup as a commented setup file that [`SetupFile::parse`] reads back exactly: each
/// section's table head, then each row's `key = value` and its comment.
pub fn to_toml(s: &Setup) -> String {
    let mut t = String::from(
        "# Gantry machine setup. Lengths in mm (degrees for A/B/C), speeds in mm/min,\n\
         # accelerations in mm/s². See docs/settings.md for every key and its range.\n",
    );
    for section in SECTIONS {
        let name = section_name(section);
        for i in 0..section.count(s) {
            let _ = match section {
                Section::Top => Ok(()),
                Section::Tool | Section::Mcode => writeln!(t, "\n[[{name}]]"),
                _ => writeln!(t, "\n[{}]", place(section, i).trim_end_matches('.')),
            };
            for (key, name) in rows(section) {
                let (note, v, n) = (key.text().note, key.value(s, i), usize::from(s.axis_count));
                let _ = if key.row().unit == Unit::Text {
                    writeln!(t, "{}", codec::write(key, i, s))
                } else if let Some(example) = unset(key, v) {
                    writeln!(t, "# {name} = {example}{note}")
                } else if name != key.text().name {
                    let (a, b) = (
                        value_text(key, v, n),
                        value_text(key.next(), key.next().value(s, i), n),
                    );
                    writeln!(t, "{name} = [{a}, {b}]{note}")
                } else {
                    writeln!(t, "{name} = {}{note}", value_text(key, v, n))
                };
            }
        }
        if section == Section::Tool {
            codec::write_work_offsets(s, &mut t);
        }
    }
    t
}

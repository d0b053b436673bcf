//! Where the settings table's rows sit in the file: each section's rows under their file names,
//! the place a key is named by in messages, the tables below the top.

use gantry_machine::setup::table::{Section, ROWS, SECTIONS};
use gantry_machine::setup::{section_name, Key, KeyName, USER_OUTPUTS};

/// The highest user output number.
pub(super) const OUTPUT_MAX: u8 = USER_OUTPUTS - 1;

/// The rows of `section` with their key in the file: a `[low, high]` pair (`travel[0]`,
/// `travel[1]`) once, under its base name, as its first row.
pub(super) fn rows(section: Section) -> impl Iterator<Item = (Key, &'static str)> {
    ROWS.iter()
        .filter(move |r| r.section == section)
        .filter_map(|r| {
            let name = r.key.text().name;
            (!name.ends_with("[1]")).then(|| (r.key, name.strip_suffix("[0]").unwrap_or(name)))
        })
}

/// Where the keys of `section` (item `i`) sit in messages: `axis.X.`, `tool[2].`, `path.`.
pub(super) fn place(section: Section, i: usize) -> String {
    let key = ROWS
        .iter()
        .find(|r| r.section == section)
        .map_or(Key::Axes, |r| r.key);
    let full = KeyName(key, i).to_string();
    full[..full.len() - key.text().name.len()].to_string()
}

/// The file's table names: the sections below the top, and the work offsets (no table rows).
pub(super) fn tables() -> impl Iterator<Item = &'static str> {
    SECTIONS
        .iter()
        .filter(|s| !matches!(s, Section::Top | Section::HomingAxis))
        .map(|s| section_name(*s))
        .chain(["work_offsets"])
}

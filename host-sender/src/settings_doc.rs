//! docs/settings.md's per-setting tables, generated from the settings table
//! (machine/src/setup/table.rs): each sits between `<!-- settings:SECTION -->` and
//! `<!-- /settings -->`, the prose around them is hand-written. `gantry setup docs FILE`
//! rewrites them; a test fails when docs/settings.md differs from what the table generates.

use anyhow::bail;
use gantry_machine::setup::table::{Row, Section, Unit, ROWS, SECTIONS};
use gantry_machine::setup::{file_value, section_name, Setup};
use gantry_machine::units::AXIS_LETTERS;

const END: &str = "<!-- /settings -->";

/// The marker that opens a section's table.
fn start_marker(s: Section) -> String {
    let name = match s {
        Section::Top => "top",
        other => section_name(other),
    };
    format!("<!-- settings:{name} -->")
}

/// One value of `row` as the docs show it.
fn shown(row: &Row, v: i64) -> String {
    let t = row.key.text();
    match row.unit {
        Unit::Bool => format!("{}", v != 0),
        Unit::Choice => format!("\"{}\"", t.choices.get(v as usize).unwrap_or(&"?")),
        _ => file_value(row.key, v).to_string(),
    }
}

/// The default of `rows` (one row, or a `[low, high]` pair), per axis where the axes differ.
fn default(rows: &[&Row], s: &Setup) -> String {
    let t = rows[0].key.text();
    if !t.default.is_empty() {
        return t.default.to_string();
    }
    let at = |i: usize| {
        let v: Vec<String> = rows.iter().map(|r| shown(r, r.key.value(s, i))).collect();
        if v.len() == 1 {
            format!("`{}`", v[0])
        } else {
            format!("`[{}]`", v.join(", "))
        }
    };
    let n = rows[0].section.count(s);
    let all: Vec<String> = (0..n).map(at).collect();
    if all.windows(2).all(|w| w[0] == w[1]) {
        all.into_iter().next().unwrap_or_default()
    } else {
        let v: Vec<String> = all
            .iter()
            .enumerate()
            .map(|(i, d)| format!("{} {d}", AXIS_LETTERS[i]))
            .collect();
        v.join(", ")
    }
}

/// The range of one row as the docs show it.
fn range(row: &Row) -> String {
    let t = row.key.text();
    if !t.range.is_empty() {
        return t.range.to_string();
    }
    let v = |x: i64| file_value(row.key, x).to_string();
    let (lo, hi) = (row.min(), row.max());
    match row.unit {
        Unit::Bool | Unit::Text => String::new(),
        Unit::Choice => {
            let c: Vec<String> = t.choices.iter().map(|c| format!("`\"{c}\"`")).collect();
            c.join(", ")
        }
        _ if hi == i64::from(u32::MAX) || hi == i64::MAX => format!("≥ {}", v(lo)),
        _ if lo == -hi => format!("±{}", v(hi)),
        u => format!("{}-{}{}", v(lo), v(hi), u.suffix()),
    }
}

/// The markdown table of section `sec`.
pub(crate) fn table(sec: Section) -> String {
    let s = Setup::default();
    let mut out = String::from("| key | default | range | meaning |\n|---|---|---|---|\n");
    let rows: Vec<&Row> = ROWS.iter().filter(|r| r.section == sec).collect();
    let mut i = 0;
    while i < rows.len() {
        let t = rows[i].key.text();
        let (name, group) = match t.name.strip_suffix("[0]") {
            Some(base) => (base, &rows[i..i + 2]),
            None => (t.name, &rows[i..i + 1]),
        };
        // A pair's range: the first row's text, or each half's (once when they agree).
        let mut ranges: Vec<String> = if t.range.is_empty() {
            group.iter().map(|r| range(r)).collect()
        } else {
            vec![t.range.to_string()]
        };
        ranges.retain(|r| !r.is_empty());
        ranges.dedup();
        out.push_str(&format!(
            "| `{name}` | {} | {} | {} |\n",
            default(group, &s),
            ranges.join(", "),
            t.doc
        ));
        i += group.len();
    }
    out
}

/// `doc` with every marked table replaced by the generated one.
pub fn render(doc: &str) -> anyhow::Result<String> {
    let mut out = doc.to_string();
    for sec in SECTIONS {
        let start = start_marker(sec);
        let Some(a) = out.find(&start) else {
            bail!("no {start} marker");
        };
        let body = a + start.len() + 1;
        let Some(b) = out[body..].find(END).map(|b| body + b) else {
            bail!("{start} has no {END}");
        };
        out.replace_range(body..b, &table(sec));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn docs_settings_md_is_what_the_table_generates() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/settings.md");
        let doc = std::fs::read_to_string(path).unwrap();
        let want = render(&doc).unwrap();
        assert!(
            doc == want,
            "docs/settings.md is stale: run `cargo run -p host-sender -- setup docs docs/settings.md`"
        );
    }

    #[test]
    fn tables_show_defaults_ranges_and_pairs() {
        let axis = table(Section::Axis);
        assert!(
            axis.contains("| `max_rate` | `3000` | 1-200000 |"),
            "{axis}"
        );
        assert!(
            axis.contains("| `travel` | X `[-300, 300]`, Y `[-200, 200]`, Z `[-100, 100]` | ±100000, min ≤ max |"),
            "{axis}"
        );
        let drivers = table(Section::Drivers);
        assert!(
            drivers.contains("| `step_pulse_us` | `2.5` | 1-50 µs |"),
            "{drivers}"
        );
    }
}

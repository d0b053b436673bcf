//! Every error of setup text at once (`gantry setup check`): each setting read on its own, then
//! the rules between the settings that are valid on their own.

use super::read::{apply, read};
use toml::{Table, Value};

/// Every error of setup text, each with its line (0: unknown) and a message naming its key: each
/// setting is read on its own (with `axes`, which decides what the others may name), so one bad
/// key does not hide the next; the rules between settings are checked once every setting is
/// valid on its own. Empty: the text is valid.
pub(super) fn every_error(text: &str) -> Vec<(u32, String)> {
    let table: Table = match toml::from_str(text) {
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
        let mut t = Table::new();
        if let Some(axes) = table.get("axes") {
            t.insert("axes".into(), axes.clone());
        }
        let mut at = &mut t;
        for seg in &path[..path.len() - 1] {
            at = at
                .entry(seg.clone())
                .or_insert_with(|| Value::Table(Default::default()))
                .as_table_mut()
                .expect("a table on the way to a setting");
        }
        at.insert(path[path.len() - 1].clone(), value.clone());
        if let Err(e) = apply(&t) {
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
    if let Err(e) = read(&valid) {
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

/// The settings of a parsed setup, each with its key path: a value that is not a table, and an
/// array of tables (`[[tool]]`, `[[mcode]]`) as one setting (its entries are checked together).
fn setting_leaves(table: &Table, path: &mut Vec<String>, out: &mut Vec<(Vec<String>, Value)>) {
    for (k, v) in table {
        path.push(k.clone());
        match v {
            Value::Table(t) => setting_leaves(t, path, out),
            _ => out.push((path.clone(), v.clone())),
        }
        path.pop();
    }
}

/// Removes the setting at `path` from `table`.
fn remove_path(table: &mut Table, path: &[String]) {
    match path {
        [] => {}
        [last] => {
            table.remove(last);
        }
        [first, rest @ ..] => {
            if let Some(Value::Table(t)) = table.get_mut(first) {
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

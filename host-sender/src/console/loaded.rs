//! The program serve holds for every page: its text, its check (as `gantry check` reports it),
//! its tool path from where the tool stands, and a revision. A page reads it from serve when it
//! connects, on reload, in a second tab, and whenever the revision changes (another client
//! opened a program, the setup or its work offsets changed, a run starts from another place):
//! the listing and the path are serve's, never the page's memory.

use super::program;
use crate::program::Program;
use gantry_machine::setup::Setup;
use serde_json::{json, Value};

/// One program as serve holds it.
pub(crate) struct Loaded {
    pub(crate) name: String,
    pub(crate) text: String,
    pub(crate) rev: u64,
    /// What every page shows of it (name, lines, check, errors, error lines, planned time).
    pub(crate) summary: Value,
    /// The tool path (`program::path_json`'s points), machine mm.
    pub(crate) path: Value,
}

impl Loaded {
    /// Checks `text` with `setup` and draws its path from `here` (machine nm).
    pub(crate) fn build(name: &str, text: &str, setup: &Setup, here: &[i64; 6], rev: u64) -> Self {
        let checked = program::check(name, text, setup, here);
        let path: Value = serde_json::from_str(&program::path_json(text, setup, here))
            .map_or(Value::Null, |mut v: Value| v["pts"].take());
        let from = [0, 1, 2].map(|i| here[i] as f64 / 1e6);
        let summary = json!({
            "name": name, "lines": Program::from_text(text).len(), "rev": rev,
            "check": checked.text, "errors": checked.errors,
            "error_lines": checked.error_lines, "seconds": checked.seconds,
            "tools": checked.tools, "size": text.len(),
            "from": from,
        });
        Loaded {
            name: name.to_owned(),
            text: text.to_owned(),
            rev,
            summary,
            path,
        }
    }

    /// Everything a page needs to show it: the summary, the source and the path.
    pub(crate) fn whole(&self) -> Value {
        let mut v = self.summary.clone();
        v["ok"] = Value::from(true);
        v["source"] = Value::from(self.text.as_str());
        v["path"] = self.path.clone();
        v
    }
}

//! What a push leaves of the board's own: the work offsets, the G28/G30 positions and the tool
//! table stay the board's unless the file names them (docs/controller.md "Work offsets").

use super::codec;
use gantry_machine::setup::Setup;
use toml::{Table, Value};

/// `s` (read from `root`) with what `root` does not name taken from `stored`, and a list of what
/// was kept that holds anything ("work offsets G54 G55", "G28 position", "tool table (2 tools)").
pub(super) fn boards_own(root: &Table, mut s: Setup, stored: &Setup) -> (Setup, Vec<String>) {
    let named = |t: &str, k: &str| root.get(t).and_then(|t| t.get(k)).is_some();
    let tools = root.get("tool").and_then(Value::as_array);
    let (from, to, mut kept) = (&stored.program, &mut s.program, Vec::new());
    if !codec::has_work_offsets(root) {
        to.work_offsets = from.work_offsets;
        let set = codec::WORK_SYSTEMS.iter().zip(&from.work_offsets);
        let set: Vec<&str> = set
            .filter(|(_, o)| o.iter().any(|v| *v != 0))
            .map(|(n, _)| *n)
            .collect();
        if !set.is_empty() {
            kept.push(format!("work offsets {}", set.join(" ")));
        }
    }
    for (key, name, at, stored_at) in [
        ("g28_home", "G28", &mut to.g28_home, &from.g28_home),
        ("g30_home", "G30", &mut to.g30_home, &from.g30_home),
    ] {
        if !named("program", key) {
            *at = *stored_at;
            if stored_at.iter().any(|v| *v != 0) {
                kept.push(format!("{name} position"));
            }
        }
    }
    if tools.is_none_or(|a| a.is_empty()) {
        to.tools = from.tools.clone();
        match from.tools.len() {
            0 => {}
            1 => kept.push("tool table (1 tool)".into()),
            n => kept.push(format!("tool table ({n} tools)")),
        }
    }
    (s, kept)
}

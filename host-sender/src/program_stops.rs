//! Where a program stops for the operator: M0 / M1 (program stop, optional stop) and M6 (a
//! manual tool change), read from the text the sender sends (`Program::wire_text`: comments and
//! blanks removed), and what the sender says there. The stops themselves are the board's (the
//! core holds the job at M0/M1 and at M6, docs/probing.md "Tool change"): the sender only words
//! the message, with the tool the board names in its `ToolChange` state.

/// A stop the sender announces and waits out with the operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stop {
    /// M0 (`optional` false) or M1.
    Program { optional: bool },
    /// M6 with the tool named in the block (T word), if any.
    ToolChange { tool: Option<u32> },
}

/// The words of a block: (letter, number text), e.g. `G1X-2.5` → (G, "1"), (X, "-2.5").
fn words(text: &str) -> impl Iterator<Item = (char, &str)> {
    let b = text.as_bytes();
    let mut i = 0;
    std::iter::from_fn(move || {
        while i < b.len() {
            let c = b[i] as char;
            i += 1;
            if c.is_ascii_alphabetic() {
                let start = i;
                while i < b.len() && (b[i].is_ascii_digit() || b"+-.".contains(&b[i])) {
                    i += 1;
                }
                return Some((c.to_ascii_uppercase(), &text[start..i]));
            }
        }
        None
    })
}

/// The whole-number value of a word (`06` → 6); `None` for `6.1` or no number.
fn whole(v: &str) -> Option<u32> {
    v.parse().ok()
}

/// The operator stop in a block, if any (M6 first: a tool change block may also stop).
pub(crate) fn stop_in(text: &str) -> Option<Stop> {
    let mut stop = None;
    let mut tool = None;
    for (letter, value) in words(text) {
        match (letter, whole(value)) {
            ('M', Some(6)) => stop = Some(Stop::ToolChange { tool: None }),
            ('M', Some(0)) if stop.is_none() => stop = Some(Stop::Program { optional: false }),
            ('M', Some(1)) if stop.is_none() => stop = Some(Stop::Program { optional: true }),
            ('T', Some(t)) => tool = Some(t),
            _ => {}
        }
    }
    match stop {
        Some(Stop::ToolChange { .. }) => Some(Stop::ToolChange { tool }),
        s => s,
    }
}

/// What the sender tells the operator at a stop.
/// The stop the job stands at, if the board's state says it stopped for one: an M6 (the board
/// names the tool) or an M0/M1 on line `line` of `program` (a feed hold is not a stop).
pub(crate) fn stop_at(
    state: Option<gantry_proto::MachineState>,
    program: &crate::program::Program,
    line: u32,
) -> Option<Stop> {
    use gantry_proto::MachineState;
    match state? {
        MachineState::ToolChange { tool } => Some(Stop::ToolChange { tool: Some(tool) }),
        MachineState::Hold { stopped: true } => program
            .wire_text(line)
            .ok()
            .flatten()
            .and_then(|t| stop_in(&t))
            .filter(|s| matches!(s, Stop::Program { .. })),
        _ => None,
    }
}

pub(crate) fn message(stop: Stop, line: u32) -> String {
    message_with(stop, line, None)
}

/// [`message`] with the stop line's comment (`M0 (check the cut)`: the program's word to the
/// operator); line 0 is a run-from-line preamble's block.
pub(crate) fn message_with(stop: Stop, line: u32, source: Option<&str>) -> String {
    let place = if line == 0 {
        "resume preamble".to_owned()
    } else {
        format!("line {line}")
    };
    let note = source
        .and_then(comment_of)
        .map_or(String::new(), |c| format!(" \u{2014} \u{201c}{c}\u{201d}"));
    match stop {
        Stop::Program { optional } => format!(
            "{place}: program stop ({}): press Enter (or cycle start) to continue{note}",
            if optional { "M1" } else { "M0" }
        ),
        Stop::ToolChange { tool } => format!(
            "{place}: tool change: put {} in the spindle, then press Enter (or cycle start) to continue{note}",
            tool.map_or("the next tool".to_owned(), |t| format!("tool {t}"))
        ),
    }
}

/// The first comment of a line: `( … )` or after `;`, trimmed; none when empty.
fn comment_of(line: &str) -> Option<&str> {
    let text = match (line.find('('), line.find(';')) {
        (Some(p), Some(s)) if s < p => &line[s + 1..],
        (Some(p), _) => {
            let rest = &line[p + 1..];
            &rest[..rest.find(')').unwrap_or(rest.len())]
        }
        (None, Some(s)) => &line[s + 1..],
        (None, None) => return None,
    };
    Some(text.trim()).filter(|t| !t.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_shows_its_comment_and_a_preamble_stop_says_so() {
        let m0 = Stop::Program { optional: false };
        assert_eq!(
            message_with(m0, 3, Some("M0 (check the cut)")),
            "line 3: program stop (M0): press Enter (or cycle start) to continue \u{2014} \u{201c}check the cut\u{201d}"
        );
        assert_eq!(
            message_with(m0, 4, Some("G0 X1 M0 ; look")),
            "line 4: program stop (M0): press Enter (or cycle start) to continue \u{2014} \u{201c}look\u{201d}"
        );
        assert!(message_with(m0, 5, Some("M0 ()")).ends_with("to continue"));
        let tc = Stop::ToolChange { tool: Some(1) };
        assert!(message_with(tc, 0, None).starts_with("resume preamble: tool change: put tool 1"));
    }

    #[test]
    fn stops_are_found_by_their_words() {
        assert_eq!(stop_in("G0X1M0"), Some(Stop::Program { optional: false }));
        assert_eq!(stop_in("m01"), Some(Stop::Program { optional: true }));
        assert_eq!(stop_in("T2M6"), Some(Stop::ToolChange { tool: Some(2) }));
        assert_eq!(stop_in("M06T12"), Some(Stop::ToolChange { tool: Some(12) }));
        assert_eq!(stop_in("M6"), Some(Stop::ToolChange { tool: None }));
        assert_eq!(stop_in("G1X10M3S1000"), None);
        assert_eq!(stop_in("M30"), None);
        assert_eq!(stop_in("M60"), None);
        assert_eq!(stop_in("G10L2P1X0"), None);
        assert_eq!(
            message(Stop::ToolChange { tool: Some(3) }, 12),
            "line 12: tool change: put tool 3 in the spindle, then press Enter (or cycle start) to continue"
        );
    }
}

//! Where a run from a line can start: a line inside O-word control flow (a loop, an `if`
//! branch, a Fanuc `WHILE … DO`) cannot, since the board would meet the block's end without its
//! start; the block's first line can, the state before it rebuilt as for any line
//! (`crate::resume`). Found from the program text with the core's O-word parser
//! (machine/src/gcode/oword.rs).

use gantry_machine::gcode::oword::{parse, Keyword, Label};

/// An O-word block open at some line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct OpenBlock {
    /// Its first line (1-based).
    pub(crate) line: u32,
    /// It is a subroutine definition (`sub`): its lines run only when called.
    pub(crate) sub: bool,
    /// That line's text, trimmed.
    pub(crate) text: String,
}

/// How a block ends.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Sub,
    If,
    While,
    Do,
    Repeat,
}

/// The outermost O-word block still open when line `line` is reached in file order, if any.
pub(crate) fn enclosing_block(text: &str, line: u32) -> Option<OpenBlock> {
    let mut open: Vec<(Label, Kind, u32)> = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let n = i as u32 + 1;
        if n >= line {
            break;
        }
        let Some(o) = parse(l.as_bytes()) else {
            continue;
        };
        let close = |open: &mut Vec<(Label, Kind, u32)>, kinds: &[Kind]| {
            if let Some(at) = open
                .iter()
                .rposition(|&(label, k, _)| label == o.label && kinds.contains(&k))
            {
                open.truncate(at);
            }
        };
        match o.keyword {
            Keyword::Sub => open.push((o.label, Kind::Sub, n)),
            Keyword::EndSub => close(&mut open, &[Kind::Sub]),
            Keyword::If => open.push((o.label, Kind::If, n)),
            Keyword::EndIf => close(&mut open, &[Kind::If]),
            Keyword::Do => open.push((o.label, Kind::Do, n)),
            Keyword::Repeat => open.push((o.label, Kind::Repeat, n)),
            Keyword::EndRepeat => close(&mut open, &[Kind::Repeat]),
            Keyword::EndWhile => close(&mut open, &[Kind::While]),
            Keyword::While => {
                // The `while` of a `do` ends it; any other opens a loop.
                if open
                    .last()
                    .is_some_and(|&(label, k, _)| label == o.label && k == Kind::Do)
                {
                    open.pop();
                } else {
                    open.push((o.label, Kind::While, n));
                }
            }
            _ => {}
        }
    }
    let &(_, kind, first) = open.first()?;
    let text = text.lines().nth(first as usize - 1).unwrap_or("").trim();
    Some(OpenBlock {
        line: first,
        sub: kind == Kind::Sub,
        text: text.to_owned(),
    })
}

/// The line a run meant to start at `line` can start at: `line` itself, or the first line of the
/// control-flow block around it (never a subroutine's: those lines are refused as before).
pub(crate) fn resumable_line(text: &str, line: u32) -> u32 {
    match enclosing_block(text, line) {
        Some(b) if !b.sub => b.line,
        _ => line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIGN: &str = "G21 G90\n#1 = 0\no100 while [#1 LT 3]\n  G1 X[#1 * 10] F600\n  o200 if [#1 EQ 1]\n    G1 Y5\n  o200 endif\n  #1 = [#1 + 1]\no100 endwhile\no300 do\n  G0 Z1\no300 while [0]\nM2\n";

    #[test]
    fn a_line_inside_nested_blocks_names_the_outermost_start() {
        assert_eq!(enclosing_block(SIGN, 3), None);
        let b = enclosing_block(SIGN, 6).unwrap();
        assert_eq!((b.line, b.sub), (3, false));
        assert_eq!(b.text, "o100 while [#1 LT 3]");
        // The closing line itself is inside too; the line after it is not.
        assert_eq!(resumable_line(SIGN, 9), 3);
        assert_eq!(resumable_line(SIGN, 10), 10);
        // A do … while loop ends at its while.
        assert_eq!(resumable_line(SIGN, 11), 10);
        assert_eq!(resumable_line(SIGN, 13), 13);
    }

    #[test]
    fn fanuc_loops_and_subroutines() {
        let text = "WHILE [#1 LT 2] DO1\nG1 X1\nEND1\no5 sub\nG0 X0\no5 endsub\nM2\n";
        assert_eq!(resumable_line(text, 2), 1);
        assert_eq!(resumable_line(text, 4), 4);
        let b = enclosing_block(text, 5).unwrap();
        assert!(b.sub);
        assert_eq!(resumable_line(text, 5), 5);
    }
}

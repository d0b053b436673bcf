//! A G-code file as the sender serves it: numbered lines, the text that goes on the wire, and
//! where each `O` subprogram and `N` block starts (for the board's jump requests).

use anyhow::Context;
use gantry_proto::LINE_MAX;
use std::path::Path;

/// A program file, line by line (line 1 is the first line of the file).
pub struct Program {
    lines: Vec<String>,
}

/// Where a board asked the sender to continue.
pub(crate) use gantry_proto::ProgramTarget;

/// The longest line a program file may have, bytes: far beyond any G-code line (the board takes
/// [`LINE_MAX`] once comments and blanks are stripped), short enough to read any line whole.
pub(crate) const FILE_LINE_LIMIT: usize = 64 * 1024;

/// Reads `path` through once in constant memory and refuses it at the first line longer than
/// [`FILE_LINE_LIMIT`] (a binary file, `/dev/zero`), naming the line, before anything reads it
/// whole (`gantry check`, `simulate`, `preview`, `stream`).
pub fn check_line_lengths(path: &Path) -> anyhow::Result<()> {
    use std::io::BufRead;
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
    let (mut line, mut len) = (1u64, 0usize);
    loop {
        let buf = reader
            .fill_buf()
            .with_context(|| format!("cannot read {}", path.display()))?;
        if buf.is_empty() {
            return Ok(());
        }
        let n = buf.len();
        for &b in buf {
            if b == b'\n' {
                line += 1;
                len = 0;
            } else {
                len += 1;
                if len > FILE_LINE_LIMIT {
                    anyhow::bail!(
                        "{}:{line}: line longer than {FILE_LINE_LIMIT} characters: not a G-code program (the board takes {LINE_MAX} once comments and blanks are dropped)",
                        path.display()
                    );
                }
            }
        }
        reader.consume(n);
    }
}

impl Program {
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        check_line_lengths(path)?;
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        Ok(Self::from_text(&text))
    }

    pub fn from_text(text: &str) -> Self {
        Program {
            lines: text.lines().map(str::to_owned).collect(),
        }
    }

    /// Number of lines in the file.
    pub(crate) fn len(&self) -> u32 {
        self.lines.len() as u32
    }

    /// Line `n` as written (1-based).
    pub(crate) fn line(&self, n: u32) -> Option<&str> {
        self.lines
            .get(n.checked_sub(1)? as usize)
            .map(String::as_str)
    }

    /// The text sent for line `n`: comments and blanks removed (they never change what a block
    /// does). `Ok(None)` when nothing is left; `Err` when it is longer than the protocol's limit.
    pub(crate) fn wire_text(&self, n: u32) -> Result<Option<String>, WireTextError> {
        match self.line(n) {
            Some(line) => wire_text_of(n, line),
            None => Ok(None),
        }
    }

    /// The columns `[start, end)` in line `n` as written of the word that starts at 1-based
    /// column `wire_column` of its [`Program::wire_text`] (where the board reports errors).
    pub(crate) fn source_columns(&self, n: u32, wire_column: u16) -> Option<(u16, u16)> {
        let line = self.line(n)?;
        let start = usize::from(wire_column.checked_sub(1)?);
        // Byte index in `line` of every character sent, in order.
        let kept = kept_chars(line);
        let wire: Vec<char> = kept.iter().map(|&(_, c)| c).collect();
        wire.get(start)?;
        // The word: its letter and the number after it, up to the next letter.
        let len = 1 + wire[start + 1..]
            .iter()
            .take_while(|c| !c.is_ascii_alphabetic() && **c != '(')
            .count();
        let col = |byte: usize| line[..byte].chars().count() as u16;
        let begin = col(kept[start].0);
        let last = kept[start + len - 1];
        let end = col(last.0) + 1;
        Some((begin, end))
    }

    /// The first line a jump target refers to.
    pub(crate) fn resolve(&self, target: ProgramTarget) -> Option<u32> {
        match target {
            ProgramTarget::Line(n) => (n >= 1 && n <= self.len() + 1).then_some(n),
            ProgramTarget::Program(p) => self.find(|t| word_value(t, b'O') == Some(p)),
            ProgramTarget::Sequence(s) => self.find(|t| word_value(t, b'N') == Some(s)),
        }
    }

    fn find(&self, pred: impl Fn(&str) -> bool) -> Option<u32> {
        (1..=self.len()).find(|&n| pred(&strip(&self.lines[n as usize - 1])))
    }
}

/// [`Program::wire_text`] of one line `text` numbered `n` (for tools that read a file line by
/// line: `preview::source::Watched`).
pub(crate) fn wire_text_of(n: u32, text: &str) -> Result<Option<String>, WireTextError> {
    let text = strip(text);
    if text.is_empty() {
        Ok(None)
    } else if text.len() > LINE_MAX {
        Err(WireTextError {
            line: n,
            len: text.len(),
        })
    } else {
        Ok(Some(text))
    }
}

/// A line too long for the protocol even after comments and blanks were removed.
#[derive(Debug, PartialEq, Eq)]
pub(crate) struct WireTextError {
    pub(crate) line: u32,
    pub(crate) len: usize,
}

impl std::fmt::Display for WireTextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "line {}: {} characters without comments and blanks, the board takes at most {LINE_MAX}",
            self.line, self.len
        )
    }
}

/// Removes `( … )` and `;` comments and white space.
fn strip(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut in_comment = false;
    for c in line.chars() {
        match c {
            '(' if !in_comment => in_comment = true,
            ')' if in_comment => in_comment = false,
            ';' if !in_comment => break,
            c if in_comment || c.is_whitespace() => {}
            c => out.push(c),
        }
    }
    // An unclosed comment is left for the board to report, with the rest of the line.
    if in_comment {
        return line.trim().to_owned();
    }
    out
}

/// The characters [`strip`] keeps, with their byte index in `line`.
fn kept_chars(line: &str) -> Vec<(usize, char)> {
    let mut out = Vec::new();
    let mut in_comment = false;
    for (i, c) in line.char_indices() {
        match c {
            '(' if !in_comment => in_comment = true,
            ')' if in_comment => in_comment = false,
            ';' if !in_comment => break,
            c if in_comment || c.is_whitespace() => {}
            c => out.push((i, c)),
        }
    }
    if in_comment {
        let lead = line.len() - line.trim_start().len();
        return line
            .trim()
            .char_indices()
            .map(|(i, c)| (i + lead, c))
            .collect();
    }
    out
}

/// The N number of line `n`'s block, if it starts with one.
pub(crate) fn n_word(program: &Program, n: u32) -> Option<u32> {
    word_value(&strip(program.line(n)?), b'N')
}

/// The value of a leading word `letter<digits>` (after an optional `/`), e.g. `O100` → 100.
fn word_value(text: &str, letter: u8) -> Option<u32> {
    let t = text.strip_prefix('/').unwrap_or(text).as_bytes();
    let (&first, rest) = t.split_first()?;
    if first.to_ascii_uppercase() != letter {
        return None;
    }
    let digits: &[u8] = &rest[..rest.iter().take_while(|b| b.is_ascii_digit()).count()];
    std::str::from_utf8(digits).ok()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_and_blanks_are_not_sent() {
        let p = Program::from_text("G0 X1 (rapid) Y2 ; done\n(only a comment)\n\nG1 X(unclosed\n");
        assert_eq!(p.wire_text(1), Ok(Some("G0X1Y2".into())));
        assert_eq!(p.wire_text(2), Ok(None));
        assert_eq!(p.wire_text(3), Ok(None));
        assert_eq!(p.wire_text(4), Ok(Some("G1 X(unclosed".into())));
        assert_eq!(p.wire_text(5), Ok(None));
    }

    #[test]
    fn long_lines_are_refused_with_their_number() {
        // 4 + 126 × 2 = 256 characters sent: the longest line; one more is refused.
        let fits = format!("G1 X1 (c) {}", "Y1".repeat(126));
        let long = format!("G1 X1 (c) {}Z", "Y1".repeat(126));
        let p = Program::from_text(&format!("G0\n{fits}\n{long}\n"));
        assert_eq!(p.wire_text(2).unwrap().unwrap().len(), 256);
        assert_eq!(p.wire_text(3), Err(WireTextError { line: 3, len: 257 }));
    }

    #[test]
    fn board_columns_map_back_to_the_line_as_written() {
        let p = Program::from_text("N20 G1 (feed) Q2.5 X3 F1\n");
        // Sent as "N20G1Q2.5X3F1": the Q is at column 6 (1-based).
        assert_eq!(p.source_columns(1, 6), Some((14, 18)));
        assert_eq!(p.source_columns(1, 0), None);
        assert_eq!(n_word(&p, 1), Some(20));
    }

    #[test]
    fn jump_targets_resolve_to_file_lines() {
        let p = Program::from_text("O1\nM98 P100\nM30\nO100 (sub)\nN20 G0 X1\nM99\n");
        assert_eq!(p.resolve(ProgramTarget::Program(100)), Some(4));
        assert_eq!(p.resolve(ProgramTarget::Program(7)), None);
        assert_eq!(p.resolve(ProgramTarget::Sequence(20)), Some(5));
        assert_eq!(p.resolve(ProgramTarget::Line(3)), Some(3));
        assert_eq!(p.resolve(ProgramTarget::Line(9)), None);
    }
}

//! Program sources: where the interpreter pulls lines from, with the jumps subprograms need.
//!
//! The interpreter owns the call stack; a source only serves lines and repositions on request, so a
//! streaming host can answer "program O from its start" or "line n" without knowing any G-code
//! semantics. [`MemorySource`] serves a program held in memory (flash or RAM) with no heap.

/// Why a source could not jump.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourceError {
    /// No `O<program>` line in the program.
    UnknownProgram,
    /// Two `O<program>` lines in the program.
    DuplicateProgram,
    /// No block with that N word (gixa M98 P).
    UnknownSequence,
    /// The line number does not exist.
    NoSuchLine,
    /// The sender streams lines in order only and cannot serve a jump (grbl mode).
    NotServed,
}

/// A G-code program that can be read line by line and repositioned.
pub trait ProgramSource {
    /// The next line: its 1-based line number in the file and its bytes (without the newline), or
    /// `None` at the end of the file.
    fn next_line(&mut self) -> Option<(u32, &[u8])>;

    /// Repositions so that the next line returned is the `O<program>` line itself; returns its line
    /// number.
    fn jump_to_program(&mut self, program: u32) -> Result<u32, SourceError>;

    /// Repositions so that the next line returned is the first block whose N word is `n` (gixa
    /// subroutines are addressed by N); returns its line number.
    fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError>;

    /// Repositions so that the next line returned is line `line` (1-based); `line` may be one past
    /// the last line (then the source is at its end).
    fn jump_to_line(&mut self, line: u32) -> Result<(), SourceError>;

    /// True when no line will ever follow (the end of the file). A streaming source returns false
    /// while it merely waits for the host: the interpreter then returns `None` from
    /// [`crate::gcode::Interpreter::next`] without finishing, and continues once lines arrive.
    fn is_exhausted(&self) -> bool {
        true
    }
}

/// Remembered (line, byte offset) pairs, so returns from subprograms do not rescan the file.
const POSITION_CACHE: usize = 16;

/// A program in memory (`&[u8]`), indexed lazily: jumps scan the text and remember recent targets.
pub struct MemorySource<'a> {
    text: &'a [u8],
    offset: usize,
    line: u32,
    cache: heapless::Vec<(u32, usize), POSITION_CACHE>,
    cache_next: usize,
    /// Programs already located: (O number, line, byte offset); found once, with duplicates checked.
    programs: heapless::Vec<(u32, u32, usize), PROGRAM_CACHE>,
    programs_next: usize,
}

/// Remembered subprogram locations.
const PROGRAM_CACHE: usize = 8;

impl<'a> MemorySource<'a> {
    /// A source positioned at line 1.
    pub fn new(text: &'a [u8]) -> Self {
        MemorySource {
            text,
            offset: 0,
            line: 1,
            cache: heapless::Vec::new(),
            cache_next: 0,
            programs: heapless::Vec::new(),
            programs_next: 0,
        }
    }

    /// Back to line 1.
    pub fn rewind(&mut self) {
        self.offset = 0;
        self.line = 1;
    }

    fn remember(&mut self, line: u32, offset: usize) {
        if self.cache.iter().any(|&(l, _)| l == line) {
            return;
        }
        if self.cache.push((line, offset)).is_err() {
            self.cache[self.cache_next] = (line, offset);
            self.cache_next = (self.cache_next + 1) % POSITION_CACHE;
        }
    }

    /// Iterates over (line number, byte offset, line bytes) from the start of the text.
    fn lines(&self) -> impl Iterator<Item = (u32, usize, &'a [u8])> + 'a {
        let text = self.text;
        let mut offset = 0usize;
        let mut line = 0u32;
        core::iter::from_fn(move || {
            if offset >= text.len() {
                return None;
            }
            let start = offset;
            let end = text[start..]
                .iter()
                .position(|&c| c == b'\n')
                .map_or(text.len(), |p| start + p);
            offset = end + 1;
            line += 1;
            Some((line, start, &text[start..end]))
        })
    }
}

impl Seekable for MemorySource<'_> {
    type Position = usize;

    fn position(&self) -> (u32, usize) {
        (self.line, self.offset)
    }

    fn scan<F: Fn(&[u8]) -> bool>(&mut self, is_target: F) -> (Option<(u32, usize)>, bool) {
        let mut lines = self.lines();
        find_target(|| lines.next().map(|(l, o, bytes)| (l, o, is_target(bytes))))
    }

    fn move_to(&mut self, line: u32, offset: usize) {
        self.line = line;
        self.offset = offset;
    }

    fn remember_line(&mut self, line: u32, offset: usize) {
        self.remember(line, offset);
    }

    fn known_program(&self, program: u32) -> Option<(u32, usize)> {
        self.programs
            .iter()
            .find(|&&(p, _, _)| p == program)
            .map(|&(_, l, o)| (l, o))
    }

    fn remember_program(&mut self, program: u32, line: u32, offset: usize) {
        let entry = (program, line, offset);
        if self.programs.push(entry).is_err() {
            self.programs[self.programs_next] = entry;
            self.programs_next = (self.programs_next + 1) % PROGRAM_CACHE;
        }
    }
}

/// What a jump to a program or a sequence number needs of a source: where it stands, a scan of
/// its lines from the start, a move, and its caches. [`seek_program`] and [`seek_sequence`] do
/// the jumps over it for [`MemorySource`] (byte offsets in a slice) and the host's file source
/// (host-sender/src/preview/source.rs, offsets it seeks to in a file), which differ only here.
pub trait Seekable {
    /// Where a line starts (a byte offset).
    type Position: Copy;

    /// The next line's number and position.
    fn position(&self) -> (u32, Self::Position);

    /// Every line from the start through `is_target` ([`find_target`]): the first target's line
    /// and position, and whether a second target follows. May leave the source anywhere (the
    /// jump moves it afterwards).
    fn scan<F: Fn(&[u8]) -> bool>(&mut self, is_target: F)
        -> (Option<(u32, Self::Position)>, bool);

    /// Repositions so that the next line read is `line`, which starts at `position`.
    fn move_to(&mut self, line: u32, position: Self::Position);

    /// Remembers where `line` starts (for [`ProgramSource::jump_to_line`]).
    fn remember_line(&mut self, line: u32, position: Self::Position);

    /// Where `O<program>` was found before, if it is still remembered.
    fn known_program(&self, program: u32) -> Option<(u32, Self::Position)>;

    /// Remembers where `O<program>` starts.
    fn remember_program(&mut self, program: u32, line: u32, position: Self::Position);
}

/// [`ProgramSource::jump_to_program`] for a [`Seekable`] source: the remembered place, else a
/// scan for the one `O<program>`/`:<program>` line (two are an error); on an error the source
/// stays where it was.
pub fn seek_program<S: Seekable>(source: &mut S, program: u32) -> Result<u32, SourceError> {
    let here = source.position();
    let target = match source.known_program(program) {
        Some(found) => found,
        None => {
            let (found, duplicate) =
                source.scan(|bytes| leading_number(bytes, b"O:") == Some(program));
            let found = match (found, duplicate) {
                (_, true) => Err(SourceError::DuplicateProgram),
                (found, false) => found.ok_or(SourceError::UnknownProgram),
            };
            let found = stay_on_error(source, here, found)?;
            source.remember_program(program, found.0, found.1);
            found
        }
    };
    Ok(jump(source, here, target))
}

/// [`ProgramSource::jump_to_sequence`] for a [`Seekable`] source: the first block whose N word
/// is `n`; on an error the source stays where it was.
pub fn seek_sequence<S: Seekable>(source: &mut S, n: u32) -> Result<u32, SourceError> {
    let here = source.position();
    let (found, _) = source.scan(|bytes| leading_number(bytes, b"N") == Some(n));
    let target = stay_on_error(source, here, found.ok_or(SourceError::UnknownSequence))?;
    Ok(jump(source, here, target))
}

/// Back to `here` when the scan found no target.
fn stay_on_error<S: Seekable>(
    source: &mut S,
    here: (u32, S::Position),
    found: Result<(u32, S::Position), SourceError>,
) -> Result<(u32, S::Position), SourceError> {
    if found.is_err() {
        source.move_to(here.0, here.1);
    }
    found
}

/// Moves to `target`, remembering both ends: the caller comes back to `here` after M99.
fn jump<S: Seekable>(source: &mut S, here: (u32, S::Position), target: (u32, S::Position)) -> u32 {
    source.remember_line(here.0, here.1);
    source.remember_line(target.0, target.1);
    source.move_to(target.0, target.1);
    target.0
}

/// The scan behind a jump: pulls (line number, position, whether the line is the target) from
/// `next_line` until the end, and returns the first target's line and position, and whether a
/// second target follows (the scan stops there). Shared by [`MemorySource`] and the host's file
/// source (host-sender/src/preview/source.rs), which read their lines differently.
pub fn find_target<P>(
    mut next_line: impl FnMut() -> Option<(u32, P, bool)>,
) -> (Option<(u32, P)>, bool) {
    let mut found = None;
    while let Some((line, position, is_target)) = next_line() {
        if is_target {
            if found.is_some() {
                return (found, true);
            }
            found = Some((line, position));
        }
    }
    (found, false)
}

/// The number after a leading letter (`O`/`:` or `N`) at the start of a line, blanks and a
/// block-delete slash skipped: how a jump finds its target line. Public so that every
/// [`ProgramSource`] (the host's file source, host-sender/src/preview/source.rs) finds the same
/// lines as [`MemorySource`].
pub(crate) fn leading_number(line: &[u8], letters: &[u8]) -> Option<u32> {
    let mut i = 0;
    while i < line.len() && (line[i] == b' ' || line[i] == b'\t' || line[i] == b'/') {
        i += 1;
    }
    if i >= line.len() || !letters.contains(&line[i].to_ascii_uppercase()) {
        return None;
    }
    i += 1;
    let mut v: u64 = 0;
    let mut digits = 0;
    while i < line.len() {
        match line[i] {
            b'0'..=b'9' => {
                v = v * 10 + (line[i] - b'0') as u64;
                digits += 1;
                if digits > 9 {
                    return None;
                }
            }
            b' ' | b'\t' => {}
            _ => break,
        }
        i += 1;
    }
    (digits > 0).then_some(v as u32)
}

impl ProgramSource for MemorySource<'_> {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        if self.offset >= self.text.len() {
            return None;
        }
        let start = self.offset;
        let end = self.text[start..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(self.text.len(), |p| start + p);
        let line = self.line;
        self.offset = end + 1;
        self.line += 1;
        Some((line, &self.text[start..end]))
    }

    fn jump_to_program(&mut self, program: u32) -> Result<u32, SourceError> {
        seek_program(self, program)
    }

    fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
        seek_sequence(self, n)
    }

    fn jump_to_line(&mut self, line: u32) -> Result<(), SourceError> {
        if line == 0 {
            return Err(SourceError::NoSuchLine);
        }
        if let Some(&(l, o)) = self.cache.iter().find(|&&(l, _)| l == line) {
            self.line = l;
            self.offset = o;
            return Ok(());
        }
        let mut end_line = 1;
        for (l, o, _) in self.lines() {
            if l == line {
                self.line = l;
                self.offset = o;
                self.remember(l, o);
                return Ok(());
            }
            end_line = l + 1;
        }
        if line == end_line {
            self.line = line;
            self.offset = self.text.len();
            return Ok(());
        }
        Err(SourceError::NoSuchLine)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_jumps() {
        let text = b"G0 X1\nM98 P7\nM30\nO7 (sub)\nG0 X2\nM99\n";
        let mut s = MemorySource::new(text);
        assert_eq!(s.next_line(), Some((1, &b"G0 X1"[..])));
        assert_eq!(s.next_line().unwrap().0, 2);
        assert_eq!(s.jump_to_program(7), Ok(4));
        assert_eq!(s.next_line(), Some((4, &b"O7 (sub)"[..])));
        s.jump_to_line(3).unwrap();
        assert_eq!(s.next_line(), Some((3, &b"M30"[..])));
        assert_eq!(s.jump_to_program(8), Err(SourceError::UnknownProgram));
        s.jump_to_line(7).unwrap();
        assert_eq!(s.next_line(), None);
        assert_eq!(s.jump_to_line(9), Err(SourceError::NoSuchLine));
        let dup = b"O5\nM99\nO0005\nM99\n";
        let mut s = MemorySource::new(dup);
        assert_eq!(s.jump_to_program(5), Err(SourceError::DuplicateProgram));
    }
}

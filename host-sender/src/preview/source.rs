//! Program text → canonical actions with the core's interpreter, configured from the machine setup,
//! in constant memory: [`FileSource`] reads a file line by line (jumps to subprograms seek in it),
//! [`Watched`] looks at every line the first time it is read (lines too long for the board, the
//! text of recent lines for error reports), and [`Actions`] hands out the actions one at a time.
//! `gantry check`, `simulate` and `preview` pull from it, so no program is held in memory whole.

use super::model::{Interpreted, ProgramError};
use crate::program::WireTextError;
use gantry_machine::canon::Canon;
use gantry_machine::gcode::source::{find_target, seek_program, seek_sequence, Seekable};
use gantry_machine::gcode::{
    GcodeError, InterpConfig, Interpreter, MemorySource, ProgramSource, SourceError,
};
use gantry_machine::setup::Setup;
use std::collections::VecDeque;
use std::fs::File;
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::Path;

/// Actions one program may produce at least before it is taken for an endless loop (M99 back to
/// a label, a `while` that never ends); longer files get [`ACTIONS_PER_LINE`] more per line.
pub(crate) const MIN_ACTION_LIMIT: u64 = 5_000_000;
/// Actions allowed per line read, on top of [`MIN_ACTION_LIMIT`]: the cap grows with the file,
/// so no program is too long, only one that loops far more than its text.
pub(crate) const ACTIONS_PER_LINE: u64 = 100;

/// Remembered (line, byte offset) pairs, so returns from subprograms do not rescan the file.
const POSITION_CACHE: usize = 32;
/// Remembered subprogram starts (O number, line, byte offset).
const PROGRAM_CACHE: usize = 32;

/// A program file read through a buffer, repositioned by seeking: memory stays constant whatever
/// the file's length (the same jumps as the core's `MemorySource`).
pub(crate) struct FileSource {
    reader: BufReader<File>,
    /// Number and byte offset of the next line.
    line: u32,
    offset: u64,
    /// The last line read, without its newline.
    buf: Vec<u8>,
    cache: VecDeque<(u32, u64)>,
    programs: VecDeque<(u32, u32, u64)>,
}

impl FileSource {
    pub(crate) fn open(path: &Path) -> std::io::Result<Self> {
        Ok(FileSource {
            reader: BufReader::with_capacity(1 << 16, File::open(path)?),
            line: 1,
            offset: 0,
            buf: Vec::new(),
            cache: VecDeque::new(),
            programs: VecDeque::new(),
        })
    }

    fn remember(&mut self, line: u32, offset: u64) {
        if self.cache.iter().any(|&(l, _)| l == line) {
            return;
        }
        if self.cache.len() == POSITION_CACHE {
            self.cache.pop_front();
        }
        self.cache.push_back((line, offset));
    }

    /// Reads the line at the reader's position into `buf`; false at the end of the file.
    fn read_line(&mut self) -> bool {
        self.buf.clear();
        match self.reader.read_until(b'\n', &mut self.buf) {
            Ok(0) | Err(_) => false,
            Ok(n) => {
                self.offset += n as u64;
                if self.buf.last() == Some(&b'\n') {
                    self.buf.pop();
                }
                true
            }
        }
    }
}

/// The core's jumps ([`seek_program`], [`seek_sequence`]) over a file: a scan reads it from the
/// start, a move seeks.
impl Seekable for FileSource {
    type Position = u64;

    fn position(&self) -> (u32, u64) {
        (self.line, self.offset)
    }

    /// Leaves the reader past the lines read (the jump seeks afterwards).
    fn scan<F: Fn(&[u8]) -> bool>(&mut self, is_target: F) -> (Option<(u32, u64)>, bool) {
        self.seek_back(1, 0);
        find_target(|| {
            let (line, offset) = (self.line, self.offset);
            if !self.read_line() {
                return None;
            }
            self.line += 1;
            Some((line, offset, is_target(&self.buf)))
        })
    }

    fn move_to(&mut self, line: u32, offset: u64) {
        self.seek_back(line, offset);
    }

    fn remember_line(&mut self, line: u32, offset: u64) {
        self.remember(line, offset);
    }

    fn known_program(&self, program: u32) -> Option<(u32, u64)> {
        self.programs
            .iter()
            .find(|&&(p, _, _)| p == program)
            .map(|&(_, l, o)| (l, o))
    }

    fn remember_program(&mut self, program: u32, line: u32, offset: u64) {
        if self.programs.len() == PROGRAM_CACHE {
            self.programs.pop_front();
        }
        self.programs.push_back((program, line, offset));
    }
}

impl ProgramSource for FileSource {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        let line = self.line;
        if !self.read_line() {
            return None;
        }
        self.line += 1;
        Some((line, &self.buf))
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
            self.seek_back(l, o);
            return Ok(());
        }
        let (back_line, back_offset) = (self.line, self.offset);
        // Forwards from here when the line lies ahead, else from the start.
        if line < self.line {
            self.seek_back(1, 0);
        }
        while self.line < line {
            if !self.read_line() {
                self.seek_back(back_line, back_offset);
                return Err(SourceError::NoSuchLine);
            }
            self.line += 1;
        }
        self.remember(self.line, self.offset);
        Ok(())
    }

    fn is_exhausted(&self) -> bool {
        true
    }
}

impl FileSource {
    /// Positions the reader at `offset`, the start of line `line` (a failed seek leaves it where
    /// it was; the next read then ends the file).
    fn seek_back(&mut self, line: u32, offset: u64) {
        let _ = self.reader.seek(SeekFrom::Start(offset));
        self.line = line;
        self.offset = offset;
    }
}

/// Recent lines kept for error reports.
const RECENT_LINES: usize = 8;

/// A source whose lines are looked at the first time they are read: lines too long for the board
/// are queued as [`WireTextError`]s (in file order), and the text of the last few lines read is
/// kept for error reports.
pub(crate) struct Watched<S> {
    pub(crate) inner: S,
    /// The highest line number read so far.
    pub(crate) furthest: u32,
    long: VecDeque<(WireTextError, String)>,
    recent: VecDeque<(u32, Vec<u8>)>,
}

impl<S: ProgramSource> Watched<S> {
    pub(crate) fn new(inner: S) -> Self {
        Watched {
            inner,
            furthest: 0,
            long: VecDeque::new(),
            recent: VecDeque::new(),
        }
    }

    /// The next line too long for the board, in file order, found so far, with its text.
    pub(crate) fn take_long_line(&mut self) -> Option<(WireTextError, String)> {
        self.long.pop_front()
    }

    /// The first long line found and not yet taken.
    pub(crate) fn peek_long_line(&self) -> Option<&WireTextError> {
        self.long.front().map(|(e, _)| e)
    }

    /// The text of `line` if it was among the last lines read.
    pub(crate) fn recent(&self, line: u32) -> Option<String> {
        self.recent
            .iter()
            .rev()
            .find(|(l, _)| *l == line)
            .map(|(_, t)| String::from_utf8_lossy(t).into_owned())
    }

    /// Reads the lines after the furthest one read (the interpreter stopped at M2/M30 or an
    /// error), so that long lines there are found too.
    pub(crate) fn read_rest(&mut self) {
        if self.inner.jump_to_line(self.furthest + 1).is_err() {
            return;
        }
        while self.next_line().is_some() {}
    }
}

impl<S: ProgramSource> ProgramSource for Watched<S> {
    fn next_line(&mut self) -> Option<(u32, &[u8])> {
        let (line, bytes) = self.inner.next_line()?;
        if line > self.furthest {
            self.furthest = line;
            // Only a line longer than the limit as written can be longer once stripped.
            if bytes.len() > gantry_proto::LINE_MAX {
                let text = String::from_utf8_lossy(bytes);
                if let Err(e) = crate::program::wire_text_of(line, &text) {
                    self.long.push_back((e, text.into_owned()));
                }
            }
        }
        // Keep the line's text, reusing the oldest buffer.
        let mut text = if self.recent.len() == RECENT_LINES {
            self.recent.pop_front().map(|(_, t)| t).unwrap_or_default()
        } else {
            Vec::new()
        };
        text.clear();
        text.extend_from_slice(bytes);
        self.recent.push_back((line, text));
        let (_, text) = self.recent.back().expect("just pushed");
        Some((line, text))
    }

    fn jump_to_program(&mut self, program: u32) -> Result<u32, SourceError> {
        self.inner.jump_to_program(program)
    }

    fn jump_to_sequence(&mut self, n: u32) -> Result<u32, SourceError> {
        self.inner.jump_to_sequence(n)
    }

    fn jump_to_line(&mut self, line: u32) -> Result<(), SourceError> {
        self.inner.jump_to_line(line)
    }

    fn is_exhausted(&self) -> bool {
        self.inner.is_exhausted()
    }
}

/// Why [`Actions`] ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Ended {
    /// Still running, or the program ended (end of file, M2/M30, one pass of an M99 loop).
    No,
    /// The interpreter refused a block.
    Error(GcodeError),
    /// More actions than [`action_limit`] allows for the lines read: an endless loop.
    Limit(u64),
}

/// The action cap for a program whose furthest line read is `lines`.
pub(crate) fn action_limit(lines: u32) -> u64 {
    MIN_ACTION_LIMIT + ACTIONS_PER_LINE * u64::from(lines)
}

/// A program's canonical actions, one at a time, up to its first error (then [`Actions::ended`]
/// tells why); after one pass of a main program that loops with M99; at most [`action_limit`].
pub(crate) struct Actions<S> {
    pub(crate) interp: Interpreter,
    pub(crate) src: Watched<S>,
    pub(crate) ended: Ended,
    /// Actions handed out.
    pub(crate) count: u64,
    stopped: bool,
}

impl<S: ProgramSource> Actions<S> {
    pub(crate) fn new(src: S, config: &InterpConfig) -> Self {
        Actions {
            interp: Interpreter::new(config),
            src: Watched::new(src),
            ended: Ended::No,
            count: 0,
            stopped: false,
        }
    }

    /// The program interpreted from machine position `at` (nm), where the machine stands, as the
    /// board's interpreter starts a job (`crate::session::standing`).
    pub(crate) fn starting_at(mut self, at: &gantry_machine::units::Pos) -> Self {
        let mut state = *self.interp.state();
        state.position = *at;
        self.interp.set_state(state);
        self
    }
}

impl<S: ProgramSource> Iterator for Actions<S> {
    type Item = Canon;

    fn next(&mut self) -> Option<Canon> {
        if self.stopped {
            return None;
        }
        match self.interp.next(&mut self.src) {
            Some(Ok(c)) => {
                self.count += 1;
                if self.interp.restarts() > 0 {
                    // M99 in the main program loops forever; one pass is the program.
                    self.stopped = true;
                }
                if self.count >= action_limit(self.src.furthest) {
                    self.stopped = true;
                    self.ended = Ended::Limit(self.count);
                }
                Some(c)
            }
            Some(Err(e)) => {
                self.stopped = true;
                self.ended = Ended::Error(e);
                None
            }
            None => {
                self.stopped = true;
                None
            }
        }
    }
}

/// The message of an [`Ended`] error for the preview and the summary.
pub(crate) fn ended_error(ended: &Ended, what: &str) -> Option<ProgramError> {
    match ended {
        Ended::No => None,
        Ended::Error(e) => Some(ProgramError {
            line: e.line,
            message: format!("E{}: {}", e.code.number(), e.message()),
        }),
        Ended::Limit(n) => Some(ProgramError {
            line: 0,
            message: format!("{n} actions, more than the program's lines allow: {what} stopped (an endless loop?)"),
        }),
    }
}

/// Interprets a whole program held in memory (tests and small tools). Stops at the first error
/// (returned with its line and message), after one pass of a main program that loops with M99,
/// or at [`action_limit`].
pub fn interpret(program: &[u8], setup: &Setup) -> Interpreted {
    let mut actions = Actions::new(MemorySource::new(program), &setup.interp_config());
    let out: Vec<Canon> = actions.by_ref().collect();
    (out, ended_error(&actions.ended, "preview"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(text: &str) -> (tempfile_path::TempPath, FileSource) {
        let p = tempfile_path::TempPath::new(text);
        let s = FileSource::open(&p.0).unwrap();
        (p, s)
    }

    /// A file in the temp directory, removed when dropped.
    mod tempfile_path {
        pub(crate) struct TempPath(pub(crate) std::path::PathBuf);
        impl TempPath {
            pub(crate) fn new(text: &str) -> Self {
                use std::sync::atomic::{AtomicU32, Ordering};
                static N: AtomicU32 = AtomicU32::new(0);
                let p = std::env::temp_dir().join(format!(
                    "gantry-source-{}-{}.nc",
                    std::process::id(),
                    N.fetch_add(1, Ordering::Relaxed)
                ));
                std::fs::write(&p, text).unwrap();
                TempPath(p)
            }
        }
        impl Drop for TempPath {
            fn drop(&mut self) {
                let _ = std::fs::remove_file(&self.0);
            }
        }
    }

    #[test]
    fn file_source_reads_and_jumps_like_the_memory_source() {
        let text = b"G0 X1\nM98 P7\nM30\nO7 (sub)\nG0 X2\nM99\n";
        let (_p, mut s) = file(std::str::from_utf8(text).unwrap());
        assert_eq!(s.next_line(), Some((1, &b"G0 X1"[..])));
        assert_eq!(s.next_line().unwrap().0, 2);
        assert_eq!(s.jump_to_program(7), Ok(4));
        assert_eq!(s.next_line(), Some((4, &b"O7 (sub)"[..])));
        s.jump_to_line(3).unwrap();
        assert_eq!(s.next_line(), Some((3, &b"M30"[..])));
        assert_eq!(s.jump_to_program(8), Err(SourceError::UnknownProgram));
        // A failed jump leaves the source where it was.
        assert_eq!(s.next_line(), Some((4, &b"O7 (sub)"[..])));
        s.jump_to_line(7).unwrap();
        assert_eq!(s.next_line(), None);
        assert_eq!(s.jump_to_line(9), Err(SourceError::NoSuchLine));
        s.jump_to_line(2).unwrap();
        assert_eq!(s.next_line(), Some((2, &b"M98 P7"[..])));
        let (_p, mut s) = file("O5\nM99\nO0005\nM99\n");
        assert_eq!(s.jump_to_program(5), Err(SourceError::DuplicateProgram));
    }

    #[test]
    fn file_and_memory_sources_give_the_same_actions() {
        let program = "G21 G90\nO100 sub\nG91 G1 X1 F600\nO100 endsub\n\
                       O100 call\nO101 repeat [3]\nO100 call\nO101 endrepeat\nM98 P200 L2\nM30\n\
                       O200\nG1 Y1\nM99\n";
        let setup = Setup::default();
        let (memory, err) = interpret(program.as_bytes(), &setup);
        assert_eq!(err, None);
        let (_p, s) = file(program);
        let from_file: Vec<Canon> = Actions::new(s, &setup.interp_config()).collect();
        assert_eq!(from_file, memory);
        assert!(memory.len() > 6, "{memory:?}");
    }
}

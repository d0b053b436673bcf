//! The interpreter: pulls lines from a [`ProgramSource`], executes each block in RS274NGC order and
//! hands out canonical actions one at a time.
//!
//! A block expands into a small queue of actions (spindle, coolant, motion, stop...); canned cycles
//! are expanded lazily by [`CycleRun`], and subprogram calls only move the source, so memory stays
//! bounded whatever the program does. A failing block restores the state saved before it and
//! produces no action.

use super::codes::*;
use super::comp::{Comp, Side};
use core::ops::ControlFlow;

use super::block::{
    letter_mask, parse_block_into, Block, BlockError, GGroup, MGroup, TRANSFORM_GROUPS,
};
use super::config::{ArcCenterMode, Dialect, DwellUnits, InterpConfig};
use super::cycles::{CycleBody, CycleRun};
use super::error::{ErrorCode, GcodeError};
use super::expand::{self, Assignments, Expanded};
use super::expr::{self, Cursor, Fx, ParamRead, ParamRef, ONE};
use super::geometry::{self, ArcTolerances};
use super::lexer::{Lexer, LineStart, Word, MICRO};
use super::oword::{self, Keyword, Label, OLine};
use super::params::{Params, LOCALS};
use super::source::{ProgramSource, SourceError};
use super::state::{CycleMemory, ModalState, MotionMode, Rollback};
use super::transform::ONE as FACTOR_ONE;
use crate::canon::{Action, ArcDir, Canon, PathMode, Plane, ProbeMode, Spindle, StopKind};
use crate::units::{Nm, Pos, MAX_AXES};

/// Capacity of the per-block action queue (a block expands to at most 10 actions; cycle steps to 7).
pub const QUEUE_CAPACITY: usize = 12;
/// Deepest subprogram nesting.
pub const MAX_NESTING: usize = 16;
/// Deepest G65 macro nesting (Fanuc allows 4 levels).
pub const MAX_MACRO_NESTING: usize = 4;

/// Fanuc G65 argument specification I: the variable each letter sets (0 = not an argument).
const G65_ARGUMENT: [u8; 26] = [
    1, 2, 3, 7, 8, 9, 0, 11, 4, 5, 6, 0, 0, 0, 0, 0, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26,
];
/// Largest coordinate magnitude accepted (100 m).
const MAX_COORD: Nm = 100_000_000_000_000 / 1000;
/// Largest axis word value (999999.999999 units).
const MAX_WORD: i64 = 999_999_999_999;
/// Largest F word (99 999 999 units/min: LinuxCNC takes CAM feeds such as `F2250000`; the planner
/// limits the speed to the axes' maximum anyway).
const MAX_FEED_WORD: i64 = 99_999_999 * MICRO;

const AXIS_LETTERS: [u8; MAX_AXES] = [b'X', b'Y', b'Z', b'A', b'B', b'C'];
/// Per axis `i`: the mask of the axis letters from `AXIS_LETTERS[i]` on, so a loop over the axes
/// stops after the block's last axis word (`target`: the usual XY line skips Z, A, B and C).
const AXIS_LETTERS_FROM: [u32; MAX_AXES] = {
    let mut masks = [0; MAX_AXES];
    let mut i = MAX_AXES;
    let mut mask = 0;
    while i > 0 {
        i -= 1;
        mask |= letter_mask(&[AXIS_LETTERS[i]]);
        masks[i] = mask;
    }
    masks
};
/// The axis words' mask ([`AXIS_LETTERS`] and the `@`/`^` polar words) for [`Block::has_any`].
const AXIS_WORDS: u32 = letter_mask(&AXIS_LETTERS) | letter_mask(b"@^");
/// [`AXIS_WORDS`] in three groups whose letters' slots are in the order X Y Z A B C @ ^, so the
/// first word of the first group the block has is the block's first axis word in that order.
const AXIS_WORDS_IN_ORDER: [u32; 3] =
    [letter_mask(b"XYZ"), letter_mask(b"ABC"), letter_mask(b"@^")];

/// What runs after the block's motion (and its canned cycle) is out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Post {
    None,
    Stop(StopKind, u32),
}

/// One subprogram call on the stack.
#[derive(Clone, Copy, Debug)]
struct Frame {
    /// Line to continue at after the last repeat.
    return_line: u32,
    /// First line of the subprogram (for repeats).
    start_line: u32,
    /// Repeats still to run, including the current one.
    remaining: u32,
    /// A G65 macro call: M99 gives the caller back its locals (the top of `macros`).
    macro_call: bool,
}

/// A G65 caller's local variables #1-#33 (bit mask of the set ones, values).
type SavedLocals = (u64, [Fx; LOCALS]);

/// Deepest `o.. call` nesting.
pub const MAX_O_CALLS: usize = 8;
/// Most O-word loops open at once.
pub const MAX_LOOPS: usize = 16;
/// Subroutine definitions remembered (label → line).
pub const MAX_SUBS: usize = 24;

/// What a skip over lines looks for (a false `if`, a `sub` definition, a `break`...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SkipTo {
    /// The `endsub` of a definition met in the flow.
    EndSub,
    /// The `sub` of a call to a subroutine not met yet.
    Sub,
    /// The next `elseif` (evaluated), `else` or `endif` of a false branch.
    IfBranch,
    /// The `endif` after a branch that ran.
    EndIf,
    EndWhile,
    EndRepeat,
    /// The `while` of a `do` loop: consumed after `break`, evaluated after `continue`.
    DoWhile {
        consume: bool,
    },
}

#[derive(Clone, Copy, Debug)]
struct Skip {
    label: Label,
    to: SkipTo,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LoopKind {
    While,
    Do,
    /// Repeats left, including the current one.
    Repeat(u32),
}

/// An open O-word loop: its label, kind and the line of its `while`/`do`/`repeat`.
#[derive(Clone, Copy, Debug)]
struct Loop {
    label: Label,
    kind: LoopKind,
    line: u32,
}

/// An `o.. call` on the stack: where to return and the caller's #1-#30.
#[derive(Clone, Copy, Debug)]
struct OCall {
    label: Label,
    return_line: u32,
    saved_mask: u32,
    saved: [Fx; 30],
    loops: u8,
}

/// What a line turned into.
enum Parsed {
    Nothing,
    /// A block to execute (filled into the caller's [`Block`]).
    Block,
    /// Continue at this line (an O-word loop or return).
    Jump(u32),
    /// Continue at the block with this N word (Fanuc `GOTO`).
    JumpSequence(u32),
}

/// Parameter reads for expressions at one call level.
struct Reader<'a> {
    params: &'a Params,
    level: u8,
    state: &'a ModalState,
    /// Inside a G65 macro: an unset local #1-#33 reads as vacant (Fanuc) instead of 0.
    in_macro: bool,
}

impl ParamRead for Reader<'_> {
    fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
        match p {
            ParamRef::Numbered(0) => Ok(expr::VACANT),
            ParamRef::Numbered(n)
                if self.in_macro && (1..=LOCALS as u16).contains(&n) && !self.params.is_set(n) =>
            {
                Ok(expr::VACANT)
            }
            _ => self.params.read(p, self.level, self.state),
        }
    }
    fn exists(&self, p: ParamRef) -> bool {
        self.params.exists(p, self.level)
    }
}

/// The actions of the current block (or cycle step) not handed out yet, oldest first: a ring
/// of fixed slots. Unlike a `heapless::Deque` it hands the oldest out by reference and takes
/// an action in place, so a short line's move is copied once in and once out (three copies of
/// ~100 bytes and the deque's bookkeeping cost ~500 Cortex-M4 instructions a line,
/// target-tests/src/bin/bench_motion.rs).
struct ActionQueue {
    slots: [Canon; QUEUE_CAPACITY],
    /// Slot of the oldest action.
    head: u8,
    len: u8,
}

impl ActionQueue {
    const fn new() -> Self {
        const FREE: Canon = Canon {
            line: 0,
            action: Action::Stop(StopKind::End),
        };
        ActionQueue {
            slots: [FREE; QUEUE_CAPACITY],
            head: 0,
            len: 0,
        }
    }

    fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    /// Appends `action` of `line`; `Err` when all slots are taken.
    #[inline]
    fn push_action(&mut self, line: u32, action: Action) -> Result<(), ()> {
        let len = self.len as usize;
        if len == QUEUE_CAPACITY {
            return Err(());
        }
        let mut at = self.head as usize + len;
        if at >= QUEUE_CAPACITY {
            at -= QUEUE_CAPACITY;
        }
        self.slots[at] = Canon { line, action };
        self.len += 1;
        Ok(())
    }

    /// Appends `canon`; `Err` when all slots are taken.
    fn push_back(&mut self, canon: Canon) -> Result<(), ()> {
        self.push_action(canon.line, canon.action)
    }

    /// Takes the oldest action out (its slot is free again once the reference is dropped).
    #[inline]
    fn pop_front(&mut self) -> Option<&Canon> {
        if self.len == 0 {
            return None;
        }
        let at = self.head as usize;
        self.head = if at + 1 == QUEUE_CAPACITY {
            0
        } else {
            at as u8 + 1
        };
        self.len -= 1;
        Some(&self.slots[at])
    }
}

/// The G-code interpreter (see the module documentation).
pub struct Interpreter {
    config: InterpConfig,
    state: ModalState,
    queue: ActionQueue,
    cycle: Option<CycleRun>,
    post: Post,
    stack: heapless::Vec<Frame, MAX_NESTING>,
    /// The locals of every G65 caller on `stack`, innermost last.
    macros: heapless::Vec<SavedLocals, MAX_MACRO_NESTING>,
    finished: bool,
    percent_lines: u8,
    restarts: u32,
    /// M98/M99 jumps since the last action handed out (endless-loop guard).
    jumps_without_action: u32,
    /// Line number of the last line read.
    last_line: u32,
    /// Numbered and named parameters.
    params: Params,
    /// Lines being skipped up to an O-word line.
    skip: Option<Skip>,
    loops: heapless::Vec<Loop, MAX_LOOPS>,
    ocalls: heapless::Vec<OCall, MAX_O_CALLS>,
    subs: heapless::Vec<(Label, u32), MAX_SUBS>,
    /// The current line was rewritten by parameter substitution (its columns no longer apply).
    expanded_line: bool,
    /// Cutter radius compensation and the moves it holds back (`comp.rs`).
    comp: Comp,
}

/// Most subprogram jumps without an action before the program is declared an endless loop.
pub const MAX_JUMPS_WITHOUT_ACTION: u32 = 10_000;

/// 11,600 B (measured): 10,360 B with the G65 locals stack of 4 levels × 33 values, and
/// 1,240 B for cutter compensation's look-ahead (`comp.rs`: up to 6 actions held back until
/// the next move decides the corner), hence 12 KiB.
const _: () = assert!(core::mem::size_of::<Interpreter>() <= 12 * 1024);

type Res<T> = Result<T, BlockError>;

fn err<T>(code: ErrorCode, word: Option<Word>) -> Res<T> {
    Err((code, word.map(|w| w.cols)))
}

impl Interpreter {
    /// A fresh interpreter for a setup (power-up modal state, offsets from the setup).
    pub fn new(config: &InterpConfig) -> Self {
        Interpreter {
            config: config.clone(),
            state: ModalState::new(config),
            queue: ActionQueue::new(),
            cycle: None,
            post: Post::None,
            stack: heapless::Vec::new(),
            macros: heapless::Vec::new(),
            finished: false,
            percent_lines: 0,
            restarts: 0,
            jumps_without_action: 0,
            last_line: 0,
            params: Params::new(),
            skip: None,
            loops: heapless::Vec::new(),
            ocalls: heapless::Vec::new(),
            subs: heapless::Vec::new(),
            expanded_line: false,
            comp: Comp::new(),
        }
    }

    /// The modal state and position after the last interpreted block (for status and resume).
    pub fn state(&self) -> &ModalState {
        &self.state
    }

    /// Replaces the modal state (resume from a line with a state rebuilt by the host).
    pub fn set_state(&mut self, state: ModalState) {
        self.state = state;
    }

    /// Block-delete switch (`/` blocks skipped when on).
    pub fn set_block_delete(&mut self, on: bool) {
        self.config.block_delete = on;
    }

    /// Optional-stop switch (M1 stops when on).
    pub fn set_optional_stop(&mut self, on: bool) {
        self.config.optional_stop = on;
    }

    /// The setup in use.
    pub fn config(&self) -> &InterpConfig {
        &self.config
    }

    /// True once M2/M30, the closing `%`, `E` or the end of the file was reached.
    pub fn is_finished(&self) -> bool {
        self.finished && self.queue.is_empty() && self.cycle.is_none() && self.post == Post::None
    }

    /// How many times M99 in the main program restarted it.
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Current subprogram nesting depth.
    pub fn call_depth(&self) -> usize {
        self.stack.len()
    }

    /// Starts the program again (after M30): keeps modal state, clears the call stack.
    pub fn rewind(&mut self) {
        self.queue.clear();
        self.cycle = None;
        self.post = Post::None;
        self.stack.clear();
        self.macros.clear();
        self.finished = false;
        self.percent_lines = 0;
        self.clear_control();
        self.comp.reset();
    }

    fn clear_control(&mut self) {
        self.skip = None;
        self.loops.clear();
        self.ocalls.clear();
    }

    /// A G38.x probe move has ended (docs/probing.md): the machine stands at `at` (machine nm) and
    /// the probe changed state at `tripped` (machine nm), or never did (`None`: the probe
    /// results hold the end position). Writes #5061-#5066 (the trip position, or where the
    /// move ended, in the program's coordinates and units as LinuxCNC does) and #5070 (1 when
    /// the probe tripped, else 0), and continues from `at`.
    pub fn probe_done(&mut self, at: Pos, tripped: Option<Pos>) {
        self.state.position = at;
        let found = tripped.unwrap_or(at);
        let offset = self.state.offset();
        for (i, (&m, &o)) in found.iter().zip(offset.iter()).enumerate() {
            let v = super::params::nm_to_fx(m - o, self.state.inch);
            let _ = self
                .params
                .write(ParamRef::Numbered(5061 + i as u16), v, 0, &mut self.state);
        }
        let ok = if tripped.is_some() { ONE } else { 0 };
        let _ = self
            .params
            .write(ParamRef::Numbered(5070), ok, 0, &mut self.state);
    }

    /// The value of a parameter as a program would read it (tests, status).
    pub fn parameter(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
        self.params.read(p, self.ocalls.len() as u8, &self.state)
    }

    /// The next canonical action, an error of the next bad block, or `None` at the end.
    /// After an error the next call continues with the following line.
    #[inline(never)]
    pub fn next(&mut self, src: &mut impl ProgramSource) -> Option<Result<Canon, GcodeError>> {
        loop {
            if let Some(&c) = self.queue.pop_front() {
                self.jumps_without_action = 0;
                return Some(Ok(c));
            }
            if let ControlFlow::Break(done) = self.refill(src) {
                return done;
            }
        }
    }

    /// One step of [`Interpreter::next`] while no action waits: a cycle step, a stop, the
    /// compensated moves held back at the end, or one line read and executed. `Break` hands
    /// `next` its answer. Not inlined: in `next`'s loop its ~90 pointers into `self` were
    /// computed again on every call (target-tests/src/bin/bench_motion.rs, per-line profile).
    #[inline(never)]
    fn refill(
        &mut self,
        src: &mut impl ProgramSource,
    ) -> ControlFlow<Option<Result<Canon, GcodeError>>> {
        if let Some(run) = self.cycle.as_mut() {
            let queue = &mut self.queue;
            let more = run.step(&mut |c| {
                // Capacity is guaranteed: the queue is empty when a step starts.
                let _ = queue.push_back(c);
            });
            if !more {
                self.cycle = None;
            }
            return ControlFlow::Continue(());
        }
        if let Post::Stop(kind, line) = self.post {
            self.post = Post::None;
            let _ = self.queue.push_back(Canon {
                line,
                action: Action::Stop(kind),
            });
            return ControlFlow::Continue(());
        }
        if self.comp.holds() && self.finished {
            // The program ended with compensated moves held back: they end as aimed.
            let queue = &mut self.queue;
            let released = self.comp.release(&mut |c| {
                let _ = queue.push_back(c);
            });
            if let Err(code) = released {
                self.comp.reset();
                self.finished = true;
                return ControlFlow::Break(Some(Err(GcodeError {
                    line: self.last_line,
                    n_word: None,
                    columns: None,
                    code,
                })));
            }
            return ControlFlow::Continue(());
        }
        if self.finished {
            return ControlFlow::Break(None);
        }
        let mut block = Block::new();
        let (line, parsed) = match src.next_line() {
            Some((line, bytes)) => {
                self.last_line = line;
                self.expanded_line = false;
                if self.skip.is_some() {
                    match self.skip_line(line, bytes) {
                        Ok(true) => return ControlFlow::Continue(()),
                        Ok(false) => {}
                        Err((code, columns)) => {
                            self.skip = None;
                            return ControlFlow::Break(Some(Err(GcodeError {
                                line,
                                n_word: None,
                                columns,
                                code,
                            })));
                        }
                    }
                }
                (line, self.parse_line(line, bytes, &mut block))
            }
            None => {
                if !src.is_exhausted() {
                    return ControlFlow::Break(None);
                }
                self.finished = true;
                if self.comp.holds() {
                    return ControlFlow::Continue(());
                }
                let open = match self.skip {
                    Some(Skip {
                        to: SkipTo::Sub, ..
                    }) => Some(ErrorCode::UnknownSubroutine),
                    Some(_) => Some(ErrorCode::UnbalancedBlock),
                    None if !self.loops.is_empty() || !self.ocalls.is_empty() => {
                        Some(ErrorCode::UnbalancedBlock)
                    }
                    None => None,
                };
                if let Some(code) = open {
                    self.clear_control();
                    return ControlFlow::Break(Some(Err(GcodeError {
                        line: self.last_line,
                        n_word: None,
                        columns: None,
                        code,
                    })));
                }
                if !self.stack.is_empty() {
                    self.stack.clear();
                    self.macros.clear();
                    return ControlFlow::Break(Some(Err(GcodeError {
                        line: self.last_line,
                        n_word: None,
                        columns: None,
                        code: ErrorCode::SubprogramWithoutM99,
                    })));
                }
                return ControlFlow::Break(None);
            }
        };
        match parsed {
            Ok(Parsed::Block) => {}
            Ok(Parsed::Nothing) => return ControlFlow::Continue(()),
            Ok(Parsed::Jump(to)) => {
                self.jumps_without_action += 1;
                if self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION {
                    self.finished = true;
                    self.clear_control();
                    return ControlFlow::Break(Some(Err(GcodeError {
                        line,
                        n_word: None,
                        columns: None,
                        code: ErrorCode::EndlessLoop,
                    })));
                }
                if let Err(e) = src.jump_to_line(to) {
                    self.finished = true;
                    return ControlFlow::Break(Some(Err(GcodeError {
                        line,
                        n_word: None,
                        columns: None,
                        code: match e {
                            SourceError::NotServed => ErrorCode::JumpNotServed,
                            _ => ErrorCode::SourceJumpFailed,
                        },
                    })));
                }
                return ControlFlow::Continue(());
            }
            Ok(Parsed::JumpSequence(n)) => {
                self.jumps_without_action += 1;
                let endless = self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION;
                if endless || src.jump_to_sequence(n).is_err() {
                    self.finished = true;
                    self.clear_control();
                    return ControlFlow::Break(Some(Err(GcodeError {
                        line,
                        n_word: None,
                        columns: None,
                        code: if endless {
                            ErrorCode::EndlessLoop
                        } else {
                            ErrorCode::SourceJumpFailed
                        },
                    })));
                }
                return ControlFlow::Continue(());
            }
            Err((n_word, (code, columns))) => {
                return ControlFlow::Break(Some(Err(GcodeError {
                    line,
                    n_word,
                    columns,
                    code,
                })))
            }
        };
        let tables = block.g_of(GGroup::NonModal).is_some()
            || block.g_of(GGroup::ToolLength).is_some()
            || block.has_g_in(TRANSFORM_GROUPS)
            || !block.m.is_empty();
        let saved = Rollback::of(&self.state, tables);
        let saved_finished = self.finished;
        let saved_comp = (!self.comp.is_idle()).then(|| self.comp.clone());
        match self.execute(&mut block, line, src) {
            Ok(()) => {}
            Err((code, columns)) => {
                let columns = if self.expanded_line { None } else { columns };
                saved.restore(&mut self.state);
                self.comp = saved_comp.unwrap_or_default();
                // An endless loop ends the program; other errors skip the block.
                self.finished = saved_finished || code == ErrorCode::EndlessLoop;
                self.queue.clear();
                self.cycle = None;
                self.post = Post::None;
                return ControlFlow::Break(Some(Err(GcodeError {
                    line,
                    n_word: block.n,
                    columns,
                    code,
                })));
            }
        }
        ControlFlow::Continue(())
    }
}

/// True if `bytes` may hold an O-word, a Fanuc keyword or a parameter: an `O`, `E`, `[` or `#`
/// (either case). Most lines have none, and then neither [`oword::parse`] nor the expansion
/// scan needs to look at them. Four bytes at a time: two byte-wise scans cost ~20 Cortex-M4
/// instructions a character (target-tests/src/bin/bench_motion.rs, `line_cost`).
fn may_be_control_or_expanded(bytes: &[u8]) -> bool {
    /// Nonzero if a byte of `v` is zero.
    fn zero_byte(v: u32) -> u32 {
        v.wrapping_sub(0x0101_0101) & !v & 0x8080_8080
    }
    const fn each(c: u8) -> u32 {
        c as u32 * 0x0101_0101
    }
    let special = |v: u32| {
        let folded = v | each(0x20);
        zero_byte(folded ^ each(b'o'))
            | zero_byte(folded ^ each(b'e'))
            | zero_byte(v ^ each(b'['))
            | zero_byte(v ^ each(b'#'))
    };
    let mut chunks = bytes.chunks_exact(4);
    for c in &mut chunks {
        if special(u32::from_le_bytes([c[0], c[1], c[2], c[3]])) != 0 {
            return true;
        }
    }
    chunks
        .remainder()
        .iter()
        .any(|&c| matches!(c | 0x20, b'o' | b'e') || matches!(c, b'[' | b'#'))
}

/// Plane axes for arcs: (first, second, normal), so that G2 turns first → second clockwise seen
/// from the positive normal axis.
fn arc_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

impl Interpreter {
    /// Reads one line: a block (into `block`, a new one), a control-flow jump or nothing.
    fn parse_line(
        &mut self,
        line: u32,
        bytes: &[u8],
        block: &mut Block,
    ) -> Result<Parsed, (Option<u32>, BlockError)> {
        let n_word = || super::source::leading_number(bytes, b"N");
        let mut lexer = Lexer::new(bytes, true);
        match lexer.start() {
            LineStart::Percent => {
                // Only the opening `%` may carry text (a program name); inside the program a
                // `% text` line is a bad character, as in rs274, never a silent end.
                let at = bytes.iter().position(|&c| c == b'%').unwrap_or(0);
                let text = bytes[at + 1..].iter().any(|c| !c.is_ascii_whitespace());
                if self.percent_lines >= 1 && text {
                    let cols = Some((at as u16, at as u16 + 1));
                    return Err((None, (ErrorCode::UnexpectedCharacter, cols)));
                }
                self.percent_lines = self.percent_lines.saturating_add(1);
                if self.percent_lines >= 2 {
                    self.finished = true;
                }
                return Ok(Parsed::Nothing);
            }
            LineStart::EndOfTape => {
                self.finished = true;
                return Ok(Parsed::Nothing);
            }
            LineStart::Block => {}
        }
        if lexer.block_delete && self.config.block_delete {
            return Ok(Parsed::Nothing);
        }
        if self.gixa() {
            return match parse_block_into(&mut lexer, &self.config, block) {
                Ok(()) if block.empty => Ok(Parsed::Nothing),
                Ok(()) => Ok(Parsed::Block),
                Err(e) => Err((n_word(), e)),
            };
        }
        let mut bytes = bytes;
        // Every O-word line has an `O`, and every Fanuc `GOTO`, `END`, `WHILE [` and `IF [` an
        // `O`, an `E` or a `[` (machine/src/gcode/oword.rs): most lines need not be parsed as one.
        let special = may_be_control_or_expanded(bytes);
        let control = special
            && bytes
                .iter()
                .any(|&c| matches!(c, b'O' | b'o' | b'E' | b'e' | b'['));
        let o_line = if control { oword::parse(bytes) } else { None };
        if let Some(o) = o_line {
            if o.keyword != Keyword::IfThen {
                return self.control(line, bytes, o).map_err(|e| (n_word(), e));
            }
            // Fanuc `IF [c] THEN statement`: the statement runs only when c is true.
            if self.o_value(bytes, &o).map_err(|e| (n_word(), e))? == 0 {
                return Ok(Parsed::Nothing);
            }
            bytes = &bytes[o.label as usize..];
            self.expanded_line = true;
        }
        let mut assignments = Assignments::new();
        let mut expanded = Expanded::new();
        // No `#` or `[` anywhere: nothing to expand (an `IF` line's statement is part of a line
        // that was `special`).
        let text: &[u8] = if special && expand::needs_expansion(bytes) {
            expand::expand(bytes, &self.reader(), &mut expanded, &mut assignments)
                .map_err(|(code, cols)| (n_word(), (code, Some(cols))))?;
            self.expanded_line = true;
            &expanded
        } else {
            bytes
        };
        // The line as read is lexed by the lexer that classified it (already past its start).
        let mut lexer = if self.expanded_line {
            let mut lexer = Lexer::new(text, true);
            lexer.start();
            lexer
        } else {
            lexer
        };
        match parse_block_into(&mut lexer, &self.config, block) {
            Ok(()) => {}
            Err((code, cols)) => {
                let cols = if self.expanded_line { None } else { cols };
                return Err((n_word(), (code, cols)));
            }
        }
        let level = self.ocalls.len() as u8;
        for &(p, v, at) in &assignments {
            let done = if v == expr::VACANT {
                self.params.make_vacant(p)
            } else {
                self.params.write(p, v, level, &mut self.state)
            };
            done.map_err(|code| (n_word(), (code, Some((at, at + 1)))))?;
        }
        Ok(if block.empty {
            Parsed::Nothing
        } else {
            Parsed::Block
        })
    }

    fn reader(&self) -> Reader<'_> {
        Reader {
            params: &self.params,
            level: self.ocalls.len() as u8,
            state: &self.state,
            in_macro: !self.macros.is_empty(),
        }
    }

    /// The value of the expression after an O-word keyword (`[#1 LT 3]`).
    fn o_value(&self, bytes: &[u8], o: &OLine) -> Res<Fx> {
        let mut c = Cursor::new(bytes, o.rest);
        if c.peek() != Some(b'[') {
            return Err((ErrorCode::ExpressionSyntax, Some(o.cols)));
        }
        expr::real_value(&mut c, &self.reader(), 0)
            .map_err(|(code, at)| (code, Some((at as u16, at as u16 + 1))))
    }

    fn start_skip(&mut self, label: Label, to: SkipTo) -> Res<Parsed> {
        self.skip = Some(Skip { label, to });
        Ok(Parsed::Nothing)
    }

    fn remember_sub(&mut self, label: Label, line: u32) -> Res<()> {
        match self.subs.iter_mut().find(|s| s.0 == label) {
            Some(s) => s.1 = line,
            None => self
                .subs
                .push((label, line))
                .map_err(|_| (ErrorCode::ParameterTableFull, None))?,
        }
        Ok(())
    }

    /// A line read while skipping: `Ok(true)` to go on skipping (or the line ended the skip and
    /// is consumed), `Ok(false)` to interpret this line normally.
    fn skip_line(&mut self, line: u32, bytes: &[u8]) -> Res<bool> {
        let (Some(o), Some(skip)) = (oword::parse(bytes), self.skip) else {
            return Ok(true);
        };
        if o.label != skip.label {
            return Ok(true);
        }
        let done = match (skip.to, o.keyword) {
            (SkipTo::EndSub, Keyword::EndSub)
            | (SkipTo::EndIf, Keyword::EndIf)
            | (SkipTo::EndWhile, Keyword::EndWhile)
            | (SkipTo::EndRepeat, Keyword::EndRepeat)
            | (SkipTo::IfBranch, Keyword::Else | Keyword::EndIf) => true,
            (SkipTo::Sub, Keyword::Sub) => {
                self.remember_sub(o.label, line)?;
                true
            }
            (SkipTo::IfBranch, Keyword::ElseIf) => self.o_value(bytes, &o)? != 0,
            (SkipTo::DoWhile { consume }, Keyword::While) => {
                self.skip = None;
                return Ok(consume);
            }
            _ => false,
        };
        if done {
            self.skip = None;
        }
        Ok(true)
    }

    /// Executes an O-word line (RS274NGC subroutines and control flow, LinuxCNC's dialect).
    fn control(&mut self, line: u32, bytes: &[u8], o: OLine) -> Res<Parsed> {
        let unbalanced = Err((ErrorCode::UnbalancedBlock, Some(o.cols)));
        let top = self.loops.last().copied().filter(|l| l.label == o.label);
        match o.keyword {
            Keyword::Sub => {
                self.remember_sub(o.label, line)?;
                self.start_skip(o.label, SkipTo::EndSub)
            }
            Keyword::EndSub | Keyword::Return => {
                let Some(call) = self.ocalls.pop() else {
                    return unbalanced;
                };
                if call.label != o.label {
                    return unbalanced;
                }
                self.params
                    .restore_args(call.saved_mask, &call.saved)
                    .map_err(|c| (c, None))?;
                self.params.drop_locals_above(self.ocalls.len() as u8);
                self.loops.truncate(call.loops as usize);
                Ok(Parsed::Jump(call.return_line))
            }
            Keyword::Call => {
                let mut args = [0 as Fx; 30];
                let mut count = 0usize;
                let mut c = Cursor::new(bytes, o.rest);
                while c.peek() == Some(b'[') {
                    if count == 30 {
                        return Err((ErrorCode::ExpressionSyntax, Some(o.cols)));
                    }
                    args[count] = expr::bracketed(&mut c, &self.reader(), 0)
                        .map_err(|(code, at)| (code, Some((at as u16, at as u16 + 1))))?;
                    count += 1;
                }
                if self.ocalls.is_full() {
                    return Err((ErrorCode::NestingTooDeep, Some(o.cols)));
                }
                let (saved_mask, saved) = self.params.save_args();
                let _ = self.ocalls.push(OCall {
                    label: o.label,
                    return_line: line + 1,
                    saved_mask,
                    saved,
                    loops: self.loops.len() as u8,
                });
                let mask = if count == 30 {
                    u32::MAX >> 2
                } else {
                    (1u32 << count) - 1
                };
                self.params
                    .restore_args(mask, &args)
                    .map_err(|c| (c, None))?;
                match self.subs.iter().find(|s| s.0 == o.label) {
                    Some(&(_, at)) => Ok(Parsed::Jump(at + 1)),
                    None => self.start_skip(o.label, SkipTo::Sub),
                }
            }
            Keyword::If => {
                if self.o_value(bytes, &o)? != 0 {
                    Ok(Parsed::Nothing)
                } else {
                    self.start_skip(o.label, SkipTo::IfBranch)
                }
            }
            Keyword::ElseIf | Keyword::Else => self.start_skip(o.label, SkipTo::EndIf),
            Keyword::EndIf => Ok(Parsed::Nothing),
            Keyword::While => {
                let go = self.o_value(bytes, &o)? != 0;
                match top {
                    Some(l) if l.kind == LoopKind::Do => {
                        if go {
                            Ok(Parsed::Jump(l.line + 1))
                        } else {
                            self.loops.pop();
                            Ok(Parsed::Nothing)
                        }
                    }
                    Some(l) if l.kind == LoopKind::While && l.line == line => {
                        if go {
                            Ok(Parsed::Nothing)
                        } else {
                            self.loops.pop();
                            self.start_skip(o.label, SkipTo::EndWhile)
                        }
                    }
                    _ if go => {
                        self.push_loop(o, LoopKind::While, line)?;
                        Ok(Parsed::Nothing)
                    }
                    _ => self.start_skip(o.label, SkipTo::EndWhile),
                }
            }
            Keyword::EndWhile => match top {
                Some(l) if l.kind == LoopKind::While => Ok(Parsed::Jump(l.line)),
                _ => unbalanced,
            },
            Keyword::Do => {
                self.push_loop(o, LoopKind::Do, line)?;
                Ok(Parsed::Nothing)
            }
            Keyword::Repeat => {
                let n = self.o_value(bytes, &o)?;
                let times = if n <= 0 {
                    0
                } else {
                    (n / ONE).min(u32::MAX as i64) as u32
                };
                if times == 0 {
                    return self.start_skip(o.label, SkipTo::EndRepeat);
                }
                self.push_loop(o, LoopKind::Repeat(times), line)?;
                Ok(Parsed::Nothing)
            }
            Keyword::EndRepeat => self.end_repeat(top, o),
            // As LinuxCNC: break and continue belong to while and do loops, not to repeat.
            Keyword::Goto => Ok(Parsed::JumpSequence(o.label as u32)),
            Keyword::IfGoto => Ok(if self.o_value(bytes, &o)? != 0 {
                Parsed::JumpSequence(o.label as u32)
            } else {
                Parsed::Nothing
            }),
            // Handled by `parse_line` before it gets here.
            Keyword::IfThen => Ok(Parsed::Nothing),
            Keyword::Break => {
                let to = match top.map(|l| l.kind) {
                    Some(LoopKind::While) => SkipTo::EndWhile,
                    Some(LoopKind::Do) => SkipTo::DoWhile { consume: true },
                    _ => return unbalanced,
                };
                self.loops.pop();
                self.start_skip(o.label, to)
            }
            Keyword::Continue => match top {
                Some(l) if l.kind == LoopKind::While => Ok(Parsed::Jump(l.line)),
                Some(l) if l.kind == LoopKind::Do => {
                    self.start_skip(o.label, SkipTo::DoWhile { consume: false })
                }
                _ => unbalanced,
            },
        }
    }

    fn push_loop(&mut self, o: OLine, kind: LoopKind, line: u32) -> Res<()> {
        self.loops
            .push(Loop {
                label: o.label,
                kind,
                line,
            })
            .map_err(|_| (ErrorCode::ParameterTableFull, Some(o.cols)))
    }

    fn end_repeat(&mut self, top: Option<Loop>, o: OLine) -> Res<Parsed> {
        match top {
            Some(Loop {
                kind: LoopKind::Repeat(left),
                line,
                ..
            }) => {
                if left > 1 {
                    if let Some(l) = self.loops.last_mut() {
                        l.kind = LoopKind::Repeat(left - 1);
                    }
                    Ok(Parsed::Jump(line + 1))
                } else {
                    self.loops.pop();
                    Ok(Parsed::Nothing)
                }
            }
            _ => Err((ErrorCode::UnbalancedBlock, Some(o.cols))),
        }
    }

    // Not inlined: it is called from every phase, and its compensation routing would be copied
    // into each (measured: flash of the F411 build).
    #[inline(never)]
    fn push(&mut self, line: u32, action: Action) -> Res<()> {
        if self.comp.catch(Canon { line, action }) {
            return Ok(());
        }
        if self.comp.holds() {
            // Behind a compensated move that waits for the next one.
            return self
                .comp
                .hold(Canon { line, action })
                .map_err(|c| (c, None));
        }
        self.queue
            .push_action(line, action)
            .map_err(|_| (ErrorCode::NotSupported, None))
    }

    /// Refuses what cannot happen while cutter compensation is on (as LinuxCNC).
    fn refuse_under_comp(&self, cols: Option<(u16, u16)>) -> Res<()> {
        if self.comp.is_on() {
            return Err((ErrorCode::CompForbidden, cols));
        }
        Ok(())
    }

    /// G10 L2/L20 of the active coordinate system (refused under compensation).
    fn g10_sets_active_system(&self, b: &Block) -> bool {
        let l = b.word(b'L').and_then(|w| w.integer());
        let p = b.word(b'P').and_then(|w| w.integer());
        matches!(l, Some(2 | 20))
            && matches!(p, Some(p) if p == 0 || p == self.state.work_system as i64 + 1)
    }

    /// Phase 4's G40, G41/G42 (D: a tool of the table, else the tool in the spindle) and
    /// G41.1/G42.1 (D: the diameter).
    fn cutter_compensation(&mut self, b: &mut Block) -> Res<()> {
        let Some(code) = b.g(GGroup::CutterComp) else {
            return Ok(());
        };
        let cols = Some(code.cols);
        let side = match code.code {
            G41 | G41_1 => Side::Left,
            G42 | G42_1 => Side::Right,
            _ => {
                let queue = &mut self.queue;
                let back = self
                    .comp
                    .turn_off(&mut |c| {
                        let _ = queue.push_back(c);
                    })
                    .map_err(|c| (c, cols))?;
                if let Some(programmed) = back {
                    // LinuxCNC continues from the programmed point (the exit move starts there).
                    let (first, second, _) = arc_axes(self.state.plane);
                    self.state.position[first] = programmed[first];
                    self.state.position[second] = programmed[second];
                }
                return Ok(());
            }
        };
        let d = b.take(b'D');
        let diameter = if matches!(code.code, G41_1 | G42_1) {
            let d = d.ok_or((ErrorCode::CompDiameterMissing, cols))?;
            if let Some(l) = b.word(b'L') {
                return err(ErrorCode::NotSupported, Some(l));
            }
            self.len_word(d)?
        } else {
            let number = match d {
                Some(w) => {
                    let v = w.integer().ok_or((ErrorCode::NotAnInteger, Some(w.cols)))?;
                    if v < 0 {
                        return err(ErrorCode::ValueOutOfRange, Some(w));
                    }
                    Self::integer(w, 99_999_999)? as u32
                }
                None => self.state.tool_loaded,
            };
            if number == 0 {
                0
            } else {
                self.config
                    .tool(number)
                    .ok_or((ErrorCode::ToolNotInTable, d.map(|w| w.cols).or(cols)))?
                    .diameter
            }
        };
        // One mirrored plane axis swaps G41 and G42 (compensation runs on the transformed path).
        let (first, second, _) = arc_axes(self.state.plane);
        let side = match (side, self.state.xf.flips(first, second)) {
            (Side::Left, true) => Side::Right,
            (Side::Right, true) => Side::Left,
            (side, false) => side,
        };
        self.comp
            .turn_on(side, diameter / 2, self.state.plane)
            .map_err(|c| (c, cols))
    }

    fn gixa(&self) -> bool {
        self.config.dialect == Dialect::Gixa
    }

    /// A length word in program units to nm (inch: ×25.4, rounded to the nearest nm).
    fn len(&self, value: i64) -> Nm {
        if self.state.inch {
            geometry::div_round(value as i128 * 254, 10) as Nm
        } else {
            value
        }
    }

    /// An axis word to nm (linear) or 1e-6 degree (rotary), range-checked.
    fn axis_value(&self, axis: usize, w: Word) -> Res<Nm> {
        if w.value.abs() > MAX_WORD {
            return err(ErrorCode::NumberOutOfRange, Some(w));
        }
        Ok(if axis >= 3 {
            w.value
        } else if self.state.inch {
            // Nine decimals of an inch (expressions give them): 10^-9 in × 25.4 = nm / 39370.
            let exact = w.value as i128 * 1000 + w.nano as i128;
            geometry::div_round(exact * 254, 10_000) as Nm
        } else {
            w.value
        })
    }

    fn len_word(&self, w: Word) -> Res<Nm> {
        self.axis_value(0, w)
    }

    fn integer(w: Word, max: i64) -> Res<i64> {
        let v = w.integer().ok_or((ErrorCode::NotAnInteger, Some(w.cols)))?;
        if v < 0 || v > max {
            return err(ErrorCode::ValueOutOfRange, Some(w));
        }
        Ok(v)
    }

    /// Dwell time of a P (or Fanuc X) word in microseconds.
    fn dwell_us(&self, w: Word) -> Res<u64> {
        if w.value < 0 {
            return err(ErrorCode::ValueOutOfRange, Some(w));
        }
        let v = w.value as u64;
        Ok(if self.gixa() {
            // Hundredths of a second.
            v / 100
        } else {
            match self.config.dwell_units {
                DwellUnits::Seconds => v,
                DwellUnits::FanucIntegerMillis if w.has_point => v,
                DwellUnits::FanucIntegerMillis => v / 1000,
            }
        })
    }

    /// The machine end point of a move from the block's axis words (consumed), with LinuxCNC's
    /// polar coordinates (`@` radius, `^` angle about the XY origin) for X and Y, written over
    /// `to` (the current position on entry). Written through a reference: returned in a
    /// `Res<Pos>` it was copied byte by byte several times per line on the Cortex-M4.
    fn target(&self, b: &mut Block, g53: bool, to: &mut Pos) -> Res<()> {
        let polar = self.polar_words(b)?;
        // `to` is the program point plus the offsets (no transform) unless in G53.
        if let Some((radius, angle, cols)) = polar {
            if g53 {
                return Err((ErrorCode::NotSupported, Some(cols)));
            }
            let at = |i: usize| to[i] - self.state.axis_offset(i);
            let (x, y) = geometry::polar_end((at(0), at(1)), radius, angle, self.state.absolute)
                .map_err(|c| (c, Some(cols)))?;
            to[0] = x + self.state.axis_offset(0);
            to[1] = y + self.state.axis_offset(1);
        }
        for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
            if !b.has_any(AXIS_LETTERS_FROM[i]) {
                break;
            }
            if !b.has(letter) {
                continue;
            }
            if let Some(w) = b.take(letter) {
                let v = self.axis_value(i, w)?;
                let m = if g53 {
                    v
                } else if self.state.absolute {
                    v + self.state.axis_offset(i)
                } else {
                    to[i] + v
                };
                if m.abs() > MAX_COORD {
                    return err(ErrorCode::CoordinateOverflow, Some(w));
                }
                to[i] = m;
            }
        }
        Ok(())
    }

    /// Where a move's target starts: the position, or under a transform the program point plus
    /// the offsets (docs/gcode-transforms.md).
    #[inline(never)]
    /// Written through a reference, as [`Interpreter::target`].
    fn start_point(&self, to: &mut Pos) {
        *to = self.state.position;
        if self.state.xf.active() {
            *to = self.state.program_point();
            for (i, v) in to.iter_mut().enumerate() {
                *v += self.state.axis_offset(i);
            }
        }
    }

    /// The machine end point of a straight move from the block's axis words, written over `to`
    /// (a `Res<Pos>` return was copied byte by byte on the Cortex-M4).
    fn move_target(&mut self, b: &mut Block, g53: bool, to: &mut Pos) -> Res<()> {
        if g53 {
            *to = self.state.position;
        } else {
            self.start_point(to);
        }
        self.target(b, g53, to)?;
        if !g53 {
            self.transform(to)?;
        }
        Ok(())
    }

    /// The transform pipeline: a program point plus offsets (from [`Interpreter::target`]) to
    /// machine coordinates, X, Y, Z mirrored, scaled and rotated (drilling axis `keep` not
    /// scaled). The end point of a block (`end`) also becomes the position's program point.
    #[inline(never)]
    fn xf_point(&mut self, to: &mut Pos, keep: usize, end: bool) -> Res<()> {
        let off: [Nm; 3] = core::array::from_fn(|i| self.state.axis_offset(i));
        let p: [Nm; 3] = core::array::from_fn(|i| to[i] - off[i]);
        let w = self.state.xf.forward(p, keep);
        for i in 0..3 {
            to[i] = w[i] + off[i];
            if to[i].abs() > MAX_COORD {
                return Err((ErrorCode::CoordinateOverflow, None));
            }
        }
        if end {
            self.state.xf_prog = p;
            self.state.xf_at = w;
        }
        Ok(())
    }

    /// [`Interpreter::xf_point`] for the block's end point when a transform is in force.
    #[inline(always)]
    fn transform(&mut self, to: &mut Pos) -> Res<()> {
        if self.state.xf.active() {
            self.xf_point(to, 3, true)?;
        }
        Ok(())
    }

    /// Checks of a block under (or setting) a transform, before phase 0: G51 alone, no plane
    /// change under G68, no G92/G52/G10 L20 under a transform; and G16's X and Y become `@`
    /// and `^` (LinuxCNC's polar words about the XY origin) where they are a move's end point.
    #[inline(never)]
    fn check_transforms(&mut self, b: &mut Block) -> Res<()> {
        let xf = self.state.xf;
        if let Some(c) = b.g(GGroup::Scaling).filter(|c| c.code == G51) {
            // Hurco §3.18: G51 stands alone.
            let alone = !b.has_g_besides(GGroup::Scaling)
                && b.m.is_empty()
                && b.has_only(const { letter_mask(b"IJKPXYZ") });
            if !alone {
                return Err((ErrorCode::TransformNotAlone, Some(c.cols)));
            }
        }
        if let Some(p) = b.g(GGroup::Plane) {
            // G17, G18, G19 in the order of `Plane`.
            let same = p.code == G17 + 10 * self.state.plane as u16;
            if xf.rotating && !same && b.g_of(GGroup::Rotation) != Some(G69) {
                return Err((ErrorCode::TransformPlane, Some(p.cols)));
            }
        }
        let nonmodal = b.g(GGroup::NonModal);
        if let Some(g) = nonmodal {
            let moves_frame = matches!(g.code, G52 | G92 | G92_1 | G92_2 | G92_3)
                || (g.code == G10 && b.word(b'L').is_some_and(|w| w.value == 20 * MICRO));
            if moves_frame && xf.active() {
                return Err((ErrorCode::TransformOffset, Some(g.cols)));
            }
        }
        // G16 (in this block or before): X is the radius, Y the angle, the `@` and `^` words of
        // LinuxCNC's polar coordinates (about the XY origin), except where X and Y are not a
        // move's end point.
        let polar = b
            .g_of(GGroup::Polar)
            .map_or(self.state.xf.polar, |c| c == G16);
        if polar
            && nonmodal.is_none()
            && !b.has_g_in(TRANSFORM_GROUPS & !(1 << GGroup::Polar as u16))
            && b.g_of(GGroup::ToolLength) != Some(G43_1)
            && b.has_any(const { letter_mask(b"XY") })
        {
            let x = b.word(b'X');
            if b.g_of(GGroup::Plane)
                .map_or(self.state.plane != Plane::XY, |p| p != G17)
                || (x.is_some()
                    && b.g_of(GGroup::Distance)
                        .map_or(!self.state.absolute, |d| d == G91))
                || !b.rename(b'X', b'@')
                || !b.rename(b'Y', b'^')
            {
                return err(ErrorCode::NotSupported, x.or(b.word(b'Y')));
            }
        }
        Ok(())
    }

    /// Phase 5b: G50.1/G51.1 mirror, G50/G51 scaling, G68/G69 rotation, G15/G16 polar mode.
    /// Cancels run first (G69, G50, G50.1), then the settings in pipeline order. The X, Y, Z
    /// words are absolute program coordinates: the mirror axes, the scaling or rotation centre.
    #[inline(never)]
    fn set_transforms(&mut self, b: &mut Block) -> Res<()> {
        let p = self.state.program_point();
        let mut xf = self.state.xf;
        let (sc, rot, mir) = (
            b.g_of(GGroup::Scaling).unwrap_or(0),
            b.g_of(GGroup::Rotation).unwrap_or(0),
            b.g_of(GGroup::Mirror).unwrap_or(0),
        );
        if let Some(c) = b.g(GGroup::Polar) {
            xf.polar = c.code == G16;
        }
        let cols = b
            .g(GGroup::Scaling)
            .or(b.g(GGroup::Rotation))
            .or(b.g(GGroup::Mirror))
            .map(|c| c.cols);
        if cols.is_some() {
            self.refuse_under_comp(cols)?;
        }
        // The X, Y, Z words (absolute) over the program point, and which were given.
        let mut centre = [p[0], p[1], p[2]];
        let mut named = 0u8;
        for (i, v) in centre.iter_mut().enumerate() {
            if let Some(w) = b.take(AXIS_LETTERS[i]) {
                *v = bounded(self.axis_value(i, w)?, w)?;
                named |= 1 << i;
            }
        }
        let fanuc_int = self.config.dwell_units == DwellUnits::FanucIntegerMillis;
        // A G51 factor or G68 angle word: with the Fanuc integer setting, a number without a
        // decimal point is in thousandths.
        let value = |w: Word| -> i64 {
            if fanuc_int && !w.has_point {
                w.value / 1000
            } else {
                w.value
            }
        };
        let order = Err((ErrorCode::TransformOrder, cols));
        let bad = Err((ErrorCode::TransformValue, cols));
        if rot == G69 {
            xf.rotating = false;
        }
        if sc != 0 {
            if xf.rotating || (sc == G51 && xf.scaling()) {
                return order;
            }
            xf.factor = [FACTOR_ONE; 3];
        }
        if mir != 0 {
            if xf.rotating || xf.scaling() {
                return order;
            }
            if mir == G51_1 {
                if named == 0 {
                    return bad;
                }
                xf.mirror |= named;
                for (i, v) in centre.iter().enumerate() {
                    if named >> i & 1 != 0 {
                        xf.mirror_twice[i] = 2 * v;
                    }
                }
            } else {
                xf.mirror &= if named == 0 { 0 } else { !named };
            }
        } else if named != 0 && sc != G51 && rot != G68 {
            return Err((ErrorCode::UnusedWord, cols));
        }
        // A centre is a program point: it goes through the stages before its own (G51 stands
        // alone, so at most one of the two below runs).
        let c = xf.forward(centre, 3);
        if sc == G51 {
            // 0: not given; -1: not positive.
            let factor = |w: Word| {
                let v = value(w);
                if v > 0 && v < 1000 * FACTOR_ONE as i64 {
                    v as i32
                } else {
                    -1
                }
            };
            let mut f = [0; 3];
            for (v, l) in f.iter_mut().zip(b"IJK") {
                if let Some(w) = b.take(*l) {
                    *v = factor(w);
                }
            }
            if let Some(w) = b.take(b'P') {
                if f != [0; 3] {
                    return bad;
                }
                f = [factor(w); 3];
            } else if f[1..] == [0, 0] {
                // Hurco: I alone scales every axis.
                f = [f[0]; 3];
            } else {
                f = f.map(|v| if v == 0 { FACTOR_ONE } else { v });
            }
            if f.iter().any(|&v| v <= 0) {
                return bad;
            }
            xf.scale_center = c;
            xf.factor = f;
        }
        if rot == G68 {
            if xf.rotating {
                return order;
            }
            let (f, s, n) = arc_axes(self.state.plane);
            let Some(r) = b.take(b'R') else { return bad };
            let mut angle = value(r);
            if named >> n & 1 != 0 || angle.abs() > 360 * MICRO {
                return bad;
            }
            // One mirrored plane axis reverses the angle.
            if xf.flips(f, s) {
                angle = -angle;
            }
            xf.rot_axes = (f as u8, s as u8);
            xf.rot_center = (c[f], c[s]);
            xf.set_angle(angle);
            xf.rotating = true;
        }
        xf.update();
        self.state.xf = xf;
        // The tool stays where it is; its program point stays what the program last wrote.
        self.state.xf_prog = [p[0], p[1], p[2]];
        self.state.xf_at =
            core::array::from_fn(|i| self.state.position[i] - self.state.axis_offset(i));
        Ok(())
    }

    /// The block's polar words (`@` radius in nm, `^` angle in 10⁻⁶ degree, their columns),
    /// consumed; refused beside X or Y.
    fn polar_words(&self, b: &mut Block) -> Res<Option<PolarWords>> {
        if !b.has(b'@') && !b.has(b'^') {
            return Ok(None);
        }
        let (r, a) = (b.take(b'@'), b.take(b'^'));
        let Some(first) = r.or(a) else {
            return Ok(None);
        };
        if let Some(w) = b.word(b'X').or(b.word(b'Y')) {
            return err(ErrorCode::AxisWordsConflict, Some(w));
        }
        let radius = r.map(|w| self.len_word(w)).transpose()?;
        Ok(Some((radius, a.map(|w| w.value), first.cols)))
    }

    /// Feed (nm/min, or 1e-6 deg/min for rotary-only moves) of a straight feed move.
    fn straight_feed(&self, from: &Pos, to: &Pos, f_given: bool) -> Res<i64> {
        let d = |i: usize| to[i] - from[i];
        let linear = (0..3).any(|i| d(i) != 0);
        let rotary = (3..MAX_AXES).any(|i| d(i) != 0);
        if self.state.inverse_time {
            if !f_given {
                return err(ErrorCode::InverseTimeFeedMissing, None);
            }
            if self.state.feed == 0 {
                return err(ErrorCode::ZeroFeedRate, None);
            }
            let length = if linear || !rotary {
                geometry::hypot3(d(0), d(1), d(2))
            } else {
                geometry::hypot3(d(3), d(4), d(5))
            };
            return self.inverse_time_feed(length as i128);
        }
        if self.state.feed == 0 {
            return err(ErrorCode::ZeroFeedRate, None);
        }
        Ok(if !linear && rotary {
            self.state.feed
        } else {
            self.len(self.state.feed)
        })
    }

    fn inverse_time_feed(&self, length: i128) -> Res<i64> {
        let feed = crate::arith::div_i128(length * self.state.feed as i128, MICRO as i128);
        if feed > i64::MAX as i128 / 4 {
            return err(ErrorCode::CoordinateOverflow, None);
        }
        Ok((feed as i64).max(1))
    }

    fn execute(&mut self, b: &mut Block, line: u32, src: &mut impl ProgramSource) -> Res<()> {
        let gixa = self.gixa();
        if b.g_of(GGroup::NonModal) == Some(G65) && !gixa {
            // Every letter of a G65 block is an argument, axis letters included.
            return self.macro_call(b, line, src);
        }
        if b.has_g_in(TRANSFORM_GROUPS) || self.state.xf.active() || self.state.xf.polar {
            self.check_transforms(b)?;
        }
        // The RS274NGC order of execution, one phase each.
        let pre = self.check_block(b)?;
        let s_word = self.set_feed_speed_tool(b)?;
        self.switch_tool_spindle_coolant(b, line, s_word)?;
        self.dwell(b, line, &pre)?;
        self.set_plane_units_tool_length(b)?;
        self.set_modes(b, line)?;
        if b.has_g_in(TRANSFORM_GROUPS) {
            self.set_transforms(b)?;
        }
        let tool_write = self.apply_nonmodal(b, line, pre.nonmodal)?;
        self.move_block(b, line, &pre)?;
        // M98's P and L words, taken before the unused-word check (a pair of words returned
        // through `Res` was copied byte by byte on the Cortex-M4).
        let (call_p, call_l) = if b.has_m(98) {
            (b.take(b'P'), b.take(b'L'))
        } else {
            (None, None)
        };
        self.finish_block(b, tool_write)?;
        // 9. stops and program flow
        self.flow(b, line, src, call_p, call_l)
    }

    /// Phase 0: checks that concern the whole block (axes the machine has, cutter compensation,
    /// axis words with and without a motion) and what the later phases need to know of it.
    fn check_block(&mut self, b: &mut Block) -> Res<Prelude> {
        let gixa = self.gixa();
        for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
            if i >= self.config.axis_count as usize && b.has(letter) {
                if let Some(w) = b.word(letter) {
                    return err(ErrorCode::AxisNotConfigured, Some(w));
                }
            }
        }
        if gixa && b.has_m(98) {
            if let Some(o) = b.word(b'O') {
                return err(ErrorCode::NotSupported, Some(o));
            }
        }
        if b.has(b'O') {
            b.take(b'O');
        }
        let nonmodal = b.g_of(GGroup::NonModal);
        // Fanuc: G4 X<time> is a dwell, not a move.
        let dwell_word = if nonmodal == Some(G4) {
            match b.take(b'P') {
                Some(p) => Some(p),
                None if !gixa => b.take(b'X'),
                None => None,
            }
        } else {
            None
        };
        let motion_g = b.g(GGroup::Motion);
        let first_axis = AXIS_WORDS_IN_ORDER
            .iter()
            .find_map(|&mask| b.first_word(mask));
        let nonmodal_axes = matches!(nonmodal, Some(G10 | G28 | G30 | G52 | G92))
            || b.g_of(GGroup::ToolLength) == Some(G43_1)
            || b.g_of(GGroup::Scaling) == Some(G51)
            || b.g_of(GGroup::Rotation) == Some(G68)
            || b.g(GGroup::Mirror).is_some();
        if nonmodal_axes {
            if let Some(m) = motion_g {
                if m.code != G80 {
                    return Err((ErrorCode::AxisWordsConflict, Some(m.cols)));
                }
            }
        }
        let motion = match motion_g {
            Some(m) => Some(decode_motion(m.code)),
            None if first_axis.is_some() && !nonmodal_axes => Some(self.state.motion),
            None => None,
        };
        if motion == Some(MotionMode::None) && !nonmodal_axes && !(gixa && motion_g.is_some()) {
            if let Some(w) = first_axis {
                return err(ErrorCode::AxisWordsWithoutMotion, Some(w));
            }
        }
        let f_given = b.has(b'F');
        if b.cancels_cycle {
            self.state.cycle = CycleMemory::default();
        }
        Ok(Prelude {
            nonmodal,
            dwell_word,
            motion_g,
            motion,
            f_given,
        })
    }

    /// Phase 1: feed mode, F, S and T. Returns the S word (phase 2 re-sends the spindle for it).
    fn set_feed_speed_tool(&mut self, b: &mut Block) -> Res<Option<Word>> {
        match b.g_of(GGroup::FeedMode) {
            Some(G93) => self.state.inverse_time = true,
            Some(G94) => {
                // LinuxCNC: leaving inverse time leaves no feed rate (an F must follow).
                if self.state.inverse_time {
                    self.state.feed = 0;
                }
                self.state.inverse_time = false;
            }
            _ => {}
        }
        if let Some(w) = b.take(b'F') {
            if w.value < 0 {
                return err(ErrorCode::ValueOutOfRange, Some(w));
            }
            if w.value > MAX_FEED_WORD {
                return err(ErrorCode::NumberOutOfRange, Some(w));
            }
            self.state.feed = w.value;
        }
        let s_word = b.take(b'S');
        if let Some(w) = s_word {
            if w.value < 0 {
                return err(ErrorCode::ValueOutOfRange, Some(w));
            }
            self.state.rpm = ((w.value + MICRO / 2) / MICRO).min(u32::MAX as i64) as u32;
        }
        if let Some(w) = b.take(b'T') {
            let t = Self::integer(w, 99_999_999)? as u32;
            // LinuxCNC: with a tool table in the setup, T names one of its tools (or is T0).
            if t != 0 && self.config.tools[0].number != 0 && self.config.tool(t).is_none() {
                return err(ErrorCode::ToolNotInTable, Some(w));
            }
            self.state.tool_selected = t;
        }
        Ok(s_word)
    }

    /// Phase 2: M6, spindle, coolant and user M codes, in RS274NGC order.
    fn switch_tool_spindle_coolant(
        &mut self,
        b: &mut Block,
        line: u32,
        s_word: Option<Word>,
    ) -> Res<()> {
        if b.has_m(6) {
            self.refuse_under_comp(b.m.iter().find(|(_, c)| c.code == 6).map(|(_, c)| c.cols))?;
            self.state.tool_loaded = self.state.tool_selected;
            let tool = self.state.tool_loaded;
            self.move_to_tool_change(line)?;
            self.push(line, Action::ToolChange { tool })?;
        }
        let spindle_m =
            b.m.iter()
                .find(|(g, _)| *g == MGroup::Spindle)
                .map(|(_, c)| c.code);
        if let Some(code) = spindle_m {
            self.state.spindle = match code {
                3 => Spindle::Cw,
                4 => Spindle::Ccw,
                _ => Spindle::Off,
            };
        }
        if spindle_m.is_some() || (s_word.is_some() && self.state.spindle != Spindle::Off) {
            let (state, rpm) = (self.state.spindle, self.state.rpm);
            self.push(line, Action::Spindle { state, rpm })?;
        }
        if b.m.iter().any(|(g, _)| *g == MGroup::Coolant) {
            if b.has_m(9) {
                self.state.mist = false;
                self.state.flood = false;
            }
            if b.has_m(7) {
                self.state.mist = true;
            }
            if b.has_m(8) {
                self.state.flood = true;
            }
            let (mist, flood) = (self.state.mist, self.state.flood);
            self.push(line, Action::Coolant { mist, flood })?;
        }
        let mut user_codes: heapless::Vec<u16, 5> = heapless::Vec::new();
        for (g, c) in b.m.iter() {
            if *g == MGroup::User {
                let _ = user_codes.push(c.code);
            }
        }
        for code in user_codes {
            self.push(
                line,
                Action::UserMCode {
                    code,
                    at_rest: false,
                },
            )?;
        }
        Ok(())
    }

    /// M6 with a tool-change position in the setup: spindle and coolant off, then rapids in
    /// machine coordinates, Z (the tool axis) alone first, then the other axes named. The next
    /// programmed move starts from there (LinuxCNC's `CHANGE_TOOL` makes one straight move to
    /// its `TOOL_CHANGE_POSITION` and continues from it; Gantry lifts Z first so the tool leaves
    /// the work before anything moves sideways). docs/probing.md "Tool change".
    fn move_to_tool_change(&mut self, line: u32) -> Res<()> {
        let place = self.config.tool_change_position;
        let axis_count = self.config.axis_count as usize;
        let named = |i: usize| i < axis_count && place.axes & (1 << i) != 0;
        if !(0..MAX_AXES).any(named) {
            return Ok(());
        }
        // Only what is on is switched off: a first `T1 M6` with nothing on queues nothing before
        // its rapids, so a change position beyond the travel ends the job with error 900 at the
        // M6 before anything moves (board/mod.rs `soft_limit`).
        if self.state.spindle != Spindle::Off {
            self.state.spindle = Spindle::Off;
            let rpm = self.state.rpm;
            self.push(
                line,
                Action::Spindle {
                    state: Spindle::Off,
                    rpm,
                },
            )?;
        }
        if self.state.mist || self.state.flood {
            self.state.mist = false;
            self.state.flood = false;
            self.push(
                line,
                Action::Coolant {
                    mist: false,
                    flood: false,
                },
            )?;
        }
        const TOOL_AXIS: usize = 2;
        let mut to = self.state.position;
        for only_z in [true, false] {
            for i in (0..MAX_AXES).filter(|&i| named(i) && (i == TOOL_AXIS) == only_z) {
                to[i] = place.at[i];
            }
            if to != self.state.position {
                self.push(line, Action::Rapid { to })?;
                self.state.position = to;
            }
        }
        Ok(())
    }

    /// Phase 3: dwell (G4; stored for the next cycle in the gixa dialect).
    fn dwell(&mut self, b: &Block, line: u32, pre: &Prelude) -> Res<()> {
        let (nonmodal, dwell_word) = (pre.nonmodal, pre.dwell_word);
        let gixa = self.gixa();
        if nonmodal == Some(G4) {
            let w = dwell_word.ok_or((ErrorCode::DwellTimeMissing, b.g_cols(G4)))?;
            let micros = self.dwell_us(w)?;
            if gixa {
                self.state.stored_dwell_us = micros;
            } else {
                self.push(line, Action::Dwell { micros })?;
            }
        }
        Ok(())
    }

    /// Phase 4: plane, units, cutter compensation and tool length offset.
    fn set_plane_units_tool_length(&mut self, b: &mut Block) -> Res<()> {
        if let Some(p) = b.g(GGroup::Plane) {
            let same = matches!(
                (p.code, self.state.plane),
                (G17, Plane::XY) | (G18, Plane::ZX)
            );
            if self.comp.is_on() && !same {
                return Err((ErrorCode::CompPlane, Some(p.cols)));
            }
        }
        match b.g_of(GGroup::Plane) {
            Some(G17) => self.state.plane = Plane::XY,
            Some(G18) => self.state.plane = Plane::ZX,
            Some(G19) => self.state.plane = Plane::YZ,
            _ => {}
        }
        if let Some(code) = b.g_of(GGroup::Units) {
            let inch = code == G20;
            if inch != self.state.inch && !self.state.inverse_time {
                // The feed keeps its physical value (LinuxCNC converts the feed in force).
                let f = self.state.feed as i128;
                self.state.feed = if inch {
                    geometry::div_round(f * 10, 254)
                } else {
                    geometry::div_round(f * 254, 10)
                } as i64;
            }
            self.state.inch = inch;
        }
        self.cutter_compensation(b)?;
        if let Some(t) = b.g(GGroup::ToolLength) {
            self.refuse_under_comp(Some(t.cols))?;
        }
        match b.g_of(GGroup::ToolLength) {
            Some(G43) => {
                let h = b.take(b'H');
                let number = match h {
                    Some(w) => Self::integer(w, 99_999_999)? as u32,
                    None => self.state.tool_loaded,
                };
                let length = if number == 0 {
                    0
                } else {
                    self.config
                        .tool(number)
                        .ok_or((
                            ErrorCode::ToolNotInTable,
                            h.map(|w| w.cols).or(b.g_cols(G43)),
                        ))?
                        .length
                };
                self.state.tool_offset = [0, 0, length, 0, 0, 0];
            }
            Some(G43_1) => {
                let mut offset = [0; MAX_AXES];
                for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
                    if let Some(w) = b.take(letter) {
                        offset[i] = bounded(self.axis_value(i, w)?, w)?;
                    }
                }
                self.state.tool_offset = offset;
            }
            Some(G49) => self.state.tool_offset = [0; MAX_AXES],
            _ => {}
        }
        Ok(())
    }

    /// Phase 5: coordinate system, path mode, distance modes and retract mode.
    fn set_modes(&mut self, b: &mut Block, line: u32) -> Res<()> {
        for group in [GGroup::Coordinate, GGroup::Path, GGroup::Return] {
            if let Some(c) = b.g(group) {
                self.refuse_under_comp(Some(c.cols))?;
            }
        }
        if let Some(code) = b.g_of(GGroup::Coordinate) {
            self.state.work_system = match code {
                G54..=G59 => ((code - G54) / 10) as u8,
                c => (c - G59_1 + 6) as u8,
            };
        }
        match b.g_of(GGroup::Path) {
            Some(G61) | Some(G61_1) => {
                self.state.path = PathMode::ExactStop;
                self.push(line, Action::PathMode(PathMode::ExactStop))?;
            }
            Some(G64) => {
                let tolerance = match b.take(b'P') {
                    Some(w) if w.value < 0 => return err(ErrorCode::ValueOutOfRange, Some(w)),
                    Some(w) => self.len_word(w)?,
                    None => 0,
                };
                // Q (LinuxCNC's naive-CAM collinearity tolerance) is accepted: the planner
                // does not merge segments, so it has no effect here.
                if let Some(q) = b.take(b'Q') {
                    if q.value < 0 {
                        return err(ErrorCode::ValueOutOfRange, Some(q));
                    }
                }
                self.state.path = PathMode::Blend { tolerance };
                self.push(line, Action::PathMode(self.state.path))?;
            }
            _ => {}
        }
        match b.g_of(GGroup::Distance) {
            Some(G90) => self.state.absolute = true,
            Some(G91) => self.state.absolute = false,
            _ => {}
        }
        match b.g_of(GGroup::ArcDistance) {
            Some(G90_1) => self.state.arc_absolute = true,
            Some(G91_1) => self.state.arc_absolute = false,
            _ => {}
        }
        match b.g_of(GGroup::Return) {
            Some(G98) => self.state.retract_to_r = false,
            Some(G99) => self.state.retract_to_r = true,
            _ => {}
        }
        Ok(())
    }

    /// Phase 6: the G10 / G28 / G30 / G52 / G92 family. Returns a G10 L1 tool length to be
    /// written once the whole block is known to be valid (phase 8).
    fn apply_nonmodal(
        &mut self,
        b: &mut Block,
        line: u32,
        nonmodal: Option<u16>,
    ) -> Res<Option<(u32, Nm)>> {
        let mut tool_write = None;
        if matches!(
            nonmodal,
            Some(G28 | G30 | G28_1 | G30_1 | G52 | G92 | G92_1 | G92_2 | G92_3)
        ) || (nonmodal == Some(G10) && self.g10_sets_active_system(b))
        {
            self.refuse_under_comp(nonmodal.and_then(|g| b.g_cols(g)))?;
        }
        match nonmodal {
            Some(G10) => tool_write = self.set_work_offset(b)?,
            Some(G52) => {
                // LinuxCNC: G52 sets the same offset as G92, to the values given.
                if !AXIS_LETTERS.iter().any(|&l| b.has(l)) {
                    return Err((ErrorCode::MissingAxisWords, b.g_cols(G52)));
                }
                for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
                    if let Some(word) = b.take(letter) {
                        self.state.g92[i] = bounded(self.axis_value(i, word)?, word)?;
                    }
                }
                self.state.g92_saved = self.state.g92;
            }
            Some(G28) | Some(G30) => {
                let home = if nonmodal == Some(G28) {
                    self.state.g28
                } else {
                    self.state.g30
                };
                let named: [bool; MAX_AXES] = core::array::from_fn(|i| b.has(AXIS_LETTERS[i]));
                let mut via = [0; MAX_AXES];
                self.move_target(b, false, &mut via)?;
                self.push(line, Action::Rapid { to: via })?;
                let mut to = via;
                let any = named.iter().any(|&n| n);
                for i in 0..MAX_AXES {
                    if named[i] || (!any && i < self.config.axis_count as usize) {
                        to[i] = home[i];
                    }
                }
                self.push(line, Action::Rapid { to })?;
                self.state.position = to;
            }
            Some(G28_1) => self.state.g28 = self.state.position,
            Some(G30_1) => self.state.g30 = self.state.position,
            Some(G92) => {
                if !AXIS_LETTERS.iter().any(|&l| b.has(l)) {
                    return Err((ErrorCode::MissingAxisWords, b.g_cols(G92)));
                }
                let w = self.state.work_offsets[self.state.work_system as usize];
                for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
                    if let Some(word) = b.take(letter) {
                        let v = self.axis_value(i, word)?;
                        self.state.g92[i] = bounded(
                            self.state.position[i] - w[i] - self.state.tool_offset[i] - v,
                            word,
                        )?;
                    }
                }
                self.state.g92_saved = self.state.g92;
            }
            Some(G92_1) => {
                self.state.g92 = [0; MAX_AXES];
                self.state.g92_saved = [0; MAX_AXES];
            }
            Some(G92_2) => self.state.g92 = [0; MAX_AXES],
            Some(G92_3) => self.state.g92 = self.state.g92_saved,
            _ => {}
        }
        Ok(tool_write)
    }

    /// Phase 7: the motion of the block.
    fn move_block(&mut self, b: &mut Block, line: u32, pre: &Prelude) -> Res<()> {
        let g53 = pre.nonmodal == Some(G53);
        let (motion, motion_g, f_given) = (pre.motion, pre.motion_g, pre.f_given);
        if let Some(mode) = motion {
            if g53
                && (!matches!(mode, MotionMode::Rapid | MotionMode::Linear) || !self.state.absolute)
            {
                return Err((ErrorCode::G53Invalid, b.g_cols(G53)));
            }
            self.motion(b, line, mode, motion_g.is_some(), g53, f_given)?;
        }
        Ok(())
    }

    /// Phase 8: every word must have been used; then a G10 L1 tool length is written.
    fn finish_block(&mut self, b: &Block, tool_write: Option<(u32, Nm)>) -> Res<()> {
        if let Some(l) = b.letters().next() {
            return err(ErrorCode::UnusedWord, b.word(l));
        }
        if let Some((tool, length)) = tool_write {
            if !self.config.set_tool(tool, length) {
                return Err((ErrorCode::G10Invalid, b.g_cols(G10)));
            }
        }
        Ok(())
    }

    /// G10 L2/L20 (work offsets, applied now) and G10 L1 (tool length, returned to be written
    /// once the whole block is known to be valid).
    fn set_work_offset(&mut self, b: &mut Block) -> Res<Option<(u32, Nm)>> {
        let g10 = b.g_cols(G10);
        let l = b.take(b'L').ok_or((ErrorCode::G10Invalid, g10))?;
        let p = b.take(b'P').ok_or((ErrorCode::G10Invalid, g10))?;
        let l_value = l.integer().ok_or((ErrorCode::G10Invalid, Some(l.cols)))?;
        let p_value = p.integer().ok_or((ErrorCode::G10Invalid, Some(p.cols)))?;
        if l_value == 1 {
            // Tool table: P tool, Z length (R, the radius, is accepted and unused).
            if !(1..=99_999_999).contains(&p_value) {
                return err(ErrorCode::G10Invalid, Some(p));
            }
            b.take(b'R');
            for &letter in b"XYABC" {
                if let Some(w) = b.word(letter) {
                    return err(ErrorCode::NotSupported, Some(w));
                }
            }
            let z = b.take(b'Z').ok_or((ErrorCode::MissingAxisWords, g10))?;
            let length = bounded(self.len_word(z)?, z)?;
            return Ok(Some((p_value as u32, length)));
        }
        if !(0..=9).contains(&p_value) {
            return err(ErrorCode::G10Invalid, Some(p));
        }
        if let Some(r) = b.word(b'R') {
            return err(ErrorCode::NotSupported, Some(r));
        }
        let index = if p_value == 0 {
            self.state.work_system as usize
        } else {
            p_value as usize - 1
        };
        for (i, &letter) in AXIS_LETTERS.iter().enumerate() {
            if let Some(w) = b.take(letter) {
                let v = self.axis_value(i, w)?;
                let value = match l_value {
                    2 => v,
                    20 => {
                        self.state.position[i] - self.state.g92[i] - self.state.tool_offset[i] - v
                    }
                    _ => return err(ErrorCode::G10Invalid, Some(l)),
                };
                self.state.work_offsets[index][i] = bounded(value, w)?;
            }
        }
        if l_value != 2 && l_value != 20 {
            return err(ErrorCode::G10Invalid, Some(l));
        }
        Ok(None)
    }

    fn motion(
        &mut self,
        b: &mut Block,
        line: u32,
        mode: MotionMode,
        explicit: bool,
        g53: bool,
        f_given: bool,
    ) -> Res<()> {
        let straight_or_arc = matches!(
            mode,
            MotionMode::Rapid | MotionMode::Linear | MotionMode::ArcCw | MotionMode::ArcCcw
        );
        if straight_or_arc && (explicit || !matches!(self.state.motion, MotionMode::Cycle(_))) {
            self.state.cycle = CycleMemory::default();
        }
        let compensated = straight_or_arc && self.comp.applies();
        if compensated && g53 {
            return Err((ErrorCode::CompForbidden, b.g_cols(G53)));
        }
        if matches!(mode, MotionMode::ArcCw | MotionMode::ArcCcw) {
            self.comp.check_arc().map_err(|c| (c, None))?;
        } else if straight_or_arc {
            self.comp.straight_done();
        }
        // Where the tool stands (copied only under compensation).
        let tool = if compensated {
            let tool = self.state.position;
            // The block's programmed move is computed from the programmed point and caught.
            self.state.position = self.comp.program_base(tool);
            self.comp.start_catching();
            Some(tool)
        } else {
            None
        };
        let sets_mode = self.plain_motion(b, line, mode, explicit, g53, f_given)?;
        if let Some(tool) = tool {
            self.state.position = match self.comp.caught() {
                Some(canon) => {
                    let queue = &mut self.queue;
                    self.comp
                        .motion(canon, tool, self.state.inch, &mut |c| {
                            let _ = queue.push_back(c);
                        })
                        .map_err(|c| (c, None))?
                }
                None => tool,
            };
        }
        if sets_mode {
            self.state.motion = mode;
        }
        Ok(())
    }

    /// The motion of a block as programmed (compensation aside); false when the block leaves
    /// the motion mode as it is (gixa G80).
    fn plain_motion(
        &mut self,
        b: &mut Block,
        line: u32,
        mode: MotionMode,
        explicit: bool,
        g53: bool,
        f_given: bool,
    ) -> Res<bool> {
        let gixa = self.gixa();
        match mode {
            MotionMode::Rapid => {
                // As LinuxCNC, an explicit G0 without axis words is a zero-length move.
                let has_axes = b.has_any(AXIS_WORDS);
                let mut to = [0; MAX_AXES];
                self.move_target(b, g53, &mut to)?;
                if has_axes || explicit {
                    self.push(line, Action::Rapid { to })?;
                }
                self.state.position = to;
            }
            MotionMode::Linear => {
                let has_axes = b.has_any(AXIS_WORDS);
                let mut to = [0; MAX_AXES];
                self.move_target(b, g53, &mut to)?;
                if has_axes || explicit {
                    let feed = self.straight_feed(&self.state.position, &to, f_given)?;
                    self.push(line, Action::Feed { to, feed })?;
                }
                self.state.position = to;
            }
            MotionMode::ArcCw | MotionMode::ArcCcw => {
                self.arc(b, line, mode == MotionMode::ArcCw, f_given)?;
            }
            MotionMode::Probe(code) => {
                // LinuxCNC refuses probing under cutter compensation too.
                self.refuse_under_comp(b.g_cols(code))?;
                let mut to = [0; MAX_AXES];
                self.move_target(b, g53, &mut to)?;
                if self.state.inverse_time {
                    return Err((ErrorCode::ProbeInverseTime, b.g_cols(code)));
                }
                if to == self.state.position {
                    return Err((ErrorCode::ProbeZeroLength, b.g_cols(code)));
                }
                let feed = self.straight_feed(&self.state.position, &to, f_given)?;
                let mode = ProbeMode {
                    toward: matches!(code, G38_2 | G38_3),
                    must_trip: matches!(code, G38_2 | G38_4),
                };
                self.push(line, Action::Probe { to, feed, mode })?;
                // Where the probe stops is known only once it has run: the board sets the
                // position then (`Interpreter::probe_done`).
                self.state.position = to;
            }
            MotionMode::None => {
                self.state.cycle = CycleMemory::default();
                if gixa && explicit {
                    self.state.motion = self.state.motion_before_cycle;
                    return Ok(false);
                }
            }
            MotionMode::Cycle(code) => {
                if explicit && !b.has_any(AXIS_WORDS) {
                    return Err((ErrorCode::MissingAxisWords, b.g_cols(code)));
                }
                self.refuse_under_comp(b.g_cols(code))?;
                self.cycle(b, line, code)?;
                if !matches!(self.state.motion, MotionMode::Cycle(_)) {
                    self.state.motion_before_cycle = self.state.motion;
                }
            }
        }
        Ok(true)
    }

    #[inline(never)]
    fn arc(&mut self, b: &mut Block, line: u32, cw: bool, f_given: bool) -> Res<()> {
        let gixa = self.gixa();
        let plane = self.state.plane;
        let (first, second, normal) = arc_axes(plane);
        // Centre words for the first and second plane axes.
        let (w_first, w_second, wrong): (Option<Word>, Option<Word>, Option<Word>);
        let mut absolute_center = self.state.arc_absolute;
        if gixa {
            if let Some(r) = b.word(b'R') {
                return err(ErrorCode::NotSupported, Some(r));
            }
            // I: X centre (Y in G19); J: Y centre in G17, Z centre in G18/G19.
            let i = b.take(b'I');
            let j = b.take(b'J');
            let (for_x_or_y, for_y_or_z) = (i, j);
            let map = |axis: usize| -> Option<Word> {
                match (plane, axis) {
                    (Plane::XY, 0) | (Plane::ZX, 0) | (Plane::YZ, 1) => for_x_or_y,
                    _ => for_y_or_z,
                }
            };
            w_first = map(first);
            w_second = map(second);
            wrong = b.word(b'K');
            if let Some(w) = wrong {
                return err(ErrorCode::ArcOffsetWrongPlane, Some(w));
            }
            absolute_center = match self.config.gixa.arc_centers {
                ArcCenterMode::Absolute => true,
                ArcCenterMode::Incremental => false,
                ArcCenterMode::FollowsDistanceMode => self.state.absolute,
            };
            if w_first.is_none() && w_second.is_none() {
                return Err((ErrorCode::ArcCenterMissing, None));
            }
        } else {
            let letter = |axis: usize| [b'I', b'J', b'K'][axis];
            let has_ijk = b.has(b'I') || b.has(b'J') || b.has(b'K');
            let r = b.word(b'R');
            if r.is_none() && !has_ijk {
                return Err((ErrorCode::ArcCenterMissing, None));
            }
            if let (Some(r), true) = (r, has_ijk) {
                return err(ErrorCode::ArcMixedFormats, Some(r));
            }
            wrong = b.word(letter(normal));
            w_first = b.take(letter(first));
            w_second = b.take(letter(second));
        }
        if let Some(w) = wrong {
            return err(ErrorCode::ArcOffsetWrongPlane, Some(w));
        }
        if self.state.inverse_time && !f_given {
            return err(ErrorCode::InverseTimeFeedMissing, None);
        }
        if self.state.feed == 0 {
            return err(ErrorCode::ZeroFeedRate, None);
        }
        let turns = match b.take(b'P') {
            Some(p) if gixa => return err(ErrorCode::UnusedWord, Some(p)),
            Some(p) => match p.integer() {
                Some(t) if (1..=1_000_000).contains(&t) => t as u32,
                _ => return err(ErrorCode::ArcTurnsInvalid, Some(p)),
            },
            None => 1,
        };
        let r_word = if gixa { None } else { b.take(b'R') };
        if r_word.is_some()
            && !b.has(AXIS_LETTERS[first])
            && !b.has(AXIS_LETTERS[second])
            && !b.has_any(const { letter_mask(b"@^") })
        {
            return Err((ErrorCode::ArcEndPointMissing, r_word.map(|w| w.cols)));
        }
        // The arc as programmed (program points plus offsets), then through the transforms.
        let mut start = [0; MAX_AXES];
        self.start_point(&mut start);
        let mut to = start;
        self.target(b, false, &mut to)?;
        let offset = self.state.offset();
        let tol = ArcTolerances::for_units(self.state.inch);
        let s2 = (start[first], start[second]);
        let e2 = (to[first], to[second]);
        let mut center = match r_word {
            Some(r) => {
                let radius = self.len_word(r)?;
                geometry::r_format_center(s2, e2, radius, cw, tol).map_err(|c| (c, Some(r.cols)))?
            }
            None => {
                let value = |w: Option<Word>, axis: usize| -> Res<Nm> {
                    match w {
                        Some(w) => {
                            let v = self.len_word(w)?;
                            Ok(if absolute_center {
                                v + offset[axis]
                            } else {
                                start[axis] + v
                            })
                        }
                        None if absolute_center => Err((ErrorCode::ArcAbsoluteCenterMissing, None)),
                        None => Ok(start[axis]),
                    }
                };
                let c = (value(w_first, first)?, value(w_second, second)?);
                geometry::check_center_arc(s2, e2, c, tol)
                    .map_err(|code| (code, w_first.or(w_second).map(|w| w.cols)))?;
                c
            }
        };
        let mut cw = cw;
        if self.state.xf.active() {
            let xf = &self.state.xf;
            if xf.factor[first] != xf.factor[second] {
                return Err((ErrorCode::TransformArcScaled, None));
            }
            cw ^= xf.flips(first, second);
            let mut c = to;
            (c[first], c[second]) = center;
            self.xf_point(&mut c, 3, false)?;
            center = (c[first], c[second]);
            self.transform(&mut to)?;
        }
        let start = self.state.position;
        let feed = if self.state.inverse_time {
            let (s2, e2) = ((start[first], start[second]), (to[first], to[second]));
            let sweep = geometry::sweep(s2, e2, center, !cw, turns);
            let radius = geometry::hypot(s2.0 - center.0, s2.1 - center.1);
            let length = geometry::arc_length(sweep, radius, to[normal] - start[normal]);
            self.inverse_time_feed(length)?
        } else {
            self.len(self.state.feed)
        };
        let mut c3 = [0; 3];
        c3[first] = center.0;
        c3[second] = center.1;
        c3[normal] = start[normal];
        self.push(
            line,
            Action::Arc {
                to,
                center: c3,
                plane,
                dir: if cw { ArcDir::Cw } else { ArcDir::Ccw },
                turns,
                feed,
            },
        )?;
        self.state.position = to;
        Ok(())
    }

    #[inline(never)]
    fn cycle(&mut self, b: &mut Block, line: u32, code: u16) -> Res<()> {
        let gixa = self.gixa();
        let g_cols = b.g_cols(code);
        let body = match (gixa, code) {
            (false, G73) => CycleBody::PeckChipBreak,
            (_, G81) => CycleBody::Drill,
            (_, G82) => CycleBody::DrillDwell,
            (_, G83) => CycleBody::PeckFull,
            (_, G84) | (false, G74) => CycleBody::Tap,
            (_, G85) => CycleBody::Bore,
            (false, G86) => CycleBody::BoreSpindleStop,
            (true, G86) => CycleBody::DrillPause,
            (true, G87) => CycleBody::PeckChipBreak,
            (true, G88) => CycleBody::Punch,
            (false, G87) => CycleBody::BackBore,
            (false, G88) => CycleBody::BoreManualRetract,
            (_, G89) => CycleBody::BoreDwell,
            _ => return Err((ErrorCode::CycleNotSupported, g_cols)),
        };
        if self.state.inverse_time {
            return Err((ErrorCode::CycleInverseTime, g_cols));
        }
        for &letter in &AXIS_LETTERS[3..] {
            if let Some(w) = b.word(letter) {
                return err(ErrorCode::CycleRotaryAxis, Some(w));
            }
        }
        if self.state.feed == 0 && body != CycleBody::Punch {
            return Err((ErrorCode::ZeroFeedRate, g_cols));
        }
        let (a, bx, c) = arc_axes(self.state.plane);
        let same = self.state.motion == MotionMode::Cycle(code);
        // Under a transform the hole positions are program points; the drilling axis is neither
        // mirrored nor scaled (Hurco §3.18), so its level is where the tool is.
        let on = self.state.xf.active();
        if self.state.xf.mirror >> c & 1 != 0 {
            return Err((ErrorCode::NotSupported, g_cols));
        }
        let mut prog = self.state.program_point();
        prog[c] = self.state.position[c] - self.state.axis_offset(c);
        let offset = self.state.offset();
        let mem = self.state.cycle;
        let polar = if self.state.plane == Plane::XY {
            self.polar_words(b)?
        } else {
            None
        };
        let a_w = b.take(AXIS_LETTERS[a]);
        let b_w = b.take(AXIS_LETTERS[bx]);
        let c_w = b.take(AXIS_LETTERS[c]);
        let r_w = b.take(b'R');
        let a_v = a_w.map(|w| self.axis_value(a, w)).transpose()?;
        let b_v = b_w.map(|w| self.axis_value(bx, w)).transpose()?;
        let initial = mem.initial_level.unwrap_or(prog[c]);
        let r_raw = match r_w {
            Some(w) => self.len_word(w)?,
            None if same || gixa => mem.r.unwrap_or(0),
            None => return Err((ErrorCode::CycleRMissing, g_cols)),
        };
        let depth_raw = match c_w {
            Some(w) => self.len_word(w)?,
            None => match mem.depth {
                Some(d) if same || gixa => d,
                _ if body == CycleBody::Punch => 0,
                _ => return Err((ErrorCode::CycleDepthMissing, g_cols)),
            },
        };
        // G87: offsets on the plane axes and the middle level, each on the I/J/K letter of its axis
        // (so K is not a repeat count here). LinuxCNC keeps them for the following G87 blocks.
        let mut back_bore = mem.back_bore;
        if body == CycleBody::BackBore {
            let mut raw = [0; 3];
            for (slot, axis) in raw.iter_mut().zip([a, bx, c]) {
                let letter = b"IJK"[axis];
                *slot = match b.take(letter) {
                    Some(w) => self.len_word(w)?,
                    None => match mem.back_bore {
                        Some(m) if same => m[axis],
                        _ => return Err((ErrorCode::CycleBackBoreWordMissing, g_cols)),
                    },
                };
            }
            let mut kept = [0; 3];
            for (slot, axis) in raw.into_iter().zip([a, bx, c]) {
                kept[axis] = slot;
            }
            back_bore = Some(kept);
        }
        let mut repeats = 1u32;
        if !gixa {
            if let Some(w) = b.take(b'L').or_else(|| b.take(b'K')) {
                repeats = w
                    .integer()
                    .filter(|v| (0..=1_000_000).contains(v))
                    .ok_or((ErrorCode::CycleRepeatInvalid, Some(w.cols)))?
                    as u32;
            }
        }
        let (mut aa, mut bb) = (0, 0);
        let mut polar_step = None;
        if let (Some((radius, angle, cols)), false) = (polar, gixa) {
            let at = (prog[a], prog[bx]);
            if self.state.absolute {
                (aa, bb) =
                    geometry::polar_end(at, radius, angle, true).map_err(|c| (c, Some(cols)))?;
            } else {
                geometry::polar_end(at, radius, angle, false).map_err(|c| (c, Some(cols)))?;
                polar_step = Some((radius.unwrap_or(0), angle.unwrap_or(0)));
            }
        }
        let (aa, bb, inc, r, bottom) = if gixa {
            let (aa, bb) = if self.state.absolute {
                (a_v.unwrap_or(prog[a]), b_v.unwrap_or(prog[bx]))
            } else {
                (prog[a] + a_v.unwrap_or(0), prog[bx] + b_v.unwrap_or(0))
            };
            let (r, bottom) = if self.state.absolute {
                (r_raw, depth_raw)
            } else {
                let r = initial - r_raw.abs();
                (r, r - depth_raw.abs())
            };
            (aa, bb, (0, 0), r, bottom)
        } else if self.state.absolute {
            if polar.is_none() {
                aa = a_v.unwrap_or(prog[a]);
                bb = b_v.unwrap_or(prog[bx]);
            }
            (aa, bb, (0, 0), r_raw, depth_raw)
        } else {
            let r = r_raw + initial;
            (
                prog[a],
                prog[bx],
                (a_v.unwrap_or(0), b_v.unwrap_or(0)),
                r,
                r + depth_raw,
            )
        };
        if r < bottom && body != CycleBody::Punch {
            return Err((
                ErrorCode::CycleRBelowBottom,
                r_w.or(c_w).map(|w| w.cols).or(g_cols),
            ));
        }
        for v in [aa, bb, r, bottom] {
            if v.abs() > MAX_COORD {
                return Err((ErrorCode::CoordinateOverflow, g_cols));
            }
        }
        if (inc.0.abs() as i128 + inc.1.abs() as i128) * repeats as i128 > MAX_COORD as i128 {
            return Err((ErrorCode::CoordinateOverflow, g_cols));
        }
        // Body parameters.
        let mut q = 0;
        if matches!(body, CycleBody::PeckFull | CycleBody::PeckChipBreak) {
            let q_w = b.take(b'Q');
            q = match q_w {
                Some(w) => self.len_word(w)?,
                None if same || gixa => mem.q.unwrap_or(0),
                None => 0,
            };
            if q <= 0 {
                return Err((ErrorCode::CycleQInvalid, q_w.map(|w| w.cols).or(g_cols)));
            }
            if gixa && body == CycleBody::PeckChipBreak && q <= self.config.gixa.partial_retract {
                return Err((
                    ErrorCode::CyclePeckNotAboveRetract,
                    q_w.map(|w| w.cols).or(g_cols),
                ));
            }
        }
        let mut dwell_us = 0;
        if gixa {
            dwell_us = self.state.stored_dwell_us;
        } else if matches!(
            body,
            CycleBody::DrillDwell
                | CycleBody::BoreSpindleStop
                | CycleBody::BoreDwell
                | CycleBody::BoreManualRetract
                | CycleBody::Tap
        ) {
            dwell_us = match b.take(b'P') {
                Some(w) => self.dwell_us(w)?,
                None if same || body == CycleBody::Tap => mem.dwell_us.unwrap_or(0),
                None => return Err((ErrorCode::CycleDwellMissing, g_cols)),
            };
        }
        if !gixa {
            let ok = match body {
                // G74 taps left-handed: down with M4, reversed to M3 at the bottom.
                CycleBody::Tap if code == G74 => self.state.spindle == Spindle::Ccw,
                CycleBody::Tap => self.state.spindle == Spindle::Cw,
                CycleBody::BoreSpindleStop | CycleBody::BackBore | CycleBody::BoreManualRetract => {
                    self.state.spindle != Spindle::Off
                }
                _ => true,
            };
            if !ok {
                return Err((ErrorCode::CycleSpindleState, g_cols));
            }
        }
        self.state.cycle = CycleMemory {
            r: Some(r_raw),
            depth: Some(depth_raw),
            q: if q > 0 { Some(q) } else { mem.q },
            dwell_us: Some(dwell_us),
            initial_level: Some(initial),
            back_bore,
        };
        if repeats == 0 {
            return Ok(());
        }
        let raise_first = !gixa && initial < r;
        if raise_first {
            // LinuxCNC: a tool below R first rises to R where it stands.
            // (The drilling axis is neither mirrored, scaled nor turned by a transform.)
            let mut to = self.state.position;
            to[c] = r + offset[c];
            self.push(line, Action::Rapid { to })?;
        }
        let mut program = prog;
        program[a] = aa;
        program[bx] = bb;
        if raise_first {
            program[c] = r;
        }
        let mut run = CycleRun::new(line, body, gixa, (a, bx, c), program, offset, repeats);
        run.xf = self.state.xf;
        run.inc = inc;
        run.polar_step = polar_step;
        run.r = r;
        run.bottom = bottom;
        let old_c = if !gixa && initial < r { r } else { initial };
        run.clear = if self.state.retract_to_r { r } else { old_c };
        run.q = q;
        run.clearance = match (gixa, body) {
            (true, CycleBody::PeckFull) => 0,
            (true, _) => self.config.gixa.partial_retract,
            (false, _) => self.config.peck_clearance,
        };
        run.dwell_us = dwell_us;
        if let (CycleBody::BackBore, Some(m)) = (body, back_bore) {
            run.back_bore_offset = (m[a], m[bx]);
            // K (the drilling-axis letter) is absolute in G90 and relative to the bottom in G91.
            run.middle = if self.state.absolute {
                m[c]
            } else {
                bottom + m[c]
            };
        }
        run.feed = self.len(self.state.feed);
        run.spindle = self.state.spindle;
        run.rpm = self.state.rpm;
        let end = run.final_program_position();
        let mut machine = end;
        for (v, o) in machine.iter_mut().zip(offset) {
            *v += o;
        }
        if on {
            self.xf_point(&mut machine, c, true)?;
        }
        self.state.position = machine;
        if body == CycleBody::Tap && gixa {
            // The spindle ends as it started.
        }
        self.cycle = Some(run);
        Ok(())
    }

    fn flow(
        &mut self,
        b: &Block,
        line: u32,
        src: &mut impl ProgramSource,
        call_p: Option<Word>,
        call_l: Option<Word>,
    ) -> Res<()> {
        let Some(&(_, code)) = b.m.iter().find(|(g, _)| *g == MGroup::Flow) else {
            return Ok(());
        };
        if matches!(code.code, 0 | 1 | 2 | 30) {
            // A stop releases the compensated moves held back (LinuxCNC `convert_stop`).
            let queue = &mut self.queue;
            self.comp
                .release(&mut |c| {
                    let _ = queue.push_back(c);
                })
                .map_err(|c| (c, Some(code.cols)))?;
        }
        match code.code {
            0 => self.post = Post::Stop(StopKind::Pause, line),
            1 if self.config.optional_stop => {
                self.post = Post::Stop(StopKind::OptionalPause, line);
            }
            2 | 30 => {
                let kind = if code.code == 2 {
                    StopKind::End
                } else {
                    StopKind::EndRewind
                };
                self.post = Post::Stop(kind, line);
                self.state.reset_at_program_end(&self.config);
                self.comp.reset();
                self.stack.clear();
                self.macros.clear();
                self.clear_control();
                self.finished = true;
            }
            98 | 99 => {
                self.jumps_without_action += 1;
                if self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION {
                    self.finished = true;
                    self.stack.clear();
                    self.macros.clear();
                    return Err((ErrorCode::EndlessLoop, Some(code.cols)));
                }
            }
            _ => {}
        }
        match code.code {
            98 => {
                self.call(line, code.cols, src, call_p, call_l, false)?;
            }
            99 => {
                let result = match self.stack.last_mut() {
                    Some(top) if top.remaining > 1 => {
                        top.remaining -= 1;
                        src.jump_to_line(top.start_line)
                    }
                    Some(_) => {
                        let frame = self.stack.pop().unwrap_or(Frame {
                            return_line: 1,
                            start_line: 1,
                            remaining: 0,
                            macro_call: false,
                        });
                        if frame.macro_call {
                            if let Some((mask, values)) = self.macros.pop() {
                                self.params
                                    .restore_locals(mask, &values)
                                    .map_err(|c| (c, Some(code.cols)))?;
                            }
                        }
                        src.jump_to_line(frame.return_line)
                    }
                    None => {
                        self.restarts = self.restarts.saturating_add(1);
                        self.percent_lines = 0;
                        src.jump_to_line(1)
                    }
                };
                result.map_err(|e| {
                    let code_of = match e {
                        SourceError::NotServed => ErrorCode::JumpNotServed,
                        _ => ErrorCode::SourceJumpFailed,
                    };
                    (code_of, Some(code.cols))
                })?;
            }
            _ => {}
        }
        Ok(())
    }

    fn call(
        &mut self,
        line: u32,
        cols: (u16, u16),
        src: &mut impl ProgramSource,
        p: Option<Word>,
        l: Option<Word>,
        macro_call: bool,
    ) -> Res<bool> {
        let p = p.ok_or((ErrorCode::SubprogramPMissing, Some(cols)))?;
        let mut repeats = match l {
            Some(w) => Self::integer(w, 1_000_000)? as u32,
            None => 1,
        };
        let mut program = Self::integer(p, 99_999_999)? as u32;
        if !macro_call && !self.gixa() && l.is_none() && program > 9999 {
            repeats = program / 10_000;
            program %= 10_000;
        }
        if repeats == 0 {
            return Ok(false);
        }
        if self.stack.is_full() || (macro_call && self.macros.is_full()) {
            return Err((ErrorCode::NestingTooDeep, Some(cols)));
        }
        let start = if self.gixa() {
            src.jump_to_sequence(program)
        } else {
            src.jump_to_program(program)
        }
        .map_err(|e| {
            let code = match e {
                SourceError::DuplicateProgram => ErrorCode::DuplicateProgram,
                SourceError::NoSuchLine => ErrorCode::SourceJumpFailed,
                SourceError::NotServed => ErrorCode::JumpNotServed,
                _ => ErrorCode::UnknownProgram,
            };
            (code, Some(p.cols))
        })?;
        let _ = self.stack.push(Frame {
            return_line: line + 1,
            start_line: start,
            remaining: repeats,
            macro_call,
        });
        Ok(true)
    }

    /// Fanuc `G65 P<program> L<repeats> <arguments>`: a macro call like M98 (streamed the same
    /// way) with a new level of locals #1-#33, set from the argument words (specification I,
    /// [`G65_ARGUMENT`]) and unset otherwise; M99 gives the caller its locals back.
    fn macro_call(&mut self, b: &mut Block, line: u32, src: &mut impl ProgramSource) -> Res<()> {
        let cols = b.g_cols(G65);
        let others = b.has_g_besides(GGroup::NonModal);
        if others || !b.m.is_empty() {
            return Err((ErrorCode::NotSupported, cols));
        }
        let p = b.take(b'P');
        let l = b.take(b'L');
        let mut mask = 0u64;
        let mut args = [0 as Fx; LOCALS];
        for letter in b'A'..=b'Z' {
            let var = G65_ARGUMENT[(letter - b'A') as usize];
            if var == 0 {
                continue;
            }
            if let Some(w) = b.take(letter) {
                args[var as usize - 1] = w.value * 1000 + w.nano as Fx;
                mask |= 1 << (var - 1);
            }
        }
        if let Some(letter) = b.letters().next() {
            return err(ErrorCode::UnusedWord, b.word(letter));
        }
        self.jumps_without_action += 1;
        if self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION {
            self.finished = true;
            self.stack.clear();
            self.macros.clear();
            return Err((ErrorCode::EndlessLoop, cols));
        }
        let saved = self.params.save_locals();
        if self.call(line, cols.unwrap_or((0, 0)), src, p, l, true)? {
            let _ = self.macros.push(saved);
            self.params
                .restore_locals(mask, &args)
                .map_err(|c| (c, cols))?;
        }
        Ok(())
    }
}

/// Offsets stay within ±10 × the coordinate range, so offset arithmetic can never overflow.
fn bounded(v: Nm, w: Word) -> Res<Nm> {
    if v.abs() > 10 * MAX_COORD {
        return err(ErrorCode::CoordinateOverflow, Some(w));
    }
    Ok(v)
}

fn decode_motion(code: u16) -> MotionMode {
    match code {
        G0 => MotionMode::Rapid,
        G1 => MotionMode::Linear,
        G2 => MotionMode::ArcCw,
        G3 => MotionMode::ArcCcw,
        G80 => MotionMode::None,
        G38_2 | G38_3 | G38_4 | G38_5 => MotionMode::Probe(code),
        c => MotionMode::Cycle(c),
    }
}

/// A block's polar words: `@` radius (nm), `^` angle (10⁻⁶ degree), columns of the first.
type PolarWords = (Option<Nm>, Option<i64>, (u16, u16));

/// What [`Interpreter::check_block`] learned of a block for the phases after it.
struct Prelude {
    /// The block's non-modal G code (group 0), ×10.
    nonmodal: Option<u16>,
    /// G4's time word (P, or X in Fanuc style).
    dwell_word: Option<Word>,
    /// The motion G code written in the block.
    motion_g: Option<super::block::Code>,
    /// The motion the block runs (written, or the modal one for bare axis words).
    motion: Option<MotionMode>,
    /// The block has an F word.
    f_given: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::MemorySource;

    /// The state once `program` ran to its end or to its first error, and that error.
    fn state_after(program: &str) -> (Option<ErrorCode>, ModalState) {
        let mut it = Interpreter::new(&InterpConfig::default());
        let mut src = MemorySource::new(program.as_bytes());
        while let Some(x) = it.next(&mut src) {
            if let Err(e) = x {
                return (Some(e.code), *it.state());
            }
        }
        (None, *it.state())
    }

    /// The four-bytes-at-a-time scan finds every `O`, `E` (either case), `[` and `#` at every
    /// position, and nothing in a plain line.
    #[test]
    fn the_control_scan_finds_each_special_character_anywhere() {
        let plain = *b"G1 X-99.893 Y-6.789 F3000 (nd) ;\t\r\n";
        assert!(!may_be_control_or_expanded(&plain));
        for &c in b"OoEe[#" {
            for at in 0..plain.len() {
                let mut line = plain;
                line[at] = c;
                for len in at + 1..=plain.len() {
                    assert!(may_be_control_or_expanded(&line[..len]), "{c} at {at}");
                }
                assert!(!may_be_control_or_expanded(&line[..at]));
            }
        }
        // Bytes one bit away from the special ones.
        assert!(!may_be_control_or_expanded(b"MmDdFfNn{{\"\"\x0f\x05\x03"));
    }

    /// A failing block leaves the state as before it, whether it changed only modes and
    /// position or the offset tables too (`Rollback` in machine/src/gcode/state.rs).
    #[test]
    fn a_failing_block_leaves_the_state_as_before() {
        let before = "G92 X1\nG1 X2 F200\n";
        let (error, state) = state_after(before);
        assert_eq!(error, None);
        for (program, code) in [
            (
                "G92 X1\nG1 X2 F200\nG20 G91 G1 X1 Y2 F100 G55 Q7\n",
                ErrorCode::UnusedWord,
            ),
            ("G92 X1\nG1 X2 F200\nG92 X5 Q7\n", ErrorCode::UnusedWord),
            (
                "G92 X1\nG1 X2 F200\nG10 L2 P1 X5 Q7\n",
                ErrorCode::UnusedWord,
            ),
            ("G92 X1\nG1 X2 F200\nG28.1 X1 Q7\n", ErrorCode::UnusedWord),
            ("G92 X1\nG1 X2 F200\nG43.1 Z3 Q7\n", ErrorCode::UnusedWord),
            ("G92 X1\nG1 X2 F200\nM3 S100 Q7\n", ErrorCode::UnusedWord),
            ("G92 X1\nG1 X2 F200\nM2 Q7\n", ErrorCode::UnusedWord),
            (
                "G92 X1\nG1 X2 F200\nG0 X3 @1\n",
                ErrorCode::AxisWordsConflict,
            ),
        ] {
            assert_eq!(state_after(program), (Some(code), state), "{program}");
        }
    }
}

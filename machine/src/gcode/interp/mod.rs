//! The interpreter: pulls lines from a [`ProgramSource`], executes each block in RS274NGC order and
//! hands out canonical actions one at a time.
//!
//! A block expands into a small queue of actions (spindle, coolant, motion, stop...); canned cycles
//! are expanded lazily by [`CycleRun`], and subprogram calls only move the source, so memory stays
//! bounded whatever the program does. A failing block restores the state saved before it and
//! produces no action.
//!
//! This file holds the state, the line reader and the block's execution order; program flow
//! (O-words, calls, macros) is in `flow.rs`, targets, transforms, feeds and the motion modes in
//! `moves.rs`, canned-cycle blocks in `cycle.rs`.

use super::codes::*;
use super::comp::{Comp, Side};
use core::ops::ControlFlow;

use super::block::{
    letter_mask, parse_block_into, Block, BlockError, GGroup, MGroup, TRANSFORM_GROUPS,
};
use super::config::{ArcCenterMode, Dialect, DwellUnits, InterpConfig, OffPlaneOffset};
use super::cycles::{CycleBody, CycleRun};
use super::error::{ErrorCode, GcodeError};
use super::expand::{self, Assignments, Expanded};
use super::expr::{self, Cursor, Fx, ParamRead, ParamRef, ONE};
use super::geometry::{self, ArcTolerances};
use super::lexer::{Lexer, LineStart, Word, MICRO};
use super::oword::{self, Keyword, Label, OLine};
use super::params::{Params, LOCALS};
use super::source::{ProgramSource, SourceError};
use super::spline::SplineRun;
use super::state::{CycleMemory, ModalState, MotionMode, Rollback};
use super::transform::ONE as FACTOR_ONE;
use crate::canon::{Action, ArcDir, Canon, PathMode, Plane, ProbeMode, Spindle, StopKind};
use crate::units::{Nm, Pos, MAX_AXES};

/// Capacity of the per-block action queue (a block expands to at most 10 actions; cycle steps to 7).
pub(crate) const QUEUE_CAPACITY: usize = 12;
/// Deepest subprogram nesting.
pub(crate) const MAX_NESTING: usize = 16;
/// Deepest G65 macro nesting (Fanuc allows 4 levels).
pub(crate) const MAX_MACRO_NESTING: usize = 4;

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
pub(crate) const MAX_O_CALLS: usize = 8;
/// Most O-word loops open at once.
pub(crate) const MAX_LOOPS: usize = 16;
/// Subroutine definitions remembered (label → line).
pub(crate) const MAX_SUBS: usize = 24;

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
    /// What the last `endsub`/`return` gave back (`#<_value>`, `#<_value_returned>`).
    returned: Option<Fx>,
    /// Lines being skipped: an unset named parameter reads 0 (LinuxCNC evaluates the `endsub`
    /// value of a definition it skips, and an unset name there is no error).
    skipping: bool,
}

/// `#<_value>`: the value the last `o… endsub [v]` / `o… return [v]` gave back (0 without one).
const VALUE: ParamRef = ParamRef::Named {
    hash: expr::name_hash(b"_value"),
    global: true,
};
/// `#<_value_returned>`: 1 if the last `endsub`/`return` gave a value back, else 0.
const VALUE_RETURNED: ParamRef = ParamRef::Named {
    hash: expr::name_hash(b"_value_returned"),
    global: true,
};

/// True for the read-only named parameters the interpreter defines (LinuxCNC's).
fn read_only(p: ParamRef) -> bool {
    p == VALUE || p == VALUE_RETURNED || names::is_predefined(p)
}

impl ParamRead for Reader<'_> {
    fn read(&self, p: ParamRef) -> Result<Fx, ErrorCode> {
        match p {
            VALUE => Ok(self.returned.unwrap_or(0)),
            VALUE_RETURNED => Ok(if self.returned.is_some() { ONE } else { 0 }),
            ParamRef::Numbered(0) => Ok(expr::VACANT),
            ParamRef::Numbered(n)
                if self.in_macro && (1..=LOCALS as u16).contains(&n) && !self.params.is_set(n) =>
            {
                Ok(expr::VACANT)
            }
            _ if read_only(p) => names::read(p, self.state, |n| {
                self.params
                    .read(ParamRef::Numbered(n), self.level, self.state)
            })
            .unwrap_or(Ok(0)),
            _ => match self.params.read(p, self.level, self.state) {
                Err(ErrorCode::UndefinedParameter) if self.skipping => Ok(0),
                r => r,
            },
        }
    }
    fn exists(&self, p: ParamRef) -> bool {
        read_only(p) || self.params.exists(p, self.level)
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
    /// A G5/G5.1 spline being made into arcs, one piece a step (`spline.rs`).
    spline: Option<SplineRun>,
    /// The I, J a G5 without them takes: −P, −Q of the G5 before.
    spline_next_ij: Option<(Nm, Nm)>,
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
    /// What the last `endsub`/`return` gave back (`#<_value>`), `None` without a value.
    returned: Option<Fx>,
    /// Modal states saved by M70/M73, one a call level (`context.rs`).
    contexts: heapless::Vec<context::Context, { context::MAX_CONTEXTS }>,
    /// Cutter radius compensation and the moves it holds back (`comp.rs`).
    comp: Comp,
}

/// Most subprogram jumps without an action before the program is declared an endless loop.
pub(crate) const MAX_JUMPS_WITHOUT_ACTION: u32 = 10_000;

/// 12,864 B (measured): 10,360 B with the G65 locals stack of 4 levels × 33 values, 1,240 B
/// for cutter compensation's look-ahead (`comp.rs`: up to 6 actions held back until the next
/// move decides the corner) and 936 B for the modal states M70/M73 save (`context.rs`: 9
/// levels × 104 B), hence 13 KiB.
const _: () = assert!(core::mem::size_of::<Interpreter>() <= 13 * 1024);

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
            spline: None,
            spline_next_ij: None,
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
            returned: None,
            contexts: heapless::Vec::new(),
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

    /// What an arc's off-plane centre word does (the grbl front end's jobs ignore it).
    pub(crate) fn set_off_plane_offset(&mut self, o: OffPlaneOffset) {
        self.config.off_plane_offset = o;
    }

    /// Optional-stop switch (M1 stops when on).
    pub(crate) fn set_optional_stop(&mut self, on: bool) {
        self.config.optional_stop = on;
    }

    /// The setup in use.
    pub fn config(&self) -> &InterpConfig {
        &self.config
    }

    /// True once M2/M30, the closing `%`, `E` or the end of the file was reached.
    pub(crate) fn is_finished(&self) -> bool {
        self.finished
            && self.queue.is_empty()
            && self.cycle.is_none()
            && self.spline.is_none()
            && self.post == Post::None
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
        self.spline = None;
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
    pub(crate) fn probe_done(&mut self, at: Pos, tripped: Option<Pos>) {
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
                return done.map(Err);
            }
        }
    }

    /// One step of [`Interpreter::next`] while no action waits: a cycle step, a stop, the
    /// compensated moves held back at the end, or one line read and executed. `Break` hands
    /// `next` its answer. Not inlined: in `next`'s loop its ~90 pointers into `self` were
    /// computed again on every call (target-tests/src/bin/bench_motion.rs, per-line profile).
    /// Its steps below are inlined into it (one caller each, and on every line's path).
    #[inline(never)]
    fn refill(&mut self, src: &mut impl ProgramSource) -> Step {
        if let Some(step) = self.before_next_line() {
            return step;
        }
        let mut block = Block::new();
        let Some((line, bytes)) = src.next_line() else {
            return self.end_of_source(src);
        };
        self.last_line = line;
        self.expanded_line = false;
        if self.skip.is_some() {
            if let Some(step) = self.skip_step(line, bytes) {
                return step;
            }
        }
        match self.parse_line(line, bytes, &mut block) {
            Ok(Parsed::Block) => self.execute_or_roll_back(&mut block, line, src),
            other => self.follow(line, other, src),
        }
    }

    /// What comes before the next line is read: the next step of a canned cycle, the stop
    /// after a block, the compensated moves held back when the program has ended, the end;
    /// `None` when a line is to be read.
    #[inline(always)]
    fn before_next_line(&mut self) -> Option<Step> {
        if let Some(run) = self.cycle.as_mut() {
            let queue = &mut self.queue;
            let more = run.step(&mut |c| {
                // Capacity is guaranteed: the queue is empty when a step starts.
                let _ = queue.push_back(c);
            });
            if !more {
                self.cycle = None;
            }
            return Some(ANOTHER_STEP);
        }
        if let Some(run) = self.spline.as_mut() {
            let queue = &mut self.queue;
            // At most three actions a step; the queue is empty when a step starts.
            let more = run.step(&mut |c| {
                let _ = queue.push_back(c);
            });
            if !more {
                self.spline = None;
            }
            return Some(ANOTHER_STEP);
        }
        if let Post::Stop(kind, line) = self.post {
            self.post = Post::None;
            let _ = self.queue.push_back(Canon {
                line,
                action: Action::Stop(kind),
            });
            return Some(ANOTHER_STEP);
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
                return Some(line_error(self.last_line, code));
            }
            return Some(ANOTHER_STEP);
        }
        if self.finished {
            return Some(ControlFlow::Break(None));
        }
        None
    }

    /// A line read while O-word flow skips lines ([`Interpreter::skip_line`]): the step it
    /// is (skipped, or it ended the skip; an error ends the skip), or `None` when the skip has
    /// ended before it and the line is read as usual.
    #[inline(always)]
    fn skip_step(&mut self, line: u32, bytes: &[u8]) -> Option<Step> {
        match self.skip_line(line, bytes) {
            Ok(true) => Some(ANOTHER_STEP),
            Ok(false) => None,
            Err((code, columns)) => {
                self.skip = None;
                Some(ControlFlow::Break(Some(GcodeError {
                    line,
                    n_word: None,
                    columns,
                    code,
                })))
            }
        }
    }

    /// The source has no line now: wait for one (`next` answers `None` while it is not
    /// exhausted), or end the program, refusing O-word flow or subprograms left open (once the
    /// compensated moves held back are out).
    #[inline(always)]
    fn end_of_source(&mut self, src: &mut impl ProgramSource) -> Step {
        if !src.is_exhausted() {
            return ControlFlow::Break(None);
        }
        self.finished = true;
        if self.comp.holds() {
            return ANOTHER_STEP;
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
            return line_error(self.last_line, code);
        }
        if !self.stack.is_empty() {
            self.stack.clear();
            self.macros.clear();
            return line_error(self.last_line, ErrorCode::SubprogramWithoutM99);
        }
        ControlFlow::Break(None)
    }

    /// What a line turned into other than a block: nothing, a jump in `src` (counted against
    /// endless loops), or its error.
    #[inline(always)]
    fn follow(&mut self, line: u32, parsed: ParsedLine, src: &mut impl ProgramSource) -> Step {
        match parsed {
            Ok(Parsed::Block | Parsed::Nothing) => ANOTHER_STEP,
            Ok(Parsed::Jump(to)) => {
                self.jumps_without_action += 1;
                if self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION {
                    self.finished = true;
                    self.clear_control();
                    return line_error(line, ErrorCode::EndlessLoop);
                }
                if let Err(e) = src.jump_to_line(to) {
                    self.finished = true;
                    let code = match e {
                        SourceError::NotServed => ErrorCode::JumpNotServed,
                        _ => ErrorCode::SourceJumpFailed,
                    };
                    return line_error(line, code);
                }
                ANOTHER_STEP
            }
            Ok(Parsed::JumpSequence(n)) => {
                self.jumps_without_action += 1;
                let endless = self.jumps_without_action > MAX_JUMPS_WITHOUT_ACTION;
                if endless || src.jump_to_sequence(n).is_err() {
                    self.finished = true;
                    self.clear_control();
                    let code = if endless {
                        ErrorCode::EndlessLoop
                    } else {
                        ErrorCode::SourceJumpFailed
                    };
                    return line_error(line, code);
                }
                ANOTHER_STEP
            }
            Err((n_word, (code, columns))) => ControlFlow::Break(Some(GcodeError {
                line,
                n_word,
                columns,
                code,
            })),
        }
    }

    /// Executes the block of `line`; a failing block gives back the state, compensation and
    /// the end flag saved before it (only the tables it may change) and drops what it queued.
    #[inline(always)]
    fn execute_or_roll_back(
        &mut self,
        block: &mut Block,
        line: u32,
        src: &mut impl ProgramSource,
    ) -> Step {
        let tables = block.g_of(GGroup::NonModal).is_some()
            || block.g_of(GGroup::ToolLength).is_some()
            || block.has_g_in(TRANSFORM_GROUPS)
            || !block.m.is_empty();
        let saved = Rollback::of(&self.state, tables);
        let saved_finished = self.finished;
        let saved_comp = (!self.comp.is_idle()).then(|| self.comp.clone());
        let Err((code, columns)) = self.execute(block, line, src) else {
            return ANOTHER_STEP;
        };
        let columns = if self.expanded_line { None } else { columns };
        saved.restore(&mut self.state);
        self.comp = saved_comp.unwrap_or_default();
        // An endless loop ends the program; other errors skip the block.
        self.finished = saved_finished || code == ErrorCode::EndlessLoop;
        self.queue.clear();
        self.cycle = None;
        self.spline = None;
        self.post = Post::None;
        ControlFlow::Break(Some(GcodeError {
            line,
            n_word: block.n,
            columns,
            code,
        }))
    }
}

/// A step of [`Interpreter::refill`]: `Break` with `next`'s answer (an error, or `None`: the
/// end, or no line yet), or `Continue`: `next` takes what was queued or asks again. Never an
/// action: small values, written without copying an action around.
type Step = ControlFlow<Option<GcodeError>>;
/// A line read: a block, a jump or nothing, or the line's error (with its N word).
type ParsedLine = Result<Parsed, (Option<u32>, BlockError)>;

/// `refill` is done: `next` takes what was queued, or calls it again.
const ANOTHER_STEP: Step = ControlFlow::Continue(());

/// `next`'s answer: the error `code` of `line`, not tied to a word or an N word.
fn line_error(line: u32, code: ErrorCode) -> Step {
    ControlFlow::Break(Some(GcodeError {
        line,
        n_word: None,
        columns: None,
        code,
    }))
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
        if let Some(mut o) = o_line {
            self.resolve_label(bytes, &mut o)
                .map_err(|e| (n_word(), e))?;
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
            let done = if read_only(p) {
                Err(ErrorCode::ParameterNumberInvalid)
            } else if v == expr::VACANT {
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
            returned: self.returned,
            skipping: self.skip.is_some(),
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
            _ => return self.comp_off(cols),
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

    /// G40 (and an `M72`/`M73` restore of a state saved without compensation): what waits is
    /// released, the last move ends where it was aimed.
    pub(super) fn comp_off(&mut self, cols: Option<(u16, u16)>) -> Res<()> {
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
        Ok(())
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
        self.modal_context(b, line)?;
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
        if let Some(&(_, c)) = b.m.iter().find(|(g, _)| *g == MGroup::Digital) {
            // M62/M63 P2 (grblHAL's plasma port 2): the board switches torch height control off
            // / on with the next move (docs/laser-plasma.md). Other ports do not exist here.
            match b.take(b'P') {
                Some(p) if p.value == 2_000_000 => {}
                _ => return Err((ErrorCode::UnknownMCode, Some(c.cols))),
            }
            self.push(
                line,
                Action::UserMCode {
                    code: c.code,
                    at_rest: false,
                },
            )?;
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
        G5 | G5_1 => MotionMode::Spline(code),
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

mod context;
mod cycle;
mod flow;
mod moves;
mod names;

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

//! Look-ahead planner: a ring of blocks with grbl-style junction limits and a reverse pass.
//!
//! Speeds are planned as squares (nm²/s²). Each line block knows its length, its per-axis-limited
//! top speed, acceleration and start speed, and the geometric junction limit with the block before
//! (grbl junction deviation and the GIXA controller's "Feed Shift"). The end of the buffer is always planned
//! to stop (exit speed 0), so the machine can stop on whatever is buffered.
//!
//! *Reverse pass in O(1) per block.* Unrolled, grbl's reverse recurrence
//! `E_k = min(C_k, E_{k+1} + D_k)` (C = max entry², D = 2·a·length) is
//! `E_k = min(min_{m ≥ k} (C_m + P_m), P_end) − P_k` with P the prefix sums of D. The planner keeps
//! the candidates `C_m + P_m` of the open contour (the blocks since the last stop) in a monotonic
//! queue (increasing keys), so appending a block costs amortized O(1) and the head's exit limit is
//! read off the queue front. When a stop closes a contour (G61, dwell, M code, program stop), one
//! explicit pass settles that contour's limits; every block is settled once, so that too is O(1)
//! amortized. Override changes and resumes replan everything, O(ring), as grbl does.
//!
//! The *forward pass* (acceleration limit) is applied lazily by segment prep: it profiles the head
//! block from the speed it really has, aiming at `min(reverse limit, reachable)`. A full replan
//! (override change, resume) recomputes every limit, as grbl does.

use super::config::{MotionConfig, MAX_SPEED};
use super::laser::LaserPower;
use crate::arith::{div_i128, div_u64, isqrt_u128, isqrt_u64, mul_div, sat_mul};
use crate::step::output_event::OutputEvent;
use crate::units::MAX_AXES;
use heapless::Deque;

/// Unit vectors are scaled by 2³⁰.
pub const UNIT: i64 = 1 << 30;

/// What a block does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockKind {
    /// A straight move (G0, G1 or an arc chord); `output` is switched as it starts, with its
    /// first step (an on-the-fly M code; it sits in the enum's padding, so blocks do not grow).
    Line { output: OutputEvent },
    /// A dwell of this many kernel timer counts.
    Dwell { counts: u64 },
    /// A point where motion stops and the controller acts (M codes, tool change, program stop).
    Sync,
}

impl BlockKind {
    pub const fn is_line(self) -> bool {
        matches!(self, BlockKind::Line { .. })
    }
}

/// What a block does, as stored (a dwell's counts live in [`Block::length`], a line's output
/// event in [`Block::output`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Line,
    Dwell,
    Sync,
}

/// One planner block.
///
/// Laid out for the MCU's RAM (the ring holds 128 of them): speeds are `u32` (the planner caps
/// them at [`MAX_SPEED`] = `u32::MAX` nm/s), a dwell's counts share the `length` field, and the
/// speed² budget is recomputed from `accel` and `length` instead of stored. 120 bytes on
/// thumbv7em instead of 152, with the same planning results. [`Block::kind`] gives the
/// [`BlockKind`] back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Sum of the [`Block::budget`]s of the blocks before this one in its contour.
    pub prefix: u128,
    /// Path length, nm (a dwell: its length in kernel timer counts).
    pub length: u64,
    /// Path acceleration (every axis within its limit), nm/s².
    pub accel: u64,
    /// Geometric junction limit with the previous block, nm²/s².
    pub junction_sq: u64,
    /// Largest entry speed², from junction and nominal speeds.
    pub max_entry_sq: u64,
    /// Entry speed² limit from the reverse pass (settled once the block's contour is closed;
    /// use [`Planner::exit_sq`] for the live value).
    pub entry_sq: u64,
    /// Sequence number (increases by one per queued block).
    pub seq: u32,
    /// Source line.
    pub line: u32,
    /// Absolute step count of each axis.
    pub steps: [u32; MAX_AXES],
    /// Step events of the dominant axis.
    pub events: u32,
    /// Path speed at which some axis reaches its max rate, nm/s.
    pub max_speed: u32,
    /// Programmed path speed, nm/s (rapids: `max_speed`).
    pub programmed: u32,
    /// Cruise speed with the current overrides, nm/s (kept up to date by the planner).
    pub nominal: u32,
    /// Path speed reachable instantly from rest (every axis within its start speed), nm/s.
    pub start_speed: u32,
    kind: Kind,
    /// A line's on-the-fly output, switched as it starts.
    output: OutputEvent,
    /// What the laser does while the line runs (laser mode).
    pub laser: LaserPower,
    /// Direction byte (bit i set = axis i moves towards negative).
    pub dir: u8,
    pub rapid: bool,
    /// The machine is at rest before this block (first after a stop, G61, dwell or sync).
    pub stop_before: bool,
    /// The machine comes to rest after this block.
    pub stop_after: bool,
}

impl Block {
    /// The fields of a non-motion block: at rest before and after, unit speeds.
    const MARKER: Block = Block {
        kind: Kind::Sync,
        output: OutputEvent::NONE,
        laser: LaserPower::Keep,
        seq: 0,
        prefix: 0,
        line: 0,
        steps: [0; MAX_AXES],
        dir: 0,
        events: 0,
        length: 0,
        accel: 1,
        max_speed: 1,
        programmed: 1,
        rapid: false,
        nominal: 1,
        start_speed: 0,
        junction_sq: 0,
        stop_before: true,
        stop_after: true,
        max_entry_sq: 0,
        entry_sq: 0,
    };

    /// A non-motion block.
    pub fn marker(kind: BlockKind, line: u32) -> Self {
        let (kind, length, output) = match kind {
            BlockKind::Line { output } => (Kind::Line, 0, output),
            BlockKind::Dwell { counts } => (Kind::Dwell, counts, OutputEvent::NONE),
            BlockKind::Sync => (Kind::Sync, 0, OutputEvent::NONE),
        };
        Block {
            kind,
            length,
            output,
            line,
            ..Self::MARKER
        }
    }

    /// What the block does.
    pub fn kind(&self) -> BlockKind {
        match self.kind {
            Kind::Line => BlockKind::Line {
                output: self.output,
            },
            Kind::Dwell => BlockKind::Dwell {
                counts: self.length,
            },
            Kind::Sync => BlockKind::Sync,
        }
    }

    pub fn is_line(&self) -> bool {
        self.kind == Kind::Line
    }

    /// 2·a·length, saturated: the speed² a line block can gain or shed (0 for markers).
    pub fn budget(&self) -> u64 {
        if self.is_line() {
            sat_mul(self.accel.saturating_mul(2), self.length)
        } else {
            0
        }
    }

    /// Its key in the open contour's candidate queue: C + P (`max_entry_sq` + `prefix`).
    #[inline(always)]
    fn candidate_key(&self) -> u128 {
        self.max_entry_sq as u128 + self.prefix
    }
}

/// A line to plan, in machine terms (its displacement per axis comes from the function given to
/// [`Planner::push_block`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LineRequest {
    pub line: u32,
    /// Programmed speed, nm/s; `None` = rapid.
    pub speed: Option<u64>,
    /// The block before must end at rest (G61 exact stop).
    pub exact_stop_before: bool,
    /// Junction deviation for this corner, nm.
    pub junction_deviation: u64,
    /// Junction speed² limit to use instead of junction deviation's (the line starts or
    /// continues a rounded corner, machine/src/motion/corner.rs).
    pub corner_sq: Option<u64>,
    /// On-the-fly output switched as the line starts.
    pub output: OutputEvent,
    /// What the laser does while the line runs.
    pub laser: LaserPower,
}

/// The block ring and the planning state.
pub struct Planner<const N: usize> {
    /// The queued blocks, oldest first. A `Deque` rather than an array: its free slots stay
    /// uninitialised, so a new planner costs no 15 KiB of stores, and moving a new one into place
    /// copies nothing of them (the firmware builds its board in a static with one board-sized
    /// stack frame, not several).
    ring: Deque<Block, N>,
    /// Unit vector of the last line block, if the next line may blend with it.
    prev_unit: Option<[i64; MAX_AXES]>,
    /// The next line continues a move cut short at the current speed ([`Self::continue_from`]),
    /// although the ring is empty.
    continuing: bool,
    feed_pct: u16,
    rapid_pct: u16,
    /// Sequence number of the next block.
    next_seq: u32,
    /// First sequence number of the open contour.
    open_from: u32,
    /// Sum of the budgets of the open contour.
    prefix_end: u128,
    /// Monotonic queue of the candidates of the open contour by sequence number, increasing
    /// keys (C + P, read from the block, which stays in the ring as long as it is in the
    /// queue).
    hull: Deque<u32, N>,
    /// Changes with every change of the planning state ([`Self::revision`]).
    revision: u32,
}

impl<const N: usize> Default for Planner<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Planner<N> {
    #[inline(always)] // see `Board::power_up`: no planner-sized temporary
    pub const fn new() -> Self {
        Planner {
            ring: Deque::new(),
            prev_unit: None,
            continuing: false,
            feed_pct: 100,
            rapid_pct: 100,
            next_seq: 0,
            open_from: 0,
            prefix_end: 0,
            hull: Deque::new(),
            revision: 0,
        }
    }

    /// A number that changes whenever the planner does (a block added or retired, a replan):
    /// while it stays the same, so do [`Self::exit_sq`] and [`Self::nominal`] of every block.
    /// Segment prep checks its head block's plan only when it changed (it wraps after 2³²
    /// changes; prep checks it every segment).
    pub fn revision(&self) -> u32 {
        self.revision
    }

    fn changed(&mut self) {
        self.revision = self.revision.wrapping_add(1);
    }

    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// The sequence number the next queued block gets.
    pub fn next_seq(&self) -> u32 {
        self.next_seq
    }

    pub fn is_empty(&self) -> bool {
        self.ring.is_empty()
    }

    pub fn is_full(&self) -> bool {
        self.ring.is_full()
    }

    /// The block `offset` places after the head.
    pub fn get(&self, offset: usize) -> Option<&Block> {
        self.ring.get(offset)
    }

    /// The queued block `offset` places after the head (`offset < len`, as every caller in
    /// this module guarantees).
    fn at(&self, offset: usize) -> &Block {
        self.ring.get(offset).unwrap()
    }

    fn at_mut(&mut self, offset: usize) -> &mut Block {
        self.ring.get_mut(offset).unwrap()
    }

    /// The oldest block (the one segment prep works on).
    pub fn head(&self) -> Option<&Block> {
        self.ring.front()
    }

    /// Retires the head block.
    pub fn pop(&mut self) {
        self.changed();
        if let Some(b) = self.ring.pop_front() {
            while self.hull.front().is_some_and(|&s| s <= b.seq) {
                self.hull.pop_front();
            }
            if self.ring.is_empty() {
                self.prev_unit = None;
            }
        }
    }

    /// Drops every block.
    pub fn clear(&mut self) {
        self.changed();
        self.ring.clear();
        self.prev_unit = None;
        self.continuing = false;
        self.hull.clear();
        self.prefix_end = 0;
        self.open_from = self.next_seq;
    }

    pub fn feed_override(&self) -> u16 {
        self.feed_pct
    }

    pub fn rapid_override(&self) -> u16 {
        self.rapid_pct
    }

    /// Sets the overrides (percent) and replans every block.
    pub fn set_overrides(&mut self, feed_pct: u16, rapid_pct: u16) {
        self.feed_pct = feed_pct;
        self.rapid_pct = rapid_pct;
        self.replan_all();
    }

    /// Sets the programmed speed (nm/s) of every queued feed block and replans (a jog's new
    /// speed; rapids keep theirs).
    pub(crate) fn set_programmed_speed(&mut self, speed: u64) {
        for b in self.ring.iter_mut() {
            if b.is_line() && !b.rapid {
                // MAX_SPEED is u32::MAX.
                b.programmed = speed.max(1).min(MAX_SPEED) as u32;
            }
        }
        self.replan_all();
    }

    /// Speed the block cruises at with the current overrides, nm/s.
    pub fn nominal(&self, b: &Block) -> u64 {
        u64::from(b.nominal)
    }

    /// Computes the cruise speed of a block for the current overrides.
    fn override_speed(&self, b: &Block) -> u32 {
        let (max_speed, programmed) = (u64::from(b.max_speed), u64::from(b.programmed));
        // `div_u64`: the hardware-assisted division, not the 64-bit library call.
        // At 100 % (the usual override) the speed itself, without the division.
        let (v, pct) = if b.rapid {
            (max_speed, self.rapid_pct)
        } else {
            (programmed, self.feed_pct)
        };
        let v = if pct == 100 {
            v
        } else {
            div_u64(v * pct as u64, 100)
        };
        let v = if b.rapid { v } else { v.min(max_speed) };
        // MAX_SPEED is u32::MAX.
        v.max(1).min(MAX_SPEED) as u32
    }

    /// Speed² the block `offset` must exit with at most (reverse-pass limit).
    pub(crate) fn exit_sq(&self, offset: usize) -> u64 {
        let b = self.at(offset);
        if b.stop_after {
            return self.stop_exit_sq(b);
        }
        match self.ring.get(offset + 1) {
            None => 0,
            Some(next) if next.seq < self.open_from => next.entry_sq,
            // The ring's blocks are numbered consecutively: the head's number is `b`'s less
            // `offset` (no second lookup of the head for the candidate's place).
            Some(next) => self.open_entry_sq(next, b.seq.wrapping_sub(offset as u32)),
        }
    }

    /// Reverse-pass entry limit of a block of the open contour, from the candidate queue
    /// (`head_seq`: the number of the head block).
    fn open_entry_sq(&self, b: &Block, head_seq: u32) -> u64 {
        // The open end exits at rest: candidate P_end.
        let mut min = self.prefix_end;
        if let Some(&s) = self.hull.iter().find(|&&s| s >= b.seq) {
            // Most often the candidate is `b` itself: its key without a ring lookup.
            let c = if s == b.seq {
                b
            } else {
                self.at(s.wrapping_sub(head_seq) as usize)
            };
            min = min.min(c.candidate_key());
        }
        (min - b.prefix).min(u64::MAX as u128) as u64
    }

    /// Makes the newest block of the open contour, numbered `seq`, a candidate: returns its
    /// prefix (the open contour's budget before it) and adds its own `budget`. Its key is
    /// `max_entry_sq` + prefix; the queued candidates with keys not below it leave the queue (they
    /// are older blocks, all in the ring; the new block itself need not be there yet).
    fn add_candidate(&mut self, seq: u32, max_entry_sq: u64, budget: u64) -> u128 {
        let prefix = self.prefix_end;
        let key = max_entry_sq as u128 + prefix;
        self.prefix_end += budget as u128;
        // The ring's blocks are numbered consecutively from the head's.
        let head_seq = self.ring.front().map_or(0, |h| h.seq);
        while self.hull.back().is_some_and(|&s| {
            let c = self.at(s.wrapping_sub(head_seq) as usize);
            c.candidate_key() >= key
        }) {
            self.hull.pop_back();
        }
        let _ = self.hull.push_back(seq);
        prefix
    }

    /// Ends the open contour: its last block now comes to rest, and one reverse pass settles the
    /// contour's entry limits. The next block opens a new contour.
    fn close_contour(&mut self) {
        if let Some(last) = self.ring.back_mut() {
            last.stop_after = true;
            self.settle(self.open_from);
        }
        self.hull.clear();
        self.prefix_end = 0;
        self.open_from = self.next_seq;
    }

    /// Speed² a block may end with when the machine stops right after it (its start speed).
    fn stop_exit_sq(&self, b: &Block) -> u64 {
        let v = u64::from(b.start_speed).min(self.nominal(b));
        v * v
    }

    /// Largest entry speed² of the line block `b` given the block before it in the ring (none:
    /// `b` is the head).
    fn max_entry_sq(&self, b: &Block, prev: Option<&Block>) -> u64 {
        let nom = self.nominal(b);
        let prev = match prev {
            Some(prev) if !b.stop_before => prev,
            _ => {
                let v = u64::from(b.start_speed).min(nom);
                return if b.stop_before { v * v } else { nom * nom };
            }
        };
        let prev_nom = self.nominal(prev);
        let v = nom.min(prev_nom);
        b.junction_sq.min(v * v)
    }

    /// Adds a non-motion block (dwell or sync); the machine stops before it.
    pub(crate) fn push_marker(&mut self, block: Block) -> bool {
        self.changed();
        if self.is_full() {
            return false;
        }
        self.close_contour();
        let _ = self.ring.push_back(Block {
            seq: self.next_seq,
            ..block
        });
        self.next_seq = self.next_seq.wrapping_add(1);
        self.open_from = self.next_seq;
        self.prev_unit = None;
        true
    }

    /// Plans a straight move; false when the ring is full (then `axis_move` is not called). A
    /// move without steps is dropped (true; the ring's length tells whether a block was added).
    ///
    /// `axis_move(i)` gives the displacement of configured axis `i` as (steps, nm); it is called
    /// once per configured axis, in order (the pipeline converts and books its new end there: no
    /// zero-filled displacement arrays built and copied per line).
    pub(crate) fn push_block(
        &mut self,
        cfg: &MotionConfig,
        req: &LineRequest,
        mut axis_move: impl FnMut(usize) -> (i64, i64),
    ) -> bool {
        self.changed();
        if self.is_full() {
            return false;
        }
        let axes = cfg.axis_count_in_bounds();
        let mut steps = [0u32; MAX_AXES];
        let mut delta = [0i64; MAX_AXES];
        let mut dir = 0u8;
        let mut events = 0u32;
        let mut len_sq: u128 = 0;
        for i in 0..axes {
            let (s, d) = axis_move(i);
            steps[i] = s.unsigned_abs().min(u32::MAX as u64) as u32;
            if s < 0 {
                dir |= 1 << i;
            }
            events = events.max(steps[i]);
            delta[i] = d;
            let d = d.unsigned_abs();
            len_sq += u128::from(d) * u128::from(d);
        }
        if events == 0 {
            return true;
        }
        let length = if len_sq <= u64::MAX as u128 {
            isqrt_u64(len_sq as u64)
        } else {
            isqrt_u128(len_sq) as u64
        }
        .max(1);
        // Max rate, acceleration and start speed.
        let mut limits = [LeastRatio::NONE; 3];
        let mut unit = [0i64; MAX_AXES];
        for i in 0..axes {
            let d = delta[i].unsigned_abs();
            if d == 0 {
                continue;
            }
            let ax = &cfg.axes[i];
            LeastRatio::add_each(
                &mut limits,
                [ax.max_rate, ax.accel, ax.start_speed],
                d,
                length,
            );
            // `delta · 2³⁰ / length` truncated toward zero, on the magnitude: a hardware-assisted
            // `div_u64` instead of the signed 64-bit library division, whenever `d · 2³⁰` fits
            // 64 bits (no signed overflow check of the product; |q| ≤ 2³⁰ as d ≤ length).
            unit[i] = if d >> 34 == 0 {
                let q = div_u64(d << 30, length) as i64;
                if delta[i] < 0 {
                    -q
                } else {
                    q
                }
            } else {
                div_i128(delta[i] as i128 * UNIT as i128, length as i128) as i64
            };
        }
        let max_speed = limits[0].least(length).min(MAX_SPEED).max(1);
        let accel = limits[1].least(length).max(1);
        let start_speed = limits[2].least(length).min(MAX_SPEED);
        let (programmed, rapid) = match req.speed {
            Some(v) => (v.max(1).min(MAX_SPEED), false),
            None => (max_speed, true),
        };
        let stop_before = req.exact_stop_before
            || self.prev_unit.is_none()
            || (self.is_empty() && !self.continuing);
        // `as_ref`: matching on the `Option` itself copied its 48-byte array (a `memcpy` call).
        let junction_sq = match (stop_before, self.prev_unit.as_ref()) {
            (false, Some(prev)) => match req.corner_sq {
                Some(limit) => limit,
                None => junction_limit_sq(cfg, prev, &unit, req.junction_deviation),
            },
            _ => 0,
        };
        if stop_before {
            self.close_contour();
        }
        let mut block = Block {
            kind: Kind::Line,
            output: req.output,
            laser: req.laser,
            seq: self.next_seq,
            prefix: 0,
            line: req.line,
            steps,
            dir,
            events,
            length,
            accel,
            // All three are capped at MAX_SPEED = u32::MAX above.
            max_speed: max_speed as u32,
            programmed: programmed as u32,
            rapid,
            nominal: 1,
            start_speed: start_speed as u32,
            junction_sq,
            stop_before,
            stop_after: false,
            max_entry_sq: 0,
            entry_sq: u64::MAX,
        };
        block.nominal = self.override_speed(&block);
        // Planned before it joins the ring (its predecessor is the ring's last block): no
        // lookups of it in the ring afterwards.
        block.max_entry_sq = self.max_entry_sq(&block, self.ring.back());
        block.prefix = self.add_candidate(block.seq, block.max_entry_sq, block.budget());
        let _ = self.ring.push_back(block);
        self.next_seq = self.next_seq.wrapping_add(1);
        // Not `= Some(unit)` nor `*prev = unit`: those compiled to a `memmove` call on the
        // Cortex-M4 (1.5 KiB of flash for the routine), and a zipped loop to a `Zip::next` call
        // per axis; `copy_from_slice` is one `memcpy` (non-overlapping by its contract). The zero
        // array only when there is none yet (`get_or_insert` cleared one on every line, which
        // clippy's lazy-evaluation lint does not weigh).
        #[allow(clippy::unnecessary_lazy_evaluations)]
        self.prev_unit
            .get_or_insert_with(|| [0; MAX_AXES])
            .copy_from_slice(&unit);
        self.continuing = false;
        true
    }

    /// The ring is empty and the machine still moves along `unit` (2³⁰ scale): the next line
    /// blends with that direction (junction limits) instead of starting from rest. Segment prep
    /// carries the speed.
    pub(crate) fn continue_from(&mut self, unit: [i64; MAX_AXES]) {
        self.changed();
        if self.is_empty() {
            self.prev_unit = Some(unit);
            self.continuing = true;
        }
    }

    /// Recomputes every entry limit (after an override change or a resume).
    pub(crate) fn replan_all(&mut self) {
        self.changed();
        for off in 0..self.len() {
            self.at_mut(off).nominal = self.override_speed(self.at(off));
        }
        for off in 0..self.len() {
            let b = self.at(off);
            if b.is_line() {
                let prev = off.checked_sub(1).map(|p| self.at(p));
                self.at_mut(off).max_entry_sq = self.max_entry_sq(b, prev);
            }
        }
        self.settle(0);
        self.hull.clear();
        self.prefix_end = 0;
        for off in 0..self.len() {
            let b = self.at(off);
            if b.seq >= self.open_from && b.is_line() {
                let (seq, max_entry_sq, budget) = (b.seq, b.max_entry_sq, b.budget());
                self.at_mut(off).prefix = self.add_candidate(seq, max_entry_sq, budget);
            }
        }
    }

    /// Explicit reverse pass over the blocks numbered `from_seq` or later, newest first, down to
    /// the block after the head.
    fn settle(&mut self, from_seq: u32) {
        if self.is_empty() {
            return;
        }
        let mut next_entry = 0u64;
        let mut off = self.len();
        let last = off - 1;
        while off > 1 {
            off -= 1;
            let b = self.at(off);
            if b.seq < from_seq {
                break;
            }
            let entry = if b.is_line() {
                let exit = if b.stop_after {
                    let v = u64::from(b.start_speed.min(b.nominal));
                    v * v
                } else if off == last {
                    0
                } else {
                    next_entry
                };
                b.max_entry_sq.min(exit.saturating_add(b.budget()))
            } else {
                0
            };
            self.at_mut(off).entry_sq = entry;
            next_entry = entry;
        }
    }
}

/// What the machine's axes allow along a straight move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Direction {
    /// Unit vector, 2³⁰ scale.
    pub unit: [i64; MAX_AXES],
    /// Path acceleration and speed with every axis within its limits, nm/s² and nm/s.
    pub accel: u64,
    pub max_speed: u64,
}

/// The direction of a move by `delta` (nm per axis) and what the axes allow along it; `None`
/// for no move. (The same limits [`Planner::push_block`] applies.)
pub(crate) fn direction(cfg: &MotionConfig, delta: &[i64; MAX_AXES]) -> Option<Direction> {
    let axes = cfg.axis_count_in_bounds();
    let len_sq: u128 = delta[..axes]
        .iter()
        .map(|d| d.unsigned_abs() as u128 * d.unsigned_abs() as u128)
        .sum();
    let length = isqrt_u128(len_sq) as u64;
    if length == 0 {
        return None;
    }
    let mut dir = Direction {
        unit: [0; MAX_AXES],
        accel: u64::MAX,
        max_speed: MAX_SPEED,
    };
    for i in 0..axes {
        let d = delta[i].unsigned_abs();
        if d == 0 {
            continue;
        }
        let ax = &cfg.axes[i];
        dir.max_speed = dir.max_speed.min(mul_div(ax.max_rate, length, d));
        dir.accel = dir.accel.min(mul_div(ax.accel, length, d));
        dir.unit[i] = div_i128(delta[i] as i128 * UNIT as i128, length as i128) as i64;
    }
    dir.max_speed = dir.max_speed.max(1);
    dir.accel = dir.accel.max(1);
    Some(dir)
}

/// The least `⌊r·length / d⌋` (saturated, as [`mul_div`]) over a move's axes, each given as its
/// limit `r` and its share `d > 0` of the move: `u64::MAX` for none.
///
/// An axis whose ratio `r/d` is known to be no smaller than another's, because its limit is no
/// lower and its share no larger, cannot give the least value, and `⌊·⌋` keeps that order: it is
/// dropped without a division. Axes with the same limits (the usual machine) thus cost one
/// `mul_div` per move instead of one per moving axis; only axes that neither dominates are each
/// divided. The result is the minimum over every axis's own `mul_div`
/// (`least_ratio_is_the_minimum_over_the_axes` in this file).
#[derive(Clone, Copy)]
struct LeastRatio {
    /// Least value of the axes already dropped because neither dominated.
    settled: u64,
    /// The axis with the least ratio so far (`d` = 0: none yet).
    r: u64,
    d: u64,
}

impl LeastRatio {
    const NONE: LeastRatio = LeastRatio {
        settled: u64::MAX,
        r: 0,
        d: 0,
    };

    /// Takes an axis with limit `r` and share `d` (out of line: one copy for the planner's
    /// limits and the junction's acceleration).
    #[inline(never)]
    fn add(&mut self, r: u64, d: u64, length: u64) {
        if self.d == 0 || (r <= self.r && d >= self.d) {
            (self.r, self.d) = (r, d);
        } else if r < self.r || d > self.d {
            // Neither dominates: the one so far is divided now.
            self.settled = self.settled.min(mul_div(self.r, length, self.d));
            (self.r, self.d) = (r, d);
        }
    }

    /// [`Self::add`] for several limits of one axis.
    #[inline(always)]
    fn add_each<const K: usize>(all: &mut [LeastRatio; K], r: [u64; K], d: u64, length: u64) {
        for k in 0..K {
            all[k].add(r[k], d, length);
        }
    }

    #[inline(always)]
    fn least(&self, length: u64) -> u64 {
        if self.d == 0 {
            self.settled
        } else {
            self.settled.min(mul_div(self.r, length, self.d))
        }
    }
}

/// Junction speed² limit between unit vectors `prev` and `cur` (2³⁰ scale): the larger of grbl's
/// junction-deviation limit and the speed whose vector change at the corner is the GIXA controller's Feed
/// Shift (a jump the steppers take instantly), so a feed shift never slows a corner below
/// junction deviation's speed.
pub fn junction_limit_sq(
    cfg: &MotionConfig,
    prev: &[i64; MAX_AXES],
    cur: &[i64; MAX_AXES],
    deviation: u64,
) -> u64 {
    let axes = cfg.axis_count_in_bounds();
    let mut dot: i64 = 0;
    let mut jump_sq: u64 = 0;
    for i in 0..axes {
        dot += prev[i] * cur[i];
        let jump = cur[i] - prev[i];
        // |jump| ≤ 2·2³⁰, so the sum of squares stays below 2⁶².
        jump_sq += (jump * jump) as u64;
    }
    // |û_cur − û_prev| in 2³⁰ units; 0 means a straight continuation.
    let jump_len = isqrt_u64(jump_sq);
    if jump_len <= 2 {
        return u64::MAX;
    }
    // sin(θ/2) = √((1 + û_prev·û_cur) / 2), θ the angle between −û_prev and û_cur (grbl).
    let unit_sq = (UNIT as i128) * (UNIT as i128);
    let half = ((unit_sq + dot as i128).max(0) / 2) as u64;
    let sin_half = sin_half_of(half).min(UNIT as u64);
    let mut limit = u64::MAX;
    if sin_half < UNIT as u64 {
        // Acceleration along the junction direction, every axis within its own limit.
        // The jump is recomputed per axis (no array of it: clearing one cost a `memset` call).
        let mut accel = LeastRatio::NONE;
        for i in 0..axes {
            let j = cur[i] - prev[i];
            if j != 0 {
                accel.add(cfg.axes[i].accel, j.unsigned_abs(), jump_len);
            }
        }
        let accel = accel.least(jump_len);
        // a·δ·sin / (1 − sin), split so every product stays within 64 bits.
        let q = sat_mul(accel, deviation);
        let den = UNIT as u64 - sin_half;
        let q_den = div_u64(q, den);
        let whole = sat_mul(q_den, sin_half);
        limit = whole.saturating_add(div_u64((q - q_den * den) * sin_half, den));
    }
    if cfg.feed_shift > 0 {
        // Feed Shift is a speed jump the machine takes at any junction: it can only raise the
        // junction-deviation speed, never lower it (docs/settings.md, `feed_shift`).
        let v = mul_div(cfg.feed_shift, UNIT as u64, jump_len).min(MAX_SPEED);
        limit = limit.max(v * v);
    }
    limit
}

/// ⌊√half⌋ for [`junction_limit_sq`], exactly [`isqrt_u64`]`(half)`, mostly without its division:
/// with `half = UNIT² − e` near `UNIT²` (a gentle corner), `√half ≈ UNIT − t − t²/2·UNIT` for
/// `t = e/2·UNIT` (the first two terms of √(1 − z), every further one negative, so the guess is
/// at or just above the root). It is stepped to the floor root by exact squares; a guess more than
/// a few steps off (a sharper corner) falls back to the full root.
fn sin_half_of(half: u64) -> u64 {
    const STEPS: u32 = 4;
    let unit = UNIT as u64;
    // t ≤ 2²⁹, so t² fits 64 bits; x ≤ 2³⁰, so x² and (x + 1)² do too.
    let t = (unit * unit).saturating_sub(half) >> 31;
    let mut x = unit - t - ((t * t) >> 31);
    let mut steps = 0;
    while x * x > half {
        x -= 1;
        steps += 1;
        if steps > STEPS {
            return isqrt_u64(half);
        }
    }
    while (x + 1) * (x + 1) <= half {
        x += 1;
        steps += 1;
        if steps > STEPS {
            return isqrt_u64(half);
        }
    }
    x
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::arith::XorShift;
    use crate::units::NM_PER_MM;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn sin_half_of_is_the_floor_root_for_any_guess() {
        let mut rng = XorShift(0x2545_F491_4F6C_DD1D);
        let mut next = || rng.next();
        let unit_sq = (UNIT as u64) * (UNIT as u64);
        for _ in 0..200_000 {
            // Near UNIT² (gentle corners, the fast path) and anywhere (the fallback).
            let near = unit_sq - (next() >> (4 + next() % 60));
            let above = unit_sq + (next() >> (4 + next() % 60));
            for half in [
                near,
                above,
                next() >> 3,
                next() % 1000,
                0,
                unit_sq,
                unit_sq - 1,
            ] {
                assert_eq!(sin_half_of(half), isqrt_u64(half), "half {half}");
            }
        }
    }

    /// A test line: the request and its displacement per axis (steps, nm).
    struct TestLine {
        req: LineRequest,
        steps: [i64; MAX_AXES],
        delta: [i64; MAX_AXES],
    }

    fn line(cfg: &MotionConfig, dx: i64, dy: i64, feed_mm_min: u64) -> TestLine {
        let delta = [dx, dy, 0, 0, 0, 0];
        let mut steps = [0; MAX_AXES];
        for i in 0..2 {
            steps[i] = cfg.axes[i].nm_to_steps(delta[i]);
        }
        let req = LineRequest {
            line: 1,
            speed: Some(feed_mm_min * NM_PER_MM as u64 / 60),
            exact_stop_before: false,
            junction_deviation: cfg.junction_deviation as u64,
            corner_sq: None,
            output: OutputEvent::NONE,
            laser: LaserPower::Keep,
        };
        TestLine { req, steps, delta }
    }

    fn push<const N: usize>(p: &mut Planner<N>, cfg: &MotionConfig, l: &TestLine) -> bool {
        p.push_block(cfg, &l.req, |i| (l.steps[i], l.delta[i]))
    }

    #[test]
    fn right_angle_junction_matches_grbl_formula() {
        let cfg = MotionConfig {
            feed_shift: 0,
            ..Default::default()
        };
        let x = [UNIT, 0, 0, 0, 0, 0];
        let y = [0, UNIT, 0, 0, 0, 0];
        // a_j: junction vector (−1, 1)/√2 → a = 200 mm/s² · √2 on each axis limit = 282.8 mm/s².
        // v² = a·δ·sin45/(1 − sin45) = 2.828e8 · 1e4 · 2.414 = 6.83e12 → 2.61 mm/s.
        let v = isqrt_u64(junction_limit_sq(&cfg, &x, &y, 10_000));
        assert!((2_600_000..2_620_000).contains(&v), "{v}");
        assert_eq!(junction_limit_sq(&cfg, &x, &x, 10_000), u64::MAX);
        let back = [-UNIT, 0, 0, 0, 0, 0];
        assert_eq!(junction_limit_sq(&cfg, &x, &back, 10_000), 0);
        // Feed Shift 60 mm/min = 1 mm/s over a √2 vector jump: 0.707 mm/s, below junction
        // deviation's 2.61 mm/s, so the default corner is junction deviation's, to the nm/s.
        let cfg = MotionConfig::default();
        let jd = junction_limit_sq(&cfg, &x, &y, 10_000);
        let shift_only = junction_limit_sq(&cfg, &x, &y, 0);
        assert!(
            (706_000..708_000).contains(&isqrt_u64(shift_only)),
            "{shift_only}"
        );
        let no_shift = MotionConfig {
            feed_shift: 0,
            ..cfg
        };
        assert_eq!(jd, junction_limit_sq(&no_shift, &x, &y, 10_000));
        // A feed shift of 300 mm/min (5 mm/s) raises the corner to 5/√2 = 3.54 mm/s.
        let big = MotionConfig {
            feed_shift: 5_000_000,
            ..cfg
        };
        let v = isqrt_u64(junction_limit_sq(&big, &x, &y, 10_000));
        assert!((3_535_000..3_537_000).contains(&v), "{v}");
        // A reversal: junction deviation stops, the feed shift allows ±v with 2v = 1 mm/s.
        assert_eq!(
            isqrt_u64(junction_limit_sq(&cfg, &x, &back, 10_000)),
            500_000
        );
    }

    #[test]
    fn least_ratio_is_the_minimum_over_the_axes() {
        // Limits and shares from tiny to huge (saturating products included), equal and mixed
        // per axis, against one `mul_div` per axis (the formula it replaces).
        let values = [
            0,
            1,
            2,
            3,
            781,
            1_000_000,
            50_000_000,
            200_000_000,
            u32::MAX as u64,
            u32::MAX as u64 + 1,
            1 << 40,
            u64::MAX / 3,
            u64::MAX,
        ];
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        let mut pick = |n: usize| {
            let seed = rng.next();
            values[(seed % n as u64) as usize].saturating_add((seed >> 60) * ((seed >> 59) & 1))
        };
        for case in 0..200_000 {
            let axes = 1 + case % MAX_AXES;
            let length = pick(values.len()).max(1);
            let mut least = LeastRatio::NONE;
            let mut want = u64::MAX;
            let mut seen = Vec::new();
            for _ in 0..axes {
                let (r, d) = (pick(values.len()), pick(values.len()).max(1));
                seen.push((r, d));
                least.add(r, d, length);
                want = want.min(mul_div(r, length, d));
            }
            assert_eq!(least.least(length), want, "{seen:?} length {length}");
        }
        assert_eq!(LeastRatio::NONE.least(5), u64::MAX);
    }

    #[test]
    fn buffer_end_always_stops_and_entries_only_grow() {
        let cfg = MotionConfig::default();
        let mut p: Planner<8> = Planner::new();
        assert!(push(&mut p, &cfg, &line(&cfg, NM_PER_MM, 0, 1200)));
        assert!(push(&mut p, &cfg, &line(&cfg, NM_PER_MM, 0, 1200)));
        assert_eq!(p.exit_sq(1), 0);
        let e1 = p.exit_sq(0);
        // 1 mm at 200 mm/s²: entry² ≤ 2·a·L = 4e14, i.e. exactly the nominal 20 mm/s.
        assert_eq!(e1, 400_000_000_000_000);
        assert!(push(&mut p, &cfg, &line(&cfg, NM_PER_MM / 2, 0, 1200)));
        assert_eq!(p.exit_sq(0), e1);
        // Block 1 (0.5 mm) can only gain 2e14 before block 2 must stop: 4e14 vs 2e14 + 2e14.
        assert_eq!(p.exit_sq(1), 200_000_000_000_000);
        assert_eq!(p.exit_sq(2), 0);
    }

    #[test]
    fn revision_changes_with_every_planning_change() {
        let cfg = MotionConfig::default();
        let mut p: Planner<8> = Planner::new();
        let mut seen = vec![p.revision()];
        let mut check = |p: &Planner<8>| {
            assert!(!seen.contains(&p.revision()), "{seen:?}");
            seen.push(p.revision());
        };
        assert!(push(&mut p, &cfg, &line(&cfg, NM_PER_MM, 0, 1200)));
        check(&p);
        assert!(push(&mut p, &cfg, &line(&cfg, NM_PER_MM, 0, 1200)));
        check(&p);
        let exit = p.exit_sq(0);
        p.set_overrides(50, 100);
        check(&p);
        assert_ne!(p.exit_sq(0), exit);
        p.set_programmed_speed(1_000_000);
        check(&p);
        assert!(p.push_marker(Block::marker(BlockKind::Sync, 0)));
        check(&p);
        p.pop();
        check(&p);
        p.clear();
        check(&p);
    }

    /// Exit limits recomputed naively (full grbl recurrence) for comparison.
    fn naive_exits<const N: usize>(p: &Planner<N>) -> Vec<u64> {
        let n = p.len();
        let mut entry = vec![0u64; n];
        let mut exits = vec![0u64; n];
        for off in (0..n).rev() {
            let b = p.get(off).unwrap();
            let exit = if b.stop_after {
                let v = u64::from(b.start_speed.min(b.nominal));
                v * v
            } else if off == n - 1 {
                0
            } else {
                entry[off + 1]
            };
            exits[off] = exit;
            entry[off] = if b.is_line() {
                b.max_entry_sq.min(exit.saturating_add(b.budget()))
            } else {
                0
            };
        }
        exits
    }

    #[test]
    fn candidate_queue_matches_the_full_reverse_pass() {
        extern crate std;
        use std::vec::Vec;
        let cfg = MotionConfig::default();
        let mut p: Planner<32> = Planner::new();
        let mut seed = 77u64;
        let mut rnd = |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        for step in 0..20_000 {
            match rnd(20) {
                0..=10 if !p.is_full() => {
                    let dx = rnd(4_000_000) as i64 - 2_000_000;
                    let dy = rnd(400_000) as i64 - 200_000;
                    let mut req = line(&cfg, dx, dy, 100 + rnd(5000));
                    req.req.exact_stop_before = rnd(25) == 0;
                    if rnd(10) == 0 {
                        req.req.speed = None;
                    }
                    assert!(push(&mut p, &cfg, &req));
                }
                11 if !p.is_full() => {
                    assert!(p.push_marker(Block::marker(BlockKind::Sync, 0)));
                }
                12 => p.set_overrides(10 + rnd(190) as u16, 1 + rnd(100) as u16),
                _ => p.pop(),
            }
            let naive: Vec<u64> = naive_exits(&p);
            for (off, want) in naive.iter().enumerate() {
                assert_eq!(p.exit_sq(off), *want, "step {step} offset {off}");
            }
        }
    }
}

//! The motion pipeline the controller drives: canonical actions in, step segments out.
//!
//! [`Motion`] owns the planner ring (`N` blocks), the arc being cut into chords, segment prep and
//! the sync points (M codes, tool changes, program stops) that wait in the queue with the motion.
//!
//! Main-context use: `push` canonical actions while it accepts them, `next_segment` to fill the
//! kernel's segment queue, and `sync_point` / `release_sync` when the queue reaches an action the
//! controller must perform at rest. Realtime requests: [`Motion::feed_hold`], [`Motion::resume`],
//! [`Motion::abort`], [`Motion::change_speed`], [`Motion::set_feed_override`],
//! [`Motion::set_rapid_override`].
//!
//! A hold, an abort, a speed change and a bend ([`Motion::bend`]) want to act from the kernel's
//! running segment, not after the segments queued behind it: they raise
//! [`Motion::drop_request`]; the kernel's owner then
//! drops up to that many of the newest queued segments the kernel has not started and reports how
//! many with [`Motion::segments_dropped`], and prep continues from the end of the last one kept
//! ([`super::history`]). An owner that never drops keeps the old behaviour (the queue runs out).
//!
//! On-the-fly outputs (docs/controller.md, "On-the-fly outputs"): [`Motion::push_output`] takes an M code that switches one output
//! without stopping. Its [`OutputEvent`] waits for the next line block and rides on it, so it
//! fires as that block starts: at the junction when it stands between two moves (at any speed),
//! before the motion when it shares a block with it. Two of them between the same pair of moves
//! break the contour (both become sync points, run at rest in order), and one followed by no
//! motion before a sync point, a dwell or the end ([`Motion::flush_output`]) becomes a sync
//! point itself, so it runs when the motion before it has ended.
//!
//! Laser mode (docs/laser-plasma.md, [`super::laser`]): a program's M3/M4/M5 and S
//! ([`Motion::push_program`]) are no sync points: they set the laser power that each following
//! feed move of the program carries in its blocks (arc chords included); rapids, and the moves
//! of jogs, homing and probing ([`Motion::push`]), carry the beam off. `G64 P` merging and
//! corner rounding are off in laser mode, so every move keeps its own power.

use super::arc::{plane_axes, ArcChords};
use super::blend::Chain;
use super::config::MotionConfig;
use super::corner::{self, MAX_VERTICES};
use super::laser::LaserPower;
use super::planner::{direction, junction_limit_sq, Block, BlockKind, LineRequest, Planner, UNIT};
use super::prep::{BlockOut, BlockReport, JerkSetup, Prep, PrepOut, PrepState};
use super::thc::ThcCommand;
use crate::arith::{self, mul_div};
use crate::arith::{polar, QUARTER_TURN};
use crate::canon::{Action, Canon, StopKind};
use crate::step::kernel::{Segment, KERNEL_TIMER_HZ};
use crate::step::output_event::OutputEvent;
use crate::units::{Pos, MAX_AXES};
use heapless::Deque;

/// Sync points the queue holds at once.
pub(crate) const MAX_SYNCS: usize = 16;

/// Why a canonical action was not taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PushError {
    /// The queue is full: prepare segments (let motion run) and push the same action again.
    Full,
    /// The move leaves the travel box of this axis (soft limit); nothing was queued.
    Travel { axis: usize },
}

/// What the pipeline is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionState {
    /// Nothing queued.
    Idle,
    Running,
    /// Decelerating for a feed hold or an abort.
    Holding,
    /// Stopped on the path by a hold; `resume` continues.
    Held,
    /// The queue reached a sync point (see [`Motion::sync_point`]).
    Sync,
}

/// An on-the-fly user M code waiting for the next line block (its sync-point form is rebuilt
/// from it when it cannot ride on one).
#[derive(Clone, Copy, Debug)]
struct PendingOutput {
    line: u32,
    code: u16,
    output: OutputEvent,
}

impl PendingOutput {
    fn canon(self) -> Canon {
        Canon {
            line: self.line,
            action: Action::UserMCode {
                code: self.code,
                at_rest: false,
            },
        }
    }
}

/// An arc being fed into the planner chord by chord.
#[derive(Clone, Copy, Debug)]
struct PendingArc {
    chords: ArcChords,
    line: u32,
    speed: u64,
    /// The laser power its chords carry.
    power: LaserPower,
}

/// A finished feed move (a single move or a merged chain) held back under `G64 P` until the
/// next one, so the corner between them can be rounded ([`super::corner`]).
#[derive(Clone, Copy, Debug)]
struct Leg {
    /// Programmed start (the move's direction runs from here to `to`).
    start: Pos,
    /// Programmed end.
    to: Pos,
    /// Programmed length, nm (a rounded corner takes at most half of it from either end).
    length: u64,
    line: u32,
    speed: u64,
    /// Junction speed² limit at its start when it leaves a rounded corner.
    entry_sq: Option<u64>,
}

/// Where the queue's flow stands. An abort and a sync point exclude each other: an abort at a
/// sync point drops everything at once, and a sync point reached while an abort decelerates
/// finishes the abort.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Flow {
    /// Segments are prepared as the planner holds them.
    Open,
    /// The queue stopped at a sync point ([`Motion::sync_point`]) until it is released.
    AtSync,
    /// An abort decelerates on the path (as a hold); everything queued goes once stopped.
    Aborting,
}

/// Planner blocks a push may queue when it ends a held-back chain and leg: the leg up to a
/// rounded corner, the corner's polygon, the chain's leg itself, and the action.
const BLEND_RESERVE: usize = MAX_VERTICES + 2;

/// Planner + arc cutter + segment prep.
pub struct Motion<const N: usize> {
    cfg: MotionConfig,
    planner: Planner<N>,
    prep: Prep,
    arc: Option<PendingArc>,
    syncs: Deque<Canon, MAX_SYNCS>,
    /// End of the last queued move: machine position (nm) and its exact step position.
    position: Pos,
    steps: [i64; MAX_AXES],
    exact_stop: bool,
    junction_deviation: u64,
    /// `G64 P` tolerance, nm (0: no merging): short feed moves within it of one chord run as
    /// one block ([`super::blend`]).
    blend_tolerance: u64,
    /// Short feed moves held back to run as one chord (after everything in the planner and
    /// after `leg`).
    chain: Option<Chain>,
    /// The last finished feed move, held back until the corner after it is known.
    leg: Option<Leg>,
    flow: Flow,
    /// An on-the-fly M code waiting for the next line block.
    pending_output: Option<PendingOutput>,
    /// A hold, abort, speed change or bend waits for the owner to drop the queued segments.
    /// Independent of `flow`: every pair occurs (a hold at a sync point raises it, an abort
    /// raises it as its deceleration starts and keeps decelerating once it is answered).
    drop_wanted: bool,
    /// Laser mode: the power the program's M3/M4/M5 and S set for its feed moves.
    laser: LaserPower,
    /// The power of the line being queued ([`LaserPower::Keep`] without laser mode).
    line_power: LaserPower,
}

impl<const N: usize> Motion<N> {
    /// An idle pipeline at machine position 0.
    #[inline(always)] // see `Board::new`: no planner-sized temporary
    pub fn new(cfg: MotionConfig) -> Self {
        Motion {
            cfg,
            planner: Planner::new(),
            prep: Prep::with_laser(cfg.laser, cfg.thc).with_jerk(JerkSetup::of(&cfg)),
            arc: None,
            syncs: Deque::new(),
            position: [0; MAX_AXES],
            steps: [0; MAX_AXES],
            exact_stop: false,
            junction_deviation: blend_deviation(&cfg, cfg.blend_tolerance),
            blend_tolerance: cfg.blend_tolerance.max(0) as u64,
            chain: None,
            leg: None,
            flow: Flow::Open,
            pending_output: None,
            drop_wanted: false,
            laser: unpowered(&cfg),
            line_power: LaserPower::Keep,
        }
    }

    /// The power of a move that never fires the beam: off in laser mode, else none.
    #[inline(always)]
    fn unpowered(&self) -> LaserPower {
        unpowered(&self.cfg)
    }

    /// The laser power the program's feed moves carry now ([`LaserPower::Keep`] without laser
    /// mode), for status reports.
    pub fn laser(&self) -> LaserPower {
        self.laser
    }

    pub fn config(&self) -> &MotionConfig {
        &self.cfg
    }

    /// The planner (read-only, for status and tests).
    pub fn planner(&self) -> &Planner<N> {
        &self.planner
    }

    /// Machine position (nm) at the end of everything queued (a held-back chain included).
    pub fn queued_position(&self) -> Pos {
        self.chain.as_ref().map_or(self.blend_end(), Chain::end)
    }

    /// End of everything queued in the planner and the held-back leg (where a new chain starts).
    fn blend_end(&self) -> Pos {
        self.leg.map_or(self.position, |l| l.to)
    }

    /// Planner blocks a push needs room for.
    fn reserve(&self) -> usize {
        if self.chain.is_some() || self.leg.is_some() {
            BLEND_RESERVE
        } else {
            1
        }
    }

    /// Step position at the end of everything prepared (handed out as segments).
    pub fn prepared_steps(&self) -> [i64; MAX_AXES] {
        self.prep.position()
    }

    /// Sets the machine position (homing, G92-free resync). Only while idle; false otherwise.
    pub fn set_position(&mut self, position: Pos) -> bool {
        if self.state() != MotionState::Idle {
            return false;
        }
        self.position = position;
        self.steps = self.cfg.to_steps(&position);
        self.prep.set_position(self.steps);
        // A new frame: a height correction still in Z is part of the new position.
        self.prep.thc.absorbed();
        true
    }

    /// Queues one canonical action. Non-motion actions that must happen at rest become sync
    /// points. Its moves never fire a laser (jogs, homing, probing, the board's own moves).
    pub fn push(&mut self, canon: &Canon) -> Result<(), PushError> {
        self.push_as(canon, false)
    }

    /// Queues one canonical action of the program: as [`Self::push`], but in laser mode its
    /// M3/M4/M5 and S set the power of the feed moves after it, without stopping.
    pub(crate) fn push_program(&mut self, canon: &Canon) -> Result<(), PushError> {
        self.push_as(canon, true)
    }

    fn push_as(&mut self, canon: &Canon, program: bool) -> Result<(), PushError> {
        self.feed_arc();
        if self.arc.is_some() || !self.has_room(self.reserve(), 0) || self.aborting() {
            return Err(PushError::Full);
        }
        self.line_power = match canon.action {
            Action::Feed { .. } | Action::Arc { .. } if program => self.laser,
            _ => self.unpowered(),
        };
        if self.cfg.laser.is_some() {
            match canon.action {
                Action::Spindle { state, rpm } if program => {
                    self.laser = LaserPower::of(state, rpm);
                    return Ok(());
                }
                // A job's end, abort or tool change leaves the beam off (as the spindle).
                Action::ToolChange { .. } | Action::Stop(StopKind::End | StopKind::EndRewind) => {
                    self.laser = LaserPower::Off
                }
                _ => {}
            }
        }
        if let Action::Feed { to, feed } = canon.action {
            return self.push_feed(canon.line, &to, speed_of(feed));
        }
        // Anything else ends a held-back chain and leg first (the planner has room for them).
        self.flush_blend();
        if self.planner.is_full() {
            return Err(PushError::Full);
        }
        match canon.action {
            Action::Rapid { to } => self.push_straight(canon.line, &to, None),
            Action::Feed { .. } => Ok(()),
            Action::Arc {
                to,
                center,
                plane,
                dir,
                turns,
                feed,
            } => {
                let to = self.masked(&to);
                let chords =
                    ArcChords::new(&self.cfg, &self.position, &to, &center, plane, dir, turns);
                self.check_arc_travel(&chords, &center, plane, &to)?;
                self.arc = Some(PendingArc {
                    chords,
                    line: canon.line,
                    speed: speed_of(feed),
                    power: self.line_power,
                });
                self.feed_arc();
                Ok(())
            }
            Action::Dwell { micros } => {
                let pending = usize::from(self.pending_output.is_some());
                if !self.has_room(1 + pending, pending) {
                    return Err(PushError::Full);
                }
                self.output_to_sync();
                let counts = micros.saturating_mul(KERNEL_TIMER_HZ as u64 / 1_000_000);
                self.planner
                    .push_marker(Block::marker(BlockKind::Dwell { counts }, canon.line));
                Ok(())
            }
            Action::PathMode(mode) => {
                match mode {
                    crate::canon::PathMode::ExactStop => self.exact_stop = true,
                    crate::canon::PathMode::Blend { tolerance } => {
                        // `G64` without P (or P0) blends with the setup's default tolerance.
                        let tolerance = if tolerance > 0 {
                            tolerance
                        } else {
                            self.cfg.blend_tolerance
                        };
                        self.exact_stop = false;
                        self.blend_tolerance = tolerance.max(0) as u64;
                        self.junction_deviation = blend_deviation(&self.cfg, tolerance);
                    }
                }
                Ok(())
            }
            Action::Spindle { .. }
            | Action::SpindleOrient
            | Action::Coolant { .. }
            | Action::ToolChange { .. }
            | Action::UserMCode { .. }
            | Action::Probe { .. }
            | Action::Stop(_) => {
                let pending = usize::from(self.pending_output.is_some());
                if !self.has_room(1 + pending, 1 + pending) {
                    return Err(PushError::Full);
                }
                self.output_to_sync();
                self.push_sync(canon);
                Ok(())
            }
        }
    }

    /// Queues the on-the-fly user M code `code` of source line `line` (its list is one output
    /// command) that switches `output` without stopping: it fires as the next line block starts.
    /// A second one before that block makes both sync points (docs/controller.md, "On-the-fly outputs": two M codes between the
    /// same pair of motion blocks break the contour), performed as
    /// `Action::UserMCode { code, at_rest: false }`. `output` may be [`OutputEvent::NONE`] (a dry
    /// run skips the output but keeps the motion the same).
    pub fn push_output(
        &mut self,
        line: u32,
        code: u16,
        output: OutputEvent,
    ) -> Result<(), PushError> {
        self.feed_arc();
        if self.arc.is_some() || self.aborting() {
            return Err(PushError::Full);
        }
        if self.chain.is_some() || self.leg.is_some() {
            // The output fires where the chain ends: queue it first.
            if !self.has_room(BLEND_RESERVE, 0) {
                return Err(PushError::Full);
            }
            self.flush_blend();
        }
        let this = PendingOutput { line, code, output };
        if self.pending_output.is_none() {
            self.pending_output = Some(this);
            return Ok(());
        }
        if !self.has_room(2, 2) {
            return Err(PushError::Full);
        }
        self.output_to_sync();
        self.push_sync(&this.canon());
        Ok(())
    }

    /// No more motion follows (end of the program, or a rejected block): an on-the-fly M code
    /// still waiting for a line block becomes a sync point, performed when the motion before it
    /// has ended. `Full` while the queue has no room (call again).
    pub fn flush_output(&mut self) -> Result<(), PushError> {
        if self.pending_output.is_none() {
            return Ok(());
        }
        self.feed_arc();
        if self.arc.is_some() || self.aborting() || !self.has_room(1, 1) {
            return Err(PushError::Full);
        }
        self.output_to_sync();
        Ok(())
    }

    /// True while an on-the-fly M code waits for the next line block.
    pub fn output_pending(&self) -> bool {
        self.pending_output.is_some()
    }

    /// True while an abort decelerates (nothing new is taken).
    #[inline(always)]
    fn aborting(&self) -> bool {
        self.flow == Flow::Aborting
    }

    /// Room for `blocks` more planner blocks and `syncs` more sync points.
    #[inline(always)]
    fn has_room(&self, blocks: usize, syncs: usize) -> bool {
        self.planner.len() + blocks <= N && self.syncs.len() + syncs <= MAX_SYNCS
    }

    /// Queues a sync point (room checked by the caller).
    fn push_sync(&mut self, canon: &Canon) {
        let _ = self.syncs.push_back(*canon);
        self.planner
            .push_marker(Block::marker(BlockKind::Sync, canon.line));
    }

    /// The waiting on-the-fly M code, if any, becomes a sync point (room checked by the caller).
    fn output_to_sync(&mut self) {
        if let Some(p) = self.pending_output.take() {
            self.push_sync(&p.canon());
        }
    }

    /// Axes beyond the configured count stay where they are.
    fn masked(&self, to: &Pos) -> Pos {
        // One fixed-size copy of the target and the few unused axes from the position (copying
        // the position and then a slice of the target called the byte-wise `memcpy` twice; the
        // loop is the few stores clippy's `copy_from_slice` would turn back into a call).
        let mut p = *to;
        #[allow(clippy::manual_memcpy)]
        for i in self.cfg.axis_count as usize..MAX_AXES {
            p[i] = self.position[i];
        }
        p
    }

    /// A feed move: merged into the held-back chain when its chord holds (`G64 P`), else queued
    /// (after the chain, which it ends), or held back as the start of a new chain.
    fn push_feed(&mut self, line: u32, to: &Pos, speed: u64) -> Result<(), PushError> {
        // The travel check and `queue_line` read the configured axes only: the target is masked
        // only for the held-back chain and leg, which keep it.
        if let Some(axis) = self.cfg.travel_violation(to) {
            return Err(PushError::Travel { axis });
        }
        let (tolerance, axes) = (self.blend_tolerance, self.cfg.axis_count as usize);
        let mergeable = tolerance > 0
            && !self.exact_stop
            && self.pending_output.is_none()
            && self.cfg.laser.is_none();
        if mergeable {
            let to = self.masked(to);
            if let Some(chain) = self.chain.as_mut() {
                if chain.extend(&to, line, speed, tolerance, axes) {
                    return Ok(());
                }
                self.end_chain();
            }
            let start = self.blend_end();
            match Chain::new(&start, &to, line, speed, axes) {
                Some(chain) => self.chain = Some(chain),
                None => self.finish_leg(start, to, line, speed),
            }
            return Ok(());
        }
        // Not merged: a held-back chain ends, then the move is queued after it.
        if self.chain.is_some() {
            self.end_chain();
        }
        self.flush_blend();
        if self.planner.is_full() {
            return Err(PushError::Full);
        }
        self.queue_line(line, to, Some(speed));
        Ok(())
    }

    /// Ends the held-back chain: it becomes the held-back leg ([`Self::finish_leg`]).
    fn end_chain(&mut self) {
        // Read the chain in place: `take()` would move all its points (1.5 KiB) on every move.
        if let Some(chain) = self.chain.as_ref() {
            let (start, end, line, speed) = (chain.start(), chain.end(), chain.line, chain.speed);
            self.chain = None;
            self.finish_leg(start, end, line, speed);
        }
    }

    /// A finished feed move from `start` to `to`: the held-back leg before it is queued up to
    /// the corner between them, rounded within the tolerance when [`corner::round`] finds one
    /// (the corner's polygon follows it, reported with the leg's line), and this move becomes
    /// the held-back leg, joined at the corner's last vertex (the planner has room for
    /// [`BLEND_RESERVE`] blocks). Not inlined: it stays out of the plain `G64` path's `push`.
    #[inline(never)]
    fn finish_leg(&mut self, start: Pos, to: Pos, line: u32, speed: u64) {
        let mut next = Leg {
            start,
            to,
            length: length(&sub(&to, &start)),
            line,
            speed,
            entry_sq: None,
        };
        if let Some(prev) = self.leg.take() {
            let lengths = (prev.length, next.length);
            let rounded = corner::round(
                &self.cfg,
                &prev.start,
                &prev.to,
                &to,
                lengths,
                self.blend_tolerance,
            );
            match rounded {
                Some(c) => {
                    let arc_speed = arith::isqrt_u64(c.speed_sq).max(1);
                    let corner_speed = Some(prev.speed.min(arc_speed));
                    self.queue_line_at(prev.line, &c.vertices[0], Some(prev.speed), prev.entry_sq);
                    for v in c.vertices.iter().skip(1) {
                        self.queue_line_at(prev.line, v, corner_speed, Some(c.speed_sq));
                    }
                    next.entry_sq = Some(c.speed_sq);
                }
                None => self.queue_line_at(prev.line, &prev.to, Some(prev.speed), prev.entry_sq),
            }
        }
        self.leg = Some(next);
    }

    /// Queues the held-back chain and leg as they are (the planner has room for
    /// [`BLEND_RESERVE`] blocks).
    fn flush_blend(&mut self) {
        if self.chain.is_none() && self.leg.is_none() {
            return;
        }
        self.end_chain();
        if let Some(l) = self.leg.take() {
            self.queue_line_at(l.line, &l.to, Some(l.speed), l.entry_sq);
        }
    }

    fn push_straight(&mut self, line: u32, to: &Pos, speed: Option<u64>) -> Result<(), PushError> {
        // Both read the configured axes only (no masked copy of the target).
        if let Some(axis) = self.cfg.travel_violation(to) {
            return Err(PushError::Travel { axis });
        }
        self.queue_line(line, to, speed);
        Ok(())
    }

    /// Plans a line to `to` (the ring has room).
    fn queue_line(&mut self, line: u32, to: &Pos, speed: Option<u64>) {
        self.queue_line_at(line, to, speed, None);
    }

    /// Plans a line to `to` entering with at most `corner_sq` (nm²/s²) when given, instead of
    /// the junction deviation's limit (the ring has room). Axes beyond the configured count
    /// stay where they are, whatever `to` says of them.
    fn queue_line_at(&mut self, line: u32, to: &Pos, speed: Option<u64>, corner_sq: Option<u64>) {
        let req = LineRequest {
            line,
            speed,
            exact_stop_before: self.exact_stop,
            junction_deviation: self.junction_deviation,
            corner_sq,
            output: self.pending_output.map_or(OutputEvent::NONE, |p| p.output),
            laser: self.line_power,
        };
        // The planner asks for each configured axis's displacement once, in order: the step
        // target is converted and the new end stored as it is read (no displacement arrays
        // built, zero-filled and copied per line, which were `memclr`/`memcpy` calls on the
        // Cortex-M4). The other axes keep their position (`to` need not be masked) and the step
        // count `MotionConfig::to_steps` gives them (0).
        let axes = self.cfg.axis_count as usize;
        for i in axes..MAX_AXES {
            self.steps[i] = 0;
        }
        let blocks = self.planner.len();
        let (cfg, steps, position) = (&self.cfg, &mut self.steps, &mut self.position);
        let queued = self.planner.push_block(cfg, &req, |i| {
            if to[i] == position[i] {
                // An axis the line does not move makes no step (and costs no conversion: a
                // 64-bit division per axis on the Cortex-M4).
                return (0, 0);
            }
            let target = cfg.axes[i].nm_to_steps(to[i]);
            let moved = (target - steps[i], to[i] - position[i]);
            steps[i] = target;
            position[i] = to[i];
            moved
        });
        debug_assert!(queued);
        if self.planner.len() > blocks {
            // The waiting on-the-fly output rides on this block (a move without steps adds no
            // block and leaves it for the next one).
            self.pending_output = None;
        }
    }

    /// Moves chords of the pending arc into the ring while it has room. Inlined, the check
    /// alone: `push` and `next_segment` call it every time, and the out-of-line loop's prologue
    /// cost ~25 instructions per call without an arc.
    #[inline(always)]
    fn feed_arc(&mut self) {
        if self.arc.is_some() {
            self.feed_arc_chords();
        }
    }

    #[inline(never)]
    fn feed_arc_chords(&mut self) {
        while let Some(arc) = self.arc.as_mut() {
            if self.planner.is_full() || self.flow == Flow::Aborting {
                return;
            }
            let (line, speed) = (arc.line, arc.speed);
            self.line_power = arc.power;
            match arc.chords.next_point() {
                Some(p) => self.queue_line(line, &p, Some(speed)),
                None => self.arc = None,
            }
            if self.arc.is_some_and(|a| a.chords.is_done()) {
                self.arc = None;
            }
        }
    }

    /// Soft-limit check of an arc: its end and every axis extreme its sweep passes.
    fn check_arc_travel(
        &self,
        chords: &ArcChords,
        center: &[i64; 3],
        plane: crate::canon::Plane,
        to: &Pos,
    ) -> Result<(), PushError> {
        if let Some(axis) = self.cfg.travel_violation(to) {
            return Err(PushError::Travel { axis });
        }
        let (a0, a1, _) = plane_axes(plane);
        let (sx, sy) = (
            self.position[a0] - center[a0],
            self.position[a1] - center[a1],
        );
        let start = crate::arith::atan2(sy, sx);
        let sweep = chords.sweep();
        let r = {
            let (ex, ey) = (to[a0] - center[a0], to[a1] - center[a1]);
            let sq = |v: i64| arith::mul_i128(v as i128, v as i128);
            let r2 = |x: i64, y: i64| (sq(x) + sq(y)) as u128;
            crate::arith::isqrt_u128(r2(sx, sy).max(r2(ex, ey))) as i64
        };
        for k in 0..4i64 {
            let q = k * QUARTER_TURN;
            // Is the cardinal angle q inside the swept range?
            let rel = if sweep >= 0 {
                (q - start).rem_euclid(crate::arith::TURN)
            } else {
                (start - q).rem_euclid(crate::arith::TURN)
            };
            if rel <= sweep.abs() {
                let (dx, dy) = polar(r, q);
                let mut p = self.position;
                p[a0] = center[a0] + dx;
                p[a1] = center[a1] + dy;
                if let Some(axis) = self.cfg.travel_violation(&p) {
                    if axis == a0 || axis == a1 {
                        return Err(PushError::Travel { axis });
                    }
                }
            }
        }
        Ok(())
    }

    /// Prepares the next step segment for the kernel's queue (`None`: nothing now).
    pub fn next_segment(&mut self) -> Option<Segment> {
        let at_sync = self.flow == Flow::AtSync;
        if (self.chain.is_some() || self.leg.is_some()) && self.planner.len() < 2 && !at_sync {
            // The motion is about to run out: the held-back chain and leg run as they are.
            self.flush_blend();
        }
        if at_sync {
            return None;
        }
        loop {
            let out = self.prep.next(&mut self.planner);
            self.feed_arc();
            match out {
                PrepOut::Segment(s) => return Some(s),
                PrepOut::Sync => {
                    if self.aborting() {
                        // The abort drops the sync point with the rest; prep is idle now.
                        self.finish_abort();
                        continue;
                    }
                    self.flow = Flow::AtSync;
                    return None;
                }
                PrepOut::Idle => {
                    if self.aborting()
                        && (self.prep.state == PrepState::Held || self.planner.is_empty())
                    {
                        self.finish_abort();
                    }
                    return None;
                }
            }
        }
    }

    /// Host planning tools: like [`Self::next_segment`], but the head block whole, timed in
    /// closed form ([`Prep::next_block`]): `Some(counts)` for a finished line or dwell block,
    /// `None` at a sync point or with nothing queued. Not for a board: nothing is stepped.
    pub(crate) fn next_block(&mut self) -> Option<u64> {
        if self.flow == Flow::AtSync {
            return None;
        }
        let out = self.prep.next_block(&mut self.planner);
        self.feed_arc();
        match out {
            BlockOut::Time(counts) => Some(counts),
            // A sync point reached while aborting goes with the rest, as in `next_segment`
            // (no host planning tool aborts).
            BlockOut::Sync if self.aborting() => {
                self.finish_abort();
                None
            }
            BlockOut::Sync => {
                self.flow = Flow::AtSync;
                None
            }
            BlockOut::Idle => None,
        }
    }

    /// The sync point the queue stopped at: once the kernel has run every segment handed out,
    /// perform it, then call [`Self::release_sync`].
    pub fn sync_point(&self) -> Option<&Canon> {
        if self.flow == Flow::AtSync {
            self.syncs.front()
        } else {
            None
        }
    }

    /// Continues past the current sync point.
    pub fn release_sync(&mut self) {
        if self.flow == Flow::AtSync {
            self.flow = Flow::Open;
            self.syncs.pop_front();
            self.planner.pop();
        }
    }

    /// The report of the block segment prep finished last (once).
    pub(crate) fn take_report(&mut self) -> Option<BlockReport> {
        self.prep.take_report()
    }

    pub fn state(&self) -> MotionState {
        if self.flow == Flow::AtSync {
            return MotionState::Sync;
        }
        match self.prep.state {
            PrepState::Holding => MotionState::Holding,
            PrepState::Held => MotionState::Held,
            PrepState::Running => {
                if self.planner.is_empty()
                    && self.arc.is_none()
                    && self.chain.is_none()
                    && self.leg.is_none()
                    && !self.prep.is_active()
                {
                    MotionState::Idle
                } else {
                    MotionState::Running
                }
            }
        }
    }

    /// Feed hold: decelerate on the path and stop, from the end of the kernel's running segment
    /// once the owner has dropped the queued ones ([`Self::drop_request`]), else after them.
    pub fn feed_hold(&mut self) {
        if self.prep.state == PrepState::Running {
            self.prep.state = PrepState::Holding;
            self.drop_wanted = true;
        }
    }

    /// Sets the programmed speed (nm/min) of every queued feed move — a jog's single move — and
    /// ramps to it at the move's acceleration from the end of the kernel's running segment once
    /// the owner has dropped the queued ones (like a feed override without the queue's lag).
    /// Ignored while holding or stopping.
    pub(crate) fn change_speed(&mut self, feed: i64) {
        if self.prep.state == PrepState::Running && !self.aborting() {
            self.planner.set_programmed_speed(speed_of(feed));
            self.drop_wanted = true;
        }
    }

    /// Asks the owner to drop the queued segments (see [`Self::drop_request`]) without changing
    /// anything else: after [`Self::segments_dropped`], prep stands at the end of the kernel's
    /// running segment (for a [`Self::bend`]).
    pub(crate) fn request_drop(&mut self) {
        self.drop_wanted = true;
    }

    /// Bends the move in progress toward a new jog target without stopping (an analog stick
    /// turned): from where prep stands (after [`Self::segments_dropped`]: the end of the kernel's
    /// running segment) it keeps the old direction just as long as it needs to slow down to the
    /// corner speed the planner allows there (junction deviation, feed shift, the new move's
    /// speed), then runs to `target(corner)` at `feed` (nm/min). `target` gives the end of the new
    /// move from a start point (the jog's soft-limit edge). False, with nothing changed, when it
    /// cannot bend here: not a single line in progress (a jog), holding, or the new move too short
    /// to stop from the corner speed.
    pub fn bend(&mut self, feed: i64, target: impl Fn(&Pos) -> Option<Pos>) -> bool {
        if self.prep.state != PrepState::Running
            || self.flow != Flow::Open
            || self.arc.is_some()
            || !self.prep.is_active()
            || self.planner.len() != 1
            || self.pending_output.is_some()
            || self.chain.is_some()
            || self.leg.is_some()
        {
            return false;
        }
        let Some(head) = self.planner.head().copied() else {
            return false;
        };
        if !head.is_line() {
            return false;
        }
        let cfg = self.cfg;
        let here_steps = self.prep.position();
        let here = cfg.to_nm(&here_steps);
        // The old direction, from the head block's step counts.
        let mut old_delta = [0i64; MAX_AXES];
        for (i, d) in old_delta.iter_mut().enumerate() {
            let nm = cfg.axes[i].steps_to_nm(i64::from(head.steps[i]));
            *d = if head.dir & (1 << i) != 0 { -nm } else { nm };
        }
        let (Some(old), Some(first)) = (direction(&cfg, &old_delta), target(&here)) else {
            return false;
        };
        let Some(new) = direction(&cfg, &sub(&first, &here)) else {
            return false;
        };
        let v = self.prep.speed();
        let pct = u64::from(self.planner.feed_override());
        let new_speed = (speed_of(feed) * pct / 100).max(1).min(new.max_speed);
        let corner_sq = junction_limit_sq(&cfg, &old.unit, &new.unit, self.junction_deviation)
            .min(v * v)
            .min(new_speed * new_speed);
        // Slow down to the corner speed on the old line (never beyond its end).
        let two_a = head.accel.saturating_mul(2);
        let remaining = head.length.saturating_sub(self.prep.path_position());
        let slow = (v * v - corner_sq).div_ceil(two_a).min(remaining);
        let mut corner = here;
        for (c, u) in corner.iter_mut().zip(old.unit) {
            *c += arith::div_i128(
                arith::mul_i128(i128::from(u), i128::from(slow)),
                i128::from(UNIT),
            ) as i64;
        }
        let Some(to) = target(&corner) else {
            return false;
        };
        let rest = length(&sub(&to, &corner));
        if u128::from(new.accel) * 2 * u128::from(rest) < u128::from(corner_sq) {
            // Too close to the edge to stop from the corner speed.
            return false;
        }
        self.prep.cut();
        self.planner.clear();
        self.syncs.clear();
        self.steps = here_steps;
        self.position = here;
        self.planner.continue_from(old.unit);
        let exact_stop = core::mem::replace(&mut self.exact_stop, false);
        self.line_power = self.unpowered();
        if slow > 0 {
            // At the current speed (with the feed override), slowing for the corner.
            self.queue_line(0, &corner, Some(mul_div(v, 100, pct).max(1)));
        }
        self.queue_line(0, &to, Some(speed_of(feed)));
        self.exact_stop = exact_stop;
        true
    }

    /// How many of the newest segments handed out the owner should drop from the kernel's queue
    /// now, if they have not started (`None`: no request). Answer with [`Self::segments_dropped`]
    /// before asking for the next segment.
    pub fn drop_request(&self) -> Option<usize> {
        self.drop_wanted.then(|| self.prep.droppable(&self.planner))
    }

    /// The owner dropped the newest `k` segments (at most [`Self::drop_request`]) before the
    /// kernel started them: prep continues from the end of the last one kept.
    pub fn segments_dropped(&mut self, k: usize) {
        self.drop_wanted = false;
        self.prep.rewind(k, &self.planner);
    }

    /// Resumes after a hold, on the path, from where it stopped (or from the current speed).
    pub fn resume(&mut self) {
        if self.aborting() {
            return;
        }
        if self.prep.state != PrepState::Running {
            self.prep.state = PrepState::Running;
            self.planner.replan_all();
        }
    }

    /// Abort: decelerate on the path like a hold, then drop everything queued. The step position
    /// stays exact ([`Self::prepared_steps`]); the queued position becomes the stopped position.
    pub fn abort(&mut self) {
        self.arc = None;
        if self.flow == Flow::AtSync || !self.prep.is_active() {
            self.finish_abort();
        } else {
            self.flow = Flow::Aborting;
            self.feed_hold();
        }
    }

    fn finish_abort(&mut self) {
        self.planner.clear();
        self.chain = None;
        self.leg = None;
        self.syncs.clear();
        self.pending_output = None;
        self.arc = None;
        self.flow = Flow::Open;
        self.prep.reset();
        self.drop_wanted = false;
        self.steps = self.prep.position();
        self.position = self.cfg.to_nm(&self.steps);
        self.laser = self.unpowered();
    }

    /// Drops everything queued at once, without deceleration, and takes `steps` (normally
    /// [`super::kernel::StepKernel::position`]) as the exact position. For a limit stop: the kernel
    /// has already stopped stepping, so flush the segment queue, then call this.
    pub fn reset(&mut self, steps: [i64; MAX_AXES]) {
        self.prep.set_position(steps);
        self.finish_abort();
        self.prep.state = PrepState::Running;
    }

    /// Takes a new machine model and drops everything queued, in place, at step position `steps`
    /// (like [`Self::new`] followed by a position, but without a second `Motion` — tens of KiB —
    /// on the MCU's stack). Overrides are kept.
    pub(crate) fn reconfigure(&mut self, cfg: MotionConfig, steps: [i64; MAX_AXES]) {
        self.cfg = cfg;
        self.junction_deviation = blend_deviation(&cfg, cfg.blend_tolerance);
        self.blend_tolerance = cfg.blend_tolerance.max(0) as u64;
        self.exact_stop = false;
        self.prep = Prep::new();
        self.prep.set_laser(cfg.laser);
        self.prep.set_thc(cfg.thc);
        self.prep.set_jerk(JerkSetup::of(&cfg));
        self.reset(steps);
    }

    /// Torch height control (`motion/thc.rs`): what the inputs ask for the segments prepared
    /// from now on.
    #[inline(always)]
    pub(crate) fn set_thc_command(&mut self, cmd: ThcCommand) {
        self.prep.thc.command = cmd;
    }

    /// Torch height control switched by the program (`M62 P2` off, `M63 P2` on) or at a job's
    /// start (on).
    pub(crate) fn set_thc_enabled(&mut self, on: bool) {
        self.prep.thc.enabled = on;
    }

    /// The torch height correction made so far, Z steps (+ = up).
    pub(crate) fn thc_correction(&self) -> i32 {
        self.prep.thc.correction
    }

    /// At a sync point: a Z-only segment taking the height correction back towards 0 (`None`
    /// once it is 0, or when not at a sync point).
    pub(crate) fn thc_return_segment(&mut self) -> Option<Segment> {
        if self.flow != Flow::AtSync {
            return None;
        }
        self.prep.thc_return()
    }

    /// Laser mode: the spindle override, percent, that scales S in the segments prepared from
    /// now on (docs/laser-plasma.md).
    #[inline(always)]
    pub(crate) fn set_laser_override(&mut self, pct: u16) {
        self.prep.laser_override = pct;
    }

    /// Feed override in percent (clamped to 10-200), applied at once.
    pub fn set_feed_override(&mut self, pct: u16) {
        let rapid = self.planner.rapid_override();
        self.planner.set_overrides(pct.max(10).min(200), rapid);
    }

    /// Rapid override in percent (clamped to 1-100), applied at once.
    pub fn set_rapid_override(&mut self, pct: u16) {
        let feed = self.planner.feed_override();
        self.planner.set_overrides(feed, pct.max(1).min(100));
    }
}

/// Junction deviation while blending with `tolerance` (nm): the tolerance itself, or the
/// machine's junction deviation when blending is off (0).
fn blend_deviation(cfg: &MotionConfig, tolerance: i64) -> u64 {
    if tolerance > 0 {
        tolerance as u64
    } else {
        cfg.junction_deviation.max(0) as u64
    }
}

/// `a - b` per axis.
fn sub(a: &Pos, b: &Pos) -> Pos {
    let mut d = [0; MAX_AXES];
    for i in 0..MAX_AXES {
        d[i] = a[i] - b[i];
    }
    d
}

/// Euclidean length of a displacement, nm.
fn length(d: &Pos) -> u64 {
    let sq: u128 = d
        .iter()
        .map(|v| v.unsigned_abs() as u128 * v.unsigned_abs() as u128)
        .sum();
    crate::arith::isqrt_u128(sq) as u64
}

/// The power of a move that never fires the beam on machine `cfg`: off in laser mode, else none.
#[inline(always)]
fn unpowered(cfg: &MotionConfig) -> LaserPower {
    if cfg.laser.is_some() {
        LaserPower::Off
    } else {
        LaserPower::Keep
    }
}

/// nm/min → nm/s.
fn speed_of(feed: i64) -> u64 {
    (feed.max(0) as u64 / 60).max(1)
}

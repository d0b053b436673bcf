//! Canned cycles, generated lazily: one hole position or one peck per step, so a cycle with many
//! repeats or thousands of pecks never needs more than a few queue slots.
//!
//! The motions follow LinuxCNC's `interp_cycles.cc` (RS274 dialect) and GIXA's cycle table (gixa
//! dialect). All values are program coordinates on the plane axes `a`, `b` and the drilling axis
//! `c`; `offset` converts them to machine coordinates when an action is emitted.
//!
//! RS274NGC G87 (back boring) and G88 (boring, manual retract) follow rs274's canonical output
//! (goldens tests/golden/rs274/112-g87-back-bore and 113-g88-manual-retract). rs274's
//! ORIENT_SPINDLE after each spindle stop there has no action. G88, as in
//! LinuxCNC, emits no retract after its program stop: the interpreter takes the tool to be at the
//! clear level (the operator's job at the stop), and the next move starts from the hole's bottom
//! if the operator did not retract it.
//!
//! G76 fine boring (the Hurco ISNC manual's bore orient, only on a machine whose setup has an
//! orient output) stops the spindle at the bottom, orients it ([`Action::SpindleOrient`]), moves
//! the bar off the wall by I/J, rapids out, moves back over the hole and restarts the spindle.

use super::transform::Transform;
use crate::canon::{Action, Canon, Spindle, StopKind};
use crate::units::{Nm, Pos};

/// Maximum actions one step pushes (the tapping body: feed, 2 spindle, dwell, feed, 2 spindle).
pub const MAX_ACTIONS_PER_STEP: usize = 8;

/// What a cycle does at the bottom and on the way out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CycleBody {
    /// G81: feed down, rapid out.
    Drill,
    /// G82: feed down, dwell, rapid out.
    DrillDwell,
    /// G83 (and gixa G83 with zero clearance): pecks with a rapid out to R between them.
    PeckFull,
    /// G73 (and gixa G87): pecks with a short rapid back-off of `clearance`.
    PeckChipBreak,
    /// G84: feed down, reverse the spindle, dwell, feed out, restore the spindle.
    Tap,
    /// G85: feed down, feed out to R, rapid to clear.
    Bore,
    /// G86: feed down, dwell, spindle stop, rapid out, spindle restart.
    BoreSpindleStop,
    /// gixa G86: feed down, program pause (operator), rapid out.
    DrillPause,
    /// G89: feed down, dwell, feed out (to clear in RS274, to R then rapid in gixa).
    BoreDwell,
    /// gixa G88: punch: position only, then the M10 list.
    Punch,
    /// RS274NGC G87 back boring: spindle stopped, enter the hole at the offset position, back to
    /// the axis, spindle on, feed up to the middle level and back, stop, out at the offset.
    BackBore,
    /// RS274NGC G88: feed down, dwell, spindle stop, program stop (the operator retracts by hand),
    /// spindle restart. Like LinuxCNC, no retract is emitted: the next move starts at the bottom.
    BoreManualRetract,
    /// G76 fine boring: feed down, dwell (P > 0), spindle stop and orient, shift by the offset,
    /// rapid out, shift back, spindle restart.
    FineBore,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Position,
    Body,
    Peck,
    /// G87's way out of the hole (second half of its body).
    BackBoreOut,
    Finish,
}

/// One canned-cycle block being expanded.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CycleRun {
    pub line: u32,
    pub body: CycleBody,
    /// gixa positioning and retract rules.
    pub gixa: bool,
    /// Plane axes and drilling axis indices.
    pub axes: (usize, usize, usize),
    /// Program position of every axis (a, b, c slots are overwritten as the cycle moves).
    pub program: Pos,
    /// Program → machine offset.
    pub offset: Pos,
    /// The transforms in force (hole positions mirrored, scaled and rotated; the drilling
    /// axis is not scaled).
    pub xf: Transform,
    /// Per-repeat increments on a, b (G91).
    pub inc: (Nm, Nm),
    /// G91 polar increments per repeat (radius nm, angle 10⁻⁶ degree about the XY origin).
    pub polar_step: Option<(Nm, i64)>,
    pub r: Nm,
    pub bottom: Nm,
    pub clear: Nm,
    /// Drilling-axis value before the first hole (LinuxCNC `current_cc`).
    pub start_c: Nm,
    pub q: Nm,
    pub clearance: Nm,
    pub dwell_us: u64,
    pub feed: i64,
    pub spindle: Spindle,
    pub rpm: u32,
    /// User M code run at each punch position (gixa M10).
    pub punch_m_code: u16,
    /// G87 offsets on the plane axes (I/J/K of the plane) and the middle level on the drilling
    /// axis; G76's shift on the plane axes.
    pub back_bore_offset: (Nm, Nm),
    pub middle: Nm,
    pub repeats_left: u32,
    pub first: bool,
    depth: Nm,
    phase: Phase,
}

impl CycleRun {
    /// A run ready to start (`repeats` ≥ 1).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        line: u32,
        body: CycleBody,
        gixa: bool,
        axes: (usize, usize, usize),
        program: Pos,
        offset: Pos,
        repeats: u32,
    ) -> Self {
        CycleRun {
            line,
            body,
            gixa,
            axes,
            program,
            offset,
            xf: Transform::OFF,
            inc: (0, 0),
            polar_step: None,
            r: 0,
            bottom: 0,
            clear: 0,
            start_c: program[axes.2],
            q: 0,
            clearance: 0,
            dwell_us: 0,
            feed: 0,
            spindle: Spindle::Off,
            rpm: 0,
            punch_m_code: 10,
            back_bore_offset: (0, 0),
            middle: 0,
            repeats_left: repeats,
            first: true,
            depth: 0,
            phase: Phase::Position,
        }
    }

    fn machine(&self) -> Pos {
        let mut p = self.program;
        if self.xf.active() {
            let w = self.xf.forward([p[0], p[1], p[2]], self.axes.2);
            p[..3].copy_from_slice(&w);
        }
        for (v, o) in p.iter_mut().zip(self.offset) {
            *v += o;
        }
        p
    }

    fn push(&self, out: &mut impl FnMut(Canon), action: Action) {
        out(Canon {
            line: self.line,
            action,
        })
    }

    /// Program position of axis `axis`. This and [`Self::set`] are the run's only indexing of
    /// `program`: one bounds check each instead of one per use (flash).
    #[inline(never)]
    fn at(&self, axis: usize) -> Nm {
        self.program[axis]
    }

    /// Moves axis `axis` to `v` (program position).
    #[inline(never)]
    fn set(&mut self, axis: usize, v: Nm) {
        self.program[axis] = v;
    }

    /// The hole's position in the plane.
    fn plane(&self) -> (Nm, Nm) {
        (self.at(self.axes.0), self.at(self.axes.1))
    }

    /// Moves the hole in the plane.
    fn set_plane(&mut self, at: (Nm, Nm)) {
        self.set(self.axes.0, at.0);
        self.set(self.axes.1, at.1);
    }

    /// The drilling-axis position.
    fn c(&self) -> Nm {
        self.at(self.axes.2)
    }

    /// Moves the drilling axis.
    fn set_c(&mut self, c: Nm) {
        self.set(self.axes.2, c);
    }

    /// The next hole: one G91 increment in the plane.
    fn advance(&mut self) {
        let (a, b) = self.plane();
        self.set_plane((a + self.inc.0, b + self.inc.1));
    }

    fn rapid_c(&mut self, c: Nm, out: &mut impl FnMut(Canon)) {
        self.set_c(c);
        let to = self.machine();
        self.push(out, Action::Rapid { to });
    }

    fn feed_c(&mut self, c: Nm, out: &mut impl FnMut(Canon)) {
        self.set_c(c);
        let to = self.machine();
        let feed = self.feed;
        self.push(out, Action::Feed { to, feed });
    }

    /// Rapid to plane position (`pa`, `pb`) at drilling level `c`.
    fn rapid_abc(&mut self, pa: Nm, pb: Nm, c: Nm, out: &mut impl FnMut(Canon)) {
        self.set_plane((pa, pb));
        self.rapid_c(c, out)
    }

    /// The hole's plane position and the G87 offset position.
    fn hole_and_offset(&self) -> ((Nm, Nm), (Nm, Nm)) {
        let hole = self.plane();
        let (oa, ob) = self.back_bore_offset;
        (hole, (hole.0 + oa, hole.1 + ob))
    }

    fn dwell(&self, out: &mut impl FnMut(Canon)) {
        self.push(
            out,
            Action::Dwell {
                micros: self.dwell_us,
            },
        );
    }

    fn spindle(&self, state: Spindle, out: &mut impl FnMut(Canon)) {
        self.push(
            out,
            Action::Spindle {
                state,
                rpm: if state == Spindle::Off { 0 } else { self.rpm },
            },
        );
    }

    /// Pushes the next few actions; returns false when the cycle is complete (nothing pushed).
    pub fn step(&mut self, out: &mut impl FnMut(Canon)) -> bool {
        match self.phase {
            Phase::Position => return self.position(out),
            Phase::Peck => self.peck(out),
            Phase::Body => self.body(out),
            Phase::BackBoreOut => self.back_bore_out(out),
            Phase::Finish => {
                // The hole is done: on to the next one.
                self.repeats_left -= 1;
                self.phase = Phase::Position;
                return self.position(out);
            }
        }
        true
    }

    /// The next hole (false when none is left): the plane move and the approach to R (gixa:
    /// in the plane at the current level, then to R; a punch stops there for its M code).
    #[inline(always)]
    fn position(&mut self, out: &mut impl FnMut(Canon)) -> bool {
        if self.repeats_left == 0 {
            return false;
        }
        let current_c = self.c();
        self.advance();
        self.polar_move();
        // The plane axes hold the hole already: each rapid below goes there too.
        if self.gixa {
            // Rapid in the plane at the current level, then down (or up) to R.
            self.rapid_c(current_c, out);
            if self.body == CycleBody::Punch {
                self.push(
                    out,
                    Action::UserMCode {
                        code: self.punch_m_code,
                        // A punch needs the machine stopped at its position.
                        at_rest: true,
                    },
                );
                self.first = false;
                self.repeats_left -= 1;
                return true;
            }
            if current_c != self.r {
                self.rapid_c(self.r, out);
            }
        } else if self.first && self.start_c > self.r {
            self.rapid_c(self.start_c, out);
            self.rapid_c(self.r, out);
        } else {
            self.rapid_c(self.clear, out);
            if self.clear > self.r {
                self.rapid_c(self.r, out);
            }
        }
        self.first = false;
        self.depth = self.r - self.q;
        self.phase = match self.body {
            CycleBody::PeckFull | CycleBody::PeckChipBreak => Phase::Peck,
            _ => Phase::Body,
        };
        true
    }

    /// One peck down to the next depth and its retract (to R, or a short back-off), or the
    /// last one to the bottom and out to the clear level.
    #[inline(always)]
    fn peck(&mut self, out: &mut impl FnMut(Canon)) {
        if self.depth > self.bottom {
            let depth = self.depth;
            self.feed_c(depth, out);
            if self.body == CycleBody::PeckFull {
                self.rapid_c(self.r, out);
            }
            self.rapid_c(depth + self.clearance, out);
            self.depth -= self.q;
        } else {
            self.feed_c(self.bottom, out);
            self.rapid_c(self.clear, out);
            self.phase = Phase::Finish;
        }
    }

    /// The body of a non-pecking cycle at the hole (G87's first half; its way out is
    /// [`Self::back_bore_out`]).
    #[inline(always)]
    fn body(&mut self, out: &mut impl FnMut(Canon)) {
        let (bottom, clear, r) = (self.bottom, self.clear, self.r);
        self.phase = Phase::Finish;
        match self.body {
            CycleBody::Drill => {
                self.feed_c(bottom, out);
                self.rapid_c(clear, out);
            }
            CycleBody::DrillDwell => {
                self.feed_c(bottom, out);
                self.dwell(out);
                self.rapid_c(clear, out);
            }
            CycleBody::Tap => self.tap(out),
            CycleBody::Bore => {
                self.feed_c(bottom, out);
                self.feed_c(r, out);
                if !self.gixa || clear != r {
                    self.rapid_c(clear, out);
                }
            }
            CycleBody::BoreSpindleStop => {
                self.feed_c(bottom, out);
                self.dwell(out);
                self.spindle(Spindle::Off, out);
                self.rapid_c(clear, out);
                self.spindle(self.spindle, out);
            }
            CycleBody::DrillPause => {
                self.feed_c(bottom, out);
                self.push(out, Action::Stop(StopKind::Pause));
                self.rapid_c(clear, out);
            }
            CycleBody::BoreDwell => {
                self.feed_c(bottom, out);
                self.dwell(out);
                if self.gixa {
                    self.feed_c(r, out);
                    if clear != r {
                        self.rapid_c(clear, out);
                    }
                } else {
                    self.feed_c(clear, out);
                }
            }
            CycleBody::BackBore => {
                let (hole, off) = self.hole_and_offset();
                self.rapid_abc(off.0, off.1, r, out);
                self.spindle(Spindle::Off, out);
                self.rapid_c(bottom, out);
                self.rapid_abc(hole.0, hole.1, bottom, out);
                self.spindle(self.spindle, out);
                self.feed_c(self.middle, out);
                self.feed_c(bottom, out);
                self.phase = Phase::BackBoreOut;
            }
            CycleBody::BoreManualRetract => {
                self.feed_c(bottom, out);
                self.dwell(out);
                self.spindle(Spindle::Off, out);
                self.push(out, Action::Stop(StopKind::Pause));
                self.spindle(self.spindle, out);
            }
            CycleBody::FineBore => {
                let (hole, off) = self.hole_and_offset();
                self.feed_c(bottom, out);
                if self.dwell_us > 0 {
                    self.dwell(out);
                }
                self.spindle(Spindle::Off, out);
                // The board sets the orient output and waits at rest; the shift comes after.
                self.push(out, Action::SpindleOrient);
                self.rapid_abc(off.0, off.1, bottom, out);
                self.rapid_c(clear, out);
                self.rapid_abc(hole.0, hole.1, clear, out);
                self.spindle(self.spindle, out);
            }
            CycleBody::PeckFull | CycleBody::PeckChipBreak | CycleBody::Punch => {}
        }
    }

    /// G84 (and G74): feed down, reverse the spindle (RS274: stopped first), dwell, feed out
    /// (gixa: to R, then rapid to clear), the spindle turning as before.
    #[inline(always)]
    fn tap(&mut self, out: &mut impl FnMut(Canon)) {
        let (bottom, clear, r) = (self.bottom, self.clear, self.r);
        let (reverse, forward) = if self.spindle == Spindle::Cw {
            (Spindle::Ccw, Spindle::Cw)
        } else {
            (Spindle::Cw, Spindle::Ccw)
        };
        self.feed_c(bottom, out);
        if !self.gixa {
            self.spindle(Spindle::Off, out);
        }
        self.spindle(reverse, out);
        if self.dwell_us > 0 {
            self.dwell(out);
        }
        if self.gixa {
            self.feed_c(r, out);
            self.spindle(forward, out);
            if clear != r {
                self.rapid_c(clear, out);
            }
        } else {
            self.feed_c(clear, out);
            self.spindle(Spindle::Off, out);
            self.spindle(forward, out);
        }
    }

    /// G87's way out: spindle stopped, to the offset position at the bottom, out to the clear
    /// level, back over the hole, spindle on again.
    #[inline(always)]
    fn back_bore_out(&mut self, out: &mut impl FnMut(Canon)) {
        let (hole, off) = self.hole_and_offset();
        self.spindle(Spindle::Off, out);
        self.rapid_abc(off.0, off.1, self.bottom, out);
        self.rapid_c(self.clear, out);
        self.rapid_abc(hole.0, hole.1, self.clear, out);
        self.spindle(self.spindle, out);
        self.phase = Phase::Finish;
    }

    /// One G91 polar increment of the hole position (LinuxCNC: radius, then angle).
    fn polar_move(&mut self) {
        if let Some((dr, da)) = self.polar_step {
            let at = self.plane();
            let step = |r: Option<Nm>, d: Option<i64>, at| {
                super::geometry::polar_end(at, r, d, false).unwrap_or(at)
            };
            let mut at = at;
            if dr != 0 {
                at = step(Some(dr), None, at);
            }
            if da != 0 {
                at = step(None, Some(da), at);
            }
            self.set_plane(at);
        }
    }

    /// Program position after the whole run (for the interpreter's state).
    pub(crate) fn final_program_position(&self) -> Pos {
        let mut run = *self;
        if self.polar_step.is_some() {
            for _ in 0..self.repeats_left {
                run.advance();
                run.polar_move();
            }
        } else {
            let n = self.repeats_left as i64;
            let (a, b) = run.plane();
            run.set_plane((a + self.inc.0 * n, b + self.inc.1 * n));
        }
        // Punching never moves the drilling axis.
        if self.body != CycleBody::Punch {
            run.set_c(self.clear);
        }
        run.program
    }
}

//! The interpreter's canned-cycle blocks (G73-G89 as the dialect reads them), in the order of
//! their checks: the block's cycle and its refusals, its words read against the cycle memory,
//! the first hole and the levels, the body's own words, then the [`CycleRun`]
//! (`gcode/cycles.rs`) that expands the holes lazily, one step at a time.

use super::*;

/// What every step of one cycle block reads.
struct CycleBlock {
    /// The cycle's G code (×10).
    code: u16,
    body: CycleBody,
    /// Columns of the cycle's G word (for errors without a word of their own).
    g_cols: Option<(u16, u16)>,
    gixa: bool,
    /// The block repeats the cycle in force: its remembered words stand in for missing ones.
    same: bool,
    /// First and second plane axes and the drilling axis ([`arc_axes`]).
    axes: (usize, usize, usize),
    /// The program point, its drilling axis where the tool is (a transform leaves that axis alone).
    prog: Pos,
    /// The drilling-axis level before the cycle (the first cycle block's, remembered).
    initial: Nm,
}

/// A cycle block's position words, read (consumed) against the cycle memory.
struct CycleWords {
    /// The plane-axis words in nm, as written (absolute or incremental).
    plane: (Option<Nm>, Option<Nm>),
    /// The `@`/`^` polar words (XY plane only).
    polar: Option<PolarWords>,
    /// The R and drilling-axis words, for the columns of an error.
    r_word: Option<Word>,
    depth_word: Option<Word>,
    /// R and the depth as written, or remembered.
    r_raw: Nm,
    depth_raw: Nm,
    /// G87's offsets per axis (X, Y, Z), written or remembered.
    back_bore: Option<[Nm; 3]>,
    /// L (or K): how many times the cycle runs (0: it only sets the cycle memory).
    repeats: u32,
}

/// The first hole and the levels of a cycle, program coordinates.
struct CyclePlace {
    /// The first hole on the plane axes (G91: where the tool is; each repeat adds `inc` first).
    hole: (Nm, Nm),
    /// G91: the increment per repeat on the plane axes.
    inc: (Nm, Nm),
    /// G91 polar words: radius and angle added per repeat.
    polar_step: Option<(Nm, i64)>,
    r: Nm,
    bottom: Nm,
}

/// A cycle body's own words: the peck (Q) and the dwell (P).
struct BodyWords {
    q: Nm,
    dwell_us: u64,
}

/// The body of cycle `code` in the dialect (`None`: no such cycle, or G76 on a machine
/// without an oriented spindle stop).
fn cycle_body(gixa: bool, orient: bool, code: u16) -> Option<CycleBody> {
    Some(match (gixa, code) {
        (false, G76) if orient => CycleBody::FineBore,
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
        _ => return None,
    })
}

impl Interpreter {
    /// A canned-cycle block: checked and resolved in the steps below, the cycle memory updated,
    /// and the run started (the tool first rises to R when it stands below it).
    #[inline(never)]
    pub(super) fn cycle(&mut self, b: &mut Block, line: u32, code: u16) -> Res<()> {
        let cb = self.cycle_block(b, code)?;
        let words = self.cycle_words(b, &cb)?;
        let place = self.cycle_place(&cb, &words)?;
        let body = self.body_words(b, &cb)?;
        self.state.cycle = CycleMemory {
            r: Some(words.r_raw),
            depth: Some(words.depth_raw),
            q: if body.q > 0 {
                Some(body.q)
            } else {
                self.state.cycle.q
            },
            dwell_us: Some(body.dwell_us),
            initial_level: Some(cb.initial),
            back_bore: words.back_bore,
        };
        if words.repeats == 0 {
            return Ok(());
        }
        self.start_cycle(line, &cb, &words, &place, &body)
    }

    /// The block's cycle and the refusals that need none of its words: inverse time, rotary
    /// axis words, no feed, a mirrored drilling axis.
    #[inline(always)]
    fn cycle_block(&self, b: &Block, code: u16) -> Res<CycleBlock> {
        let gixa = self.gixa();
        let g_cols = b.g_cols(code);
        let Some(body) = cycle_body(gixa, self.config.spindle_orient, code) else {
            return Err((ErrorCode::CycleNotSupported, g_cols));
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
        let axes = arc_axes(self.state.plane);
        let c = axes.2;
        // Under a transform the hole positions are program points; the drilling axis is neither
        // mirrored nor scaled (Hurco §3.18), so its level is where the tool is.
        if self.state.xf.mirror >> c & 1 != 0 {
            return Err((ErrorCode::NotSupported, g_cols));
        }
        let mut prog = self.state.program_point();
        prog[c] = self.state.position[c] - self.state.axis_offset(c);
        Ok(CycleBlock {
            code,
            body,
            g_cols,
            gixa,
            same: self.state.motion == MotionMode::Cycle(code),
            axes,
            prog,
            initial: self.state.cycle.initial_level.unwrap_or(prog[c]),
        })
    }

    /// The block's position words (plane axes, polar, R, depth, G87's I/J/K, L), each written
    /// or, where the dialect allows, remembered.
    #[inline(always)]
    fn cycle_words(&self, b: &mut Block, cb: &CycleBlock) -> Res<CycleWords> {
        let (a, bx, c) = cb.axes;
        let mem = self.state.cycle;
        let polar = if self.state.plane == Plane::XY {
            self.polar_words(b)?
        } else {
            None
        };
        let a_w = b.take(AXIS_LETTERS[a]);
        let b_w = b.take(AXIS_LETTERS[bx]);
        let depth_word = b.take(AXIS_LETTERS[c]);
        let r_word = b.take(b'R');
        let plane = (
            a_w.map(|w| self.axis_value(a, w)).transpose()?,
            b_w.map(|w| self.axis_value(bx, w)).transpose()?,
        );
        let r_raw = match r_word {
            Some(w) => self.len_word(w)?,
            None if cb.same || cb.gixa => mem.r.unwrap_or(0),
            None => return Err((ErrorCode::CycleRMissing, cb.g_cols)),
        };
        let depth_raw = match depth_word {
            Some(w) => self.len_word(w)?,
            None => match mem.depth {
                Some(d) if cb.same || cb.gixa => d,
                _ if cb.body == CycleBody::Punch => 0,
                _ => return Err((ErrorCode::CycleDepthMissing, cb.g_cols)),
            },
        };
        let back_bore = match cb.body {
            CycleBody::BackBore => Some(self.back_bore_words(b, cb)?),
            CycleBody::FineBore => Some(self.fine_bore_shift(b, cb)?),
            _ => mem.back_bore,
        };
        let mut repeats = 1u32;
        if !cb.gixa {
            if let Some(w) = b.take(b'L').or_else(|| b.take(b'K')) {
                repeats = w
                    .integer()
                    .filter(|v| (0..=1_000_000).contains(v))
                    .ok_or((ErrorCode::CycleRepeatInvalid, Some(w.cols)))?
                    as u32;
            }
        }
        Ok(CycleWords {
            plane,
            polar,
            r_word,
            depth_word,
            r_raw,
            depth_raw,
            back_bore,
            repeats,
        })
    }

    /// G87's offsets on the plane axes and the middle level, each on the I/J/K letter of its
    /// axis (so K is not a repeat count here), indexed by axis. LinuxCNC keeps them for the
    /// following G87 blocks.
    #[inline(always)]
    fn back_bore_words(&self, b: &mut Block, cb: &CycleBlock) -> Res<[Nm; 3]> {
        let (a, bx, c) = cb.axes;
        let mut kept = [0; 3];
        for axis in [a, bx, c] {
            kept[axis] = match b.take(b"IJK"[axis]) {
                Some(w) => self.len_word(w)?,
                None => match self.state.cycle.back_bore {
                    Some(m) if cb.same => m[axis],
                    _ => return Err((ErrorCode::CycleBackBoreWordMissing, cb.g_cols)),
                },
            };
        }
        Ok(kept)
    }

    /// G76's shift on the plane axes (I/J in G17, K/I in G18, J/K in G19), indexed by axis: a
    /// missing word is the remembered one in a repeated G76 block, else 0 (Hurco: I/J are
    /// signed increments). Q (Fanuc's shift, its direction a machine parameter) is refused.
    #[inline(always)]
    fn fine_bore_shift(&self, b: &mut Block, cb: &CycleBlock) -> Res<[Nm; 3]> {
        if let Some(w) = b.word(b'Q') {
            return err(ErrorCode::CycleFineBoreQ, Some(w));
        }
        let (a, bx, _) = cb.axes;
        let mut kept = [0; 3];
        for axis in [a, bx] {
            kept[axis] = match b.take(b"IJK"[axis]) {
                Some(w) => self.len_word(w)?,
                None => match self.state.cycle.back_bore {
                    Some(m) if cb.same => m[axis],
                    _ => 0,
                },
            };
        }
        Ok(kept)
    }

    /// The first hole, the increments and the R and bottom levels from the words in the
    /// dialect's and the distance mode's reading; refused when R is below the bottom or a
    /// value leaves the coordinate range.
    #[inline(always)]
    fn cycle_place(&self, cb: &CycleBlock, w: &CycleWords) -> Res<CyclePlace> {
        let (a, bx, _) = cb.axes;
        let (prog, initial, absolute) = (cb.prog, cb.initial, self.state.absolute);
        let (a_v, b_v) = w.plane;
        let mut hole = (0, 0);
        let mut polar_step = None;
        if let (Some((radius, angle, cols)), false) = (w.polar, cb.gixa) {
            let at = (prog[a], prog[bx]);
            if absolute {
                hole = geometry::polar_end(at, radius, angle, true).map_err(|c| (c, Some(cols)))?;
            } else {
                geometry::polar_end(at, radius, angle, false).map_err(|c| (c, Some(cols)))?;
                polar_step = Some((radius.unwrap_or(0), angle.unwrap_or(0)));
            }
        }
        let (hole, inc, r, bottom) = if cb.gixa {
            let hole = if absolute {
                (a_v.unwrap_or(prog[a]), b_v.unwrap_or(prog[bx]))
            } else {
                (prog[a] + a_v.unwrap_or(0), prog[bx] + b_v.unwrap_or(0))
            };
            let (r, bottom) = if absolute {
                (w.r_raw, w.depth_raw)
            } else {
                let r = initial - w.r_raw.abs();
                (r, r - w.depth_raw.abs())
            };
            (hole, (0, 0), r, bottom)
        } else if absolute {
            if w.polar.is_none() {
                hole = (a_v.unwrap_or(prog[a]), b_v.unwrap_or(prog[bx]));
            }
            (hole, (0, 0), w.r_raw, w.depth_raw)
        } else {
            let r = w.r_raw + initial;
            let inc = (a_v.unwrap_or(0), b_v.unwrap_or(0));
            ((prog[a], prog[bx]), inc, r, r + w.depth_raw)
        };
        if r < bottom && cb.body != CycleBody::Punch {
            let cols = w.r_word.or(w.depth_word).map(|w| w.cols).or(cb.g_cols);
            return Err((ErrorCode::CycleRBelowBottom, cols));
        }
        for v in [hole.0, hole.1, r, bottom] {
            if v.abs() > MAX_COORD {
                return Err((ErrorCode::CoordinateOverflow, cb.g_cols));
            }
        }
        let travel = (inc.0.abs() as i128 + inc.1.abs() as i128) * w.repeats as i128;
        if travel > MAX_COORD as i128 {
            return Err((ErrorCode::CoordinateOverflow, cb.g_cols));
        }
        Ok(CyclePlace {
            hole,
            inc,
            polar_step,
            r,
            bottom,
        })
    }

    /// The body's own words: Q of a pecking cycle, P of a dwelling one (gixa: the stored
    /// dwell), and the spindle the body needs turning (RS274).
    #[inline(always)]
    fn body_words(&self, b: &mut Block, cb: &CycleBlock) -> Res<BodyWords> {
        let (body, gixa, mem) = (cb.body, cb.gixa, self.state.cycle);
        let mut q = 0;
        if matches!(body, CycleBody::PeckFull | CycleBody::PeckChipBreak) {
            let q_w = b.take(b'Q');
            q = match q_w {
                Some(w) => self.len_word(w)?,
                None if cb.same || gixa => mem.q.unwrap_or(0),
                None => 0,
            };
            let cols = q_w.map(|w| w.cols).or(cb.g_cols);
            if q <= 0 {
                return Err((ErrorCode::CycleQInvalid, cols));
            }
            if gixa && body == CycleBody::PeckChipBreak && q <= self.config.gixa.partial_retract {
                return Err((ErrorCode::CyclePeckNotAboveRetract, cols));
            }
        }
        let mut dwell_us = 0;
        if gixa {
            dwell_us = self.state.stored_dwell_us;
        } else if body == CycleBody::FineBore {
            // P is optional (Hurco: the dwell at the bottom before the orient).
            dwell_us = match b.take(b'P') {
                Some(w) => self.dwell_us(w)?,
                None if cb.same => mem.dwell_us.unwrap_or(0),
                None => 0,
            };
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
                None if cb.same || body == CycleBody::Tap => mem.dwell_us.unwrap_or(0),
                None => return Err((ErrorCode::CycleDwellMissing, cb.g_cols)),
            };
        }
        if !gixa && !self.cycle_spindle_ok(cb) {
            return Err((ErrorCode::CycleSpindleState, cb.g_cols));
        }
        Ok(BodyWords { q, dwell_us })
    }

    /// RS274: the spindle turns as the body needs (a tap's direction; turning for a body that
    /// stops and restarts it).
    #[inline(always)]
    fn cycle_spindle_ok(&self, cb: &CycleBlock) -> bool {
        match cb.body {
            // G74 taps left-handed: down with M4, reversed to M3 at the bottom.
            CycleBody::Tap if cb.code == G74 => self.state.spindle == Spindle::Ccw,
            CycleBody::Tap => self.state.spindle == Spindle::Cw,
            CycleBody::BoreSpindleStop
            | CycleBody::BackBore
            | CycleBody::BoreManualRetract
            | CycleBody::FineBore => self.state.spindle != Spindle::Off,
            _ => true,
        }
    }

    /// Starts the run (at least one repeat): RS274 first raises a tool below R to R where it
    /// stands; the run's parameters are set and the position becomes the run's end (through
    /// the transforms when they are on).
    #[inline(always)]
    fn start_cycle(
        &mut self,
        line: u32,
        cb: &CycleBlock,
        w: &CycleWords,
        place: &CyclePlace,
        body: &BodyWords,
    ) -> Res<()> {
        let (a, bx, c) = cb.axes;
        let (gixa, r) = (cb.gixa, place.r);
        let offset = self.state.offset();
        let raise_first = !gixa && cb.initial < r;
        if raise_first {
            // LinuxCNC: a tool below R first rises to R where it stands.
            // (The drilling axis is neither mirrored, scaled nor turned by a transform.)
            let mut to = self.state.position;
            to[c] = r + offset[c];
            self.push(line, Action::Rapid { to })?;
        }
        let mut program = cb.prog;
        (program[a], program[bx]) = place.hole;
        if raise_first {
            program[c] = r;
        }
        let old_c = if raise_first { r } else { cb.initial };
        let clear = if self.state.retract_to_r { r } else { old_c };
        let clearance = match (gixa, cb.body) {
            (true, CycleBody::PeckFull) => 0,
            (true, _) => self.config.gixa.partial_retract,
            (false, _) => self.config.peck_clearance,
        };
        let feed = self.len(self.state.feed);
        let (xf, spindle, rpm, absolute) = (
            self.state.xf,
            self.state.spindle,
            self.state.rpm,
            self.state.absolute,
        );
        // Built in place (a failing block clears it with the rest of the block's work).
        let run = self.cycle.insert(CycleRun::new(
            line, cb.body, gixa, cb.axes, program, offset, w.repeats,
        ));
        run.xf = xf;
        run.inc = place.inc;
        run.polar_step = place.polar_step;
        run.r = r;
        run.bottom = place.bottom;
        run.clear = clear;
        run.q = body.q;
        run.clearance = clearance;
        run.dwell_us = body.dwell_us;
        if let (CycleBody::BackBore | CycleBody::FineBore, Some(m)) = (cb.body, w.back_bore) {
            run.back_bore_offset = (m[a], m[bx]);
            // K (the drilling-axis letter) is absolute in G90 and relative to the bottom in G91.
            run.middle = if absolute { m[c] } else { place.bottom + m[c] };
        }
        run.feed = feed;
        run.spindle = spindle;
        run.rpm = rpm;
        let mut machine = run.final_program_position();
        for (v, o) in machine.iter_mut().zip(offset) {
            *v += o;
        }
        if xf.active() {
            self.xf_point(&mut machine, c, true)?;
        }
        self.state.position = machine;
        Ok(())
    }
}

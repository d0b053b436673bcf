//! The interpreter's motion: targets from axis words through the coordinate transforms and
//! offsets, feeds, and the motion modes (straight, arc, canned cycle) turned into canonical
//! actions (the transforms pipeline is documented in docs/gcode-transforms.md).

use super::*;

impl Interpreter {
    /// The machine end point of a move from the block's axis words (consumed), with LinuxCNC's
    /// polar coordinates (`@` radius, `^` angle about the XY origin) for X and Y, written over
    /// `to` (the current position on entry). Written through a reference: returned in a
    /// `Res<Pos>` it was copied byte by byte several times per line on the Cortex-M4.
    pub(super) fn target(&self, b: &mut Block, g53: bool, to: &mut Pos) -> Res<()> {
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
    pub(super) fn start_point(&self, to: &mut Pos) {
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
    pub(super) fn move_target(&mut self, b: &mut Block, g53: bool, to: &mut Pos) -> Res<()> {
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
    pub(super) fn xf_point(&mut self, to: &mut Pos, keep: usize, end: bool) -> Res<()> {
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
    pub(super) fn transform(&mut self, to: &mut Pos) -> Res<()> {
        if self.state.xf.active() {
            self.xf_point(to, 3, true)?;
        }
        Ok(())
    }

    /// Checks of a block under (or setting) a transform, before phase 0: G51 alone, no plane
    /// change under G68, no G92/G52/G10 L20 under a transform; and G16's X and Y become `@`
    /// and `^` (LinuxCNC's polar words about the XY origin) where they are a move's end point.
    #[inline(never)]
    pub(super) fn check_transforms(&mut self, b: &mut Block) -> Res<()> {
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
    pub(super) fn set_transforms(&mut self, b: &mut Block) -> Res<()> {
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
    pub(super) fn polar_words(&self, b: &mut Block) -> Res<Option<PolarWords>> {
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
    pub(super) fn straight_feed(&self, from: &Pos, to: &Pos, f_given: bool) -> Res<i64> {
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

    pub(super) fn inverse_time_feed(&self, length: i128) -> Res<i64> {
        let feed = crate::arith::div_i128(length * self.state.feed as i128, MICRO as i128);
        if feed > i64::MAX as i128 / 4 {
            return err(ErrorCode::CoordinateOverflow, None);
        }
        Ok((feed as i64).max(1))
    }

    pub(super) fn motion(
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
    pub(super) fn plain_motion(
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
            MotionMode::Rapid | MotionMode::Linear if self.stays_under_transform(b, g53) => {}
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
            MotionMode::Spline(code) => self.spline(b, line, code)?,
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

    /// True for a G0/G1 block without axis words under a mirror, scaling or rotation: it makes
    /// no motion, as on Fanuc, Hurco and LinuxCNC. The transformed image of the program point is
    /// not where the tool stands when the transform was set there (a G51.1 keeps the tool in
    /// place, [`Interpreter::set_transforms`]), so going through the pipeline would rapid to it.
    fn stays_under_transform(&self, b: &Block, g53: bool) -> bool {
        !g53 && self.state.xf.active() && !b.has_any(AXIS_WORDS)
    }

    /// G5 cubic (`I J` from the start, `P Q` from the end to the control points) and G5.1
    /// quadratic (`I J` from the start) splines, as LinuxCNC's `convert_spline`: XY plane only,
    /// not under cutter compensation, transforms or G93; X and Y only. A G5 without I and J
    /// continues the G5 before it smoothly (its −P, −Q).
    #[inline(never)]
    pub(super) fn spline(&mut self, b: &mut Block, line: u32, code: u16) -> Res<()> {
        let cols = b.g_cols(code);
        if self.gixa() {
            return Err((ErrorCode::UnknownGCode, cols));
        }
        self.refuse_under_comp(cols)?;
        let xf = &self.state.xf;
        if self.state.plane != Plane::XY || xf.active() || xf.polar || self.state.inverse_time {
            return Err((ErrorCode::NotSupported, cols));
        }
        for letter in [b'Z', b'A', b'B', b'C', b'@', b'^'] {
            if let Some(w) = b.word(letter) {
                return err(ErrorCode::NotSupported, Some(w));
            }
        }
        if self.state.feed == 0 {
            return err(ErrorCode::ZeroFeedRate, None);
        }
        let missing = Err((ErrorCode::SplineWordMissing, cols));
        let (i, j) = (b.take(b'I'), b.take(b'J'));
        let cubic = code == G5;
        let (p, q) = if cubic {
            (b.take(b'P'), b.take(b'Q'))
        } else {
            (None, None)
        };
        let start = self.state.position;
        let mut to = start;
        self.target(b, false, &mut to)?;
        let first = match (i, j) {
            (Some(i), Some(j)) => (self.len_word(i)?, self.len_word(j)?),
            (None, None) if cubic => match self.spline_next_ij {
                Some(ij) => ij,
                None => return missing,
            },
            _ => return missing,
        };
        let c1 = (start[0] + first.0, start[1] + first.1);
        let feed = self.len(self.state.feed);
        let end = (to[0], to[1]);
        let run = if cubic {
            let (Some(p), Some(q)) = (p, q) else {
                return missing;
            };
            let (p, q) = (self.len_word(p)?, self.len_word(q)?);
            self.spline_next_ij = Some((-p, -q));
            let c2 = (end.0 + p, end.1 + q);
            SplineRun::new(line, start, &[c1, c2], end, feed, self.state.inch)
        } else {
            SplineRun::new(line, start, &[c1], end, feed, self.state.inch)
        };
        self.spline = Some(run);
        self.state.position = to;
        Ok(())
    }

    #[inline(never)]
    pub(super) fn arc(&mut self, b: &mut Block, line: u32, cw: bool, f_given: bool) -> Res<()> {
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
            wrong = match self.config.off_plane_offset {
                OffPlaneOffset::Refused => b.word(letter(normal)),
                OffPlaneOffset::Ignored => {
                    // grbl reads and drops it (its parser clears I, J and K after the arc).
                    let _ = b.take(letter(normal));
                    None
                }
            };
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
}

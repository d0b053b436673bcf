//! The interpreter's program flow: O-word control (if/else/while/do/repeat, subroutines),
//! M98/M99 and G65 calls, and the macro frames they push (the block grammar is in
//! `gcode/oword.rs`; the interpreter's state in `gcode/interp/mod.rs`).

use super::*;

impl Interpreter {
    /// The value of the expression after an O-word keyword (`[#1 LT 3]`).
    pub(super) fn o_value(&self, bytes: &[u8], o: &OLine) -> Res<Fx> {
        let mut c = Cursor::new(bytes, o.rest);
        if c.peek() != Some(b'[') {
            return Err((ErrorCode::ExpressionSyntax, Some(o.cols)));
        }
        expr::real_value(&mut c, &self.reader(), 0)
            .map_err(|(code, at)| (code, Some((at as u16, at as u16 + 1))))
    }

    /// The label of a computed O-word number `o[expr]` (LinuxCNC's `read_integer_value`: a
    /// whole number within 0.0001, not negative).
    pub(super) fn resolve_label(&self, bytes: &[u8], o: &mut OLine) -> Res<()> {
        let Some(at) = o.computed else {
            return Ok(());
        };
        let mut c = Cursor::new(bytes, at as usize);
        let v = expr::bracketed(&mut c, &self.reader(), 0)
            .map_err(|(code, at)| (code, Some((at as u16, at as u16 + 1))))?;
        let rounded = (v + ONE / 2).div_euclid(ONE);
        if (v - rounded * ONE).abs() > ONE / 10_000 {
            return Err((ErrorCode::NotAnInteger, Some(o.cols)));
        }
        if !(0..=u32::MAX as i64).contains(&rounded) {
            return Err((ErrorCode::ValueOutOfRange, Some(o.cols)));
        }
        o.label = rounded as Label;
        Ok(())
    }

    pub(super) fn start_skip(&mut self, label: Label, to: SkipTo) -> Res<Parsed> {
        self.skip = Some(Skip { label, to });
        Ok(Parsed::Nothing)
    }

    pub(super) fn remember_sub(&mut self, label: Label, line: u32) -> Res<()> {
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
    pub(super) fn skip_line(&mut self, line: u32, bytes: &[u8]) -> Res<bool> {
        let (Some(mut o), Some(skip)) = (oword::parse(bytes), self.skip) else {
            return Ok(true);
        };
        // A computed number that cannot be evaluated here is not the label looked for.
        if self.resolve_label(bytes, &mut o).is_err() {
            return Ok(true);
        }
        if o.label != skip.label {
            return Ok(true);
        }
        if skip.to == SkipTo::EndSub && matches!(o.keyword, Keyword::EndSub | Keyword::Return) {
            // LinuxCNC evaluates the value of an `endsub`/`return` of a definition it skips.
            self.returned = self.return_value(bytes, &o)?;
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
    pub(super) fn control(&mut self, line: u32, bytes: &[u8], o: OLine) -> Res<Parsed> {
        let unbalanced = Err((ErrorCode::UnbalancedBlock, Some(o.cols)));
        let top = self.loops.last().copied().filter(|l| l.label == o.label);
        match o.keyword {
            Keyword::Sub => {
                self.remember_sub(o.label, line)?;
                self.start_skip(o.label, SkipTo::EndSub)
            }
            Keyword::EndSub | Keyword::Return => self.o_return(line, bytes, o),
            Keyword::Call => self.o_call(line, bytes, o),
            Keyword::If => {
                if self.o_value(bytes, &o)? != 0 {
                    Ok(Parsed::Nothing)
                } else {
                    self.start_skip(o.label, SkipTo::IfBranch)
                }
            }
            Keyword::ElseIf | Keyword::Else => self.start_skip(o.label, SkipTo::EndIf),
            Keyword::EndIf => Ok(Parsed::Nothing),
            Keyword::While => self.o_while(line, bytes, o, top),
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

    /// `o.. endsub` / `o.. return`: back to the caller of the `o.. call` on top (its #1-#30
    /// and loops restored); refused when no call of this label is open.
    #[inline(always)]
    fn o_return(&mut self, line: u32, bytes: &[u8], o: OLine) -> Res<Parsed> {
        let unbalanced = Err((ErrorCode::UnbalancedBlock, Some(o.cols)));
        // Read with the subroutine's parameters, before the caller's come back.
        let value = self.return_value(bytes, &o)?;
        let level = self.call_level();
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
        self.returned = value;
        self.leave_level(level, line)?;
        Ok(Parsed::Jump(call.return_line))
    }

    /// The optional value of `o… endsub [v]` / `o… return [v]` (`None` without one).
    fn return_value(&self, bytes: &[u8], o: &OLine) -> Res<Option<Fx>> {
        let mut c = Cursor::new(bytes, o.rest);
        if c.peek() != Some(b'[') {
            return Ok(None);
        }
        expr::bracketed(&mut c, &self.reader(), 0)
            .map(Some)
            .map_err(|(code, at)| (code, Some((at as u16, at as u16 + 1))))
    }

    /// `o.. call [a] [b]...`: the arguments become #1-#30 (the caller's saved), then on to
    /// the subroutine's first line, or a skip to its definition when it has not been met.
    #[inline(always)]
    fn o_call(&mut self, line: u32, bytes: &[u8], o: OLine) -> Res<Parsed> {
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

    /// `o.. while [c]`: the end of a `do` loop (back to its start while c holds), a `while`
    /// loop met again (on, or skip past its `endwhile`), or a new loop (entered, or skipped).
    #[inline(always)]
    fn o_while(&mut self, line: u32, bytes: &[u8], o: OLine, top: Option<Loop>) -> Res<Parsed> {
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

    pub(super) fn push_loop(&mut self, o: OLine, kind: LoopKind, line: u32) -> Res<()> {
        self.loops
            .push(Loop {
                label: o.label,
                kind,
                line,
            })
            .map_err(|_| (ErrorCode::ParameterTableFull, Some(o.cols)))
    }

    pub(super) fn end_repeat(&mut self, top: Option<Loop>, o: OLine) -> Res<Parsed> {
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

    pub(super) fn flow(
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
                self.contexts.clear();
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
                let level = self.call_level();
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
                        self.leave_level(level, line)?;
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

    pub(super) fn call(
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
    pub(super) fn macro_call(
        &mut self,
        b: &mut Block,
        line: u32,
        src: &mut impl ProgramSource,
    ) -> Res<()> {
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

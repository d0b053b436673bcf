//! Deterministic driver: planner + prep + kernel on virtual time, reporting every step event.
//!
//! Used by the tests, the cross-target vectors, `gantry simulate` and the emulated board. Time is
//! counted in kernel timer counts ([`KERNEL_TIMER_HZ`]); each kernel tick advances it by the period
//! the tick returned. Segments go through a small FIFO exactly as on the board (prep in the main
//! context, the kernel pulling from the queue), and sync points are released automatically once
//! the kernel has drained (override [`Sim::auto_release`] to act on them yourself).

use super::config::MotionConfig;
use super::pipeline::{Motion, MotionState, PushError};
use super::prep::BlockReport;
use crate::canon::{Action, Canon};
use crate::setup::MAX_MCODE_LISTS;
use crate::step::kernel::{Segment, SegmentSource, StepKernel, TickOut, KERNEL_TIMER_HZ};
use crate::step::output_event::OutputEvent;
use heapless::Deque;

/// Segments queued between prep and the kernel in this planner-level simulation (≈ 16 ms at 2 ms
/// per segment). Not the board's queue: the firmware and the emulated board queue
/// `device::main_loop::SEGMENT_QUEUE_DEPTH` (15) segments. Kept at 8 here: the motion digests and
/// the Cortex-M target vectors were recorded with it.
pub(crate) const SEGMENT_QUEUE: usize = 8;

/// One tick that stepped at least one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepEvent {
    /// Virtual time of the tick, kernel timer counts.
    pub time: u64,
    pub step: u8,
    pub dir: u8,
}

/// Everything the driver reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SimEvent {
    Step(StepEvent),
    /// A tick switched a user output (an on-the-fly event), before that tick's steps.
    Output {
        time: u64,
        output: OutputEvent,
        /// The kernel's user output word after it.
        outputs: u16,
    },
    /// Segment prep finished a block (reported when prepared, `time` is the virtual time then).
    Block {
        report: BlockReport,
        time: u64,
    },
    /// The kernel drained at a sync point; it is released after this event when auto-releasing.
    Sync {
        canon: Canon,
        time: u64,
    },
}

/// The SPSC segment queue between prep and the kernel.
#[derive(Default)]
pub struct SegmentFifo<const Q: usize>(pub Deque<Segment, Q>);

impl<const Q: usize> crate::step::SegmentQueue for SegmentFifo<Q> {
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl<const Q: usize> SegmentSource for SegmentFifo<Q> {
    fn next_segment(&mut self) -> Option<Segment> {
        self.0.pop_front()
    }
}

/// Planner, prep and kernel on virtual time.
pub struct Sim<const N: usize> {
    pub motion: Motion<N>,
    pub kernel: StepKernel,
    pub fifo: SegmentFifo<SEGMENT_QUEUE>,
    /// Virtual time, kernel timer counts.
    pub now: u64,
    /// Release sync points automatically once the kernel is idle.
    pub auto_release: bool,
    /// Times the kernel went idle while motion was running and not at a sync (segment underrun).
    pub underruns: u32,
    /// Limit flag handed to the kernel.
    pub stop: bool,
    /// User M codes that switch an output on the fly (`McodeList::on_the_fly` of the setup's
    /// lists): [`Sim::run`] queues them with [`Motion::push_output`] as the board does.
    pub on_the_fly: heapless::Vec<(u16, OutputEvent), MAX_MCODE_LISTS>,
}

impl<const N: usize> Sim<N> {
    pub fn new(cfg: MotionConfig) -> Self {
        Sim {
            motion: Motion::new(cfg),
            kernel: StepKernel::new(),
            fifo: SegmentFifo::default(),
            now: 0,
            auto_release: true,
            underruns: 0,
            stop: false,
            on_the_fly: heapless::Vec::new(),
        }
    }

    /// Queues one action: an on-the-fly user M code (see [`Sim::on_the_fly`]) with
    /// [`Motion::push_output`], a G38 probe move as the feed move it is when nothing trips it
    /// (its longest case, never powered), anything else as the program's with
    /// [`Motion::push_program`] (in laser mode S and M3/M4/M5 do not stop, as on the board).
    pub fn push(&mut self, c: &Canon) -> Result<(), PushError> {
        if let Action::Probe { to, feed, .. } = c.action {
            let feed_move = Canon {
                line: c.line,
                action: Action::Feed { to, feed },
            };
            return self.motion.push(&feed_move);
        }
        if let Action::UserMCode {
            code,
            at_rest: false,
        } = c.action
        {
            if let Some(&(_, output)) = self.on_the_fly.iter().find(|(m, _)| *m == code) {
                return self.motion.push_output(c.line, code, output);
            }
        }
        self.motion.push_program(c)
    }

    /// Virtual time in seconds × 1000 (milliseconds, rounded down).
    pub fn millis(&self) -> u64 {
        self.now / (KERNEL_TIMER_HZ as u64 / 1000)
    }

    /// Tops up the segment queue from prep.
    pub fn fill(&mut self, on: &mut impl FnMut(SimEvent)) {
        while !self.fifo.0.is_full() {
            let seg = self.motion.next_segment();
            if let Some(report) = self.motion.take_report() {
                on(SimEvent::Block {
                    report,
                    time: self.now,
                });
            }
            match seg {
                Some(s) => {
                    let _ = self.fifo.0.push_back(s);
                }
                None => break,
            }
        }
    }

    /// Runs one kernel tick and advances virtual time. Returns the tick's output (`period == 0`:
    /// the kernel is idle; time does not advance).
    pub fn tick(&mut self, on: &mut impl FnMut(SimEvent)) -> TickOut {
        if self.fifo.0.len() < SEGMENT_QUEUE / 2 {
            self.fill(on);
        }
        let out = self.kernel.tick(&mut self.fifo, self.stop, false);
        if out.output.is_some() {
            on(SimEvent::Output {
                time: self.now,
                output: out.output,
                outputs: self.kernel.outputs(),
            });
        }
        if out.step != 0 {
            on(SimEvent::Step(StepEvent {
                time: self.now,
                step: out.step,
                dir: out.dir,
            }));
        }
        if out.period == 0 {
            self.fill(on);
            if let Some(canon) = self.motion.sync_point().copied() {
                if self.fifo.0.is_empty() {
                    on(SimEvent::Sync {
                        canon,
                        time: self.now,
                    });
                    if self.auto_release {
                        self.motion.release_sync();
                    }
                }
            } else if self.fifo.0.is_empty() && self.motion.state() == MotionState::Running {
                self.underruns += 1;
            }
        }
        self.now += out.period as u64;
        out
    }

    /// Runs until the kernel is idle and nothing more can be prepared (program done, held, or
    /// waiting at a sync point that is not auto-released).
    pub fn run_until_idle(&mut self, on: &mut impl FnMut(SimEvent)) {
        let mut idle_ticks = 0;
        loop {
            let out = self.tick(on);
            if out.period == 0 {
                idle_ticks += 1;
                if idle_ticks > 2 {
                    return;
                }
            } else {
                idle_ticks = 0;
            }
        }
    }

    /// Runs a whole program: pushes actions whenever the queue accepts them and ticks the kernel.
    pub fn run(
        &mut self,
        program: impl IntoIterator<Item = Canon>,
        on: &mut impl FnMut(SimEvent),
    ) -> Result<(), (Canon, PushError)> {
        let mut feeder = Feeder::new(program.into_iter());
        let mut idle_ticks = 0;
        loop {
            feeder.feed(self)?;
            let exhausted = feeder.exhausted();
            let out = self.tick(on);
            if out.period == 0 {
                idle_ticks += 1;
                let stuck = matches!(
                    self.motion.state(),
                    MotionState::Held | MotionState::Sync | MotionState::Idle
                );
                if exhausted && stuck && idle_ticks > 2 && !self.motion.output_pending() {
                    return Ok(());
                }
                if idle_ticks > 1_000_000 {
                    return Ok(());
                }
            } else {
                idle_ticks = 0;
            }
        }
    }
}

impl<const N: usize> Sim<N> {
    /// Runs a whole program like [`Sim::run`], but takes each planned block whole and adds its
    /// closed-form duration to [`Sim::now`] ([`Motion::next_block`]: the profile segment prep
    /// would cut into segments, timed by [`super::profile::Profile::duration`]) instead of
    /// stepping the kernel, so the work grows with the number of blocks, not with segments,
    /// steps or dwell time. `Block` events carry the time the block ends; sync points are
    /// released at once. The total agrees with [`Sim::run`]'s to within the rounding of segment
    /// periods and the re-profiling of a block whose exit speed rises while it runs (the test
    /// `closed_form_time_agrees_with_the_stepped_run` below bounds it).
    pub fn run_planned(
        &mut self,
        program: impl IntoIterator<Item = Canon>,
        on: &mut impl FnMut(SimEvent),
    ) -> Result<(), (Canon, PushError)> {
        let mut feeder = Feeder::new(program.into_iter());
        loop {
            feeder.feed(self)?;
            let exhausted = feeder.exhausted();
            let counts = self.motion.next_block();
            if let Some(c) = counts {
                self.now += c;
            }
            if let Some(report) = self.motion.take_report() {
                on(SimEvent::Block {
                    report,
                    time: self.now,
                });
            }
            if counts.is_none() {
                if let Some(canon) = self.motion.sync_point().copied() {
                    on(SimEvent::Sync {
                        canon,
                        time: self.now,
                    });
                    self.motion.release_sync();
                } else if exhausted && !self.motion.output_pending() {
                    return Ok(());
                }
            }
        }
    }
}

/// Hands a program's actions to a [`Sim`] whenever its queue accepts them (for [`Sim::run`] and
/// for host tools that advance the simulation their own way).
pub struct Feeder<I> {
    program: I,
    /// An action the full queue refused, pushed first next time.
    pending: Option<Canon>,
    exhausted: bool,
}

impl<I: Iterator<Item = Canon>> Feeder<I> {
    pub fn new(program: I) -> Self {
        Feeder {
            program,
            pending: None,
            exhausted: false,
        }
    }

    /// Pushes actions until the queue is full or the program has ended; once it has ended, a
    /// waiting on-the-fly M code is flushed (retried each call while the queue is full).
    pub fn feed<const N: usize>(&mut self, sim: &mut Sim<N>) -> Result<(), (Canon, PushError)> {
        while !self.exhausted {
            let Some(c) = self.pending.take().or_else(|| self.program.next()) else {
                self.exhausted = true;
                break;
            };
            match sim.push(&c) {
                Ok(()) => {}
                Err(PushError::Full) => {
                    self.pending = Some(c);
                    break;
                }
                Err(e) => return Err((c, e)),
            }
        }
        if self.exhausted {
            let _ = sim.motion.flush_output();
        }
        Ok(())
    }

    /// Every action of the program has been pushed.
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::gcode::{InterpConfig, Interpreter, MemorySource};

    fn canon(program: &str) -> std::vec::Vec<Canon> {
        let mut interp = Interpreter::new(&InterpConfig::default());
        let mut src = MemorySource::new(program.as_bytes());
        core::iter::from_fn(|| interp.next(&mut src))
            .map(|c| c.unwrap())
            .collect()
    }

    /// (total counts, block reports) of a program, stepped or in closed form.
    fn both(
        program: &str,
    ) -> (
        (u64, std::vec::Vec<BlockReport>),
        (u64, std::vec::Vec<BlockReport>),
    ) {
        let actions = canon(program);
        let cfg = MotionConfig::from_setup(&crate::setup::Setup::default());
        let reports = |sim: &mut Sim<128>, stepped: bool| {
            let mut out = std::vec::Vec::new();
            let mut on = |e: SimEvent| {
                if let SimEvent::Block { report, .. } = e {
                    out.push(report);
                }
            };
            if stepped {
                sim.run(actions.iter().copied(), &mut on).unwrap();
            } else {
                sim.run_planned(actions.iter().copied(), &mut on).unwrap();
            }
            (sim.now, out)
        };
        let mut stepped = std::boxed::Box::new(Sim::<128>::new(cfg));
        let mut planned = std::boxed::Box::new(Sim::<128>::new(cfg));
        (reports(&mut stepped, true), reports(&mut planned, false))
    }

    /// µm as a G-code number in mm.
    fn mm_text(um: i64) -> std::string::String {
        std::format!(
            "{}{}.{:03}",
            if um < 0 { "-" } else { "" },
            um.abs() / 1000,
            um.abs() % 1000
        )
    }

    /// Relative difference in parts per million.
    fn ppm(a: u64, b: u64) -> u64 {
        a.abs_diff(b) * 1_000_000 / a.max(1)
    }

    #[test]
    fn closed_form_time_agrees_with_the_stepped_run() {
        let mut fine = std::string::String::from("G21 G90 G0 X0 Y0 Z1\nG1 Z0 F3000\n");
        for i in 1..=3000i64 {
            // A fine 3D polyline: 0.05 mm steps with small corners and a slow Z wave.
            // Triangle waves in µm: Y ±2 mm over 400 lines, Z 0..-1 mm over 1000 lines.
            let x = i * 50;
            let y = (i % 400 - 200).abs() * 20 - 2000;
            let z = -((i % 1000 - 500).abs() * 2);
            fine.push_str(&std::format!(
                "X{} Y{} Z{}\n",
                mm_text(x),
                mm_text(y),
                mm_text(z)
            ));
        }
        let programs = [
            include_str!("../../../examples/bracket.ngc"),
            "G21 G90 F600\nG0 X5 Y5 Z5\nG1 Z-1\nG2 X15 Y5 I5 J0\nG3 X5 Y5 I-5 J0 F1200\n\
             G99 G83 X20 Y20 Z-4 R1 Q0.3\nX25\nG80\nG4 P0.2\nG0 Z5\nG1 X0 Y0\nM30\n",
            fine.as_str(),
        ];
        for program in programs {
            let ((stepped, sr), (planned, pr)) = both(program);
            // Same blocks in the same order, the same entry and exit speeds to 0.1 %; total time
            // to 1 ppm (measured: 7 counts of 12 MHz on each program). The stepped run loses no
            // tick-period rounding at block ends: what a block's last segment leaves out is paid
            // in the next block's first segment (`owed` in `motion/prep.rs`); before that, 357 ppm
            // on the 0.05 mm polyline.
            assert_eq!(sr.len(), pr.len());
            for (s, p) in sr.iter().zip(&pr) {
                assert_eq!((s.line, s.length, s.rapid), (p.line, p.length, p.rapid));
                assert!(s.exit.abs_diff(p.exit) <= s.exit / 1000 + 1, "{s:?} {p:?}");
                assert!(
                    s.entry.abs_diff(p.entry) <= s.entry / 1000 + 1,
                    "{s:?} {p:?}"
                );
            }
            std::println!(
                "stepped {stepped} planned {planned}: {} ppm",
                ppm(stepped, planned)
            );
            assert!(ppm(stepped, planned) <= 1, "{stepped} {planned}");
        }
    }

    #[test]
    fn closed_form_work_does_not_grow_with_dwell_time() {
        let ((stepped, _), (planned, reports)) = both("G4 P2\nG1 X1 F60\nG4 P3\n");
        assert_eq!(planned, stepped);
        // 5 s of dwell plus 1 mm at 1 mm/s (the start speed: no ramps).
        assert_eq!(planned, 6 * KERNEL_TIMER_HZ as u64);
        assert_eq!(reports.len(), 1);
    }
}

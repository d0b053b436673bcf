//! Deterministic driver: planner + prep + kernel on virtual time, reporting every step event.
//!
//! Used by the tests, the cross-target vectors, `gantry simulate` and the emulated board. Time is
//! counted in kernel timer counts ([`KERNEL_TIMER_HZ`]); each kernel tick advances it by the period
//! the tick returned. Segments go through a small FIFO exactly as on the board (prep in the main
//! context, the kernel pulling from the queue), and sync points are released automatically once
//! the kernel has drained (override [`Sim::auto_release`] to act on them yourself).

use super::config::MotionConfig;
use super::kernel::{Segment, SegmentSource, StepKernel, TickOut, KERNEL_TIMER_HZ};
use super::output_event::OutputEvent;
use super::pipeline::{Motion, MotionState, PushError};
use super::prep::BlockReport;
use crate::canon::{Action, Canon};
use crate::setup::MAX_MCODE_LISTS;
use heapless::Deque;

/// Segments queued between prep and the kernel in this planner-level simulation (≈ 16 ms at 2 ms
/// per segment). Not the board's queue: the firmware and the emulated board queue
/// `board::main_loop::SEGMENT_QUEUE_DEPTH` (15) segments. Kept at 8 here: the motion digests and
/// the Cortex-M target vectors were recorded with it.
pub const SEGMENT_QUEUE: usize = 8;

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
    /// (its longest case), anything else with [`Motion::push`].
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
        self.motion.push(c)
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

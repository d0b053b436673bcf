//! The step interrupt's body, apart from the registers it writes: one run per step event.
//!
//! The firmware runs it in the TIM2 compare-1 interrupt (`step.rs`) over the real timer and GPIO
//! registers; `target-tests/src/bin/bench_step.rs` includes this same file and runs it over a
//! memory-backed fake of those registers to count its instructions. So it depends on nothing but
//! the core and `core`, and reaches the hardware only through [`StepHardware`].
//!
//! Timeline of one step (timer counts from the update that starts a period):
//! - count 0, the update: a DMA request copies the *step word* (a GPIO BSRR word raising this
//!   step's pins) to the step port: the rising edges come from the hardware, on time;
//! - count `pulse`, compare 1 and compare 2: one DMA request drops every step pin (the pulse end),
//!   the other overwrites the step word with that same reset word, so an update the body did not
//!   prepare raises nothing; and this interrupt starts;
//! - the body ([`StepIsr::on_pulse_end`]): writes the dir pins of the step computed on the run
//!   before, the step word for the next update and the timer period that follows it, then runs
//!   the kernel's tick for the step after. A dir pin that changes does so at least `dir_setup`
//!   counts before the next update, because the body writes nothing unless the timer says there
//!   is that much time left ([`StepIsr::on_pulse_end`] returns [`Run::Late`] and the next period
//!   retries); when no dir pin changes, it only needs time for its own writes.
//!
//! A late run never loses or repeats a step: the step word it would have written is kept for the
//! next period, and the word the hardware copies at an unprepared update is the reset word.

use gantry_machine::motion::kernel::{
    SegmentSource, StepKernel, StepTiming, TickOut, KERNEL_TIMER_HZ,
};
use gantry_machine::motion::output_event::OutputEvent;

/// Tick period while the kernel is idle (1 ms), i.e. how often an empty queue is polled.
pub const IDLE_PERIOD_COUNTS: u32 = KERNEL_TIMER_HZ / 1_000;

/// Timer counts (83.3 ns each) kept between the body's timer read and the next update, for its
/// writes in between: the step word must be in CCR3 before the update copies it. The F411
/// firmware's handler runs 23 instructions from the read to that write (31 with an output
/// event), about 35-45 cycles with the TIM2 read; 6 counts are 48 cycles at 96 MHz (84 at the
/// F446's 168 MHz).
pub const WRITE_GUARD: u32 = 6;

/// GPIO BSRR words for the step and dir pins, indexed by the kernel's 6-bit step and dir bytes:
/// one table lookup and one register write each, no loop in the interrupt.
pub struct PinWords {
    /// Raises the step pins of each step mask.
    pub step_set: [u32; 64],
    /// Drops every step pin (the pulse end, and the step word of an unprepared update).
    pub step_reset: u32,
    /// Sets every dir pin for each dir mask (bit set = negative = pin high).
    pub dir: [u32; 64],
}

impl PinWords {
    /// Words for step and dir pins with these masks (bit n of a port = pin n), axis order; the
    /// step pins share one port and so do the dir pins.
    pub const fn new(step: &[u32], dir: &[u32]) -> Self {
        let mut words = PinWords {
            step_set: [0; 64],
            step_reset: 0,
            dir: [0; 64],
        };
        let mut axis = 0;
        while axis < step.len() {
            words.step_reset |= step[axis] << 16;
            axis += 1;
        }
        let mut bits = 0;
        while bits < 64 {
            let mut axis = 0;
            while axis < step.len() {
                if bits & (1 << axis) != 0 {
                    words.step_set[bits] |= step[axis];
                }
                axis += 1;
            }
            let mut axis = 0;
            while axis < dir.len() {
                words.dir[bits] |= if bits & (1 << axis) != 0 {
                    dir[axis]
                } else {
                    dir[axis] << 16
                };
                axis += 1;
            }
            bits += 1;
        }
        words
    }
}

/// The registers the body reads and writes (TIM2 and GPIO on the board, plain memory in the
/// benchmark).
pub trait StepHardware {
    /// Timer counts since the last update.
    fn count(&self) -> u32;
    /// Auto-reload value of the running period (its length − 1). The body writes it once per
    /// period (preloaded: it takes effect at the next update), after reading it.
    fn reload(&self) -> u32;
    /// Sets the reload value that takes effect at the next update.
    fn set_reload(&mut self, reload: u32);
    /// Writes the dir port's BSRR.
    fn write_dir(&mut self, bsrr: u32);
    /// Sets the step word the next update copies to the step port's BSRR.
    fn set_step_word(&mut self, bsrr: u32);
    /// Switches one user output (an on-the-fly M code).
    fn write_output(&mut self, event: OutputEvent);
    /// The touch probe's raw level (true = pin low = closed), for the kernel's probe latch.
    fn probe_closed(&self) -> bool;
}

/// What a run of the body did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Run {
    /// The next update emits the pending step (or nothing, when the kernel is idle).
    Scheduled,
    /// Too early (the period's compare DMA may not have cleared the step word yet) or too late
    /// (less than the dir set-up left before the next update): nothing written, the pending
    /// step waits for the next period.
    Late,
}

/// Everything the step interrupt owns.
pub struct StepIsr<S> {
    pub kernel: StepKernel,
    pub source: S,
    /// The kernel's last tick, not yet scheduled: written to the dir pins and the step word by
    /// the next run.
    pub pending: TickOut,
    /// The last run scheduled no step and no segment was waiting (the kernel is at rest once
    /// the queue is empty too).
    pub idle: bool,
    /// Pulse width, dir set-up and shortest period, from the setup.
    pub timing: StepTiming,
    /// The dir byte last written to the dir pins (all low at power-up).
    pub dir_pins: u8,
}

impl<S: SegmentSource> StepIsr<S> {
    /// An idle kernel at step 0 reading segments from `source`.
    pub const fn new(source: S, timing: StepTiming) -> Self {
        StepIsr {
            kernel: StepKernel::new(),
            source,
            pending: TickOut {
                step: 0,
                dir: 0,
                period: 0,
                output: OutputEvent::NONE,
            },
            idle: true,
            timing,
            dir_pins: 0,
        }
    }

    /// One run, right after a pulse end: schedules the pending step for the next update and
    /// ticks the kernel for the one after. `stop` is the limit flag the kernel latches.
    #[inline(always)]
    pub fn on_pulse_end(
        &mut self,
        words: &PinWords,
        hw: &mut impl StepHardware,
        stop: bool,
    ) -> Run {
        let probe = hw.probe_closed();
        if self.pending.period == 0 {
            // Nothing was waiting at the last tick: look again now, so a segment queued since
            // starts at the next update rather than a poll later.
            self.pending = self.kernel.tick(&mut self.source, stop, probe);
        }
        let t = self.timing;
        let next = self.pending;
        // A dir pin that changes must lead the next update by the set-up time.
        let setup = if next.dir != self.dir_pins {
            t.dir_setup
        } else {
            0
        };
        let now = hw.count();
        // After this period's compare (the step word is cleared then), and early enough for the
        // writes below and the set-up.
        if now <= t.pulse || now + setup + WRITE_GUARD > hw.reload() + 1 {
            return Run::Late;
        }
        hw.write_dir(words.dir[(next.dir & 63) as usize]);
        self.dir_pins = next.dir;
        if next.output.is_some() {
            // On-the-fly output: switched before the first step of its block.
            hw.write_output(next.output);
        }
        hw.set_step_word(words.step_set[(next.step & 63) as usize]);
        let period = match next.period {
            0 => IDLE_PERIOD_COUNTS,
            p => t.stretch(p),
        };
        hw.set_reload(period - 1);
        self.idle = next.period == 0;
        if !self.idle {
            self.pending = self.kernel.tick(&mut self.source, stop, probe);
        }
        Run::Scheduled
    }
}

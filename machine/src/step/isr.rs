//! The step interrupt's body, apart from the registers it writes: one run per step event.
//!
//! The firmware runs it in the TIM2 compare-1 interrupt (`firmware/src/step.rs`) over the real
//! timer and GPIO registers; the emulated board (`emulator/src/step_clock.rs`) runs it over a
//! timer on its virtual clock; `target-tests/src/bin/bench_step.rs` runs it over a memory-backed
//! fake of the registers to count its instructions. It reaches the hardware only through
//! [`StepHardware`].
//!
//! Timeline of one step (timer counts from the update that starts a period):
//! - count 0, the update: a DMA request copies the *step word* (a GPIO BSRR word raising this
//!   step's pins) to the step port: the rising edges come from the hardware, on time;
//! - count `pulse`, compare 1 and compare 2: one DMA request drops every step pin (the pulse end),
//!   the other overwrites the step word with that same reset word, so an update the body did not
//!   prepare raises nothing; and this interrupt starts;
//! - the body ([`StepIsr::on_pulse_end`]): writes the dir pins of the step the next update
//!   emits, the step word for that update and the timer period that follows it, all prepared
//!   on the run before ([`Prepared`]), so between its timer read and the update it only
//!   compares and stores; then it runs the kernel's tick and prepares the writes of the update
//!   after. The kernel is so two ticks ahead: the period a step starts comes from
//!   [`StepTiming::period`] with the dir byte of the step after it ([`StepIsr::after`]): the
//!   kernel's period, at least the shortest one the pulse and this body's writes allow, and at
//!   least the dir set-up more when that next step has another dir byte. So the period in which
//!   the dir pins change is already long enough for the set-up when it starts, and no other
//!   period is stretched for it. The body still checks the timer before writing: a dir pin that
//!   changes does so at least `dir_setup` counts before the next update, and every write lands
//!   before it, or the body writes nothing ([`Run::Late`]) and the next period retries (with the
//!   same period, which was chosen for that set-up).
//!
//! A late run never loses or repeats a step: the step word it would have written is kept for the
//! next period, and the word the hardware copies at an unprepared update is the reset word.

use super::hardware::StepHardware;
use super::kernel::{SegmentSource, StepKernel, StepTiming, TickOut, KEEP_DUTY, KERNEL_TIMER_HZ};
use super::output_event::OutputEvent;
use super::pins::PinWords;

/// Tick period while the kernel is idle (1 ms), i.e. how often an empty queue is polled.
pub const IDLE_PERIOD_COUNTS: u32 = KERNEL_TIMER_HZ / 1_000;

/// Kernel ticks computed ahead of the step pins ([`StepIsr::next`] and [`StepIsr::after`]): the
/// kernel's position leads the pins by up to this many steps per axis, a stop latched by the
/// kernel still lets that many go out, and the first step after an idle poll finds a segment
/// comes that many periods after the one that poll set.
pub const TICKS_AHEAD: u32 = 2;

/// Timer counts kept between the body's timer read and the next update, for its writes in
/// between ([`StepTiming::WRITE_GUARD`], where the figure is derived).
pub const WRITE_GUARD: u32 = StepTiming::WRITE_GUARD;

/// What a run of the body did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Run {
    /// The next update emits the prepared step (or nothing, when the kernel is idle).
    Scheduled,
    /// Too early (the period's compare DMA may not have cleared the step word yet) or too late
    /// (less than the writes and the dir set-up need before the next update): nothing
    /// written, the prepared step waits for the next period.
    Late,
}

/// The register writes of the next update, prepared by the run before it, so a run only
/// checks the timer and stores between its timer read and the update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prepared {
    /// Dir port BSRR word of the step.
    pub dir_word: u32,
    /// Step word (step port BSRR) the update copies.
    pub step_word: u32,
    /// Reload value of the period the update starts.
    pub reload: u32,
    /// Counts that must be left before the update at the timer read: the write guard, plus the
    /// dir set-up when the dir pins change.
    pub lead: u32,
    /// The kernel's period of the tick (0: the kernel was idle, no step).
    pub period: u32,
    /// Dir byte of the tick (the dir pins after the writes).
    pub dir: u8,
    /// User output to switch with the dir pins.
    pub output: OutputEvent,
    /// Laser duty to write with the dir pins ([`KEEP_DUTY`]: none).
    pub power: u16,
}

impl Prepared {
    /// The writes of an idle kernel at power-up: no step, dir pins left low, a poll a period
    /// later.
    pub(crate) const IDLE: Prepared = Prepared {
        dir_word: 0,
        step_word: 0,
        reload: IDLE_PERIOD_COUNTS - 1,
        lead: WRITE_GUARD,
        period: 0,
        dir: 0,
        output: OutputEvent::NONE,
        power: KEEP_DUTY,
    };
}

/// Everything the step interrupt owns.
pub struct StepIsr<S> {
    pub kernel: StepKernel,
    pub source: S,
    /// The writes for the next update (the kernel's tick before [`Self::after`]).
    pub next: Prepared,
    /// The kernel's last tick, not yet prepared: its dir byte tells whether the period
    /// [`Self::next`] starts must hold the dir set-up, and it is prepared by the next run.
    pub after: TickOut,
    /// No step is written or computed (the kernel is at rest once the queue is empty too).
    pub idle: bool,
    /// Pulse width, dir set-up and shortest periods, from the setup.
    pub timing: StepTiming,
}

impl<S: SegmentSource> StepIsr<S> {
    /// An idle kernel at step 0 reading segments from `source`.
    pub const fn new(source: S, timing: StepTiming) -> Self {
        StepIsr {
            kernel: StepKernel::new(),
            source,
            next: Prepared::IDLE,
            after: TickOut {
                step: 0,
                dir: 0,
                period: 0,
                output: OutputEvent::NONE,
                power: KEEP_DUTY,
            },
            idle: true,
            timing,
        }
    }

    /// One run, right after a pulse end: writes the prepared step for the next update, with the
    /// period after it, ticks the kernel and prepares the writes of the following update.
    /// `stop` is the limit flag the kernel latches.
    #[inline(always)]
    pub fn on_pulse_end(
        &mut self,
        words: &PinWords,
        hw: &mut impl StepHardware,
        stop: bool,
    ) -> Run {
        let w = self.next;
        let pulse = self.timing.pulse;
        let end = hw.reload() + 1;
        let now = hw.count();
        // After this period's compare (the step word is cleared then), and early enough for the
        // writes below and a dir set-up.
        if now <= pulse || now + w.lead > end {
            return Run::Late;
        }
        hw.write_dir(w.dir_word);
        if w.output.is_some() {
            // On-the-fly output: switched before the first step of its block.
            hw.write_output(w.output);
        }
        if w.power != KEEP_DUTY {
            // Laser duty of the segment this step starts (or 0 as the kernel stops): a
            // compare-register store, computed by segment prep.
            hw.write_power(w.power);
        }
        hw.set_step_word(w.step_word);
        hw.set_reload(w.reload);
        // The writes of the update after: the tick computed on the run before, timed with the
        // dir byte of the tick computed now.
        let probe = hw.probe_closed();
        let tick = self.after;
        let after = self.kernel.tick(&mut self.source, stop, probe);
        self.after = after;
        self.next = prepare(&self.timing, words, tick, after, w.dir);
        self.idle = w.period | tick.period | after.period == 0;
        Run::Scheduled
    }
}

/// The writes for `tick`, followed by the tick `after`, when the dir pins hold `dir_pins`.
#[inline(always)]
fn prepare(
    t: &StepTiming,
    words: &PinWords,
    tick: TickOut,
    after: TickOut,
    dir_pins: u8,
) -> Prepared {
    let period = match tick.period {
        // Idle: poll again in a millisecond, or start the step the poll found after a period
        // long enough for its dir set-up.
        0 if after.period == 0 => IDLE_PERIOD_COUNTS,
        0 => t.turn_period,
        p => t.period(p, after.dir != tick.dir),
    };
    Prepared {
        dir_word: words.dir[(tick.dir & 63) as usize],
        step_word: words.step_set[(tick.step & 63) as usize],
        reload: period - 1,
        // A dir pin that changes must lead the next update by the set-up time.
        lead: if tick.dir != dir_pins {
            WRITE_GUARD + t.dir_setup
        } else {
            WRITE_GUARD
        },
        period: tick.period,
        dir: tick.dir,
        output: tick.output,
        power: tick.power,
    }
}

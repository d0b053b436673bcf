//! The step timer's clock and the step pulse shape the drivers need, in its counts: what the step
//! interrupt (`isr.rs`) times every period with, what the setup checks step rates against
//! (`setup.rs`), and what segment prep's periods count in (`step/kernel.rs` re-exports it).

use serde::{Deserialize, Serialize};

/// Step and direction signal timing the stepper drivers need (their datasheets give both as
/// minimums). The step interrupt holds each step pulse for `step_pulse_ns` and changes a direction
/// pin at least `dir_setup_ns` before the next step pulse starts; both are rounded up to whole
/// step-timer counts (83.3 ns, [`StepTiming`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DriverSetup {
    /// Width of every step pulse, ns ([`Self::PULSE_NS`]).
    pub step_pulse_ns: u32,
    /// Time from a direction change to the next step pulse, at least, ns ([`Self::DIR_SETUP_NS`]).
    pub dir_setup_ns: u32,
}

impl DriverSetup {
    /// Accepted step pulse widths, ns: 1-50 µs (the step interrupt cannot end a pulse much
    /// sooner than 1 µs after starting it).
    pub(crate) const PULSE_NS: core::ops::RangeInclusive<u32> = 1_000..=50_000;
    /// Accepted direction set-up times, ns: 0-50 µs.
    pub(crate) const DIR_SETUP_NS: core::ops::RangeInclusive<u32> = 0..=50_000;

    /// 2.5 µs pulse, 5 µs direction set-up: the minimums of the most demanding common driver,
    /// the opto-isolated Leadshine DM542 (pulse ≥ 2.5 µs, direction ≥ 5 µs ahead of the pulse);
    /// more than TB6600 modules (≥ 2.2 µs), the DRV8825 (1.9 µs, 650 ns set-up) and the A4988
    /// (1 µs, 200 ns). It allows 200 k steps/s (a 5 µs period: the pulse and as long low), with
    /// 8.5 µs before a direction change ([`StepTiming`]).
    pub const DEFAULT: DriverSetup = DriverSetup {
        step_pulse_ns: 2_500,
        dir_setup_ns: 5_000,
    };
}

/// Frequency of the step timer the periods count in: 12 MHz divides both boards' TIM2 clocks
/// (F411 at 96 MHz: TIM2 96 MHz / 8; F446 at 168 MHz: APB1 42 MHz, TIM2 84 MHz / 7). One count is
/// 83.3 ns, fine enough for step rates far beyond what drivers accept.
pub const KERNEL_TIMER_HZ: u32 = 12_000_000;

/// Timer counts (at [`KERNEL_TIMER_HZ`]) of at least `ns` nanoseconds: rounded up, so a pulse or
/// set-up time is never shorter than asked.
pub const fn ns_to_counts(ns: u32) -> u32 {
    (ns as u64 * KERNEL_TIMER_HZ as u64).div_ceil(1_000_000_000) as u32
}

/// The step pulse shape in timer counts, from the setup's [`DriverSetup`], and the shortest
/// timer periods it allows.
///
/// The step timer raises the step pins at each update and drops them `pulse` counts later; the
/// step interrupt then writes the dir pins of the next step, its step word and the period after
/// it (`step/isr.rs` explains the timeline). So a period must hold the pulse, then
/// the pin low at least as long as the pulse (drivers want that) and at least as long as the
/// interrupt's *write window* ([`Self::WRITE_WINDOW`]): [`Self::min_period`]. Only the period
/// before a step whose dir byte differs from the step before must also hold the dir set-up
/// ([`Self::turn_period`]). [`Self::period`] applies both; the firmware and the emulated board
/// both time every period with it, and [`crate::setup::Setup::step_rate_fits`] refuses axes
/// whose max rate would need shorter periods than [`Self::min_period`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepTiming {
    /// Step pulse width, counts.
    pub pulse: u32,
    /// Direction set-up before a step pulse, counts.
    pub dir_setup: u32,
    /// Shortest tick period, counts: the pulse, then the pin low for the longer of the pulse
    /// and [`Self::WRITE_WINDOW`].
    pub min_period: u32,
    /// Shortest period before a tick whose dir byte differs from the tick before: the pulse,
    /// the write window and the dir set-up (at least [`Self::min_period`]).
    pub turn_period: u32,
}

impl StepTiming {
    /// Timer counts (83.3 ns, 8 cycles at the F411's 96 MHz) from the pulse end (compare 1,
    /// where the step interrupt is raised) to the body's timer read, at most: exception entry
    /// (12 cycles and the vector fetch) and the F411 handler's 22 instructions up to the read of
    /// TIM2's counter (register saves, flag clear, the reload read), about 62-65 cycles with
    /// the flash wait states the ART accelerator leaves. Derivation: firmware/README.md, "Step
    /// generation"; `target-tests/src/bin/bench_step.rs` checks the body against it.
    pub const ENTRY_COUNTS: u32 = 8;
    /// Timer counts the step interrupt keeps between its timer read and the next update, for
    /// the register writes that must precede that update (dir pins, user output, step word,
    /// reload): 13 instructions on the F411, about 27 cycles with the two TIM2 writes.
    pub const WRITE_GUARD: u32 = 4;
    /// Counts from the pulse end to the step interrupt's last write that must precede the next
    /// update (12 = 1 µs): the shortest low time of the step pins the interrupt keeps up with.
    pub const WRITE_WINDOW: u32 = Self::ENTRY_COUNTS + Self::WRITE_GUARD;

    pub const fn from_setup(d: &DriverSetup) -> Self {
        let pulse = ns_to_counts(d.step_pulse_ns);
        let dir_setup = ns_to_counts(d.dir_setup_ns);
        let low = max(pulse, Self::WRITE_WINDOW);
        let min_period = pulse + low;
        StepTiming {
            pulse,
            dir_setup,
            min_period,
            turn_period: max(min_period, pulse + dir_setup + Self::WRITE_WINDOW),
        }
    }

    /// The timer period that follows a tick the kernel timed `period` (≥ 1) counts; `turn`:
    /// the tick after it has another dir byte (the dir pins change in this period).
    #[inline]
    pub const fn period(&self, period: u32, turn: bool) -> u32 {
        max(
            period,
            if turn {
                self.turn_period
            } else {
                self.min_period
            },
        )
    }
}

const fn max(a: u32, b: u32) -> u32 {
    if a > b {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn driver_timing_rounds_up_to_whole_timer_counts() {
        // 12 MHz: one count is 83.3 ns.
        assert_eq!(ns_to_counts(5_000), 60);
        assert_eq!(ns_to_counts(2_500), 30);
        assert_eq!(ns_to_counts(1_900), 23);
        assert_eq!(ns_to_counts(1), 1);
        assert_eq!(ns_to_counts(0), 0);
        // The defaults (DM542): the low time is the pulse's, the dir set-up only counts before a
        // direction change.
        let t = StepTiming::from_setup(&DriverSetup::DEFAULT);
        let w = StepTiming::WRITE_WINDOW;
        assert_eq!(
            t,
            StepTiming {
                pulse: 30,
                dir_setup: 60,
                min_period: 60,
                turn_period: 90 + w,
            }
        );
        // No dir set-up: the turn period is the shortest one.
        let t = StepTiming::from_setup(&DriverSetup {
            step_pulse_ns: 2_000,
            dir_setup_ns: 0,
        });
        assert_eq!(
            (t.pulse, t.dir_setup, t.min_period, t.turn_period),
            (24, 0, 48, 48)
        );
        // A long dir set-up lengthens only the turn period.
        let t = StepTiming::from_setup(&DriverSetup {
            step_pulse_ns: 1_000,
            dir_setup_ns: 10_000,
        });
        assert_eq!((t.pulse, t.dir_setup, t.min_period), (12, 120, 24));
        assert_eq!(t.turn_period, 12 + 120 + StepTiming::WRITE_WINDOW);
    }

    /// The goal: 1 µs pulse and 1 µs dir set-up step at 500 kHz (24 counts of 12 MHz)
    /// and only the period before a direction change holds the set-up.
    #[test]
    fn one_microsecond_pulses_step_at_500_khz() {
        let t = StepTiming::from_setup(&DriverSetup {
            step_pulse_ns: 1_000,
            dir_setup_ns: 1_000,
        });
        assert_eq!((t.pulse, t.dir_setup, t.min_period), (12, 12, 24));
        assert_eq!(KERNEL_TIMER_HZ / t.min_period, 500_000);
        assert_eq!(t.turn_period, 24 + StepTiming::WRITE_WINDOW);
        // Same direction: only periods shorter than 24 counts are stretched.
        assert_eq!(t.period(1, false), 24);
        assert_eq!(t.period(23, false), 24);
        assert_eq!(t.period(24, false), 24);
        assert_eq!(t.period(25, false), 25);
        assert_eq!(t.period(5_000, false), 5_000);
        // Before a direction change: pulse + dir set-up + write window.
        assert_eq!(t.period(24, true), 24 + StepTiming::WRITE_WINDOW);
        assert_eq!(t.period(1, true), t.turn_period);
        assert_eq!(t.period(t.turn_period + 1, true), t.turn_period + 1);
        assert_eq!(t.period(5_000, true), 5_000);
    }
}

//! The emulated board's step timer: TIM2 and its DMA streams (`firmware/src/step.rs`,
//! `firmware/src/step_dma.rs`) on the virtual clock, behind the core's [`StepHardware`]. The
//! interrupt's body is the core's [`StepIsr`], the firmware's own; this file only models the
//! registers it reads and writes and when the timer raises it:
//! - at each update the step word is copied to the step pins (the rising edges) and the
//!   preloaded reload value starts the period;
//! - at compare 1 (`pulse` counts later) the step word is cleared and the interrupt runs,
//!   [`StepTiming::ENTRY_COUNTS`] later (on time: the emulated CPU has no other interrupt);
//! - while the kernel is idle the body keeps the 1 ms poll ([`IDLE_PERIOD_COUNTS`]).
//!
//! Step pins are bits 0..6 of the step word and dir pins bits 0..6 of the dir port ([`PINS`]), so
//! the words read back as the kernel's step and dir bytes.

use gantry_machine::step::kernel::{SegmentSource, StepTiming};
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::step::{PinWords, Run, StepHardware, StepIsr, IDLE_PERIOD_COUNTS};

/// Step pin n and dir pin n of axis n, bit n of their ports.
pub const PINS: PinWords = PinWords::new(&[1, 2, 4, 8, 16, 32], &[1, 2, 4, 8, 16, 32]);

/// The registers the body reaches: TIM2's counter, reload and step word (CCR3), the dir port,
/// the user output pins and the probe pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VirtualRegisters {
    /// Counter at the body's read (counts since the update).
    pub count: u32,
    /// Auto-reload (preload register): the next period's length − 1.
    pub reload: u32,
    /// The step word the next update copies to the step pins.
    pub step_word: u32,
    /// Dir pin levels (bit n = axis n, set = negative).
    pub dir_pins: u8,
    /// User output pin levels (bit n = output n).
    pub outputs: u16,
    /// Laser PWM duty (compare counts) the interrupt wrote last (laser mode).
    pub pwm: u16,
    /// The probe pin's raw level (as `board::inputs` reads it: set = active).
    pub probe: bool,
}

impl StepHardware for VirtualRegisters {
    fn count(&self) -> u32 {
        self.count
    }
    fn reload(&self) -> u32 {
        self.reload
    }
    fn set_reload(&mut self, reload: u32) {
        self.reload = reload;
    }
    fn write_dir(&mut self, bsrr: u32) {
        self.dir_pins = ((u32::from(self.dir_pins) | (bsrr & 0xFFFF)) & !(bsrr >> 16)) as u8;
    }
    fn set_step_word(&mut self, bsrr: u32) {
        self.step_word = bsrr;
    }
    fn write_output(&mut self, event: OutputEvent) {
        self.outputs = event.apply(self.outputs);
    }
    fn write_power(&mut self, duty: u16) {
        self.pwm = duty;
    }
    fn probe_closed(&self) -> bool {
        self.probe
    }
}

/// What the clock did at one of its events.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockEvent {
    /// An update: the step pins of `step` rose (0: none), with the dir pins as they were, and a
    /// period of `period` counts started.
    Update { step: u8, period: u32 },
    /// The interrupt ran.
    Interrupt(Run),
}

/// The step timer on virtual time (kernel timer counts).
#[derive(Clone, Copy, Debug)]
pub struct StepClock {
    pub regs: VirtualRegisters,
    /// Virtual time of the running period's update.
    update_at: u64,
    /// Length of the running period.
    period: u32,
    /// When the running period's interrupt runs (`None`: it has run).
    interrupt_at: Option<u64>,
    /// Pulse width (compare 1).
    pulse: u32,
    /// Runs that found themselves late and wrote nothing (the firmware's `LATE_TICKS`).
    pub late: u32,
}

impl StepClock {
    /// The timer started at `now` as the firmware starts it: an idle period, the reset word as
    /// the step word, dir and output pins low.
    pub fn start(now: u64, timing: &StepTiming) -> Self {
        StepClock {
            regs: VirtualRegisters {
                count: 0,
                reload: IDLE_PERIOD_COUNTS - 1,
                step_word: PINS.step_reset,
                dir_pins: 0,
                outputs: 0,
                pwm: 0,
                probe: false,
            },
            update_at: now,
            period: IDLE_PERIOD_COUNTS,
            interrupt_at: Some(now + Self::entry(timing.pulse, IDLE_PERIOD_COUNTS)),
            pulse: timing.pulse,
            late: 0,
        }
    }

    /// Counts from an update to the interrupt's timer read: the compare, then the entry (within
    /// the period).
    fn entry(pulse: u32, period: u32) -> u64 {
        u64::from((pulse + StepTiming::ENTRY_COUNTS).min(period - 1))
    }

    /// A new pulse width (a setup change, with the machine idle).
    pub fn set_pulse(&mut self, pulse: u32) {
        self.pulse = pulse;
    }

    /// Virtual time of the next update.
    pub fn next_update(&self) -> u64 {
        self.update_at + u64::from(self.period)
    }

    /// Virtual time of the clock's next event.
    pub fn next_event(&self) -> u64 {
        self.interrupt_at.unwrap_or_else(|| self.next_update())
    }

    /// Runs the event due at `now` ([`Self::next_event`]): the interrupt runs `isr` with the
    /// kernel's limit flag `stop`.
    pub fn advance<S: SegmentSource>(
        &mut self,
        now: u64,
        isr: &mut StepIsr<S>,
        stop: bool,
    ) -> ClockEvent {
        if let Some(at) = self.interrupt_at.take() {
            debug_assert_eq!(at, now);
            self.regs.count = (at - self.update_at) as u32;
            let run = isr.on_pulse_end(&PINS, &mut self.regs, stop);
            if run == Run::Late {
                self.late += 1;
            }
            return ClockEvent::Interrupt(run);
        }
        // The update: the preloaded reload starts its period, the update DMA copies the step
        // word; at compare 1 and 2 the pins drop and the word is reset, then the interrupt.
        self.update_at = self.next_update();
        self.period = self.regs.reload + 1;
        let step = (self.regs.step_word & 0x3F) as u8;
        self.regs.step_word = PINS.step_reset;
        self.interrupt_at = Some(self.update_at + Self::entry(self.pulse, self.period));
        ClockEvent::Update {
            step,
            period: self.period,
        }
    }
}

//! What the step interrupt reads and writes: one trait, implemented by the firmware's TIM2 and
//! DMA (`firmware/src/step.rs`), the emulated board's virtual timer
//! (`emulator/src/step_clock.rs`) and the benchmark's registers in RAM
//! (`target-tests/src/bin/bench_step.rs`).

use super::output_event::OutputEvent;

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
    /// Sets the laser PWM duty (compare counts of a PWM period of `pwm_max` counts, laser mode
    /// only: docs/laser-plasma.md).
    fn write_power(&mut self, duty: u16);
    /// The touch probe's raw level (true = pin low = closed), for the kernel's probe latch.
    fn probe_closed(&self) -> bool;
}

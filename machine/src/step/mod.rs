//! The step interrupt, written once: the step kernel it drives ([`kernel`]: segments in, step
//! bits and on-the-fly [`output_event`]s out), its body ([`isr`]), the pin words it writes ([`pins`]), the
//! registers it reaches ([`hardware::StepHardware`]), the main loop's access to its state
//! ([`access`]) and the pulse timing it keeps ([`timing`]). The firmware's TIM2 and DMA (`firmware/src/step.rs`) and the emulated board's
//! virtual timer (`emulator/src/step_clock.rs`) each implement [`StepHardware`] and nothing
//! more.

pub(crate) mod access;
pub(crate) mod hardware;
pub(crate) mod isr;
pub mod kernel;
pub mod output_event;
pub(crate) mod pins;
pub(crate) mod timing;

pub use access::{KernelSnapshot, SegmentQueue};
pub use hardware::StepHardware;
pub use isr::{Prepared, Run, StepIsr, IDLE_PERIOD_COUNTS, TICKS_AHEAD, WRITE_GUARD};
pub use pins::PinWords;

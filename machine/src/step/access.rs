//! The step interrupt's state as the main loop reaches it (between two runs: the firmware holds
//! the interrupt off meanwhile, `firmware/src/step.rs` `with_kernel`; the emulated board runs
//! one or the other on its virtual clock). Each method is one of the main loop's port calls
//! (`device::main_loop::BoardPort`), so both boards answer them with the same code.

use super::isr::StepIsr;
use super::kernel::{ProbeLatch, SegmentSource};
use super::output_event::OutputEvent;
use crate::units::MAX_AXES;

/// A segment queue the interrupt takes segments from, as the main loop sees it.
pub trait SegmentQueue: SegmentSource {
    /// No segment waits in the queue.
    fn is_empty(&self) -> bool;
}

/// What the main loop reads of the step kernel at one moment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KernelSnapshot {
    /// Step position the kernel has reached (up to the two steps the interrupt has prepared and
    /// not emitted yet: [`StepIsr`]).
    pub steps: [i64; MAX_AXES],
    /// The kernel latched a stop (its limit flag) and steps no more until re-armed.
    pub stopped: bool,
    /// The queue is empty, the kernel has no segment running and the interrupt has no step
    /// prepared: every step has reached the pins.
    pub drained: bool,
    /// Times the kernel found its queue empty after a segment (wrapping,
    /// [`crate::step::kernel::StepKernel::dry_runs`]): the main loop counts underruns by it.
    pub dry_runs: u16,
    /// Laser PWM duty the kernel's segments set last (0 at rest; laser mode only).
    pub laser_duty: u16,
}

impl<S: SegmentQueue> StepIsr<S> {
    /// The kernel now.
    pub fn snapshot(&self) -> KernelSnapshot {
        KernelSnapshot {
            steps: self.kernel.position(),
            drained: self.idle && !self.kernel.is_busy() && self.source.is_empty(),
            stopped: self.kernel.is_stopped(),
            dry_runs: self.kernel.dry_runs(),
            laser_duty: self.kernel.laser_duty(),
        }
    }

    /// After a latched stop: drops every queued segment and the running one (the position keeps
    /// the steps made; the two steps already prepared still go out, and were counted).
    pub fn flush(&mut self) {
        while self.source.next_segment().is_some() {}
        self.kernel.flush();
    }

    /// Clears the kernel's latched stop.
    pub fn rearm(&mut self) {
        self.kernel.clear_stop();
    }

    /// Arms the kernel's probe latch for the raw probe level `trips_at` (`None`: off, forgetting
    /// a latched position); an armed or tripped latch for the same level is left alone (the main
    /// loop calls it every pass).
    pub fn arm_probe(&mut self, trips_at: Option<bool>) {
        match (self.kernel.probe_latch(), trips_at) {
            (ProbeLatch::Armed { trips_at: t }, Some(l)) if t == l => {}
            (ProbeLatch::Tripped { .. }, Some(_)) | (ProbeLatch::Off, None) => {}
            (_, Some(l)) => self.kernel.arm_probe(l),
            (_, None) => self.kernel.disarm_probe(),
        }
    }

    /// The step position the probe latch recorded, if it tripped.
    pub fn probe_latched(&self) -> Option<[i64; MAX_AXES]> {
        match self.kernel.probe_latch() {
            ProbeLatch::Tripped { steps } => Some(steps),
            _ => None,
        }
    }

    /// Exchanges the user output word with the board: `f` gets the kernel's word (every
    /// on-the-fly event fired so far) and returns a word to load, if the board switched outputs
    /// itself. Returns that word, which the caller drives onto the pins before the interrupt
    /// runs again; an event computed but not yet emitted is dropped with it.
    pub fn exchange_outputs(&mut self, f: impl FnOnce(u16) -> Option<u16>) -> Option<u16> {
        let word = f(self.kernel.outputs())?;
        self.kernel.set_outputs(word);
        self.next.output = OutputEvent::NONE;
        self.after.output = OutputEvent::NONE;
        Some(word)
    }
}

//! What only the step kernel's owner (the main loop, machine/src/device/main_loop.rs) knows of
//! the machine, for the status reports of both front ends: the framed link
//! (machine/src/device/link.rs) and grbl (machine/src/device/grbl/).

use crate::units::MAX_AXES;

/// What only the kernel's owner knows, for status reports.
#[derive(Clone, Copy, Debug, Default)]
pub struct KernelView {
    /// Step position the kernel has reached.
    pub steps: [i64; MAX_AXES],
    /// Debounced input levels.
    pub inputs: u32,
    /// Current path speed, µm/min.
    pub feed_um_min: u32,
    /// The current or last job's time lost to starvation, ms (machine/src/device/starvation.rs).
    pub starved_ms: u32,
    /// Laser PWM duty now (compare counts of `pwm_max`; 0 when off or not a laser).
    pub laser_duty: u16,
}

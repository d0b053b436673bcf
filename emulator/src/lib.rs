//! The emulated Gantry board: a board beside `firmware/`, over the same core (`gantry-machine`).
//! The firmware puts the core's [`gantry_machine::device::main_loop::MainLoop`] and step interrupt
//! on the STM32's registers; this crate puts them on virtual time and virtual pins, so the CLI
//! (`host-sender`, which carries its bytes over a pty, TCP or in process) and the system tests
//! (`tests/`) run the board's own code without hardware.
//!
//! - [`board`]: the board itself ([`EmulatedBoard`]): virtual step timer, switches, probe
//!   target, pins, the host's bytes and DTR, flash.
//! - [`step_clock`]: the step interrupt's timer on the virtual clock (the firmware's TIM2).
//! - [`cpu_model`]: what each main-loop pass costs on an MCU (`--cpu-model f411`).
//! - [`torch_script`]: a plasma power source and height controller on virtual time (`--arc-ok-delay`,
//!   `--thc`, …).

pub mod board;
pub mod cpu_model;
pub mod step_clock;
pub mod torch_script;

pub use board::*;

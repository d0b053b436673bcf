//! Gantry's shared core: everything that decides anything.
//!
//! The interpreter, look-ahead planner, step kernel and controller state machine live here, with no
//! HAL or executor dependency, so the firmware and the host's emulated board run the very same code.
//! There is no floating point anywhere in this crate: lengths are integer nanometres ([`units`]) and
//! geometry is integer arithmetic ([`arith`]), so the same input gives bit-identical output on
//! every target.
//!
//! # The API
//!
//! What is `pub` is what the firmware, the emulated board (`gantry-emulator`), the `gantry` CLI,
//! the system and target tests and the benches use; everything else is `pub(crate)`. The modules
//! bottom up (tests/tests/import_graph.rs checks that no module imports one above it):
//!
//! - [`arith`], [`units`]: integer geometry (square roots, angles) and the nanometre position
//!   model (`Pos`, `NM_PER_MM`, `AXIS_LETTERS`), which the CLI uses to parse and print positions.
//! - [`canon`]: the canonical machining actions the interpreter emits (`Canon`, `Action`); the
//!   CLI's preview and trace read them.
//! - [`gcode`]: the interpreter (`Interpreter`, `MemorySource`, `ErrorCode`); the CLI checks and
//!   previews programs with it before sending, and its block parser checks a setup file's
//!   startup lines.
//! - [`motion`]: planner and segment prep (`Motion`, `MotionConfig`, `sim`); the CLI estimates
//!   and previews with it, the target tests time it on Cortex-M4.
//! - [`step`]: the step kernel (`step::kernel::StepKernel`) and the step interrupt (`StepIsr`)
//!   over a `StepHardware`: the firmware's TIM2 and the emulator's virtual TIM2 implement it.
//! - [`setup`]: the machine setup (`Setup`), its flash blob and its settings table; the CLI's setup
//!   file, the firmware's settings store and the tests build setups from it.
//! - [`vectors`]: the cross-target vectors the host tests and the QEMU harness both run.
//! - [`board`]: the controller state machine ([`board::Board`]) with its state and alarms
//!   (`State`, `AlarmCode`), inputs (`board::inputs::Signal`), output levels and power-up rule
//!   (`board::power_up`); the firmware and the emulator map its levels onto pins, the tests drive it.
//! - [`device`]: the device's side of the wire and the one main-loop pass (`device::main_loop`,
//!   `device::link`, the grbl front end `device::grbl`), which the firmware and the emulator call
//!   every millisecond; `gantry emulate` and the tests read an emulated board's status through
//!   `device::link::status_of`.
//!
//! Integer clamping is written `.max(lo).min(hi)` (same result for `lo ≤ hi`, which every use
//! here has): `Ord::clamp` formats its arguments into its panic message, which links `core::fmt`'s
//! integer formatting into the firmware's flash.
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
// See above: integer clamping is spelled out as max/min on purpose.
#![allow(clippy::manual_clamp)]

pub mod arith;
pub mod board;
pub mod canon;
pub mod device;
pub mod gcode;
pub mod motion;
pub mod setup;
pub mod step;
pub mod units;
pub mod vectors;

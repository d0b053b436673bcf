//! Gantry's shared core: everything that decides anything.
//!
//! The interpreter, look-ahead planner, step kernel and controller state machine live here, with no
//! HAL or executor dependency, so the firmware and the host's emulated board run the very same code.
//! There is no floating point anywhere in this crate: lengths are integer nanometres ([`units`]) and
//! geometry is integer arithmetic ([`arith`]), so the same input gives bit-identical output on
//! every target.
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

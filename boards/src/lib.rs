//! The board tables in `boards/*.rs`: the one reader of their grammar ([`board_table!`]) with
//! pins and clock numbers (`table.rs`, no_std, used by the firmware too), and with the `std`
//! feature (default) the host-side data ([`PinMap`]) the checks run on.
//!
//! The firmware expands each board file's `gantry_board!` invocation into embassy peripherals; this
//! crate expands the very same file into plain data ([`PinMap`]) so tests can check the table on
//! the host: no pin used twice, step pins on one port, dir pins on one port, EXTI channels matching
//! their pins and distinct, analog roles on ADC1 pins, reserved pins untouched, and clocks that
//! give exactly 48 MHz USB and a TIM2 clock within limits.
#![cfg_attr(not(feature = "std"), no_std)]

mod table;
pub use table::{same_port, Clocks, Pin};

#[cfg(feature = "std")]
mod host;
#[cfg(feature = "std")]
pub use host::*;

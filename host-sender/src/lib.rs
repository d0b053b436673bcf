//! The `gantry` sender's library: command implementations and the emulated board.

pub mod check;
pub mod emulator;
pub mod link;
pub mod program;
pub mod stream;
pub mod preview;
pub mod setup_file;
pub mod simulate;
pub mod vcd;

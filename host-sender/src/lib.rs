//! The `gantry` sender's library: command implementations and the emulated board.

pub mod check;
pub mod simulate;
pub mod setup_file;

//! The `gantry` sender's library: command implementations and the emulated board.

pub mod check;
pub mod check_summary;
pub mod commands;
pub mod cpu_model;
pub mod emulate;
pub mod emulator;
pub mod link;
pub mod port;
pub mod preview;
pub mod program;
pub mod program_stops;
pub mod resume;
pub mod serve;
pub mod settings_doc;
pub mod setup_file;
pub mod simulate;
pub mod stream;
pub mod tcp;
pub mod trace;
pub mod vcd;

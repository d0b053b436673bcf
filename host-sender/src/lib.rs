//! The `gantry` sender's library. Its layers, each using only those below it:
//! - `link`: the byte transport and the protocol endpoint (`Client`);
//! - `session`: one session owns the link to a board (setup kept, status, requests, jobs);
//! - `present`: the words (statuses, errors with carets, reports) for a terminal;
//! - `commands`: the CLI commands that work a board (one-shot, `stream`, `serve`);
//! - beside them: the emulated board (`emulator`, `emulate`, `tcp`), the offline tools (`check`,
//!   `simulate`, `preview`, `trace`, `settings_doc`) and the program and setup files.

pub mod check;
pub mod check_summary;
pub mod commands;
pub mod console;
pub mod emulate;
pub mod emulated;
pub mod link;
pub mod port;
pub mod present;
pub mod preview;
pub mod program;
pub mod program_stops;
pub mod resume;
pub mod resume_blocks;
pub mod session;
pub mod settings_doc;
pub mod setup_file;
pub mod simulate;
pub mod tcp;
pub mod trace;
pub mod vcd;

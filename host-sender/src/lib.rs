//! The `gantry` sender's library. Its layers, each using only those below it:
//! - `link`: the byte transport and the protocol endpoint (`Client`);
//! - `session`: one session owns the link to a board (setup kept, status, requests, jobs);
//! - `present`: the words (statuses, errors with carets, reports) for a terminal;
//! - `commands`: the CLI commands that work a board (one-shot, `stream`, `serve`);
//! - beside them: the emulated board (`emulator`, `emulate`, `tcp`), the offline tools (`check`,
//!   `simulate`, `preview`, `trace`, `settings_doc`) and the program and setup files.
//!
//! The crate's API is what the `gantry` binary (`src/main.rs`), the system tests (`tests/`), this
//! crate's tests and benchmarks call; everything else is `pub(crate)`:
//! - the link and the session: `link::{Transport, SerialTransport, Client}`,
//!   `session::{Session, Target, Overrides}` and the job runners `session::{stream_program,
//!   continue_job, stream_from_line}` with their `Flow`, `Progress`, `StreamReport`, `BoardAlarm`,
//!   `session::{push_setup_over, pull_setup_over}`, `session::{standing, probe, socket}`;
//! - the commands: `commands::oneshot`, `commands::stream::run_checked`, `commands::serve::run`,
//!   `emulate::run`, `tcp::run`, `console::Options`, `port::discover`;
//! - the files: `setup_file::{SetupFile, to_toml}`, `program::Program`, `settings_doc::render`,
//!   `resume::resume_preamble`;
//! - the offline tools: `check::{run, canon_jsonl, canon_output}`, `simulate`, `preview` (`run`,
//!   `render`, its model, SVG and PNG renderers and views), `trace`, `vcd`, `present`'s words.

pub mod check;
pub(crate) mod check_summary;
pub mod commands;
pub mod console;
pub mod emulate;
pub(crate) mod emulated;
pub mod link;
pub mod port;
pub mod present;
pub mod preview;
pub mod program;
pub(crate) mod program_stops;
pub mod resume;
pub(crate) mod resume_blocks;
pub mod session;
pub mod settings_doc;
pub mod setup_file;
pub mod simulate;
pub mod tcp;
pub mod trace;
pub mod vcd;

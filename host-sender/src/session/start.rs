//! The one check every program start goes through (`gantry stream`, `--from-line`, `gantry mdi`,
//! the console's Run, run-from-line and MDI): the whole program interpreted without motion with
//! the board's setup, as `gantry check` does, before anything moves. A program with an error
//! does not start. [`Session::start_job`](super::Session::start_job) takes only a [`Cleared`],
//! which only this check (or the operator's explicit `--no-check`) makes.

use gantry_machine::gcode::ProgramSource;
use gantry_machine::setup::Setup;

/// Proof that a program passed the start check ([`check_program`]), or that the operator chose to
/// start it unchecked ([`Cleared::unchecked`]).
#[derive(Debug)]
pub(crate) struct Cleared {
    /// The check's warning lines (spindle speeds the board clamps …), for the operator to see
    /// before the job starts; empty unchecked. (Private: only this module makes a `Cleared`.)
    warnings: String,
}

impl Cleared {
    /// The operator asked for no check (`gantry stream --no-check`: a program too long to check
    /// first; the board still stops at its first error).
    pub(crate) fn unchecked() -> Cleared {
        Cleared {
            warnings: String::new(),
        }
    }

    /// The check's warning lines (`NAME:LINE: warning: …`), empty when there were none.
    pub(crate) fn warnings(&self) -> &str {
        &self.warnings
    }
}

/// A program the check refused: `gantry check`'s report (every error with its line and caret,
/// then the summary up to the first).
#[derive(Clone, Debug)]
pub(crate) struct Refused {
    pub(crate) report: String,
}

/// Checks the program `name` read from `src` with `setup`: cleared to start, or refused.
pub(crate) fn check_program<S: ProgramSource>(
    name: &str,
    src: S,
    setup: &Setup,
) -> anyhow::Result<Result<Cleared, Refused>> {
    let mut out = Vec::new();
    let (errors, _summary) =
        crate::check::check_stream(name, src, &setup.interp_config(), Some(setup), &mut out)?;
    // (The travel is the board's to check: the job starts where the machine stands, which a
    // check from the setup alone does not know.)
    let report = String::from_utf8_lossy(&out).into_owned();
    if errors == 0 {
        return Ok(Ok(Cleared {
            warnings: crate::check::warning_lines(&report),
        }));
    }
    Ok(Err(Refused { report }))
}

/// [`check_program`] on program text.
pub(crate) fn check_text(name: &str, text: &str, setup: &Setup) -> Result<Cleared, Refused> {
    check_program(
        name,
        gantry_machine::gcode::MemorySource::new(text.as_bytes()),
        setup,
    )
    .expect("checking text in memory does not fail")
}

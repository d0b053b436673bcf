//! `gantry simulate`: plan a program and report per-move speeds and the total time.
use std::path::Path;
use std::process::ExitCode;

/// Runs `gantry simulate FILE [--json]`.
pub fn run(_file: &Path, _json: bool) -> anyhow::Result<ExitCode> {
    anyhow::bail!("simulate is not implemented yet")
}

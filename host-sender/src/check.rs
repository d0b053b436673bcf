//! `gantry check`: interpret a program without motion and report errors or the canonical stream.
use std::path::Path;
use std::process::ExitCode;

/// Runs `gantry check FILE [--canon]`.
pub fn run(_file: &Path, _canon: bool) -> anyhow::Result<ExitCode> {
    anyhow::bail!("check is not implemented yet")
}

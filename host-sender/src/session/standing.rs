//! The machine a program is checked, simulated or previewed against (`gantry check`,
//! `simulate`, `preview`; the console asks the same for its figures): the connected board's
//! setup and where it stands when there is a board, a setup file when one is given, the
//! built-in defaults otherwise, and a line that says which.

use super::{Session, Target};
use crate::link::OnClose;
use gantry_machine::setup::Setup;
use gantry_machine::units::{Pos, AXIS_LETTERS, MAX_AXES, NM_PER_MM};
use std::path::PathBuf;

/// Where the setup of a check comes from.
pub enum Basis {
    /// `--setup FILE`: the file, the machine at 0, 0, 0 (no board is asked).
    File(PathBuf),
    /// A board on this port (`--port`, `GANTRY_PORT`, or the one plugged in), or through the
    /// `gantry serve` that owns it.
    Port(String),
    /// No board and no file.
    Defaults,
}

/// The machine a program is measured against.
pub struct Standing {
    pub setup: Setup,
    /// Machine position when the job starts, nm.
    pub at: Pos,
    /// Which setup and position, for the user: "the board's setup on P, machine at X 10 Y 5 Z 0".
    pub origin: String,
}

/// Millimetres with up to 3 decimals.
fn mm(nm: i64) -> String {
    let text = format!("{:.3}", nm as f64 / NM_PER_MM as f64);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

/// `X 10 Y 5 Z 0` for the axes in use.
fn position_text(at: &Pos, axes: usize) -> String {
    (0..axes.min(MAX_AXES))
        .map(|i| format!("{} {}", AXIS_LETTERS[i], mm(at[i])))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The setup and start position for `basis`: a board is asked for its setup and its machine
/// position (a one-shot session: closing it leaves the board as it was).
pub fn standing(basis: Basis) -> anyhow::Result<Standing> {
    match basis {
        Basis::File(f) => Ok(Standing {
            setup: crate::setup_file::SetupFile::load(&f)?,
            at: [0; MAX_AXES],
            origin: format!("setup file {}, machine at 0, 0, 0", f.display()),
        }),
        Basis::Defaults => Ok(Standing {
            setup: Setup::default(),
            at: [0; MAX_AXES],
            origin: "built-in defaults, machine at 0, 0, 0 (no board: give --port for the machine's, or --setup FILE)".into(),
        }),
        Basis::Port(p) => {
            let mut session = Session::connect(Target::Port(p.clone()), OnClose::KeepDtr)?;
            let status = session.status()?;
            let setup = session.setup().clone();
            let mut at = [0; MAX_AXES];
            at.copy_from_slice(&status.machine_pos[..MAX_AXES]);
            let origin = format!(
                "the board's setup on {p}, machine at {}",
                position_text(&at, usize::from(setup.axis_count))
            );
            Ok(Standing { setup, at, origin })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_read_in_millimetres() {
        let at = [10_000_000, -2_500_000, 1, 0, 0, 0];
        assert_eq!(position_text(&at, 3), "X 10 Y -2.5 Z 0");
    }
}

//! The `gantry` commands that work a board, on top of the session layer (`crate::session`) and
//! the words of `crate::present`: the one-shot commands ([`oneshot`]: status, hold, resume, abort,
//! override, watch, unlock, home, jog, mdi, setup push / pull), `gantry stream` ([`stream`]) and
//! `gantry serve` ([`serve`]). This module holds what they share.

pub mod oneshot;
pub mod serve;
pub mod stream;

use crate::present::{alarm_text, limit_text, state_name};
use crate::session::Session;
use gantry_proto::{BoardMsg, MachineState};

/// How long a one-shot command waits for the board to confirm what it asked, ms (an abort's
/// deceleration from full speed is well under this).
pub(crate) const CONFIRM_MS: u32 = 10_000;

/// Prints the limit and alarm reports the board sent (squaring lists' switch hits, alarms).
pub(crate) fn print_notices(session: &mut Session) {
    for msg in session.take_notices() {
        match msg {
            BoardMsg::Limit { axis, max } => println!("{}", limit_text(axis, max)),
            BoardMsg::Alarm { code, .. } => println!("{}", alarm_text(code)),
            _ => {}
        }
    }
}

/// Refuses a start the board would refuse, with its reason: in alarm (with what clears it), or
/// busy with another job, jog or homing cycle.
pub(crate) fn check_can_start(session: &mut Session) -> anyhow::Result<()> {
    let status = session.status()?;
    match status.state {
        MachineState::Idle => Ok(()),
        MachineState::Alarm { code } => anyhow::bail!(
            "the board is in {}\n  clear it first: gantry unlock (gantry home when homing is required)",
            alarm_text(code)
        ),
        MachineState::Run | MachineState::Hold { .. } | MachineState::ToolChange { .. } => {
            anyhow::bail!(
                "the board is running a job (state {}, line {}): take it over with `gantry stream FILE --continue`, or `gantry abort` it",
                state_name(status.state),
                status.line
            )
        }
        other => anyhow::bail!(
            "the board is busy ({}): wait until it is Idle",
            state_name(other)
        ),
    }
}

/// A flag set by Ctrl-C (installed once per process).
pub(crate) fn ctrl_c_flag() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::{Arc, OnceLock};
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        // If no handler can be installed, Ctrl-C keeps its default meaning (the board then holds
        // by itself when the link goes silent).
        let _ = ctrlc::set_handler(move || {
            f.store(true, Ordering::SeqCst);
            crate::link::request_stop();
        });
        flag
    })
    .clone()
}

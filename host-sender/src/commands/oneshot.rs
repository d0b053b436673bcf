//! The one-shot board commands: `status`, `watch`, `hold`, `resume`, `abort`, `override`,
//! `unlock`, `home`, `jog`, `mdi`, `setup push` / `setup pull`.
//!
//! Each opens a session with the target (the board on `--port`, through its `gantry serve` when
//! one runs, or a fresh emulated board), does its one thing, prints the resulting status and
//! closes the link; the board keeps running whatever it runs.

use super::{check_can_start, ctrl_c_flag, print_notices, CONFIRM_MS};
use crate::emulator::emulated_with_switches;
use crate::link::OnClose;
use crate::present::{alarm_text, format_status, limit_text, refusal_text, state_name};
use crate::session::{Flow, Overrides, Session, Target};
use gantry_machine::setup::Setup;
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{HostMsg, Status};
use std::process::ExitCode;

/// Opens a session for a one-shot command: closing it later leaves DTR up, so the board does not
/// take the command's exit for a sender that went away ([`OnClose::KeepDtr`]).
fn connect(target: Target) -> anyhow::Result<Session> {
    Session::connect(target, OnClose::KeepDtr)
}

/// Clears an alarm (unlock) and prints the status; exits 1 when the board keeps the alarm
/// (homing required, or still decelerating) and says why.
pub fn unlock(target: Target) -> anyhow::Result<ExitCode> {
    let mut session = connect(target)?;
    let axes = session.axes();
    let answer = session.unlock(CONFIRM_MS)?;
    let status = session.status()?;
    print_notices(&mut session);
    println!("{}", format_status(&status, axes));
    match answer {
        Some(0) => Ok(ExitCode::SUCCESS),
        Some(code) => {
            println!("unlock refused: {}", refusal_text(code));
            Ok(ExitCode::from(1))
        }
        None => anyhow::bail!(
            "the board did not answer the unlock within {} s",
            CONFIRM_MS / 1000
        ),
    }
}

/// Sends one realtime message (or none), waits until the board shows its effect (bounded by
/// [`CONFIRM_MS`]), prints the status and closes the port without dropping DTR: a resume is not
/// undone by the exit (the firmware takes a DTR drop as a feed hold).
pub fn realtime(target: Target, msg: Option<HostMsg>) -> anyhow::Result<ExitCode> {
    let mut session = connect(target)?;
    let axes = session.axes();
    let Some(m) = msg else {
        println!("{}", format_status(&session.status()?, axes));
        return Ok(ExitCode::SUCCESS);
    };
    let before = session.status()?;
    if matches!(m, HostMsg::Resume) {
        if let Some(why) = nothing_to_resume(&before) {
            println!("{}", format_status(&before, axes));
            println!("nothing to resume: {why}");
            return Ok(ExitCode::from(1));
        }
    }
    let expected = expected_after(&m, &before);
    let hold = matches!(m, HostMsg::FeedHold);
    session.send(m)?;
    session.pump(20)?;
    let mut status = session.status()?;
    let start = session.now_ms();
    if let Some((what, done)) = expected {
        while !done(&status) {
            if session.now_ms().wrapping_sub(start) > CONFIRM_MS {
                println!("{}", format_status(&status, axes));
                anyhow::bail!(
                    "the board did not confirm within {} s (expected {what})",
                    CONFIRM_MS / 1000
                );
            }
            session.pump(50)?;
            status = session.status()?;
        }
    }
    print_notices(&mut session);
    println!("{}", format_status(&status, axes));
    if hold && matches!(before.state, gantry_proto::MachineState::Run) {
        if let gantry_proto::MachineState::Idle | gantry_proto::MachineState::Alarm { .. } =
            status.state
        {
            // Stops take precedence (docs/controller.md "Run (stopping...)"): an abort or alarm
            // that was decelerating ends the job; the hold does not undo it.
            eprintln!("gantry: no hold: the job was ending (abort or alarm) and has ended at rest");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Why a resume (cycle start) would do nothing in the state of `before`: only a feed hold, an
/// M0/M1 stop (a hold at rest) and a tool-change stop wait for one.
fn nothing_to_resume(before: &Status) -> Option<String> {
    use gantry_proto::MachineState as S;
    match before.state {
        S::Hold { .. } | S::ToolChange { .. } => None,
        S::Alarm { code } => Some(format!(
            "the board is in {} (clear it with `gantry unlock`, or home)",
            alarm_text(code)
        )),
        S::Run => Some("the job is running (or ending after an abort or alarm)".into()),
        other => Some(format!("the board is {}", state_name(other))),
    }
}

/// A state test for what a realtime request leads to from `before`, with its description.
type Expectation = (&'static str, fn(&Status) -> bool);

fn expected_after(msg: &HostMsg, before: &Status) -> Option<Expectation> {
    use gantry_proto::MachineState as S;
    match (msg, before.state) {
        (HostMsg::FeedHold, S::Run | S::Hold { .. } | S::Jog) => {
            Some(("the machine held at rest", |s| {
                matches!(
                    s.state,
                    S::Hold { stopped: true } | S::Idle | S::Alarm { .. }
                )
            }))
        }
        (HostMsg::Resume, S::Hold { .. }) => Some(("the job running again", |s| {
            !matches!(s.state, S::Hold { .. })
        })),
        (HostMsg::Resume, S::ToolChange { .. }) => Some(("the job running again", |s| {
            !matches!(s.state, S::ToolChange { .. })
        })),
        (HostMsg::Abort, S::Run | S::Hold { .. } | S::Jog | S::Homing | S::Check) => {
            Some(("the job ended at rest", |s| {
                matches!(s.state, S::Idle | S::Alarm { .. })
            }))
        }
        _ => None,
    }
}

/// Sets the feed and/or rapid override (already range-checked) and prints the status once the
/// board shows them.
pub fn set_overrides(target: Target, overrides: Overrides) -> anyhow::Result<ExitCode> {
    let mut session = connect(target)?;
    let axes = session.axes();
    session.set_overrides(overrides)?;
    let start = session.now_ms();
    loop {
        session.pump(20)?;
        let s = session.status()?;
        if overrides.shown_in(&s) {
            println!("{}", format_status(&s, axes));
            return Ok(ExitCode::SUCCESS);
        }
        if session.now_ms().wrapping_sub(start) > CONFIRM_MS {
            anyhow::bail!(
                "the board did not confirm the override within {} s (its status still shows feed {} %, rapid {} %)",
                CONFIRM_MS / 1000,
                s.feed_override,
                s.rapid_override
            );
        }
    }
}

/// Live status readout: redraws every 200 ms (link time) until Ctrl-C or `seconds` have passed.
pub fn watch(target: Target, seconds: Option<f64>) -> anyhow::Result<ExitCode> {
    use std::io::{IsTerminal, Write};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    // Without a handler Ctrl-C simply ends the process, which is just as good here.
    let _ = ctrlc::set_handler(move || {
        s.store(true, Ordering::SeqCst);
        crate::link::request_stop();
    });
    let mut session = connect(target)?;
    let axes = session.axes();
    let start = session.now_ms();
    let tty = std::io::stdout().is_terminal();
    while !stop.load(Ordering::SeqCst) {
        let status = session.status()?;
        let elapsed = session.now_ms().wrapping_sub(start) as f64 / 1000.0;
        if tty {
            // Home the cursor and clear the screen, then redraw.
            print!("\x1b[H\x1b[2J");
        }
        println!("{}\n", format_status(&status, axes));
        std::io::stdout().flush()?;
        if seconds.is_some_and(|limit| elapsed >= limit) {
            break;
        }
        session.pump(200)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs blocks typed on the command line as a small job and prints the result.
pub fn mdi(target: Target, blocks: &[String]) -> anyhow::Result<ExitCode> {
    let mut session = connect(target)?;
    let axes = session.axes();
    check_can_start(&mut session)?;
    let (program, report) = session.mdi(blocks, &mut |_| Flow::Continue)?;
    for e in &report.errors {
        print!("{}", e.describe("mdi", &program));
    }
    for &(axis, max) in &report.limits {
        println!("{}", limit_text(axis, max));
    }
    for a in &report.alarms {
        println!("{}", a.describe(&program));
    }
    if let Some(s) = &report.final_status {
        println!("{}", format_status(s, axes));
    }
    Ok(if report.completed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// Sends a setup to the board, which validates it, applies it and saves it to flash (idle only).
pub fn setup_push(target: Target, setup: &gantry_machine::setup::Setup) -> anyhow::Result<()> {
    connect(target)?.push_setup(setup)
}

/// Sends the setup file `file` to the board, keeping the board's work offsets and G28/G30
/// positions where the file does not name them ([`crate::setup_file::SetupFile::load_for_push`]).
pub fn setup_push_file(target: Target, file: &std::path::Path) -> anyhow::Result<()> {
    let mut session = connect(target)?;
    let setup = crate::setup_file::SetupFile::load_for_push(file, session.setup())?;
    session.push_setup(&setup)
}

/// Reads the board's setup.
pub fn setup_pull(target: Target) -> anyhow::Result<gantry_machine::setup::Setup> {
    Ok(connect(target)?.setup().clone())
}

/// Polls the status every 100 ms (link time) while the board is in `state`, for at most
/// `limit_ms`, and returns the first status in another state; an error naming `what` when the
/// board is still in `state` then.
fn wait_while(
    session: &mut Session,
    state: gantry_proto::MachineState,
    limit_ms: u32,
    what: &str,
) -> anyhow::Result<Status> {
    let start = session.now_ms();
    let mut status = session.status()?;
    while status.state == state {
        if session.now_ms().wrapping_sub(start) > limit_ms {
            anyhow::bail!(
                "the board is still in {} after {} s (expected {what})",
                state_name(state),
                limit_ms / 1000
            );
        }
        session.pump(100)?;
        status = session.status()?;
    }
    Ok(status)
}

/// How long a homing cycle may take: every seek over the whole travel at its seek rate, plus
/// the locate and retract moves, with a margin.
fn homing_bound_ms(setup: &Setup) -> u32 {
    let mut ms = 30_000u64;
    for axis in 0..setup.axis_count as usize {
        let a = &setup.axes[axis];
        let h = &setup.homing.axes[axis];
        let travel_nm = (a.travel_max - a.travel_min).unsigned_abs();
        if h.priority == 0 {
            continue;
        }
        ms += 2 * travel_nm * 60_000 / (h.seek_rate.max(1) as u64);
        // The locate searches twice the pull-off at the slow rate.
        ms += 2 * 2 * h.retract.unsigned_abs() * 60_000 / (h.locate_rate.max(1) as u64);
    }
    ms.min(u32::MAX as u64) as u32
}

/// Homes the axes in `axes` (bit 0 = X; 0 = all), waits for the cycle to end and prints the status.
pub fn home(target: Target, axes: u8) -> anyhow::Result<ExitCode> {
    let mut session = match target {
        Target::Emulated(setup) => {
            Session::emulated(emulated_with_switches((*setup).clone()), *setup)?
        }
        t => connect(t)?,
    };
    let setup = session.setup().clone();
    let n = setup.axis_count as usize;
    match session.home(axes, 1000)? {
        Some(0) => {}
        // Nothing to home: said below with the status.
        Some(gantry_machine::board::ERROR_INVALID_REQUEST) => {}
        Some(code) => {
            println!("{}", format_status(&session.status()?, n));
            println!("home refused: {}", refusal_text(code));
            return Ok(ExitCode::from(1));
        }
        None => anyhow::bail!("the board did not answer the homing request within 1 s"),
    }
    // Seeks run at a slow constant rate over the whole travel.
    let status = wait_while(
        &mut session,
        gantry_proto::MachineState::Homing,
        homing_bound_ms(&setup),
        "the homing cycle to end",
    )?;
    print_notices(&mut session);
    println!("{}", format_status(&status, n));
    let alarmed = matches!(status.state, gantry_proto::MachineState::Alarm { .. });
    if status.homed == 0 && !alarmed {
        println!("no axis was homed: give axes a priority in [homing.axis.X] (docs/settings.md)");
    }
    Ok(if alarmed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// How far a jog goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JogMove {
    /// This signed distance, mm (degrees for A/B/C).
    By(f64),
    /// In this direction (true = positive) until stopped (Ctrl-C, or after `seconds`), never
    /// beyond the soft limits.
    Continuous {
        positive: bool,
        seconds: Option<f64>,
    },
}

/// A jog distance in whole nanometres (the wire unit), refused unless it is a real, non-zero
/// distance: on the wire 0 nm means "continuous until JogStop", so a zero, NaN, infinite or
/// sub-nanometre distance must never be sent as one.
pub fn jog_distance_nm(distance_mm: f64) -> anyhow::Result<u64> {
    anyhow::ensure!(
        distance_mm.is_finite(),
        "jog distance {distance_mm}: not a number of mm (for a continuous jog use --continuous + or -)"
    );
    let nm = (distance_mm.abs() * 1e6).round();
    anyhow::ensure!(
        nm >= 1.0,
        "jog distance {distance_mm} mm: must be at least 0.000001 mm (1 nm) either way (for a continuous jog use --continuous + or -)"
    );
    anyhow::ensure!(
        nm <= 1e13,
        "jog distance {distance_mm} mm: beyond any machine (at most 10 000 000 mm)"
    );
    Ok(nm as u64)
}

/// A jog feed in µm/min (the wire unit), refused unless it is a real, positive speed the wire can
/// carry.
pub fn jog_feed_um_min(feed_mm_min: f64) -> anyhow::Result<i32> {
    anyhow::ensure!(
        feed_mm_min.is_finite() && feed_mm_min > 0.0,
        "--feed {feed_mm_min}: must be a positive speed in mm/min"
    );
    let um = (feed_mm_min * 1000.0).round();
    anyhow::ensure!(
        um >= 1.0,
        "--feed {feed_mm_min}: below 0.001 mm/min, the slowest speed the board takes"
    );
    anyhow::ensure!(
        um <= i32::MAX as f64,
        "--feed {feed_mm_min}: too fast (at most {} mm/min)",
        i32::MAX / 1000
    );
    Ok(um as i32)
}

/// Jogs one axis, waits until it stops and prints the status. A refused jog (in alarm, beyond
/// the travel, …) prints why and exits 1 with no motion.
pub fn jog(target: Target, axis: u8, how: JogMove, feed_mm_min: f64) -> anyhow::Result<ExitCode> {
    let distance_nm = match how {
        JogMove::By(d) => jog_distance_nm(d)?,
        JogMove::Continuous { .. } => 0,
    };
    let speed = jog_feed_um_min(feed_mm_min)?;
    let negative = match how {
        JogMove::By(d) => d < 0.0,
        JogMove::Continuous { positive, .. } => !positive,
    };
    let mut session = connect(target)?;
    let setup = session.setup().clone();
    let n = setup.axis_count as usize;
    anyhow::ensure!(
        (axis as usize) < n,
        "axis {}: this machine has {n} axes ({})",
        AXIS_LETTERS[axis as usize],
        AXIS_LETTERS[..n].iter().collect::<String>()
    );
    let before = session.status()?;
    use gantry_proto::MachineState as S;
    match before.state {
        S::Idle | S::Jog => {}
        S::Alarm { code } => {
            println!("{}", format_status(&before, n));
            println!("jog refused: the board is in {}", alarm_text(code));
            println!("clear it first: gantry unlock (or gantry home when homing is required)");
            return Ok(ExitCode::from(1));
        }
        other => {
            println!("{}", format_status(&before, n));
            println!(
                "jog refused: the board is in {} (jogs start from Idle)",
                state_name(other)
            );
            return Ok(ExitCode::from(1));
        }
    }
    let feed_um_min = if negative { -speed } else { speed };
    // The board answers this jog (its id), started or refused; nothing else counts.
    let start = session.now_ms();
    match session.jog(axis, feed_um_min, distance_nm, 1000)? {
        Some(0) => {}
        answer => {
            println!("{}", format_status(&session.status()?, n));
            match answer {
                Some(code) => println!("jog refused: {}", refusal_text(code)),
                None => println!("jog refused: the board did not answer it within 1 s"),
            }
            return Ok(ExitCode::from(1));
        }
    }
    if let JogMove::Continuous { seconds, .. } = how {
        let stop = ctrl_c_flag();
        let limit_ms = seconds.map(|s| (s * 1000.0) as u32);
        eprintln!("jogging: Ctrl-C stops");
        while !stop.swap(false, std::sync::atomic::Ordering::SeqCst)
            && limit_ms.is_none_or(|l| session.now_ms().wrapping_sub(start) < l)
        {
            session.pump(20)?;
            if session.status()?.state != S::Jog {
                break;
            }
        }
        session.jog_stop()?;
    }
    // The longest jog: the whole travel at the requested speed, with a margin.
    let span = setup.axes[axis as usize].travel_max - setup.axes[axis as usize].travel_min;
    let bound = 5000 + (span.unsigned_abs() as f64 / 1e6 / feed_mm_min * 60_000.0) as u64;
    let status = wait_while(
        &mut session,
        S::Jog,
        bound.min(u32::MAX as u64 / 2) as u32,
        "the jog to end",
    )?;
    print_notices(&mut session);
    println!("{}", format_status(&status, n));
    let a = &setup.axes[axis as usize];
    let step_nm = a.units_nm.unsigned_abs() as f64 / f64::from(a.steps.max(1));
    if distance_nm > 0
        && (distance_nm as f64) < step_nm
        && status.machine_pos[axis as usize] == before.machine_pos[axis as usize]
    {
        println!(
            "no motion: {} mm is less than one step of {} ({} mm)",
            distance_nm as f64 / 1e6,
            AXIS_LETTERS[axis as usize],
            step_nm / 1e6
        );
    }
    Ok(ExitCode::SUCCESS)
}

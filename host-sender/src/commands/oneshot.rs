//! The one-shot board commands: `status`, `watch`, `hold`, `resume`, `abort`, `override`,
//! `unlock`, `home`, `jog`, `mdi`, `setup push` / `setup pull`.
//!
//! Each opens a session with the target (the board on `--port`, through its `gantry serve` when
//! one runs, or a fresh emulated board), does its one thing, prints the resulting status and
//! closes the link; the board keeps running whatever it runs.

use super::{check_can_start, ctrl_c_flag, print_notices, CONFIRM_MS};
use crate::link::OnClose;
use crate::present::{alarm_text, format_status, limit_text, refusal_text, state_name};
use crate::session::{Flow, Overrides, Session, Target};
use anyhow::Context;
use gantry_emulator::emulated_with_switches;
use gantry_machine::setup::Setup;
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{BoardMsg, HostMsg, Status};
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
            if let Some(hint) = pressed_switch_hint(&status, session.setup()) {
                println!("{hint}, then gantry unlock");
            }
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
    // A hold is sent whatever the state (a stop is never withheld); at rest it has nothing to do.
    let idle_hold = if hold { nothing_to_hold(&before) } else { None };
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
    if let Some(why) = idle_hold {
        // Exit 0 as `gantry unlock` without an alarm: the machine stands, as the hold asks.
        eprintln!("gantry: nothing to hold: {why}");
    }
    Ok(ExitCode::SUCCESS)
}

/// Why a feed hold finds nothing to stop in the state of `before`: only motion (a job, a jog,
/// homing, a hold still decelerating) has something to hold.
fn nothing_to_hold(before: &Status) -> Option<String> {
    use gantry_proto::MachineState as S;
    match before.state {
        S::Run | S::Jog | S::Homing | S::Check | S::Hold { stopped: false } => None,
        S::Hold { stopped: true } => Some("the job is already held at rest".into()),
        S::ToolChange { tool } => Some(format!(
            "the job stands at its tool change (T{tool}), nothing moves"
        )),
        S::Alarm { code } => Some(format!(
            "the board is in {}, nothing moves",
            alarm_text(code)
        )),
        other => Some(format!("the board is {}, nothing moves", state_name(other))),
    }
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
/// A block that stops (M0/M1, M6) waits there for the operator (cycle start, or `gantry
/// resume` through `gantry serve`), said once; on the emulated board in this process, which
/// nobody else can reach, it is aborted instead of waiting for ever.
pub fn mdi(target: Target, blocks: &[String]) -> anyhow::Result<ExitCode> {
    let in_process = matches!(target, Target::Emulated(_));
    let mut session = connect(target)?;
    let axes = session.axes();
    check_can_start(&mut session)?;
    let served = session.served();
    let mut told = false;
    let (program, report) = session.mdi(blocks, &mut |p| {
        let state = p.status.as_ref().map(|s| s.state);
        let standing = matches!(
            state,
            Some(gantry_proto::MachineState::Hold { stopped: true })
                | Some(gantry_proto::MachineState::ToolChange { .. })
        );
        if !standing || told {
            return Flow::Continue;
        }
        told = true;
        let state = state.map_or("-", state_name);
        if in_process {
            eprintln!(
                "mdi: the job stands at a stop ({state}) that nothing can continue on the emulated board in this process: aborting it"
            );
            return Flow::Abort;
        }
        let who = if served {
            "cycle start on the machine, or `gantry resume` from another terminal"
        } else {
            "cycle start on the machine"
        };
        eprintln!("mdi: the job stands at a stop ({state}): it goes on with {who}");
        Flow::Continue
    })?;
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

/// Sends the setup file `file` to the board, keeping the board's work offsets and G28/G30
/// positions where the file does not name them (the session's one push path,
/// [`Session::push_setup_text`]); an empty file is refused.
pub fn setup_push_file(target: Target, file: &std::path::Path) -> anyhow::Result<()> {
    let text = crate::setup_file::SetupFile::read_bounded(file)?;
    let mut session = connect(target)?;
    session
        .push_setup_text(&text)
        .with_context(|| format!("in setup file {}", file.display()))?;
    Ok(())
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
            let status = session.status()?;
            println!("{}", format_status(&status, n));
            println!("home refused: {}", refusal_text(code));
            if let Some(hint) = pressed_switch_hint(&status, &setup) {
                println!("{hint}, then gantry unlock and gantry home");
            }
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

/// What to do about the limit switches `status` shows pressed (error 905): the switch and the
/// jog that takes the axis off it and back inside the travel (`gantry jog X -2`), one per switch.
fn pressed_switch_hint(status: &Status, setup: &Setup) -> Option<String> {
    use gantry_machine::board::inputs::{LIMIT_MAX_BIT, LIMIT_MIN_BIT};
    let mut jogs = Vec::new();
    let axes = setup.axes.iter().zip(status.machine_pos).zip(AXIS_LETTERS);
    for (axis, ((a, at), letter)) in axes.take(setup.axis_count as usize).enumerate() {
        for (bit, max) in [(LIMIT_MIN_BIT, false), (LIMIT_MAX_BIT, true)] {
            if status.inputs >> (bit as usize + axis) & 1 == 0 {
                continue;
            }
            // Back inside the travel, then 1 mm more, in whole mm.
            let beyond = if max {
                at - a.travel_max
            } else {
                a.travel_min - at
            };
            let mm = (beyond.max(0) as f64 / 1e6).ceil() + 1.0;
            let side = if max { "max" } else { "min" };
            let sign = if max { "-" } else { "" };
            jogs.push(format!(
                "the {letter} {side} limit switch is pressed: jog off it with gantry jog {letter} {sign}{mm}"
            ));
        }
    }
    (!jogs.is_empty()).then(|| jogs.join("; "))
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
    let limit_bits = gantry_machine::board::LIMIT_BITS;
    match before.state {
        S::Idle | S::Jog => {}
        // A jog off a pressed limit switch: the board decides whether it may leave the alarm.
        S::Alarm { .. } if before.inputs & limit_bits != 0 => {}
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
    let mut deadman = false;
    if let JogMove::Continuous { seconds, .. } = how {
        let stop = ctrl_c_flag();
        let limit_ms = seconds.map(|s| (s * 1000.0) as u32);
        eprintln!("jogging: Ctrl-C stops");
        // The board's dead-man ends the jog 250 ms after the last keepalive, so this process
        // being killed or stopped stops the axis (docs/controller.md "Jogging").
        let (mut alive_at, mut asked_at) = (start, start);
        let mut ended = false;
        while !stop.swap(false, std::sync::atomic::Ordering::SeqCst)
            && limit_ms.is_none_or(|l| session.now_ms().wrapping_sub(start) < l)
        {
            session.pump(10)?;
            let now = session.now_ms();
            if now.wrapping_sub(alive_at) >= JOG_KEEPALIVE_MS {
                session.jog_keepalive()?;
                alive_at = now;
            }
            if now.wrapping_sub(asked_at) >= 100 {
                asked_at = now;
                if session.status()?.state != S::Jog {
                    ended = true;
                    break;
                }
            }
        }
        if !ended {
            session.jog_stop()?;
        }
        deadman = took_deadman_error(&mut session)?;
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
    if deadman || took_deadman_error(&mut session)? {
        println!(
            "the board stopped the jog: no keepalive from this command for {} ms (it was stopped, \
             too slow or cut off from the board)",
            gantry_machine::board::JOG_DEADMAN_MS
        );
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// How often `gantry jog --continuous` keeps its jog alive, ms (the board's dead-man waits 250 ms;
/// senders send at least every 100 ms).
const JOG_KEEPALIVE_MS: u32 = 50;

/// True when the board reported ending a continuous jog by its dead-man (error 904) among the
/// messages received so far; the others stay for whoever waits for them.
fn took_deadman_error(session: &mut Session) -> anyhow::Result<bool> {
    session.pump(0)?;
    let mut kept = Vec::new();
    let mut found = false;
    while let Some(m) = session.link().recv() {
        match m {
            BoardMsg::Error {
                code: gantry_machine::board::ERROR_JOG_DEADMAN,
                ..
            } => found = true,
            other => kept.push(other),
        }
    }
    session.link().put_back(kept);
    Ok(found)
}

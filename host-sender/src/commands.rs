//! The one-shot board commands: `status`, `hold`, `resume`, `abort`, `override`, `mdi`.
//!
//! Each opens the link (to the board on `--port`, or a fresh emulated board), does its one thing,
//! prints the resulting status and closes the link; the board keeps running whatever it runs.

use crate::emulator::EmulatedBoard;
use crate::link::{Client, OnClose, SerialTransport, Transport};
use crate::program::Program;
use crate::stream::{
    alarm_text, axes_line, fresh_status, state_name, stream_program, Flow, Target,
};
use gantry_machine::setup::Setup;
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{HostMsg, Status};
use std::process::ExitCode;

/// Opens the link to the target for a one-shot command: closing it later leaves DTR up, so the
/// board does not take the command's exit for a sender that went away ([`OnClose::KeepDtr`]).
/// Returns the link and the machine's setup (the board's own, read over the link: axis count,
/// travel, units).
pub fn connect(target: Target) -> anyhow::Result<(Client<Box<dyn Transport>>, Setup)> {
    connect_with(target, OnClose::KeepDtr)
}

/// [`connect`] with the given close behaviour ([`OnClose::DropDtr`] for the sender that owns a
/// job).
pub fn connect_with(
    target: Target,
    on_close: OnClose,
) -> anyhow::Result<(Client<Box<dyn Transport>>, Setup)> {
    Ok(match target {
        Target::Emulated(setup) => {
            let t: Box<dyn Transport> = Box::new(EmulatedBoard::new((*setup).clone()));
            (Client::connect(t, 2000)?, *setup)
        }
        Target::Port(p) => {
            // A `gantry serve` that owns the port takes the command; else the port itself.
            let t: Box<dyn Transport> = match crate::serve::SocketTransport::connect(&p)? {
                Some(s) => Box::new(s),
                None => Box::new(SerialTransport::open_with(&p, on_close)?),
            };
            let mut client = Client::connect(t, 3000)?;
            let setup = pull_setup_over(&mut client)
                .map_err(|e| anyhow::anyhow!("{p}: cannot read the board's setup: {e:#}"))?;
            (client, setup)
        }
    })
}

/// The status as a short table.
pub fn format_status(s: &Status, axes: usize) -> String {
    let pos = |p: &[i64]| axes_line(p, axes);
    let homed: String = (0..axes)
        .filter(|i| s.homed >> i & 1 == 1)
        .map(|i| AXIS_LETTERS[i])
        .collect();
    format!(
        "state:     {}\nmachine:   {}\nwork:      {}\nfeed:      {:.1} mm/min (override feed {} %, rapid {} %)\nline:      {}\nbuffers:   {} planner blocks, {} lines\ninputs:    {:#010x}\nhomed:     {}\noutputs:   {}",
        state_name(s.state),
        pos(&s.machine_pos),
        pos(&s.work_pos),
        s.feed_um_min as f64 / 1000.0,
        s.feed_override,
        s.rapid_override,
        s.line,
        s.planner_fill,
        s.queue_fill,
        s.inputs,
        if homed.is_empty() { "none".into() } else { homed },
        outputs_text(&s.outputs)
    ) + &s.probe.map_or(String::new(), |p| {
        let contact = if p.success { "contact" } else { "no contact" };
        format!("\nprobe:     {} ({contact})", pos(&p.machine_pos))
    }) + &match s.state {
        gantry_proto::MachineState::Alarm { code } => format!("\nalarm:     {}", alarm_text(code)),
        gantry_proto::MachineState::ToolChange { tool } => format!(
            "\ntool:      change to tool T{tool}, then cycle start or `gantry resume`"
        ),
        _ => String::new(),
    }
}

/// The spindle, coolant and tool as the board drives them: `spindle CW 12000 rpm, flood, tool 3`.
pub fn outputs_text(o: &gantry_proto::OutputsStatus) -> String {
    use gantry_proto::SpindleStatus;
    let spindle = match o.spindle {
        SpindleStatus::Off => "spindle off".to_owned(),
        SpindleStatus::Cw => format!("spindle CW {} rpm", o.rpm),
        SpindleStatus::Ccw => format!("spindle CCW {} rpm", o.rpm),
    };
    let coolant = match (o.mist, o.flood) {
        (false, false) => "coolant off",
        (true, false) => "mist",
        (false, true) => "flood",
        (true, true) => "mist and flood",
    };
    let tool = match o.tool {
        0 => "no tool".to_owned(),
        t => format!("tool {t}"),
    };
    format!("{spindle}, {coolant}, {tool}")
}

/// Prints the limit and alarm reports the board sent (squaring lists' switch hits, alarms).
fn print_notices<T: Transport>(client: &mut Client<T>) {
    for msg in client.take_notices() {
        match msg {
            gantry_proto::BoardMsg::Limit { axis, max } => {
                println!("{}", crate::stream::limit_text(axis, max))
            }
            gantry_proto::BoardMsg::Alarm { code, .. } => println!("{}", alarm_text(code)),
            _ => {}
        }
    }
}

/// How long a one-shot command waits for the board to confirm what it asked, ms (an abort's
/// deceleration from full speed is well under this).
pub const CONFIRM_MS: u32 = 10_000;

/// `error 900: move exceeds the machine travel (soft limit)` for a refused request's code.
fn refusal_text(code: u16) -> String {
    crate::stream::BoardError {
        line: 0,
        code,
        column: 0,
    }
    .describe("", &Program::from_text(""))
    .trim_start_matches("resume preamble: ")
    .to_owned()
}

/// Clears an alarm (unlock) and prints the status; exits 1 when the board keeps the alarm
/// (homing required, or still decelerating) and says why.
pub fn unlock(target: Target) -> anyhow::Result<ExitCode> {
    let (mut client, setup) = connect(target)?;
    let axes = setup.axis_count as usize;
    let id = client.request_id();
    client.send(HostMsg::Unlock { id })?;
    let answer = client.await_answer(id, CONFIRM_MS)?;
    let status = fresh_status(&mut client)?;
    print_notices(&mut client);
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
    let (mut client, setup) = connect(target)?;
    let axes = setup.axis_count as usize;
    let Some(m) = msg else {
        println!("{}", format_status(&fresh_status(&mut client)?, axes));
        return Ok(ExitCode::SUCCESS);
    };
    let before = fresh_status(&mut client)?;
    let expected = expected_after(&m, &before);
    let hold = matches!(m, HostMsg::FeedHold);
    client.send(m)?;
    client.pump(20)?;
    let mut status = fresh_status(&mut client)?;
    let start = client.transport.now_ms();
    if let Some((what, done)) = expected {
        while !done(&status) {
            if client.transport.now_ms().wrapping_sub(start) > CONFIRM_MS {
                println!("{}", format_status(&status, axes));
                anyhow::bail!(
                    "the board did not confirm within {} s (expected {what})",
                    CONFIRM_MS / 1000
                );
            }
            client.pump(50)?;
            status = fresh_status(&mut client)?;
        }
    }
    print_notices(&mut client);
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
pub fn set_overrides(
    target: Target,
    feed: Option<u16>,
    rapid: Option<u16>,
) -> anyhow::Result<ExitCode> {
    let (mut client, setup) = connect(target)?;
    if let Some(f) = feed {
        client.send(HostMsg::FeedOverride(f))?;
    }
    if let Some(r) = rapid {
        client.send(HostMsg::RapidOverride(r))?;
    }
    let start = client.transport.now_ms();
    loop {
        client.pump(20)?;
        let s = fresh_status(&mut client)?;
        if feed.is_none_or(|f| s.feed_override == f) && rapid.is_none_or(|r| s.rapid_override == r)
        {
            println!("{}", format_status(&s, setup.axis_count as usize));
            return Ok(ExitCode::SUCCESS);
        }
        if client.transport.now_ms().wrapping_sub(start) > CONFIRM_MS {
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
    let _ = ctrlc::set_handler(move || s.store(true, Ordering::SeqCst));
    let (mut client, setup) = connect(target)?;
    let axes = setup.axis_count as usize;
    let start = client.transport.now_ms();
    let tty = std::io::stdout().is_terminal();
    while !stop.load(Ordering::SeqCst) {
        let status = fresh_status(&mut client)?;
        let elapsed = client.transport.now_ms().wrapping_sub(start) as f64 / 1000.0;
        if tty {
            // Home the cursor and clear the screen, then redraw.
            print!("\x1b[H\x1b[2J");
        }
        println!("{}\n", format_status(&status, axes));
        std::io::stdout().flush()?;
        if seconds.is_some_and(|limit| elapsed >= limit) {
            break;
        }
        client.pump(200)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs blocks typed on the command line as a small job and prints the result.
pub fn mdi(target: Target, blocks: &[String]) -> anyhow::Result<ExitCode> {
    let (mut client, setup) = connect(target)?;
    let axes = setup.axis_count as usize;
    let program = Program::from_text(&blocks.join("\n"));
    crate::stream::check_can_start(&mut client)?;
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue)?;
    for e in &report.errors {
        print!("{}", e.describe("mdi", &program));
    }
    for &(axis, max) in &report.limits {
        println!("{}", crate::stream::limit_text(axis, max));
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
    let (mut client, _) = connect(target)?;
    push_setup_over(&mut client, setup)
}

/// [`setup_push`] over an open link.
pub fn push_setup_over<T: Transport>(
    client: &mut Client<T>,
    setup: &gantry_machine::setup::Setup,
) -> anyhow::Result<()> {
    use gantry_machine::setup::SETUP_BLOB_MAX;
    use gantry_proto::messages::SETUP_CHUNK_MAX;
    let mut buf = [0u8; SETUP_BLOB_MAX];
    let blob = setup.to_blob(&mut buf).ok_or_else(|| {
        anyhow::anyhow!("the setup does not fit the board's {SETUP_BLOB_MAX} bytes")
    })?;
    for (i, chunk) in blob.chunks(SETUP_CHUNK_MAX).enumerate() {
        client.send(HostMsg::SetupChunk {
            offset: (i * SETUP_CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(chunk).expect("chunk size"),
        })?;
    }
    let id = client.request_id();
    client.send(HostMsg::SetupCommit {
        id,
        len: blob.len() as u32,
        crc32: gantry_proto::crc::crc32(blob),
    })?;
    match client.await_answer(id, 3000)? {
        Some(0) => Ok(()),
        Some(1) => anyhow::bail!("the board received a damaged setup (length or CRC)"),
        Some(2) => anyhow::bail!("the board refused the setup as invalid"),
        Some(3) => anyhow::bail!("the board is not idle: setups are changed only when idle"),
        Some(c) => anyhow::bail!("the board refused the setup (code {c})"),
        None => anyhow::bail!("the board did not answer the setup within 3 s"),
    }
}

/// Reads the board's setup.
pub fn setup_pull(target: Target) -> anyhow::Result<gantry_machine::setup::Setup> {
    let (_, setup) = connect(target)?;
    Ok(setup)
}

/// [`setup_pull`] over an open link.
pub fn pull_setup_over<T: Transport>(
    client: &mut Client<T>,
) -> anyhow::Result<gantry_machine::setup::Setup> {
    use gantry_proto::BoardMsg;
    client.send(HostMsg::SetupRequest)?;
    // Other messages (a job's program requests, errors, job ends) are kept for later.
    let mut kept = Vec::new();
    let result = (|| {
        let mut blob = Vec::new();
        let mut damaged = false;
        for _ in 0..3000 {
            client.pump(1)?;
            while let Some(msg) = client.recv() {
                match msg {
                    // Through `gantry serve` another command's request may restart the
                    // board's transfer (offset 0 again): follow the newest one; the length and
                    // CRC check the result.
                    BoardMsg::SetupChunk { offset, bytes } => {
                        if offset == 0 {
                            blob.clear();
                        }
                        if offset as usize == blob.len() {
                            blob.extend_from_slice(&bytes);
                        }
                    }
                    BoardMsg::SetupEnd { len, crc32 } => {
                        if len as usize == blob.len() && gantry_proto::crc::crc32(&blob) == crc32 {
                            return gantry_machine::setup::Setup::from_blob(&blob)
                                .ok_or_else(|| anyhow::anyhow!("the board sent an invalid setup"));
                        }
                        damaged = true;
                        blob.clear();
                    }
                    BoardMsg::Status(_) => {}
                    other => kept.push(other),
                }
            }
        }
        if damaged {
            anyhow::bail!("the board's setup arrived damaged (length or CRC)");
        }
        anyhow::bail!("the board did not send its setup within 3 s (expected its setup chunks)")
    })();
    client.put_back(kept);
    result
}

/// The emulated board for `gantry home`: a limit switch sits at the travel end each homed axis
/// seeks, as on a real machine, so the homing cycle can be tried without hardware.
pub fn emulated_with_switches(setup: gantry_machine::setup::Setup) -> EmulatedBoard {
    let mut board = EmulatedBoard::new(setup.clone());
    for axis in 0..setup.axis_count as usize {
        let h = &setup.homing.axes[axis];
        if h.priority == 0 {
            continue;
        }
        let a = &setup.axes[axis];
        let at = if h.seek_low {
            a.travel_min
        } else {
            a.travel_max
        };
        board.add_switch(axis, !h.seek_low, at);
    }
    board
}

/// Polls the status every 100 ms (link time) while the board is in `state`, for at most
/// `limit_ms`, and returns the first status in another state; an error naming `what` when the
/// board is still in `state` then.
fn wait_while<T: Transport>(
    client: &mut Client<T>,
    state: gantry_proto::MachineState,
    limit_ms: u32,
    what: &str,
) -> anyhow::Result<Status> {
    let start = client.transport.now_ms();
    let mut status = fresh_status(client)?;
    while status.state == state {
        if client.transport.now_ms().wrapping_sub(start) > limit_ms {
            anyhow::bail!(
                "the board is still in {} after {} s (expected {what})",
                state_name(state),
                limit_ms / 1000
            );
        }
        client.pump(100)?;
        status = fresh_status(client)?;
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
    }
    ms.min(u32::MAX as u64) as u32
}

/// Homes the axes in `axes` (bit 0 = X; 0 = all), waits for the cycle to end and prints the status.
pub fn home(target: Target, axes: u8) -> anyhow::Result<ExitCode> {
    let (mut client, setup) = match target {
        Target::Emulated(setup) => {
            let t: Box<dyn Transport> = Box::new(emulated_with_switches((*setup).clone()));
            (Client::connect(t, 2000)?, *setup)
        }
        t => connect(t)?,
    };
    let n = setup.axis_count as usize;
    let id = client.request_id();
    client.send(HostMsg::Home { id, axes })?;
    match client.await_answer(id, 1000)? {
        Some(0) => {}
        // Nothing to home: said below with the status.
        Some(gantry_machine::board::ERROR_INVALID_REQUEST) => {}
        Some(code) => {
            println!("{}", format_status(&fresh_status(&mut client)?, n));
            println!("home refused: {}", refusal_text(code));
            return Ok(ExitCode::from(1));
        }
        None => anyhow::bail!("the board did not answer the homing request within 1 s"),
    }
    // Seeks run at a slow constant rate over the whole travel.
    let status = wait_while(
        &mut client,
        gantry_proto::MachineState::Homing,
        homing_bound_ms(&setup),
        "the homing cycle to end",
    )?;
    print_notices(&mut client);
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
    let (mut client, setup) = connect(target)?;
    let n = setup.axis_count as usize;
    anyhow::ensure!(
        (axis as usize) < n,
        "axis {}: this machine has {n} axes ({})",
        AXIS_LETTERS[axis as usize],
        AXIS_LETTERS[..n].iter().collect::<String>()
    );
    let before = fresh_status(&mut client)?;
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
    let id = client.request_id();
    client.send(HostMsg::Jog(gantry_proto::Jog {
        id,
        axis,
        feed_um_min: if negative { -speed } else { speed },
        distance_nm,
    }))?;
    // The board answers this jog (its id), started or refused; nothing else counts.
    let start = client.transport.now_ms();
    match client.await_answer(id, 1000)? {
        Some(0) => {}
        answer => {
            println!("{}", format_status(&fresh_status(&mut client)?, n));
            match answer {
                Some(code) => println!("jog refused: {}", refusal_text(code)),
                None => println!("jog refused: the board did not answer it within 1 s"),
            }
            return Ok(ExitCode::from(1));
        }
    }
    if let JogMove::Continuous { seconds, .. } = how {
        let stop = crate::stream::ctrl_c_flag();
        let limit_ms = seconds.map(|s| (s * 1000.0) as u32);
        eprintln!("jogging: Ctrl-C stops");
        while !stop.swap(false, std::sync::atomic::Ordering::SeqCst)
            && limit_ms.is_none_or(|l| client.transport.now_ms().wrapping_sub(start) < l)
        {
            client.pump(20)?;
            if fresh_status(&mut client)?.state != S::Jog {
                break;
            }
        }
        client.send(HostMsg::JogStop)?;
    }
    // The longest jog: the whole travel at the requested speed, with a margin.
    let span = setup.axes[axis as usize].travel_max - setup.axes[axis as usize].travel_min;
    let bound = 5000 + (span.unsigned_abs() as f64 / 1e6 / feed_mm_min * 60_000.0) as u64;
    let status = wait_while(
        &mut client,
        S::Jog,
        bound.min(u32::MAX as u64 / 2) as u32,
        "the jog to end",
    )?;
    print_notices(&mut client);
    println!("{}", format_status(&status, n));
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gantry_proto::MachineState;

    fn status(state: MachineState) -> Status {
        Status {
            state,
            machine_pos: [1_500_000, 0, 0, 0, 0, 0],
            work_pos: [1_500_000, 0, 0, 0, 0, 0],
            feed_um_min: 0,
            feed_override: 100,
            rapid_override: 100,
            planner_fill: 0,
            queue_fill: 0,
            line: 7,
            inputs: 0,
            homed: 0b001,
            outputs: Default::default(),
            probe: None,
        }
    }

    #[test]
    fn the_status_names_the_alarm_and_says_what_it_means() {
        let text = format_status(&status(MachineState::Alarm { code: 20 }), 3);
        assert!(text.starts_with("state:     Alarm\nmachine:   X 1.500  Y 0.000  Z 0.000"));
        assert!(
            text.ends_with(
                "homed:     X\noutputs:   spindle off, coolant off, no tool\nalarm:     alarm 20 (host lost): the host stayed away while the job stood still: job ended, spindle and coolant off"
            ),
            "{text}"
        );
        assert!(!format_status(&status(MachineState::Idle), 3).contains("alarm"));
        assert!(!format_status(&status(MachineState::Idle), 3).contains("probe"));
        let mut probed = status(MachineState::Idle);
        probed.probe = Some(gantry_proto::ProbeStatus {
            machine_pos: [0, 0, -5_000_000, 0, 0, 0],
            success: true,
        });
        let text = format_status(&probed, 3);
        assert!(
            text.ends_with("no tool\nprobe:     X 0.000  Y 0.000  Z -5.000 (contact)"),
            "{text}"
        );
        probed.probe = Some(gantry_proto::ProbeStatus {
            machine_pos: [0, 0, -4_000_000, 0, 0, 0],
            success: false,
        });
        let text = format_status(&probed, 3);
        assert!(text.ends_with("Z -4.000 (no contact)"), "{text}");
        let mut running = status(MachineState::Run);
        running.outputs = gantry_proto::OutputsStatus {
            spindle: gantry_proto::SpindleStatus::Ccw,
            rpm: 12_000,
            mist: true,
            flood: true,
            tool: 2,
        };
        assert!(format_status(&running, 3)
            .ends_with("outputs:   spindle CCW 12000 rpm, mist and flood, tool 2"));
        assert!(format_status(&status(MachineState::Alarm { code: 99 }), 3)
            .ends_with("alarm:     alarm 99 (unknown to this gantry)"));
        // Every alarm the board can raise has a name and a text.
        for a in gantry_machine::controller::AlarmCode::ALL {
            assert!(!alarm_text(a as u16).contains("unknown to this gantry"));
        }
    }

    #[test]
    fn the_status_names_the_tool_a_tool_change_waits_for() {
        let text = format_status(&status(MachineState::ToolChange { tool: 2 }), 3);
        assert!(
            text.starts_with(
                "state:     ToolChange
"
            ),
            "{text}"
        );
        assert!(
            text.ends_with("tool:      change to tool T2, then cycle start or `gantry resume`"),
            "{text}"
        );
    }
}

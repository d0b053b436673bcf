//! The one-shot board commands: `status`, `hold`, `resume`, `abort`, `override`, `mdi`.
//!
//! Each opens the link (to the board on `--port`, or a fresh emulated board), does its one thing,
//! prints the resulting status and closes the link; the board keeps running whatever it runs.

use crate::emulator::EmulatedBoard;
use crate::link::{Client, SerialTransport, Transport};
use crate::program::Program;
use crate::stream::{
    alarm_text, axes_line, fresh_status, state_name, stream_program, Flow, Target,
};
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{HostMsg, Status};
use std::process::ExitCode;

/// Opens the link to the target.
pub fn connect(target: Target) -> anyhow::Result<(Client<Box<dyn Transport>>, usize)> {
    Ok(match target {
        Target::Emulated(setup) => {
            let axes = setup.axis_count as usize;
            let t: Box<dyn Transport> = Box::new(EmulatedBoard::new(*setup));
            (Client::connect(t, 2000)?, axes)
        }
        Target::Port(p) => {
            let t: Box<dyn Transport> = Box::new(SerialTransport::open(&p)?);
            (Client::connect(t, 3000)?, 3)
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
        "state:     {}\nmachine:   {}\nwork:      {}\nfeed:      {:.1} mm/min (override feed {} %, rapid {} %)\nline:      {}\nbuffers:   {} planner blocks, {} lines\ninputs:    {:#010x}\nhomed:     {}",
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
        if homed.is_empty() { "none".into() } else { homed }
    ) + &match s.state {
        gantry_proto::MachineState::Alarm { code } => format!("\nalarm:     {}", alarm_text(code)),
        _ => String::new(),
    }
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

/// Sends one realtime message (or none), waits a moment and prints the status.
pub fn realtime(target: Target, msg: Option<HostMsg>) -> anyhow::Result<ExitCode> {
    let (mut client, axes) = connect(target)?;
    if let Some(m) = msg {
        client.send(m)?;
        client.pump(100)?;
    }
    println!("{}", format_status(&fresh_status(&mut client)?, axes));
    Ok(ExitCode::SUCCESS)
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
    let (mut client, axes) = connect(target)?;
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
    let (mut client, axes) = connect(target)?;
    let program = Program::from_text(&blocks.join("\n"));
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue)?;
    for e in &report.errors {
        println!("error: {}", e.describe(&program));
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
    client.send(HostMsg::SetupCommit {
        len: blob.len() as u32,
        crc32: gantry_proto::crc::crc32(blob),
    })?;
    for _ in 0..3000 {
        client.pump(1)?;
        while let Some(msg) = client.recv() {
            if let gantry_proto::BoardMsg::SetupResult { code } = msg {
                return match code {
                    0 => Ok(()),
                    1 => anyhow::bail!("the board received a damaged setup (length or CRC)"),
                    2 => anyhow::bail!("the board refused the setup as invalid"),
                    3 => anyhow::bail!("the board is not idle: setups are changed only when idle"),
                    c => anyhow::bail!("the board refused the setup (code {c})"),
                };
            }
        }
    }
    anyhow::bail!("the board did not answer the setup within 3 s")
}

/// Reads the board's setup.
pub fn setup_pull(target: Target) -> anyhow::Result<gantry_machine::setup::Setup> {
    let (mut client, _) = connect(target)?;
    pull_setup_over(&mut client)
}

/// [`setup_pull`] over an open link.
pub fn pull_setup_over<T: Transport>(
    client: &mut Client<T>,
) -> anyhow::Result<gantry_machine::setup::Setup> {
    use gantry_proto::BoardMsg;
    client.send(HostMsg::SetupRequest)?;
    let mut blob = Vec::new();
    for _ in 0..3000 {
        client.pump(1)?;
        while let Some(msg) = client.recv() {
            match msg {
                BoardMsg::SetupChunk { offset, bytes } => {
                    anyhow::ensure!(offset as usize == blob.len(), "setup chunk out of order");
                    blob.extend_from_slice(&bytes);
                }
                BoardMsg::SetupEnd { len, crc32 } => {
                    anyhow::ensure!(
                        len as usize == blob.len() && gantry_proto::crc::crc32(&blob) == crc32,
                        "the board's setup arrived damaged"
                    );
                    return gantry_machine::setup::Setup::from_blob(&blob)
                        .ok_or_else(|| anyhow::anyhow!("the board sent an invalid setup"));
                }
                _ => {}
            }
        }
    }
    anyhow::bail!("the board did not send its setup within 3 s")
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

/// Polls the status every 100 ms (link time) while the board is in `state`, for up to an hour,
/// and returns the first status in another state (or the last one).
fn wait_while<T: Transport>(
    client: &mut Client<T>,
    state: gantry_proto::MachineState,
) -> anyhow::Result<Status> {
    let mut status = fresh_status(client)?;
    for _ in 0..36_000 {
        if status.state != state {
            break;
        }
        client.pump(100)?;
        status = fresh_status(client)?;
    }
    Ok(status)
}

/// Homes the axes in `axes` (bit 0 = X; 0 = all), waits for the cycle to end and prints the status.
pub fn home(target: Target, axes: u8) -> anyhow::Result<ExitCode> {
    let (mut client, n) = match target {
        Target::Emulated(setup) => {
            let n = setup.axis_count as usize;
            let t: Box<dyn Transport> = Box::new(emulated_with_switches(*setup));
            (Client::connect(t, 2000)?, n)
        }
        t => connect(t)?,
    };
    client.send(HostMsg::Home { axes })?;
    // Seeks run at a slow constant rate over the whole travel.
    let status = wait_while(&mut client, gantry_proto::MachineState::Homing)?;
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

/// Jogs one axis by `distance_mm` (signed) at `feed_mm_min`, waits until it stops and prints the
/// status.
pub fn jog(
    target: Target,
    axis: u8,
    distance_mm: f64,
    feed_mm_min: f64,
) -> anyhow::Result<ExitCode> {
    let (mut client, n) = connect(target)?;
    anyhow::ensure!(
        (axis as usize) < n,
        "axis {}: this machine has {n} axes",
        AXIS_LETTERS[axis as usize]
    );
    anyhow::ensure!(feed_mm_min > 0.0, "--feed must be positive");
    let speed = (feed_mm_min * 1000.0).round() as i32 * if distance_mm < 0.0 { -1 } else { 1 };
    client.send(HostMsg::Jog(gantry_proto::Jog {
        axis,
        feed_um_min: speed,
        distance_nm: (distance_mm.abs() * 1e6).round() as u64,
    }))?;
    let status = wait_while(&mut client, gantry_proto::MachineState::Jog)?;
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
        }
    }

    #[test]
    fn the_status_names_the_alarm_and_says_what_it_means() {
        let text = format_status(&status(MachineState::Alarm { code: 20 }), 3);
        assert!(text.starts_with("state:     Alarm\nmachine:   X 1.500  Y 0.000  Z 0.000"));
        assert!(
            text.ends_with(
                "homed:     X\nalarm:     alarm 20 (host lost): the host stayed away while the job stood still: job ended, spindle and coolant off"
            ),
            "{text}"
        );
        assert!(!format_status(&status(MachineState::Idle), 3).contains("alarm"));
        assert!(format_status(&status(MachineState::Alarm { code: 99 }), 3)
            .ends_with("alarm:     alarm 99 (unknown to this gantry)"));
        // Every alarm the board can raise has a name and a text.
        for a in gantry_machine::controller::AlarmCode::ALL {
            assert!(!alarm_text(a as u16).contains("unknown to this gantry"));
        }
    }
}

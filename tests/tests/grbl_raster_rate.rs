//! The board's share of a grbl character-counting sender's line rate, on virtual time: a
//! LightBurn-style raster (a `G1 X… S…` per pixel under M4, a new S on every pixel) streamed by
//! grbl's counting rule (127 bytes unanswered at most) to the grbl port of the emulated board,
//! with a fixed host turnaround (an `ok` the board wrote at t is answered by the sender's next
//! bytes in the board's receive pipe at t + `HOST_TURNAROUND_US`: a USB frame each way and the
//! sender's reaction). The board's part of the round trip is its main-loop cadence (a pass every
//! millisecond, machine/src/device/main_loop.rs; a line is answered in the pass that reads it);
//! a counting sender gets 127 bytes per round trip, so at 3,333 lines/s of ~17-byte lines the
//! whole round trip must stay under ~2.2 ms. Real-time figures through `gantry emulate` and a
//! real sender are scripts/bench-laser.sh's (docs/laser-plasma.md "Raster speed").

mod controller_support;

use controller_support::*;
use gantry_emulator::cpu_model::CpuModel;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::State;
use gantry_machine::device::grbl::BANNER;
use gantry_machine::motion::kernel::KERNEL_TIMER_HZ;
use gantry_machine::setup::Setup;
use std::collections::VecDeque;

/// The host's turnaround, µs: from the board writing an `ok` to the sender's next line in the
/// board's receive pipe. 1 ms: a full-speed USB frame in each direction is at most 1 ms each
/// (a bulk transfer is scheduled within the frame), less the sender's reaction.
const HOST_TURNAROUND_US: u64 = 1000;

/// grbl's counting rule: the bytes of unanswered lines stay below the 128-byte ring.
const COUNTED: usize = 127;

/// A laser machine as scripts/bench-laser.sh's: X and Y at 12,000 mm/min and 3,000 mm/s²,
/// S 0-1000 onto a PWM of 1,000 counts, laser mode.
fn laser_machine(s: &mut Setup) {
    for a in s.axes.iter_mut().take(2) {
        a.max_rate = 12_000_000_000;
        a.accel = 3_000_000_000;
    }
    s.outputs.laser = true;
    s.outputs.spindle_min_rpm = 0;
    s.outputs.spindle_max_rpm = 1000;
    s.outputs.pwm_min = 0;
    s.outputs.pwm_max = 1000;
}

/// `rows` raster rows of 50 mm in pixels of `px_um` µm at `feed` mm/min, 2 mm overscan at S0.
fn raster(px_um: u32, feed: u32, rows: u32) -> Vec<String> {
    let n = 50_000 / px_um;
    let mm = |um: i64| format!("{}.{:03}", um / 1000, um % 1000);
    let at = |um: i64| {
        if um < 0 {
            format!("-{}", mm(-um))
        } else {
            mm(um)
        }
    };
    let mut p: Vec<String> = vec![
        "G21 G90 G94".into(),
        "M4 S0".into(),
        "G0 X0 Y0".into(),
        format!("G1 F{feed}"),
    ];
    let mut k = 0u32;
    for r in 0..rows {
        let fwd = r.is_multiple_of(2);
        let x = |i: u32| i64::from(if fwd { i } else { n - i }) * i64::from(px_um);
        let over = if fwd { -2000 } else { 2000 };
        p.push(format!(
            "G0 X{} Y{}",
            at(x(0) + over),
            at(i64::from(r * px_um))
        ));
        p.push(format!("G1 X{} S0", at(x(0))));
        for i in 1..=n {
            k += 1;
            p.push(format!("G1 X{} S{}", at(x(i)), (k * 37) % 1000 + 1));
        }
        p.push(format!("G1 X{} S0", at(x(n) - over)));
    }
    p.push("M5".into());
    p.push("M2".into());
    p
}

/// Streams `lines` by counting with the host turnaround; the board's time from the first line
/// to Idle at rest, s, and the steps it ends on.
fn stream_counting(eb: &mut EmulatedBoard, lines: &[String]) -> (f64, [i64; 2]) {
    let quantum = u64::from(KERNEL_TIMER_HZ) / 10_000; // 100 µs
    let turnaround = u64::from(KERNEL_TIMER_HZ) * HOST_TURNAROUND_US / 1_000_000;
    eb.receive(b"\x18");
    let mut seen = String::new();
    while !seen.contains(BANNER) {
        eb.run_ms(1);
        seen.push_str(&String::from_utf8_lossy(&eb.take_output()));
        assert!(eb.now_ms() < 2000, "no banner: {seen:?}");
    }
    // Bytes on their way to the board (due time, bytes), lines unanswered (their lengths).
    let mut arriving: VecDeque<(u64, Vec<u8>)> = VecDeque::new();
    let mut unanswered: VecDeque<usize> = VecDeque::new();
    let (mut sent, mut answered) = (0, 0);
    let mut text = String::new();
    let start = eb.now();
    let fill = |now: u64,
                sent: &mut usize,
                unanswered: &mut VecDeque<usize>,
                arriving: &mut VecDeque<(u64, Vec<u8>)>| {
        while *sent < lines.len() {
            let line = format!("{}\n", lines[*sent]);
            if unanswered.iter().sum::<usize>() + line.len() > COUNTED {
                break;
            }
            unanswered.push_back(line.len());
            arriving.push_back((now, line.into_bytes()));
            *sent += 1;
        }
    };
    fill(start, &mut sent, &mut unanswered, &mut arriving);
    while answered < lines.len() {
        while arriving.front().is_some_and(|(at, _)| *at <= eb.now()) {
            let (_, bytes) = arriving.pop_front().unwrap();
            eb.receive(&bytes);
        }
        eb.run_for(quantum);
        text.push_str(&String::from_utf8_lossy(&eb.take_output()));
        let mut got = 0;
        while let Some(i) = text.find("\r\n") {
            let line: String = text.drain(..i + 2).collect();
            let line = line.trim_end();
            assert!(
                !line.starts_with("error"),
                "{line} after {answered} answers"
            );
            if line == "ok" {
                got += 1;
            }
        }
        for _ in 0..got {
            unanswered.pop_front().expect("an ok for a line sent");
            answered += 1;
        }
        if got > 0 {
            fill(
                eb.now() + turnaround,
                &mut sent,
                &mut unanswered,
                &mut arriving,
            );
        }
        assert!(
            eb.now() - start < 120 * u64::from(KERNEL_TIMER_HZ),
            "stalled at {answered} of {} answers",
            lines.len()
        );
    }
    assert!(eb.run_until(60_000, |b| b.board.state() == State::Idle
        && !b.isr.kernel.is_busy()));
    let took = (eb.now() - start) as f64 / f64::from(KERNEL_TIMER_HZ);
    let p = eb.isr.kernel.position();
    (took, [p[0], p[1]])
}

/// The raster through the counting sender against `gantry simulate`'s planned time, with and
/// without the F411 CPU model; the steps are the program's.
fn within_planned(px_um: u32, feed: u32, rows: u32) {
    let lines = raster(px_um, feed, rows);
    let program = lines.join("\n") + "\n";
    let mut s = Setup::default();
    laser_machine(&mut s);
    let (_, planned) = host_sender::simulate::simulate(program.as_bytes(), &s).unwrap();
    for cpu in [None, Some(CpuModel::F411)] {
        let mut eb = board(laser_machine);
        eb.set_cpu_model(cpu);
        let (took, steps) = stream_counting(&mut eb, &lines);
        let name = cpu.map_or("no CPU model", |c| c.name);
        eprintln!(
            "{} lines, {px_um} µm pixels at F{feed}, {name}: {took:.3} s, planned {planned:.3} s, ratio {:.4}",
            lines.len(),
            took / planned
        );
        assert!(
            took <= planned * 1.02,
            "{name}: {took:.3} s, planned {planned:.3} s"
        );
        // Ends at the last overscan: X at -2 mm or 52 mm, Y on the last row.
        let end_x = if rows.is_multiple_of(2) { -2 } else { 52 };
        assert_eq!(
            steps,
            [
                end_x * STEPS_PER_MM,
                i64::from((rows - 1) * px_um) * STEPS_PER_MM / 1000
            ],
            "{name}"
        );
    }
}

#[test]
fn a_raster_of_0_1_mm_pixels_at_f6000_streams_by_counting_in_its_planned_time() {
    within_planned(100, 6000, 4);
}

#[test]
fn a_raster_of_0_05_mm_pixels_at_f10000_streams_by_counting_in_its_planned_time() {
    within_planned(50, 10_000, 4);
}

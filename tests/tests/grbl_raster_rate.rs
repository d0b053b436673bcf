//! The board's share of a grbl character-counting sender's line rate, on virtual time: a
//! LightBurn-style raster (a `G1 X… S…` per pixel under M4, a new S on every pixel) streamed by
//! grbl's counting rule (127 bytes unanswered at most) to the grbl port of the emulated board,
//! with a fixed host turnaround (an `ok` the board wrote at t is answered by the sender's next
//! bytes in the board's receive pipe at t + `HOST_TURNAROUND_US`: a USB frame each way and the
//! sender's reaction). The board's part of the round trip is the pass the bytes wake (the
//! firmware's USB receive task wakes its main loop at once, machine/src/device/main_loop.rs
//! `MainLoop::host_bytes_pass`; a line is answered in that pass when the planner has room):
//! nothing without a CPU model, that pass's time on the F411's. A counting sender gets 127
//! bytes per round trip, so at 3,333 lines/s of ~17-byte lines the whole round trip must stay
//! under ~2.2 ms. Real-time figures through `gantry emulate` and a
//! real sender are scripts/bench-laser.sh's (docs/laser-plasma.md "Raster speed").

mod controller_support;

use controller_support::*;
use gantry_emulator::cpu_model::CpuModel;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::State;
use gantry_machine::device::grbl::BANNER;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
use std::collections::VecDeque;

/// The host's turnaround, µs: from the board writing an `ok` to the sender's next line in the
/// board's receive pipe. 1 ms: a full-speed USB frame in each direction is at most 1 ms each
/// (a bulk transfer is scheduled within the frame), less the sender's reaction.
const HOST_TURNAROUND_US: u64 = 1000;
/// A slow host's turnaround (a loaded computer, a sender with threads between its reader and
/// writer): with the board answering a line in the pass its bytes wake, the 0.05 mm raster
/// keeps its planned time even so (it took 1.17× while each line waited for the next tick).
const SLOW_HOST_TURNAROUND_US: u64 = 2000;

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

/// Streams `lines` by counting with a host turnaround of `turnaround_us`; the board's time from
/// the first line to Idle at rest, s, and the steps it ends on.
fn stream_counting(
    eb: &mut EmulatedBoard,
    lines: &[String],
    turnaround_us: u64,
) -> (f64, [i64; 2]) {
    let quantum = u64::from(KERNEL_TIMER_HZ) / 10_000; // 100 µs
    let turnaround = u64::from(KERNEL_TIMER_HZ) * turnaround_us / 1_000_000;
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

/// The raster through the counting sender (host turnaround `turnaround_us`) against `gantry
/// simulate`'s planned time, with and without the F411 CPU model; the steps are the program's.
fn within_planned(px_um: u32, feed: u32, rows: u32, turnaround_us: u64) {
    let lines = raster(px_um, feed, rows);
    let program = lines.join("\n") + "\n";
    let mut s = Setup::default();
    laser_machine(&mut s);
    let (_, planned) = host_sender::simulate::simulate(program.as_bytes(), &s).unwrap();
    for cpu in [None, Some(CpuModel::F411)] {
        let mut eb = board(laser_machine);
        eb.set_cpu_model(cpu);
        let (took, steps) = stream_counting(&mut eb, &lines, turnaround_us);
        let name = cpu.map_or("no CPU model", |c| c.name);
        eprintln!(
            "{} lines, {px_um} µm pixels at F{feed}, host turnaround {turnaround_us} µs, {name}: {took:.3} s, planned {planned:.3} s, ratio {:.4}",
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
    within_planned(100, 6000, 4, HOST_TURNAROUND_US);
}

#[test]
fn a_raster_of_0_05_mm_pixels_at_f10000_streams_by_counting_in_its_planned_time() {
    within_planned(50, 10_000, 4, HOST_TURNAROUND_US);
}

#[test]
fn the_0_05_mm_raster_keeps_its_planned_time_with_a_slow_host() {
    within_planned(50, 10_000, 4, SLOW_HOST_TURNAROUND_US);
}

/// A line that arrives between two ticks is answered in the pass its bytes wake, not at the
/// next tick: at the instant it arrives without a CPU model, before the next tick with the
/// F411's (the CPU may still be in the tick's pass; the emulated board's bytes leave at its
/// pass's start, the model charging the pass's time after). Each line arrives 0.3 ms after a
/// tick, with the planner far from full.
#[test]
fn a_line_arriving_between_two_ticks_is_answered_in_the_pass_its_bytes_wake() {
    let lines = raster(50, 10_000, 1);
    let us = COUNTS_PER_MS / 1000;
    for cpu in [None, Some(CpuModel::F411)] {
        let name = cpu.map_or("no CPU model", |c| c.name);
        let mut eb = board(laser_machine);
        eb.set_cpu_model(cpu);
        eb.receive(b"\x18");
        let mut seen = String::new();
        while !seen.contains(BANNER) {
            eb.run_ms(1);
            seen.push_str(&String::from_utf8_lossy(&eb.take_output()));
        }
        eb.run_ms(5);
        eb.take_output();
        let mut worst = 0;
        for line in &lines[..60] {
            // 0.3 ms after the next tick.
            let tick = eb.next_tick();
            eb.run_for(tick + 300 * us - eb.now());
            let at = eb.now();
            eb.receive(format!("{line}\n").as_bytes());
            eb.run_due();
            let mut out = String::from_utf8_lossy(&eb.take_output()).into_owned();
            while !out.contains("ok\r\n") {
                assert!(!out.contains("error"), "{name}: {line}: {out:?}");
                assert!(
                    eb.now() < at + 700 * us,
                    "{name}: {line} not answered before the next tick"
                );
                eb.run_for(10 * us);
                out.push_str(&String::from_utf8_lossy(&eb.take_output()));
            }
            worst = worst.max(eb.now() - at);
        }
        if cpu.is_none() {
            assert_eq!(
                worst, 0,
                "answered in the pass at the instant its line arrived"
            );
        }
        eprintln!("{name}: longest wait for an ok {} µs", worst / us);
    }
}

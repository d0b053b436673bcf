//! G38.x probing on the emulated board, in process (docs/probing.md): the kernel's latch at the
//! step the probe pin changes, the planned deceleration after it, the results in #5061-#5070,
//! the alarms of grbl (4: probe already tripped, 5: no contact) and XY probing of a boss.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, ProbeTarget};
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::board::{BoardEvent, JobEnd};
use gantry_machine::device::link::status_of;
use gantry_machine::gcode::expr::ParamRef;
use gantry_proto::ProbeStatus;
use host_sender::present::format_status;

/// A parameter's value in µm (program units are mm: values are mm × 10⁹).
fn param_um(eb: &EmulatedBoard, n: u16) -> i64 {
    eb.board
        .interpreter()
        .parameter(ParamRef::Numbered(n))
        .unwrap()
        / 1_000_000
}

fn param_nm(eb: &EmulatedBoard, n: u16) -> i64 {
    eb.board
        .interpreter()
        .parameter(ParamRef::Numbered(n))
        .unwrap()
        / 1_000
}

/// Runs `program` to its end (idle or alarm) with the probe targets given.
fn run(targets: &[ProbeTarget], program: &str) -> EmulatedBoard {
    let mut eb = board(|_| {});
    eb.capture_events();
    for t in targets {
        eb.add_probe_target(*t);
    }
    job(&mut eb, program);
    let done = eb.run_until(120_000, |b| {
        matches!(b.board.state(), State::Idle | State::Alarm) && b.kernel_drained()
    });
    assert!(done, "still {:?}", eb.board.state());
    eb
}

const PLANE: ProbeTarget = ProbeTarget::Plane { z: -5 * MM };

#[test]
fn g38_2_toward_a_plane_latches_within_one_step_and_decelerates_after_contact() {
    // Z at 640 steps/mm: -5.000 mm is step -3200; the pin is low above, high at and below it.
    // (feed mm/min, steps the deceleration ran on after the contact step)
    // Planned deceleration at 200 mm/s² down to the 60 mm/min start speed, (v² − v0²) / 2a:
    // F100 0.0044 mm (2.8 steps), F300 0.060 mm (38.4), F600 0.2475 mm (158.4); on top of it
    // the latency from the contact to the stop plan (the main-loop pass after the latch, ≤ 1 ms,
    // and the kernel's running segment, ≤ 2 ms): at most 3 ms at the feed. F20 is below the
    // start speed: the move stops at once, on the contact step.
    let cases: [(i64, i64); 4] = [(20, 0), (100, 5), (300, 46), (600, 172)];
    // The step onto the plane (-3200 steps) raised the pin; the interrupt's next kernel tick saw
    // it and latched the kernel's count before its own step: the plane, plus the steps of the
    // two ticks the interrupt had computed ahead of the pins (machine/src/step/isr.rs
    // `TICKS_AHEAD`, as on the board): at F600 one of them stepped, below it neither did
    // (slower feeds tick several times per step: AMASS, machine/src/motion/prep.rs).
    let latched_past = [0, 0, 0, 1];
    let mut overruns = Vec::new();
    for ((feed, overrun), past) in cases.into_iter().zip(latched_past) {
        let eb = run(&[PLANE], &format!("G38.2 Z-20 F{feed}\nM2"));
        assert_eq!(eb.board.state(), State::Idle, "F{feed}");
        assert_eq!(param_um(&eb, 5070), 1000, "F{feed}: #5070 success");
        let z = param_nm(&eb, 5063);
        assert!((z - (-5 * MM)).abs() <= MM / 640, "F{feed}: #5063 = {z} nm");
        let latched = -5_000_000 - past * MM / 640;
        assert_eq!(
            z, latched,
            "F{feed}: the step onto the plane and {past} after it"
        );
        assert_eq!((param_nm(&eb, 5061), param_nm(&eb, 5062)), (0, 0));
        let result = eb.board.probe_result().unwrap();
        assert!(result.success);
        assert_eq!(result.position[2], latched);
        // At rest below the contact by the planned deceleration (200 mm/s², stops from the 60
        // mm/min start speed at once) plus the kernel's running segment.
        let stopped = eb.isr.kernel.position()[2];
        overruns.push((feed, -3200 - stopped));
        let v = feed as f64 / 60.0;
        let bound = ((v * v - 1.0).max(0.0) / 400.0 + v * 0.003) * 640.0;
        assert!(
            (overrun as f64) <= bound.ceil(),
            "F{feed}: {overrun} > {bound}"
        );
        // The interpreter continues from where the machine stands.
        let pos = eb.board.interpreter().state().position;
        assert_eq!(
            pos[2],
            eb.board.machine_position(&eb.isr.kernel.position())[2]
        );
    }
    assert_eq!(overruns, cases.to_vec(), "(feed, overrun steps)");
}

#[test]
fn g38_3_without_contact_ends_the_move_without_error() {
    let eb = run(&[PLANE], "G38.3 Z-4 F300\nG0 Z0\nM2");
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(param_um(&eb, 5070), 0);
    assert_eq!(param_um(&eb, 5063), -4000);
    assert_eq!(eb.isr.kernel.position()[2], 0, "the G0 after it ran");
    assert!(!eb.board.probe_result().unwrap().success);
}

#[test]
fn the_framed_status_carries_the_last_probe_result() {
    let eb = board(|_| {});
    assert_eq!(status_of(&eb.board, &eb.kernel_view()).probe, None);
    let eb = run(&[PLANE], "G38.2 Z-20 F100\nG0 Z0\nM2");
    let status = status_of(&eb.board, &eb.kernel_view());
    assert_eq!(
        status.probe,
        Some(ProbeStatus {
            machine_pos: [0, 0, -5_000_000, 0, 0, 0],
            success: true
        })
    );
    let text = format_status(&status, 3);
    assert!(
        text.contains("\nprobe:     X 0.000  Y 0.000  Z -5.000 (contact)"),
        "{text}"
    );
    let eb = run(&[PLANE], "G38.3 Z-4 F300\nM2");
    let status = status_of(&eb.board, &eb.kernel_view());
    assert!(
        format_status(&status, 3).contains("Z -4.000 (no contact)"),
        "{status:?}"
    );
}

#[test]
fn g38_2_without_contact_is_alarm_5() {
    let mut eb = run(&[PLANE], "G38.2 Z-4 F300\nG0 Z0\nM2");
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ProbeFailContact));
    assert_eq!(AlarmCode::ProbeFailContact as u16, 5);
    assert_eq!(
        eb.isr.kernel.position()[2],
        -2560,
        "stopped at the end of the probe move"
    );
    let ev = events(&mut eb);
    assert!(
        ev.contains(&BoardEvent::Alarm {
            code: AlarmCode::ProbeFailContact,
            line: 1
        }),
        "{ev:?}"
    );
}

#[test]
fn a_probe_already_touching_is_alarm_4_and_nothing_moves() {
    let mut eb = run(&[PLANE], "G0 Z-6\nG38.2 Z-10 F100\nG0 Z0");
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ProbeFailInitial));
    assert_eq!(eb.isr.kernel.position()[2], -6 * 640);
    let ev = events(&mut eb);
    assert!(ev.contains(&BoardEvent::Alarm {
        code: AlarmCode::ProbeFailInitial,
        line: 2
    }));
}

#[test]
fn g38_4_away_from_contact_trips_when_the_probe_clears() {
    // Start below the plane (touching), probe up: the probe clears at -5 mm going up.
    let mut eb = board(|_| {});
    eb.add_probe_target(PLANE);
    job(&mut eb, "G0 Z-5.5\nM2");
    until_state(&mut eb, State::Idle, 10_000);
    job(&mut eb, "G38.4 Z0 F100\nM2");
    assert!(eb.run_until(20_000, |b| b.board.state() == State::Idle
        && b.kernel_drained()));
    assert_eq!(param_um(&eb, 5070), 1000);
    // Clears on the first step above the plane (-3199 steps): the next tick latches there.
    assert_eq!(param_nm(&eb, 5063), -4_998_437);
}

#[test]
fn xy_probing_of_a_boss_finds_its_centre() {
    // A 30 × 20 mm boss centred on (12.5, -7.25), top at Z -2; the probe goes down to Z -5
    // beside it and touches each side, then moves to the centre it computed.
    let boss = ProbeTarget::Boss {
        x: [-2_500_000, 27_500_000],
        y: [-17_250_000, 2_750_000],
        top: -2 * MM,
    };
    let program = "G21 G90\n\
        G0 X-10 Y-7.25\n\
        G0 Z-5\n\
        G38.2 X40 F200\n\
        #1 = #5061\n\
        G0 X-10\n\
        G0 Z0\n\
        G0 X40\n\
        G0 Z-5\n\
        G38.2 X-10 F200\n\
        #2 = #5061\n\
        G0 X40\n\
        G0 Z0\n\
        G0 X[[#1 + #2] / 2] Y-30\n\
        G0 Z-5\n\
        G38.2 Y20 F200\n\
        #3 = #5062\n\
        G0 Y-30\n\
        G0 Z0\n\
        G0 Y20\n\
        G0 Z-5\n\
        G38.2 Y-30 F200\n\
        #4 = #5062\n\
        G0 Y20\n\
        G0 Z0\n\
        G0 X[[#1 + #2] / 2] Y[[#3 + #4] / 2]\n\
        M2";
    let eb = run(&[boss], program);
    assert_eq!(eb.board.state(), State::Idle);
    let (x1, x2, y1, y2) = (
        param_nm(&eb, 1),
        param_nm(&eb, 2),
        param_nm(&eb, 3),
        param_nm(&eb, 4),
    );
    // Each edge within one step (1.5625 µm) of the true one, on the approach side.
    let step = 1_562;
    assert!((-2_500_000 - step..=-2_500_000).contains(&x1), "{x1}");
    assert!((27_500_000..=27_500_000 + step).contains(&x2), "{x2}");
    assert!((-17_250_000 - step..=-17_250_000).contains(&y1), "{y1}");
    assert!((2_750_000..=2_750_000 + step).contains(&y2), "{y2}");
    // The centre: within one step of (12.5, -7.25), where the machine now stands.
    let at = eb.board.machine_position(&eb.isr.kernel.position());
    assert!((at[0] - 12_500_000).abs() <= step, "{at:?}");
    assert!((at[1] - -7_250_000).abs() <= step, "{at:?}");
    assert_eq!(at[2], 0);
}

#[test]
fn a_job_with_two_tools_measures_each_length_with_the_probe_and_cuts_at_the_same_depth() {
    // A touch plate at machine Z -50 (its top is the work's Z0). Tool 1 sticks out 30 mm below
    // the spindle, tool 2 45 mm: each touches the plate with the spindle at -20 and -5 mm.
    // After each tool change the job probes the plate and takes the contact as the tool's length
    // offset (G43.1 Z#5063: with G49 and zero offsets #5063 is the spindle's machine Z), so
    // both cut 1 mm into the work: the spindle goes to -21 mm with tool 1, -6 mm with tool 2.
    let mut eb = board(|_| {});
    eb.capture_events();
    eb.add_probe_target(ProbeTarget::Plane { z: -50 * MM });
    eb.tool_lengths = vec![(1, 30 * MM), (2, 45 * MM)];
    let program = "G21 G90 G49\n\
        T1 M6\n\
        G38.2 Z-90 F100\n\
        G43.1 Z#5063\n\
        G0 Z5\n\
        G1 Z-1 F300\n\
        G0 Z5\n\
        G49\n\
        G53 G0 Z0\n\
        T2 M6\n\
        G38.2 Z-90 F100\n\
        G43.1 Z#5063\n\
        G0 Z5\n\
        G1 Z-1 F300\n\
        G0 Z5\n\
        M2";
    job(&mut eb, program);
    // The lowest spindle Z (steps) while each tool is in the spindle (the probe's overrun at
    // F100 is 5 steps, far above the cut). Each M6 stops the job at rest, spindle off, until
    // the operator presses cycle start.
    let mut lowest = [i64::MAX; 3];
    let mut changes = Vec::new();
    for _ in 0..3 {
        let done = eb.run_until(200_000, |b| {
            let t = b.board.outputs().tool as usize;
            lowest[t] = lowest[t].min(b.isr.kernel.position()[2]);
            matches!(b.board.state(), State::Idle | State::ToolChange) && b.kernel_drained()
        });
        assert!(done, "still {:?}: {:?}", eb.board.state(), events(&mut eb));
        if eb.board.state() == State::Idle {
            break;
        }
        let tool = eb.board.tool_change().unwrap();
        changes.push((tool, eb.board.line(), eb.isr.kernel.position()[2]));
        assert_eq!(
            eb.board.outputs().spindle,
            gantry_machine::canon::Spindle::Off
        );
        eb.run_ms(100);
        assert_eq!(
            eb.board.state(),
            State::ToolChange,
            "waits for the operator"
        );
        set(
            &mut eb,
            gantry_machine::board::inputs::Signal::CycleStart1,
            true,
        );
        eb.run_ms(5);
        set(
            &mut eb,
            gantry_machine::board::inputs::Signal::CycleStart1,
            false,
        );
    }
    // Stopped at line 2 at Z0 for T1, at line 10 at the G53 Z0 for T2.
    assert_eq!(changes, vec![(1, 2, 0), (2, 10, 0)]);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::JobDone {
            line: 16,
            end: JobEnd::Completed
        }]
    );
    // 640 steps per mm: -21 mm and -6 mm exactly.
    assert_eq!(lowest[1], -21 * 640, "tool 1 cut depth (spindle Z, steps)");
    assert_eq!(lowest[2], -6 * 640, "tool 2 cut depth (spindle Z, steps)");
    // The second length stays in force, exactly the contact: -5 mm.
    assert_eq!(eb.board.interpreter().state().tool_offset[2], -5 * MM);
    assert_eq!(
        eb.isr.kernel.position()[2],
        0,
        "ended at Z5 over the work = spindle at 0"
    );
}

#[test]
fn work_z_from_a_touch_plate_with_g10_l20() {
    // The plate's top at machine Z -5, the plate 10 mm thick: after the touch, G10 L20 makes the
    // spot where the machine stopped read Z10, so G54 Z0 (the work top) is 10 mm below it.
    let eb = run(
        &[PLANE],
        "G21 G90\nG38.2 Z-50 F100\nG10 L20 P1 Z10\nG0 Z15\nM2",
    );
    assert_eq!(eb.board.state(), State::Idle);
    // The offset counts from where the machine stands (5 steps of deceleration below the
    // contact), as G10 L20 does: the contact itself is the program's business (#5063).
    let stopped = eb.board.machine_position(&[0, 0, -3205, 0, 0, 0])[2];
    assert_eq!(param_nm(&eb, 5223), stopped - 10 * MM, "G54 Z offset");
    // Z15 = 5 mm above where it stopped: step -3205 + 3200.
    assert_eq!(eb.isr.kernel.position()[2], -5);
}

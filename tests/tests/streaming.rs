//! Whole-system streaming tests: the `gantry` sender against the emulated board over the real
//! protocol. Every job must end exactly where the core's own simulation of the same file ends.

use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use gantry_proto::fault::Faults;
use gantry_proto::MachineState;
use host_sender::link::{Client, Transport};
use host_sender::program::Program;
use host_sender::session::{continue_job, stream_program, BoardAlarm, Flow, StreamReport};
use system_tests::{cam_program, reference, CycleStart, FaultyBoard};

/// Streams `text` to an emulated board that stands for no machine: its M0/M1/M6 stops are
/// answered as they come (`ThroughStops`, an operator pressing cycle start at once).
fn stream_emulated(text: &str) -> (StreamReport, EmulatedBoard) {
    let mut client = Client::connect(EmulatedBoard::new(Setup::default()), 2000).unwrap();
    let program = Program::from_text(text);
    let mut stops = host_sender::session::job::ThroughStops::new();
    let report = stream_program(&mut client, &program, &mut |p| stops.flow(&program, p)).unwrap();
    (report, client.transport)
}

const BRACKET: &str = include_str!("../../examples/bracket.ngc");

#[test]
fn the_example_job_ends_where_the_core_simulation_ends() {
    let (report, board) = stream_emulated(BRACKET);
    assert!(report.completed, "{:?}", report.errors);
    let r = reference(BRACKET, &Setup::default());
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
    // The program ends at X0 Y0 Z10: 10 mm at 3200 steps / 5 mm.
    assert_eq!(&r.steps[..3], &[0, 0, 6400]);
    let status = report.final_status.unwrap();
    assert_eq!(&status.machine_pos[..3], &[0, 0, 10_000_000]);
}

#[test]
fn a_rejected_block_stops_the_job_before_its_motion() {
    let program = "G21 G90\nG1 X1 F600\nG2 X10 Y0 R2\nG1 X5\nM30\n";
    let (report, board) = stream_emulated(program);
    assert!(!report.completed);
    assert_eq!(report.errors.len(), 1);
    assert_eq!(report.errors[0].line, 3);
    // Only line 2 ran: X stands at 1 mm = 640 steps, nothing after the bad block moved.
    assert_eq!(board.isr.kernel.position()[..3], [640, 0, 0]);
}

#[test]
fn a_soft_limit_violation_before_anything_ran_is_error_900_and_nothing_moves() {
    let program = "G21 G90\nG0 X400\nG0 X20\nM30\n";
    let (report, board) = stream_emulated(program);
    assert_eq!(report.errors.len(), 1);
    assert_eq!(
        (report.errors[0].line, report.errors[0].code),
        (2, gantry_machine::board::ERROR_SOFT_LIMIT)
    );
    assert!(report.alarms.is_empty());
    assert_eq!(board.pulses, [0; 6]);
    assert_eq!(report.final_status.unwrap().state, MachineState::Idle);
}

#[test]
fn a_soft_limit_violation_in_a_running_job_stops_it_with_alarm_2_at_that_line() {
    let program = Program::from_text("G21 G90\nG0 X10\nG0 X400\nG0 X20\nM30\n");
    let mut client = Client::connect(EmulatedBoard::new(Setup::default()), 2000).unwrap();
    let report = stream_program(&mut client, &program, &mut |_| Flow::Continue).unwrap();
    assert!(!report.completed);
    assert!(report.errors.is_empty(), "{:?}", report.errors);
    assert_eq!(report.alarms, vec![BoardAlarm { code: 2, line: 3 }]);
    assert_eq!(
        report.alarms[0].describe(&program),
        "line 3: alarm 2 (soft limit): a block would leave the machine travel: the job stopped on its path before it; position kept\n    G0 X400"
    );
    // The interpreter met line 3 in the pass that queued line 2, before its first step: the
    // stop left X at 0 (a program: alarm 2 all the same, as a job had queued motion).
    assert_eq!(client.transport.pulses, [0; 6]);
    let status = report.final_status.unwrap();
    assert_eq!(status.state, MachineState::Alarm { code: 2 });
    assert_eq!(status.machine_pos[0], 0);
}

#[test]
fn subprograms_after_m30_are_served_on_request_and_repeat() {
    // O100 is called 3 times with L3 and once more from O200 (nested); the main program is longer
    // than the board's line buffer, so the jumps happen while the stream is in flight.
    let mut p = String::from("G21 G90 G94\nG0 X0 Y0 Z0\n");
    for i in 0..40 {
        p.push_str(&format!("G1 X{} F3000\n", i % 5));
    }
    p.push_str("M98 P100 L3\nG0 X0\nM98 P200\nG0 Y0\nM30\n");
    p.push_str("O100\nG91 G1 Y1 F3000\nG90\nM99\n");
    p.push_str("O200\nG91 G1 Z-1 F3000\nM98 P100\nG90\nM99\n");
    let (report, board) = stream_emulated(&p);
    assert!(report.completed, "{:?}", report.errors);
    // Four calls of O100 (+1 mm Y each), then G0 Y0; one O200 (-1 mm Z).
    assert_eq!(board.isr.kernel.position()[..3], [0, 0, -640]);
    let r = reference(&p, &Setup::default());
    assert_eq!(board.pulses, r.pulses);
    assert_eq!(board.isr.kernel.position(), r.steps);
    // 3 calls + 3 returns/repeats for L3, 2 for O200, 2 for the nested O100.
    assert!(report.jumps_served >= 7, "{}", report.jumps_served);
}

#[test]
fn one_percent_dropped_corrupted_and_duplicated_bytes_lose_nothing() {
    let program = cam_program(3_000);
    let setup = Setup::default();
    let faults = Faults::uniform(10_000);
    let mut client = Client::connect(FaultyBoard::new(setup.clone(), 7, faults), 5000).unwrap();
    let report = stream_program(&mut client, &Program::from_text(&program), &mut |_| {
        Flow::Continue
    })
    .unwrap();
    assert!(report.completed, "{:?} {:?}", report.errors, report.alarms);
    let r = reference(&program, &setup);
    let board = &client.transport.board;
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
    let stats = client.transport.to_board.stats();
    assert!(
        stats.dropped > 100 && stats.corrupted > 100 && stats.duplicated > 100,
        "{stats:?}"
    );
}

#[test]
fn a_100k_line_cam_program_streams_without_loss() {
    let program = cam_program(100_000);
    let (report, board) = stream_emulated(&program);
    assert!(report.completed, "{:?}", report.errors);
    assert_eq!(report.lines_sent, 100_007);
    assert_eq!(board.starved.gaps, 0, "the planner starved the kernel");
    let r = reference(&program, &Setup::default());
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
}

#[test]
fn a_thousand_blocks_per_second_never_starve_the_planner() {
    // 0.1 mm segments at 6000 mm/min = 1000 blocks/s; axes fast enough not to limit the feed.
    let mut setup = Setup::default();
    for a in setup.axes.iter_mut() {
        a.max_rate = 10_000_000_000;
        a.accel = 2_000_000_000;
    }
    // The Z ripple deflects the path ~2° per block; the default feed shift (largest speed jump at
    // a junction, 60 mm/min) would cap the feed near 1500 mm/min there.
    setup.path.feed_shift = 600_000_000;
    let program = system_tests::cam_program_at(20_000, 6000);
    let mut client = Client::connect(EmulatedBoard::new(setup.clone()), 2000).unwrap();
    let report = stream_program(&mut client, &Program::from_text(&program), &mut |_| {
        Flow::Continue
    })
    .unwrap();
    assert!(report.completed, "{:?}", report.errors);
    let board = &client.transport;
    assert_eq!(board.starved.gaps, 0, "the planner starved the kernel");
    let r = reference(&program, &setup);
    assert_eq!(board.isr.kernel.position(), r.steps);
    // The streamed job takes as long as the core's own simulation (the link never held motion
    // up). 2000 mm of path at 100 mm/s is 20 s, plus 40 row reversals at 2000 mm/s² (about
    // 0.05 s each) and the approach: 22.3 s means the 1000 blocks/s rate was really held.
    let seconds = report.elapsed_ms as f64 / 1000.0;
    assert!(
        (seconds - r.seconds).abs() < 0.1,
        "{seconds} s, reference {} s",
        r.seconds
    );
    assert!(r.seconds < 22.5, "reference {} s", r.seconds);
}

#[test]
fn a_new_host_takes_over_a_job_after_the_cable_was_pulled() {
    let program = cam_program(4_000);
    let setup = Setup::default();
    let text = Program::from_text(&program);
    let mut client =
        Client::connect(FaultyBoard::new(setup.clone(), 3, Faults::NONE), 2000).unwrap();
    // Stream until the board runs line 1500, then the cable goes and this host process is gone.
    let first = stream_program(&mut client, &text, &mut |p| {
        if p.line >= 1500 {
            Flow::Detach
        } else {
            Flow::Continue
        }
    })
    .unwrap();
    assert!(!first.completed);
    let mut transport = client.into_transport();
    transport.connected = false;
    transport.to_board.clear();
    transport.to_host.clear();
    transport.wait(3000);
    // The board noticed the silence and held the job on its path.
    let held_at = transport.board.isr.kernel.position();
    assert_eq!(
        transport.board.board.state(),
        gantry_machine::board::State::Hold
    );
    transport.wait(500);
    assert_eq!(
        transport.board.isr.kernel.position(),
        held_at,
        "held means no motion"
    );
    // A new host connects and is asked for exactly the missing lines; the job stays held until
    // the operator presses cycle start (here 2 s later): the take-over resumes nothing.
    transport.connected = true;
    let mut client = Client::connect(transport, 2000).unwrap();
    let mut operator = CycleStart::after(2_000);
    // (A report sent before the pull may still arrive first.)
    let mut seen_hold = false;
    let report = continue_job(&mut client, &text, &mut |p| {
        if let (None, Some(s)) = (operator.pressed_at, &p.status) {
            seen_hold |= matches!(s.state, MachineState::Hold { .. });
            assert!(
                !seen_hold || matches!(s.state, MachineState::Hold { stopped: true }),
                "held until the operator resumes: {:?}",
                s.state
            );
        }
        operator.flow(p)
    })
    .unwrap();
    assert!(operator.held_ms >= 2_000, "{}", operator.held_ms);
    assert!(report.completed, "{:?}", report.errors);
    assert!(report.jumps_served >= 1);
    let r = reference(&program, &setup);
    let board = &client.transport.board;
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
}

#[test]
fn after_a_short_cable_pull_the_same_host_leaves_the_job_held_until_the_operator_resumes() {
    let program = cam_program(4_000);
    let setup = Setup::default();
    let text = Program::from_text(&program);
    let mut transport = FaultyBoard::new(setup.clone(), 5, Faults::NONE);
    // The cable is out from 8 s to 10 s of link time, mid-job: long enough for the board to hold.
    transport.outage = Some((8_000, 10_000));
    let mut client = Client::connect(transport, 2000).unwrap();
    let mut states = Vec::new();
    // The operator presses cycle start 3 s after the job stands held (the sender used to send a
    // resume of its own as soon as the link was back: the machine cut on by itself).
    let mut operator = CycleStart::after(3_000);
    let mut gap_reported = 0;
    let report = stream_program(&mut client, &text, &mut |p| {
        if let Some(s) = &p.status {
            states.push((p.elapsed_ms, s.state));
        }
        gap_reported = gap_reported.max(p.link_gap_ms);
        operator.flow(p)
    })
    .unwrap();
    // Held from the host timeout to the operator's press, which came 3 s after the link was
    // back and the sender saw the hold: no resume came from the host meanwhile.
    let pressed = operator
        .pressed_at
        .expect("the operator pressed cycle start");
    assert!(pressed >= 10_000 + 3_000, "pressed at {pressed}");
    let held = states
        .iter()
        .position(|(t, s)| *t > 8_000 && matches!(s, MachineState::Hold { .. }))
        .unwrap();
    let resumed = states[held..]
        .iter()
        .find(|(_, s)| *s == MachineState::Run)
        .map(|(t, _)| *t)
        .unwrap();
    assert!(
        resumed >= pressed,
        "running again at {resumed}, pressed at {pressed}"
    );
    // The sender saw the gap and can say why the job is held.
    assert!((1_000..=2_500).contains(&gap_reported), "{gap_reported}");
    assert!(report.completed, "{:?}", report.errors);
    let board = &client.transport.board;
    assert!(board.board.state() == gantry_machine::board::State::Idle);
    let r = reference(&program, &setup);
    assert_eq!(board.isr.kernel.position(), r.steps);
    assert_eq!(board.pulses, r.pulses);
    // The board really held during the outage: from the host timeout (1 s of silence after the
    // last frame, which came a little before the pull) to the cable's return.
    let held = client.transport.held_in_outage_ms;
    assert!(
        (1000..=1100).contains(&held),
        "held {held} ms of the outage"
    );
    // And the job took longer than an uninterrupted one.
    assert!(
        report.elapsed_ms as f64 / 1000.0 > r.seconds + 0.9,
        "{} ms",
        report.elapsed_ms
    );
}

#[test]
fn running_from_a_line_rebuilds_the_state_and_ends_like_a_full_run() {
    use host_sender::resume::resume_preamble;
    use host_sender::session::stream_from_line;
    let text = "G21 G90 G17\nG10 L2 P2 X5 Y5\nG55\nG92 X1\nT1 M6\nS1000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F300\nG1 X10 F900\nX20 Y3\nG91 X1\nG90 G0 Z5\nM30\n";
    let setup = Setup::default();
    let (full, full_board) = stream_emulated(text);
    assert!(full.completed, "{:?}", full.errors);
    for from in [9, 10, 11] {
        let program = Program::from_text(text);
        let mut client = Client::connect(EmulatedBoard::new(setup.clone()), 2000).unwrap();
        let pre = resume_preamble(&program, text, from, &setup, &[0; 6]).unwrap();
        let mut stops = host_sender::session::job::ThroughStops::new();
        let report = stream_from_line(&mut client, &program, from, pre, &mut |p| {
            stops.flow(&program, p)
        })
        .unwrap();
        assert!(report.completed, "from {from}: {:?}", report.errors);
        assert_eq!(
            client.transport.isr.kernel.position(),
            full_board.isr.kernel.position(),
            "from line {from}"
        );
        // The work offsets were rebuilt too: same work position as the full run.
        assert_eq!(
            report.final_status.unwrap().work_pos,
            full.final_status.clone().unwrap().work_pos,
            "from line {from}"
        );
    }
}

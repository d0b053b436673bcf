//! Alarms 2 (soft limit in a running job), 3 (reset during motion) and 20 (host lost) on the
//! emulated board, on its virtual clock: exact states, alarm codes and lines, positions, output
//! levels and times.

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::power_up::{PowerUp, ResetCause, MARKER_IDLE, MARKER_MOVING};
use gantry_machine::board::{AlarmCode, OutputLevels, State};
use gantry_machine::board::{BoardEvent, JobEnd, ERROR_SOFT_LIMIT};
use gantry_machine::motion::pipeline::MotionState;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::continue_job;

// ---- alarm 2: a block of a running job would leave the travel ----

/// M3, M8, 200 one-millimetre feeds along X at 1200 mm/min (line 4-203), then line 204.
fn long_job(line_204: &str) -> String {
    let mut p = String::from("G90 G21\nM3 S12000\nM8\n");
    for i in 1..=200 {
        p.push_str(&format!("G1 X{i} F1200\n"));
    }
    p.push_str(line_204);
    p.push_str("\nG0 X0\nM30\n");
    p
}

/// X homed on a min switch at -2 mm (retract 2 mm: home is the switch + 2 mm = physical 0).
fn homed_x_board() -> EmulatedBoard {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b001;
        s.homing.axes[0].priority = 1;
    });
    eb.add_switch(0, false, -2 * MM);
    assert!(eb.board.home(0b001));
    until_state(&mut eb, State::Idle, 20_000);
    assert_eq!(eb.board.homed(), 0b001);
    eb.capture_events();
    events(&mut eb);
    eb
}

#[test]
fn a_block_beyond_the_travel_in_a_running_job_stops_it_on_the_path_with_alarm_2() {
    let mut eb = homed_x_board();
    eb.output_changes = Some(Vec::new());
    job(&mut eb, &long_job("G1 X400"));
    // The interpreter meets line 204 while line 77 runs (the planner holds the 128 blocks in
    // between): the stop starts at once. (With the firmware's 15-segment queue, shared since the
    // main loop is the core's, prep runs 14 ms further ahead than with the emulator's old 8.)
    assert!(eb.run_until(20_000, |b| b.board.motion().state() == MotionState::Holding));
    // The board's clock counts from power-up, homing included: the two-speed homing's fast seek,
    // pull-off and slow locate (docs/settings.md) take 333 ms more than the single slow seek did,
    // so the job runs on another phase of the millisecond grid: the pass that sees line 204 finds
    // the kernel 8 steps earlier in line 77 (the end of the stop, below, is the same).
    let stop_ms = eb.now_ms() - 1;
    assert_eq!(stop_ms, 6207);
    assert_eq!(eb.isr.kernel.position()[0], 46_371);
    assert_eq!(eb.board.line(), 77);
    // Spindle and coolant run until the machine is at rest (a feed hold's rule) …
    assert!(eb.board.output_levels().spindle_enable && eb.board.output_levels().flood);
    until_state(&mut eb, State::Alarm, 5_000);
    let x = eb.isr.kernel.position()[0];
    // The stop takes back the queued segments of the block being prepared (line 77); those of
    // line 76 still queued run first (a stop only rewinds into the block in progress), so the
    // ramp (1 mm from 20 mm/s) starts at X 73 and ends exactly on the end of line 77.
    assert_eq!(x, 47_360, "74.00 mm: the end of line 77 (G1 X74)");
    // … then the program-stop sequence, alarm 2 naming line 204, the job ended at line 77.
    assert_eq!(eb.board.alarm(), Some(AlarmCode::SoftLimit));
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    // Spindle and flood ran through the last step of the ramp and went off in the first
    // main-loop pass that found the kernel drained (the pass at that very count runs first).
    let changes = eb.output_changes.take().unwrap();
    let (off_at, off) = changes[changes.len() - 1];
    assert_eq!(off, OutputLevels::SAFE);
    assert!(changes[changes.len() - 2].1.spindle_enable && changes[changes.len() - 2].1.flood);
    assert!(eb.last_step_at < eb.kernel_idle_at);
    assert_eq!(
        off_at,
        (eb.kernel_idle_at / COUNTS_PER_MS + 1) * COUNTS_PER_MS
    );
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Alarm {
                code: AlarmCode::SoftLimit,
                line: 204
            },
            BoardEvent::JobDone {
                line: 77,
                end: JobEnd::Alarm
            }
        ]
    );
    assert_eq!(eb.board.resume_line(), 77);
    // Position kept: still homed, the board's idea of X is the kernel's.
    assert_eq!(eb.board.homed(), 0b001);
    assert_eq!(eb.board.motion().queued_position()[0], 74_000_000);
    eb.run_ms(1000);
    assert_eq!(eb.isr.kernel.position()[0], x, "nothing moves in the alarm");
    assert!(!eb.board.start_job());
    assert!(!eb.board.jog(0, 600_000, MM as u64));
    // Unlock clears it; the machine goes on from where it stands.
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
    job(&mut eb, "G90 G21\nG0 X0\nM30\n");
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 0);

    // The same job with a legal line 204, feed-held at that very millisecond, makes a 1 mm
    // ramp from 20 mm/s from where the kernel stood (X 72.43): the alarm stop is a feed
    // hold's deceleration on the path, never an abrupt stop. The hold lands between two passes,
    // so the next pass rewinds into every queued segment; the alarm is raised by the interpreter
    // inside a pass whose top-up (machine/src/device/main_loop.rs step 3) had already handed out
    // line 77's segments, and a stop rewinds only into the block in progress: its ramp starts
    // at X 73 and ends further on, at the end of line 77.
    let mut twin = homed_x_board();
    job(&mut twin, &long_job("G1 X200"));
    assert!(twin.run_until(20_000, |b| b.now_ms() == stop_ms));
    assert_eq!(twin.isr.kernel.position()[0], 46_358);
    twin.board.feed_hold();
    assert!(twin.run_until(5_000, |b| b.board.motion().state() == MotionState::Held));
    twin.run_ms(200);
    assert_eq!(twin.isr.kernel.position()[0], 47_019);
    assert!(twin.isr.kernel.position()[0] < x);
}

#[test]
fn before_the_job_queued_anything_a_block_beyond_the_travel_is_error_900_and_nothing_moves() {
    // An MDI command (`gantry mdi "G0 X400"`): nothing ran, nothing to stop.
    let mut eb = board(|_| {});
    eb.capture_events();
    job(&mut eb, "G90 G21\nG0 X400\n");
    until_state(&mut eb, State::Idle, 1_000);
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Error {
                line: 2,
                code: ERROR_SOFT_LIMIT,
                column: 0
            },
            BoardEvent::JobDone {
                line: 0,
                end: JobEnd::Failed
            }
        ]
    );
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(eb.pulses, [0; 6]);
    // A jog beyond the travel is refused the same way (error 900, no motion).
    assert!(!eb.board.jog(0, 600_000, 301 * MM as u64));
    eb.run_ms(5);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::Error {
            line: 0,
            code: ERROR_SOFT_LIMIT,
            column: 0
        }]
    );
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(eb.pulses, [0; 6]);
}

// ---- alarm 3: the board reset while the steppers were moving ----

/// Runs a 50 mm feed along X for one second, so the kernel is mid-move.
fn moving(eb: &mut EmulatedBoard) {
    job(eb, "G90 G21\nM3 S12000\nG1 X50 F1200\nM30\n");
    eb.run_ms(1000);
    assert!(eb.isr.kernel.is_busy());
    assert_eq!(eb.motion_marker, MARKER_MOVING);
}

#[test]
fn a_watchdog_reset_during_motion_powers_up_in_alarm_3_and_unlock_clears_it_without_homing() {
    let mut eb = board(|_| {});
    moving(&mut eb);
    let here = eb.physical();
    assert_eq!(here[0], 12_184, "19.04 mm along when the reset hits");
    assert_eq!(eb.reset(ResetCause::Watchdog), PowerUp::MotionInterrupted);
    // The machine stands where the reset stopped it; the new kernel counts from 0.
    assert_eq!(eb.physical(), here);
    assert_eq!(eb.isr.kernel.position(), [0; 6]);
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ResetDuringMotion));
    assert_eq!(eb.board.homed(), 0);
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    // Motion is refused until unlock.
    assert!(!eb.board.start_job());
    assert!(!eb.board.jog(0, 600_000, MM as u64));
    eb.run_ms(100);
    assert_eq!(eb.physical(), here);
    // Until the position is re-established the marker stays set: another reset (say the
    // operator presses reset now) powers up in alarm 3 again.
    assert_eq!(eb.motion_marker, MARKER_MOVING);
    assert_eq!(eb.reset(ResetCause::Pin), PowerUp::MotionInterrupted);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ResetDuringMotion));
    // No homing set up: unlock accepts the position as it is.
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(eb.board.alarm(), None);
    assert!(eb.board.jog(0, 600_000, MM as u64));
    assert!(!eb.board.position_lost());
    until_state(&mut eb, State::Idle, 5_000);
    assert_eq!(eb.physical()[0], here[0] + STEPS_PER_MM);
    eb.run_ms(2);
    assert_eq!(eb.motion_marker, MARKER_IDLE);
}

#[test]
fn with_homing_set_up_a_reset_during_motion_requires_homing() {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b001;
        s.homing.axes[0].priority = 1;
    });
    eb.add_switch(0, false, -2 * MM);
    assert!(eb.board.home(0b001));
    until_state(&mut eb, State::Idle, 20_000);
    moving(&mut eb);
    let here = eb.physical()[0];
    assert_eq!(eb.reset(ResetCause::Pin), PowerUp::MotionInterrupted);
    eb.capture_events();
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ResetDuringMotion));
    assert_eq!(eb.board.homed(), 0);
    // Unlock is not enough: the board asks for homing (alarm 11) and still refuses motion.
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingRequired));
    assert!(!eb.board.start_job());
    eb.run_ms(2);
    assert_eq!(
        events(&mut eb),
        vec![BoardEvent::Alarm {
            code: AlarmCode::HomingRequired,
            line: 0
        }]
    );
    assert_eq!(eb.physical()[0], here);
    // Homing finds the switch again from wherever the machine stood.
    assert!(eb.board.home(0));
    until_state(&mut eb, State::Idle, 60_000);
    assert_eq!(eb.board.homed(), 0b001);
    assert_eq!(eb.physical()[0], 0, "switch at -2 mm + 2 mm retract");
    assert!(!eb.board.position_lost());
    eb.run_ms(2);
    assert_eq!(eb.motion_marker, MARKER_IDLE);
    assert!(eb.board.start_job());
}

#[test]
fn a_reset_at_rest_or_a_power_on_reset_starts_clean() {
    // At rest: the marker says idle.
    let mut eb = board(|_| {});
    job(&mut eb, "G90 G21\nG1 X5 F1200\nM30\n");
    until_state(&mut eb, State::Idle, 5_000);
    eb.run_ms(2);
    assert_eq!(eb.motion_marker, MARKER_IDLE);
    assert_eq!(eb.reset(ResetCause::Watchdog), PowerUp::Clean);
    assert_eq!(eb.board.state(), State::Idle);
    // Power-on in the middle of a move (the supply was cut): RAM is undefined, nothing is
    // claimed; an ordinary power-up.
    moving(&mut eb);
    assert_eq!(eb.reset(ResetCause::PowerOn), PowerUp::Clean);
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(eb.board.alarm(), None);
    // A brown-out keeps RAM: it counts.
    moving(&mut eb);
    assert_eq!(eb.reset(ResetCause::BrownOut), PowerUp::MotionInterrupted);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::ResetDuringMotion));
}

// ---- alarm 20: the host stayed away while the job was held ----

/// 250 mm at 300 mm/min (50 s) with spindle and flood on.
const LONG_FEED: &str = "G21 G90\nM3 S12000\nM8\nG1 X250 F300\nM30\n";

#[test]
fn a_job_held_by_host_loss_ends_with_alarm_20_after_host_lost_stop_s() {
    let (mut eb, gone) = host_vanishes(|_| {}, LONG_FEED, 4);
    assert_eq!(eb.board.setup().link.host_lost_stop_s, 60);
    // More than HOST_TIMEOUT_MS (1 s) of silence: the link holds the job on its path (spindle
    // and coolant run while it decelerates, then go off at rest: docs/controller.md "Host lost").
    assert!(eb.run_until(5_000, |b| b.board.state() == State::Hold));
    let held = eb.now_ms() - 1;
    assert_eq!(held - gone, 1_001);
    eb.capture_events();
    // Decelerated to a stop on the path within 200 ms (5 mm/s at 200 mm/s²: 25 ms).
    eb.run_ms(200);
    assert_eq!(eb.board.motion().state(), MotionState::Held);
    let at = eb.isr.kernel.position();
    // Until the 60 s are up nothing changes.
    assert!(eb.run_until(70_000, |b| b.now_ms() == held + 60_000));
    assert_eq!(eb.board.state(), State::Hold);
    assert!(!eb.board.output_levels().spindle_enable && !eb.board.output_levels().flood);
    assert!(events(&mut eb).is_empty());
    // Then the job ends (the main-loop pass at 60 000 ms drops it, the next one finds it at
    // rest): spindle and coolant off, alarm 20 at the held line, position kept.
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Run, "stopping");
    eb.run_ms(1);
    assert_eq!(eb.board.state(), State::Alarm);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HostLost));
    assert_eq!(eb.board.output_levels(), OutputLevels::SAFE);
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Alarm {
                code: AlarmCode::HostLost,
                line: 4
            },
            BoardEvent::JobDone {
                line: 4,
                end: JobEnd::Alarm
            }
        ]
    );
    assert_eq!(eb.board.resume_line(), 4);
    assert_eq!(eb.isr.kernel.position(), at);
    // The hold ramps down from the kernel's running segment (the queued ones were taken back).
    assert_eq!(at[0], 9_288, "14.51 mm along the 250 mm feed");
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
}

#[test]
fn a_host_back_within_the_limit_continues_the_job() {
    let (mut eb, gone) = host_vanishes(|_| {}, LONG_FEED, 4);
    assert!(eb.run_until(5_000, |b| b.board.state() == State::Hold));
    let held = eb.now_ms() - 1;
    assert_eq!(held - gone, 1_001);
    // A new host process attaches after 59 s of hold and takes the job over; the operator
    // resumes it at once (the take-over itself releases no hold).
    assert!(eb.run_until(70_000, |b| b.now_ms() == held + 59_000));
    let mut client = Client::connect(eb, 2000).unwrap();
    let program = Program::from_text(LONG_FEED);
    let mut operator = system_tests::CycleStart::after(0);
    let report = continue_job(&mut client, &program, &mut |p| operator.flow(p)).unwrap();
    assert!(operator.pressed_at.is_some());
    assert!(report.completed, "{:?} {:?}", report.errors, report.alarms);
    let eb = client.into_transport();
    assert_eq!(eb.board.state(), State::Idle);
    assert_eq!(eb.isr.kernel.position()[0], 250 * STEPS_PER_MM);
    assert!(eb.now_ms() > held + 60_000, "ran on past the limit");
}

#[test]
fn with_host_lost_stop_s_0_a_held_job_waits_for_the_host_forever() {
    let (mut eb, _) = host_vanishes(|s| s.link.host_lost_stop_s = 0, LONG_FEED, 4);
    assert!(eb.run_until(5_000, |b| b.board.state() == State::Hold));
    eb.run_ms(600_000);
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.board.alarm(), None);
    // At rest with the host gone: spindle and coolant off while it waits.
    assert!(!eb.board.output_levels().spindle_enable && !eb.board.output_levels().flood);
}

#[test]
fn an_m0_stop_is_not_ended_by_host_loss() {
    // At M0 spindle and coolant are already off; the job waits for cycle start as programmed.
    let (mut eb, _) = host_vanishes(
        |_| {},
        "G21 G90\nM3 S12000\nG1 X1 F600\nM0\nG1 X2\nM30\n",
        3,
    );
    assert!(eb.run_until(10_000, |b| b.board.state() == State::Hold));
    eb.run_ms(120_000);
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.board.alarm(), None);
    eb.board.cycle_start();
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(eb.isr.kernel.position()[0], 2 * STEPS_PER_MM);
}

// ---- the job's owner lost behind a server that stays (`HostMsg::OwnerLost`, protocol 5.1) ----

/// Streams [`LONG_FEED`] until line 4 runs at 2 s link time, then says the job's owner is lost
/// on the same link, which stays alive (as `gantry serve` does); returns the connected client.
fn owner_lost_on_a_live_link(host_lost_stop_s: u16) -> Client<EmulatedBoard> {
    let mut client =
        Client::connect(board(|s| s.link.host_lost_stop_s = host_lost_stop_s), 2000).unwrap();
    let program = Program::from_text(LONG_FEED);
    let report = host_sender::session::stream_program(&mut client, &program, &mut |p| {
        if p.line >= 4 && p.elapsed_ms >= 2000 {
            host_sender::session::Flow::Detach
        } else {
            host_sender::session::Flow::Continue
        }
    })
    .unwrap();
    assert!(report.alarms.is_empty());
    assert_eq!(client.transport.board.state(), State::Run);
    assert!(client.transport.board.output_levels().spindle_enable);
    client.send(gantry_proto::HostMsg::OwnerLost).unwrap();
    client
}

/// Pumps the live link for `ms` of link time (its keepalives keep the host attached).
fn keep_link(client: &mut Client<EmulatedBoard>, ms: u32) {
    for _ in 0..ms / 10 {
        client.pump(10).unwrap();
        while client.recv().is_some() {}
    }
}

#[test]
fn an_owner_lost_behind_a_live_link_is_a_lost_host_and_ends_with_alarm_20() {
    let mut client = owner_lost_on_a_live_link(3);
    // Held on its path, spindle and coolant off once at rest, exactly as for a dropped DTR.
    keep_link(&mut client, 300);
    let eb = &client.transport;
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.board.motion().state(), MotionState::Held);
    assert!(!eb.board.output_levels().spindle_enable && !eb.board.output_levels().flood);
    // The server reconnecting (a new hello, as serve does to drop the lost owner's lines) is
    // still no owner: the alarm-20 count goes on and ends the job after host_lost_stop_s.
    client.reconnect();
    keep_link(&mut client, 2_000);
    assert_eq!(client.transport.board.state(), State::Hold);
    keep_link(&mut client, 1_500);
    assert_eq!(client.transport.board.alarm(), Some(AlarmCode::HostLost));
}

#[test]
fn a_take_over_after_an_owner_lost_stops_the_count_and_only_the_operator_resumes() {
    let mut client = owner_lost_on_a_live_link(3);
    keep_link(&mut client, 1_000);
    let held_at = client.transport.isr.kernel.position();
    client.send(gantry_proto::HostMsg::TakeOver).unwrap();
    // Twice the limit: no alarm 20, and still held (the take-over resumes nothing).
    keep_link(&mut client, 6_000);
    let eb = &client.transport;
    assert_eq!(eb.board.state(), State::Hold);
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(eb.isr.kernel.position(), held_at);
    // The operator's resume: spindle and flood come back, the job goes on.
    client.send(gantry_proto::HostMsg::Resume).unwrap();
    keep_link(&mut client, 100);
    let eb = &client.transport;
    assert_eq!(eb.board.state(), State::Run);
    assert!(eb.board.output_levels().spindle_enable && eb.board.output_levels().flood);
}

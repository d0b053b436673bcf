//! Homing (limit-switch seek, docs/controller.md "Homing") on the emulated board: priority order one axis at a
//! time, a fast seek, a pull-off and a slow locate at a constant rate, retract at rapid to the
//! exact step, set home, command lists, and the failure alarms. Every switch stop counts in
//! `limit_stops`: the fast seek's and the locate's are the cycle's first two.

mod controller_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::inputs::{LIMIT_MAX_BIT, LIMIT_MIN_BIT};
use gantry_machine::board::BoardEvent;
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::motion::pipeline::MotionState;
use gantry_machine::setup::ListCommand;

/// X seeks its min switch (physical -3 mm) second, Z its max switch (physical +7 mm) first.
fn machine(edit: impl FnOnce(&mut gantry_machine::setup::Setup)) -> EmulatedBoard {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b001;
        s.inputs.limit_max = 0b100;
        s.homing.axes[0].priority = 2;
        s.homing.axes[0].retract = 2 * MM;
        s.homing.axes[0].home_position = -10 * MM;
        s.homing.axes[2].priority = 1;
        s.homing.axes[2].seek_low = false;
        s.homing.axes[2].retract = MM;
        s.homing.axes[2].home_position = 0;
        edit(s);
    });
    eb.add_switch(0, false, -3 * MM);
    eb.add_switch(2, true, 7 * MM);
    eb
}

#[test]
fn axes_home_in_priority_order_and_the_retract_lands_on_the_exact_step() {
    let mut eb = machine(|_| {});
    assert!(eb.board.home(0));
    assert_eq!(eb.board.state(), State::Homing);
    // Z goes first; X does not move until Z is homed.
    eb.run_until(30_000, |b| b.board.homed() & 0b100 != 0);
    assert_eq!(eb.physical()[0], 0);
    assert_eq!(eb.board.state(), State::Homing);
    until_state(&mut eb, State::Idle, 30_000);
    assert_eq!(eb.board.homed(), 0b101);
    // Physical: on the switch step, then exactly the retract away from it.
    let p = eb.physical();
    assert_eq!(p[0], -3 * STEPS_PER_MM + 2 * STEPS_PER_MM);
    assert_eq!(p[2], 7 * STEPS_PER_MM - STEPS_PER_MM);
    // Set home: the machine position after the retract is the configured home position.
    assert_eq!(eb.isr.kernel.position()[0], -10 * STEPS_PER_MM);
    assert_eq!(eb.isr.kernel.position()[2], 0);
    let m = eb.board.machine_position(&eb.isr.kernel.position());
    assert_eq!((m[0], m[2]), (-10 * MM, 0));
    assert_eq!(eb.board.motion().queued_position(), m);
    // Soft limits apply again in the new coordinates: X travel is ±300 mm.
    job(&mut eb, "G90 G21\nG0 X-305\nM30\n");
    until_state(&mut eb, State::Idle, 1_000);
    assert_eq!(eb.isr.kernel.position()[0], -10 * STEPS_PER_MM);
}

#[test]
fn the_locate_runs_at_a_constant_rate() {
    // The fast seek (2000 mm/min) meets the switch 3 mm away and the pull-off at rapid comes
    // back 2 mm, both within the first 250 ms; the locate then runs at its rate = the start
    // speed (60 mm/min = 640 steps/s), no ramp, for the 2 mm (2 s) back to the switch.
    let mut eb = machine(|s| s.homing.axes[2].priority = 0);
    let mut counts = Vec::new();
    eb.board.home(0b001);
    eb.run_until(1_000, |b| b.limit_stops == 1);
    // The first window holds the start: the interrupt's idle poll and its two ticks ahead of
    // the pins (up to 2 ms and two periods, one step of 160 here).
    eb.run_ms(250);
    for _ in 0..6 {
        let before = eb.pulses[0];
        eb.run_ms(250);
        counts.push(eb.pulses[0] - before);
    }
    assert!(counts.iter().all(|&c| c == 160), "{counts:?}");
}

#[test]
fn a_missing_switch_alarms_after_the_travel() {
    let mut eb = machine(|s| s.homing.axes[2].priority = 0);
    eb.switches.clear();
    let mut s = eb.board.setup().clone();
    s.axes[0].travel_min = -5 * MM;
    s.axes[0].travel_max = 5 * MM;
    s.homing.axes[0].seek_rate = 600 * MM;
    assert!(eb.board.set_setup(s));
    assert!(eb.board.home(0b001));
    until_state(&mut eb, State::Alarm, 30_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingSwitchNotFound));
    assert_eq!(eb.board.homed(), 0);
    // It gave up after the travel span plus the retract: 12 mm.
    assert_eq!(eb.physical()[0], -12 * STEPS_PER_MM);
}

#[test]
fn a_switch_that_stays_active_fails_the_pull_off() {
    let mut eb = machine(|s| s.homing.axes[2].priority = 0);
    eb.switches.clear();
    eb.set_pin(LIMIT_MIN_BIT, true);
    eb.run_ms(5);
    assert!(eb.board.home(0b001));
    until_state(&mut eb, State::Alarm, 30_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingPullOffFailed));
    // The seek stopped at once (the switch was already active), the retract moved 2 mm.
    assert_eq!(eb.physical()[0], 2 * STEPS_PER_MM);
}

#[test]
fn command_lists_run_before_seek_before_retract_and_after_retract() {
    let mut eb = machine(|s| {
        s.homing.axes[2].priority = 0;
        s.homing.before_seek.push(ListCommand::Set(1)).unwrap();
        s.homing
            .before_retract
            .push(ListCommand::DwellMs(300))
            .unwrap();
        s.homing.before_retract.push(ListCommand::Set(3)).unwrap();
        s.homing.after_retract.push(ListCommand::Clear(1)).unwrap();
    });
    assert!(eb.board.home(0));
    eb.run_ms(100);
    assert_eq!(eb.board.output_levels().user, 0b0010);
    // The locate ends on the switch; the dwell holds the retract back for 300 ms.
    eb.run_until(30_000, |b| b.limit_stops == 2);
    let on_switch = eb.physical()[0];
    assert_eq!(on_switch, -3 * STEPS_PER_MM);
    eb.run_ms(250);
    assert_eq!(eb.physical()[0], on_switch);
    assert_eq!(eb.board.output_levels().user, 0b0010);
    until_state(&mut eb, State::Idle, 30_000);
    assert_eq!(eb.board.output_levels().user, 0b1000);
}

#[test]
fn abort_during_homing_alarms_at_rest_and_leaves_the_axis_unhomed() {
    // Output 1 stands for the drivers of a squared axis, enabled by the cycle's first list.
    let mut eb = machine(|s| s.homing.before_seek.push(ListCommand::Set(1)).unwrap());
    assert!(eb.board.home(0));
    eb.run_ms(500);
    eb.board.abort();
    // The seek decelerates with its drivers still enabled; alarm 6 comes at rest.
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(eb.board.state(), State::Homing);
    while eb.board.state() == State::Homing {
        assert_eq!(eb.board.output_levels().user, 0b0010);
        eb.run_ms(1);
        assert!(eb.now_ms() < 10_000, "homing abort never came to rest");
    }
    assert!(eb.kernel_drained());
    let stopped = eb.physical()[0];
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HomingAborted));
    assert_eq!(eb.board.output_levels().user, 0);
    until_at_rest(&mut eb, 5_000);
    assert_eq!(eb.physical()[0], stopped);
    assert_eq!(eb.board.homed(), 0);
    eb.board.unlock();
    assert_eq!(eb.board.state(), State::Idle);
    // Soft limits are back once at rest.
    assert!(eb.board.motion().config().soft_limits);
    let _ = LIMIT_MAX_BIT;
}

/// Y is two motors on one step channel, enabled by outputs 0 and 1 (which also gate their
/// switches); the gantry is racked: motor 0 meets its switch at -2 mm, motor 1 at -3 mm. The
/// squaring lists of docs/settings.md, `before_retract` led by `disable_limit_report` when `quiet`.
fn squaring(quiet: bool, edit: impl FnOnce(&mut gantry_machine::setup::Setup)) -> EmulatedBoard {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b010;
        s.homing.axes[1].priority = 1;
        s.homing.axes[1].retract = MM;
        let c = |t: &str| match t {
            "seek" => ListCommand::Seek,
            "set0" => ListCommand::Set(0),
            "set1" => ListCommand::Set(1),
            "clear0" => ListCommand::Clear(0),
            "clear1" => ListCommand::Clear(1),
            "settle" => ListCommand::DwellMs(100),
            _ => ListCommand::DisableLimitReport,
        };
        for t in ["set0", "set1"] {
            s.homing.before_seek.push(c(t)).unwrap();
        }
        // Seed sequence: each side alone onto its own switch, then both enabled again.
        if quiet {
            s.homing.before_retract.push(c("report")).unwrap();
        }
        for t in ["clear1", "seek", "set1", "clear0", "seek", "set0", "settle"] {
            s.homing.before_retract.push(c(t)).unwrap();
        }
        edit(s);
    });
    eb.add_gang(1, false, [0, 1], [-2 * MM, -3 * MM]);
    eb.capture_events();
    eb
}

#[test]
fn squaring_leaves_both_motors_on_their_switches_then_retracts() {
    let mut eb = squaring(true, |_| {});
    assert!(eb.board.home(0b010));
    // The locate's stop: motor 0 on its switch, motor 1 dragged along to -2 mm.
    eb.run_until(30_000, |b| b.limit_stops == 2);
    let g = eb.gang.unwrap();
    assert_eq!(g.motors, [-2 * STEPS_PER_MM, -2 * STEPS_PER_MM]);
    // Motor 0 alone seeks (already on its switch: no step), then motor 1 alone.
    eb.run_until(30_000, |b| b.limit_stops == 4);
    eb.run_ms(50);
    let g = eb.gang.unwrap();
    assert_eq!(g.motors, g.at, "both motors on their switches");
    assert_eq!(g.at, [-2 * STEPS_PER_MM, -3 * STEPS_PER_MM]);
    assert_eq!(eb.board.output_levels().user, 0b11);
    until_state(&mut eb, State::Idle, 30_000);
    // Both retracted together by 1 mm: still square to their switches.
    let g = eb.gang.unwrap();
    assert_eq!(g.motors, [g.at[0] + STEPS_PER_MM, g.at[1] + STEPS_PER_MM]);
    assert_eq!(eb.board.homed(), 0b010);
    assert_eq!(eb.isr.kernel.position()[1], 0);
    assert_eq!(eb.board.output_levels().user, 0b11);
    // No alarm on the way, and `disable_limit_report` kept the list's two commanded switch
    // hits from the host; the cycle's own seek is never reported.
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(events(&mut eb), vec![]);
}

#[test]
fn without_the_directive_each_commanded_switch_hit_of_a_list_is_reported() {
    let mut eb = squaring(false, |_| {});
    assert!(eb.board.home(0b010));
    until_state(&mut eb, State::Idle, 30_000);
    assert_eq!(eb.limit_stops, 4);
    let y_min = BoardEvent::Limit {
        axis: 1,
        max: false,
    };
    // The two `seek` commands of before_retract, not the cycle's seek and locate; no alarm.
    assert_eq!(events(&mut eb), vec![y_min, y_min]);
    assert_eq!(eb.board.alarm(), None);
    assert_eq!(eb.board.homed(), 0b010);
    let g = eb.gang.unwrap();
    assert_eq!(g.motors, [g.at[0] + STEPS_PER_MM, g.at[1] + STEPS_PER_MM]);
}

#[test]
fn an_unexpected_switch_during_a_quiet_list_seek_still_stops_and_alarms() {
    // X has a max switch; it trips while motor 1 alone seeks in the quiet list.
    let mut eb = squaring(true, |s| s.inputs.limit_max = 0b001);
    assert!(eb.board.home(0b010));
    eb.run_until(30_000, |b| b.limit_stops == 3);
    eb.run_ms(300);
    assert_eq!(
        eb.board.motion().state(),
        MotionState::Running,
        "motor 1 seeking"
    );
    let y = eb.isr.kernel.position()[1];
    eb.set_pin(LIMIT_MAX_BIT, true);
    until_state(&mut eb, State::Alarm, 1_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    assert_eq!(eb.limit_stops, 4);
    // Motor 1 steps every 1.5625 ms: the pass that saw the pin armed the stop before its next step.
    assert_eq!(eb.isr.kernel.position()[1], y);
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Limit { axis: 0, max: true },
            BoardEvent::Alarm {
                code: AlarmCode::HardLimit,
                line: 0
            }
        ]
    );
    assert_eq!(eb.board.homed(), 0);
    assert_eq!(eb.board.output_levels().user, 0);
}

#[test]
fn another_switch_tripping_with_the_seek_switch_is_a_hard_limit() {
    // X seeks its min switch; the Z max switch closes in the same instant.
    let mut eb = machine(|s| s.homing.axes[2].priority = 0);
    eb.switches.clear();
    eb.capture_events();
    assert!(eb.board.home(0b001));
    eb.run_ms(500);
    assert_eq!(eb.board.motion().state(), MotionState::Running, "seeking");
    eb.set_pin(LIMIT_MIN_BIT, true);
    eb.set_pin(LIMIT_MAX_BIT + 2, true);
    until_state(&mut eb, State::Alarm, 1_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    assert_eq!(eb.limit_stops, 1);
    assert_eq!(
        events(&mut eb),
        vec![
            BoardEvent::Limit {
                axis: 0,
                max: false
            },
            BoardEvent::Limit { axis: 2, max: true },
            BoardEvent::Alarm {
                code: AlarmCode::HardLimit,
                line: 0
            }
        ]
    );
    assert_eq!(eb.board.homed(), 0);
}

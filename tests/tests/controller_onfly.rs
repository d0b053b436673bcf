//! On-the-fly outputs on the emulated board (docs/controller.md, "On-the-fly outputs"): an M code whose
//! list is one `set`/`clear` switches its output at the exact step of the path, at full speed;
//! anything else stops the motion as before. Measured on the virtual pins (the emulator's pin
//! events, as `gantry simulate --vcd` records them).

mod controller_support;

use controller_support::*;
use gantry_emulator::{EmulatedBoard, PinEvent};
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::setup::{Dialect, ListCommand, McodeList, Setup};
use std::cell::RefCell;
use std::rc::Rc;

/// 1.0 in of X in steps (640 steps/mm × 25.4 mm).
const STEPS_1IN: i64 = 16_256;
/// 1125 mm/min = 12 000 X steps/s: a tick every 1000 timer counts at cruise.
const CRUISE_PERIOD: u32 = 1000;

fn list(s: &mut Setup, code: u16, dry_run_disabled: bool, commands: &[ListCommand]) {
    s.program.user_mcodes.push(code).unwrap();
    let mut l = McodeList {
        code,
        dry_run_disabled,
        commands: Default::default(),
    };
    for c in commands {
        l.commands.push(*c).unwrap();
    }
    s.outputs.mcode_lists.push(l).unwrap();
}

/// M14 = [set 1], M15 = [clear 1] (the GIXA controller manual's on-the-fly example), M16 = [set 2, clear 3] (two entries),
/// M17 = [] (no entry), M18 = [set 4] disabled for dry run.
fn machine(edit: impl FnOnce(&mut Setup)) -> EmulatedBoard {
    board(|s| {
        list(s, 14, false, &[ListCommand::Set(1)]);
        list(s, 15, false, &[ListCommand::Clear(1)]);
        list(s, 16, false, &[ListCommand::Set(2), ListCommand::Clear(3)]);
        list(s, 17, false, &[]);
        list(s, 18, true, &[ListCommand::Set(4)]);
        edit(s);
    })
}

/// Records every pin event of the board.
fn record(eb: &mut EmulatedBoard) -> Rc<RefCell<Vec<PinEvent>>> {
    let events = Rc::new(RefCell::new(Vec::new()));
    let sink = events.clone();
    eb.observe(move |p| sink.borrow_mut().push(p));
    events
}

/// One change of a user output pin, read off the pin events.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Edge {
    output: u8,
    on: bool,
    /// X steps made before the change (the change comes before its event's steps).
    x: i64,
    /// Switched by a kernel tick (on the fly), not by the main loop.
    tick: bool,
    /// The kernel's period at that tick, timer counts (0 for main-loop changes).
    period: u32,
    time: u64,
}

fn edges(events: &[PinEvent]) -> Vec<Edge> {
    let mut out = Vec::new();
    let (mut x, mut last) = (0i64, 0u16);
    for e in events {
        let changed = e.outputs ^ last;
        for n in 0..16u8 {
            if changed >> n & 1 == 1 {
                out.push(Edge {
                    output: n,
                    on: e.outputs >> n & 1 == 1,
                    x,
                    tick: e.step != 0 || e.period != 0,
                    period: e.period,
                    time: e.time,
                });
            }
        }
        last = e.outputs;
        if e.step & 1 != 0 {
            x += if e.dir & 1 != 0 { -1 } else { 1 };
        }
    }
    out
}

/// The X steps' pin events: (steps made before it, the event).
fn x_steps(events: &[PinEvent]) -> Vec<(i64, PinEvent)> {
    events
        .iter()
        .filter(|e| e.step & 1 != 0)
        .enumerate()
        .map(|(x, e)| (x as i64, *e))
        .collect()
}

/// Runs until idle, checking every millisecond that the board's output levels (status, stop
/// rules) never disagree with the pins for more than one main-loop pass.
fn run_to_idle(eb: &mut EmulatedBoard, max_ms: u64) {
    let mut behind = 0;
    for _ in 0..max_ms {
        eb.run_ms(1);
        if eb.board.output_levels().user != eb.user_outputs() {
            behind += 1;
            assert!(behind <= 1, "status lags the pins by {behind} ms");
        } else {
            behind = 0;
        }
        if eb.board.state() == State::Idle && !eb.isr.kernel.is_busy() {
            assert_eq!(eb.board.output_levels().user, eb.user_outputs());
            return;
        }
    }
    panic!(
        "still {:?} after {max_ms} ms at {:?}, events {:?}, motion {:?}",
        eb.board.state(),
        steps(eb),
        events(eb),
        eb.board.motion().state()
    );
}

/// The GIXA controller manual's on-the-fly example as it is written: `G91 G01 X1.0` / `X5.0 M14` / `X1.0 M15` in inches.
#[test]
fn the_gixa_example_switches_at_one_and_six_inches_at_speed() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    // G20 on its own line: an F in the same block is read before the unit change (RS274NGC order).
    job(&mut eb, "G20\nG91 G01 X1.0 F50\nX5.0 M14\nX1.0 M15\nM30\n");
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    assert_eq!(e.len(), 2, "{e:?}");
    assert_eq!(
        (e[0].output, e[0].on, e[0].x, e[0].tick),
        (1, true, STEPS_1IN, true)
    );
    assert_eq!(
        (e[1].output, e[1].on, e[1].x, e[1].tick),
        (1, false, 6 * STEPS_1IN, true)
    );
    // F50 in/min = 21.1667 mm/s = 13 546.7 steps/s: 885.8 timer counts per step. Both edges
    // come on a tick at that cruise period (prep rounds each segment's period to a whole count;
    // a block's first segment also pays the counts the block before's last segment rounded off,
    // under one of its periods spread over ~27 ticks: up to 887, as the edge at 6 in shows).
    for edge in &e {
        assert!((885..=887).contains(&edge.period), "{edge:?}");
    }
    // The machine stops with 1 in left: exactly 7 in in all.
    assert_eq!(steps(&eb)[0], 7 * STEPS_1IN);
    assert_eq!(eb.user_outputs(), 0);
}

/// The same in mm at a feed whose cruise period is a whole number of timer counts.
#[test]
fn outputs_switch_at_the_exact_step_without_slowing() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G91 G01 X25.4 F1125\nX127 M14\nX25.4 M15\nM30\n",
    );
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    assert_eq!(
        e.iter()
            .map(|e| (e.on, e.x, e.tick, e.period))
            .collect::<Vec<_>>(),
        [
            (true, STEPS_1IN, true, CRUISE_PERIOD),
            (false, 6 * STEPS_1IN, true, CRUISE_PERIOD)
        ]
    );
    // Cruise on both sides of each edge: the ticks before and after run at the same period.
    let xs = x_steps(&ev);
    for edge in &e {
        let i = xs.iter().position(|(x, _)| *x == edge.x).unwrap();
        for (_, p) in &xs[i - 50..i + 50] {
            assert_eq!(p.period, CRUISE_PERIOD);
        }
        assert_eq!(
            xs[i].1.time, edge.time,
            "the edge comes with the block's first step"
        );
    }
    assert_eq!(steps(&eb)[0], 7 * STEPS_1IN);
}

/// Standing alone between two moves (its own line) is the same point as in the second move's block.
#[test]
fn an_m_code_alone_between_two_moves_fires_at_the_junction() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    job(&mut eb, "G21 G91 G01 X10 F1125\nM14\nX10\nM15\nX10\nM30\n");
    run_to_idle(&mut eb, 20_000);
    let e = edges(&events.borrow());
    assert_eq!(
        e.iter().map(|e| (e.on, e.x, e.period)).collect::<Vec<_>>(),
        [(true, 6400, CRUISE_PERIOD), (false, 12_800, CRUISE_PERIOD)]
    );
}

/// The moves around `M` (a list with two entries, an empty list, or two on-the-fly M codes) come
/// to rest at the junction: the last steps before it come below a tenth of the cruise speed (the
/// ramp ends at the 1 mm/s start speed) and the next step comes at least one main-loop pass
/// (1 ms = 12 000 counts) later.
fn assert_rest_at(ev: &[PinEvent], x: i64) {
    let xs = x_steps(ev);
    let i = xs.iter().position(|(s, _)| *s == x).unwrap();
    let (last, stop, next) = (xs[i - 2].1, xs[i - 1].1, xs[i].1);
    assert!(
        stop.time - last.time >= 10 * u64::from(CRUISE_PERIOD),
        "not slowed: {last:?} {stop:?}"
    );
    assert!(
        next.time - stop.time >= 12_000,
        "no pause: {stop:?} {next:?}"
    );
}

#[test]
fn a_list_with_two_entries_or_none_breaks_the_contour() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G91 G01 X10 F1125\nX10 M16\nX10 M17\nX10\nM30\n",
    );
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    // M16's set 2 comes from the main loop at rest (its clear 3 changes nothing).
    assert_eq!(e.len(), 1);
    assert_eq!(
        (e[0].output, e[0].on, e[0].x, e[0].tick),
        (2, true, 6400, false)
    );
    assert_rest_at(&ev, 6400);
    assert_rest_at(&ev, 12_800);
    assert_eq!(steps(&eb)[0], 25_600);
}

#[test]
fn two_on_the_fly_m_codes_between_the_same_moves_stop_the_motion_there() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    job(&mut eb, "G21 G91 G01 X10 F1125\nM14\nM15\nX10\nM30\n");
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    // Both run at rest, in order, one main-loop pass (1 ms) apart; the motion stops and starts
    // again.
    assert_eq!(
        e.iter().map(|e| (e.on, e.x, e.tick)).collect::<Vec<_>>(),
        [(true, 6400, false), (false, 6400, false)]
    );
    assert_eq!(e[1].time - e[0].time, 12_000);
    assert_rest_at(&ev, 6400);
    assert_eq!(steps(&eb)[0], 12_800);
}

#[test]
fn an_m_code_with_no_move_after_it_runs_once_the_motion_has_ended() {
    for end in ["M30\n", ""] {
        let mut eb = machine(|_| {});
        let events = record(&mut eb);
        job(&mut eb, &format!("G21 G91 G01 X10 F1125\nM14\n{end}"));
        run_to_idle(&mut eb, 20_000);
        let e = edges(&events.borrow());
        assert_eq!(e.len(), 1, "end {end:?}: {e:?}");
        assert_eq!((e[0].on, e[0].x, e[0].tick), (true, 6400, false));
        assert_eq!(eb.board.output_levels().user, 0b10);
    }
}

#[test]
fn a_hold_and_resume_across_the_point_fire_it_once_at_the_same_step() {
    // Decelerating from 18.75 mm/s takes 0.88 mm plus the queued segments: a hold at 24 mm comes to
    // rest before the 25.4 mm point, one at 25 mm passes it on the way down.
    for (hold_mm, stops_beyond) in [(24, false), (25, true)] {
        let mut eb = machine(|_| {});
        let events = record(&mut eb);
        job(
            &mut eb,
            "G21 G91 G01 X25.4 F1125\nX127 M14\nX25.4 M15\nM30\n",
        );
        assert!(eb.run_until(10_000, |b| steps(b)[0] >= hold_mm * STEPS_PER_MM));
        eb.board.feed_hold();
        assert!(eb.run_until(2_000, |b| b.board.motion().state()
            == gantry_machine::motion::pipeline::MotionState::Held
            && !b.isr.kernel.is_busy()));
        let stopped = steps(&eb)[0];
        assert_eq!(stopped > STEPS_1IN, stops_beyond, "stopped at {stopped}");
        eb.run_ms(500);
        assert_eq!(eb.user_outputs() == 0b10, stops_beyond);
        assert_eq!(eb.board.output_levels().user, eb.user_outputs());
        eb.board.resume();
        run_to_idle(&mut eb, 20_000);
        let e = edges(&events.borrow());
        assert_eq!(
            e.iter().map(|e| (e.on, e.x, e.tick)).collect::<Vec<_>>(),
            [(true, STEPS_1IN, true), (false, 6 * STEPS_1IN, true)],
            "hold at {hold_mm} mm"
        );
        assert_eq!(e[1].period, CRUISE_PERIOD);
        assert_eq!(steps(&eb)[0], 7 * STEPS_1IN);
    }
}

#[test]
fn a_limit_stop_after_the_point_switches_the_outputs_off() {
    let mut eb = machine(|s| s.inputs.limit_max = 0b001);
    eb.add_switch(0, true, 50 * MM);
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G91 G01 X25.4 F1125\nX127 M14\nX25.4 M15\nM30\n",
    );
    until_state(&mut eb, State::Alarm, 10_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::HardLimit));
    eb.run_ms(2);
    let e = edges(&events.borrow());
    // On at 1 in on the fly, off from the main loop at the stop (the M15 point is never reached).
    assert_eq!(
        e.iter().map(|e| (e.on, e.x, e.tick)).collect::<Vec<_>>(),
        [
            (true, STEPS_1IN, true),
            (false, 50 * STEPS_PER_MM + AHEAD, false)
        ]
    );
    assert_eq!(eb.user_outputs(), 0);
    assert_eq!(eb.board.output_levels().user, 0);
    // Stays off: the queued M15 was dropped with the rest of the job.
    eb.run_ms(1000);
    assert_eq!(edges(&events.borrow()).len(), 2);
}

#[test]
fn an_abort_after_the_point_keeps_the_seed_stop_rules() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G91 M3 S1000\nG01 X25.4 F1125\nX127 M14\nX25.4 M15\nM30\n",
    );
    assert!(eb.run_until(10_000, |b| steps(b)[0] >= 40 * STEPS_PER_MM));
    assert_eq!(eb.user_outputs(), 0b10);
    eb.board.abort();
    until_state(&mut eb, State::Idle, 5_000);
    eb.run_ms(500);
    // Abort = program stop: spindle off, user outputs as the program left them (as with lists);
    // the M15 point beyond the stop never fires.
    let levels = eb.board.output_levels();
    assert!(!levels.spindle_enable);
    assert_eq!((levels.user, eb.user_outputs()), (0b10, 0b10));
    assert_eq!(edges(&events.borrow()).len(), 1);
    assert!(steps(&eb)[0] < 6 * STEPS_1IN);
}

#[test]
fn dry_run_skips_a_disabled_on_the_fly_output_without_changing_the_motion() {
    let mut eb = machine(|s| s.operator.dry_run_feed = 1125 * MM);
    assert!(eb.board.set_dry_run(true));
    let events = record(&mut eb);
    job(
        &mut eb,
        "G21 G91 G01 X10 F600\nX10 M18\nX10 M14\nX10\nM30\n",
    );
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    // M18 (disabled for dry run) switches nothing, M14 switches at its point; neither stops.
    assert_eq!(
        e.iter()
            .map(|e| (e.output, e.on, e.x, e.period))
            .collect::<Vec<_>>(),
        [(1, true, 12_800, CRUISE_PERIOD)]
    );
    let xs = x_steps(&ev);
    let i = xs.iter().position(|(x, _)| *x == 6400).unwrap();
    assert_eq!(xs[i].1.period, CRUISE_PERIOD);
}

#[test]
fn check_mode_switches_no_output() {
    let mut eb = machine(|_| {});
    let events = record(&mut eb);
    assert!(eb.board.start_check());
    for (i, l) in "G21 G91 G01 X10 F1125\nX10 M14\nX10 M16\nM30\n"
        .lines()
        .enumerate()
    {
        assert!(eb.board.push_line(0, i as u32 + 1, l));
    }
    eb.board.end_of_lines(0);
    until_state(&mut eb, State::Idle, 1_000);
    assert!(events
        .borrow()
        .iter()
        .all(|e| e.outputs == 0 && e.step == 0));
    assert_eq!(eb.user_outputs(), 0);
}

#[test]
fn the_gixa_punch_runs_its_one_command_list_at_rest() {
    let mut eb = board(|s| {
        s.program.dialect = Dialect::Gixa;
        list(s, 10, false, &[ListCommand::Set(1)]);
    });
    let events = record(&mut eb);
    job(&mut eb, "G21\nG88 X10 Y0\nG80\nG01 X20 F1125\nM30\n");
    run_to_idle(&mut eb, 20_000);
    let ev = events.borrow();
    let e = edges(&ev);
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!((e[0].x, e[0].tick), (6400, false));
    assert_rest_at(&ev, 6400);
}

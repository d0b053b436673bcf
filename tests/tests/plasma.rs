//! Plasma torch mode on the emulated board (docs/laser-plasma.md "Plasma"), on virtual time with
//! the scripted power source and height controller (emulator/src/torch_script.rs): the wait
//! for arc-OK after M3, the "no arc" alarm, the hold when the arc is lost mid-cut (resumed only
//! by cycle start, which re-fires the torch and waits again), and torch height control's Z
//! steps: at cruise only, never in ramps, corners or below the anti-dive speed, reported beside
//! a Z that stays where the program put it, and taken out before the next pierce.

mod controller_support;

use controller_support::*;
use gantry_emulator::torch_script::{parse_thc, TorchModel, TorchScript};
use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
use gantry_machine::board::BoardEvent;
use gantry_machine::board::{AlarmCode, State};
use gantry_machine::device::link::status_of;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::{Segment, KERNEL_TIMER_HZ};

const Z: usize = 2;

/// A torch machine (debounce 1 ms) with `script` as its power source and height controller.
fn torch_board(script: TorchScript, edit: impl FnOnce(&mut Setup)) -> EmulatedBoard {
    let mut eb = board(|s| {
        s.outputs.torch.on = true;
        edit(s);
    });
    eb.torch = Some(TorchModel::new(script));
    eb.output_changes = Some(Vec::new());
    eb.started_segments = Some(Vec::new());
    eb.capture_events();
    eb
}

fn script(arc_ok_ms: Option<u64>, lost_ms: Option<u64>, thc: &str) -> TorchScript {
    TorchScript {
        arc_ok_delay_ms: arc_ok_ms,
        arc_lost_at_ms: lost_ms,
        thc: parse_thc(thc).unwrap(),
    }
}

/// Virtual times (timer counts) the torch output went on and off, in order.
fn torch_edges(eb: &EmulatedBoard) -> Vec<(u64, bool)> {
    let mut last = false;
    let mut v = Vec::new();
    for (t, l) in eb.output_changes.as_ref().unwrap() {
        if l.spindle_enable != last {
            last = l.spindle_enable;
            v.push((*t, last));
        }
    }
    v
}

/// Segments the kernel started that step (time, segment).
fn stepping(eb: &EmulatedBoard) -> Vec<(u64, Segment)> {
    let segs = eb.started_segments.as_ref().unwrap();
    segs.iter()
        .filter(|(_, s)| s.steps.iter().any(|&n| n > 0))
        .copied()
        .collect()
}

fn z_correction_nm(eb: &EmulatedBoard) -> i32 {
    let st = status_of(&eb.board, &eb.kernel_view());
    st.outputs.torch.expect("a torch status").thc_nm
}

#[test]
fn the_first_move_starts_when_arc_ok_comes_300_ms_after_the_torch_fired() {
    let mut eb = torch_board(script(Some(300), None, ""), |_| {});
    job(
        &mut eb,
        "G21 G90 G94\nG0 X2\nM3 S1000\nG1 X12 F1200\nM5\nM2\n",
    );
    until_state(&mut eb, State::Idle, 10_000);
    assert!(events(&mut eb)
        .iter()
        .all(|e| !matches!(e, BoardEvent::Alarm { .. })));
    let edges = torch_edges(&eb);
    assert_eq!(edges.len(), 2, "{edges:?}");
    let fired = edges[0].0;
    // The G0 ran before the torch fired; the G1 is the first segment after it.
    let first_cut = stepping(&eb)
        .into_iter()
        .find(|(t, _)| *t > fired)
        .expect("the cut ran")
        .0;
    let waited = first_cut - fired;
    // 300 ms of script, then one 1 ms input sample (debounce 1) and the pass that hands out
    // the first segment: within 1 ms of 301 ms.
    assert!(
        (300 * COUNTS_PER_MS..=302 * COUNTS_PER_MS).contains(&waited),
        "the cut started {:.3} ms after the torch fired",
        waited as f64 / COUNTS_PER_MS as f64
    );
    assert_eq!(steps(&eb)[0], 12 * STEPS_PER_MM);
    // Nothing stepped between the torch firing and arc-OK: the machine stood at X2.
    assert!(stepping(&eb)
        .iter()
        .all(|(t, _)| *t <= fired || *t >= fired + 300 * COUNTS_PER_MS));
}

#[test]
fn no_arc_ok_raises_alarm_22_with_the_torch_off_and_nothing_moved() {
    let mut eb = torch_board(script(None, None, ""), |s| {
        s.outputs.torch.arc_ok_timeout_ms = 1500
    });
    job(&mut eb, "G21 G90 G94\nM3 S1000\nG1 X10 F1200\nM5\nM2\n");
    until_state(&mut eb, State::Alarm, 5_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::NoArc));
    let edges = torch_edges(&eb);
    assert_eq!(edges.len(), 2, "fired once, then off: {edges:?}");
    let waited = edges[1].0 - edges[0].0;
    assert!(
        (1500 * COUNTS_PER_MS..=1501 * COUNTS_PER_MS).contains(&waited),
        "off after {waited} counts"
    );
    assert!(!eb.board.output_levels().spindle_enable);
    assert_eq!(steps(&eb), [0; 6]);
    assert!(events(&mut eb).contains(&BoardEvent::Alarm {
        code: AlarmCode::NoArc,
        line: 2
    }));
}

#[test]
fn an_arc_lost_mid_cut_holds_on_the_path_torch_off_until_cycle_start_re_fires_it() {
    let mut eb = torch_board(script(Some(100), Some(1000), ""), |_| {});
    job(&mut eb, "G21 G90 G94\nM3 S1000\nG1 X50 F1200\nM5\nM2\n");
    until_state(&mut eb, State::Hold, 3_000);
    // Lost 1000 ms after firing: torch off at once, the machine decelerates on the path.
    let edges = torch_edges(&eb);
    assert_eq!(edges.iter().filter(|e| e.1).count(), 1);
    assert_eq!(edges.last().map(|e| e.1), Some(false));
    until_at_rest_held(&mut eb);
    let stopped = steps(&eb);
    assert!(stopped[0] > 0 && stopped[0] < 50 * STEPS_PER_MM);
    assert_eq!(stopped[1], 0, "on the path");
    let st = status_of(&eb.board, &eb.kernel_view());
    assert!(st.outputs.torch.unwrap().arc_lost);
    // Nothing resumes by itself (the stop rule), not even with arc-OK back on the pin.
    eb.run_ms(3_000);
    assert_eq!((eb.board.state(), steps(&eb)), (State::Hold, stopped));
    assert!(!eb.board.output_levels().spindle_enable);
    // Cycle start: the torch fires again and the motion waits for arc-OK (100 ms) first.
    eb.board.cycle_start();
    let refire = eb.now();
    eb.run_ms(90);
    assert!(eb.board.output_levels().spindle_enable);
    assert_eq!(steps(&eb), stopped, "no motion before arc-OK");
    let st = status_of(&eb.board, &eb.kernel_view());
    assert!(st.outputs.torch.unwrap().waiting);
    until_state(&mut eb, State::Idle, 10_000);
    let resumed = stepping(&eb)
        .into_iter()
        .find(|(t, _)| *t > refire)
        .unwrap()
        .0;
    assert!(resumed - refire >= 100 * COUNTS_PER_MS);
    assert_eq!(
        steps(&eb)[0],
        50 * STEPS_PER_MM,
        "the cut finished on its path"
    );
    assert!(events(&mut eb)
        .iter()
        .all(|e| !matches!(e, BoardEvent::Alarm { .. })));
}

#[test]
fn a_re_fired_torch_without_arc_ok_ends_in_alarm_22() {
    let mut eb = torch_board(script(Some(50), Some(600), ""), |s| {
        s.outputs.torch.arc_ok_timeout_ms = 400
    });
    job(&mut eb, "G21 G90 G94\nM3 S1000\nG1 X50 F1200\nM5\nM2\n");
    until_state(&mut eb, State::Hold, 3_000);
    until_at_rest_held(&mut eb);
    // The script's arc comes back only after a fresh firing: take it away for good.
    eb.torch.as_mut().unwrap().script.arc_ok_delay_ms = None;
    eb.board.cycle_start();
    until_state(&mut eb, State::Alarm, 2_000);
    assert_eq!(eb.board.alarm(), Some(AlarmCode::NoArc));
    assert!(!eb.board.output_levels().spindle_enable);
}

/// Runs until the held machine stands still.
fn until_at_rest_held(eb: &mut EmulatedBoard) {
    let ok = eb.run_until(2_000, |b| {
        b.kernel_drained()
            && b.board.motion().state() == gantry_machine::motion::pipeline::MotionState::Held
    });
    assert!(ok, "the hold did not come to rest");
}

/// THC at 120 mm/min (2 mm/s: 1280 Z steps/s) within ±1 mm, no settle delay.
fn thc_setup(s: &mut Setup) {
    s.outputs.torch.thc_rate = 120 * MM;
    s.outputs.torch.thc_travel = MM;
    s.outputs.torch.thc_delay_ms = 0;
}

/// X and Y steps per second of a segment.
fn xy_rate(s: &Segment) -> f64 {
    let xy = s.steps[0].max(s.steps[1]) as f64;
    xy * KERNEL_TIMER_HZ as f64 / s.duration() as f64
}

#[test]
fn thc_up_moves_z_by_its_rate_at_cruise_while_z_reads_as_programmed() {
    // Arc-OK at 100 ms; the controller asks up from 1000 to 1250 ms after firing (250 ms at
    // 1280 steps/s = 320 steps, 0.5 mm), the cut runs at F1200 (12800 X steps/s) from 100 ms to 5.1 s.
    let mut eb = torch_board(script(Some(100), None, "up:1000-1250"), thc_setup);
    job(
        &mut eb,
        "G21 G90 G94\nG0 Z5\nM3 S1000\nG1 X100 F1200\nM5\nM2\n",
    );
    let fired = {
        let ok = eb.run_until(2_000, |b| b.board.output_levels().spindle_enable);
        assert!(ok);
        eb.now()
    };
    eb.run_until(1_400, |b| b.now() >= fired + 1_400 * COUNTS_PER_MS);
    let z_now = steps(&eb)[Z] - 5 * STEPS_PER_MM;
    assert!((z_now - 320).abs() <= 4, "Z corrected {z_now} steps");
    // The status: Z where the program put it, the correction beside it.
    let st = status_of(&eb.board, &eb.kernel_view());
    assert_eq!(st.machine_pos[Z], 5 * MM);
    let corr = z_correction_nm(&eb);
    assert!((corr - 500_000).abs() <= 4 * 1563, "THC {corr} nm");
    // Every segment that carried Z steps ran at the cut's cruise rate.
    let segs = stepping(&eb);
    for (_, s) in segs
        .iter()
        .filter(|(_, s)| s.steps[Z] > 0 && s.steps[0] > 0)
    {
        assert!(
            (xy_rate(s) - 12_800.0).abs() < 13.0,
            "{s:?} at {}",
            xy_rate(s)
        );
    }
    until_state(&mut eb, State::Idle, 10_000);
    assert_eq!(steps(&eb)[0], 100 * STEPS_PER_MM);
}

#[test]
fn thc_holds_in_accelerations_corners_and_below_the_anti_dive_speed() {
    // Up the whole time from arc-OK on, over a square of 20 mm sides: Z may only move in the
    // cruise of each side, never while a side accelerates or slows for its corner.
    let square = "G21 G90 G94\nM3 S1000\nG1 X20 F1200\nG1 Y20\nG1 X0\nG1 Y0\nM5\nM2\n";
    let mut eb = torch_board(script(Some(10), None, "up:10-60000"), |s| {
        thc_setup(s);
        s.outputs.torch.thc_travel = 50 * MM;
    });
    job(&mut eb, square);
    until_state(&mut eb, State::Idle, 20_000);
    let segs = stepping(&eb);
    let (mut ramp, mut cruise_z) = (0, 0);
    // (Z-only segments are the correction taken out at M2, after the torch went off.)
    for (_, s) in segs.iter().filter(|(_, s)| s.steps[0] + s.steps[1] > 0) {
        let at_cruise = (xy_rate(s) - 12_800.0).abs() < 13.0;
        if s.steps[Z] > 0 {
            assert!(at_cruise, "Z stepped at {} XY steps/s: {s:?}", xy_rate(s));
            cruise_z += s.steps[Z];
        } else if !at_cruise {
            ramp += 1;
        }
    }
    assert!(
        ramp >= 8,
        "four sides each ramp up and down ({ramp} ramp segments)"
    );
    // 4 × 20 mm at 20 mm/s = 4 s, less the ramps (0.1 s each way at 200 mm/s²): about 3.6 s
    // of cruise at 1280 steps/s.
    assert!(
        (4400..=4700).contains(&cruise_z),
        "Z corrected {cruise_z} steps"
    );

    // The same square at a 50 % feed override: below the 90 % anti-dive, Z never moves.
    let mut eb = torch_board(script(Some(10), None, "up:10-60000"), thc_setup);
    eb.board.set_feed_override(50);
    job(&mut eb, square);
    until_state(&mut eb, State::Idle, 20_000);
    assert!(stepping(&eb).iter().all(|(_, s)| s.steps[Z] == 0));
    assert_eq!(steps(&eb)[Z], 0);
}

#[test]
fn the_correction_is_taken_out_before_the_next_pierce_and_at_the_end() {
    let mut eb = torch_board(script(Some(10), None, "down:10-400"), thc_setup);
    let program = "G21 G90 G94\nG0 Z3\nM3 S1000\nG1 X30 F1200\nM5\nG0 Z5\nG0 X40\nG0 Z3\n\
                   M3 S1000\nG1 X60\nM5\nM2\n";
    job(&mut eb, program);
    // The first cut lowers Z; the retract and the rapid carry the correction with them.
    let ok = eb.run_until(5_000, |b| b.board.line() >= 7);
    assert!(ok);
    let z_cut = steps(&eb)[Z] - 5 * STEPS_PER_MM;
    assert!(z_cut < -300, "lowered {z_cut} steps");
    until_state(&mut eb, State::Idle, 20_000);
    let edges = torch_edges(&eb);
    assert_eq!(edges.iter().filter(|e| e.1).count(), 2);
    // At the second M3's sync point Z went back by the correction before the torch fired:
    // the second pierce at Z3 exactly, then its own correction of the same pattern.
    let second_fire = edges[2].0;
    let before: i64 = stepping(&eb)
        .iter()
        .filter(|(t, s)| *t < second_fire && s.steps[0] == 0 && s.steps[Z] > 0 && s.dir & 4 == 0)
        .map(|(_, s)| i64::from(s.steps[Z]))
        .sum();
    assert!(before >= -z_cut, "returned {before} of {z_cut}");
    // M2 is a sync point after the torch went off: the second correction came out too.
    assert_eq!(z_correction_nm(&eb), 0);
    assert_eq!(steps(&eb)[Z], 3 * STEPS_PER_MM);
}

#[test]
fn m62_p2_switches_thc_off_and_m63_p2_on_with_the_next_move() {
    let mut eb = torch_board(script(Some(10), None, "up:10-60000"), |s| {
        thc_setup(s);
        s.outputs.torch.thc_travel = 50 * MM;
    });
    job(
        &mut eb,
        "G21 G90 G94\nM3 S1000\nM62 P2\nG1 X20 F1200\nM63 P2\nG1 X40\nM5\nM2\n",
    );
    until_state(&mut eb, State::Idle, 10_000);
    assert!(events(&mut eb)
        .iter()
        .all(|e| !matches!(e, BoardEvent::Alarm { .. } | BoardEvent::Error { .. })));
    // Z steps by where X stood: none in the first 20 mm (THC off), some in the second.
    let (mut x, mut z_off, mut z_on) = (0i64, 0u32, 0u32);
    for (_, s) in stepping(&eb) {
        if x < 20 * STEPS_PER_MM {
            z_off += s.steps[Z];
        } else if s.steps[0] > 0 {
            z_on += s.steps[Z];
        }
        x += i64::from(s.steps[0]);
    }
    assert_eq!(z_off, 0);
    assert!(z_on > 1000, "Z corrected {z_on} steps with THC back on");
    // Other ports are not there: M62 P1 is refused.
    let mut eb = torch_board(script(Some(10), None, ""), |_| {});
    job(&mut eb, "M62 P1\n");
    until_state(&mut eb, State::Idle, 1_000);
    assert!(events(&mut eb)
        .iter()
        .any(|e| matches!(e, BoardEvent::Error { line: 1, .. })));
}

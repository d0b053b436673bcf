//! Step timing on the emulated board at the shortest periods (`StepTiming::period` in
//! machine/src/step/timing.rs): with 1 µs pulses and 1 µs dir set-up, steps in one direction
//! come every 24 timer counts (500 kHz) and only the period before a direction change holds the
//! set-up; the first step after idle waits for the 1 ms idle poll and the two kernel ticks ahead.
//! Measured on the board's pin events (one per tick that steps or changes direction).

use gantry_emulator::{EmulatedBoard, PinEvent};
use gantry_machine::device::main_loop::BoardPort;
use gantry_machine::setup::{DriverSetup, Setup};
use gantry_machine::step::kernel::{Segment, StepTiming};
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::step::IDLE_PERIOD_COUNTS;
use std::cell::RefCell;
use std::rc::Rc;

const FAST: DriverSetup = DriverSetup {
    step_pulse_ns: 1_000,
    dir_setup_ns: 1_000,
};

fn seg(steps: [u32; 6], ticks: u32, period: u32, dir: u8) -> Segment {
    Segment {
        steps,
        ticks,
        period,
        dir,
        output: OutputEvent::NONE,
        power: gantry_machine::step::kernel::KEEP_DUTY,
    }
}

/// Runs `segs` queued at 5 ms on an idle board with 1 µs pulse and dir set-up; returns its pin
/// events and the time they were queued.
fn run(segs: &[Segment]) -> (Vec<PinEvent>, EmulatedBoard, u64) {
    let mut eb = EmulatedBoard::new(Setup {
        drivers: FAST,
        ..Setup::default()
    });
    eb.run_ms(5);
    let events = Rc::new(RefCell::new(Vec::new()));
    let sink = events.clone();
    eb.observe(move |p| sink.borrow_mut().push(p));
    let queued = eb.now();
    for s in segs {
        eb.push_segment(*s);
    }
    eb.run_ms(5);
    let e = events.borrow().clone();
    (e, eb, queued)
}

#[test]
fn one_microsecond_pulses_run_at_500_khz_and_only_reversals_wait_for_the_dir_set_up() {
    let t = StepTiming::from_setup(&FAST);
    assert_eq!(
        (t.min_period, t.turn_period),
        (24, 24 + StepTiming::WRITE_WINDOW)
    );
    // X forward 20 steps, back 20, forward 20 with Y joining (Y's dir bit set: another
    // reversal of the dir byte), all asking for 20-count periods (600 kHz, stretched to 24).
    let segs = [
        seg([20, 0, 0, 0, 0, 0], 20, 20, 0b00),
        seg([20, 0, 0, 0, 0, 0], 20, 20, 0b01),
        seg([20, 10, 0, 0, 0, 0], 20, 20, 0b10),
    ];
    let (events, eb, _) = run(&segs);
    let steps: Vec<&PinEvent> = events.iter().filter(|e| e.step != 0).collect();
    assert_eq!(steps.len(), 60);
    assert_eq!(eb.pulses[0], 60);
    assert_eq!(eb.pulses[1], 10);
    assert_eq!(eb.physical()[0], 20);
    assert_eq!(eb.physical()[1], -10);
    let t0 = steps[0].time;
    let times: Vec<u64> = steps.iter().map(|e| e.time - t0).collect();
    // Exact tick times: 24 counts apart within a direction; the reversals after the 20th and
    // 40th step wait the turn period, and the dir byte changes with the first step after it.
    let turn = u64::from(t.turn_period);
    for (n, time) in times.iter().enumerate() {
        let n = n as u64;
        let want = match n {
            0..=19 => 24 * n,
            20..=39 => 19 * 24 + turn + 24 * (n - 20),
            _ => 19 * 24 + turn + 19 * 24 + turn + 24 * (n - 40),
        };
        assert_eq!(*time, want, "step {n}");
    }
    assert_eq!(steps[19].dir, 0b00);
    assert_eq!(steps[20].dir, 0b01);
    assert_eq!(steps[20].time - steps[19].time, turn);
    assert_eq!(steps[39].dir, 0b01);
    assert_eq!(steps[40].dir, 0b10);
    assert_eq!(steps[40].time - steps[39].time, turn);
    // Nothing else is stretched beyond 24 counts.
    let gaps: Vec<u64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    assert_eq!(gaps.iter().filter(|g| **g != 24).count(), 2);
}

#[test]
fn a_segment_change_in_the_same_direction_is_not_stretched() {
    let segs = [
        seg([30, 0, 0, 0, 0, 0], 30, 24, 0b100),
        seg([30, 30, 0, 0, 0, 0], 30, 24, 0b100),
    ];
    let (events, _, _) = run(&segs);
    let times: Vec<u64> = events
        .iter()
        .filter(|e| e.step != 0)
        .map(|e| e.time)
        .collect();
    assert_eq!(times.len(), 60);
    assert!(times.windows(2).all(|w| w[1] - w[0] == 24));
}

#[test]
fn the_first_step_after_idle_waits_for_the_poll_and_the_two_ticks_ahead() {
    let t = StepTiming::from_setup(&FAST);
    // X 10 steps, Y 5, 100 counts apart.
    let (events, _, queued) = run(&[seg([10, 5, 0, 0, 0, 0], 10, 100, 0)]);
    let steps: Vec<PinEvent> = events.into_iter().filter(|e| e.step != 0).collect();
    assert_eq!(steps.len(), 10);
    // Queued at 5 ms, just before the update at 5 ms: its interrupt (at the pulse end plus the
    // entry) polls the queue and finds the segment; the period it starts next was set by the
    // poll before (1 ms idle), the one after by this poll (the turn period, for the dir set-up);
    // the step goes out at the update after it. The old emulation stepped at 5 ms sharp.
    assert_eq!(queued, 60_000);
    let first = steps[0].time - queued;
    assert_eq!(
        first,
        2 * u64::from(IDLE_PERIOD_COUNTS) + u64::from(t.turn_period)
    );
    // Then every 100 counts, each event naming the period it starts; X steps on each, Y on
    // every second.
    for (n, e) in steps.iter().enumerate() {
        assert_eq!(e.time - steps[0].time, 100 * n as u64);
        assert_eq!(e.step & 1, 1);
    }
    assert_eq!(steps.iter().filter(|e| e.step & 2 != 0).count(), 5);
    assert!(steps[..9].iter().all(|e| e.period == 100));
}

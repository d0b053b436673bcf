//! `gantry simulate --vcd`: the trace of the emulated board's pins parses, and its step pulses
//! are exactly the steps the board made.

use gantry_machine::setup::Setup;
use host_sender::program::Program;
use host_sender::trace::trace;
use host_sender::vcd::read_vcd;

#[test]
fn the_vcd_of_the_example_job_has_every_step_the_board_made() {
    let program = Program::from_text(include_str!("../../examples/bracket.ngc"));
    let out = std::env::temp_dir().join(format!("gantry-trace-{}.vcd", std::process::id()));
    let r = trace(&program, Setup::default(), &out, None, None).unwrap();
    assert!(r.completed);
    let text = std::fs::read_to_string(&out).unwrap();
    std::fs::remove_file(&out).ok();
    let vcd = read_vcd(&text).unwrap();
    for (axis, name) in ["x_step", "y_step", "z_step"].iter().enumerate() {
        assert_eq!(
            vcd.rising.get(*name).copied(),
            Some(r.pulses[axis]),
            "{name}"
        );
    }
    assert_eq!(&r.pulses[..3], &[302_080, 197_120, 65_280]);
    // The steppers are enabled by the first motion.
    assert_eq!(vcd.rising.get("enable").copied(), Some(1));
}

#[test]
fn input_changes_reach_the_pin_observer() {
    use host_sender::emulator::EmulatedBoard;
    use std::sync::{Arc, Mutex};
    let mut board = EmulatedBoard::new(Setup::default());
    let seen = Arc::new(Mutex::new(Vec::new()));
    let s = seen.clone();
    board.observe(move |p| s.lock().unwrap().push(p));
    board.run_ms(10);
    // The cycle-start pin goes high for 20 ms (debounced over 5 ms samples by default).
    board.set_pin(2, true);
    board.run_ms(20);
    board.set_pin(2, false);
    board.run_ms(20);
    let events = seen.lock().unwrap();
    let levels: Vec<u32> = events.iter().map(|e| e.inputs & 0b100).collect();
    assert_eq!(levels, vec![0b100, 0]);
    assert!(events.iter().all(|e| e.step == 0));
}

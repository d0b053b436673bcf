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
    use gantry_emulator::EmulatedBoard;
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

/// Widths (ns) of the high pulses of signal `name` in a VCD text.
fn pulse_widths(vcd: &str, name: &str) -> Vec<u64> {
    let id = vcd
        .lines()
        .find_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() >= 5 && w[0] == "$var" && w[4] == name).then(|| w[3].to_string())
        })
        .expect("signal in the header");
    let (mut now, mut rose, mut widths) = (0u64, None, Vec::new());
    for l in vcd.lines() {
        if let Some(t) = l.strip_prefix('#') {
            now = t.parse().unwrap();
        } else if l.len() > 1 && l[1..] == id {
            match &l[..1] {
                "1" => rose = Some(now),
                "0" => widths.extend(rose.take().map(|r| now - r)),
                _ => {}
            }
        }
    }
    widths
}

/// The trace shows the step pulse width the setup asks for, in whole step-timer counts (1.9 µs
/// is 23 counts of 83.3 ns: 1917 ns), on every pulse.
#[test]
fn the_trace_has_the_pulse_width_of_the_setup() {
    let program = Program::from_text("G21 G90\nG1 X2 Y-1 F600\nM2\n");
    for (pulse_ns, want) in [(2_500, 2_500), (1_900, 1_917)] {
        let mut setup = Setup::default();
        setup.drivers.step_pulse_ns = pulse_ns;
        let out = std::env::temp_dir().join(format!(
            "gantry-trace-pulse-{}-{pulse_ns}.vcd",
            std::process::id()
        ));
        let r = trace(&program, setup, &out, None, None).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        std::fs::remove_file(&out).ok();
        let widths = pulse_widths(&text, "x_step");
        assert_eq!(widths.len() as u64, r.pulses[0]);
        assert_eq!(r.pulses[0], 1280); // 2 mm at 3200 steps per 5 mm
        assert!(widths.iter().all(|&w| w == want), "{pulse_ns} ns");
    }
}

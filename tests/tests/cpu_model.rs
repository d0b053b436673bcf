//! The emulated board's CPU model (emulator/src/cpu_model.rs): a fine-segment 3D program
//! streamed to the emulated board with the F411 model on shows underruns at a feed the F411
//! cannot keep up with, and none at a feed it can; without the model the same fast job has none.

mod fine_lines;

use fine_lines::{fine_lines, Wording};
use gantry_emulator::cpu_model::CpuModel;
use gantry_emulator::EmulatedBoard;
use gantry_machine::setup::Setup;
use host_sender::link::Client;
use host_sender::program::Program;
use host_sender::session::{stream_program, Flow};

/// A machine fast enough that the planner, not the axes, bounds the speed: 500 mm/s, 10 m/s²,
/// 160 steps/mm (64 kHz at 400 mm/s, well within the default pulse timing).
fn fast_machine() -> Setup {
    let mut setup = Setup::default();
    for a in setup.axes.iter_mut() {
        a.steps = 800;
        a.units_nm = 5_000_000;
        a.max_rate = 30_000_000_000;
        a.accel = 10_000_000_000;
    }
    setup
}

/// 10,000 lines of `step_um` µm along a straight 3D line (X, with Y and Z drifting), from
/// X −250 mm, written short.
fn fine_program(feed_mm_min: u32, step_um: i64) -> String {
    fine_lines(-250, 10_000, step_um, feed_mm_min, Wording::Short)
}

/// [`fine_program`]'s moves, 143 bytes a line ([`Wording::Wordy`]).
fn wordy_program(feed_mm_min: u32, step_um: i64) -> String {
    fine_lines(-250, 10_000, step_um, feed_mm_min, Wording::Wordy)
}

/// Streams `program` to the emulated fast machine; returns the gaps, the machine seconds and
/// the seconds the board says the job lost to starvation. Every step must arrive, whatever the
/// model does to the timing: X ends at `x_end_steps` (160 steps/mm).
fn stream_starved(program: &str, cpu: Option<CpuModel>, x_end_steps: i64) -> (u64, f64, f64) {
    let mut board = EmulatedBoard::new(fast_machine());
    board.set_cpu_model(cpu);
    let mut client = Client::connect(board, 2000).unwrap();
    let report = stream_program(&mut client, &Program::from_text(program), &mut |_| {
        Flow::Continue
    })
    .unwrap();
    assert!(report.completed, "{:?}", report.errors);
    assert_eq!(client.transport.isr.kernel.position()[0], x_end_steps);
    (
        client.transport.starved.gaps,
        report.elapsed_ms as f64 / 1000.0,
        report.final_status.unwrap().starved_ms as f64 / 1000.0,
    )
}

/// [`stream_starved`] without the starved time.
fn stream(program: &str, cpu: Option<CpuModel>, x_end_steps: i64) -> (u64, f64) {
    let (gaps, seconds, _) = stream_starved(program, cpu, x_end_steps);
    (gaps, seconds)
}

/// The board's starved time (machine/src/device/starvation.rs) is the time the job took beyond
/// its planned time because the planner held too little. 0.02 mm lines at F30000 need ~11,000
/// lines/s; written with 143 bytes each ([`wordy_program`]) the in-process link delivers ~5,300
/// a second (the board takes at most 512 B a pass, in the tick's pass and in the one each write
/// wakes), the planner runs short, and the job takes ~0.4 s longer than the same moves written
/// short and fed in time (1.49 s without the CPU model, `simulate` plans 1.46 s), ~0.7 s with the
/// F411 model. The starved time accounts for that time within a few percent, with the F411 model
/// and without it, and the short-line job fed in time loses next to nothing.
///
/// Written short, the same job on the F411 model is bound by the CPU instead: the planner stays
/// full, the kernel runs dry between long passes, and the report counts underruns
/// ([`the_f411_model_starves_the_kernel_only_where_the_f411_would`]), not starvation.
#[test]
fn the_starved_time_is_the_time_beyond_the_plan() {
    let (_, fed_in_time, starved_fed) = stream_starved(&fine_program(30_000, 20), None, -8_000);
    let wordy = wordy_program(30_000, 20);
    for cpu in [None, Some(CpuModel::F411)] {
        let (gaps, took, starved) = stream_starved(&wordy, cpu, -8_000);
        let beyond = took - fed_in_time;
        eprintln!(
            "F30000 in 143-byte lines, model {}: {took:.3} s, {beyond:.3} s beyond {fed_in_time:.3} s, starved {starved:.3} s, {gaps} underruns",
            cpu.map_or("none", |c| c.name)
        );
        assert!(beyond > 0.25, "{beyond}");
        // Within 5 % and the speed meter's 20 ms window (the starved time is counted from the
        // measured speed, `device/starvation.rs`).
        assert!(
            (starved - beyond).abs() <= 0.05 * beyond + 0.02,
            "starved {starved} s of {beyond} s beyond"
        );
    }
    assert!(starved_fed < 0.01, "{starved_fed}");
    // 0.05 mm lines at F6000 (2,000 lines/s): the model keeps up.
    let (_, _, starved) = stream_starved(&fine_program(6_000, 50), Some(CpuModel::F411), 40_000);
    assert!(starved < 0.01, "{starved}");
}

#[test]
fn the_f411_model_starves_the_kernel_only_where_the_f411_would() {
    // 0.02 mm lines at up to 226 mm/s (the 128-block look-ahead over 2.56 mm at 10 m/s²) is
    // ~11,000 lines/s, more than the ~8,000 a 96 MHz F411 receives, interprets, plans and
    // prepares (firmware/README.md "Measured figures") less the step interrupt's share: X ends
    // at −50 mm.
    let fast = fine_program(30_000, 20);
    let (gaps, with_model) = stream(&fast, Some(CpuModel::F411), -8_000);
    eprintln!("0.02 mm lines at F30000, F411 model: {gaps} underruns, {with_model:.3} s");
    assert!(gaps > 0, "no underrun at 30,000 mm/min");
    let (gaps, without) = stream(&fast, None, -8_000);
    eprintln!("0.02 mm lines at F30000, no model: {gaps} underruns, {without:.3} s");
    assert_eq!(gaps, 0, "underruns without the CPU model");
    // The starved job takes longer than the one whose main loop costs nothing.
    assert!(with_model > without * 1.05, "{with_model} {without}");
    // 0.05 mm lines at 100 mm/s: 2,000 lines/s, well within the F411's budget; X ends at 250 mm.
    let (gaps, t) = stream(&fine_program(6_000, 50), Some(CpuModel::F411), 40_000);
    eprintln!("0.05 mm lines at F6000, F411 model: {gaps} underruns, {t:.3} s");
    assert_eq!(gaps, 0, "underruns at 6,000 mm/min");
}

/// [`fast_machine`] with a jerk limit of 1,000,000 mm/s³ on every axis (A/J = 10 ms at 10 m/s²).
fn fast_jerk_machine() -> Setup {
    let mut setup = fast_machine();
    for a in setup.axes.iter_mut() {
        a.jerk = 1_000_000_000_000;
    }
    setup
}

/// 0.02 mm chords jerk-limited on [`fast_jerk_machine`] with the F411 model: the underruns and
/// machine seconds, and the seconds without the model. X ends at −50 mm, every step there.
fn jerk_chords(feed_mm_min: u32) -> (u64, f64, f64) {
    let program = fine_program(feed_mm_min, 20);
    let run = |cpu: Option<CpuModel>| {
        let mut board = EmulatedBoard::new(fast_jerk_machine());
        board.set_cpu_model(cpu);
        let mut client = Client::connect(board, 2000).unwrap();
        let report = stream_program(&mut client, &Program::from_text(&program), &mut |_| {
            Flow::Continue
        })
        .unwrap();
        assert!(report.completed, "{:?}", report.errors);
        assert_eq!(client.transport.isr.kernel.position()[0], -8_000);
        (
            client.transport.starved.gaps,
            report.elapsed_ms as f64 / 1000.0,
        )
    };
    let (gaps, with_model) = run(Some(CpuModel::F411));
    let (free_gaps, without) = run(None);
    assert_eq!(
        free_gaps, 0,
        "underruns without the CPU model at F{feed_mm_min}"
    );
    eprintln!(
        "0.02 mm lines at F{feed_mm_min}, jerk-limited: F411 model {gaps} underruns, \
         {with_model:.3} s; no model {without:.3} s"
    );
    (gaps, with_model, without)
}

#[test]
fn the_f411_model_keeps_up_with_jerk_limited_chords_to_7500_a_second() {
    // The jerk-limited braking in the 128-block look-ahead (2.56 mm of 0.02 mm chords) still
    // allows ~180 mm/s, so the feed sets the line rate. The model charges each segment the
    // jerk-limited figure of 0.1 mm lines (two segments a line there: half a tracker step
    // each), more than a 2 ms step over ~16 blocks costs. At F9000, 7,500 lines a second: no
    // underrun.
    let (gaps, with_model, without) = jerk_chords(9_000);
    assert_eq!(gaps, 0, "underruns at 7,500 lines/s");
    assert!(with_model <= without * 1.005, "{with_model} {without}");
    // At F9600, 8,000 lines a second (the trapezoid's limit on this model: no underrun there,
    // `the_f411_model_starves_the_kernel_only_where_the_f411_would` runs F30000), the kernel
    // runs dry a few times and the job loses a few ms.
    let (gaps, with_model, without) = jerk_chords(9_600);
    assert!(gaps < 100, "{gaps} underruns at 8,000 lines/s");
    assert!(with_model <= without * 1.01, "{with_model} {without}");
}

//! The emulated board's underrun count through the `gantry` binary: `gantry emulate --pty
//! --cpu-model f411` logs each time its step kernel ran dry mid-job ("N so far") and, at each
//! state change, the count the main loop keeps ("underruns N"). Both are the one count of the
//! core's main loop (machine/src/device/underruns.rs); before, the first was the emulator's own
//! and the second the main loop's pass count, and they disagreed.

mod serial_support;

use serial_support::*;
use std::time::Duration;

/// The last figure after `key` on a line of `log` that contains `key`.
fn last_figure(log: &str, key: &str, end: &str) -> Option<u64> {
    log.lines().rev().find_map(|l| {
        let rest = &l[l.find(key)? + key.len()..];
        let figure = rest.split(end).next()?;
        figure.trim().parse().ok()
    })
}

#[test]
fn the_emulators_underrun_log_and_its_main_loop_count_agree() {
    let dir = Dir::new("underruns-cli");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let emu = Emulator::start_with(&dir, Some(&setup), &["--cpu-model", "f411"]);
    // 3,000 moves of 0.005 mm along X at 6000 mm/min: 20,000 lines a second, twice what the
    // F411 model interprets and plans, so the kernel runs dry again and again mid-job.
    let mut program = String::from("G21 G91 G1 F6000\n");
    for _ in 0..3_000 {
        program.push_str("X0.005\n");
    }
    program.push_str("M30\n");
    let job = dir.file("fine.ngc", &program);
    let out = gantry(
        &["--port", emu.port(), "stream", job.to_str().unwrap()],
        Duration::from_secs(60),
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    // The state lines: Run, then Idle at the job's end, each followed by the count.
    let back_to_idle = |l: &str| {
        let (run, idle) = (l.rfind(" Run line"), l.rfind(" Idle line"));
        run.is_some() && idle > run && l.rfind("emulate: underruns") > idle
    };
    assert!(
        emu.wait_log(Duration::from_secs(5), back_to_idle),
        "{}",
        emu.log()
    );
    let log = emu.log();
    let gaps = last_figure(&log, "mid-job (", " so far").expect("an underrun was logged");
    let counted = last_figure(&log, "emulate: underruns ", "\n").unwrap();
    eprintln!("{gaps} underruns logged, {counted} counted");
    assert!(gaps > 0);
    assert_eq!(gaps, counted, "{log}");
}

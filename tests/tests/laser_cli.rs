//! Laser mode as users run it (docs/laser-plasma.md): the `gantry` binary against
//! `gantry emulate --pty`, and `gantry simulate --vcd`'s trace of the laser PWM beside the step
//! pins.

mod serial_support;

use host_sender::vcd::read_vcd;
use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);
const LASER_SETUP: &str = "[spindle]\nlaser = true\nrpm_range = [0, 1000]\npwm_range = [0, 1000]\n";

/// The S of pixel `k`: 100-999, never the same twice in a row.
fn s_of(k: usize) -> u32 {
    100 + (k as u32 * 37) % 900
}

/// 200 pixels of 0.5 mm, each `G1 X… S…` under M4 at F1200 (a LightBurn-style raster line).
fn raster_200() -> String {
    let mut p = String::from("G21 G90 G94\nM4 S0\nF1200\n");
    for k in 0..200 {
        p += &format!("G1 X{:.1} S{}\n", 0.5 * (k + 1) as f64, s_of(k));
    }
    p + "M5\nM2\n"
}

/// A number after `key` in `text` (`total time: 5.123 s` → 5.123).
fn number_after(text: &str, key: &str) -> f64 {
    let at = text
        .find(key)
        .unwrap_or_else(|| panic!("no {key:?} in {text}"))
        + key.len();
    text[at..]
        .split_whitespace()
        .next()
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("no number after {key:?} in {text}"))
}

/// Seconds of the emulated board's clock from the first `Run` state line to the `Idle` after it.
fn board_run_seconds(log: &str) -> f64 {
    let time_of = |l: &str| -> f64 {
        l.trim_start_matches("emulate: ")
            .split(" s ")
            .next()
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("no time in {l:?}"))
    };
    let mut lines = log
        .lines()
        .filter(|l| l.starts_with("emulate: ") && l.contains(" pulses "));
    let run = lines
        .by_ref()
        .find(|l| l.contains(" s Run "))
        .unwrap_or_else(|| panic!("no Run state line in {log}"));
    let idle = lines
        .find(|l| l.contains(" s Idle "))
        .unwrap_or_else(|| panic!("no Idle state line after Run in {log}"));
    time_of(idle) - time_of(run)
}

#[test]
fn a_varying_s_raster_under_m4_streams_in_its_planned_time_and_the_status_shows_the_laser() {
    let dir = Dir::new("laser-stream");
    let setup = dir.file("laser.toml", LASER_SETUP);
    let job = dir.file("raster.nc", &raster_200());
    let planned = gantry(
        &[
            "simulate",
            job.to_str().unwrap(),
            "--setup",
            setup.to_str().unwrap(),
        ],
        60 * S,
    );
    assert_eq!(planned.code, Some(0), "{planned:?}");
    let planned = number_after(&planned.stdout, "total time:");
    assert!(planned < 5.3, "planned {planned} s");
    let emu = Emulator::start(&dir, Some(&setup));
    let out = gantry(
        &["stream", job.to_str().unwrap(), "--port", emu.port()],
        120 * S,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    // The board's own clock, from its state lines (`emulate: T s Run …` to the `Idle` that ends
    // the job), not the sender's report, which is the host's link time: on a loaded test machine
    // the sender starts feeding late and its report grows, while the board, which holds every
    // line of this job within its first pass, runs the plan.
    assert!(wait_for(10 * S, || {
        let log = emu.log();
        log.find(" s Run ")
            .is_some_and(|at| log[at..].contains(" s Idle "))
    }));
    let took = board_run_seconds(&emu.log());
    assert!(
        took <= planned * 1.02 && took > planned * 0.9,
        "streamed in {took} s, planned {planned} s: {}",
        out.stdout
    );
    assert!(out.stdout.contains("X 100.000"), "{}", out.stdout);
    let st = gantry(&["status", "--port", emu.port()], 10 * S);
    assert!(
        st.stdout.contains("outputs:   laser off, power 0.0 %"),
        "{}",
        st.stdout
    );
}

/// A constant-duty stretch of the trace: its duty, the X and Y steps before it and in it, and
/// its start and end (ns).
#[derive(Debug)]
struct Stretch {
    duty: u64,
    at: (usize, usize),
    steps: usize,
    from: u64,
    to: u64,
}

#[test]
fn the_vcd_records_the_pwm_duty_per_segment_as_s_times_speed_over_f_and_zero_in_g0() {
    let dir = Dir::new("laser-vcd");
    let setup = dir.file("laser.toml", LASER_SETUP);
    // G0 out, 100 pixels along X, 100 up Y (the corner between them decelerates), G0 home.
    let mut p = String::from("G21 G90 G94\nM4 S0\nG0 X2\nF1200\n");
    for k in 0..100 {
        p += &format!("G1 X{:.1} S{}\n", 2.0 + 0.5 * (k + 1) as f64, s_of(k));
    }
    for k in 100..200 {
        p += &format!("G1 Y{:.1} S{}\n", 0.5 * (k - 99) as f64, s_of(k));
    }
    p += "G0 X0 Y0\nM5\nM2\n";
    let job = dir.file("corner.nc", &p);
    let vcd = dir.0.join("corner.vcd");
    let out = gantry(
        &[
            "simulate",
            job.to_str().unwrap(),
            "--setup",
            setup.to_str().unwrap(),
            "--vcd",
            vcd.to_str().unwrap(),
        ],
        120 * S,
    );
    assert_eq!(out.code, Some(0), "{out:?}");
    let trace = read_vcd(&std::fs::read_to_string(&vcd).unwrap()).unwrap();
    let pwm = &trace.values["laser_pwm"];
    let xs = &trace.rise_times["x_step"];
    let ys = &trace.rise_times["y_step"];
    // Steps at or after `from` and before `to`.
    let count = |v: &Vec<u64>, from: u64, to: u64| {
        v.partition_point(|&t| t < to) - v.partition_point(|&t| t < from)
    };
    let mut st = Vec::new();
    for w in pwm.windows(2) {
        let ((from, duty), (to, _)) = (w[0], w[1]);
        st.push(Stretch {
            duty,
            at: (
                xs.partition_point(|&t| t < from),
                ys.partition_point(|&t| t < from),
            ),
            steps: count(xs, from, to) + count(ys, from, to),
            from,
            to,
        });
    }
    // 640 steps/mm: the G0 out is 1280 X steps, a pixel 320.
    let pixel_at = |(x, y): (usize, usize)| -> Option<usize> {
        if y == 0 && x < 1280 {
            return None;
        }
        let k = if y == 0 {
            (x - 1280) / 320
        } else {
            100 + y / 320
        };
        (k < 200).then_some(k)
    };
    let nm_per_step = 5_000_000.0 / 3200.0;
    let f = 20_000_000.0; // F1200, nm/s
    let mut checked = 0;
    for s in st.iter().filter(|s| s.steps > 0) {
        let speed = s.steps as f64 * nm_per_step * 1e9 / (s.to - s.from) as f64;
        let expected = pixel_at(s.at).map_or(0.0, |k| f64::from(s_of(k)) * (speed / f).min(1.0));
        assert!(
            (s.duty as f64 - expected).abs() <= 1.0,
            "duty {} where S × speed ÷ F is {expected:.2}: {s:?}",
            s.duty
        );
        checked += 1;
    }
    assert!(checked > 200, "{checked} stretches");
    // The G0 out and the G0 home ran with the beam off; it ends off.
    assert_eq!(st[0].duty, 0);
    assert_eq!(pwm.last().unwrap().1, 0);
    assert_eq!(xs.len(), 1280 + 32_000 + 33_280);
}

//! `gantry serve` must not go deaf when the board's buffers are full. A job of
//! thousands of 0.05 mm moves keeps the board's line buffer and planner full; `status`, `hold`,
//! `override`, `resume` and `abort` from other processes must each act at once (they used to
//! fail after 3.3 s with "cannot read the board's setup": each command's setup request queued
//! behind the job's lines).
//!
//! The latencies (from the command's start to the board's state change in the emulator's log, or
//! to the command's exit) are printed (`--no-capture` shows them); the asserted bounds are
//! generous, so a loaded machine does not fail the test, but far below the old 3.3 s failure.

mod serial_support;

use serial_support::*;
use std::time::{Duration, Instant};

const S: Duration = Duration::from_secs(1);

/// A bound no command may take to act, even on a loaded machine (the goal is 100 ms).
const ACT_WITHIN: Duration = Duration::from_millis(1500);

/// Waits (polling every 2 ms, at most `limit`) until the emulator logs a state line after the
/// first `seen` lines that contains `what`; the time it took from `since`.
fn state_logged(
    emu: &Emulator,
    seen: usize,
    what: &str,
    since: Instant,
    limit: Duration,
) -> Option<Duration> {
    while since.elapsed() < limit {
        let log = emu.log();
        let found = log
            .lines()
            .filter(|l| l.contains(" pulses "))
            .skip(seen)
            .any(|l| l.contains(what));
        if found {
            return Some(since.elapsed());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    None
}

fn state_lines(emu: &Emulator) -> usize {
    emu.log().lines().filter(|l| l.contains(" pulses ")).count()
}

/// `gantry ARGS` run to its end; its exit, output and how long it took.
fn timed(args: &[&str]) -> Out {
    gantry(args, 10 * S)
}

#[test]
fn under_gantry_serve_commands_act_at_once_while_a_short_segment_job_fills_the_buffers() {
    let dir = Dir::new("serve-busy");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    // 6000 moves of 0.05 mm, back and forth (each reverses: the planner cannot blend them, the
    // buffers stay full for the whole job).
    let mut job = String::from("G21 G91\n");
    for i in 0..6000 {
        job.push_str(if i % 2 == 0 {
            "G1 X0.05 F600\n"
        } else {
            "G1 X-0.05 F600\n"
        });
    }
    job.push_str("M30\n");
    let job = dir.file("short.nc", &job);
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    let sender = spawn(&["stream", job.to_str().unwrap(), "--port", port]);
    assert!(emu.wait_log(10 * S, |l| l.contains(" Run line")));
    // The board's buffers fill within a second.
    let mut lines_buffered = 0;
    let mut status_ms = Vec::new();
    assert!(
        wait_for(10 * S, || {
            let out = timed(&["status", "--port", port]);
            assert_eq!(out.code, Some(0), "status during the job: {out:?}");
            status_ms.push(out.took.as_millis());
            let buffers = out
                .stdout
                .lines()
                .find(|l| l.starts_with("buffers:"))
                .unwrap_or("")
                .to_owned();
            // "buffers:   N planner blocks, M lines"
            lines_buffered = buffers
                .split(", ")
                .nth(1)
                .and_then(|t| t.split(' ').next())
                .and_then(|n| n.parse().ok())
                .unwrap_or(0);
            lines_buffered >= 8
        }),
        "the board's line buffer never filled: {lines_buffered} lines"
    );
    for _ in 0..3 {
        let out = timed(&["status", "--port", port]);
        assert_eq!(out.code, Some(0), "{out:?}");
        assert!(out.stdout.starts_with("state:     Run"), "{out:?}");
        assert!(out.took < ACT_WITHIN, "status took {:?}", out.took);
        status_ms.push(out.took.as_millis());
    }

    // Hold: from the command's start to the board's hold in its log.
    let seen = state_lines(&emu);
    let t0 = Instant::now();
    let hold = spawn(&["hold", "--port", port]);
    let hold_acts = state_logged(&emu, seen, "Hold", t0, 5 * S);
    let hold = hold.wait(10 * S);
    assert_eq!(hold.code, Some(0), "{hold:?}");
    assert!(hold.stdout.starts_with("state:     Hold"), "{hold:?}");
    let hold_acts = hold_acts.expect("the board held");
    assert!(hold_acts < ACT_WITHIN, "the hold took {hold_acts:?}");

    // Override while held, and status: both answered at once.
    let over = timed(&["override", "--feed", "50", "--port", port]);
    assert_eq!(over.code, Some(0), "{over:?}");
    assert!(over.stdout.contains("override feed 50 %"), "{over:?}");
    assert!(over.took < ACT_WITHIN, "override took {:?}", over.took);

    // Resume: back to Run.
    let seen = state_lines(&emu);
    let t0 = Instant::now();
    let resume = spawn(&["resume", "--port", port]);
    let resume_acts = state_logged(&emu, seen, "Run", t0, 5 * S).expect("the board ran again");
    let resume = resume.wait(10 * S);
    assert_eq!(resume.code, Some(0), "{resume:?}");
    assert!(resume.stdout.starts_with("state:     Run"), "{resume:?}");
    assert!(resume_acts < ACT_WITHIN, "the resume took {resume_acts:?}");
    // The buffers fill again.
    std::thread::sleep(Duration::from_millis(500));
    let over2 = timed(&["override", "--feed", "100", "--port", port]);
    assert_eq!(over2.code, Some(0), "{over2:?}");
    assert!(over2.took < ACT_WITHIN, "override took {:?}", over2.took);

    // Abort: the job ends at rest (short moves at 10 mm/s: the stop is immediate).
    let seen = state_lines(&emu);
    let t0 = Instant::now();
    let abort = spawn(&["abort", "--port", port]);
    let abort_acts = state_logged(&emu, seen, "Idle", t0, 5 * S).expect("the job ended");
    let abort = abort.wait(10 * S);
    assert_eq!(abort.code, Some(0), "{abort:?}");
    assert!(abort.stdout.starts_with("state:     Idle"), "{abort:?}");
    assert!(abort_acts < ACT_WITHIN, "the abort took {abort_acts:?}");
    let sender = sender.wait(10 * S);
    assert_eq!(sender.code, Some(1), "{sender:?}");
    assert!(sender.stdout.contains("job aborted"), "{sender:?}");

    eprintln!(
        "latencies under a full buffer ({lines_buffered} lines buffered): status command {:?} ms; \
         hold to board Hold {} ms (command {} ms); override command {} ms and {} ms; \
         resume to board Run {} ms (command {} ms); abort to board Idle {} ms (command {} ms)",
        status_ms,
        hold_acts.as_millis(),
        hold.took.as_millis(),
        over.took.as_millis(),
        over2.took.as_millis(),
        resume_acts.as_millis(),
        resume.took.as_millis(),
        abort_acts.as_millis(),
        abort.took.as_millis()
    );
    drop(server);
}

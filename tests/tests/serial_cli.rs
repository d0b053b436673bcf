//! `gantry` run as users run it: the emulated board as its own process behind a pseudo-terminal
//! (`gantry emulate --pty`), each command a separate `gantry` process with `--port`.

mod serial_support;

use nix::sys::signal::Signal;
use serial_support::*;
use std::time::Duration;

const S: Duration = Duration::from_secs(1);

/// Checks a finished `gantry` process: its exit code, and texts its stdout and its stderr must
/// contain; returns it for further checks.
fn check(out: Out, code: i32, stdout_has: &[&str], stderr_has: &[&str]) -> Out {
    assert_eq!(out.code, Some(code), "{out:?}");
    for text in stdout_has {
        assert!(out.stdout.contains(text), "{text:?} in {}", out.stdout);
    }
    for text in stderr_has {
        assert!(out.stderr.contains(text), "{text:?} in {}", out.stderr);
    }
    out
}

/// `gantry stream … --continue` as the operator runs it: the take-over leaves the held job held
/// (docs/controller.md "Only the operator releases a stop") and says so; the operator presses
/// Enter; then the run to its end (at most `limit`).
fn take_over_and_resume(args: &[&str], limit: Duration) -> Out {
    let mut taker = spawn(args);
    assert!(
        wait_for(limit, || taker.stderr().contains("takes over is held")),
        "{}",
        taker.stderr()
    );
    taker.answer("");
    taker.wait(limit)
}

/// `gantry args` (10 s at most), checked as [`check`] does.
fn run(args: &[&str], code: i32, stdout_has: &[&str], stderr_has: &[&str]) -> Out {
    check(gantry(args, 10 * S), code, stdout_has, stderr_has)
}

/// A fresh emulated board with the setup `setup_text` and [`zigzag`]`(400)` as `job.nc`, both
/// in `dir`: the board and the job's path.
fn zigzag_board(dir: &Dir, setup_text: &str) -> (Emulator, std::path::PathBuf) {
    let setup = dir.file("setup.toml", setup_text);
    let job = dir.file("job.nc", &zigzag(400));
    (Emulator::start(dir, Some(&setup)), job)
}

/// Starts `gantry stream job` on `emu` and returns once the board runs it (10 s at most).
fn stream_running(emu: &Emulator, job: &std::path::Path) -> Running {
    let sender = spawn(&["stream", job.to_str().unwrap(), "--port", emu.port()]);
    assert!(emu.wait_log(10 * S, |l| l.contains(" Run line")));
    sender
}

/// `gantry status --port P`'s first line (`state:     Idle`) and the whole text.
fn status(port: &str) -> (String, String) {
    let out = run(&["status", "--port", port], 0, &[], &[]);
    let first = out.stdout.lines().next().unwrap_or("").to_owned();
    (first, out.stdout)
}

#[test]
fn zero_nan_and_sub_nanometre_jogs_are_refused_and_nothing_moves() {
    let dir = Dir::new("jog-refused");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    for (distance, says) in [
        ("0", "must be at least 0.000001 mm"),
        ("nan", "not a number"),
        ("inf", "not a number"),
        ("-0.0000001", "must be at least 0.000001 mm"),
    ] {
        let out = gantry(&["jog", "X", distance, "--port", port], 10 * S);
        assert_eq!(out.code, Some(2), "jog X {distance}: {out:?}");
        assert!(
            out.stderr.contains(says),
            "jog X {distance}: {}",
            out.stderr
        );
    }
    check(
        gantry(
            &["jog", "X", "5", "--feed", "0.0001", "--port", port],
            10 * S,
        ),
        2,
        &[],
        &["below 0.001 mm/min"],
    );
    // Beyond the travel (X is -300..300 mm): the board's error 900, exit 1.
    run(
        &["jog", "X", "400", "--port", port],
        1,
        &["jog refused: error 900: move exceeds the machine travel"],
        &[],
    );
    let (state, text) = status(port);
    assert_eq!(state, "state:     Idle");
    assert!(
        text.contains("machine:   X 0.000  Y 0.000  Z 0.000"),
        "{text}"
    );
    assert_eq!(emu.last_counts().1, "X 0 Y 0 Z 0", "no step pulse at all");
    // A real jog still works: 2.5 mm = 1600 steps.
    run(
        &["jog", "X", "2.5", "--port", port],
        0,
        &["machine:   X 2.500"],
        &[],
    );
    assert!(emu.wait_log(2 * S, |l| l.contains("Idle line 0 steps X 1600 Y 0 Z 0")));
}

#[test]
fn in_alarm_11_mdi_stream_and_jog_print_the_alarm_and_exit_non_zero() {
    let dir = Dir::new("alarm-11");
    let setup = dir.file(
        "setup.toml",
        "[homing]\nrequired = true\n[homing.axis.X]\npriority = 1\n",
    );
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let (state, _) = status(port);
    assert_eq!(state, "state:     Alarm");
    run(
        &["mdi", "G0 X1", "--port", port],
        2,
        &[],
        &["alarm 11", "gantry home"],
    );
    let job = dir.file("job.nc", "G0 X1\nM30\n");
    run(
        &["stream", job.to_str().unwrap(), "--port", port],
        2,
        &[],
        &["alarm 11"],
    );
    run(
        &["jog", "X", "1", "--port", port],
        1,
        &["jog refused: the board is in alarm 11"],
        &[],
    );
    // --port after the subcommand or before it, or from GANTRY_PORT: the same board.
    let out = gantry(&["--port", port, "status"], 10 * S);
    assert!(out.stdout.starts_with("state:     Alarm"), "{out:?}");
    assert_eq!(emu.last_counts().1, "X 0 Y 0 Z 0", "no step pulse at all");
}

#[test]
fn machine_commands_without_a_port_refuse_the_fresh_emulated_board() {
    for args in [
        &["hold"][..],
        &["resume"],
        &["abort"],
        &["override", "--feed", "50"],
        &["jog", "X", "1"],
        &["mdi", "G0 X1"],
        &["unlock"],
    ] {
        let out = gantry(args, 10 * S);
        assert_eq!(out.code, Some(2), "{args:?}: {out:?}");
        assert!(
            out.stderr.contains("--emulated"),
            "{args:?}: {}",
            out.stderr
        );
    }
    run(&["jog", "X", "1", "--emulated"], 0, &[], &[]);
}

/// Runs `job` to its end on a fresh board and returns the board's final (steps, pulses).
fn uninterrupted(dir: &Dir, setup: &std::path::Path, job: &str) -> (String, String) {
    let emu = Emulator::start(dir, Some(setup));
    check(
        gantry(&["stream", job, "--port", emu.port()], 30 * S),
        0,
        &[],
        &[],
    );
    assert!(emu.wait_log(5 * S, |l| l.contains("Idle line 402")));
    emu.last_counts()
}

#[test]
fn a_sender_killed_mid_job_is_continued_and_the_job_ends_like_an_uninterrupted_run() {
    let dir = Dir::new("continue");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let job = dir.file("job.nc", &zigzag(400));
    let job = job.to_str().unwrap();
    let reference = uninterrupted(&dir, &setup, job);
    assert_eq!(
        reference.1, "X 38400 Y 5120 Z 0",
        "400 × 0.15 mm and 400 × 0.02 mm"
    );

    let dir2 = Dir::new("continue-2");
    let emu = Emulator::start(&dir2, Some(&setup));
    let port = emu.port();
    let sender = spawn(&["stream", job, "--port", port]);
    assert!(emu.wait_log(10 * S, |l| l.contains(" Run line")));
    std::thread::sleep(Duration::from_millis(500));
    sender.signal(Signal::SIGKILL);
    drop(sender);
    // The port closed with DTR dropped: the board holds on its path.
    assert!(emu.wait_log(5 * S, |l| l.contains("DTR drop")));
    assert!(emu.wait_log(5 * S, |l| l.contains("Hold (at rest)")));
    let out = check(
        take_over_and_resume(&["stream", job, "--continue", "--port", port], 30 * S),
        0,
        &["job done: last line 402 of 402"],
        &[],
    );
    // The lines the killed sender never sent came through the board's program request.
    assert!(
        out.stdout.contains("1 subprogram jumps served"),
        "{}",
        out.stdout
    );
    assert!(!out.stdout.contains(", 0 lines sent"), "{}", out.stdout);
    assert!(emu.wait_log(5 * S, |l| l.contains("Idle line 402")));
    assert_eq!(emu.last_counts(), reference);
}

#[test]
fn ctrl_c_asks_while_the_link_runs_then_resumes_or_aborts() {
    let dir = Dir::new("ctrl-c");
    let setup = dir.file("fast.toml", FAST_SETUP);
    let job = dir.file("job.nc", &zigzag(400));
    let job = job.to_str().unwrap();
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();

    // Ctrl-C, wait past host_lost_stop_s (1 s), answer "n": the job resumes and completes.
    let mut sender = spawn(&["stream", job, "--port", port]);
    assert!(emu.wait_log(10 * S, |l| l.contains(" Run line")));
    // By the sender's first progress line its Ctrl-C handler is set.
    assert!(wait_for(10 * S, || sender
        .stdout()
        .contains("progress: line")));
    sender.signal(Signal::SIGINT);
    assert!(wait_for(5 * S, || sender
        .stderr()
        .contains("abort the job? [y/N]")));
    assert!(emu.wait_log(5 * S, |l| l.contains("Hold (at rest)")));
    std::thread::sleep(Duration::from_millis(2000));
    // The sender kept the link alive while asking: no alarm 20, no DTR drop.
    assert!(!emu.log().contains("Alarm"), "{}", emu.log());
    assert_eq!(status_via_log(&emu), "Hold (at rest)");
    sender.answer("n");
    check(
        sender.wait(30 * S),
        0,
        &["job done: last line 402 of 402"],
        &[],
    );
    assert!(!emu.log().contains("Alarm"), "{}", emu.log());

    // Ctrl-C, answer "y": the job aborts on its path and ends at rest.
    // Ctrl-C once this job runs, by its first progress line (not a fixed time after the spawn:
    // a loaded machine starts the sender later, and a Ctrl-C before its handler is set kills it).
    let mut sender = spawn(&["stream", job, "--port", port]);
    assert!(wait_for(10 * S, || sender
        .stdout()
        .contains("progress: line")));
    sender.signal(Signal::SIGINT);
    assert!(wait_for(5 * S, || sender
        .stderr()
        .contains("abort the job?")));
    sender.answer("y");
    check(
        sender.wait(30 * S),
        1,
        &["job aborted", "state:    Idle"],
        &[],
    );
}

/// Lines still in the board's link queue when an abort comes are dropped while the job stops
/// (`Board::push_line`, `Board::line_room` in machine/src/board/mod.rs), and the line buffer is
/// emptied when the job ends, so the next job's Start never waits behind them (this failed before
/// that fix: the `mdi` hung until the board restarted).
#[test]
fn after_a_stream_is_aborted_the_board_takes_the_next_job_at_once() {
    let dir = Dir::new("abort-next");
    let (emu, job) = zigzag_board(&dir, FAST_SETUP);
    let port = emu.port();
    let mut sender = stream_running(&emu, &job);
    assert!(wait_for(10 * S, || sender
        .stdout()
        .contains("progress: line")));
    sender.signal(Signal::SIGINT);
    assert!(wait_for(5 * S, || sender
        .stderr()
        .contains("abort the job?")));
    sender.answer("y");
    let out = sender.wait(30 * S);
    assert!(out.stdout.contains("job aborted"), "{}", out.stdout);
    run(
        &["mdi", "G90 G0 X1 Y1", "--port", port],
        0,
        &["machine:   X 1.000  Y 1.000"],
        &[],
    );
}

/// The emulator's last logged state.
fn status_via_log(emu: &Emulator) -> String {
    let log = emu.log();
    let line = log.lines().rev().find(|l| l.contains(" pulses ")).unwrap();
    let rest = line.split(" s ").nth(1).unwrap();
    rest.split(" line ").next().unwrap().to_owned()
}

#[test]
fn resume_hold_and_abort_from_separate_processes_end_as_documented() {
    let dir = Dir::new("hold-resume");
    let (emu, job) = zigzag_board(&dir, FAST_SETUP);
    let port = emu.port();
    let sender = stream_running(&emu, &job);
    std::thread::sleep(Duration::from_millis(300));
    sender.signal(Signal::SIGKILL);
    drop(sender);
    assert!(emu.wait_log(5 * S, |l| l.contains("Hold (at rest)")));
    // `resume` waits for the board to run again and closes the port keeping DTR: the board does
    // not take its exit for a hold.
    let out = run(&["resume", "--port", port], 0, &[], &[]);
    assert!(out.stdout.starts_with("state:     Run"), "{}", out.stdout);
    assert!(emu.wait_log(2 * S, |l| l.contains("host closed the port (DTR kept)")));
    let (state, _) = status(port);
    assert_eq!(state, "state:     Run", "{}", emu.log());
    // `hold` returns once the machine is at rest.
    let out = run(&["hold", "--port", port], 0, &[], &[]);
    assert!(out.stdout.starts_with("state:     Hold"), "{}", out.stdout);
    // `abort` returns once the job has ended.
    let out = run(&["abort", "--port", port], 0, &[], &[]);
    assert!(out.stdout.starts_with("state:     Idle"), "{}", out.stdout);
    run(&["mdi", "G90 G0 X0 Y0", "--port", port], 0, &[], &[]);
}

#[test]
fn a_board_restarted_mid_job_stops_the_sender_with_the_resume_command() {
    let dir = Dir::new("board-reset");
    let (mut emu, job) = zigzag_board(&dir, FAST_SETUP);
    let sender = stream_running(&emu, &job);
    std::thread::sleep(Duration::from_millis(500));
    emu.kill();
    std::thread::sleep(Duration::from_millis(300));
    let _emu = Emulator::start(&dir, None);
    check(
        sender.wait(15 * S),
        1,
        &[
            "board reset: the board restarted during the job",
            "--from-line",
        ],
        &[],
    );
}

/// Stops the board's process 0.3 s from now and checks that `sender` warns after 2 s, gives up
/// after 10 s with the `--continue` command, and exits 1.
fn silence_and_expect_the_sender_to_give_up(emu: &Emulator, sender: Running) {
    std::thread::sleep(Duration::from_millis(300));
    nix::sys::signal::kill(emu.pid(), Signal::SIGSTOP).unwrap();
    let stopped = std::time::Instant::now();
    let out = sender.wait(20 * S);
    let after = stopped.elapsed();
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stderr.contains("no word from the board for 2.0 s"),
        "{}",
        out.stderr
    );
    assert!(out.stdout.contains("board silent"), "{}", out.stdout);
    assert!(out.stdout.contains("--continue"), "{}", out.stdout);
    assert!(
        after >= Duration::from_secs(9) && after < Duration::from_secs(13),
        "{after:?}"
    );
}

/// The stream of `zigzag(400)` ended done, with the pulses of an uninterrupted run.
fn zigzag_400_ended_whole(emu: &Emulator, out: &Out) {
    assert!(
        out.stdout.contains("job done: last line 402 of 402"),
        "{}",
        out.stdout
    );
    assert!(emu.wait_log(5 * S, |l| l.contains("Idle line 402")));
    assert_eq!(emu.last_counts().1, "X 38400 Y 5120 Z 0");
}

#[test]
fn a_silent_board_is_reported_and_the_sender_exits_within_its_bound() {
    let dir = Dir::new("silent");
    let (emu, job) = zigzag_board(&dir, FAST_SETUP);
    let sender = stream_running(&emu, &job);
    silence_and_expect_the_sender_to_give_up(&emu, sender);
}

#[test]
fn under_gantry_serve_a_silent_board_is_reported_and_the_sender_exits_within_its_bound() {
    let dir = Dir::new("serve-silent");
    // The held job must outlast the silence: FAST_SETUP's 1 s would end it with alarm 20 if the
    // board's clock ran the stopped 10 s (the emulator skips them; a board whose link was dead
    // that long would not).
    let setup = dir.file(
        "fast.toml",
        &FAST_SETUP.replace("host_lost_stop_s = 1", "host_lost_stop_s = 60"),
    );
    let job = dir.file("job.nc", &zigzag(400));
    let emu = Emulator::start(&dir, Some(&setup));
    let server = spawn(&["serve", "--port", emu.port()]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    let sender = stream_running(&emu, &job);
    silence_and_expect_the_sender_to_give_up(&emu, sender);
    // The server outlives the silence: once the board answers again, the job is taken over
    // and ends as an uninterrupted run would (the serve test below: pulses X 38400 Y 5120).
    nix::sys::signal::kill(emu.pid(), Signal::SIGCONT).unwrap();
    let out = check(
        take_over_and_resume(
            &[
                "stream",
                job.to_str().unwrap(),
                "--continue",
                "--port",
                emu.port(),
            ],
            30 * S,
        ),
        0,
        &[],
        &[],
    );
    zigzag_400_ended_whole(&emu, &out);
    assert!(server.stderr().contains("a command takes over the job"));
}

#[test]
fn under_gantry_serve_status_hold_resume_and_override_from_other_processes_act_during_a_job() {
    let dir = Dir::new("serve");
    let (emu, job) = zigzag_board(&dir, FAST_SETUP);
    let port = emu.port();
    let server = spawn(&["serve", "--port", port]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    let sender = stream_running(&emu, &job);
    let (state, _) = status(port);
    assert_eq!(state, "state:     Run");
    let out = run(&["hold", "--port", port], 0, &[], &[]);
    assert!(out.stdout.starts_with("state:     Hold"), "{}", out.stdout);
    assert!(emu.wait_log(2 * S, |l| l.contains("Hold (at rest)")));
    let out = run(&["resume", "--port", port], 0, &[], &[]);
    assert!(out.stdout.starts_with("state:     Run"), "{}", out.stdout);
    run(
        &["override", "--feed", "50", "--port", port],
        0,
        &["override feed 50 %"],
        &[],
    );
    let out = check(sender.wait(30 * S), 0, &[], &[]);
    zigzag_400_ended_whole(&emu, &out);
}

/// A job stop as the sender shows it: waits for `prompt` on its stderr, checks that the board
/// stands in the state and at the steps it logs as `stopped` (e.g. `ToolChange T3 line 3 steps
/// X 1280`) and has not gone on since (no state logged after it), then presses Enter.
fn stopped_until_enter(sender: &mut Running, emu: &Emulator, prompt: &str, stopped: &str) {
    assert!(
        wait_for(10 * S, || sender.stderr().contains(prompt)),
        "{}",
        sender.stderr()
    );
    std::thread::sleep(Duration::from_millis(400));
    let log = emu.log();
    let last = log.lines().rfind(|l| l.contains(" pulses "));
    assert!(
        last.is_some_and(|l| l.contains(stopped)),
        "wanted {stopped:?} last:\n{log}"
    );
    sender.answer("");
}

#[test]
fn m6_and_m0_stop_with_a_message_and_enter_continues() {
    let dir = Dir::new("m6-m0");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    let job = dir.file(
        "job.nc",
        "G21 G90\nG1 X2 F3000\nT3 M6 (tool 3)\nG1 X4\nM0\nG1 X6\nM30\n",
    );
    let mut sender = spawn(&["stream", job.to_str().unwrap(), "--port", port]);
    // The board waits at the tool change (X 2 mm = 1280 steps) until told to go on; it names
    // the tool in its state (docs/probing.md "Tool change").
    stopped_until_enter(
        &mut sender,
        &emu,
        "line 3: tool change: put tool 3 in the spindle",
        "ToolChange T3 line 3 steps X 1280 ",
    );
    stopped_until_enter(
        &mut sender,
        &emu,
        "line 5: program stop (M0): press Enter",
        "Hold (at rest) line 5 steps X 2560 ",
    );
    check(sender.wait(20 * S), 0, &["job done: last line 7 of 7"], &[]);
    assert!(emu.wait_log(2 * S, |l| l.contains("Idle line 7 steps X 3840")));
}

#[test]
fn m6_moves_to_the_setup_s_tool_change_position_z_first_and_the_job_goes_on_from_there() {
    // docs/probing.md "Tool change": with program.tool_change_position set, each M6 switches the
    // spindle and coolant off, lifts Z to 10 mm, then moves X/Y to (-20, 30) in machine
    // coordinates, and waits there; the next move starts from the change position.
    let dir = Dir::new("m6-position");
    let setup = dir.file(
        "setup.toml",
        "[program]\ntool_change_position = { X = -20.0, Y = 30.0, Z = 10.0 }\n",
    );
    let emu = Emulator::start(&dir, Some(&setup));
    let port = emu.port();
    let job = dir.file("job.nc", TWO_TOOL_JOB);
    let mut sender = spawn(&["stream", job.to_str().unwrap(), "--port", port]);
    // 640 steps per mm: X -20, Y 30, Z 10 mm.
    stopped_until_enter(
        &mut sender,
        &emu,
        "line 5: tool change: put tool 2 in the spindle",
        "ToolChange T2 line 5 steps X -12800 Y 19200 Z 6400 ",
    );
    stopped_until_enter(
        &mut sender,
        &emu,
        "line 8: tool change: put tool 3 in the spindle",
        "ToolChange T3 line 8 steps X -12800 Y 19200 Z 6400 ",
    );
    check(
        sender.wait(20 * S),
        0,
        &["job done: last line 10 of 10"],
        &[],
    );
    // G91 G0 X5 after the second change: 5 mm on from the change position's X -20.
    assert!(
        emu.wait_log(2 * S, |l| l
            .contains("Idle line 10 steps X -9600 Y 19200 Z 6400 ")),
        "{}",
        emu.log()
    );
}

/// Two tools, each M6 after a cut with spindle and flood on (the same job as
/// tests/tests/tool_change.rs runs in process).
const TWO_TOOL_JOB: &str = "G21 G90\nG0 X10 Y5 Z-2\nM3 S1000 M8\nG1 X20 F600\nT2 M6\nG0 X30\nG1 Z-1 F300\nT3 M6\nG91 G0 X5\nM2\n";

/// X reaches full speed (50 mm/s) in 5 s, so an abort's or alarm's deceleration lasts seconds.
const SLOW_X_SETUP: &str = "[axis.X]\nmax_rate = 3000.0\naccel = 10.0\n";

/// The states the emulator logged, in order (`Idle`, `Run`, `Hold (at rest)`, `Alarm 2`, ...).
fn logged_states(emu: &Emulator) -> Vec<String> {
    emu.log()
        .lines()
        .filter(|l| l.contains(" pulses "))
        .map(|l| {
            let rest = l.split(" s ").nth(1).unwrap();
            rest.split(" line ").next().unwrap().to_owned()
        })
        .collect()
}

/// Serves `job` on a fresh emulated board with [`SLOW_X_SETUP`], starts `gantry stream` and
/// returns once X has been moving for 3 s (30 mm/s, 3 s from rest).
fn slow_job_under_serve(dir: &Dir, job: &str) -> (Emulator, Running, Running) {
    let setup = dir.file("slow.toml", SLOW_X_SETUP);
    let job = dir.file("job.nc", job);
    let emu = Emulator::start(dir, Some(&setup));
    let server = spawn(&["serve", "--port", emu.port()]);
    assert!(wait_for(10 * S, || server
        .stderr()
        .contains("is served on")));
    let sender = stream_running(&emu, &job);
    std::thread::sleep(3 * S);
    (emu, server, sender)
}

/// Polls `gantry status` until the feed has fallen below 90 % of the fastest seen in two
/// readings in a row (a stop is decelerating; one low reading under load is not enough); false
/// after 20 s or when the board has left Run.
fn feed_falls(port: &str, emu: &Emulator) -> bool {
    let feed = |text: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with("feed:")).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    let mut fastest = 0.0f64;
    let mut low_readings = 0;
    wait_for(20 * S, || {
        let (_, text) = status(port);
        let f = feed(&text);
        fastest = fastest.max(f);
        low_readings = if f < fastest * 0.9 {
            low_readings + 1
        } else {
            0
        };
        // Past Run: the stop has ended (too late to hold during it).
        low_readings >= 2 || logged_states(emu).len() > 2
    }) && low_readings >= 2
}

/// `gantry hold` while a stop decelerates: it returns at rest in `end` (`Idle`, `Alarm`) with
/// the note that nothing was held.
fn hold_changes_nothing(port: &str, end: &str) {
    let hold = gantry(&["hold", "--port", port], 10 * S);
    assert_eq!(hold.code, Some(0), "{hold:?}");
    assert!(
        hold.stdout.contains(&format!("state:     {end}\n")),
        "{hold:?}"
    );
    assert!(
        hold.stderr.contains("no hold: the job was ending"),
        "{hold:?}"
    );
}

/// The board went Idle → Run → `last` (it never held), its X stopped on the path below
/// `x_below_mm`, and its status shows `state` with spindle and coolant off.
fn ended_at_rest_with_outputs_off(emu: &Emulator, last: &str, x_below_mm: i64, state: &str) {
    assert_eq!(logged_states(emu), ["Idle", "Run", last], "{}", emu.log());
    let x_steps: i64 = emu
        .last_counts()
        .0
        .split(' ')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        x_steps > 30 * 640 && x_steps < x_below_mm * 640,
        "{}",
        emu.log()
    );
    let (first, text) = status(emu.port());
    assert_eq!(first, format!("state:     {state}"));
    assert!(
        text.contains("outputs:   spindle off, coolant off, no tool"),
        "{text}"
    );
}

#[test]
fn a_hold_during_an_abort_from_another_process_does_not_undo_it() {
    let dir = Dir::new("hold-in-abort");
    let (emu, _server, sender) =
        slow_job_under_serve(&dir, "G21 G90 M3 S1000 M8\nG1 X280 F3000\nM30\n");
    let port = emu.port();
    let abort = spawn(&["abort", "--port", port]);
    // The abort decelerates for about 3 s: this hold arrives in the middle of it (not after a
    // fixed delay: under load the abort's own process may take longer than that to start).
    assert!(feed_falls(port, &emu), "{}", emu.log());
    hold_changes_nothing(port, "Idle");
    let abort = abort.wait(10 * S);
    assert_eq!(abort.code, Some(0), "{abort:?}");
    assert!(abort.stdout.starts_with("state:     Idle"), "{abort:?}");
    assert!(
        abort
            .stdout
            .contains("outputs:   spindle off, coolant off, no tool"),
        "{abort:?}"
    );
    // The sender learns that the job was aborted (not done) and where it can resume.
    check(
        sender.wait(10 * S),
        1,
        &["job aborted: last line 2 of 3", "--from-line 2"],
        &[],
    );
    // Stopped on the path, well short of X 280.
    ended_at_rest_with_outputs_off(&emu, "Idle", 200, "Idle");
}

#[test]
fn a_hold_during_an_alarm_2_stop_ends_in_the_alarm_at_rest_with_outputs_off() {
    let dir = Dir::new("hold-in-alarm2");
    // 200 blocks of 1 mm, then one that leaves the travel (X 300 is the edge): the board reads it
    // once its 128-block planner has room (about 4 s into the job, at X 80 mm and 40 mm/s), and
    // then stops on the path at once, some 80 mm before the end of the queued blocks.
    let mut job = String::from("G21 G91 M3 S1000 M8\n");
    job.push_str(&"G1 X1 F3000\n".repeat(200));
    job.push_str("G90 G1 X400\nM30\n");
    let (emu, _server, sender) = slow_job_under_serve(&dir, &job);
    let port = emu.port();
    // The feed rises until the alarm's deceleration begins: hold as soon as it falls.
    assert!(feed_falls(port, &emu), "{}", emu.log());
    hold_changes_nothing(port, "Alarm");
    check(
        sender.wait(10 * S),
        1,
        &["line 202: alarm 2 (soft limit)"],
        &[],
    );
    // Stopped on the path, well short of the 200 mm the queued blocks would have reached.
    ended_at_rest_with_outputs_off(&emu, "Alarm 2", 190, "Alarm");
}

/// A command's answer is the answer to that command. A jog the board refuses
/// (error 900) must not poison the next command: the next jog reports success and moves exactly
/// its distance, an `mdi` after a refused jog completes without the old error.
#[test]
fn a_refused_jog_then_a_good_one_no_stale_answer_exact_motion() {
    let dir = Dir::new("jog-stale");
    let emu = Emulator::start(&dir, None);
    let port = emu.port();
    run(
        &["jog", "X", "5", "--port", port],
        0,
        &["machine:   X 5.000"],
        &[],
    );
    let mut x = 5.0;
    for _ in 0..3 {
        run(
            &["jog", "X", "400", "--port", port],
            1,
            &["jog refused: error 900: move exceeds the machine travel"],
            &[],
        );
        x += 2.0;
        let out = gantry(&["jog", "X", "2", "--port", port], 10 * S);
        assert_eq!(
            out.code,
            Some(0),
            "the good jog after a refused one: {out:?}"
        );
        assert!(!out.stdout.contains("error 900"), "{}", out.stdout);
        assert!(
            out.stdout
                .contains(&format!("machine:   X {x:.3}  Y 0.000")),
            "{}",
            out.stdout
        );
    }
    // 11 mm at 640 steps/mm, and the board at rest there.
    assert!(
        emu.wait_log(2 * S, |l| l.contains("Idle line 0 steps X 7040 Y 0 Z 0")),
        "{}",
        emu.log()
    );
    // The same for a job: an MDI block after a refused jog runs and reports success.
    run(
        &["jog", "X", "-400", "--port", port],
        1,
        &["jog refused: error 900"],
        &[],
    );
    let out = gantry(&["mdi", "G90 G0 X3", "--port", port], 10 * S);
    assert_eq!(out.code, Some(0), "mdi after a refused jog: {out:?}");
    assert!(!out.stdout.contains("error 900"), "{}", out.stdout);
    assert!(
        out.stdout.contains("machine:   X 3.000  Y 0.000"),
        "{}",
        out.stdout
    );
    let (state, text) = status(port);
    assert_eq!(state, "state:     Idle");
    assert!(
        text.contains("machine:   X 3.000  Y 0.000  Z 0.000"),
        "{text}"
    );
    assert_eq!(emu.last_counts().0, "X 1920 Y 0 Z 0");
}

//! The grbl 1.1 front end (`machine/src/device/grbl/`) on the emulated board, byte for byte as a grbl
//! sender sees it: detection, banner, `ok`/`error:N`, realtime bytes, status reports and the
//! `$10` mask, `$` commands and settings, `$J=` jogs, check mode, soft reset mid-job and
//! character counting against the advertised RX buffer.

mod controller_support;

use controller_support::*;
use gantry_emulator::EmulatedBoard;
use gantry_machine::board::State;
use gantry_machine::device::grbl::{BANNER, RX_SIZE};
use gantry_machine::device::link::LinkProtocol;

/// A grbl sender on the emulated board's port.
struct Sender {
    eb: EmulatedBoard,
    seen: String,
}

impl Sender {
    fn new() -> Self {
        Self::with(|_| {})
    }

    fn with(edit: impl FnOnce(&mut gantry_machine::setup::Setup)) -> Self {
        Sender {
            eb: board(edit),
            seen: String::new(),
        }
    }

    fn send(&mut self, bytes: &[u8]) {
        self.eb.receive(bytes);
    }

    fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.eb.run_ms(1);
            let out = self.eb.take_output();
            self.seen.push_str(&String::from_utf8_lossy(&out));
        }
    }

    /// Runs until the text seen contains `what` (panics after `ms`), and returns what was seen,
    /// taking it.
    fn until(&mut self, what: &str, ms: u64) -> String {
        for _ in 0..ms {
            if self.seen.contains(what) {
                return std::mem::take(&mut self.seen);
            }
            self.run(1);
        }
        panic!("no {what:?} within {ms} ms; saw {:?}", self.seen);
    }

    /// Sends `line` and runs until its `ok` (panics after `ms`); what was seen, taken.
    fn answer(&mut self, line: &[u8], ms: u64) -> String {
        self.send(line);
        self.until("ok\r\n", ms)
    }

    /// The `ok` and `error:N` answers seen, in order.
    fn answers(&self) -> Vec<&str> {
        self.seen
            .lines()
            .filter(|l| *l == "ok" || l.starts_with("error:"))
            .collect()
    }

    /// Asserts that the text seen contains `text`.
    fn assert_seen(&self, text: &str) {
        assert!(self.seen.contains(text), "{:?}", self.seen);
    }

    /// Runs until the board is idle (panics after `ms`): the steps it ends on.
    fn ends_idle(&mut self, ms: u64) -> [i64; 3] {
        until_state(&mut self.eb, State::Idle, ms);
        self.steps()
    }

    /// Runs until a status report starts with `state` (panics after `ms`).
    fn until_state_name(&mut self, state: &str, ms: u64) {
        for _ in 0..ms {
            self.run(1);
            if self.status().starts_with(state) {
                return;
            }
        }
        panic!("no {state:?} within {ms} ms; saw {:?}", self.seen);
    }

    fn oks(&self) -> usize {
        self.seen.matches("ok\r\n").count()
    }

    fn status(&mut self) -> String {
        self.seen.clear();
        self.send(b"?");
        let s = self.until(">\r\n", 50);
        let start = s.rfind('<').unwrap();
        s[start..].trim_end().to_owned()
    }

    fn steps(&self) -> [i64; 3] {
        let p = self.eb.isr.kernel.position();
        [p[0], p[1], p[2]]
    }

    fn connected() -> Self {
        let mut s = Self::new();
        s.send(b"\x18");
        s.until(BANNER, 20);
        s
    }
}

#[test]
fn the_first_bytes_choose_the_protocol() {
    use LinkProtocol::{Framed, Grbl};
    let d = LinkProtocol::decide;
    assert_eq!(d(&[0x00]), Some(Framed));
    assert_eq!(
        d(&[0x02, 0x41]),
        Some(Framed),
        "a new endpoint's first COBS code"
    );
    assert_eq!(d(b"G0 X1"), None, "no line end yet");
    assert_eq!(d(b"G0 X1\n"), Some(Grbl));
    assert_eq!(d(b"$I\r"), Some(Grbl));
    assert_eq!(d(&[0x18]), Some(Grbl));
    assert_eq!(d(b"?"), None);
    assert_eq!(LinkProtocol::decide_after_wait(b"?"), Some(Grbl));
    assert_eq!(LinkProtocol::decide_after_wait(b"G0"), None);
    // A framed host whose endpoint ran on: any first byte, then header control bytes or the
    // frame's 0x00 before any line end.
    assert_eq!(d(&[b'?', 0x21, 0x05, b'\n']), Some(Framed));
    assert_eq!(d(&[b'A', b'B', 0x00]), Some(Framed));
    // More bytes than the longest frame (323) without a decision.
    assert_eq!(d(&[b'X'; 330][..]), Some(Grbl));
}

#[test]
fn a_status_request_gets_the_banner_then_an_idle_report() {
    let mut s = Sender::new();
    assert_eq!(s.eb.link.protocol(), LinkProtocol::Undecided);
    s.send(b"?");
    // A lone realtime byte waits UNDECIDED_MS for more, then counts as grbl.
    let seen = s.until(">\r\n", 100);
    assert!(
        seen.starts_with("\r\nGrbl 1.1h ['$' for help]\r\n"),
        "{seen:?}"
    );
    assert!(
        seen.contains("<Idle|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000|Ov:100,100,100>"),
        "{seen:?}"
    );
    assert_eq!(s.eb.link.protocol(), LinkProtocol::Grbl);
    // DTR drop: the next connection chooses again.
    s.eb.set_dtr(false);
    s.run(2);
    assert_eq!(s.eb.link.protocol(), LinkProtocol::Undecided);
}

#[test]
fn send_response_streaming_answers_every_line_and_ends_idle_at_the_exact_steps() {
    let mut s = Sender::connected();
    let program = [
        "G21 G90",
        "G1 X10 Y5 F600",
        "g0 z-2",
        "",
        "(comment)",
        "G1 X0.5 F1200",
    ];
    for line in program {
        let before = s.oks();
        s.send(format!("{line}\n").as_bytes());
        for _ in 0..5000 {
            if s.oks() > before {
                break;
            }
            s.run(1);
        }
        assert_eq!(s.oks(), before + 1, "line {line:?}: {:?}", s.seen);
    }
    assert!(!s.seen.contains("error"), "{:?}", s.seen);
    until_state(&mut s.eb, State::Idle, 20_000);
    s.run(5);
    assert_eq!(s.steps(), [320, 5 * STEPS_PER_MM, -2 * STEPS_PER_MM]);
    assert!(s.status().starts_with("<Idle|MPos:0.500,5.000,-2.000|"));
}

#[test]
fn character_counting_keeps_the_rx_buffer_full_and_loses_no_line() {
    let mut s = Sender::connected();
    // 400 short moves, 0.1 mm each, streamed by grbl's character-counting rule.
    let lines: Vec<String> = (1..=400)
        .map(|i| format!("G1 X{:.1} F3000", i as f64 * 0.1))
        .collect();
    let mut sent = 0;
    let mut in_flight: std::collections::VecDeque<usize> = Default::default();
    let mut answered = 0;
    let mut max_in_flight = 0;
    let mut ms = 0;
    while answered < lines.len() {
        while sent < lines.len() {
            let len = lines[sent].len() + 1;
            if in_flight.iter().sum::<usize>() + len > RX_SIZE {
                break;
            }
            s.send(format!("{}\n", lines[sent]).as_bytes());
            in_flight.push_back(len);
            sent += 1;
        }
        max_in_flight = max_in_flight.max(in_flight.iter().sum::<usize>());
        s.run(1);
        ms += 1;
        assert!(ms < 60_000, "stalled at {answered}");
        let oks = s.oks();
        assert!(!s.seen.contains("error"), "{:?}", s.seen);
        for _ in answered..oks {
            in_flight.pop_front();
        }
        answered = oks;
    }
    assert_eq!(answered, 400);
    assert!(
        max_in_flight > RX_SIZE - 20,
        "buffer kept full: {max_in_flight}"
    );
    assert_eq!(s.ends_idle(20_000)[0], 40 * STEPS_PER_MM);
    // A sender that ignores the count (240 bytes in one write): the board reads from the port
    // only what its receive buffer can take, the rest waits there (flow control), and every
    // line is answered once.
    s.seen.clear();
    let flood = "G4 P0\n".repeat(40);
    s.send(flood.as_bytes());
    s.run(500);
    assert_eq!(s.answers(), vec!["ok"; 40], "{:?}", s.seen);
}

#[test]
fn a_bad_line_gets_its_grbl_error_and_the_next_lines_still_run() {
    let mut s = Sender::connected();
    s.send(b"G1 X1 F600\nG5 X1\nG1 X1 X2\nG0 X2\n");
    s.run(3000);
    let answers = s.answers();
    assert_eq!(
        answers,
        ["ok", "error:20", "error:25", "ok"],
        "{:?}",
        s.seen
    );
    assert_eq!(s.ends_idle(10_000)[0], 2 * STEPS_PER_MM);
}

#[test]
fn feed_hold_resume_and_overrides_act_like_the_framed_messages() {
    let mut s = Sender::connected();
    s.send(b"G1 X20 F600\n");
    s.run(300);
    s.send(b"!");
    s.run(400);
    let st = s.status();
    assert!(st.starts_with("<Hold:0|"), "{st}");
    let held = s.steps()[0];
    s.run(200);
    assert_eq!(s.steps()[0], held, "stands still in the hold");
    s.send(b"~\x91\x91\x94\x96");
    s.run(50);
    assert_eq!(s.eb.board.feed_override(), 119);
    assert_eq!(s.eb.board.motion().planner().rapid_override(), 50);
    let mut saw_ov = false;
    for _ in 0..10 {
        let st = s.status();
        assert!(st.starts_with("<Run|"), "{st}");
        saw_ov |= st.contains("|Ov:119,50,100");
    }
    assert!(saw_ov);
    s.send(b"\x90");
    s.run(5);
    assert_eq!(s.eb.board.feed_override(), 100);
    assert_eq!(s.ends_idle(20_000)[0], 20 * STEPS_PER_MM);
}

#[test]
fn a_soft_reset_mid_job_ends_it_at_rest_and_sends_the_banner_again() {
    let mut s = Sender::connected();
    s.send(b"M3 S1000\nG1 X50 F3000\nG1 X0\n");
    s.run(500);
    assert_eq!(s.eb.board.state(), State::Run);
    let moving = s.steps()[0];
    assert!(moving > 0);
    s.seen.clear();
    s.send(b"\x18");
    let seen = s.until(BANNER, 2000);
    // Decelerated on its path, at rest, spindle off, position kept (no alarm).
    assert_eq!(s.eb.board.state(), State::Idle);
    assert!(s.eb.kernel_drained());
    assert!(!s.eb.board.output_levels().spindle_enable);
    assert!(!seen.contains("ALARM"), "{seen:?}");
    let stopped = s.steps()[0];
    assert!(stopped > moving && stopped < 50 * STEPS_PER_MM);
    s.run(200);
    assert_eq!(s.steps()[0], stopped, "the rest of the job is gone");
    s.answer(b"G0 X0\n", 100);
    assert_eq!(s.ends_idle(10_000)[0], 0);
}

#[test]
fn the_status_mask_chooses_work_or_machine_position_and_buffer_state() {
    let mut s = Sender::connected();
    s.send(b"G10 L20 P1 X-5\n$10=0\n");
    s.until("ok\r\nok\r\n", 500);
    let st = s.status();
    assert!(
        st.starts_with("<Idle|WPos:-5.000,0.000,0.000|FS:0,0|WCO:5.000,0.000,0.000"),
        "{st}"
    );
    s.answer(b"$10=3\n", 100);
    let st = s.status();
    assert!(
        st.starts_with(&format!(
            "<Idle|MPos:0.000,0.000,0.000|Bf:128,{RX_SIZE}|FS:0,0"
        )),
        "{st}"
    );
    s.answer(b"$13=1\n", 100);
    s.answer(b"G53 G0 X25.4\n", 100);
    until_state(&mut s.eb, State::Idle, 10_000);
    s.run(5);
    let st = s.status();
    assert!(st.starts_with("<Idle|MPos:1.0000,0.0000,0.0000|"), "{st}");
}

#[test]
fn dollar_commands_report_and_write_the_setup() {
    let mut s = Sender::connected();
    let seen = s.answer(b"$I\n", 100);
    assert!(seen.contains("[OPT:V,128,128]"), "{seen:?}");
    let seen = s.answer(b"$G\n", 100);
    assert!(
        seen.contains("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]"),
        "{seen:?}"
    );
    let seen = s.answer(b"$$\n", 100);
    for line in ["$0=2", "$100=640.000", "$101=640.000", "$32=0", "$10=1"] {
        assert!(seen.contains(&format!("{line}\r\n")), "{line}: {seen:?}");
    }
    s.answer(b"$100=800\n", 100);
    let a = &s.eb.board.setup().axes[0];
    assert_eq!(a.steps as i64 * MM / a.units_nm, 800);
    s.send(b"$32=2\n$999=1\n$100=abc\n");
    s.run(50);
    s.assert_seen("error:3\r\nerror:3\r\nerror:2\r\n");
    s.seen.clear();
    s.answer(b"$32=1\n", 100);
    assert!(s.eb.board.setup().outputs.laser, "$32=1 sets laser mode");
    let seen = s.answer(b"$$\n", 100);
    assert!(seen.contains("$32=1\r\n"), "{seen:?}");
    s.answer(b"$32=0\n", 100);
    assert!(!s.eb.board.setup().outputs.laser);
    s.seen.clear();
    s.send(b"G10 L2 P1 X3 Y4\n$#\n");
    let seen = s.until("[PRB:", 500);
    assert!(seen.contains("[G54:3.000,4.000,0.000]"), "{seen:?}");
    s.answer(b"$RST=#\n", 100);
    assert_eq!(s.eb.board.interpreter().state().work_offsets[0][0], 0);
    let seen = s.answer(b"$N\n", 100);
    assert!(seen.contains("$N0=\r\n$N1=\r\n"));
    s.send(b"$H\n");
    let seen = s.until("\r\n", 100);
    assert!(seen.contains("error:5"), "no homing set up: {seen:?}");
}

/// The plasma torch's settings by number (docs/grbl.md): grblHAL's plasma plugin numbers
/// (`$350` mode, `$351` THC delay in s, `$356` anti-dive %, `$358` arc-OK timeout in s) and
/// Gantry's own `$450` THC rate, `$451` THC travel; listed by `$$` after the axes, written by
/// `$N=` through the setup's own checks.
#[test]
fn the_torch_settings_have_numbers_listed_and_written_like_the_others() {
    let mut s = Sender::connected();
    let seen = s.answer(b"$$\n", 100);
    let listed: Vec<&str> = seen.lines().filter(|l| l.starts_with('$')).collect();
    // The defaults (docs/laser-plasma.md "Settings"), after the last axis setting below them
    // and before jerk's `$800`+i, in number order.
    let torch = [
        "$350=0",
        "$351=0.500",
        "$356=90",
        "$358=3.000",
        "$450=1200.000",
        "$451=5.000",
    ];
    let at = listed.iter().position(|l| *l == "$132=200.000").unwrap() + 1;
    assert_eq!(listed[at..at + torch.len()], torch, "{seen:?}");
    assert!(listed[at + torch.len()].starts_with("$800="), "{seen:?}");
    for line in [
        "$350=2",
        "$351=1.25",
        "$356=75",
        "$358=0.8",
        "$450=600",
        "$451=2.5",
    ] {
        let seen = s.answer(format!("{line}\n").as_bytes(), 100);
        assert!(!seen.contains("error"), "{line}: {seen:?}");
    }
    let t = s.eb.board.setup().outputs.torch;
    assert!(t.on && t.thc);
    assert_eq!(
        (t.thc_delay_ms, t.thc_anti_dive, t.arc_ok_timeout_ms),
        (1250, 75, 800)
    );
    assert_eq!((t.thc_rate, t.thc_travel), (600 * MM, 2500 * MM / 1000));
    // Mode 3: the torch with arc-OK only, no height control.
    s.answer(b"$350=3\n", 100);
    let t = s.eb.board.setup().outputs.torch;
    assert!(t.on && !t.thc);
    let seen = s.answer(b"$$\n", 100);
    for line in [
        "$350=3",
        "$351=1.250",
        "$358=0.800",
        "$450=600.000",
        "$451=2.500",
    ] {
        assert!(seen.contains(&format!("{line}\r\n")), "{line}: {seen:?}");
    }
    s.seen.clear();
    // Refused, each leaving the setup as it was: mode 1 (arc-voltage THC: no such input), a
    // delay above 10 s, an anti-dive above 100 %, a timeout below 0.1 s, a rate of 0; the
    // torch together with laser mode.
    s.send(b"$350=1\n$351=11\n$356=101\n$358=0.05\n$450=0\n$32=1\n");
    s.run(100);
    assert_eq!(
        s.answers(),
        ["error:3", "error:3", "error:3", "error:3", "error:4", "error:3"]
    );
    assert_eq!(s.eb.board.setup().outputs.torch, t);
    assert!(!s.eb.board.setup().outputs.laser);
    s.seen.clear();
    s.answer(b"$350=0\n", 100);
    assert!(!s.eb.board.setup().outputs.torch.on);
    // The listing fits the output whatever the axis count (here 6).
    let mut s = Sender::with(|st| st.axis_count = 6);
    s.send(b"\x18");
    s.until(BANNER, 500);
    s.seen.clear();
    let seen = s.answer(b"$$\n", 100);
    assert!(seen.contains("$135=600.000\r\n$350=0\r\n"), "{seen:?}");
    assert!(seen.contains("$451=5.000\r\n$800=0.000\r\n"), "{seen:?}");
    assert!(seen.contains("$805=0.000\r\nok\r\n"), "{seen:?}");
}

#[test]
fn jogs_move_exactly_refuse_the_travel_and_cancel() {
    let mut s = Sender::connected();
    s.answer(b"$J=G91 X10 Y-2 F1000\n", 50);
    assert_eq!(s.eb.board.state(), State::Jog);
    assert!(s.status().starts_with("<Jog|"));
    assert_eq!(
        s.ends_idle(10_000)[..2],
        [10 * STEPS_PER_MM, -2 * STEPS_PER_MM]
    );
    // X travels ±300 mm: 400 is beyond it. No F: undefined feed. Unknown word: invalid jog.
    s.send(b"$J=G90 X400 F1000\n$J=X1\n$J=G91 X1 M3 F100\n");
    s.run(50);
    s.assert_seen("error:15\r\nerror:22\r\nerror:16\r\n");
    // A long jog cancelled by 0x85 stops short, and the modal state is untouched (G90).
    s.answer(b"$J=G53 X100 F3000\n", 50);
    s.run(300);
    s.send(&[0x85]);
    until_state(&mut s.eb, State::Idle, 5_000);
    let x = s.steps()[0];
    assert!(x > 10 * STEPS_PER_MM && x < 100 * STEPS_PER_MM, "{x}");
    assert!(s.eb.board.interpreter().state().absolute);
}

#[test]
fn check_mode_interprets_without_moving_and_reports_each_error() {
    let mut s = Sender::connected();
    let seen = s.answer(b"$C\n", 50);
    assert!(seen.contains("[MSG:Enabled]"));
    s.send(b"G1 X10 F100\nG1 X1 X2\nG0 Y3\n");
    s.run(200);
    let answers = s.answers();
    assert_eq!(answers, ["ok", "error:25", "ok"]);
    assert!(s.status().starts_with("<Check|"));
    assert_eq!(s.steps(), [0, 0, 0]);
    let seen = s.answer(b"$C\n", 50);
    assert!(seen.contains("[MSG:Disabled]"));
}

#[test]
fn alarm_locks_gcode_out_until_unlocked() {
    let mut s = Sender::with(|st| {
        st.homing.required = true;
        st.homing.axes[0].priority = 1;
    });
    s.send(b"\x18");
    let seen = s.until("unlock]", 50);
    assert!(seen.contains("[MSG:'$H'|'$X' to unlock]"), "{seen:?}");
    s.send(b"G0 X1\n");
    s.until("error:9\r\n", 50);
    assert!(s.status().starts_with("<Alarm|"));
}

#[test]
fn a_soft_reset_returns_the_modal_state_to_its_defaults() {
    let mut s = Sender::connected();
    s.answer(b"G91 G20 G18 G92 X1\n", 100);
    let seen = s.answer(b"$G\n", 100);
    assert!(seen.contains("G18 G20 G91"), "{seen:?}");
    s.send(b"\x18");
    s.until(BANNER, 100);
    let seen = s.answer(b"$G\n", 100);
    assert!(
        seen.contains("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]"),
        "{seen:?}"
    );
    assert_eq!(s.eb.board.interpreter().state().g92[0], 0);
}

#[test]
fn homing_is_answered_when_it_ends_and_unlocks_the_boot_alarm() {
    let mut eb = board(|s| {
        s.inputs.limit_min = 0b001;
        s.homing.required = true;
        s.homing.axes[0].priority = 1;
        s.homing.axes[0].retract = 2 * MM;
        s.homing.axes[0].home_position = -10 * MM;
    });
    eb.add_switch(0, false, -3 * MM);
    let mut s = Sender {
        eb,
        seen: String::new(),
    };
    s.send(b"\x18");
    s.until("unlock]", 100);
    s.send(b"$$\n$22=0\n$HX\n");
    // Settings change only while idle: in the boot alarm, error 8.
    let seen = s.until("error:8\r\n", 200);
    assert!(seen.contains("$22=1\r\n"), "{seen:?}");
    s.run(50);
    assert_eq!(s.eb.board.state(), State::Homing);
    assert!(s.status().starts_with("<Home|"));
    assert!(!s.seen.contains("ok"), "answered only when homing ends");
    let seen = s.until("ok\r\n", 30_000);
    assert_eq!(s.eb.board.state(), State::Idle);
    assert!(!seen.contains("ALARM"), "{seen:?}");
    assert_eq!(s.steps()[0], -10 * STEPS_PER_MM);
    s.answer(b"G0 X0\n", 100);
}

#[test]
fn a_probe_move_reports_its_trip_in_prb_and_the_tool_change_stop_is_hold() {
    let mut s = Sender::connected();
    s.eb.add_probe_target(gantry_emulator::ProbeTarget::Plane { z: -5_000_000 });
    s.send(b"$#\n");
    assert!(
        s.until("ok\r\n", 50).contains("[PRB:0.000,0.000,0.000:0]"),
        "no probe yet"
    );
    s.send(b"G21 G90 G38.2 Z-20 F100\n");
    // Answered once the probe cycle has ended, as grbl does.
    let mut log = s.until("ok\r\n", 30_000);
    until_state(&mut s.eb, State::Idle, 30_000);
    s.run(5);
    // grbl sends the result by itself, once, when the probe move ends.
    log += &std::mem::take(&mut s.seen);
    assert_eq!(
        log.matches("[PRB:").count(),
        1,
        "one automatic probe message: {log:?}"
    );
    assert!(log.contains("[PRB:0.000,0.000,-5.000:1]\r\n"), "{log:?}");
    s.send(b"$#\n");
    let params = s.until("ok\r\n", 50);
    assert!(params.contains("[PRB:0.000,0.000,-5.000:1]"), "{params}");
    // M6 stops the job at rest for the tool change: grbl senders see Hold:0 and resume with ~.
    s.send(b"T2 M6\nG0 Z0\n");
    let mut held = false;
    for _ in 0..2_000 {
        s.run(1);
        if s.eb.board.state() == State::ToolChange {
            held = true;
            break;
        }
    }
    assert!(held, "{}", s.seen);
    assert!(s.status().starts_with("<Hold:0|"), "{}", s.seen);
    s.send(b"~");
    assert_eq!(s.ends_idle(30_000)[2], 0);
}

/// A sender whose spindle maps 0-10,000 rpm onto PWM counts 0-1000 (duty = rpm / 10).
fn pwm_sender() -> Sender {
    pwm_sender_with(|_| {})
}

/// [`pwm_sender`] with more setup changes.
fn pwm_sender_with(edit: impl FnOnce(&mut gantry_machine::setup::Setup)) -> Sender {
    let mut s = Sender::with(|st| {
        st.outputs.spindle_min_rpm = 0;
        st.outputs.spindle_max_rpm = 10_000;
        st.outputs.pwm_min = 0;
        st.outputs.pwm_max = 1000;
        edit(st);
    });
    s.send(b"\x18");
    s.until(BANNER, 20);
    s
}

#[test]
fn spindle_override_bytes_scale_the_pwm_not_the_programmed_speed() {
    let mut s = pwm_sender();
    s.answer(b"M3 S5000\n", 200);
    until_state(&mut s.eb, State::Idle, 1000);
    let duty = |s: &Sender| s.eb.board.output_levels().spindle_pwm;
    assert_eq!(duty(&s), 500);
    // +10, +1, -10, -1: 110, 111, 101, 100 %.
    let mut seen = Vec::new();
    for b in [0x9Au8, 0x9C, 0x9B, 0x9D] {
        s.send(&[b]);
        s.run(2);
        seen.push((s.eb.board.spindle_override(), duty(&s)));
    }
    assert_eq!(seen, [(110, 550), (111, 555), (101, 505), (100, 500)]);
    s.send(&[0x9A; 12]);
    s.run(2);
    assert_eq!((s.eb.board.spindle_override(), duty(&s)), (200, 1000));
    let st = s.status();
    assert!(
        st.contains("|FS:0,5000|") && st.ends_with("|Ov:100,100,200|A:S>"),
        "{st}"
    );
    s.send(&[0x99]);
    s.run(2);
    assert_eq!((s.eb.board.spindle_override(), duty(&s)), (100, 500));
    s.send(&[0x9B; 10]);
    s.run(2);
    assert_eq!((s.eb.board.spindle_override(), duty(&s)), (10, 50));
    assert_eq!(s.eb.board.outputs().rpm, 5000, "the programmed speed stays");
    let st = s.status();
    assert!(
        st.contains("|FS:0,5000|") && st.ends_with("|Ov:100,100,10|A:S>"),
        "{st}"
    );
}

#[test]
fn coolant_toggles_flip_flood_and_mist_but_not_in_alarm() {
    let mut s = pwm_sender();
    let coolant = |s: &Sender| {
        let l = s.eb.board.output_levels();
        (l.flood, l.mist)
    };
    s.send(&[0xA0]);
    s.run(2);
    assert_eq!(coolant(&s), (true, false));
    assert!(s.status().ends_with("|A:F>"));
    s.send(&[0xA1]);
    s.run(2);
    assert_eq!(coolant(&s), (true, true));
    assert!(s.status().ends_with("|A:FM>"));
    // While a job runs.
    s.send(b"G1 X5 F600\n");
    s.run(100);
    s.send(&[0xA0]);
    s.run(2);
    assert_eq!(s.eb.board.state(), State::Run);
    assert_eq!(coolant(&s), (false, true));
    let st = s.status();
    assert!(st.starts_with("<Run|") && st.ends_with("|A:M>"), "{st}");
    until_state(&mut s.eb, State::Idle, 5000);
    s.send(&[0xA1]);
    s.run(2);
    assert_eq!(coolant(&s), (false, false));
    assert!(!s.status().contains("|A:"));

    let mut s = Sender::with(|st| {
        st.homing.required = true;
        st.homing.axes[0].priority = 1;
    });
    s.send(b"\x18");
    s.until("unlock]", 50);
    s.send(&[0xA0, 0xA1]);
    s.run(5);
    assert_eq!(coolant(&s), (false, false), "no toggle in alarm");
}

#[test]
fn spindle_stop_acts_only_in_a_feed_hold_and_cycle_start_restores_it() {
    let mut s = pwm_sender();
    s.send(b"M4 S3000\nG1 X20 F600\n");
    s.run(300);
    let spindle = |s: &Sender| {
        let l = s.eb.board.output_levels();
        (l.spindle_enable, l.spindle_ccw, l.spindle_pwm)
    };
    assert_eq!(spindle(&s), (true, true, 300));
    s.send(&[0x9E]);
    s.run(2);
    assert_eq!(
        spindle(&s),
        (true, true, 300),
        "no spindle stop while running"
    );
    s.send(b"!");
    s.run(400);
    assert!(s.status().starts_with("<Hold:0|"));
    s.send(&[0x9E]);
    s.run(2);
    assert_eq!(spindle(&s), (false, false, 0));
    let st = s.status();
    assert!(!st.contains("|A:"), "{st}");
    // A second spindle stop switches it back on, a third off again.
    s.send(&[0x9E]);
    s.run(2);
    assert_eq!(spindle(&s), (true, true, 300));
    s.send(&[0x9E]);
    s.run(2);
    assert_eq!(spindle(&s), (false, false, 0));
    let held = s.steps()[0];
    s.send(b"~");
    s.run(2);
    assert_eq!(spindle(&s), (true, true, 300), "cycle start restores it");
    let st = s.status();
    assert!(st.starts_with("<Run|"), "{st}");
    until_state(&mut s.eb, State::Idle, 20_000);
    assert!(held < 20 * STEPS_PER_MM);
    assert_eq!(s.steps()[0], 20 * STEPS_PER_MM);
    assert_eq!(spindle(&s), (true, true, 300));
}

#[test]
fn startup_lines_and_report_settings_are_stored_checked_and_run_after_the_banner() {
    use std::cell::RefCell;
    use std::rc::Rc;
    let mut s = Sender::connected();
    let saved: Rc<RefCell<Option<gantry_machine::setup::Setup>>> = Rc::default();
    let keep = saved.clone();
    s.eb.on_setup_saved(move |st| *keep.borrow_mut() = Some(st.clone()));
    // Checked by parsing, as grbl does: an unknown G code, a modal group violation, a `$`
    // command, a line too long.
    s.send(b"$N1=G5\n$N1=G0 G1 X1\n$N1=$X\n");
    s.send(format!("$N1=G0X{}\n", "1".repeat(70)).as_bytes());
    s.run(20);
    assert_eq!(
        s.seen, "error:20\r\nerror:21\r\nerror:3\r\nerror:11\r\n",
        "{:?}",
        s.seen
    );
    s.seen.clear();
    s.send(b"$N0=g20 G91\n$N1=G0 X2\n$10=3\n$13=1\n$N\n");
    let seen = s.until("$N1=G0X2\r\nok\r\n", 100);
    assert!(seen.contains("$N0=G20G91\r\n"), "{seen:?}");
    assert_eq!(seen.matches("ok\r\n").count(), 5, "{seen:?}");
    s.run(5);
    let stored = saved.borrow().clone().expect("saved to flash");
    assert_eq!(stored.grbl.startup[0].as_str(), "G20G91");
    assert_eq!((stored.grbl.status_mask, stored.grbl.inches), (3, true));

    // A soft reset: the banner, then each line echoed with its answer; they ran.
    s.send(b"\x18");
    let seen = s.until(">G0X2:ok\r\n", 2000);
    assert!(
        seen.ends_with(&format!("{BANNER}\r\n>G20G91:ok\r\n>G0X2:ok\r\n")),
        "{seen:?}"
    );
    until_state(&mut s.eb, State::Idle, 10_000);
    // G20 G91 X2: 2 inches = 50.8 mm.
    assert_eq!(s.steps()[0], 508 * STEPS_PER_MM / 10);
    let seen = s.answer(b"$G\n", 100);
    assert!(seen.contains(" G20 G91 "), "{seen:?}");

    // A restart of the board from its stored setup (the flash blob, and the TOML file the
    // emulator keeps as its flash): the settings and the lines are still there.
    let mut buf = [0u8; gantry_machine::setup::SETUP_BLOB_MAX];
    let blob = stored.to_blob(&mut buf).unwrap();
    let from_flash = gantry_machine::setup::Setup::from_blob(blob).expect("valid blob");
    let toml = host_sender::setup_file::to_toml(&from_flash);
    let reloaded = host_sender::setup_file::SetupFile::parse(&toml).unwrap();
    assert_eq!(reloaded, stored, "{toml}");
    let mut s = Sender {
        eb: EmulatedBoard::new(reloaded),
        seen: String::new(),
    };
    s.send(b"\x18");
    s.until(">G0X2:ok\r\n", 2000);
    assert_eq!(s.ends_idle(10_000)[0], 508 * STEPS_PER_MM / 10);
    assert!(s
        .status()
        .starts_with("<Idle|MPos:2.0000,0.0000,0.0000|Bf:"));
    // `$RST=*` forgets them.
    s.send(b"$RST=*\n$N\n");
    let seen = s.until("$N1=\r\nok\r\n", 200);
    assert!(seen.contains("ok\r\n$N0=\r\n"), "{seen:?}");

    // In alarm no startup line runs.
    let mut s = Sender::with(|st| {
        st.homing.required = true;
        st.homing.axes[0].priority = 1;
        st.grbl.startup[0] = "G0X1".try_into().unwrap();
    });
    s.send(b"\x18");
    let seen = s.until("unlock]\r\n", 50);
    s.run(50);
    assert!(!s.seen.contains('>') && !seen.contains(">G0"), "{seen:?}");
    assert_eq!(s.steps()[0], 0);
}

#[test]
fn a_soft_reset_puts_the_overrides_back_to_100_and_the_coolant_off() {
    let mut s = pwm_sender();
    s.answer(b"M3 S5000\n", 200);
    until_state(&mut s.eb, State::Idle, 1000);
    s.send(&[0x91, 0x91, 0x96, 0x9B, 0xA0, 0xA1]);
    s.run(2);
    let st = s.status();
    assert!(st.contains("|Ov:120,50,90|A:SFM>"), "{st}");
    assert_eq!(s.eb.board.output_levels().spindle_pwm, 450);
    s.send(b"\x18");
    s.until(BANNER, 200);
    s.run(2);
    let l = s.eb.board.output_levels();
    assert_eq!((l.spindle_enable, l.flood, l.mist), (false, false, false));
    assert_eq!(
        (
            s.eb.board.feed_override(),
            s.eb.board.spindle_override(),
            s.eb.board.motion().planner().rapid_override()
        ),
        (100, 100, 100)
    );
    let st = s.status();
    assert!(st.ends_with("|Ov:100,100,100>"), "{st}");
    // The spindle at 5000 rpm again: duty 500 (no 90 % left over).
    s.answer(b"M3 S5000\n", 200);
    until_state(&mut s.eb, State::Idle, 1000);
    assert_eq!(s.eb.board.output_levels().spindle_pwm, 500);
}

#[test]
fn a_probe_line_is_answered_after_its_prb_message() {
    let mut s = Sender::connected();
    s.eb.add_probe_target(gantry_emulator::ProbeTarget::Plane { z: -2_000_000 });
    s.send(b"G21 G90\nG38.2 Z-10 F200\nG0 Z0\n");
    for _ in 0..30_000 {
        if s.oks() == 3 {
            break;
        }
        s.run(1);
    }
    let seen = std::mem::take(&mut s.seen);
    assert_eq!(seen.matches("ok\r\n").count(), 3, "{seen:?}");
    let prb = seen.find("[PRB:0.000,0.000,-2.000:1]").expect(&seen);
    let second_ok = seen.match_indices("ok\r\n").nth(1).unwrap().0;
    assert!(
        prb < second_ok,
        "[PRB] before the probe line's ok: {seen:?}"
    );
    assert_eq!(s.ends_idle(10_000)[2], 0);
}

#[test]
fn the_safety_door_stops_parks_the_outputs_and_resumes_to_the_exact_end() {
    // No spindle spin-up wait here (`door_spin_up_ms = 0`); the wait has its own tests below.
    let mut s = pwm_sender_with(|st| st.grbl.door_spin_up_ms = 0);
    let outputs = |s: &Sender| {
        let l = s.eb.board.output_levels();
        (l.spindle_enable, l.spindle_pwm, l.flood)
    };
    s.send(b"M3 S5000 M8\nG1 X20 F600\n");
    s.run(300);
    assert_eq!(s.eb.board.state(), State::Run);
    s.send(&[0x84]);
    s.run(2);
    // Decelerating: spindle and coolant still on.
    let st = s.status();
    assert!(st.starts_with("<Door:2|"), "{st}");
    assert_eq!(outputs(&s), (true, 500, true));
    // `~` while stopping is ignored.
    s.send(b"~");
    s.until_state_name("<Door:0|", 500);
    assert!(s.eb.kernel_drained());
    assert_eq!(outputs(&s), (false, 0, false), "off at rest");
    let held = s.steps()[0];
    s.run(300);
    assert_eq!(s.steps()[0], held, "the door keeps it at rest");
    assert!(s.status().starts_with("<Door:0|"));
    s.send(b"~");
    s.run(2);
    assert_eq!(outputs(&s), (true, 500, true), "restored before the motion");
    assert!(s.status().starts_with("<Run|"));
    until_state(&mut s.eb, State::Idle, 20_000);
    assert!(held > 0 && held < 20 * STEPS_PER_MM);
    assert_eq!(s.steps(), [20 * STEPS_PER_MM, 0, 0]);

    // In idle: outputs off at once and no line starts before `~`.
    s.seen.clear();
    s.send(&[0x84]);
    s.run(2);
    assert!(s.status().starts_with("<Door:0|"));
    assert_eq!(outputs(&s), (false, 0, false));
    s.send(b"$J=G91 X1 F100\n");
    s.until("error:8\r\n", 100);
    s.send(b"G0 X0\n");
    s.run(300);
    assert_eq!(s.steps()[0], 20 * STEPS_PER_MM);
    assert_eq!(s.oks(), 0, "{:?}", s.seen);
    s.answer(b"~", 100);
    assert_eq!(s.ends_idle(20_000)[0], 0);
    assert_eq!(outputs(&s), (true, 500, true));

    // A jog: cancelled, then parked; a soft reset forgets the door.
    s.answer(b"$J=G91 X10 F1000\n", 100);
    s.run(100);
    s.send(&[0x84]);
    s.until_state_name("<Door:0|", 500);
    let stopped = s.steps()[0];
    assert!(stopped > 0 && stopped < 10 * STEPS_PER_MM);
    s.send(b"\x18");
    s.until(BANNER, 200);
    assert!(s.status().starts_with("<Idle|"));
    assert_eq!(outputs(&s), (false, 0, false));
}

/// Spindle enable, PWM duty and flood coolant as driven.
fn door_outputs(s: &Sender) -> (bool, u16, bool) {
    let l = s.eb.board.output_levels();
    (l.spindle_enable, l.spindle_pwm, l.flood)
}

/// A job with spindle and flood on (`G1 X20 F600`) on a sender with the given spin-up wait,
/// stopped by the door after 300 ms and parked (`Door:0`); the times (kernel timer counts) of
/// every X step from then on are collected.
fn door_parked(spin_up_ms: u16) -> (Sender, std::rc::Rc<std::cell::RefCell<Vec<u64>>>) {
    let mut s = pwm_sender_with(|st| st.grbl.door_spin_up_ms = spin_up_ms);
    let steps = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
    let sink = steps.clone();
    s.eb.observe(move |p| {
        if p.step & 1 != 0 {
            sink.borrow_mut().push(p.time);
        }
    });
    s.send(b"M3 S5000 M8\nG1 X20 F600\n");
    s.run(300);
    s.send(&[0x84]);
    s.run(500);
    assert!(s.status().starts_with("<Door:0|"), "{}", s.seen);
    assert_eq!(door_outputs(&s), (false, 0, false));
    assert!(s.eb.kernel_drained());
    steps.borrow_mut().clear();
    (s, steps)
}

/// `~` to a parked door: spindle and coolant are back on after one millisecond (the next
/// main-loop pass); returns the virtual time the byte was sent, kernel timer counts.
fn close_the_door(s: &mut Sender) -> u64 {
    let sent = s.eb.now();
    s.send(b"~");
    s.run(1);
    assert_eq!(door_outputs(s), (true, 500, true), "restored first");
    sent
}

const COUNTS_PER_MS: u64 = gantry_emulator::COUNTS_PER_MS;

#[test]
fn after_the_door_the_spindle_spins_up_for_the_set_time_before_the_job_resumes() {
    // The reference: no wait (`door_spin_up_ms = 0`): the job resumes at once.
    let (mut s, steps) = door_parked(0);
    let t0 = close_the_door(&mut s);
    assert!(s.status().starts_with("<Run|"));
    until_state(&mut s.eb, State::Idle, 20_000);
    let first_at_once = steps.borrow()[0] - t0;
    let steps_at_once = steps.borrow().len();
    assert!(first_at_once < 10 * COUNTS_PER_MS, "{first_at_once}");
    assert_eq!(s.steps(), [20 * STEPS_PER_MM, 0, 0]);

    // The default 4 s: `Door:3` with spindle and coolant on and nothing moving, then the job
    // resumes exactly 4.000 s later than without the wait and ends on the same steps.
    assert_eq!(
        gantry_machine::setup::Setup::default().grbl.door_spin_up_ms,
        4_000
    );
    let (mut s, steps) = door_parked(4_000);
    let held = s.steps();
    let t = close_the_door(&mut s);
    let st = s.status();
    assert!(st.starts_with("<Door:3|") && st.ends_with("|A:SF>"), "{st}");
    s.send(b"~");
    s.run(3_980);
    assert!(
        s.status().starts_with("<Door:3|"),
        "`~` while spinning up is ignored"
    );
    assert_eq!(s.steps(), held, "nothing moves while the spindle spins up");
    assert!(steps.borrow().is_empty());
    assert_eq!(door_outputs(&s), (true, 500, true));
    until_state(&mut s.eb, State::Idle, 20_000);
    let first = steps.borrow()[0] - t;
    assert_eq!(first, first_at_once + 4_000 * COUNTS_PER_MS);
    assert_eq!(steps.borrow().len(), steps_at_once);
    assert_eq!(s.steps(), [20 * STEPS_PER_MM, 0, 0]);
    assert_eq!(door_outputs(&s), (true, 500, true));

    // With the spindle off there is nothing to wait for.
    let mut s = Sender::connected();
    s.send(b"G1 X5 F600\n");
    s.run(200);
    s.send(&[0x84]);
    s.run(500);
    assert!(s.status().starts_with("<Door:0|"));
    s.send(b"~");
    s.run(2);
    assert!(s.status().starts_with("<Run|"));
    assert_eq!(s.ends_idle(20_000), [5 * STEPS_PER_MM, 0, 0]);
}

#[test]
fn a_door_opened_again_or_a_reset_during_the_spin_up_acts_as_in_grbl() {
    // Opened again 1 s into the spin-up: outputs off again (`Door:0`); the next `~` waits the
    // whole 4 s again.
    let (mut s, steps) = door_parked(4_000);
    let held = s.steps();
    close_the_door(&mut s);
    s.run(1_000);
    s.send(&[0x84]);
    s.run(2);
    assert!(s.status().starts_with("<Door:0|"), "{}", s.seen);
    assert_eq!(door_outputs(&s), (false, 0, false));
    s.run(5_000);
    assert_eq!(s.steps(), held);
    let t = close_the_door(&mut s);
    assert!(s.status().starts_with("<Door:3|"));
    until_state(&mut s.eb, State::Idle, 20_000);
    let first = steps.borrow()[0] - t;
    assert!(
        (4_000 * COUNTS_PER_MS..4_010 * COUNTS_PER_MS).contains(&first),
        "{first}"
    );
    assert_eq!(s.steps(), [20 * STEPS_PER_MM, 0, 0]);

    // A soft reset during the spin-up: the job ends where it stood, outputs off, the door
    // forgotten.
    let (mut s, steps) = door_parked(4_000);
    let held = s.steps();
    close_the_door(&mut s);
    s.run(1_000);
    s.send(b"\x18");
    s.until(BANNER, 200);
    assert!(s.status().starts_with("<Idle|"));
    assert_eq!(door_outputs(&s), (false, 0, false));
    s.run(5_000);
    assert_eq!(s.steps(), held);
    assert!(steps.borrow().is_empty());
    s.answer(b"G0 X0\n", 100);
    assert_eq!(s.ends_idle(20_000), [0, 0, 0]);
}

#[test]
fn a_soft_reset_during_a_jog_stops_it_at_rest_and_check_mode_toggles_mid_stream() {
    let mut s = Sender::connected();
    s.answer(b"$J=G91 X20 F1000\n", 100);
    s.run(200);
    assert_eq!(s.eb.board.state(), State::Jog);
    s.send(b"\x18");
    let seen = s.until(BANNER, 2000);
    assert!(!seen.contains("ALARM"), "{seen:?}");
    assert_eq!(s.eb.board.state(), State::Idle);
    assert!(s.eb.kernel_drained());
    let stopped = s.steps()[0];
    assert!(stopped > 0 && stopped < 20 * STEPS_PER_MM, "{stopped}");
    s.run(200);
    assert_eq!(s.steps()[0], stopped, "the jog's rest is gone");

    // `$C` while the machine moves: error 8, as grbl (its state is not idle).
    s.send(b"G90 G0 X1\n$C\n");
    let seen = s.until("error:8\r\n", 100);
    assert!(seen.starts_with("ok\r\n"), "{seen:?}");
    assert_eq!(s.ends_idle(10_000)[0], STEPS_PER_MM);
    // `$C` between streamed lines at rest: the lines after it are only checked (an error is
    // reported, nothing moves), the second `$C` ends check mode, the last line moves.
    s.seen.clear();
    s.send(b"$C\nG0 X5\nG5\nG0 X9\n$C\nG0 X2\n");
    let mut seen = String::new();
    for _ in 0..10_000 {
        s.run(1);
        if s.seen.contains("[MSG:Disabled]") && s.oks() == 5 {
            seen = std::mem::take(&mut s.seen);
            break;
        }
    }
    assert_eq!(seen.matches("ok\r\n").count(), 5, "{seen:?} {:?}", s.seen);
    assert!(
        seen.contains("[MSG:Enabled]\r\nok\r\nok\r\nerror:20\r\nok\r\n[MSG:Disabled]\r\nok\r\n"),
        "{seen:?}"
    );
    until_state(&mut s.eb, State::Idle, 10_000);
    s.run(5);
    assert_eq!(s.steps()[0], 2 * STEPS_PER_MM);
}

/// Safety: an error line mid-job executes nothing and changes nothing else (grbl's
/// interface.md): the job goes on, the lines after it run with the spindle and coolant the
/// program switched on, and `$G` agrees with the outputs.
#[test]
fn an_error_mid_job_changes_nothing_and_the_next_lines_cut_with_the_spindle_on() {
    let mut s = pwm_sender();
    s.send(b"M3 S5000 M8\nG1 X1 F600\nG1 X11 Q1\nG1 X2\nG1 X3\n");
    let mut cut_with_spindle_off = 0;
    for _ in 0..5000 {
        s.run(1);
        let moving = s.eb.board.state() == State::Run && !s.eb.kernel_drained();
        let o = s.eb.board.outputs();
        if moving && s.steps()[0] > STEPS_PER_MM && (!o.flood || o.rpm != 5000) {
            cut_with_spindle_off += 1;
        }
        if s.answers().len() == 5 && s.eb.board.state() == State::Idle {
            break;
        }
    }
    assert_eq!(
        s.answers(),
        ["ok", "ok", "error:36", "ok", "ok"],
        "{:?}",
        s.seen
    );
    assert_eq!(
        cut_with_spindle_off, 0,
        "moves after the error ran with the spindle or flood off"
    );
    assert_eq!(s.ends_idle(10_000)[0], 3 * STEPS_PER_MM);
    let o = s.eb.board.outputs();
    assert_eq!(
        (o.spindle, o.rpm, o.flood),
        (gantry_machine::canon::Spindle::Cw, 5000, true),
        "outputs after the job"
    );
    s.seen.clear();
    let modes = s.answer(b"$G\n", 100);
    assert!(
        modes.contains(" M3 ") && modes.contains(" M8 "),
        "{modes:?}"
    );
    let st = s.status();
    assert!(st.contains("|A:SF"), "{st}");
}

/// Safety: a grbl sender that goes away mid-job (killed, or closing the port without
/// dropping DTR as pyserial does) is a lost host: the job stops on its path, the lines it left
/// in the buffers never run, spindle and coolant go off at rest, and the next connection is
/// greeted with the banner as a fresh grbl session.
#[test]
fn a_lost_grbl_sender_stops_the_job_switches_the_outputs_off_and_the_next_client_is_greeted() {
    for dtr_dropped in [false, true] {
        let mut s = pwm_sender();
        s.send(b"M3 S5000 M8\nG1 X20 F600\nG1 X40\nG1 X60\n");
        s.until_state_name("<Run", 2000);
        s.run(500);
        if dtr_dropped {
            s.eb.set_dtr(false);
        } else {
            s.eb.close_keeping_dtr();
        }
        let at_close = s.steps()[0];
        s.run(1);
        assert_eq!(s.eb.link.protocol(), LinkProtocol::Undecided);
        until_state(&mut s.eb, State::Idle, 5_000);
        let stopped = s.steps()[0];
        // Decelerated on the path (a few mm at most at 600 mm/min), nothing after.
        assert!(
            stopped >= at_close && stopped < at_close + STEPS_PER_MM,
            "{at_close} -> {stopped}"
        );
        s.run(3000);
        assert_eq!(
            s.steps()[0],
            stopped,
            "buffered lines ran after the sender left"
        );
        let o = s.eb.board.outputs();
        assert_eq!(
            (o.spindle, o.flood),
            (gantry_machine::canon::Spindle::Off, false)
        );
        // The next client: its first bytes choose grbl again and get one banner.
        s.eb.set_dtr(true);
        s.seen.clear();
        s.send(b"\x18");
        s.run(50);
        assert_eq!(s.seen.matches("Grbl 1.1h").count(), 1, "{:?}", s.seen);
        let modes = s.answer(b"$G\n", 100);
        assert!(modes.contains(" M5 ") && modes.contains(" M9"), "{modes:?}");
    }
}

/// A grbl sender that leaves an idle machine with spindle and flood on (an MDI `M3 M8`) switches
/// them off by leaving; `$G` on the next connection says M5 M9.
#[test]
fn a_grbl_sender_leaving_an_idle_machine_switches_spindle_and_coolant_off() {
    let mut s = pwm_sender();
    s.answer(b"M3 S5000 M8\n", 200);
    until_state(&mut s.eb, State::Idle, 1000);
    s.run(10);
    assert!(s.eb.board.outputs().flood);
    s.eb.close_keeping_dtr();
    s.run(2);
    let o = s.eb.board.outputs();
    assert_eq!(
        (o.spindle, o.flood),
        (gantry_machine::canon::Spindle::Off, false)
    );
    s.eb.set_dtr(true);
    s.seen.clear();
    s.send(b"?");
    let seen = s.until(">\r\n", 200);
    assert_eq!(seen.matches("Grbl 1.1h").count(), 1, "{seen:?}");
    assert!(seen.contains("<Idle") && !seen.contains("|A:"), "{seen:?}");
}

/// `M98`/`M99` from a grbl sender are answered once with grbl's unsupported-command
/// error; nothing else changes, the lines after them run and the front end stays usable.
#[test]
fn m98_and_m99_answer_error_20_once_and_the_job_reads_on() {
    let mut s = Sender::connected();
    s.send(b"G1 X1 F600\nM98 P100\nG1 X2\nM99\nG1 X3\n");
    s.run(3000);
    assert_eq!(
        s.answers(),
        ["ok", "error:20", "ok", "error:20", "ok"],
        "{:?}",
        s.seen
    );
    assert!(!s.seen.contains("[MSG:"), "{:?}", s.seen);
    assert_eq!(s.ends_idle(10_000)[0], 3 * STEPS_PER_MM);
    let st = s.status();
    assert!(st.starts_with("<Idle|MPos:3.000,"), "{st}");
}

/// `$C` checks each line from the program's own position, as grbl's parser does: an
/// arc valid from where the program stands passes, incremental moves that add up past the travel
/// fail, and `$C` off soft-resets (one banner; the parser's position is the machine's again).
#[test]
fn check_mode_follows_the_programs_position_and_ends_with_a_soft_reset() {
    let mut s = Sender::connected();
    s.answer(b"$C\n", 100);
    s.seen.clear();
    let travel_mm = s.eb.board.setup().axes[0].travel_max / 1_000_000;
    let step = travel_mm * 2 / 3;
    let program = format!(
        "G90 G0 X10 Y10\nG2 X20 Y10 I5 J0 F300\nG91 G1 X{step}\nG1 X{step}\nG90 G0 X0 Y0\n"
    );
    // Send-response, as most senders stream: each line once the last one is answered.
    for line in program.lines() {
        s.send(format!("{line}\n").as_bytes());
        s.run(50);
    }
    assert_eq!(
        s.answers(),
        ["ok", "ok", "ok", "error:900", "ok"],
        "{:?}",
        s.seen
    );
    assert_eq!(s.steps(), [0, 0, 0], "nothing moved");
    s.seen.clear();
    s.send(b"$C\n");
    s.run(100);
    assert!(s.seen.contains("[MSG:Disabled]"), "{:?}", s.seen);
    assert_eq!(s.seen.matches("Grbl 1.1h").count(), 1, "{:?}", s.seen);
    let seen = s.answer(b"G91 G1 X1 F600\n", 100);
    assert!(seen.contains("ok"), "{seen:?}");
    s.run(2000);
    assert_eq!(
        s.ends_idle(5_000)[0],
        STEPS_PER_MM,
        "from the machine's position"
    );
}

/// The `$110` and `$100` values `$$` shows.
fn listed(s: &mut Sender, number: &str) -> String {
    let seen = s.answer(b"$$\n", 100);
    let prefix = format!("{number}=");
    seen.lines()
        .find(|l| l.starts_with(&prefix))
        .unwrap_or_else(|| panic!("no {number} in {seen:?}"))
        .to_owned()
}

/// Sends `line` and returns what was seen up to and including its `error:N` line.
fn refused(s: &mut Sender, line: &[u8]) -> String {
    s.seen.clear();
    s.send(line);
    let mut seen = s.until("error:", 100);
    s.run(5);
    seen.push_str(&std::mem::take(&mut s.seen));
    seen
}

#[test]
fn a_setting_write_that_breaks_the_setup_is_refused_and_leaves_it_unchanged() {
    let mut s = Sender::connected();
    let before = s.eb.board.setup().clone();
    // Below the 60 mm/min start speed.
    let seen = refused(&mut s, b"$110=10\n");
    assert!(
        seen.contains("[MSG:Refused: start speed above max rate]\r\nerror:3\r\n"),
        "{seen:?}"
    );
    assert_eq!(s.eb.board.setup(), &before);
    assert_eq!(listed(&mut s, "$110"), "$110=3000.000");
    // 100000 steps/mm at 3000 mm/min: 5 M steps/s, beyond the drivers' 200 k.
    let seen = refused(&mut s, b"$100=100000\n");
    assert!(
        seen.contains("[MSG:Refused: step rate too high for the drivers]\r\nerror:12\r\n"),
        "{seen:?}"
    );
    assert_eq!(listed(&mut s, "$100"), "$100=640.000");
    assert_eq!(s.eb.board.setup(), &before);
    // Out of range: the table's range in the message.
    let seen = refused(&mut s, b"$110=300000\n");
    assert!(
        seen.contains("[MSG:Refused: out of range 1.000 to 200000.000]\r\nerror:3\r\n"),
        "{seen:?}"
    );
    let seen = refused(&mut s, b"$0=60\n");
    assert!(
        seen.contains("[MSG:Refused: out of range 1.000 to 50.000]\r\nerror:6\r\n"),
        "{seen:?}"
    );
    assert_eq!(s.eb.board.setup(), &before);
    // Valid writes still go through.
    s.answer(b"$110=2000\n", 100);
    assert_eq!(listed(&mut s, "$110"), "$110=2000.000");
    s.answer(b"$RST=$\n", 100);
    assert_eq!(listed(&mut s, "$110"), "$110=3000.000");
}

#[test]
fn a_setting_write_and_a_setup_file_give_the_same_refusal_from_the_same_check() {
    use gantry_machine::setup::{Key, Reason, SetupError};
    use host_sender::setup_file::SetupFile;
    // Through grbl `$x=`: the setup after the write, validated as `$x=` does.
    let grbl = |number: u16, milli: i64| {
        let mut setup = gantry_machine::setup::Setup::default();
        gantry_machine::device::grbl::settings::write(number, milli, &mut setup).unwrap();
        setup.validate().unwrap_err()
    };
    // Through the setup file (`gantry setup check`/`push`): the core's SetupError is the error.
    let file = |text: &str| {
        let e = SetupFile::parse(text).unwrap_err();
        *e.downcast_ref::<SetupError>()
            .unwrap_or_else(|| panic!("not a SetupError: {e}"))
    };
    for (number, milli, toml, key, reason) in [
        (
            110,
            300_000_000,
            "[axis.X]\nmax_rate = 300000\n",
            Key::MaxRate,
            Reason::OutOfRange,
        ),
        (
            110,
            10_000,
            "[axis.X]\nmax_rate = 10\n",
            Key::StartSpeed,
            Reason::StartAboveMaxRate,
        ),
        (
            26,
            0,
            "[inputs]\ndebounce_ms = 0\n",
            Key::DebounceMs,
            Reason::OutOfRange,
        ),
        (
            11,
            20_000,
            "[path]\njunction_deviation = 20\n",
            Key::JunctionDeviation,
            Reason::OutOfRange,
        ),
        (
            27,
            2_000_000,
            "[homing.axis.X]\nretract = 2000\n",
            Key::Retract,
            Reason::OutOfRange,
        ),
    ] {
        let e = grbl(number, milli);
        assert_eq!(file(toml), e, "${number}");
        assert_eq!((e.key, e.reason), (key, reason), "${number}");
    }
    // 100000 steps/mm on Y: the same ratio in lowest terms (1 step per 10 nm) both ways.
    let e = grbl(101, 100_000_000);
    assert_eq!(file("[axis.Y]\nsteps_per = [1, 0.00001]\n"), e);
    assert_eq!((e.key, e.index), (Key::MaxRate, 1));
    assert!(matches!(e.reason, Reason::StepRateTooHigh { .. }));
    assert_eq!(
        grbl(110, 10_000).to_string(),
        "axis.X.start_speed = 60: must not exceed axis.X.max_rate (10)"
    );
    // And on the emulated board the write is answered with the error and changes nothing.
    let mut s = Sender::connected();
    let before = s.eb.board.setup().clone();
    s.send(b"$26=0\n");
    s.until("error:3\r\n", 100);
    assert_eq!(s.eb.board.setup(), &before);
}

/// `$J=` jogs sent back to back are planned together (grbl's jogging.md): 20 jogs of
/// 0.5 mm at 1500 mm/min run as one smooth 10 mm move (no stop between them, well within 0.8 s),
/// and one jog cancel (0x85) stops them all.
#[test]
fn jogs_sent_back_to_back_are_planned_together_and_one_cancel_stops_them_all() {
    let mut s = Sender::connected();
    let jogs = b"$J=G91 X0.5 F1500\n".repeat(20);
    // Character counting: as many as the 128-byte RX buffer takes, the rest as oks come back.
    let mut sent = 0;
    let t0 = s.eb.now_ms();
    let mut speeds = Vec::new();
    let mut last = 0i64;
    let mut end_ms = None;
    for _ in 0..3000 {
        while sent < 20 && (sent + 1) * 18 - s.oks() * 18 <= 120 {
            s.send(&jogs[sent * 18..(sent + 1) * 18]);
            sent += 1;
        }
        s.run(1);
        let x = s.steps()[0];
        speeds.push(x - last);
        last = x;
        if x == 10 * STEPS_PER_MM && s.eb.board.state() == State::Idle {
            end_ms = Some(s.eb.now_ms() - t0);
            break;
        }
    }
    assert_eq!(s.oks(), 20, "{:?}", s.seen);
    let took = end_ms.expect("the 20 jogs did not end at X 10");
    assert!(took <= 800, "{took} ms");
    // Smooth: once at the cruise speed it stays there until the final deceleration (no stop
    // or dip between jogs).
    let cruise = 1500 * STEPS_PER_MM / 60_000; // steps per ms at 1500 mm/min
    let first = speeds.iter().position(|&d| d >= cruise).unwrap();
    let last_cruising = speeds.iter().rposition(|&d| d >= cruise).unwrap();
    assert!(
        speeds[first..=last_cruising]
            .iter()
            .all(|&d| d >= cruise - 1),
        "a dip between jogs: {speeds:?}"
    );
    assert!(last_cruising - first > 200, "{speeds:?}");

    // Six of 5 mm (X 10 -> 40), cancelled after 300 ms: all stop within the deceleration
    // (about 1.5 mm at 25 mm/s), nothing resumes.
    s.seen.clear();
    s.send(&b"$J=G91 X5 F1500\n".repeat(6));
    s.run(300);
    assert_eq!(s.oks(), 6, "{:?}", s.seen);
    let at_cancel = s.steps()[0];
    s.send(&[0x85]);
    until_state(&mut s.eb, State::Idle, 2_000);
    let x = s.steps()[0];
    s.run(500);
    assert_eq!(s.steps()[0], x);
    assert!(
        x > at_cancel && x < at_cancel + 2 * STEPS_PER_MM,
        "{at_cancel} -> {x}"
    );
}

/// The grbl hold rules. `!` in Idle holds (`Hold:0`): the next line waits for `~`
/// before it moves. `~` while a hold still decelerates (`Hold:1`) is ignored; once the hold is
/// complete it resumes, and the job ends at its exact end.
#[test]
fn feed_hold_in_idle_holds_the_next_motion_and_resume_waits_for_the_hold_to_complete() {
    let mut s = Sender::connected();
    s.send(b"!");
    s.run(5);
    assert!(s.status().starts_with("<Hold:0|"));
    s.send(b"G1 X5 F600\n");
    s.run(500);
    assert_eq!(s.steps()[0], 0, "moved before ~");
    assert!(s.status().starts_with("<Hold:0|"));
    s.send(b"~");
    s.run(200);
    assert!(s.steps()[0] > 0);
    assert_eq!(s.ends_idle(5_000)[0], 5 * STEPS_PER_MM);

    // A hold at full speed, then ~ at once: ignored while Hold:1.
    s.answer(b"G1 X50 F3000\n", 100);
    s.run(1000);
    s.send(b"!");
    s.run(3);
    assert!(s.status().starts_with("<Hold:1|"));
    s.send(b"~");
    s.run(1);
    for _ in 0..2000 {
        s.run(1);
        if s.status().starts_with("<Hold:0|") {
            break;
        }
    }
    let held = s.steps()[0];
    s.run(500);
    assert_eq!(
        s.steps()[0],
        held,
        "the ~ sent during Hold:1 resumed the job"
    );
    s.send(b"~");
    assert_eq!(s.ends_idle(10_000)[0], 50 * STEPS_PER_MM);
}

/// The line length limit counts what grbl keeps of a line (blanks and comments are
/// dropped first): a 120-character line that is mostly comment runs; one with 110 characters
/// of words is refused with `error:11`; blanks do not count either.
#[test]
fn the_line_limit_counts_the_words_not_the_blanks_and_comments() {
    let mut s = Sender::connected();
    let commented = format!("G1 X2 F600 ({})\n", "x".repeat(105));
    assert!(commented.len() > 110 && commented.len() < 128);
    let words = format!("G1{}X3\n", " \t".repeat(50));
    let long = format!("G1X3{}\n", "Y0".repeat(53));
    assert!(long.len() - 1 > 104);
    s.send(commented.as_bytes());
    s.run(50);
    s.send(words.as_bytes());
    s.run(50);
    s.send(long.as_bytes());
    s.run(50);
    assert_eq!(s.answers(), ["ok", "ok", "error:11"], "{:?}", s.seen);
    assert_eq!(s.ends_idle(5_000)[0], 3 * STEPS_PER_MM);
}

/// A line beyond the travel raises `ALARM:2` at once, as grbl's soft limit does
/// (nothing moves, position kept), then grbl's critical event: `[MSG:Reset to continue]`, and
/// nothing but a soft reset is taken (`$X` and lines answer `error:9`). After the reset, `$X`
/// unlocks and the machine moves again.
#[test]
fn a_soft_limit_is_alarm_2_and_needs_a_reset_before_unlock() {
    let mut s = Sender::connected();
    s.answer(b"G0 X5\n", 100);
    s.ends_idle(5_000);
    s.seen.clear();
    s.send(b"G0 X400\n");
    s.run(100);
    s.assert_seen("ALARM:2\r\n[MSG:Reset to continue]\r\n");
    assert_eq!(s.steps()[0], 5 * STEPS_PER_MM);
    s.seen.clear();
    s.send(b"$X\nG0 X6\n");
    s.run(100);
    assert_eq!(s.answers(), ["error:9", "error:9"], "{:?}", s.seen);
    s.send(b"\x18");
    s.until("[MSG:'$H'|'$X' to unlock]\r\n", 200);
    s.seen.clear();
    let seen = s.answer(b"$X\n", 100);
    assert!(seen.contains("[MSG:Caution: Unlocked]"), "{seen:?}");
    s.answer(b"G0 X6\n", 100);
    s.run(500);
    assert_eq!(s.ends_idle(5_000)[0], 6 * STEPS_PER_MM);
}

/// `$X` in alarm 11 (homing required) does not answer a misleading `ok`: Gantry keeps
/// the homing lock, so it answers `error:9` and says to home.
#[test]
fn unlock_in_the_homing_alarm_answers_error_9_and_says_to_home() {
    let mut s = Sender::with(|s| {
        s.inputs.limit_min = 0b001;
        s.homing.required = true;
        s.homing.axes[0].priority = 1;
    });
    s.send(b"\x18");
    s.until(BANNER, 50);
    s.seen.clear();
    s.send(b"$X\n");
    s.run(50);
    s.assert_seen("[MSG:Homing required: '$H' to home]\r\nerror:9\r\n");
    assert_eq!(s.eb.board.state(), State::Alarm);
}

/// `$SLP` stops everything and reports `Sleep`; only a soft reset wakes the board.
#[test]
fn sleep_reports_sleep_and_only_a_reset_wakes_it() {
    let mut s = pwm_sender();
    s.answer(b"M3 S5000 M8\n", 100);
    s.run(20);
    s.seen.clear();
    let seen = s.answer(b"$SLP\n", 100);
    assert!(seen.contains("[MSG:Sleeping]"), "{seen:?}");
    s.run(20);
    assert!(s.status().starts_with("<Sleep|"));
    let o = s.eb.board.outputs();
    assert_eq!(
        (o.spindle, o.flood),
        (gantry_machine::canon::Spindle::Off, false)
    );
    s.seen.clear();
    s.send(b"G0 X1\n");
    s.run(100);
    assert_eq!(s.answers(), ["error:9"]);
    assert_eq!(s.steps()[0], 0);
    s.send(b"\x18");
    s.until(BANNER, 100);
    assert!(s.status().starts_with("<Idle|"));
}

/// `M6` is a setting. By default Gantry's tool-change stop (`Hold:0`, `~` continues);
/// with `grbl.m6_stop = false`, grbl 1.1's `error:20`: the line runs nothing, the job reads on.
#[test]
fn m6_stops_by_default_and_answers_error_20_when_the_setting_says_so() {
    let mut s = Sender::connected();
    s.send(b"G1 X1 F600\nT2 M6\nG1 X2\n");
    s.until_state_name("<Hold:0", 3000);
    assert_eq!(s.eb.board.tool_change(), Some(2));
    s.send(b"~");
    assert_eq!(s.ends_idle(5_000)[0], 2 * STEPS_PER_MM);

    let mut s = Sender::with(|st| st.grbl.m6_stop = false);
    s.send(b"\x18");
    s.until(BANNER, 50);
    s.send(b"G1 X1 F600\nT2 M06\nG1 X2\n");
    s.run(2000);
    assert_eq!(s.answers(), ["ok", "error:20", "ok"], "{:?}", s.seen);
    assert_eq!(s.ends_idle(5_000)[0], 2 * STEPS_PER_MM);
    assert_eq!(s.eb.board.outputs().tool, 0);
}

/// grbl plans the lines that come during a hold and answers them (its protocol loop keeps
/// reading; only its planner filling stops it), so a character-counting sender with `$G` and
/// `?` beside its count never overruns the receive buffer. `!` in Idle, then 144 bytes of
/// lines in one write (more than the 128-byte buffer), then `~`: every line is answered
/// `ok` once, before the `~`, nothing moves until it, and each line runs once (the X pulses
/// are the sum of the moves).
#[test]
fn lines_sent_in_a_hold_are_planned_and_answered_and_each_runs_once() {
    let mut s = Sender::connected();
    s.send(b"!");
    s.run(5);
    assert!(s.status().starts_with("<Hold:0|"));
    let xs = [1, 2, 3, 4, 5, 6, 7, 8, 9, 8, 7, 6];
    let burst: String = xs.iter().map(|x| format!("G1 X{x} F9000\n")).collect();
    assert_eq!(burst.len(), 144);
    s.send(burst.as_bytes());
    s.send(b"$G\n?");
    for _ in 0..5_000 {
        s.run(1);
        if s.answers().len() == 13 {
            break;
        }
    }
    assert_eq!(
        s.answers(),
        vec!["ok"; 13],
        "answered in the hold: {:?}",
        s.seen
    );
    assert_eq!(s.steps()[0], 0, "moved before ~");
    assert!(s.status().starts_with("<Hold:0|"));
    s.seen.clear();
    s.send(b"~");
    assert_eq!(s.ends_idle(20_000)[0], 6 * STEPS_PER_MM);
    assert_eq!(
        s.answers(),
        Vec::<&str>::new(),
        "answered twice: {:?}",
        s.seen
    );
    let travel: i64 = xs
        .iter()
        .fold((0i64, 0i64), |(at, sum), &x| (x, sum + (x - at).abs()))
        .1;
    assert_eq!(
        s.eb.pulses[0] as i64,
        travel * STEPS_PER_MM,
        "each line ran once"
    );
    assert_eq!(s.answer(b"G0 X0\n", 2_000), "ok\r\n");
}

/// The same in a hold of a running job, and at an M0: the lines that follow are answered while
/// the machine stands, and run once after cycle start.
#[test]
fn lines_sent_while_a_job_stands_in_a_hold_or_at_m0_are_answered_and_run_once() {
    let mut s = Sender::connected();
    s.answer(b"G1 X20 F1200\n", 100);
    s.run(300);
    s.send(b"!");
    s.until_state_name("<Hold:0", 5_000);
    let held = s.steps()[0];
    s.seen.clear();
    let burst: String = (0..12).map(|i| format!("G1 Y{} F9000\n", i % 2)).collect();
    s.send(burst.as_bytes());
    for _ in 0..5_000 {
        s.run(1);
        if s.answers().len() == 12 {
            break;
        }
    }
    assert_eq!(s.answers(), vec!["ok"; 12], "{:?}", s.seen);
    assert_eq!(s.steps()[0], held, "moved in the hold");
    s.seen.clear();
    s.send(b"~");
    s.until_state_name("<Run", 2_000);
    assert_eq!(s.ends_idle(20_000)[..2], [20 * STEPS_PER_MM, STEPS_PER_MM]);
    assert_eq!(s.eb.pulses[1] as i64, 6 * 2 * STEPS_PER_MM - STEPS_PER_MM);

    // At an M0 stop: the lines after it are answered while it waits.
    s.seen.clear();
    s.send(b"G1 X0 F3000\nM0\n");
    s.until_state_name("<Hold:0", 10_000);
    s.seen.clear();
    s.send(b"G1 X1\nG1 X2\nG1 X3\n");
    for _ in 0..2_000 {
        s.run(1);
        if s.answers().len() == 3 {
            break;
        }
    }
    assert_eq!(s.answers(), vec!["ok"; 3], "{:?}", s.seen);
    assert_eq!(s.steps()[0], 0, "stands at the M0");
    s.send(b"~");
    assert_eq!(s.ends_idle(10_000)[0], 3 * STEPS_PER_MM);
}

/// A burst larger than the receive buffer (eight fast jog clicks, 160 bytes in one write, as
/// CNCjs sends them) loses nothing: the board reads only what its buffer can take and the rest
/// waits in the port. Eight `ok`s, X exactly +8 mm, and the next line is read whole.
#[test]
fn a_burst_of_eight_jogs_in_one_write_runs_all_eight() {
    let mut s = Sender::connected();
    let burst = "$J=G91 G21 X1 F2000\n".repeat(8);
    assert_eq!(burst.len(), 160);
    s.send(burst.as_bytes());
    for _ in 0..20_000 {
        s.run(1);
        if s.answers().len() == 8 {
            break;
        }
    }
    assert_eq!(s.answers(), vec!["ok"; 8], "{:?}", s.seen);
    assert_eq!(s.ends_idle(10_000)[0], 8 * STEPS_PER_MM);
    s.seen.clear();
    assert_eq!(s.answer(b"G90 G0 Y5\n", 2_000), "ok\r\n");
    assert_eq!(
        s.ends_idle(5_000)[..2],
        [8 * STEPS_PER_MM, 5 * STEPS_PER_MM]
    );
}

/// FreeCAD's grbl post writes `K0.000` on every G17 arc: grbl's parser ignores the off-plane
/// word, so grbl mode does too, and the arc runs to its exact end (a half circle X0 → X10 and
/// back, the Y pulses the two arcs' height twice each).
#[test]
fn a_freecad_arc_with_k0_runs_in_grbl_mode() {
    let mut s = Sender::connected();
    s.send(b"G17 G21 G90\nG1 X0 Y0 F2000\nG2 X10.000 Y0.000 I5.000 J0.000 K0.000 F2000\nG3 X0.000 Y0.000 I-5.000 J0.000 K0.000\n");
    for _ in 0..20_000 {
        s.run(1);
        if s.answers().len() == 4 {
            break;
        }
    }
    assert_eq!(s.answers(), vec!["ok"; 4], "{:?}", s.seen);
    assert_eq!(s.ends_idle(20_000)[..2], [0, 0]);
    assert_eq!(s.eb.pulses[0] as i64, 20 * STEPS_PER_MM);
    let y = s.eb.pulses[1] as i64;
    assert!(
        (y - 20 * STEPS_PER_MM).abs() <= 2,
        "each arc reaches 5 mm out and back: {y}"
    );
}

/// The smaller grbl seams: `$10` beyond a byte is refused (`error:3`) and keeps the mask;
/// `$I=` answers `ok`; a negative F, S or P is grbl's `error:4`; `M2`/`M30` say
/// `[MSG:Pgm End]` before their `ok`; `$RST=` says `[MSG:Restoring defaults]`.
#[test]
fn small_grbl_seams_answer_as_grbl_does() {
    let mut s = Sender::connected();
    s.send(b"$10=99999\n$$\n");
    s.run(100);
    assert_eq!(s.answers()[0], "error:3", "{:?}", s.seen);
    s.assert_seen("$10=1\r\n");
    s.seen.clear();
    assert_eq!(s.answer(b"$I=my machine\n", 100), "ok\r\n");
    s.seen.clear();
    s.send(b"G1 X1 F-100\nS-5\nG4 P-1\nN-2 G0 X0\n");
    s.run(200);
    assert_eq!(s.answers(), vec!["error:4"; 4], "{:?}", s.seen);
    s.seen.clear();
    s.send(b"G0 X1\nM2\n");
    s.run(2000);
    assert_eq!(s.answers(), ["ok", "ok"], "{:?}", s.seen);
    s.assert_seen("ok\r\n[MSG:Pgm End]\r\nok\r\n");
    s.seen.clear();
    s.send(b"G0 X2\nM30\n");
    s.run(2000);
    s.assert_seen("ok\r\n[MSG:Pgm End]\r\nok\r\n");
    s.ends_idle(5_000);
    s.seen.clear();
    s.send(b"$RST=#\n");
    s.run(200);
    assert_eq!(s.seen, "[MSG:Restoring defaults]\r\nok\r\n");
}

/// A connection that opens and says nothing is greeted with the banner after 250 ms (grbl's
/// power-up banner, for senders that wait for it), once; its first line is then answered with
/// no second banner, and a soft reset it sends brings the banner again, as grbl's does.
#[test]
fn a_silent_connection_is_greeted_with_the_banner_once() {
    let mut s = Sender::new();
    s.eb.set_dtr(false);
    s.run(10);
    s.eb.set_dtr(true);
    s.run(200);
    assert_eq!(s.seen, "", "greeted before 250 ms");
    s.run(100);
    assert_eq!(s.seen, format!("\r\n{BANNER}\r\n"));
    s.run(500);
    assert_eq!(s.seen.matches(BANNER).count(), 1);
    s.seen.clear();
    assert_eq!(s.answer(b"G0 X1\n", 2_000), "ok\r\n");
    s.send(b"\x18");
    let reset = s.until(BANNER, 2_000);
    s.run(100);
    let after = reset + &s.seen;
    assert_eq!(after.matches(BANNER).count(), 1, "{after:?}");
}

#[test]
fn in_laser_mode_fs_reports_the_power_the_beam_fires_at_none_in_g0_or_at_rest() {
    let mut s = Sender::connected();
    for set in [&b"$32=1\n"[..], b"$30=1000\n", b"$31=0\n"] {
        s.answer(set, 100);
    }
    s.answer(b"G21 G90 M4 S800\n", 100);
    // A G0 with the beam modal on: it runs at the rapid rate with the beam off (`A:C` says M4).
    s.send(b"G0 X30\n");
    s.until_state_name("<Run", 2_000);
    s.run(300);
    let mut seen = Vec::new();
    for _ in 0..10 {
        seen.push(s.status());
        s.run(20);
    }
    assert!(seen.iter().all(|st| st.contains("|FS:3000,0")), "{seen:?}");
    assert!(seen.iter().any(|st| st.contains("|A:C")), "{seen:?}");
    s.ends_idle(5_000);
    // A G1 at cruise fires at S (M4: S × speed ÷ F, full S at F).
    s.send(b"G1 X60 F3000\n");
    s.until_state_name("<Run", 2_000);
    s.run(300);
    let st = s.status();
    assert!(st.contains("|FS:3000,800"), "{st}");
    s.ends_idle(5_000);
    s.run(50);
    let st = s.status();
    assert!(st.contains("|FS:0,0"), "at rest the beam is off: {st}");
    assert!(s.answer(b"$$\n", 100).contains("$32=1\r\n"));
}

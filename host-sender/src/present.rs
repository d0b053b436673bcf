//! The host's words: how statuses, board errors (with the source line and a caret under the word
//! the board blamed), alarms, limit reports, positions and times read on a terminal. Nothing here
//! talks to a board; the session layer (`crate::session`) and the commands use it.

use crate::program::Program;
use crate::session::{BoardAlarm, BoardError};
use gantry_machine::gcode::ErrorCode;
use gantry_machine::units::AXIS_LETTERS;
use gantry_proto::{MachineState, Status};
use std::fmt::Write as _;

/// One error as `check`, `stream` and `mdi` print it (see [`format_error`]).
pub(crate) struct ErrorReport<'a> {
    /// Where the program comes from: a file name, or `mdi`.
    pub(crate) place: &'a str,
    /// 1-based line in the program.
    pub(crate) line: u32,
    /// The block's N word, if it has one.
    pub(crate) n_word: Option<u32>,
    /// The interpreter's error number (docs/errors.md); `None` for a host-side check.
    pub(crate) code: Option<u16>,
    pub(crate) message: &'a str,
    /// The line as written, when known.
    pub(crate) source: Option<&'a str>,
    /// 0-based columns `[start, end)` of the word to blame in `source`.
    pub(crate) columns: Option<(u16, u16)>,
}

/// `place:line: N20 error E211: message`, then the source line and a caret under the bad word
/// (control characters in the source are shown escaped, never sent to the terminal).
/// How much of a program line an error quotes, characters.
pub(crate) const QUOTED_CHARS: usize = 100;

pub(crate) fn format_error(r: &ErrorReport<'_>) -> String {
    let n = r.n_word.map(|n| format!(" N{n}")).unwrap_or_default();
    let code = r.code.map(|c| format!(" E{c}")).unwrap_or_default();
    let mut out = format!("{}:{}:{n} error{code}: {}\n", r.place, r.line, r.message);
    if let Some(text) = r.source {
        let text = text.trim_end_matches('\r');
        // At most the first QUOTED_CHARS characters of a line are quoted (a huge line is not
        // echoed whole); the caret only where it falls among them.
        let shown: String = text.chars().take(QUOTED_CHARS).collect();
        let cut = shown.len() < text.len();
        let _ = writeln!(
            out,
            "    {}{}",
            printable(&shown),
            if cut { " …" } else { "" }
        );
        if let Some((start, end)) = r.columns.filter(|&(s, _)| usize::from(s) < QUOTED_CHARS) {
            // Columns count characters of the raw line; escaping widens what comes before.
            let before: String = text.chars().take(start as usize).collect();
            let pad = printable(&before).chars().count();
            let width =
                (end.saturating_sub(start).max(1) as usize).min(QUOTED_CHARS - usize::from(start));
            let _ = writeln!(out, "    {}{}", " ".repeat(pad), "^".repeat(width));
        }
    }
    out
}

/// Program text made safe for a terminal: control characters (an escape sequence in a comment
/// would otherwise reach the terminal raw) are shown as `\u{1b}`-style escapes.
pub(crate) fn printable(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_unicode().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

/// "alarm 2 (soft limit): a block would leave …" for an alarm number.
pub(crate) fn alarm_text(code: u16) -> String {
    match gantry_machine::board::AlarmCode::from_number(code) {
        Some(a) => format!("alarm {code} ({}): {}", a.name(), a.message()),
        None => format!("alarm {code} (unknown to this gantry)"),
    }
}

/// "X max switch" for a limit report.
pub(crate) fn limit_text(axis: u8, max: bool) -> String {
    let letter = gantry_machine::units::AXIS_LETTERS
        .get(axis as usize)
        .copied()
        .unwrap_or('?');
    format!(
        "limit switch {letter} {} stopped the motion",
        if max { "max" } else { "min" }
    )
}

/// `Idle`, `Run`, … as users read it.
pub(crate) fn state_name(s: MachineState) -> &'static str {
    match s {
        MachineState::Idle => "Idle",
        MachineState::Run => "Run",
        MachineState::Hold { .. } => "Hold",
        MachineState::Jog => "Jog",
        MachineState::Alarm { .. } => "Alarm",
        MachineState::Homing => "Homing",
        MachineState::Check => "Check",
        MachineState::ToolChange { .. } => "ToolChange",
    }
}

/// A length in whole micrometres, half a micrometre rounded away from zero: the one rounding of
/// every position readout (`gantry status` here, the console's page in `crate::console`), so the
/// two never differ by a digit (`{:.3}` rounded 28.5625 mm to 28.562, the page to 28.563).
pub(crate) fn um_of_nm(nm: i64) -> i64 {
    let um = (nm.unsigned_abs() + 500) / 1000;
    if nm < 0 {
        -(um as i64)
    } else {
        um as i64
    }
}

/// Millimetres (from nm) to 3 decimals ([`um_of_nm`]), for the status readout.
fn mm_3dp(nm: i64) -> String {
    let um = um_of_nm(nm);
    let sign = if um < 0 { "-" } else { "" };
    let a = um.unsigned_abs();
    format!("{sign}{}.{:03}", a / 1000, a % 1000)
}

/// A position as `X 1.000  Y 2.000  Z 3.000` (mm, 3 decimals) for the first `axes` axes.
pub(crate) fn axes_line(p: &[i64], axes: usize) -> String {
    let names = gantry_machine::units::AXIS_LETTERS;
    (0..axes)
        .map(|i| format!("{} {}", names[i], mm_3dp(p[i])))
        .collect::<Vec<_>>()
        .join("  ")
}

/// Seconds as h:mm:ss.
pub(crate) fn hms(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// The report line on the emulated board's underruns (gaps where its step kernel ran dry mid-job).
pub(crate) fn underrun_line(
    gaps: u64,
    cpu: Option<gantry_emulator::cpu_model::CpuModel>,
) -> String {
    let model = match cpu {
        Some(m) => format!("CPU model {} at {} MHz", m.name, m.hz / 1_000_000),
        None => "no CPU model: main loop in no time, --cpu-model f411 charges it".to_owned(),
    };
    format!("underruns: {gaps} (times the step kernel ran dry mid-job; {model})")
}

/// The report line on the job's time lost to starvation (`Status::starved_ms`, counted by the
/// board: machine/src/device/starvation.rs).
pub(crate) fn starved_line(ms: u32) -> String {
    format!(
        "starved:  {}.{:03} s (machine time lost because the planner held too little of a program with more lines)",
        ms / 1000,
        ms % 1000
    )
}

/// The text of an error code the board itself gives (a refused request, a move, a stopped jog),
/// not the interpreter (docs/errors.md "Board refusals"); `None` for a code that is not one.
pub(crate) fn board_code_text(code: u16) -> Option<&'static str> {
    use gantry_machine::board::*;
    Some(match code {
        ERROR_SOFT_LIMIT => "move exceeds the machine travel (soft limit)",
        ERROR_HOMING_REQUIRED => "the machine must be homed first (gantry home)",
        ERROR_BUSY => {
            "the board is busy (a job, a homing cycle or a jog still moving): wait until it is Idle"
        }
        ERROR_INVALID_REQUEST => {
            "the board cannot carry this out (no such axis, no feed, or no axis to home)"
        }
        ERROR_LIMIT_PRESSED => {
            "a limit switch is still pressed: jog the axis off it (away from the switch) first"
        }
        ERROR_JOG_DEADMAN => {
            "the board stopped the continuous jog: no keepalive from the host for 250 ms"
        }
        _ => return None,
    })
}

impl BoardError {
    /// The error as `gantry check` prints it ([`format_error`]: `place:line: N.. error
    /// E231: …`, the source line, a caret under the word the board blamed).
    pub(crate) fn describe(&self, place: &str, program: &Program) -> String {
        let interpreter = || {
            ErrorCode::ALL
                .iter()
                .find(|c| c.number() == self.code)
                .map(|c| c.message())
        };
        // The board's own codes 900-903 share numbers with the interpreter's E900s (transforms):
        // an error at no line (a refused request or start, a preamble's soft limit) is the
        // board's; one at a program line is the interpreter's unless it has no such code.
        let message = if self.line == 0 {
            board_code_text(self.code).or_else(interpreter)
        } else {
            interpreter().or_else(|| board_code_text(self.code))
        }
        .unwrap_or("unknown error");
        if self.line == 0 {
            return format!("resume preamble: error {}: {message}", self.code);
        }
        format_error(&ErrorReport {
            place,
            line: self.line,
            n_word: crate::program::n_word(program, self.line),
            code: Some(self.code),
            message,
            source: program.line(self.line),
            columns: program.source_columns(self.line, self.column),
        })
    }
}

impl BoardAlarm {
    /// The alarm's name and text, with the program line it concerns and that line's text.
    pub fn describe(&self, program: &Program) -> String {
        let text = alarm_text(self.code);
        if self.line == 0 {
            return text;
        }
        let source = printable(program.line(self.line).unwrap_or("").trim());
        format!(
            "line {}: {text}
    {source}",
            self.line
        )
    }
}

/// The active inputs of a status's `inputs` bits, by name (the setup's names, `x_min`,
/// `feed_hold` …, `in29` … for bits without one): the CLI's status and the console's readout.
pub fn input_names(bits: u32) -> Vec<std::borrow::Cow<'static, str>> {
    use gantry_machine::board::inputs::INPUT_NAMES;
    (0..32)
        .filter(|i| bits >> i & 1 == 1)
        .map(|i| match INPUT_NAMES.get(i) {
            Some(n) => std::borrow::Cow::Borrowed(*n),
            None => std::borrow::Cow::Owned(format!("in{i}")),
        })
        .collect()
}

/// The status as a short table.
pub fn format_status(s: &Status, axes: usize) -> String {
    let pos = |p: &[i64]| axes_line(p, axes);
    let homed: String = (0..axes)
        .filter(|i| s.homed >> i & 1 == 1)
        .map(|i| AXIS_LETTERS[i])
        .collect();
    format!(
        "state:     {}\nmachine:   {}\nwork:      {}\nprogram:   {}\nfeed:      {:.1} mm/min, programmed {:.1} mm/min (override feed {} %, rapid {} %, spindle {} %)\nline:      {}\nbuffers:   {} planner blocks, {} lines\ninputs:    {}\nhomed:     {}\noutputs:   {}",
        state_name(s.state),
        pos(&s.machine_pos),
        pos(&s.work_pos),
        modes_text(s),
        s.feed_um_min as f64 / 1000.0,
        s.programmed_feed_um_min as f64 / 1000.0,
        s.feed_override,
        s.rapid_override,
        s.spindle_override,
        s.line,
        s.planner_fill,
        s.queue_fill,
        match input_names(s.inputs) {
            n if n.is_empty() => "none active".to_owned(),
            n => n.join(" "),
        },
        if homed.is_empty() { "none".into() } else { homed },
        outputs_text(&s.outputs)
    ) + &s.probe.map_or(String::new(), |p| {
        let contact = if p.success { "contact" } else { "no contact" };
        format!("\nprobe:     {} ({contact})", pos(&p.machine_pos))
    }) + &match s.state {
        MachineState::Alarm { code } => format!("\nalarm:     {}", alarm_text(code)),
        MachineState::ToolChange { tool } => format!(
            "\ntool:      change to tool T{tool}, then cycle start or `gantry resume`"
        ),
        _ => String::new(),
    }
}

/// Name of work system `n` (0 = G54 .. 8 = G59.3).
pub(crate) fn work_system_name(n: u8) -> &'static str {
    const NAMES: [&str; 9] = [
        "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
    ];
    NAMES.get(usize::from(n)).copied().unwrap_or("G54")
}

/// The executing block's work system and units: `G54, G21 (mm)`.
pub(crate) fn modes_text(s: &Status) -> String {
    let units = if s.inch { "G20 (inch)" } else { "G21 (mm)" };
    format!("{}, {units}", work_system_name(s.work_system))
}

/// The spindle, coolant and tool as the board drives them: `spindle CW 12000 rpm, flood, tool 3`;
/// in laser mode `laser M4 S800, power 40.0 %, coolant off, no tool`; with a plasma torch
/// `torch on (arc OK), THC +0.250 mm, coolant off, no tool`.
pub(crate) fn outputs_text(o: &gantry_proto::OutputsStatus) -> String {
    use gantry_proto::SpindleStatus;
    let spindle = match (o.torch, o.laser_permille, o.spindle) {
        (Some(t), _, _) => torch_text(t),
        (None, Some(p), s) => {
            let mode = match s {
                SpindleStatus::Off => "laser off".to_owned(),
                SpindleStatus::Cw => format!("laser M3 S{}", o.rpm),
                SpindleStatus::Ccw => format!("laser M4 S{}", o.rpm),
            };
            format!("{mode}, power {}.{} %", p / 10, p % 10)
        }
        (None, None, SpindleStatus::Off) => "spindle off".to_owned(),
        (None, None, SpindleStatus::Cw) => format!("spindle CW {} rpm", o.rpm),
        (None, None, SpindleStatus::Ccw) => format!("spindle CCW {} rpm", o.rpm),
    };
    let coolant = match (o.mist, o.flood) {
        (false, false) => "coolant off",
        (true, false) => "mist",
        (false, true) => "flood",
        (true, true) => "mist and flood",
    };
    let tool = match o.tool {
        0 => "no tool".to_owned(),
        t => format!("tool {t}"),
    };
    format!("{spindle}, {coolant}, {tool}")
}

/// A plasma torch's state: `torch off`, `torch on, waiting for arc-OK`, `torch on (arc OK)`,
/// `torch off: ARC LOST, job held (cycle start re-fires the torch)`, with the height correction.
pub(crate) fn torch_text(t: gantry_proto::TorchStatus) -> String {
    let arc = match (t.arc_lost, t.on, t.waiting) {
        (true, _, _) => "torch off: ARC LOST, job held (cycle start re-fires the torch)",
        (_, true, true) => "torch on, waiting for arc-OK",
        (_, true, false) => "torch on (arc OK)",
        _ => "torch off",
    };
    let mm = f64::from(t.thc_nm) / 1e6;
    format!("{arc}, THC {mm:+.3} mm")
}

/// `error 900: move exceeds the machine travel (soft limit)` for a refused request's code.
/// The board's answer `code` to a request, in words (the board's refusals first: a request's
/// answer is never an interpreter error).
pub(crate) fn refusal_text(code: u16) -> String {
    // The board's own codes first: 901-905 are also G-code transform errors (E901-E906), which
    // never answer a request.
    if let Some(text) = board_code_text(code) {
        return format!("error {code}: {text}");
    }
    BoardError {
        line: 0,
        code,
        column: 0,
    }
    .describe("", &Program::from_text(""))
    .trim_start_matches("resume preamble: ")
    .to_owned()
}

/// The board's state as the server's log names it: each state the status tells apart has its own
/// words, so a change is logged once and reads as one (a hold coming to rest goes from "holding"
/// to "held"; an alarm and a tool change name their code and tool).
pub(crate) fn state_words(s: MachineState) -> String {
    match s {
        MachineState::Hold { stopped: false } => "holding (stopping)".into(),
        MachineState::Hold { stopped: true } => "held".into(),
        MachineState::Alarm { code } => format!("Alarm {code}"),
        MachineState::ToolChange { tool } => format!("ToolChange T{tool}"),
        other => state_name(other).into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_busy_board_is_busy_not_a_plane_change() {
        let busy = refusal_text(gantry_machine::board::ERROR_BUSY);
        assert!(busy.starts_with("error 902: the board is busy"), "{busy}");
        let homing = refusal_text(gantry_machine::board::ERROR_HOMING_REQUIRED);
        assert!(homing.contains("homed first"), "{homing}");
        // At a program line, 902 is the interpreter's.
        let program = Program::from_text("G68 R30\nG18\n");
        let e = BoardError {
            line: 2,
            code: 902,
            column: 0,
        };
        assert!(e.describe("p.nc", &program).contains("plane change"));
    }

    #[test]
    fn positions_round_half_a_micrometre_away_from_zero() {
        assert_eq!(mm_3dp(28_562_500), "28.563");
        assert_eq!(mm_3dp(-28_562_500), "-28.563");
        assert_eq!(mm_3dp(28_562_499), "28.562");
        assert_eq!(mm_3dp(1_000_500), "1.001");
        assert_eq!(mm_3dp(0), "0.000");
        assert_eq!(mm_3dp(-400), "0.000");
        assert_eq!(mm_3dp(-12_000_000), "-12.000");
    }
    use gantry_proto::MachineState;

    fn status(state: MachineState) -> Status {
        Status {
            state,
            machine_pos: [1_500_000, 0, 0, 0, 0, 0],
            work_pos: [1_500_000, 0, 0, 0, 0, 0],
            feed_um_min: 0,
            feed_override: 100,
            rapid_override: 100,
            spindle_override: 100,
            programmed_feed_um_min: 0,
            work_system: 0,
            inch: false,
            planner_fill: 0,
            queue_fill: 0,
            line: 7,
            inputs: 0,
            homed: 0b001,
            outputs: Default::default(),
            starved_ms: 0,
            probe: None,
        }
    }

    #[test]
    fn the_status_names_the_alarm_and_says_what_it_means() {
        let text = format_status(&status(MachineState::Alarm { code: 20 }), 3);
        assert!(text.starts_with("state:     Alarm\nmachine:   X 1.500  Y 0.000  Z 0.000"));
        assert!(
            text.ends_with(
                "homed:     X\noutputs:   spindle off, coolant off, no tool\nalarm:     alarm 20 (host lost): the host stayed away while the job stood still: job ended, spindle and coolant off"
            ),
            "{text}"
        );
        assert!(!format_status(&status(MachineState::Idle), 3).contains("alarm"));
        assert!(!format_status(&status(MachineState::Idle), 3).contains("probe"));
        let mut probed = status(MachineState::Idle);
        probed.probe = Some(gantry_proto::ProbeStatus {
            machine_pos: [0, 0, -5_000_000, 0, 0, 0],
            success: true,
        });
        let text = format_status(&probed, 3);
        assert!(
            text.ends_with("no tool\nprobe:     X 0.000  Y 0.000  Z -5.000 (contact)"),
            "{text}"
        );
        probed.probe = Some(gantry_proto::ProbeStatus {
            machine_pos: [0, 0, -4_000_000, 0, 0, 0],
            success: false,
        });
        let text = format_status(&probed, 3);
        assert!(text.ends_with("Z -4.000 (no contact)"), "{text}");
        let mut running = status(MachineState::Run);
        running.outputs = gantry_proto::OutputsStatus {
            spindle: gantry_proto::SpindleStatus::Ccw,
            rpm: 12_000,
            mist: true,
            flood: true,
            tool: 2,
            laser_permille: None,
            torch: None,
        };
        assert!(format_status(&running, 3)
            .ends_with("outputs:   spindle CCW 12000 rpm, mist and flood, tool 2"));
        running.outputs.rpm = 800;
        running.outputs.laser_permille = Some(405);
        assert!(format_status(&running, 3)
            .ends_with("outputs:   laser M4 S800, power 40.5 %, mist and flood, tool 2"));
        running.outputs.laser_permille = None;
        running.outputs.torch = Some(gantry_proto::TorchStatus {
            on: true,
            waiting: false,
            arc_lost: false,
            thc_nm: -250_000,
        });
        assert!(format_status(&running, 3)
            .ends_with("outputs:   torch on (arc OK), THC -0.250 mm, mist and flood, tool 2"));
        assert!(format_status(&status(MachineState::Alarm { code: 99 }), 3)
            .ends_with("alarm:     alarm 99 (unknown to this gantry)"));
        // Every alarm the board can raise has a name and a text.
        for a in gantry_machine::board::AlarmCode::ALL {
            assert!(!alarm_text(a as u16).contains("unknown to this gantry"));
        }
    }

    #[test]
    fn the_status_names_the_tool_a_tool_change_waits_for() {
        let text = format_status(&status(MachineState::ToolChange { tool: 2 }), 3);
        assert!(
            text.starts_with(
                "state:     ToolChange
"
            ),
            "{text}"
        );
        assert!(
            text.ends_with("tool:      change to tool T2, then cycle start or `gantry resume`"),
            "{text}"
        );
    }

    #[test]
    fn program_text_never_reaches_the_terminal_with_control_characters() {
        let program = Program::from_text("G1 X1 (\u{1b}[2J\u{7}cleared)\n");
        let e = BoardError {
            line: 1,
            code: 900,
            column: 0,
        };
        let text = e.describe("p.nc", &program);
        assert!(
            !text.chars().any(|c| c.is_control() && c != '\n'),
            "{text:?}"
        );
        assert!(
            text.trim_end().ends_with("G1 X1 (\\u{1b}[2J\\u{7}cleared)"),
            "{text}"
        );
    }

    #[test]
    fn a_refusal_names_the_boards_reason_not_a_transform_error() {
        assert_eq!(
            refusal_text(902),
            "error 902: the board is busy (a job, a homing cycle or a jog still moving): wait until it is Idle"
        );
        assert!(
            refusal_text(901).contains("homed first"),
            "{}",
            refusal_text(901)
        );
        assert!(
            refusal_text(904).contains("no keepalive"),
            "{}",
            refusal_text(904)
        );
        assert!(refusal_text(900).contains("soft limit"));
    }

    #[test]
    fn eta_is_hours_minutes_seconds() {
        assert_eq!(hms(0.4), "0:00:00");
        assert_eq!(hms(3725.6), "1:02:06");
    }

    #[test]
    fn each_state_change_has_its_own_words() {
        let states = [
            MachineState::Idle,
            MachineState::Run,
            MachineState::Hold { stopped: false },
            MachineState::Hold { stopped: true },
            MachineState::Jog,
            MachineState::Alarm { code: 1 },
            MachineState::Alarm { code: 9 },
            MachineState::Homing,
            MachineState::Check,
            MachineState::ToolChange { tool: 2 },
            MachineState::ToolChange { tool: 3 },
        ];
        let words: Vec<String> = states.iter().map(|&s| state_words(s)).collect();
        for (i, w) in words.iter().enumerate() {
            assert_eq!(words.iter().filter(|o| *o == w).count(), 1, "{w}");
            assert_eq!(state_words(states[i]), *w);
        }
        assert_eq!(words[2], "holding (stopping)");
        assert_eq!(words[3], "held");
        assert_eq!(words[1], "Run");
    }
}

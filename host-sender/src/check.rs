//! `gantry check`: interpret a program without motion and report errors or the canonical stream.
//!
//! `--canon` prints one JSON object per canonical action (tests/golden/rs274/README.md: mm, machine coordinates,
//! 1-based lines) and stops at the first error; plain `check` lists every error with the source
//! line and a caret under the bad word, then a one-line summary.
use std::io::Write as _;
use std::path::Path;
use std::process::ExitCode;

use crate::check_summary::{summarize_actions_from, JobSummary};
use crate::present::{format_error, ErrorReport};
use crate::preview::source::{Actions, Ended, FileSource};
use gantry_machine::canon::{Action, ArcDir, Canon, PathMode, Plane, Spindle, StopKind};
use gantry_machine::gcode::{GcodeError, InterpConfig, MemorySource, ProgramSource};
use gantry_machine::setup::Setup;
use gantry_machine::units::{Nm, Pos, MAX_AXES};
use serde::Serialize;

/// Runs `gantry check FILE [--canon]`. Both interpret with the machine `setup` (tool table, work
/// offsets, G28/G30 positions, axes, dialect); plain `check` ends with the job summary
/// ([`crate::check_summary`]); exit code 1 on errors or when the job would exceed the travel.
/// The file is read line by line and nothing of it is kept ([`crate::preview::source`]), so
/// memory stays the same whatever its length.
///
/// `at`: where the machine stands when the job starts (nm; `crate::session::standing`).
pub fn run(file: &Path, canon: bool, setup: &Setup, at: &Pos) -> anyhow::Result<ExitCode> {
    let src = FileSource::open(file)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
    let failed = if canon {
        canon_stream_from(src, &setup.interp_config(), at, &mut out)?
    } else {
        let name = file.display().to_string();
        let (errors, summary) = check_stream_from(
            &name,
            src,
            &setup.interp_config(),
            Some(setup),
            at,
            &mut out,
        )?;
        let summary = summary.expect("planned on the setup");
        if errors > 0 {
            writeln!(
                out,
                "(the summary covers the program up to its first error)"
            )?;
        }
        write!(
            out,
            "{}",
            crate::check_summary::format_summary(&summary, setup)
        )?;
        errors > 0 || summary.leaves_travel.is_some()
    };
    out.flush()?;
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// What `gantry check --canon --setup FILE` prints: the setup's tool table, offsets, G28/G30
/// positions, axes and dialect apply, as in every other command.
#[cfg(test)]
pub(crate) fn canon_for_setup(program: &[u8], setup: &Setup) -> (String, bool) {
    canon_output(program, &setup.interp_config())
}

/// The whole `check --canon` output of `program` for the default setup (format: tests/golden/rs274/README.md).
pub fn canon_jsonl(program: &str) -> String {
    canon_output(program.as_bytes(), &InterpConfig::default()).0
}

/// JSON Lines for a program and setup; the flag tells whether an error ended it.
pub fn canon_output(program: &[u8], config: &InterpConfig) -> (String, bool) {
    let mut out = Vec::new();
    let failed = canon_stream(MemorySource::new(program), config, &mut out)
        .expect("writing to memory does not fail");
    (String::from_utf8(out).expect("JSON is UTF-8"), failed)
}

/// Writes the `check --canon` JSON Lines of the program in `src` as they come; true when an error
/// (or the first line too long for the board) ended it.
pub(crate) fn canon_stream<S: ProgramSource>(
    src: S,
    config: &InterpConfig,
    out: &mut impl std::io::Write,
) -> std::io::Result<bool> {
    canon_stream_from(src, config, &[0; MAX_AXES], out)
}

/// [`canon_stream`] with the machine at `at` (nm) when the program starts.
pub(crate) fn canon_stream_from<S: ProgramSource>(
    src: S,
    config: &InterpConfig,
    at: &Pos,
    out: &mut impl std::io::Write,
) -> std::io::Result<bool> {
    let mut actions = Actions::new(src, config).starting_at(at);
    while let Some(c) = actions.next() {
        // The first line the board would refuse: the stream ends there, as at an interpreter error.
        if let Some(e) = actions.src.peek_long_line().filter(|e| c.line >= e.line) {
            writeln!(out, "{}", error_json(e.line, &long_line_message(e)))?;
            return Ok(true);
        }
        writeln!(out, "{}", canon_json(&c))?;
    }
    let error = match &actions.ended {
        Ended::No => None,
        Ended::Error(e) => Some((e.line, error_text(e))),
        Ended::Limit(n) => Some((0, limit_message(*n))),
    };
    if let Some(e) = actions
        .src
        .peek_long_line()
        .filter(|l| error.as_ref().is_none_or(|e| l.line <= e.0))
    {
        writeln!(out, "{}", error_json(e.line, &long_line_message(e)))?;
        return Ok(true);
    }
    if let Some((line, message)) = error {
        writeln!(out, "{}", error_json(line, &message))?;
        return Ok(true);
    }
    actions.src.read_rest();
    if let Some(e) = actions.src.peek_long_line() {
        writeln!(out, "{}", error_json(e.line, &long_line_message(e)))?;
        return Ok(true);
    }
    Ok(false)
}

/// The message when a program produced more actions than its lines allow.
fn limit_message(n: u64) -> String {
    format!(
        "{n} actions, more than {} plus {} per line: check stopped (an endless loop?)",
        crate::preview::source::MIN_ACTION_LIMIT,
        crate::preview::source::ACTIONS_PER_LINE
    )
}

/// `E<code>: <message>`.
pub(crate) fn error_text(e: &GcodeError) -> String {
    format!("E{}: {}", e.code.number(), e.code.message())
}

/// Millimetres (from nm) with up to 6 decimals, trailing zeros removed.
pub(crate) fn mm_text(nm: Nm) -> String {
    let sign = if nm < 0 { "-" } else { "" };
    let a = nm.unsigned_abs();
    let int = a / 1_000_000;
    let frac = a % 1_000_000;
    if frac == 0 {
        format!("{sign}{int}")
    } else {
        let f = format!("{frac:06}");
        format!("{sign}{int}.{}", f.trim_end_matches('0'))
    }
}

/// A length in mm on the JSON output: an integer when whole, else the nearest `f64` (which prints
/// the same up-to-6 decimals as [`mm_text`], in exponent form below 0.0001 mm).
#[derive(Clone, Copy)]
struct Mm(Nm);

impl Serialize for Mm {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0 % 1_000_000 == 0 {
            s.serialize_i64(self.0 / 1_000_000)
        } else {
            s.serialize_f64(self.0 as f64 / 1e6)
        }
    }
}

fn xyz(p: &[Nm]) -> [Mm; 3] {
    [Mm(p[0]), Mm(p[1]), Mm(p[2])]
}

/// One record of `check --canon`: the source line, then the operation and its fields.
#[derive(Serialize)]
struct Record<'a> {
    line: u32,
    #[serde(flatten)]
    op: Op<'a>,
}

/// The operations of tests/golden/rs274/README.md, tagged by `op`.
#[derive(Serialize)]
#[serde(tag = "op", rename_all = "lowercase")]
enum Op<'a> {
    Rapid {
        to: [Mm; 3],
    },
    Feed {
        to: [Mm; 3],
        feed: Mm,
    },
    Arc {
        to: [Mm; 3],
        center: [Mm; 3],
        plane: &'static str,
        dir: &'static str,
        turns: u32,
        feed: Mm,
    },
    /// A G38.x probe move (to its programmed end).
    Probe {
        to: [Mm; 3],
        feed: Mm,
        code: &'static str,
    },
    Dwell {
        seconds: Mm,
    },
    Spindle {
        state: &'static str,
        rpm: u32,
    },
    /// An oriented spindle stop (G76 fine boring; rs274 has no such record).
    Orient,
    Coolant {
        mist: bool,
        flood: bool,
    },
    Tool {
        tool: u32,
    },
    Mcode {
        code: u32,
    },
    Path {
        mode: &'static str,
        #[serde(skip_serializing_if = "Option::is_none")]
        tolerance: Option<Mm>,
    },
    Stop {
        kind: &'static str,
    },
    Error {
        message: &'a str,
    },
}

fn record_json(line: u32, op: Op<'_>) -> String {
    serde_json::to_string(&Record { line, op }).expect("canon records always serialize")
}

/// One canonical action as a JSON object (no newline).
pub(crate) fn canon_json(c: &Canon) -> String {
    let op = match c.action {
        Action::Rapid { to } => Op::Rapid { to: xyz(&to) },
        Action::Feed { to, feed } => Op::Feed {
            to: xyz(&to),
            feed: Mm(feed),
        },
        Action::Arc {
            to,
            center,
            plane,
            dir,
            turns,
            feed,
        } => Op::Arc {
            to: xyz(&to),
            center: xyz(&center),
            plane: match plane {
                Plane::XY => "XY",
                Plane::ZX => "ZX",
                Plane::YZ => "YZ",
            },
            dir: match dir {
                ArcDir::Cw => "cw",
                ArcDir::Ccw => "ccw",
            },
            turns,
            feed: Mm(feed),
        },
        Action::Probe { to, feed, mode } => Op::Probe {
            to: xyz(&to),
            feed: Mm(feed),
            code: match (mode.toward, mode.must_trip) {
                (true, true) => "G38.2",
                (true, false) => "G38.3",
                (false, true) => "G38.4",
                (false, false) => "G38.5",
            },
        },
        Action::Dwell { micros } => Op::Dwell {
            seconds: Mm(micros as i64),
        },
        Action::Spindle { state, rpm } => Op::Spindle {
            state: match state {
                Spindle::Off => "off",
                Spindle::Cw => "cw",
                Spindle::Ccw => "ccw",
            },
            rpm,
        },
        Action::SpindleOrient => Op::Orient,
        Action::Coolant { mist, flood } => Op::Coolant { mist, flood },
        Action::ToolChange { tool } => Op::Tool { tool },
        Action::UserMCode { code, .. } => Op::Mcode { code: code.into() },
        Action::PathMode(PathMode::ExactStop) => Op::Path {
            mode: "exact",
            tolerance: None,
        },
        Action::PathMode(PathMode::Blend { tolerance }) => Op::Path {
            mode: "blend",
            tolerance: Some(Mm(tolerance)),
        },
        Action::Stop(kind) => Op::Stop {
            kind: match kind {
                StopKind::Pause => "pause",
                StopKind::OptionalPause => "optional",
                StopKind::End => "end",
                StopKind::EndRewind => "end_rewind",
            },
        },
    };
    record_json(c.line, op)
}

/// The `{"line":…,"op":"error","message":…}` record that ends `check --canon` output.
pub(crate) fn error_json(line: u32, message: &str) -> String {
    record_json(line, Op::Error { message })
}

/// The message of a line too long for the board ([`crate::program::wire_text_of`]).
fn long_line_message(e: &crate::program::WireTextError) -> String {
    format!(
        "line too long for the board: {} characters without comments and blanks, at most {}",
        e.len,
        gantry_proto::LINE_MAX
    )
}

/// The human-readable report of plain `check` and the number of errors found.
#[cfg(test)]
pub(crate) fn human_report(name: &str, program: &[u8], config: &InterpConfig) -> (String, usize) {
    let mut out = Vec::new();
    let (errors, _) = check_stream(name, MemorySource::new(program), config, None, &mut out)
        .expect("writing to memory does not fail");
    (String::from_utf8_lossy(&out).into_owned(), errors)
}

/// The lines that [`check_stream`]'s `report` of the program `name` names an error at
/// (`NAME:LINE: …`), in report order: the listing marks them, the start check returns them.
pub(crate) fn error_lines(report: &str, name: &str) -> Vec<u32> {
    let prefix = format!("{name}:");
    report
        .lines()
        .filter_map(|l| l.strip_prefix(&prefix))
        .filter_map(|rest| rest.split(':').next()?.parse().ok())
        .collect()
}

/// Plain `check` of the program in `src`, in one pass: writes every error as it is found (lines
/// too long for the board merged in line order), then `NAME: ok, N actions` or `NAME: E errors, N
/// actions`; returns the error count and the job summary, which covers the program up to its
/// first error (planned on `setup`; none without one).
pub(crate) fn check_stream<S: ProgramSource>(
    name: &str,
    src: S,
    config: &InterpConfig,
    setup: Option<&Setup>,
    out: &mut impl std::io::Write,
) -> std::io::Result<(usize, Option<JobSummary>)> {
    check_stream_from(name, src, config, setup, &[0; MAX_AXES], out)
}

/// [`check_stream`] of a job that starts with the machine at `at` (nm): the interpreter, the
/// extents and the planned time start there.
pub(crate) fn check_stream_from<S: ProgramSource>(
    name: &str,
    src: S,
    config: &InterpConfig,
    setup: Option<&Setup>,
    at: &Pos,
    out: &mut impl std::io::Write,
) -> std::io::Result<(usize, Option<JobSummary>)> {
    let mut actions = Actions::new(src, config).starting_at(at);
    let summary = match setup {
        Some(setup) => Some(summarize_actions_from(actions.by_ref(), setup, at)),
        None => {
            actions.by_ref().for_each(drop);
            None
        }
    };
    let mut errors = 0usize;
    let mut count = actions.count;
    // Long lines found so far, up to `line`, in line order.
    fn long_up_to<S: ProgramSource>(
        a: &mut Actions<S>,
        line: u32,
        name: &str,
        errors: &mut usize,
        out: &mut impl std::io::Write,
    ) -> std::io::Result<()> {
        while a.src.peek_long_line().is_some_and(|e| e.line <= line) {
            let (e, text) = a.src.take_long_line().expect("peeked");
            *errors += 1;
            out.write_all(
                format_error(&ErrorReport {
                    place: name,
                    line: e.line,
                    n_word: None,
                    code: None,
                    message: &long_line_message(&e),
                    source: Some(&text),
                    columns: None,
                })
                .as_bytes(),
            )?;
        }
        Ok(())
    }
    let interp_error =
        |a: &mut Actions<S>, e: &GcodeError, errors: &mut usize, out: &mut dyn std::io::Write| {
            *errors += 1;
            let text = a.src.recent(e.line);
            out.write_all(
                format_error(&ErrorReport {
                    place: name,
                    line: e.line,
                    n_word: e.n_word,
                    code: Some(e.code.number()),
                    message: e.code.message(),
                    source: text.as_deref(),
                    columns: e.columns,
                })
                .as_bytes(),
            )
        };
    match actions.ended.clone() {
        Ended::No => {}
        Ended::Limit(n) => {
            long_up_to(&mut actions, u32::MAX, name, &mut errors, out)?;
            errors += 1;
            writeln!(out, "{name}: error: {}", limit_message(n))?;
        }
        Ended::Error(e) => {
            long_up_to(&mut actions, e.line, name, &mut errors, out)?;
            interp_error(&mut actions, &e, &mut errors, out)?;
            // Past the first error, interpretation goes on to find the others.
            loop {
                let item = actions.interp.next(&mut actions.src);
                match item {
                    None => break,
                    Some(Ok(_)) => count += 1,
                    Some(Err(e)) => {
                        long_up_to(&mut actions, e.line, name, &mut errors, out)?;
                        interp_error(&mut actions, &e, &mut errors, out)?;
                    }
                }
                if actions.interp.restarts() > 0 {
                    break;
                }
                if count >= crate::preview::source::action_limit(actions.src.furthest) {
                    errors += 1;
                    writeln!(out, "{name}: error: {}", limit_message(count))?;
                    break;
                }
            }
        }
    }
    actions.src.read_rest();
    long_up_to(&mut actions, u32::MAX, name, &mut errors, out)?;
    if let (Some(s), Some(setup)) = (&summary, setup) {
        write_rpm_warnings(name, s, setup, out)?;
    }
    let leaves = summary.as_ref().and_then(|s| s.leaves_travel);
    if let (0, Some((line, axis))) = (errors, leaves) {
        // Not "ok": the job would stop there with a soft-limit alarm (the summary says more).
        writeln!(
            out,
            "{name}: no program errors, {count} actions, but line {line} leaves the {axis} travel"
        )?;
    } else if errors == 0 {
        writeln!(out, "{name}: ok, {count} actions")?;
    } else {
        writeln!(
            out,
            "{name}: {errors} error{}, {count} actions",
            if errors == 1 { "" } else { "s" }
        )?;
    }
    Ok((errors, summary))
}

/// A warning line (`NAME:LINE: warning: …`) for each spindle speed outside the setup's
/// `spindle.rpm_range`: the board runs the spindle at the end of the range it passes
/// (docs/settings.md), which the program may not expect. No error: the job may start.
fn write_rpm_warnings(
    name: &str,
    s: &JobSummary,
    setup: &Setup,
    out: &mut impl std::io::Write,
) -> std::io::Result<()> {
    let (lo, hi) = (setup.outputs.spindle_min_rpm, setup.outputs.spindle_max_rpm);
    for &(line, rpm) in &s.rpm_clamped {
        let (side, to) = if rpm > hi {
            ("above", hi)
        } else {
            ("below", lo)
        };
        writeln!(
            out,
            "{name}:{line}: warning: S{rpm} is {side} the spindle's rpm_range [{lo}, {hi}]: the board clamps it to {to} rpm"
        )?;
    }
    if s.rpm_clamped_more > 0 {
        writeln!(
            out,
            "{name}: warning: {} more spindle speeds outside rpm_range",
            s.rpm_clamped_more
        )?;
    }
    Ok(())
}

/// The warning lines of a check's report (`NAME:LINE: warning: …`).
pub(crate) fn warning_lines(report: &str) -> String {
    report
        .lines()
        .filter(|l| l.contains(": warning: "))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spindle_speeds_outside_the_rpm_range_are_warned_with_their_line() {
        let mut setup = Setup::default();
        setup.outputs.spindle_min_rpm = 1000;
        let program = "G21 G90\nM3 S30000\nG1 X1 F100\nS500\nS0\nM5\nS12000 M3\nM30\n";
        let mut out = Vec::new();
        let (errors, _) = check_stream(
            "p.nc",
            MemorySource::new(program.as_bytes()),
            &setup.interp_config(),
            Some(&setup),
            &mut out,
        )
        .unwrap();
        let out = String::from_utf8(out).unwrap();
        assert_eq!(errors, 0, "{out}");
        assert_eq!(
            warning_lines(&out),
            "p.nc:2: warning: S30000 is above the spindle's rpm_range [1000, 24000]: the board clamps it to 24000 rpm\n\
             p.nc:4: warning: S500 is below the spindle's rpm_range [1000, 24000]: the board clamps it to 1000 rpm\n",
            "{out}"
        );
        assert!(out.contains("p.nc: ok, "), "{out}");
    }

    #[test]
    fn millimetres_format() {
        assert_eq!(mm_text(0), "0");
        assert_eq!(mm_text(10_000_000), "10");
        assert_eq!(mm_text(1_500_000), "1.5");
        assert_eq!(mm_text(-254_000), "-0.254");
        assert_eq!(mm_text(7_071_068), "7.071068");
        assert_eq!(mm_text(-1), "-0.000001");
    }

    #[test]
    fn board_errors_print_as_check_does() {
        let program = crate::program::Program::from_text("G0 X1\nN20 G1 (cut) Q2 X3 F1\n");
        // The board blames column 6 of the text it got, "N20G1Q2X3F1": the Q.
        let e = crate::session::BoardError {
            line: 2,
            code: 211,
            column: 6,
        };
        let (check, _) = human_report(
            "p.nc",
            b"G0 X1\nN20 G1 (cut) Q2 X3 F1\n",
            &Default::default(),
        );
        let text = e.describe("p.nc", &program);
        assert!(check.starts_with(&text), "{check}\n{text}");
        assert!(
            text.ends_with("    N20 G1 (cut) Q2 X3 F1\n                 ^^\n"),
            "{text}"
        );
    }

    #[test]
    fn canon_lines_follow_design_section_7() {
        let out = canon_jsonl("G0 X10\nG1 Y5 F100\nG2 X15 Y10 I5 J0\n");
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], r#"{"line":1,"op":"rapid","to":[10,0,0]}"#);
        assert_eq!(
            lines[1],
            r#"{"line":2,"op":"feed","to":[10,5,0],"feed":100}"#
        );
        assert_eq!(
            lines[2],
            r#"{"line":3,"op":"arc","to":[15,10,0],"center":[15,5,0],"plane":"XY","dir":"cw","turns":1,"feed":100}"#
        );
    }

    #[test]
    fn canon_uses_the_setup_tool_table_and_axes() {
        use gantry_machine::setup::{Setup, Tool};
        let mut setup = Setup::default();
        setup
            .program
            .tools
            .push(Tool {
                number: 1,
                length: 5_000_000,
                diameter: 0,
            })
            .unwrap();
        setup.program.g28_home = [1_000_000, 0, 0, 0, 0, 0];
        let (out, failed) = canon_for_setup(b"G43 H1\nG0 Z0\nG28\n", &setup);
        assert!(!failed, "{out}");
        assert!(out.contains("\"to\":[0,0,5]"), "{out}");
        assert!(out.contains("\"to\":[1,0,0]"), "{out}");
        // Three axes: an A word is E212, as in plain `check`.
        let (out, failed) = canon_for_setup(b"G0 A10\n", &setup);
        assert!(failed && out.contains("E212"), "{out}");
    }

    #[test]
    fn errors_stop_the_canon_stream() {
        let out = canon_jsonl("G0 X1\nG1 X2\nG0 X3\n");
        assert_eq!(
            out.lines().last().unwrap(),
            r#"{"line":2,"op":"error","message":"E301: feed move with zero feed rate (program an F word)"}"#
        );
    }

    #[test]
    fn every_canon_line_is_json_with_exact_numbers() {
        let out = canon_jsonl("G0 X0.000001 Y-1.5 Z1234.25\nG4 P0.5\nG1 X1\n");
        let records: Vec<serde_json::Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
            .collect();
        assert_eq!(records.len(), 3, "{out}");
        assert_eq!(
            records[0]["to"],
            serde_json::json!([0.000001, -1.5, 1234.25])
        );
        assert_eq!(records[1]["seconds"], serde_json::json!(0.5));
        assert_eq!(records[2]["op"], "error");
        assert_eq!(records[2]["line"], 3);
        // Integral lengths stay integers, as in the rs274 goldens.
        assert_eq!(
            canon_jsonl("G0 X10\n").trim_end(),
            r#"{"line":1,"op":"rapid","to":[10,0,0]}"#
        );
    }

    #[test]
    fn error_messages_are_escaped_json_strings() {
        let line = error_json(4, "quote \" backslash \\ bell \u{7}");
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["message"], "quote \" backslash \\ bell \u{7}");
        assert_eq!(v["line"], 4);
    }

    #[test]
    fn lines_longer_than_the_board_takes_are_errors() {
        let long = format!("G1 F100 (comment) X{}1", "0".repeat(249)); // 257 characters sent
        let program = format!("G0 X0\n{long}\nG0 X2\n");
        let (report, errors) = human_report("p.nc", program.as_bytes(), &InterpConfig::default());
        assert_eq!(errors, 1, "{report}");
        assert!(
            report.starts_with(
                "p.nc:2: error: line too long for the board: 257 characters without comments and blanks, at most 256\n"
            ),
            "{report}"
        );
        let out = canon_jsonl(&program);
        let last: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
        assert_eq!(last["op"], "error");
        assert_eq!(last["line"], 2);
        assert_eq!(out.lines().count(), 2, "{out}");
        // 256 characters are fine.
        let fits = format!("G1 F100 X{}1", "0".repeat(248));
        let (_, errors) = human_report("p.nc", fits.as_bytes(), &InterpConfig::default());
        assert_eq!(errors, 0);
    }

    #[test]
    fn control_characters_are_escaped_and_the_caret_follows() {
        let report = format_error(&ErrorReport {
            place: "p.nc",
            line: 3,
            n_word: Some(7),
            code: Some(211),
            message: "m",
            source: Some("N7 (\u{1b}) Q2\r"),
            columns: Some((7, 9)),
        });
        assert_eq!(
            report,
            "p.nc:3: N7 error E211: m\n    N7 (\\u{1b}) Q2\n                ^^\n"
        );
    }

    #[test]
    fn human_report_has_a_caret() {
        let (report, errors) = human_report(
            "p.nc",
            b"G0 X1\nN20 G1 Q2 X3 F1\n",
            &InterpConfig::default(),
        );
        assert_eq!(errors, 1);
        assert!(report.contains("p.nc:2: N20 error E211"), "{report}");
        assert!(
            report.contains("    N20 G1 Q2 X3 F1\n           ^^\n"),
            "{report}"
        );
    }
}

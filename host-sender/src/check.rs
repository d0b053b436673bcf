//! `gantry check`: interpret a program without motion and report errors or the canonical stream.
//!
//! `--canon` prints one JSON object per canonical action (tests/golden/rs274/README.md: mm, machine coordinates,
//! 1-based lines) and stops at the first error; plain `check` lists every error with the source
//! line and a caret under the bad word, then a one-line summary.
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

use gantry_machine::canon::{Action, ArcDir, Canon, PathMode, Plane, Spindle, StopKind};
use gantry_machine::gcode::{GcodeError, InterpConfig, Interpreter, MemorySource};
use gantry_machine::units::Nm;

/// Most actions one check produces before it gives up (endless M99 loops, huge repeat counts).
const MAX_ACTIONS: usize = 5_000_000;

/// Runs `gantry check FILE [--canon]`. Both interpret with the machine `setup` (tool table, work
/// offsets, G28/G30 positions, axes, dialect); plain `check` ends with the job summary
/// ([`crate::check_summary`]); exit code 1 on errors or when the job would exceed the travel.
pub fn run(
    file: &Path,
    canon: bool,
    setup: &gantry_machine::setup::Setup,
) -> anyhow::Result<ExitCode> {
    let text =
        std::fs::read(file).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
    if canon {
        let (out, failed) = canon_for_setup(&text, setup);
        print!("{out}");
        return Ok(if failed {
            ExitCode::from(1)
        } else {
            ExitCode::SUCCESS
        });
    }
    let (report, errors) = human_report(&file.display().to_string(), &text, &setup.interp_config());
    print!("{report}");
    let summary = crate::check_summary::summarize(&text, setup);
    if errors > 0 {
        println!("(the summary covers the program up to its first error)");
    }
    print!("{}", crate::check_summary::format_summary(&summary, setup));
    Ok(if errors > 0 || summary.leaves_travel.is_some() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// What `gantry check --canon --setup FILE` prints: the setup's tool table, offsets, G28/G30
/// positions, axes and dialect apply, as in every other command.
pub fn canon_for_setup(program: &[u8], setup: &gantry_machine::setup::Setup) -> (String, bool) {
    canon_output(program, &setup.interp_config())
}

/// The whole `check --canon` output of `program` for the default setup (format: tests/golden/rs274/README.md).
pub fn canon_jsonl(program: &str) -> String {
    canon_output(program.as_bytes(), &InterpConfig::default()).0
}

/// JSON Lines for a program and setup; the flag tells whether an error ended it.
pub fn canon_output(program: &[u8], config: &InterpConfig) -> (String, bool) {
    let mut interp = Interpreter::new(config);
    let mut src = MemorySource::new(program);
    let mut out = String::new();
    let mut count = 0usize;
    while let Some(item) = interp.next(&mut src) {
        match item {
            Ok(c) => {
                out.push_str(&canon_json(&c));
                out.push('\n');
            }
            Err(e) => {
                let _ = writeln!(
                    out,
                    "{{\"line\":{},\"op\":\"error\",\"message\":{}}}",
                    e.line,
                    json_string(&error_text(&e))
                );
                return (out, true);
            }
        }
        count += 1;
        if interp.restarts() > 0 {
            // M99 in the main program loops forever; one pass is the program.
            break;
        }
        if count >= MAX_ACTIONS {
            let _ = writeln!(
                out,
                "{{\"line\":0,\"op\":\"error\",\"message\":\"more than {MAX_ACTIONS} actions, check stopped\"}}"
            );
            return (out, true);
        }
    }
    (out, false)
}

/// `E<code>: <message>`.
pub fn error_text(e: &GcodeError) -> String {
    format!("E{}: {}", e.code.number(), e.code.message())
}

/// Millimetres (from nm) with up to 6 decimals, trailing zeros removed.
pub fn mm(nm: Nm) -> String {
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

fn xyz(p: &[Nm]) -> String {
    format!("[{},{},{}]", mm(p[0]), mm(p[1]), mm(p[2]))
}

fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// One canonical action as a JSON object (no newline).
pub fn canon_json(c: &Canon) -> String {
    let l = c.line;
    match c.action {
        Action::Rapid { to } => format!("{{\"line\":{l},\"op\":\"rapid\",\"to\":{}}}", xyz(&to)),
        Action::Feed { to, feed } => format!(
            "{{\"line\":{l},\"op\":\"feed\",\"to\":{},\"feed\":{}}}",
            xyz(&to),
            mm(feed)
        ),
        Action::Arc {
            to,
            center,
            plane,
            dir,
            turns,
            feed,
        } => format!(
            "{{\"line\":{l},\"op\":\"arc\",\"to\":{},\"center\":{},\"plane\":\"{}\",\"dir\":\"{}\",\"turns\":{turns},\"feed\":{}}}",
            xyz(&to),
            xyz(&center),
            match plane {
                Plane::XY => "XY",
                Plane::ZX => "ZX",
                Plane::YZ => "YZ",
            },
            match dir {
                ArcDir::Cw => "cw",
                ArcDir::Ccw => "ccw",
            },
            mm(feed)
        ),
        Action::Dwell { micros } => format!(
            "{{\"line\":{l},\"op\":\"dwell\",\"seconds\":{}}}",
            mm(micros as i64)
        ),
        Action::Spindle { state, rpm } => format!(
            "{{\"line\":{l},\"op\":\"spindle\",\"state\":\"{}\",\"rpm\":{rpm}}}",
            match state {
                Spindle::Off => "off",
                Spindle::Cw => "cw",
                Spindle::Ccw => "ccw",
            }
        ),
        Action::Coolant { mist, flood } => {
            format!("{{\"line\":{l},\"op\":\"coolant\",\"mist\":{mist},\"flood\":{flood}}}")
        }
        Action::ToolChange { tool } => format!("{{\"line\":{l},\"op\":\"tool\",\"tool\":{tool}}}"),
        Action::UserMCode { code, .. } => format!("{{\"line\":{l},\"op\":\"mcode\",\"code\":{code}}}"),
        Action::PathMode(PathMode::ExactStop) => {
            format!("{{\"line\":{l},\"op\":\"path\",\"mode\":\"exact\"}}")
        }
        Action::PathMode(PathMode::Blend { tolerance }) => format!(
            "{{\"line\":{l},\"op\":\"path\",\"mode\":\"blend\",\"tolerance\":{}}}",
            mm(tolerance)
        ),
        Action::Stop(kind) => format!(
            "{{\"line\":{l},\"op\":\"stop\",\"kind\":\"{}\"}}",
            match kind {
                StopKind::Pause => "pause",
                StopKind::OptionalPause => "optional",
                StopKind::End => "end",
                StopKind::EndRewind => "end_rewind",
            }
        ),
    }
}

/// The human-readable report of plain `check` and the number of errors found.
pub fn human_report(name: &str, program: &[u8], config: &InterpConfig) -> (String, usize) {
    let lines: Vec<&[u8]> = program.split(|&c| c == b'\n').collect();
    let mut interp = Interpreter::new(config);
    let mut src = MemorySource::new(program);
    let mut out = String::new();
    let mut errors = 0usize;
    let mut actions = 0usize;
    while let Some(item) = interp.next(&mut src) {
        match item {
            Ok(_) => actions += 1,
            Err(e) => {
                errors += 1;
                let n = e.n_word.map(|n| format!(" N{n}")).unwrap_or_default();
                let _ = writeln!(
                    out,
                    "{name}:{}:{n} error E{}: {}",
                    e.line,
                    e.code.number(),
                    e.code.message()
                );
                if let Some(src_line) = e.line.checked_sub(1).and_then(|i| lines.get(i as usize)) {
                    let text = String::from_utf8_lossy(src_line);
                    let text = text.trim_end_matches('\r');
                    let _ = writeln!(out, "    {text}");
                    if let Some((start, end)) = e.columns {
                        let width = (end.saturating_sub(start)).max(1) as usize;
                        let _ = writeln!(
                            out,
                            "    {}{}",
                            " ".repeat(start as usize),
                            "^".repeat(width)
                        );
                    }
                }
            }
        }
        if interp.restarts() > 0 || actions >= MAX_ACTIONS {
            break;
        }
    }
    if errors == 0 {
        let _ = writeln!(out, "{name}: ok, {actions} actions");
    } else {
        let _ = writeln!(
            out,
            "{name}: {errors} error{}, {actions} actions",
            if errors == 1 { "" } else { "s" }
        );
    }
    (out, errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn millimetres_format() {
        assert_eq!(mm(0), "0");
        assert_eq!(mm(10_000_000), "10");
        assert_eq!(mm(1_500_000), "1.5");
        assert_eq!(mm(-254_000), "-0.254");
        assert_eq!(mm(7_071_068), "7.071068");
        assert_eq!(mm(-1), "-0.000001");
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

//! `gantry simulate`: plan a program and report per-move speeds and the total time.
//!
//! The program is interpreted with the machine setup (`--setup`, else the default one), then run
//! through the real motion core (planner and segment prep) on virtual time, each segment counted
//! by its duration rather than stepped (`preview::plan::run_segments`), dwells added in closed
//! form (`preview::plan::without_dwell_time`); M codes
//! that switch an output on the fly do not stop the motion, as on the board. Each move (consecutive planner blocks
//! of one source line, so an arc is one move) prints its line, entry, cruise (highest) and exit
//! speed in mm/min and its duration; `--json` prints the same as JSON Lines. The last line is
//! always `total time: T s` (dwells included).
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

use gantry_machine::canon::Canon;
use gantry_machine::gcode::{Interpreter, MemorySource};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::kernel::KERNEL_TIMER_HZ;
use gantry_machine::motion::pipeline::PushError;
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::motion::sim::{Sim, SimEvent};
use gantry_machine::setup::Setup;

/// Most actions one simulation takes (endless loops, huge repeat counts).
const MAX_ACTIONS: usize = 5_000_000;

/// One reported move: consecutive blocks of the same source line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    pub line: u32,
    /// Speeds in mm/min.
    pub entry: f64,
    pub cruise: f64,
    pub exit: f64,
    /// Duration in seconds.
    pub time: f64,
}

/// nm/s → mm/min.
fn mm_min(v: u64) -> f64 {
    v as f64 * 60.0 / 1e6
}

/// Simulates `program` on the machine `setup`; returns the moves and the total time in seconds.
pub fn simulate(program: &[u8], setup: &Setup) -> anyhow::Result<(Vec<Move>, f64)> {
    let mut interp = Interpreter::new(&setup.interp_config());
    let mut src = MemorySource::new(program);
    let mut actions: Vec<Canon> = Vec::new();
    while let Some(item) = interp.next(&mut src) {
        let c = item.map_err(|e| anyhow::anyhow!("line {}: {:?}", e.line, e))?;
        actions.push(c);
        if interp.restarts() > 0 {
            break;
        }
        if actions.len() >= MAX_ACTIONS {
            anyhow::bail!("more than {MAX_ACTIONS} actions, simulation stopped");
        }
    }
    let cfg = MotionConfig::from_setup(setup);
    let mut sim: Box<Sim<128>> = Box::new(Sim::new(cfg));
    for l in &setup.outputs.mcode_lists {
        if let Some(output) = l.on_the_fly() {
            let _ = sim.on_the_fly.push((l.code, output));
        }
    }
    let (actions, dwell_counts) = crate::preview::plan::without_dwell_time(&actions);
    let mut reports: Vec<BlockReport> = Vec::new();
    crate::preview::plan::run_segments(&mut *sim, actions, &mut |e| {
        if let SimEvent::Block { report, .. } = e {
            reports.push(report);
        }
    })
    .map_err(|(c, e)| match e {
        PushError::Travel { axis } => anyhow::anyhow!(
            "line {}: move leaves the travel of axis {}",
            c.line,
            gantry_machine::units::AXIS_LETTERS[axis]
        ),
        PushError::Full => anyhow::anyhow!("line {}: motion queue refused the action", c.line),
    })?;
    let mut moves: Vec<Move> = Vec::new();
    let hz = KERNEL_TIMER_HZ as f64;
    let mut last_line = None;
    for r in &reports {
        let time = r.counts as f64 / hz;
        match moves.last_mut() {
            Some(m) if last_line == Some(r.line) => {
                m.cruise = m.cruise.max(mm_min(r.peak));
                m.exit = mm_min(r.exit);
                m.time += time;
            }
            _ => moves.push(Move {
                line: r.line,
                entry: mm_min(r.entry),
                cruise: mm_min(r.peak),
                exit: mm_min(r.exit),
                time,
            }),
        }
        last_line = Some(r.line);
    }
    Ok((moves, (sim.now + dwell_counts) as f64 / hz))
}

/// The whole report text. With `json`, JSON Lines written by serde_json: one object per move
/// (`line`, `entry`, `cruise`, `exit` in mm/min, `time` in s, rounded as in the table), then
/// `{"total_time": T}`; no other line.
pub fn report(moves: &[Move], total: f64, json: bool) -> String {
    let round = |v: f64, digits: i32| {
        let f = 10f64.powi(digits);
        (v * f).round() / f
    };
    let mut out = String::new();
    for m in moves {
        if json {
            let obj = serde_json::json!({
                "line": m.line,
                "entry": round(m.entry, 3),
                "cruise": round(m.cruise, 3),
                "exit": round(m.exit, 3),
                "time": round(m.time, 6),
            });
            let _ = writeln!(out, "{obj}");
        } else {
            let _ = writeln!(
                out,
                "line {:>6}  entry {:>9.3}  cruise {:>9.3}  exit {:>9.3} mm/min  time {:>9.6} s",
                m.line, m.entry, m.cruise, m.exit, m.time
            );
        }
    }
    if json {
        let _ = writeln!(
            out,
            "{}",
            serde_json::json!({ "total_time": round(total, 6) })
        );
    } else {
        let _ = writeln!(out, "total time: {total:.3} s");
    }
    out
}

/// Runs `gantry simulate FILE [--json] [--setup S]`.
pub fn run(file: &Path, json: bool, setup: &Setup) -> anyhow::Result<ExitCode> {
    let text =
        std::fs::read(file).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
    let (moves, total) = simulate(&text, setup)?;
    print!("{}", report(&moves, total, json));
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_time_and_speeds() {
        // 60 mm at F1200 (20 mm/s), 200 mm/s², start speed 60 mm/min: ramps of ≈1 mm each.
        let (moves, total) = simulate(b"G21 G90\nG1 X60 F1200\nM2\n", &Setup::default()).unwrap();
        assert_eq!(moves.len(), 1);
        let m = moves[0];
        assert_eq!(m.line, 2);
        assert!((m.cruise - 1200.0).abs() < 0.01, "{m:?}");
        assert!((m.entry - 60.0).abs() < 0.01, "{m:?}");
        // 3 s cruise + about 0.1 s extra for the two ramps.
        assert!(total > 3.0 && total < 3.11, "{total}");
        let text = report(&moves, total, false);
        assert!(text.lines().last().unwrap().starts_with("total time: 3.0"));
        let json = report(&moves, total, true);
        // Every line is JSON (serde_json), the last one the total.
        let values: Vec<serde_json::Value> = json
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(values[0]["line"], 2);
        assert_eq!(values[0]["entry"], 60.0);
        assert_eq!(values[0]["cruise"], 1200.0);
        assert!((values[1]["total_time"].as_f64().unwrap() - total).abs() < 1e-6);
    }

    #[test]
    fn on_the_fly_m_codes_do_not_stop_the_motion_and_others_do() {
        use gantry_machine::setup::{ListCommand, McodeList};
        let mut setup = Setup::default();
        for (code, commands) in [
            (14, &[ListCommand::Set(1)][..]),
            (16, &[ListCommand::Set(1), ListCommand::DwellMs(0)][..]),
        ] {
            setup.program.user_mcodes.push(code).unwrap();
            let mut l = McodeList {
                code,
                dry_run_disabled: false,
                commands: Default::default(),
            };
            l.commands.extend_from_slice(commands).unwrap();
            setup.outputs.mcode_lists.push(l).unwrap();
        }
        let prog = |m: u16| format!("G21 G91\nG1 X10 F1200\nX10 M{m}\nX10\nM2\n");
        let (moves, _) = simulate(prog(14).as_bytes(), &setup).unwrap();
        // Line 2 runs into line 3 at the feed: M14 switches on the fly.
        assert!((moves[0].exit - 1200.0).abs() < 0.01, "{moves:?}");
        let (moves, _) = simulate(prog(16).as_bytes(), &setup).unwrap();
        // M16's list has two entries: the motion stops before line 3 (start speed 60 mm/min).
        assert!((moves[0].exit - 60.0).abs() < 0.01, "{moves:?}");
    }
}

//! `gantry simulate`: plan a program and report per-move speeds and the total time.
//!
//! The program is interpreted with the machine setup (`--setup`, else the default one) and read
//! line by line ([`crate::preview::source`]), then run through the real motion core's planner on
//! virtual time, each planned block timed in closed form from the profile segment prep would run
//! (`preview::plan::plan_stream`, `Sim::run_planned`); M codes that switch an output on the fly
//! do not stop the motion, as on the board. Each move (consecutive planner blocks of one source
//! line, so an arc is one move) prints its line, entry, cruise (highest) and exit speed in mm/min
//! and its duration, its peak acceleration and jerk (`step` for the trapezoid, whose acceleration
//! switches at once), as soon as it is planned; `--json` prints the same as JSON Lines. The last
//! line is always `total time: T s` (dwells included). Memory stays the same whatever the
//! program's length.
use std::io::Write as _;
use std::path::Path;
use std::process::ExitCode;

use crate::preview::source::{Actions, Ended, FileSource};
use gantry_machine::gcode::{MemorySource, ProgramSource};
use gantry_machine::motion::pipeline::PushError;
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::setup::Setup;
use gantry_machine::step::kernel::KERNEL_TIMER_HZ;

/// One reported move: consecutive blocks of the same source line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    pub(crate) line: u32,
    /// Speeds in mm/min.
    pub(crate) entry: f64,
    pub(crate) cruise: f64,
    pub(crate) exit: f64,
    /// Duration in seconds.
    pub(crate) time: f64,
    /// Highest path acceleration, mm/s², and jerk, mm/s³ (`None`: the acceleration switched
    /// at once, the trapezoid's ramps).
    pub(crate) accel: f64,
    pub(crate) jerk: Option<f64>,
}

/// nm/s² (nm/s³) → mm/s² (mm/s³).
fn mm(v: u64) -> f64 {
    v as f64 / 1e6
}

/// A block report's jerk in mm/s³, `None` for the trapezoid's step.
fn jerk_of(r: &BlockReport) -> Option<f64> {
    (r.jerk != gantry_machine::motion::prep::STEP_JERK).then(|| mm(r.jerk))
}

/// nm/s → mm/min.
fn mm_min(v: u64) -> f64 {
    v as f64 * 60.0 / 1e6
}

/// Block reports into moves: a move is finished when a block of another line follows.
#[derive(Default)]
struct Moves {
    current: Option<Move>,
}

impl Moves {
    /// Adds a block; returns the move it finished, if any.
    fn add(&mut self, r: &BlockReport) -> Option<Move> {
        let time = r.counts as f64 / KERNEL_TIMER_HZ as f64;
        match self.current.as_mut() {
            Some(m) if m.line == r.line => {
                m.cruise = m.cruise.max(mm_min(r.peak));
                m.exit = mm_min(r.exit);
                m.time += time;
                m.accel = m.accel.max(mm(r.accel));
                m.jerk = match (m.jerk, jerk_of(r)) {
                    (Some(a), Some(b)) => Some(a.max(b)),
                    _ => None,
                };
                None
            }
            _ => self.current.replace(Move {
                line: r.line,
                entry: mm_min(r.entry),
                cruise: mm_min(r.peak),
                exit: mm_min(r.exit),
                time,
                accel: mm(r.accel),
                jerk: jerk_of(r),
            }),
        }
    }
}

/// Simulates the program in `src` on the machine `setup`, calling `on_move` with each move as
/// soon as it is planned; returns the total time in seconds.
pub(crate) fn simulate_stream<S: ProgramSource>(
    src: S,
    setup: &Setup,
    on_move: &mut impl FnMut(Move),
) -> anyhow::Result<f64> {
    simulate_stream_from(src, setup, &[0; gantry_machine::units::MAX_AXES], on_move)
}

/// [`simulate_stream`] with the machine at `at` (nm) when the program starts.
pub(crate) fn simulate_stream_from<S: ProgramSource>(
    src: S,
    setup: &Setup,
    at: &gantry_machine::units::Pos,
    on_move: &mut impl FnMut(Move),
) -> anyhow::Result<f64> {
    let mut actions = Actions::new(src, &setup.interp_config()).starting_at(at);
    let mut moves = Moves::default();
    let planned =
        crate::preview::plan::plan_stream_from(actions.by_ref(), setup, at, &mut |r, _| {
            if let Some(m) = moves.add(r) {
                on_move(m);
            }
        });
    if let Some(m) = moves.current.take() {
        on_move(m);
    }
    match &actions.ended {
        Ended::No => {}
        Ended::Error(e) => anyhow::bail!("line {}: {:?}", e.line, e),
        Ended::Limit(n) => {
            anyhow::bail!("{n} actions, more than the program's lines allow: simulation stopped (an endless loop?)")
        }
    }
    let counts = planned.map_err(|(c, e)| match e {
        PushError::Travel { axis } => anyhow::anyhow!(
            "line {}: move leaves the travel of axis {}",
            c.line,
            gantry_machine::units::AXIS_LETTERS[axis]
        ),
        PushError::Full => anyhow::anyhow!("line {}: motion queue refused the action", c.line),
    })?;
    Ok(crate::preview::plan::seconds(counts))
}

/// Simulates `program` on the machine `setup`; returns the moves and the total time in seconds.
pub fn simulate(program: &[u8], setup: &Setup) -> anyhow::Result<(Vec<Move>, f64)> {
    let mut moves = Vec::new();
    let total = simulate_stream(MemorySource::new(program), setup, &mut |m| moves.push(m))?;
    Ok((moves, total))
}

fn round(v: f64, digits: i32) -> f64 {
    let f = 10f64.powi(digits);
    (v * f).round() / f
}

/// One move as `simulate` prints it (JSON written by serde_json with `json`), without newline.
pub(crate) fn move_line(m: &Move, json: bool) -> String {
    if json {
        serde_json::json!({
            "line": m.line,
            "entry": round(m.entry, 3),
            "cruise": round(m.cruise, 3),
            "exit": round(m.exit, 3),
            "time": round(m.time, 6),
            "accel": round(m.accel, 1),
            "jerk": m.jerk.map(|j| round(j, 0)),
        })
        .to_string()
    } else {
        let jerk = m.jerk.map_or("step".to_string(), |j| format!("{j:.0}"));
        format!(
            "line {:>6}  entry {:>9.3}  cruise {:>9.3}  exit {:>9.3} mm/min  time {:>9.6} s  accel {:>7.1} mm/s²  jerk {jerk:>7} mm/s³",
            m.line, m.entry, m.cruise, m.exit, m.time, m.accel
        )
    }
}

/// The last line: `total time: T s`, or `{"total_time": T}`.
pub(crate) fn total_line(total: f64, json: bool) -> String {
    if json {
        serde_json::json!({ "total_time": round(total, 6) }).to_string()
    } else {
        format!("total time: {total:.3} s")
    }
}

/// The whole report text. With `json`, JSON Lines written by serde_json: one object per move
/// (`line`, `entry`, `cruise`, `exit` in mm/min, `time` in s, `accel` in mm/s², `jerk` in mm/s³
/// or null for the trapezoid's step, rounded as in the table), then
/// `{"total_time": T}`; no other line.
#[cfg(test)]
pub(crate) fn report(moves: &[Move], total: f64, json: bool) -> String {
    let mut out = String::new();
    for m in moves {
        out.push_str(&move_line(m, json));
        out.push('\n');
    }
    out.push_str(&total_line(total, json));
    out.push('\n');
    out
}

/// Runs `gantry simulate FILE [--json] [--setup S]`: each move is printed as soon as it is
/// planned, so the output streams and nothing of the program is held.
/// `at`: where the machine stands when the job starts (nm; `crate::session::standing`).
pub fn run(
    file: &Path,
    json: bool,
    setup: &Setup,
    at: &gantry_machine::units::Pos,
) -> anyhow::Result<ExitCode> {
    let src = FileSource::open(file)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", file.display()))?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
    let mut write_error = None;
    let total = simulate_stream_from(src, setup, at, &mut |m| {
        if write_error.is_none() {
            if let Err(e) = writeln!(out, "{}", move_line(&m, json)) {
                write_error = Some(e);
            }
        }
    });
    if let Some(e) = write_error {
        return Err(e.into());
    }
    let total = match total {
        Ok(t) => t,
        Err(e) => {
            out.flush()?;
            return Err(e);
        }
    };
    writeln!(out, "{}", total_line(total, json))?;
    out.flush()?;
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
        // The trapezoid: its acceleration, switched at once.
        assert_eq!((m.accel, m.jerk), (200.0, None));
        assert_eq!(values[0]["jerk"], serde_json::Value::Null);
    }

    #[test]
    fn a_jerk_limit_reports_its_peaks_and_costs_its_ramps() {
        let mut setup = Setup::default();
        for a in setup.axes.iter_mut() {
            a.jerk = 5_000_000_000;
        }
        let (moves, total) = simulate(b"G21 G90\nG1 X60 F1200\nM2\n", &setup).unwrap();
        let m = moves[0];
        // 20 mm/s is above A²/J = 8 mm/s: each ramp reaches 200 mm/s² and lasts
        // A/J = 40 ms longer than the trapezoid's, from rest (no start-speed jump).
        assert!(m.accel > 199.0 && m.accel <= 200.0, "{m:?}");
        let jerk = m.jerk.unwrap();
        assert!(jerk > 4_900.0 && jerk <= 5_001.0, "{m:?}");
        assert_eq!(m.entry, 0.0);
        assert!(total > 3.1 && total < 3.2, "{total}");
        let json = report(&moves, total, true);
        let first: serde_json::Value = serde_json::from_str(json.lines().next().unwrap()).unwrap();
        assert_eq!(first["jerk"].as_f64(), Some(jerk.round()));
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

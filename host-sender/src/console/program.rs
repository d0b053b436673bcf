//! The console's program: a file uploaded from the page, checked with the board's setup as
//! `gantry check` checks it (the same text: errors with their line and a caret, the summary with
//! the planned time), and its tool path as polylines for the page's canvas.

use crate::check::check_stream_from;
use crate::check_summary::format_summary;
use crate::preview::adapt::MoveAdapter;
use crate::preview::geom::arc_interior;
use crate::preview::source::Actions;
use crate::preview::MoveKind;
use gantry_machine::gcode::MemorySource;
use gantry_machine::setup::Setup;
use std::fmt::Write as _;

/// At most this many path points go to the page (a longer path is thinned evenly).
const POINTS_MAX: usize = 400_000;

/// What checking a program found.
pub(crate) struct Checked {
    /// `gantry check`'s report.
    pub(crate) text: String,
    pub(crate) errors: usize,
    /// The lines the errors are at (1-based), in order.
    pub(crate) error_lines: Vec<u32>,
    /// Planned machine time, s (none when the check found an error).
    pub(crate) seconds: Option<f64>,
    /// Tools the program loads with M6, in order of first use.
    pub(crate) tools: Vec<u32>,
}

/// Checks `text` (named `name`) with `setup` for a job that starts with the machine at `here`
/// (machine nm), as `gantry check --port P NAME` does (`crate::check::check_stream_from`): the
/// extents and the planned time start where the tool stands.
pub(crate) fn check(name: &str, text: &str, setup: &Setup, here: &[i64; 6]) -> Checked {
    let mut out = Vec::new();
    let (errors, summary) = check_stream_from(
        name,
        MemorySource::new(text.as_bytes()),
        &setup.interp_config(),
        Some(setup),
        here,
        &mut out,
    )
    .expect("writing to memory does not fail");
    let mut report = String::from_utf8_lossy(&out).into_owned();
    let error_lines = crate::check::error_lines(&report, name);
    let mut seconds = None;
    let tools = summary.as_ref().map_or_else(Vec::new, |s| s.tools.clone());
    if let Some(s) = &summary {
        if errors == 0 {
            seconds = s.run_time_s;
        }
        report.push_str(&format_summary(s, setup));
    }
    Checked {
        text: report,
        errors,
        error_lines,
        seconds,
        tools,
    }
}

/// The tool path as JSON: `{"pts":[kind,line,x,y,z,…]}` where each point ends a move from the
/// point before (kind 0 rapid, 1 feed, 2 the first point), machine mm with the setup's work
/// offsets, starting where the tool stands (`here`, machine nm: the first move is the one the
/// machine will make from there), up to the first error. The page draws it in work coordinates
/// by taking off the board's active work offset, or in machine coordinates.
pub(crate) fn path_json(text: &str, setup: &Setup, here: &[i64; 6]) -> String {
    let mut pts: Vec<(u8, u32, [f64; 3])> = Vec::new();
    // The moves as `gantry preview` takes them (mm, arcs with their geometry).
    let mut moves = MoveAdapter::new(setup).starting_at(here);
    let mut actions = Actions::new(MemorySource::new(text.as_bytes()), &setup.interp_config());
    let mut state = *actions.interp.state();
    state.position = *here;
    actions.interp.set_state(state);
    pts.push((2, 0, [0, 1, 2].map(|i| here[i] as f64 / 1e6)));
    for c in actions {
        let Some(m) = moves.take(&c) else {
            continue;
        };
        let kind = match &m.kind {
            MoveKind::Rapid => 0u8,
            MoveKind::Feed => 1,
            MoveKind::Arc(arc) => {
                for p in arc_interior(m.from, m.to, arc, 0.25, (4, 720)) {
                    pts.push((1, m.line, p));
                }
                1
            }
        };
        pts.push((kind, m.line, m.to));
    }
    let keep = pts.len().div_ceil(POINTS_MAX).max(1);
    let mut out = String::from("{\"pts\":[");
    let last = pts.len().saturating_sub(1);
    for (i, (k, line, p)) in pts.iter().enumerate() {
        // Thinning keeps every rapid, the first and the last point.
        if keep > 1 && *k == 1 && i % keep != 0 && i != last {
            continue;
        }
        if out.len() > 8 {
            out.push(',');
        }
        let _ = write!(out, "{k},{line},{:.3},{:.3},{:.3}", p[0], p[1], p[2]);
    }
    out.push_str("]}");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_names_the_error_lines_and_the_time() {
        let setup = Setup::default();
        let ok = check("p.nc", "G21 G90\nG1 X10 F600\nM30\n", &setup, &[0; 6]);
        assert_eq!(ok.errors, 0, "{}", ok.text);
        assert!(ok.seconds.unwrap() > 0.9, "{:?}", ok.seconds);
        let bad = check(
            "p.nc",
            "G21 G90\nG1 X10 F600\nG1 X5 Q\nM30\n",
            &setup,
            &[0; 6],
        );
        assert_eq!(bad.errors, 1, "{}", bad.text);
        assert_eq!(bad.error_lines, vec![3], "{}", bad.text);
        assert!(bad.text.contains("p.nc:3:"), "{}", bad.text);
    }

    /// The page's check figures are `gantry check --port`'s: extents and planned time from where
    /// the tool stands (an incremental move from X 295 leaves the ±300 mm travel, from 0 it does not).
    #[test]
    fn the_check_starts_where_the_tool_stands() {
        let setup = Setup::default();
        let text = "G21 G91\nG1 X10 F600\nM30\n";
        let at_zero = check("p.nc", text, &setup, &[0; 6]);
        assert!(
            at_zero.text.contains("within the machine travel"),
            "{}",
            at_zero.text
        );
        let here = [295_000_000, 0, 0, 0, 0, 0];
        let near_the_end = check("p.nc", text, &setup, &here);
        assert!(
            near_the_end.text.contains("295.000 ..    305.000 mm"),
            "{}",
            near_the_end.text
        );
        assert!(
            near_the_end.text.contains("EXCEEDED"),
            "{}",
            near_the_end.text
        );
    }

    #[test]
    fn the_path_starts_where_the_tool_stands() {
        // The tool at machine X 5 Y 7 Z -3: the first rapid (Z only) starts there.
        let here = [5_000_000, 7_000_000, -3_000_000, 0, 0, 0];
        let j = path_json("G21 G90\nG0 Z1\nG0 X20 Y30\n", &Setup::default(), &here);
        let v: serde_json::Value = serde_json::from_str(&j).unwrap();
        let pts: Vec<f64> = v["pts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(
            pts,
            vec![
                2.0, 0.0, 5.0, 7.0, -3.0, //
                0.0, 2.0, 5.0, 7.0, 1.0, //
                0.0, 3.0, 20.0, 30.0, 1.0
            ]
        );
    }

    #[test]
    fn the_path_follows_lines_and_arcs() {
        let j = path_json(
            "G21 G90\nG0 X0 Y0\nG1 X10 F600\nG3 X0 Y10 I-10 J0\n",
            &Setup::default(),
            &[0; 6],
        );
        let v: serde_json::Value = serde_json::from_str(&j).unwrap();
        let pts = v["pts"].as_array().unwrap();
        assert_eq!(pts.len() % 5, 0);
        // Starts where the tool stands (the origin), ends at (0, 10); the arc stays 10 mm from
        // the centre.
        let first: Vec<f64> = pts[..5].iter().map(|v| v.as_f64().unwrap()).collect();
        assert_eq!(first, vec![2.0, 0.0, 0.0, 0.0, 0.0]);
        let n = pts.len() / 5;
        let x = pts[(n - 1) * 5 + 2].as_f64().unwrap();
        let y = pts[(n - 1) * 5 + 3].as_f64().unwrap();
        assert!(x.abs() < 1e-3 && (y - 10.0).abs() < 1e-3, "{x} {y}");
        for i in 0..n {
            if pts[i * 5 + 1].as_u64() == Some(4) {
                let (x, y) = (
                    pts[i * 5 + 2].as_f64().unwrap(),
                    pts[i * 5 + 3].as_f64().unwrap(),
                );
                assert!((x.hypot(y) - 10.0).abs() < 2e-3, "{x} {y}");
            }
        }
    }
}

//! The summary table plain `gantry check` ends with: extents against the machine travel (and the
//! first line that would hit a soft limit), tools used, the default canned-cycle retract mode, and
//! the run time the planner estimates —
//! the same figure the board takes at 100 % override.

use crate::preview::adapt::MoveAdapter;
use crate::preview::geom::extend;
use crate::preview::model::Box3;
use crate::preview::plan;
#[cfg(test)]
use crate::preview::source::Actions;
use gantry_machine::canon::{Action, Canon, Spindle};
#[cfg(test)]
use gantry_machine::gcode::MemorySource;
use gantry_machine::gcode::RetractMode;
use gantry_machine::setup::Setup;
use gantry_machine::units::Pos;
#[cfg(test)]
use gantry_machine::units::MAX_AXES;
use std::fmt::Write as _;

/// What the summary found.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct JobSummary {
    /// Job extents, mm (X, Y, Z), `None` for a job without motion.
    pub(crate) extents: Option<Box3>,
    /// First line whose move leaves the travel, with the axis letter.
    pub(crate) leaves_travel: Option<(u32, char)>,
    /// Tools loaded by M6, in order of first use.
    pub(crate) tools: Vec<u32>,
    /// Planned run time at 100 % override, s (`None` when the planner refused the program).
    pub(crate) run_time_s: Option<f64>,
    pub(crate) moves: usize,
    /// Spindle speeds outside the setup's `spindle.rpm_range` (line, S), the first
    /// [`CLAMPED_KEPT`]: the board clamps them to the range (docs/settings.md).
    pub(crate) rpm_clamped: Vec<(u32, u32)>,
    /// How many more there were beyond those kept.
    pub(crate) rpm_clamped_more: usize,
}

/// How many out-of-range spindle speeds a summary names one by one.
pub(crate) const CLAMPED_KEPT: usize = 10;

/// The summary's running aggregates, one action at a time (nothing of the program is kept).
pub(crate) struct Aggregates {
    adapter: MoveAdapter,
    travel: Box3,
    extents: Box3,
    leaves_travel: Option<(u32, char)>,
    tools: Vec<u32>,
    moves: usize,
    /// The setup's `spindle.rpm_range`.
    rpm_range: (u32, u32),
    rpm_clamped: Vec<(u32, u32)>,
    rpm_clamped_more: usize,
}

impl Aggregates {
    /// Aggregates of a job that starts with the machine at `at` (nm).
    pub(crate) fn from(setup: &Setup, at: &Pos) -> Self {
        Aggregates {
            adapter: MoveAdapter::new(setup).starting_at(at),
            travel: Box3::travel(setup),
            extents: Box3::EMPTY,
            leaves_travel: None,
            tools: Vec::new(),
            moves: 0,
            rpm_range: (setup.outputs.spindle_min_rpm, setup.outputs.spindle_max_rpm),
            rpm_clamped: Vec::new(),
            rpm_clamped_more: 0,
        }
    }

    pub(crate) fn add(&mut self, c: &Canon) {
        if let Action::Spindle { state, rpm } = c.action {
            let (lo, hi) = self.rpm_range;
            // S0 (and M5) is the spindle off, never clamped.
            if state != Spindle::Off && rpm != 0 && !(lo..=hi).contains(&rpm) {
                if self.rpm_clamped.len() < CLAMPED_KEPT {
                    self.rpm_clamped.push((c.line, rpm));
                } else {
                    self.rpm_clamped_more += 1;
                }
            }
        }
        if let Action::ToolChange { tool } = c.action {
            if !self.tools.contains(&tool) {
                self.tools.push(tool);
            }
        }
        let Some(m) = self.adapter.take(c) else {
            return;
        };
        self.moves += 1;
        let mut b = Box3::EMPTY;
        extend(&mut b, &m);
        if self.leaves_travel.is_none() && !self.travel.contains(&b) {
            let t = &self.travel;
            let axis = (0..3)
                .find(|&i| b.min[i] < t.min[i] - 1e-6 || b.max[i] > t.max[i] + 1e-6)
                .unwrap_or(0);
            self.leaves_travel = Some((m.line, ['X', 'Y', 'Z'][axis]));
        }
        if !b.is_empty() {
            self.extents.add(b.min);
            self.extents.add(b.max);
        }
    }

    pub(crate) fn finish(self, run_time_s: Option<f64>) -> JobSummary {
        let e = self.extents;
        JobSummary {
            extents: (!e.is_empty()).then_some(e),
            leaves_travel: self.leaves_travel,
            tools: self.tools,
            run_time_s,
            moves: self.moves,
            rpm_clamped: self.rpm_clamped,
            rpm_clamped_more: self.rpm_clamped_more,
        }
    }
}

/// Summarises a program's actions in one pass, pulled one at a time: the aggregates and the
/// planned time (closed form per block, `preview::plan`). A move the planner refuses (beyond the
/// travel) leaves the time unknown; the aggregates still cover every action.
#[cfg(test)]
pub(crate) fn summarize_actions(actions: impl Iterator<Item = Canon>, setup: &Setup) -> JobSummary {
    summarize_actions_from(actions, setup, &[0; MAX_AXES])
}

/// [`summarize_actions`] of a job that starts with the machine at `at` (nm): the extents and the
/// planned time include the way from there.
pub(crate) fn summarize_actions_from(
    actions: impl Iterator<Item = Canon>,
    setup: &Setup,
    at: &Pos,
) -> JobSummary {
    let mut agg = Aggregates::from(setup, at);
    let mut actions = actions.inspect(|c| agg.add(c));
    let planned = plan::plan_stream_from(actions.by_ref(), setup, at, &mut |_, _| {});
    if planned.is_err() {
        actions.for_each(drop);
    }
    agg.finish(planned.ok().map(plan::seconds))
}

/// Interprets and plans `program` on `setup` (only the part before a first error, if any).
#[cfg(test)]
pub(crate) fn summarize(program: &[u8], setup: &Setup) -> JobSummary {
    let actions = Actions::new(MemorySource::new(program), &setup.interp_config());
    summarize_actions(actions, setup)
}

/// The table as printed.
pub(crate) fn format_summary(s: &JobSummary, setup: &Setup) -> String {
    let mut out = String::from("summary\n");
    let _ = writeln!(out, "  moves       {}", s.moves);
    match &s.extents {
        Some(e) => {
            for (i, axis) in ['X', 'Y', 'Z'].iter().enumerate() {
                let a = &setup.axes[i];
                let _ = writeln!(
                    out,
                    "  {axis} extents   {:>10.3} .. {:>10.3} mm   (travel {:.3} .. {:.3})",
                    e.min[i],
                    e.max[i],
                    a.travel_min as f64 / 1e6,
                    a.travel_max as f64 / 1e6
                );
            }
        }
        None => out.push_str("  extents     no motion\n"),
    }
    match s.leaves_travel {
        Some((line, axis)) => {
            let _ = writeln!(
                out,
                "  travel      EXCEEDED: line {line} leaves the {axis} travel (soft limit)"
            );
        }
        None => out.push_str("  travel      within the machine travel\n"),
    }
    let tools: Vec<String> = s.tools.iter().map(|t| format!("T{t}")).collect();
    let _ = writeln!(
        out,
        "  tools       {}",
        if tools.is_empty() {
            "none".to_owned()
        } else {
            tools.join(" ")
        }
    );
    let _ = writeln!(
        out,
        "  retract     {} until the program sets G98 or G99 (setup program.default_retract)",
        match setup.program.default_retract {
            RetractMode::InitialLevel => "G98 (canned cycles return to the initial level)",
            RetractMode::RPlane => "G99 (canned cycles return to the R plane)",
        }
    );
    match s.run_time_s {
        Some(t) => {
            let _ = writeln!(
                out,
                "  run time    {t:.3} s (planner, 100 % override: {}:{:06.3})",
                (t / 60.0).floor(),
                t % 60.0
            );
        }
        None => out.push_str("  run time    unknown (the planner refused the program)\n"),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_example_job_is_summarised() {
        let s = summarize(
            include_bytes!("../../examples/bracket.ngc"),
            &Setup::default(),
        );
        let e = s.extents.unwrap();
        assert_eq!(
            e.min.map(|v| (v * 1000.0).round()),
            [-4000.0, -4000.0, -3500.0]
        );
        assert_eq!(
            e.max.map(|v| (v * 1000.0).round()),
            [64000.0, 44000.0, 10000.0]
        );
        assert_eq!(s.leaves_travel, None);
        assert_eq!(s.tools, vec![1]);
        // The same figure `gantry simulate` prints for this job.
        assert_eq!(format!("{:.3}", s.run_time_s.unwrap()), "51.874");
    }

    #[test]
    fn the_first_line_beyond_the_travel_is_named() {
        let s = summarize(
            b"G21 G90\nG0 X10\nG2 X20 Y0 I5 J0 F100\nG0 X350\n",
            &Setup::default(),
        );
        assert_eq!(s.leaves_travel, Some((4, 'X')));
        let text = format_summary(&s, &Setup::default());
        assert!(text.contains("line 4 leaves the X travel"), "{text}");
        assert!(text.contains("retract     G98 (canned cycles return to the initial level)"));
        let mut g99 = Setup::default();
        g99.program.default_retract = RetractMode::RPlane;
        assert!(format_summary(&s, &g99).contains("retract     G99"));
        // An arc bulging past the travel counts too: Y max is 200 by default.
        let s = summarize(
            b"G21 G90 G0 X0 Y195\nG2 X20 Y195 I10 J0 F100\n",
            &Setup::default(),
        );
        assert_eq!(s.leaves_travel, Some((2, 'Y')));
    }
}

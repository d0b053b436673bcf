//! One pass over a program's actions for the preview: each move in program order with its
//! programmed feed and, when the planner runs alongside, its planned peak speed — holding only the
//! moves whose blocks the planner has not finished yet (its look-ahead), never the whole program.
//!
//! The planner reports finished blocks in program order, tagged with their source line (arcs are
//! cut into several chord blocks). Pending moves are grouped in runs of consecutive moves of one
//! line; a block of line L finishes every run in front of the oldest run of line L, and the run
//! of line L takes the block's peak if it is the highest so far (feed blocks of non-zero length
//! only). A move's speed is thus the highest planned peak of its own
//! line's blocks at that point of the program (a line run twice, by a subprogram or a loop, is
//! coloured per run, not by its highest peak over the whole program).

use super::adapt::MoveAdapter;
use super::model::{MoveKind, PreviewMove};
use super::plan;
use gantry_machine::canon::Canon;
use gantry_machine::motion::prep::BlockReport;
use gantry_machine::setup::Setup;
use gantry_machine::units::NM_PER_MM;
use std::cell::RefCell;
use std::collections::VecDeque;

/// Pending moves held at most: past this (a line that makes moves without planner blocks, such as
/// many zero-length moves), the oldest is handed out with the peak known so far.
pub(crate) const MAX_PENDING: usize = 4096;

/// How a pass ended.
#[derive(Debug)]
pub(crate) struct PassEnd {
    /// Time estimate from the programmed feeds, without acceleration, s.
    pub(crate) estimate_s: f64,
    /// Planned job time in kernel timer counts, or the note saying why the planner refused the
    /// program (`None` when the pass did not plan).
    pub(crate) planned: Option<Result<u64, String>>,
}

/// Moves whose blocks the planner has not finished.
struct Pending<'a> {
    adapter: MoveAdapter,
    moves: VecDeque<PreviewMove>,
    /// (line, moves, highest feed peak so far, mm/min), oldest first.
    runs: VecDeque<(u32, usize, Option<f64>)>,
    /// The planner gave up: moves go out at once, without a planned speed.
    unplanned: bool,
    out: &'a mut dyn FnMut(&PreviewMove, Option<f64>),
}

impl Pending<'_> {
    fn action(&mut self, c: &Canon) {
        let Some(m) = self.adapter.take(c) else {
            return;
        };
        if self.unplanned {
            (self.out)(&m, None);
            return;
        }
        match self.runs.back_mut() {
            Some(run) if run.0 == m.line => run.1 += 1,
            _ => self.runs.push_back((m.line, 1, None)),
        }
        self.moves.push_back(m);
        if self.moves.len() > MAX_PENDING {
            self.pop_move();
        }
    }

    /// Hands out the oldest pending move.
    fn pop_move(&mut self) {
        let (Some(m), Some(run)) = (self.moves.pop_front(), self.runs.front_mut()) else {
            return;
        };
        let peak = run.2;
        run.1 -= 1;
        if run.1 == 0 {
            self.runs.pop_front();
        }
        let planned = if m.kind == MoveKind::Rapid {
            None
        } else {
            peak
        };
        (self.out)(&m, planned);
    }

    fn pop_run(&mut self) {
        if let Some(&(_, n, _)) = self.runs.front() {
            for _ in 0..n {
                self.pop_move();
            }
        }
    }

    fn block(&mut self, report: &BlockReport) {
        if !self.runs.iter().any(|r| r.0 == report.line) {
            return;
        }
        while self.runs.front().is_some_and(|r| r.0 != report.line) {
            self.pop_run();
        }
        if !report.rapid && report.length > 0 {
            // nm/s → mm/min.
            let v = report.peak as f64 * 60.0 / NM_PER_MM as f64;
            if let Some(run) = self.runs.front_mut() {
                run.2 = Some(run.2.map_or(v, |p| p.max(v)));
            }
        }
    }

    fn flush(&mut self) {
        while !self.moves.is_empty() {
            self.pop_move();
        }
    }
}

/// Runs `actions` once, calling `each` with every move (speed = programmed feed) and its planned
/// peak speed (mm/min; `None` for rapids, when not planning, after the planner refused a move, or
/// for a move without feed blocks). Plans on the `setup` machine when `planning`.
///
/// `at`: where the machine stands when the program starts (nm).
pub(crate) fn each_move(
    actions: impl Iterator<Item = Canon>,
    setup: &Setup,
    at: &gantry_machine::units::Pos,
    planning: bool,
    each: &mut dyn FnMut(&PreviewMove, Option<f64>),
) -> PassEnd {
    let pending = RefCell::new(Pending {
        adapter: MoveAdapter::new(setup).starting_at(at),
        moves: VecDeque::new(),
        runs: VecDeque::new(),
        unplanned: !planning,
        out: each,
    });
    let mut actions = actions.inspect(|c| pending.borrow_mut().action(c));
    let planned = if planning {
        let r = plan::plan_stream_from(actions.by_ref(), setup, at, &mut |report, _| {
            pending.borrow_mut().block(report)
        });
        let mut p = pending.borrow_mut();
        p.flush();
        p.unplanned = true;
        Some(r.map_err(|(c, e)| {
            super::planner_note(&anyhow::anyhow!(
                "line {}: planner refused the move: {e:?}",
                c.line
            ))
        }))
    } else {
        None
    };
    actions.for_each(drop);
    let estimate_s = pending.borrow().adapter.seconds;
    PassEnd {
        estimate_s,
        planned,
    }
}

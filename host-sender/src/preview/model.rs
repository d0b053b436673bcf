//! The renderer's input: moves in millimetres with an optional speed each, plus the job's totals.
//!
//! These types are deliberately independent of the interpreter and planner APIs; the adapters in
//! [`super::adapt`] fill them from canonical actions, canon JSON Lines or planner output.

use gantry_machine::canon::Plane;
use gantry_machine::setup::Setup;
use gantry_machine::units::NM_PER_MM;

/// A point in machine coordinates, millimetres (X, Y, Z).
pub(crate) type P3 = [f64; 3];

/// The geometry of an arc or helix (G2/G3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcGeom {
    /// Centre on the two plane axes (the normal-axis slot is ignored), mm.
    pub center: P3,
    pub plane: Plane,
    /// G3 (counter-clockwise seen from the positive end of the plane's normal axis).
    pub ccw: bool,
    /// Full turns as LinuxCNC counts them (≥ 1).
    pub turns: u32,
}

/// What kind of motion a move is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKind {
    /// G0: drawn dashed, not coloured by speed.
    Rapid,
    /// G1 straight feed.
    Feed,
    /// G2/G3 arc or helix.
    Arc(ArcGeom),
}

/// One move to draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviewMove {
    /// 1-based source line.
    pub(crate) line: u32,
    pub kind: MoveKind,
    pub(crate) from: P3,
    pub(crate) to: P3,
    /// Speed used for the colour scale (planned cruise speed, or the programmed feed), mm/min.
    pub(crate) speed_mm_min: Option<f64>,
}

/// Where the speeds (and the total time) of a job came from; shown in the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeedSource {
    /// The look-ahead planner's cruise speed per move and its total time.
    Planned,
    /// The programmed F word; the total time is estimated without acceleration.
    Programmed,
}

/// An axis-aligned box, mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Box3 {
    pub min: P3,
    pub max: P3,
}

impl Box3 {
    /// An empty box that any point extends.
    pub(crate) const EMPTY: Box3 = Box3 {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    /// The soft-limit travel box of the first three axes of `setup`.
    pub fn travel(setup: &Setup) -> Box3 {
        let mm = |nm: i64| nm as f64 / NM_PER_MM as f64;
        let mut b = Box3::EMPTY;
        for i in 0..3 {
            b.min[i] = mm(setup.axes[i].travel_min);
            b.max[i] = mm(setup.axes[i].travel_max);
        }
        b
    }

    pub(crate) fn is_empty(&self) -> bool {
        (0..3).any(|i| self.min[i] > self.max[i])
    }

    pub(crate) fn add(&mut self, p: P3) {
        for (i, v) in p.iter().enumerate() {
            self.min[i] = self.min[i].min(*v);
            self.max[i] = self.max[i].max(*v);
        }
    }

    /// The eight corners.
    pub(crate) fn corners(&self) -> [P3; 8] {
        let mut c = [[0.0; 3]; 8];
        for (k, p) in c.iter_mut().enumerate() {
            for (i, v) in p.iter_mut().enumerate() {
                *v = if k >> i & 1 == 0 {
                    self.min[i]
                } else {
                    self.max[i]
                };
            }
        }
        c
    }

    /// Whether `inner` lies inside this box (with a 1 nm tolerance).
    pub(crate) fn contains(&self, inner: &Box3) -> bool {
        (0..3).all(|i| inner.min[i] >= self.min[i] - 1e-6 && inner.max[i] <= self.max[i] + 1e-6)
    }
}

/// The error that ended a program: its source line and message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProgramError {
    pub(crate) line: u32,
    pub(crate) message: String,
}

/// Canonical actions of a program, and the error that ended it early (if any).
pub(crate) type Interpreted = (Vec<gantry_machine::canon::Canon>, Option<ProgramError>);

/// Everything the renderer draws.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewJob {
    /// Shown as the legend's heading (usually the file name).
    pub(crate) title: String,
    pub moves: Vec<PreviewMove>,
    /// Total job time, seconds (planned, or estimated — see `speed_source`).
    pub total_time_s: Option<f64>,
    pub(crate) speed_source: SpeedSource,
    /// The machine's travel (soft-limit) box.
    pub travel: Option<Box3>,
}

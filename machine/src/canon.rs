//! Canonical actions: what the interpreter hands to the planner and the controller.
//!
//! Every motion is in machine coordinates (all offsets already applied), every action carries the
//! source line it came from, and nothing here depends on the dialect that produced it.

use crate::units::{FeedNmPerMin, Nm, Pos};

/// One action of the interpreted program, tagged with its 1-based source line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Canon {
    pub line: u32,
    pub action: Action,
}

/// The plane an arc or canned cycle works in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17: arc in X/Y, helix along Z.
    XY,
    /// G18: arc in Z/X, helix along Y.
    ZX,
    /// G19: arc in Y/Z, helix along X.
    YZ,
}

/// Direction of an arc seen from the positive end of the plane's normal axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcDir {
    /// G2.
    Cw,
    /// G3.
    Ccw,
}

/// Spindle state (M3/M4/M5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spindle {
    Off,
    Cw,
    Ccw,
}

/// How a program stop came about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopKind {
    /// M0: always stops until cycle start.
    Pause,
    /// M1: stops only when the optional-stop switch is on.
    OptionalPause,
    /// M2: end of program.
    End,
    /// M30: end of program and rewind.
    EndRewind,
}

/// Path control mode (G61 / G64).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathMode {
    /// G61: come to a full stop at every block end.
    ExactStop,
    /// G64: blend corners within the junction deviation (optionally a tolerance in nm, 0 = planner default).
    Blend { tolerance: Nm },
}

/// How a G38.x probe move ends (docs/probing.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeMode {
    /// G38.2/G38.3: stop when the probe touches (its input becomes active); G38.4/G38.5: when it
    /// leaves contact (the input becomes inactive).
    pub toward: bool,
    /// G38.2/G38.4: reaching the end without the change is an alarm; G38.3/G38.5 just end.
    pub must_trip: bool,
}

/// One canonical action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// G0 straight move at rapid rate.
    Rapid { to: Pos },
    /// G1 straight move at `feed`.
    Feed { to: Pos, feed: FeedNmPerMin },
    /// G2/G3 arc or helix. `center` holds the centre on the two plane axes (in X, Y, Z slots)
    /// and, on the normal axis, the arc's start value; `turns` ≥ 1 counts full turns as LinuxCNC does.
    Arc {
        to: Pos,
        center: [Nm; 3],
        plane: Plane,
        dir: ArcDir,
        turns: u32,
        feed: FeedNmPerMin,
    },
    /// G38.2-G38.5 probe move: a straight feed to `to` that stops (with a planned deceleration)
    /// where the probe input changes; the interpreter waits for it (a sync point).
    Probe {
        to: Pos,
        feed: FeedNmPerMin,
        mode: ProbeMode,
    },
    /// G4 dwell.
    Dwell { micros: u64 },
    /// Spindle state and speed (rpm).
    Spindle { state: Spindle, rpm: u32 },
    /// Oriented spindle stop (G76 fine boring at the bottom, the spindle already stopped): at
    /// rest, the board sets the setup's orient output and waits for its done input or dwell
    /// (`board/mod.rs`); the next spindle start releases the output.
    SpindleOrient,
    /// Coolant outputs (M7 mist, M8 flood, M9 both off).
    Coolant { mist: bool, flood: bool },
    /// M6 tool change to tool `tool`.
    ToolChange { tool: u32 },
    /// A user M code from the machine setup. `at_rest`: it must run with the machine stopped
    /// even when its list could switch on the fly (the `gixa` G88 punch's M10).
    UserMCode { code: u16, at_rest: bool },
    /// G61/G64 path mode change.
    PathMode(PathMode),
    /// Program stop or end.
    Stop(StopKind),
}

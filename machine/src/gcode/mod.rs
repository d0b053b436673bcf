//! G-code interpreter: RS274NGC/Fanuc mill dialect and the `gixa` profile, fixed-point, no heap.
//!
//! Pull-based: [`Interpreter::next`] reads lines from a [`ProgramSource`] only when its small
//! action queue is empty, so the controller can stop pulling when the planner is full. Canned
//! cycles and subprograms never need big buffers.
//!
//! # Policies (where the references disagree)
//! - LinuxCNC's `rs274` is the oracle for the default dialect: block execution order, canned-cycle
//!   motions (R relative to the initial level in G91, rise to R first, G98 = max(initial, R)), arc
//!   tolerances, G28/G30 intermediate point, G92 semantics, G10 L2/L20 (G91 has no effect on
//!   G10), P in seconds for G4 and cycle dwells.
//! - Fanuc where LinuxCNC is silent or stricter: the power-up and post-M30 motion mode is G0 (a
//!   bare `X5 Y5` is a rapid); `K` as well as `L` repeats canned cycles, and 0 stores the cycle
//!   without drilling; `G4 X1.5` (no P) is a dwell; `M98 P30050` = 3 × O0050 when there is no L.
//! - Modal-group conflicts are errors (also a cycle with G0-G3 in the same block); unused words
//!   are errors.
//! - Cutter radius compensation (G41/G42, G41.1/G42.1) follows LinuxCNC (`comp.rs`), except
//!   that it must start with a straight move (Fanuc).
//! - M2/M30 reset G54, G17, G90, G94, G80 → G0, G98, M5, M9 and clear G92 offsets (G92.3 can
//!   restore them); units, the tool length offset and the path mode survive. The controller
//!   switches the spindle and coolant outputs off on [`crate::canon::StopKind::End`].
//! - M1 produces a stop only while the optional-stop switch is on; `/` blocks are skipped while
//!   the block-delete switch is on (both settable at run time).
//! - Tool length offsets apply to Z (G43 H from the setup's tool table; G43.1 takes any axis).

pub mod block;
pub mod codes;
pub mod comp;
pub mod config;
pub mod cycles;
pub mod error;
pub(crate) mod expand;
pub mod expr;
pub mod geometry;
pub(crate) mod interp;
pub mod lexer;
pub mod oword;
pub mod params;
pub mod source;
pub(crate) mod spline;
pub mod state;
pub mod transform;

pub use config::{
    ArcCenterMode, Dialect, DwellUnits, GixaSetup, InterpConfig, OffPlaneOffset, RetractMode, Tool,
    ToolChangePosition, MAX_TOOLS,
};
pub use error::{ErrorCode, GcodeError};
pub use interp::Interpreter;
pub use source::{MemorySource, ProgramSource, SourceError};
pub use state::{ModalState, MotionMode};

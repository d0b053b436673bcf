//! G-code interpreter: RS274NGC/Fanuc mill dialect and the `gixa` profile, fixed-point, no heap.
//!
//! Pull-based: [`Interpreter::next`] reads lines from a [`ProgramSource`] only when its small
//! action queue is empty, so the controller can stop pulling when the planner is full. Canned
//! cycles and subprograms never need big buffers.

pub mod block;
pub mod config;
pub mod cycles;
pub mod error;
pub mod geometry;
pub mod interp;
pub mod lexer;
pub mod source;
pub mod state;
mod test_vectors;

pub use config::{ArcCenterMode, Dialect, DwellUnits, GixaSetup, InterpConfig, ToolEntry};
pub use error::{ErrorCode, GcodeError};
pub use interp::Interpreter;
pub use source::{MemorySource, ProgramSource, SourceError};
pub use state::{ModalState, MotionMode};

/// Cross-target vectors of the interpreter (see [`crate::vectors`]).
pub use test_vectors::VECTORS;

//! G-code interpreter: RS274NGC/Fanuc mill dialect and the `gixa` profile, fixed-point, no heap.

use crate::vectors::Vector;

/// Cross-target vectors of the interpreter (see [`crate::vectors`]).
pub const VECTORS: &[Vector] = &[];

//! Cross-target vectors: embedded programs interpreted and every action digested.

use crate::vectors::Vector;

/// Cross-target vectors of the interpreter (see [`crate::vectors`]).
pub const VECTORS: &[Vector] = &[];

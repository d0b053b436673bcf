//! Motion: arc linearisation, look-ahead planner, segment preparation and the step kernel.

pub mod arc;
pub mod config;
pub mod kernel;
pub mod trig;

use crate::vectors::Vector;

/// Cross-target vectors of the planner and step kernel (see [`crate::vectors`]).
pub const VECTORS: &[Vector] = &[];

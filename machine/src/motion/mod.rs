//! Motion: arc linearisation, look-ahead planner and segment preparation for the step kernel
//! (`crate::step::kernel`).
//!
//! Data flow: [`pipeline::Motion::push`] (canonical actions; arcs cut by [`arc`], chains of short
//! moves merged within a `G64 P` tolerance by [`blend`]) → [`planner`]
//! (look-ahead ring) → [`prep`] (constant-rate [`crate::step::kernel::Segment`]s, timed by [`profile`], the
//! latest remembered in [`history`] so a stop can take back what the kernel has not started) →
//! [`crate::step::kernel::StepKernel::tick`] (the step interrupt). [`sim`] runs all of it on virtual time.
//! On-the-fly output changes (`crate::step::output_event`) ride along the same path, from a planner block to
//! its first segment to the tick that starts it, and so does the laser power ([`laser`]); a plasma
//! torch's height control ([`thc`]) adds its Z steps to the segments in prep.

// Per-axis loops index several parallel arrays by axis number; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

pub mod arc;
pub mod blend;
pub mod config;
pub mod corner;
pub(crate) mod history;
pub mod jerk;
pub mod laser;
pub mod pipeline;
pub mod planner;
pub mod prep;
pub mod profile;
pub mod sim;
pub(crate) mod thc;

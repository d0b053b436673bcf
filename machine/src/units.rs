//! Machine-native units: integer nanometres (linear axes) and nano-degrees (rotary axes).
//!
//! Decimal G-code values up to six decimals in mm (five in inch) convert exactly, so incremental
//! programs never drift, and an `i64` covers ±9.2 km at 1 nm resolution.

/// Length along a linear axis in nanometres, or an angle of a rotary axis in 1e-6 degree.
pub type Nm = i64;

/// Number of axes the core handles: X Y Z A B C.
pub const MAX_AXES: usize = 6;

/// Axis letters in axis-index order.
pub const AXIS_LETTERS: [char; MAX_AXES] = ['X', 'Y', 'Z', 'A', 'B', 'C'];

/// A position (or displacement) on every axis.
pub type Pos = [Nm; MAX_AXES];

/// Nanometres per millimetre.
pub const NM_PER_MM: Nm = 1_000_000;

/// Nanometres per inch (exact).
pub const NM_PER_INCH: Nm = 25_400_000;

/// A feed rate in nanometres (or 1e-6 degree) per minute along the programmed path.
pub(crate) type FeedNmPerMin = i64;

//! Path-tolerance blending (`G64 P<tolerance>`): chains of short feed moves run as one chord.
//!
//! CAM programs cut curves into many short, nearly collinear moves. Every move is a planner
//! block, so the look-ahead ring covers only a few millimetres of them and the machine cannot
//! reach its feed on such a chain (it must always be able to stop within what is buffered). Under
//! `G64 P<tolerance>` the pipeline ([`super::pipeline`]) holds the newest short feed move back
//! as a [`Chain`] and extends it with the next ones as long as every programmed point of the
//! chain lies within the tolerance of one straight chord, in order along it. The chain then
//! becomes a single planner block from its start to the end point of its last move: its step
//! counts are exact, the points inside it are passed within the tolerance instead of exactly,
//! and its corners with the moves around it are rounded within the same tolerance
//! ([`super::corner`]; docs/settings.md, "Path blending (`G61`, `G64`, `G64 P`)").
//!
//! Integer arithmetic only: the distance test is exact in 128-bit products.

use crate::units::{Pos, MAX_AXES};
use heapless::Vec;

/// Most programmed moves one chain merges.
pub(crate) const MAX_POINTS: usize = 32;

/// Longest chord (per axis, nm) a chain may span: 2²⁵ nm ≈ 33.5 mm. Longer moves gain nothing
/// from merging, and the bound keeps every product of the distance test within 128 bits.
pub(crate) const MAX_CHORD: i64 = 1 << 25;

/// Short feed moves held back to run as one chord.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chain {
    /// Where the chain starts (the end of the last block queued before it).
    start: Pos,
    /// Programmed end points of the merged moves, in order; the last is the chain's end.
    points: Vec<Pos, MAX_POINTS>,
    /// Source line of the last merged move (the chain's block reports it).
    pub line: u32,
    /// Programmed speed of every merged move, nm/s.
    pub speed: u64,
}

impl Chain {
    /// A chain of the one move from `start` to `to`; `None` when the move is too long to merge.
    pub fn new(start: &Pos, to: &Pos, line: u32, speed: u64, axes: usize) -> Option<Chain> {
        // Zipped rather than indexed: no bounds-check panic path.
        if to
            .iter()
            .zip(start)
            .take(axes)
            .any(|(t, s)| (t - s).abs() > MAX_CHORD)
        {
            return None;
        }
        let mut points = Vec::new();
        let _ = points.push(*to);
        Some(Chain {
            start: *start,
            points,
            line,
            speed,
        })
    }

    /// Where the chain starts.
    pub fn start(&self) -> Pos {
        self.start
    }

    /// The programmed end point of the last merged move.
    pub fn end(&self) -> Pos {
        // A chain always holds at least its first move.
        self.points.last().copied().unwrap_or(self.start)
    }

    /// Moves merged so far.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Never empty (see [`Chain::new`]).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Merges the move to `to` (source line `line`, speed `speed`) when the chord from the
    /// chain's start to `to` passes every programmed point within `tolerance` nm, in order;
    /// false (the chain unchanged) otherwise, or when the speeds differ or the chain is full.
    pub fn extend(&mut self, to: &Pos, line: u32, speed: u64, tolerance: u64, axes: usize) -> bool {
        if speed != self.speed
            || self.points.is_full()
            || !chord_holds(&self.start, &self.points, to, tolerance, axes)
        {
            return false;
        }
        let _ = self.points.push(*to);
        self.line = line;
        true
    }
}

/// True when the chord from `start` to `to` (each axis within [`MAX_CHORD`]) passes every point
/// of `points` within `tolerance` nm, with the points' projections on the chord in order and
/// inside it. Then the programmed polyline and the chord are within `tolerance` of each other
/// everywhere (the distance to a line is convex along each programmed move).
///
/// With `d = to − start` and `v = p − start`: in order when `0 ≤ v·d` does not decrease and
/// stays `≤ d·d`; near when `|v|²·|d|² − (v·d)² ≤ tolerance²·|d|²` (squared distance to the
/// chord's line times |d|², exact in integers).
pub(crate) fn chord_holds(
    start: &Pos,
    points: &[Pos],
    to: &Pos,
    tolerance: u64,
    axes: usize,
) -> bool {
    let axes = axes.min(MAX_AXES);
    // The sums fit 64 bits (|dᵢ| ≤ 2²⁵, |vᵢ| ≤ 2²⁶: |d|² < 6·2⁵⁰, |v|² < 6·2⁵², |v·d| < 6·2⁵¹);
    // only the distance test's products need 128 bits. Summed in i64, not i128: a 128-bit
    // multiply-add per axis and point was most of a merged move's cost on the Cortex-M4.
    let mut d = [0i64; MAX_AXES];
    let mut dd: i64 = 0;
    for i in 0..axes {
        let di = to[i] - start[i];
        if di.abs() > MAX_CHORD {
            return false;
        }
        d[i] = di;
        dd += di * di;
    }
    if dd == 0 {
        return false;
    }
    // |d|² < 6·2⁵⁰ and tolerance ≤ 2²⁵ (coarser ones are the same as 2²⁵ here): < 2¹⁰⁴.
    let tol = i128::from(tolerance.min(MAX_CHORD as u64));
    let limit = tol * tol * i128::from(dd);
    let mut along_before: i64 = 0;
    for p in points {
        let mut vv: i64 = 0;
        let mut vd: i64 = 0;
        for i in 0..axes {
            let vi = p[i] - start[i];
            if vi.abs() > 2 * MAX_CHORD {
                return false;
            }
            vv += vi * vi;
            vd += vi * d[i];
        }
        if vd < along_before || vd > dd {
            return false;
        }
        along_before = vd;
        // Cauchy-Schwarz: vv·dd ≥ vd²; both products < 2¹¹⁰.
        if i128::from(vv) * i128::from(dd) - i128::from(vd) * i128::from(vd) > limit {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    const MM: i64 = 1_000_000;

    fn xy(x: i64, y: i64) -> Pos {
        [x, y, 0, 0, 0, 0]
    }

    #[test]
    fn points_within_the_tolerance_merge_and_one_beyond_does_not() {
        let o = xy(0, 0);
        // (1 mm, 10 µm) is exactly 10 µm from the X axis chord to (2 mm, 0): merges at 10 µm.
        assert!(chord_holds(
            &o,
            &[xy(MM, 10_000)],
            &xy(2 * MM, 0),
            10_000,
            3
        ));
        // 10.001 µm does not.
        assert!(!chord_holds(
            &o,
            &[xy(MM, 10_001)],
            &xy(2 * MM, 0),
            10_000,
            3
        ));
        // A point behind the start or beyond the end, or out of order, never merges.
        assert!(!chord_holds(&o, &[xy(-1, 0)], &xy(2 * MM, 0), 10_000, 3));
        assert!(!chord_holds(
            &o,
            &[xy(2 * MM + 1, 0)],
            &xy(2 * MM, 0),
            10_000,
            3
        ));
        let back = [xy(MM, 0), xy(MM / 2, 0)];
        assert!(!chord_holds(&o, &back, &xy(2 * MM, 0), 10_000, 3));
        // No chord, or one too long.
        assert!(!chord_holds(&o, &[], &o, 10_000, 3));
        assert!(!chord_holds(&o, &[], &xy(MAX_CHORD + 1, 0), 10_000, 3));
    }

    #[test]
    fn a_chain_grows_while_its_chord_holds() {
        let o = xy(0, 0);
        let mut c = Chain::new(&o, &xy(50_000, 1_000), 1, 50_000_000, 3).unwrap();
        assert!(c.extend(&xy(100_000, 0), 2, 50_000_000, 10_000, 3));
        // Another speed ends the chain.
        assert!(!c.extend(&xy(150_000, 0), 3, 40_000_000, 10_000, 3));
        assert!(c.extend(&xy(150_000, 0), 3, 50_000_000, 10_000, 3));
        // A 90° turn does not hold.
        assert!(!c.extend(&xy(150_000, 100_000), 4, 50_000_000, 10_000, 3));
        assert_eq!((c.len(), c.line, c.end()), (3, 3, xy(150_000, 0)));
        // At most MAX_POINTS moves.
        for k in 4..=MAX_POINTS as i64 + 5 {
            c.extend(&xy(50_000 * k, 0), k as u32, 50_000_000, 10_000, 3);
        }
        assert_eq!(c.len(), MAX_POINTS);
        assert!(Chain::new(&o, &xy(0, MAX_CHORD + 1), 1, 1, 3).is_none());
    }
}

//! Limit-switch seek (homing, docs/controller.md "Homing"): axes one at a time in priority order; for each, the
//! before-seek list, a fast seek toward the switch (given up after the axis travel), a pull-off at
//! the rapid rate, a slow locate back onto the switch (at or below the start speed, so the switch
//! stops it on the exact step), the before-retract list, a retract at the rapid rate, set home,
//! the after-retract list. Only the locate's stop sets the position: the fast seek may stop
//! harder than the motor can follow, the locate cannot.
//!
//! This module holds the pure parts (order, targets, switch bits, phases); the board drives the
//! motion and the lists.

use crate::board::inputs::limit_bit;
use crate::setup::{HomingAxis, Setup};
use crate::units::{Nm, MAX_AXES};
use heapless::Vec;

/// Where one axis's homing stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
    BeforeSeek,
    /// The fast seek toward the switch (`seek_rate`).
    Seek,
    /// The switch stopped the fast seek; the pull-off starts at rest.
    SeekStopped,
    /// Backing off the switch by the retract distance at the rapid rate.
    PullOff,
    /// The slow seek back onto the switch (`locate_rate`).
    Locate,
    BeforeRetract,
    Retract,
    AfterRetract,
}

/// A homing cycle in progress.
#[derive(Clone, Debug)]
pub struct Homing {
    /// Axes to home, in order.
    pub order: Vec<u8, MAX_AXES>,
    /// Index into `order` of the axis being homed.
    pub index: usize,
    pub phase: Phase,
    /// Axes homed by this cycle so far.
    pub done: u8,
    /// A list's `seek` command is moving toward the switch.
    pub list_seek: bool,
}

impl Homing {
    /// True while a seek toward the axis's switch is moving (the switch is the target).
    pub fn seeking(&self) -> bool {
        matches!(self.phase, Phase::Seek | Phase::Locate) || self.list_seek
    }
}

impl Homing {
    /// A cycle over `axes` (bit mask; 0 = every axis with a priority), lowest priority number
    /// first, ties by axis order. `None` when no requested axis has homing configured.
    pub fn new(setup: &Setup, axes: u8) -> Option<Homing> {
        let order = order(setup, axes);
        (!order.is_empty()).then_some(Homing {
            order,
            index: 0,
            phase: Phase::BeforeSeek,
            done: 0,
            list_seek: false,
        })
    }

    /// The axis being homed.
    pub fn axis(&self) -> usize {
        // `index` stays below the order's length while the cycle runs and every entry is below
        // `MAX_AXES` (`order`); written with `get` and a clamp, each caller indexes the setup's
        // per-axis arrays without a bounds-check panic path.
        self.order
            .get(self.index)
            .map_or(0, |&a| usize::from(a).min(MAX_AXES - 1))
    }
}

/// Axes of `axes` (0 = all) that have a homing priority, in seek order.
pub(crate) fn order(setup: &Setup, axes: u8) -> Vec<u8, MAX_AXES> {
    let n = setup.axis_count as usize;
    let mut v: Vec<u8, MAX_AXES> = Vec::new();
    // Ascending priority, ties in axis order: a scan per priority level instead of a sort (the
    // generic sort costs kilobytes of flash for at most six axes).
    for priority in 1..=u8::MAX {
        for (i, h) in setup.homing.axes.iter().take(n).enumerate() {
            if h.priority == priority && (axes == 0 || axes & (1 << i) != 0) {
                let _ = v.push(i as u8);
            }
        }
    }
    v
}

/// The input bit of the switch an axis seeks.
pub(crate) const fn switch_bit(axis: usize, h: &HomingAxis) -> u32 {
    limit_bit(axis, !h.seek_low)
}

/// The seek's end point from `from`: the whole travel span plus the retract toward the switch.
/// Reaching it without the switch means the switch was not found.
pub(crate) fn seek_target(setup: &Setup, axis: usize, from: Nm) -> Nm {
    let a = &setup.axes[axis];
    let h = &setup.homing.axes[axis];
    let span = a.travel_max.saturating_sub(a.travel_min) + h.retract.max(0);
    if h.seek_low {
        from - span
    } else {
        from + span
    }
}

/// The locate's end point from the pulled-off position `from`: twice the pull-off back toward the
/// switch (the fast seek may have stopped past the switch's edge by a few steps, or lost some);
/// reaching it without the switch is alarm 9.
pub(crate) fn locate_target(h: &HomingAxis, from: Nm) -> Nm {
    let span = h.retract.max(0).saturating_mul(2);
    if h.seek_low {
        from - span
    } else {
        from + span
    }
}

/// The retract's (and the pull-off's) end point from the switch position `at` (away from the
/// switch).
pub(crate) fn retract_target(h: &HomingAxis, at: Nm) -> Nm {
    if h.seek_low {
        at + h.retract
    } else {
        at - h.retract
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::inputs::LIMIT_MIN_BIT;
    use crate::units::NM_PER_MM;

    #[test]
    fn axes_home_by_priority_then_axis_order() {
        let mut s = Setup::default();
        s.homing.axes[0].priority = 2;
        s.homing.axes[1].priority = 2;
        s.homing.axes[2].priority = 1;
        assert_eq!(&order(&s, 0)[..], &[2, 0, 1]);
        assert_eq!(&order(&s, 0b011)[..], &[0, 1]);
        s.homing.axes[2].priority = 0;
        assert_eq!(&order(&s, 0b100)[..], &[] as &[u8]);
    }

    #[test]
    fn seek_covers_the_travel_and_retract_backs_off() {
        let s = Setup::default();
        // X travel ±300 mm, retract 2 mm, seek low.
        assert_eq!(seek_target(&s, 0, 0), -602 * NM_PER_MM);
        assert_eq!(
            retract_target(&s.homing.axes[0], -5 * NM_PER_MM),
            -3 * NM_PER_MM
        );
        assert_eq!(switch_bit(1, &s.homing.axes[1]), LIMIT_MIN_BIT + 1);
        // The locate goes back twice the pull-off toward the switch.
        assert_eq!(
            locate_target(&s.homing.axes[0], -3 * NM_PER_MM),
            -7 * NM_PER_MM
        );
    }
}

//! Torch height control (docs/laser-plasma.md "Plasma"): extra Z steps that segment prep
//! (`motion/prep.rs`) adds to the segments of a plasma cut, so Z follows the height controller's
//! up/down inputs. The step interrupt only sees ordinary segments: nothing is computed there.
//!
//! The board says what the inputs ask ([`ThcCommand`], `board/torch.rs` decides when the torch
//! may be corrected at all); prep applies it to a segment only when the move has no Z motion of
//! its own and the segment runs at cruise speed (no acceleration, no corner slow-down, no hold)
//! at or above the anti-dive share of the programmed feed. The steps run at `thc_rate` (a
//! fractional step carried from segment to segment), within `±thc_travel` of the programmed
//! height. The correction is counted here: the board reports Z as programmed and the correction
//! beside it, and takes it out with Z-only segments at the first sync point after the torch went
//! off ([`Thc::return_segment`]), so every pierce starts at the programmed height.

use crate::step::kernel::{Segment, KEEP_DUTY, KERNEL_TIMER_HZ};
use crate::step::output_event::OutputEvent;
use crate::units::MAX_AXES;

/// The axis torch height control moves.
pub(crate) const THC_AXIS: usize = 2;
const Z_DIR: u8 = 1 << THC_AXIS;
const HZ: u64 = KERNEL_TIMER_HZ as u64;

/// What the height controller's inputs ask for now (as the board lets them through).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum ThcCommand {
    /// Keep the height (no input, both, or the control is not allowed now).
    #[default]
    Hold,
    /// Raise the torch (+Z).
    Up,
    /// Lower the torch (−Z).
    Down,
}

/// The machine's height control: its rate and travel in Z steps, and the anti-dive share.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ThcConfig {
    /// Z steps per second of the correction (≥ 1).
    pub rate: u32,
    /// Largest correction either way, Z steps.
    pub travel: i32,
    /// Below this percentage of the programmed feed the correction holds.
    pub anti_dive: u8,
}

/// Torch height control's state in segment prep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Thc {
    /// `None`: not a torch machine with height control (no segment ever changes).
    pub cfg: Option<ThcConfig>,
    /// What the inputs ask, set by the board before each segment.
    pub command: ThcCommand,
    /// Switched by the program (`M62 P2` off, `M63 P2` on; on at every job start).
    pub enabled: bool,
    /// Correction made so far, Z steps (+ = up).
    pub correction: i32,
    /// Fraction of a step carried to the next segment, in steps × timer counts per second.
    carry: u64,
}

impl Thc {
    /// Height control with `cfg` (`None`: none), nothing corrected.
    pub const fn new(cfg: Option<ThcConfig>) -> Self {
        Thc {
            cfg,
            command: ThcCommand::Hold,
            enabled: true,
            correction: 0,
            carry: 0,
        }
    }

    /// Signed Z steps (+ = up) to add to a segment of `duration` timer counts and `ticks` ticks
    /// of a move without Z motion; `cruise`: the segment runs at the move's cruise speed, at or
    /// above the anti-dive speed (prep decides). Zero whenever the correction must hold.
    pub fn steps(&mut self, cruise: bool, duration: u64, ticks: u32) -> i32 {
        let Some(cfg) = self.cfg else {
            return 0;
        };
        let sign = match self.command {
            ThcCommand::Up if cruise && self.enabled => 1,
            ThcCommand::Down if cruise && self.enabled => -1,
            _ => {
                self.carry = 0;
                return 0;
            }
        };
        let room = if sign > 0 {
            cfg.travel - self.correction
        } else {
            cfg.travel + self.correction
        };
        self.carry += u64::from(cfg.rate) * duration;
        let n = (self.carry / HZ)
            .min(u64::from(ticks))
            .min(room.max(0) as u64) as i32;
        self.carry %= HZ;
        self.correction += sign * n;
        sign * n
    }

    /// A Z-only segment (about 2 ms at `thc_rate`) that takes the correction back towards 0, or
    /// `None` once it is 0. The board hands these out at a sync point after the torch went off.
    pub(crate) fn return_segment(&mut self, segment_counts: u64) -> Option<(Segment, i32)> {
        let cfg = self.cfg?;
        if self.correction == 0 {
            return None;
        }
        self.carry = 0;
        let per = (u64::from(cfg.rate) * segment_counts / HZ).max(1);
        let n = per.min(u64::from(self.correction.unsigned_abs())) as u32;
        let signed = if self.correction > 0 {
            -(n as i32)
        } else {
            n as i32
        };
        self.correction += signed;
        let mut steps = [0; MAX_AXES];
        steps[THC_AXIS] = n;
        let seg = Segment {
            steps,
            ticks: n,
            period: (u64::from(n) * HZ / u64::from(cfg.rate))
                .div_ceil(u64::from(n))
                .clamp(1, u64::from(u32::MAX)) as u32,
            dir: if signed < 0 { Z_DIR } else { 0 },
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        };
        Some((seg, signed))
    }

    /// The owner dropped segments that carried `z` signed Z steps of correction.
    pub(crate) fn taken_back(&mut self, z: i32) {
        self.correction -= z;
        self.carry = 0;
    }

    /// The correction became part of the position (an abort or a limit stop takes the machine's
    /// step position as it is): nothing left to take out.
    pub(crate) fn absorbed(&mut self) {
        self.correction = 0;
        self.carry = 0;
    }
}

/// The direction byte of a segment of a move with direction byte `dir` after `z` correction
/// steps were added (a move without Z motion: its Z bit is free).
pub(crate) const fn with_z_dir(dir: u8, z: i32) -> u8 {
    if z < 0 {
        dir | Z_DIR
    } else if z > 0 {
        dir & !Z_DIR
    } else {
        dir
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: ThcConfig = ThcConfig {
        rate: 10_000,
        travel: 50,
        anti_dive: 90,
    };

    #[test]
    fn steps_follow_the_rate_with_a_carried_fraction_and_stop_at_the_travel() {
        let mut t = Thc::new(Some(CFG));
        t.command = ThcCommand::Up;
        // 10,000 steps/s over 2.5 ms segments: 25 steps each.
        let seg = HZ / 400;
        assert_eq!(t.steps(true, seg, 1000), 25);
        // 0.15 ms: 1.5 steps → 1, the half carried.
        assert_eq!(t.steps(true, HZ * 15 / 100_000, 1000), 1);
        assert_eq!(t.steps(true, HZ * 15 / 100_000, 1000), 2);
        assert_eq!(t.correction, 28);
        // Never more steps than ticks; never beyond the travel.
        assert_eq!(t.steps(true, seg, 3), 3);
        assert_eq!(t.steps(true, seg, 1000), 19);
        assert_eq!(t.steps(true, seg, 1000), 0);
        assert_eq!(t.correction, 50);
        t.command = ThcCommand::Down;
        assert_eq!(t.steps(false, seg, 1000), 0);
        assert_eq!(t.steps(true, seg, 1000), -25);
        t.enabled = false;
        assert_eq!(t.steps(true, seg, 1000), 0);
        assert_eq!(t.correction, 25);
    }

    #[test]
    fn the_return_takes_the_correction_out_in_z_only_segments() {
        let mut t = Thc::new(Some(CFG));
        t.correction = 30;
        let (s, z) = t.return_segment(HZ / 500).unwrap();
        assert_eq!((s.steps[THC_AXIS], s.dir, z), (20, Z_DIR, -20));
        assert_eq!(s.duration(), HZ / 500);
        let (s, z) = t.return_segment(HZ / 500).unwrap();
        assert_eq!((s.steps[THC_AXIS], z), (10, -10));
        assert_eq!(t.return_segment(HZ / 500), None);
        assert_eq!(Thc::new(None).return_segment(HZ / 500), None);
    }

    #[test]
    fn the_z_bit_follows_the_correction() {
        assert_eq!(with_z_dir(0b001, -1), 0b101);
        assert_eq!(with_z_dir(0b101, 1), 0b001);
        assert_eq!(with_z_dir(0b101, 0), 0b101);
    }
}

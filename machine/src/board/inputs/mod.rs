//! Operator and machine inputs: raw pin levels → debounced logical signals and edges.
//!
//! The firmware samples its input pins into an [`InputBits`] word once per millisecond (the emulated
//! board does the same from its virtual pins); this module applies the polarity setting, debounces
//! each bit and reports which signals changed. Limit switches are *also* seen raw by the step
//! interrupt (docs/controller.md "Safety rules as built"): debouncing here never delays the stop, only the alarm bookkeeping.

pub(crate) mod operator;

use serde::{Deserialize, Serialize};

/// One bit per input signal, as the board's pins are sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputBits(pub u32);

/// Input signals and their bit numbers in [`InputBits`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Signal {
    /// Feed hold (wired normally closed: the pin opening means hold).
    FeedHold = 0,
    /// Abort push button.
    Abort = 1,
    /// Cycle start 1 and 2 (two-hand start uses both).
    CycleStart1 = 2,
    CycleStart2 = 3,
    /// Joystick switches: S1 down, S2 left, S3 right, S4 up.
    JogS1 = 4,
    JogS2 = 5,
    JogS3 = 6,
    JogS4 = 7,
    /// Joystick Mark (S8) and Release switches.
    Mark = 8,
    Release = 9,
    /// Joystick selectors: stage pair 1, accelerated mode, nudge mode.
    PairSelect = 10,
    Accelerated = 11,
    Nudge = 12,
    /// Single block, optional stop, block delete and dry run switches.
    SingleBlock = 13,
    OptionalStop = 14,
    BlockDelete = 15,
    /// Touch probe (G38.x, docs/probing.md): active when touching. The step kernel sees its raw
    /// pin too, every tick; this bit is the debounced level for status and the start check.
    Probe = 28,
    /// Plasma torch (docs/laser-plasma.md "Plasma"): the power source's arc-OK (transfer)
    /// output, active while the arc is established.
    ArcOk = 29,
    /// Torch height controller's "raise" and "lower" outputs (the up/down THC interface).
    ThcUp = 30,
    ThcDown = 31,
}

/// Names of the input bits of [`InputBits`], bit 0 first, as the setup file and traces spell
/// them (other bits are `inN`).
pub const INPUT_NAMES: [&str; 32] = [
    "feed_hold",
    "abort",
    "cycle_start1",
    "cycle_start2",
    "jog_s1",
    "jog_s2",
    "jog_s3",
    "jog_s4",
    "mark",
    "release",
    "pair_select",
    "accelerated",
    "nudge",
    "single_block",
    "optional_stop",
    "block_delete",
    "x_min",
    "y_min",
    "z_min",
    "a_min",
    "b_min",
    "c_min",
    "x_max",
    "y_max",
    "z_max",
    "a_max",
    "b_max",
    "c_max",
    "probe",
    "arc_ok",
    "thc_up",
    "thc_down",
];

/// First bit of the six min-limit inputs (X..C), then six max-limit inputs.
pub const LIMIT_MIN_BIT: u32 = 16;
pub const LIMIT_MAX_BIT: u32 = 22;

/// Input bit of the limit switch on `axis`'s max side (`max`) or min side.
pub const fn limit_bit(axis: usize, max: bool) -> u32 {
    (if max { LIMIT_MAX_BIT } else { LIMIT_MIN_BIT }) + axis as u32
}

impl InputBits {
    pub const fn get(self, s: Signal) -> bool {
        self.0 & (1 << s as u32) != 0
    }

    pub fn set(&mut self, s: Signal, on: bool) {
        self.set_bit(s as u32, on);
    }

    pub fn set_bit(&mut self, bit: u32, on: bool) {
        if on {
            self.0 |= 1 << bit;
        } else {
            self.0 &= !(1 << bit);
        }
    }

    /// Axes (bit i = axis i) whose min limit switch is active.
    pub const fn limits_min(self) -> u8 {
        ((self.0 >> LIMIT_MIN_BIT) & 0x3f) as u8
    }

    /// Axes whose max limit switch is active.
    pub const fn limits_max(self) -> u8 {
        ((self.0 >> LIMIT_MAX_BIT) & 0x3f) as u8
    }
}

/// Debounces every input bit: a bit's new level is accepted once it has read the same for
/// `samples` consecutive samples.
#[derive(Clone, Debug)]
pub struct Debouncer {
    /// Pins that are active low (their logical level is the inverted pin level).
    invert: u32,
    samples: u8,
    stable: InputBits,
    candidate: u32,
    counts: [u8; 32],
}

impl Debouncer {
    /// `invert`: bit mask of active-low pins; `samples`: consecutive equal samples needed (≥ 1).
    /// The signals start at their idle level (`0` logical) so power-up never looks like a press.
    pub const fn new(invert: u32, samples: u8) -> Self {
        Debouncer {
            invert,
            samples: if samples == 0 { 1 } else { samples },
            stable: InputBits(0),
            candidate: 0,
            counts: [0; 32],
        }
    }

    /// Feeds one sample of raw pin levels; returns the debounced logical levels and the bits that
    /// changed with this sample.
    pub fn sample(&mut self, pins: u32) -> (InputBits, u32) {
        let logical = pins ^ self.invert;
        let differs = logical ^ self.stable.0;
        let mut changed = 0;
        for bit in 0..32 {
            let mask = 1u32 << bit;
            if differs & mask == 0 {
                self.counts[bit] = 0;
                continue;
            }
            if (self.candidate ^ logical) & mask != 0 {
                self.counts[bit] = 0;
            }
            self.counts[bit] += 1;
            if self.counts[bit] >= self.samples {
                self.stable.0 ^= mask;
                self.counts[bit] = 0;
                changed |= mask;
            }
        }
        self.candidate = logical;
        (self.stable, changed)
    }

    /// The current debounced logical levels.
    pub const fn levels(&self) -> InputBits {
        self.stable
    }
}

/// Analog readings the firmware samples with the inputs (raw ADC counts, `0..=setup.inputs.adc_max`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdcReadings {
    /// Feed-rate override potentiometer (`None`: not sampled).
    pub fro: Option<u16>,
    /// Analog joystick channels 0 and 1 (`None`: no analog stick).
    pub stick: Option<[u16; 2]>,
}

/// Feed override (percent) from a potentiometer reading: `0..=adc_max` maps linearly onto
/// `low..=high`, rounded to the nearest percent.
pub fn fro_from_adc(adc: u16, adc_max: u16, low: u16, high: u16) -> u16 {
    let max = u32::from(adc_max.max(1));
    let a = u32::from(adc).min(max);
    let span = u32::from(high.saturating_sub(low));
    (u32::from(low) + (a * span + max / 2) / max) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_is_accepted_after_the_configured_samples() {
        let mut d = Debouncer::new(0, 3);
        assert_eq!(d.sample(0b1), (InputBits(0), 0));
        assert_eq!(d.sample(0b1), (InputBits(0), 0));
        assert_eq!(d.sample(0b1), (InputBits(1), 1));
        assert_eq!(d.sample(0b1), (InputBits(1), 0));
    }

    #[test]
    fn bounces_restart_the_count() {
        let mut d = Debouncer::new(0, 3);
        for pins in [1, 1, 0, 1, 1] {
            assert_eq!(d.sample(pins).0, InputBits(0));
        }
        assert_eq!(d.sample(1), (InputBits(1), 1));
    }

    #[test]
    fn active_low_pins_are_inverted_and_start_idle() {
        // Feed hold wired normally closed to ground: pin high (open) means hold.
        let nc = 1 << Signal::FeedHold as u32;
        let mut d = Debouncer::new(0, 1);
        assert!(!d.levels().get(Signal::FeedHold));
        let (levels, changed) = d.sample(nc);
        assert!(levels.get(Signal::FeedHold));
        assert_eq!(changed, nc);
        // An active-low cycle-start button reads pressed when its pin is low.
        let start = 1 << Signal::CycleStart1 as u32;
        let mut d = Debouncer::new(start, 1);
        assert!(d.sample(0).0.get(Signal::CycleStart1));
        assert!(!d.sample(start).0.get(Signal::CycleStart1));
    }

    #[test]
    fn input_names_follow_the_bit_layout() {
        assert_eq!(INPUT_NAMES[Signal::FeedHold as usize], "feed_hold");
        assert_eq!(INPUT_NAMES[Signal::Mark as usize], "mark");
        assert_eq!(INPUT_NAMES[Signal::BlockDelete as usize], "block_delete");
        assert_eq!(INPUT_NAMES[LIMIT_MIN_BIT as usize], "x_min");
        assert_eq!(INPUT_NAMES[LIMIT_MAX_BIT as usize], "x_max");
        assert_eq!(INPUT_NAMES[LIMIT_MAX_BIT as usize + 6], "probe");
        assert_eq!(INPUT_NAMES[Signal::Probe as usize], "probe");
        assert_eq!(INPUT_NAMES[Signal::ArcOk as usize], "arc_ok");
        assert_eq!(INPUT_NAMES[Signal::ThcDown as usize], "thc_down");
    }

    #[test]
    fn limit_fields_map_to_axes() {
        let mut b = InputBits(0);
        b.set_bit(LIMIT_MIN_BIT + 2, true);
        b.set_bit(LIMIT_MAX_BIT, true);
        assert_eq!((b.limits_min(), b.limits_max()), (0b100, 0b1));
    }

    #[test]
    fn fro_pot_maps_the_adc_range_onto_the_percent_range() {
        assert_eq!(fro_from_adc(0, 4095, 30, 130), 30);
        assert_eq!(fro_from_adc(4095, 4095, 30, 130), 130);
        assert_eq!(fro_from_adc(2048, 4095, 30, 130), 80);
        assert_eq!(fro_from_adc(5000, 4095, 10, 200), 200);
    }
}

//! Operator inputs of one main-loop pass: feed hold, abort, cycle start (two-hand), the run-mode
//! switches and the feed-override potentiometer (docs/controller.md "Operator inputs"). The joystick part is in
//! [`crate::board::jog`].

use super::{fro_from_adc, AdcReadings};
use super::{InputBits, Signal};
use crate::board::state::State;
use crate::board::Board;

/// The operator's run-mode switches (docs/controller.md "Run modes"). A struct of two switches
/// grouped by concern rather than one four-valued enum: the two are independent (every
/// combination is valid) and set apart (dry run from the host and only while idle, single block
/// from the host or the switch input at any time), so an enum would only spell out their product
/// and make each setter rebuild the other switch's half.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(in crate::board) struct RunSwitches {
    /// Feed moves at `operator.dry_run_feed`, spindle and coolant untouched, M-code lists flagged
    /// `dry_run_disabled` skipped.
    pub dry_run: bool,
    /// A breakpoint after each block (the M0 stop/restore rules) until cycle start.
    pub single_block: bool,
}

/// What the board last heard from its owner: the main-loop time and debounced input levels of
/// the last [`Board::on_inputs`], the kernel's drained flag of the last [`Board::poll`], and the
/// limit switches ignored until they release.
pub(in crate::board) struct Sensed {
    /// Main-loop time, ms.
    pub(in crate::board) now_ms: u32,
    /// Debounced logical input levels.
    pub(in crate::board) levels: InputBits,
    /// The kernel was drained (segment queue empty, kernel idle).
    pub(in crate::board) drained: bool,
    /// Limit bits ignored until they release (a switch still pressed when the alarm was raised).
    disarmed: u32,
    /// When the last switch was disarmed, ms: its debounced level may show it pressed only a
    /// debounce time later, so it re-arms on a release seen after that.
    disarmed_at: u32,
}

impl Sensed {
    /// Nothing heard yet: time 0, every input low, the kernel drained.
    #[inline(always)]
    pub(in crate::board) const fn new() -> Self {
        Sensed {
            now_ms: 0,
            levels: InputBits(0),
            drained: true,
            disarmed: 0,
            disarmed_at: 0,
        }
    }

    /// A new input sample (debounced over `debounce_ms`); returns the levels before it. A
    /// disarmed limit switch re-arms once it has released, judged only once the debounced levels
    /// can show it pressed: the kernel stops on the raw pin, the debounced level follows
    /// `debounce_ms` later, and a switch re-armed in between tripped again at the unlock.
    fn sample(&mut self, now_ms: u32, levels: InputBits, debounce_ms: u8) -> InputBits {
        let prev = self.levels;
        self.now_ms = now_ms;
        self.levels = levels;
        // (Twice the debounce time and two samples: a margin over the debouncer's lag.)
        if now_ms.wrapping_sub(self.disarmed_at) > 2 * u32::from(debounce_ms) + 2 {
            self.disarmed &= levels.0;
        }
        prev
    }

    /// Ignores the limit bits of `bits` until they release.
    pub(in crate::board) fn disarm(&mut self, bits: u32) {
        self.disarmed |= bits;
        self.disarmed_at = self.now_ms;
    }

    /// The limit bits ignored until they release.
    pub(in crate::board) fn disarmed_bits(&self) -> u32 {
        self.disarmed
    }

    /// The limit bits of `installed` not disarmed.
    pub(in crate::board) fn armed(&self, installed: u32) -> u32 {
        installed & !self.disarmed
    }
}

impl Board {
    /// Cycle start: resumes a hold, an M0/M1/single-block stop or a tool-change stop.
    pub fn cycle_start(&mut self) {
        if matches!(self.state(), State::Hold | State::ToolChange) {
            self.resume();
        }
    }

    /// The inputs of one main-loop pass (every millisecond): `levels` are the debounced logical
    /// levels ([`super::Debouncer`] with the setup's polarity and debounce),
    /// `changed` the bits that changed with this sample, `adc` the analog readings. Drives feed
    /// hold, abort, cycle start, the switches (single block, optional stop, block delete), the
    /// feed-override potentiometer and the joystick.
    pub(crate) fn on_inputs(
        &mut self,
        now_ms: u32,
        levels: InputBits,
        changed: u32,
        adc: AdcReadings,
    ) {
        let prev = self
            .sensed
            .sample(now_ms, levels, self.setup.inputs.debounce_ms);
        let rose = |s: Signal| changed & (1 << s as u32) != 0 && levels.get(s);
        let fell = |s: Signal| changed & (1 << s as u32) != 0 && !levels.get(s);
        let inputs = self.setup.inputs;
        if inputs.abort && rose(Signal::Abort) {
            self.abort();
        }
        if self.torch() && fell(Signal::ArcOk) {
            self.arc_ok_fell();
        }
        if inputs.feed_hold {
            if rose(Signal::FeedHold) && self.state() == State::Run {
                self.feed_hold();
            }
            if fell(Signal::FeedHold) && !self.setup.operator.resume_needs_cycle_start {
                self.release_hold();
            }
        }
        let start = |l: InputBits| {
            let (a, b) = (l.get(Signal::CycleStart1), l.get(Signal::CycleStart2));
            if self.setup.operator.two_hand_start {
                a && b
            } else {
                a || b
            }
        };
        if start(levels) && !start(prev) {
            self.cycle_start();
        }
        if changed & (1 << Signal::SingleBlock as u32) != 0 {
            self.overrides.switches.single_block = levels.get(Signal::SingleBlock);
        }
        if changed & (1 << Signal::OptionalStop as u32) != 0 {
            self.interp
                .set_optional_stop(levels.get(Signal::OptionalStop));
        }
        if changed & (1 << Signal::BlockDelete as u32) != 0 {
            self.interp
                .set_block_delete(levels.get(Signal::BlockDelete));
        }
        if let (true, Some(raw)) = (inputs.fro_pot, adc.fro) {
            let op = &self.setup.operator;
            let pct = fro_from_adc(raw, inputs.adc_max, op.fro_low, op.fro_high);
            // Applied when the pot moves, so a host override stays until the knob is turned.
            if self.overrides.pot_moved(pct) {
                self.set_feed_override(pct);
            }
        }
        self.joystick(prev, levels, adc);
    }
}

//! Step kernel: the code the step timer interrupt runs, once per tick.
//!
//! Segment preparation (main context) hands the kernel short constant-rate [`Segment`]s through a
//! [`SegmentSource`] (an SPSC queue on the firmware, a ring in the host driver). Each segment says
//! how many ticks it lasts, the timer period of each tick, the direction byte and how many steps
//! every axis makes during it. The kernel spreads each axis's steps over the ticks with Bresenham
//! (an add, a compare and a subtract per axis), so a segment emits *exactly* its step counts.
//!
//! AMASS-style smoothing is decided by segment prep, not here: at low rates prep over-drives the
//! tick (`ticks = dominant_steps << level`, `period >>= level`), so the non-dominant axes get
//! 2, 4 or 8 times finer step placement. The kernel is the same either way.
//!
//! The tick does no division and no multiplication; positions are counted per axis in whole steps.
//! `stop = true` (a limit flag) latches: from that tick on no step is emitted, the current segment
//! is dropped and the kernel reports idle until [`StepKernel::clear_stop`] is called.
//!
//! A segment may carry an on-the-fly [`OutputEvent`]: the tick that starts the segment reports it
//! in [`TickOut::output`] (so the output switches with the segment's first step) and the kernel's
//! user output word ([`StepKernel::outputs`]) follows it. The word is what the kernel's owner has
//! on the user output pins; the owner loads it with [`StepKernel::set_outputs`] when the board
//! switches outputs itself (command lists at rest, safe state).
//!
//! Laser power (docs/laser-plasma.md): a segment's [`Segment::power`] is the PWM duty segment
//! prep computed for it (`crate::motion::laser`); the tick that starts the segment reports it in
//! [`TickOut::power`] (its owner writes the compare register, nothing is computed here), and the
//! first tick that finds the queue empty after a powered segment, or a latched stop, reports 0:
//! the beam is off whenever the kernel stands still. [`KEEP_DUTY`] (a machine without laser
//! mode) is never reported.
//!
//! Probing (G38.x, docs/probing.md): the owner passes the probe pin's raw level to every tick.
//! While the probe latch is armed ([`StepKernel::arm_probe`]) the first tick that sees the pin at
//! the armed level records the position before its steps ([`StepKernel::probe_latch`]); the
//! kernel keeps stepping (the board decelerates on the path). Unarmed, the check is one byte
//! load and a branch per tick.

use super::output_event::OutputEvent;
use crate::units::MAX_AXES;

pub use super::timing::{ns_to_counts, StepTiming, KERNEL_TIMER_HZ};

/// Segment duty meaning "no change" (not a laser machine). A laser's duty stays below it
/// (`crate::motion::laser::PwmMap::duty` clamps to `KEEP_DUTY - 1`).
pub const KEEP_DUTY: u16 = u16::MAX;

/// A piece of motion at a constant tick rate with exact per-axis step counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Segment {
    /// Steps each axis makes during the segment (each ≤ `ticks`).
    pub steps: [u32; MAX_AXES],
    /// Number of ticks the segment lasts (≥ 1).
    pub ticks: u32,
    /// Timer counts (at [`KERNEL_TIMER_HZ`]) between two ticks (≥ 1).
    pub period: u32,
    /// Direction byte: bit i set = axis i moves towards negative.
    pub dir: u8,
    /// Output switched by the tick that starts this segment (on-the-fly M code), usually none.
    pub output: OutputEvent,
    /// Laser PWM duty from the segment's first tick ([`KEEP_DUTY`]: leave the PWM alone).
    pub power: u16,
}

impl Segment {
    /// A segment that makes no step for `ticks × period` timer counts (used for dwells).
    pub const fn idle(ticks: u32, period: u32) -> Self {
        Segment {
            steps: [0; MAX_AXES],
            ticks,
            period,
            dir: 0,
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        }
    }

    /// The same segment with laser duty `power`.
    pub(crate) const fn with_power(self, power: u16) -> Self {
        Segment { power, ..self }
    }

    /// Number of axes up to and including the highest one that steps.
    fn axes_in_use(&self) -> usize {
        let mut n = 0;
        for (i, s) in self.steps.iter().enumerate() {
            if *s != 0 {
                n = i + 1;
            }
        }
        n
    }

    /// Duration in timer counts.
    pub fn duration(&self) -> u64 {
        self.ticks as u64 * self.period as u64
    }
}

/// Where the kernel pulls its segments from.
pub trait SegmentSource {
    /// The next segment, or `None` when nothing is queued.
    fn next_segment(&mut self) -> Option<Segment>;
}

/// What one tick produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TickOut {
    /// Step byte: bit i = axis i steps now (write DIR before STEP).
    pub step: u8,
    /// Direction byte: bit i set = axis i moves towards negative.
    pub dir: u8,
    /// Timer counts to the next tick; 0 = idle (no segment), stop the timer.
    pub period: u32,
    /// User output to switch now, before this tick's steps (the first tick of a segment that
    /// carries an on-the-fly event); [`OutputEvent::NONE`] on every other tick.
    pub output: OutputEvent,
    /// Laser PWM duty to write now (the first tick of a powered segment, or 0 as the kernel
    /// stops); [`KEEP_DUTY`] on every other tick.
    pub power: u16,
}

impl TickOut {
    /// An idle tick (no segment) with direction byte `dir` and laser duty `power`.
    const fn idle(dir: u8, power: u16) -> TickOut {
        TickOut {
            step: 0,
            dir,
            period: 0,
            output: OutputEvent::NONE,
            power,
        }
    }
}

/// The probe latch of the kernel (docs/probing.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeLatch {
    /// Not watching the probe pin.
    Off,
    /// Watching: the first tick that sees the raw pin at `trips_at` latches.
    Armed { trips_at: bool },
    /// The pin reached the armed level with the kernel at `steps` (before that tick's steps).
    Tripped { steps: [i64; MAX_AXES] },
}

/// The per-tick Bresenham state machine.
#[derive(Clone, Debug)]
pub struct StepKernel {
    /// Bresenham increments of the running segment (its step counts).
    increment: [u32; MAX_AXES],
    /// Bresenham accumulators.
    accumulator: [u32; MAX_AXES],
    /// Steps made by each axis in the running segment.
    done: [u32; MAX_AXES],
    /// Ticks of the running segment (the Bresenham denominator).
    ticks: u32,
    /// Ticks left in the running segment.
    ticks_left: u32,
    period: u32,
    dir: u8,
    /// Axes 0..axes are stepped by the running segment.
    axes: u8,
    /// Position at the start of the running segment, in steps.
    base: [i64; MAX_AXES],
    /// [`STOPPED`] (a stop latched) and the probe latch's arming ([`PROBE_LOW`] or
    /// [`PROBE_HIGH`]): one byte, so the tick tests both with one load.
    flags: u8,
    /// User output word (bit n = output n) as the kernel's events and its owner left it.
    outputs: u16,
    /// Laser duty the last powered segment set ([`KEEP_DUTY`]: none, or switched off since).
    power: u16,
    /// The latched position (the tick that saw the pin), until disarmed.
    probe_at: Option<[i64; MAX_AXES]>,
    /// Times a tick found the queue empty after a segment ([`Self::dry_runs`]).
    dry_runs: u16,
}

/// [`StepKernel`] flags: a stop has latched.
const STOPPED: u8 = 1;
/// The probe latch watches for a low pin, or a high one (both bits clear: off).
const PROBE_LOW: u8 = 2;
const PROBE_HIGH: u8 = 4;
const PROBE_MASK: u8 = PROBE_LOW | PROBE_HIGH;

impl Default for StepKernel {
    fn default() -> Self {
        Self::new()
    }
}

impl StepKernel {
    /// An idle kernel at step position 0.
    pub const fn new() -> Self {
        StepKernel {
            increment: [0; MAX_AXES],
            accumulator: [0; MAX_AXES],
            done: [0; MAX_AXES],
            ticks: 0,
            ticks_left: 0,
            period: 0,
            dir: 0,
            axes: 0,
            base: [0; MAX_AXES],
            flags: 0,
            outputs: 0,
            power: KEEP_DUTY,
            probe_at: None,
            dry_runs: 0,
        }
    }

    /// Runs one tick: load a segment if needed, step the axes whose Bresenham term overflows.
    /// `probe` is the probe pin's raw level now (see [`Self::arm_probe`]).
    #[inline]
    pub fn tick(&mut self, src: &mut impl SegmentSource, stop: bool, probe: bool) -> TickOut {
        // One test for the rare cases: a stop (argument or latched) or an armed probe latch.
        if stop || self.flags != 0 {
            if stop || self.flags & STOPPED != 0 {
                return self.halt();
            }
            self.probe_sample(probe);
        }
        let mut output = OutputEvent::NONE;
        let mut power = KEEP_DUTY;
        if self.ticks_left == 0 {
            match self.load(src) {
                Some(seg) => (output, power) = seg,
                None => return TickOut::idle(self.dir, self.beam_off()),
            }
        }
        let ticks = self.ticks;
        let n = (self.axes as usize).min(MAX_AXES);
        let mut step = 0u8;
        // A plain indexed loop (`n` ≤ MAX_AXES, so no bounds checks): it compiles to the same
        // tight loop at every opt-level, where an iterator chain needs the inliner (opt-level z
        // leaves it as calls and costs the tick a third more instructions).
        let mut bit = 1u8;
        let mut i = 0;
        while i < n {
            let mut acc = self.accumulator[i] + self.increment[i];
            if acc >= ticks {
                acc -= ticks;
                self.done[i] += 1;
                step |= bit;
            }
            self.accumulator[i] = acc;
            bit <<= 1;
            i += 1;
        }
        self.ticks_left -= 1;
        TickOut {
            step,
            dir: self.dir,
            period: self.period,
            output,
            power,
        }
    }

    /// The duty that switches the beam off when a powered segment left it on (latched as
    /// off), else [`KEEP_DUTY`]: the kernel stands still.
    #[inline(always)]
    fn beam_off(&mut self) -> u16 {
        if self.power == KEEP_DUTY {
            return KEEP_DUTY;
        }
        self.power = KEEP_DUTY;
        0
    }

    /// Takes the next segment from `src` and returns its output event (applied to the output
    /// word) and laser duty; `None` when there is no segment.
    #[inline(never)]
    fn load(&mut self, src: &mut impl SegmentSource) -> Option<(OutputEvent, u16)> {
        self.fold_position();
        let Some(seg) = src.next_segment() else {
            // The first empty look after a segment (`ticks` is ≥ 1 while one was loaded; 0
            // marks the kernel as dry until the next).
            if self.ticks != 0 {
                self.ticks = 0;
                self.dry_runs = self.dry_runs.wrapping_add(1);
            }
            return None;
        };
        let ticks = seg.ticks.max(1);
        self.increment = seg.steps;
        // Start every accumulator half way so steps sit in the middle of their tick slots.
        self.accumulator = [ticks >> 1; MAX_AXES];
        self.ticks = ticks;
        self.ticks_left = ticks;
        self.period = seg.period.max(1);
        self.dir = seg.dir;
        self.axes = seg.axes_in_use() as u8;
        self.outputs = seg.output.apply(self.outputs);
        // A duty of 0 needs no switching off later.
        self.power = if seg.power == 0 { KEEP_DUTY } else { seg.power };
        Some((seg.output, seg.power))
    }

    /// Adds the steps of the running segment to the base position.
    fn fold_position(&mut self) {
        for (i, done) in self.done.iter_mut().enumerate() {
            if self.dir & (1 << i) != 0 {
                self.base[i] -= *done as i64;
            } else {
                self.base[i] += *done as i64;
            }
            *done = 0;
        }
    }

    /// The armed latch's check (kept out of the tick's straight path: unarmed, the tick pays a
    /// byte load and a branch).
    #[cold]
    #[inline(never)]
    fn probe_sample(&mut self, probe: bool) {
        let level = if probe { PROBE_HIGH } else { PROBE_LOW };
        if level == self.probe_arm() {
            self.flags &= !PROBE_MASK;
            self.probe_at = Some(self.position());
        }
    }

    fn probe_arm(&self) -> u8 {
        self.flags & PROBE_MASK
    }

    /// Arms the probe latch: from the next tick, the first one that sees the probe pin's raw
    /// level equal to `trips_at` records the position. Replaces an earlier latch.
    pub fn arm_probe(&mut self, trips_at: bool) {
        self.flags = (self.flags & !PROBE_MASK) | if trips_at { PROBE_HIGH } else { PROBE_LOW };
        self.probe_at = None;
    }

    /// Stops watching the probe pin and forgets a latched position.
    pub(crate) fn disarm_probe(&mut self) {
        self.flags &= !PROBE_MASK;
        self.probe_at = None;
    }

    /// The probe latch now.
    pub fn probe_latch(&self) -> ProbeLatch {
        match (self.probe_at, self.probe_arm()) {
            (Some(steps), _) => ProbeLatch::Tripped { steps },
            (None, 0) => ProbeLatch::Off,
            (None, arm) => ProbeLatch::Armed {
                trips_at: arm == PROBE_HIGH,
            },
        }
    }

    #[cold]
    fn halt(&mut self) -> TickOut {
        if self.flags & STOPPED == 0 {
            self.flags |= STOPPED;
            self.fold_position();
            self.ticks_left = 0;
            self.axes = 0;
        }
        TickOut::idle(self.dir, self.beam_off())
    }

    /// True once a `stop` tick has latched; no step is emitted until [`Self::clear_stop`].
    pub fn is_stopped(&self) -> bool {
        self.flags & STOPPED != 0
    }

    /// Re-arms the kernel after a stop (flush the segment queue first).
    pub fn clear_stop(&mut self) {
        self.flags &= !STOPPED;
    }

    /// User output word (bit n = output n): the level of every user output after the events of
    /// the segments run so far and the last [`Self::set_outputs`].
    pub fn outputs(&self) -> u16 {
        self.outputs
    }

    /// Loads the user output word (the board switched outputs itself: a command list at rest, an
    /// alarm's safe state). The owner drives the pins to it.
    pub(crate) fn set_outputs(&mut self, word: u16) {
        self.outputs = word;
    }

    /// Times a tick found the segment queue empty after running a segment (wrapping): each is
    /// the kernel running dry, whether the motion ended there or the queue starved it (the main
    /// loop tells which, `device::main_loop`). Counted where a segment would load, off the
    /// per-step path.
    pub fn dry_runs(&self) -> u16 {
        self.dry_runs
    }

    /// Laser duty of the running powered segment, 0 when none is (the beam is off).
    pub fn laser_duty(&self) -> u16 {
        if self.power == KEEP_DUTY {
            0
        } else {
            self.power
        }
    }

    /// True while a segment is running (ticks are still due).
    pub fn is_busy(&self) -> bool {
        self.ticks_left != 0
    }

    /// Timer counts the running segment's remaining ticks take (0 when idle), not counting the
    /// wait for the next tick already scheduled.
    pub fn remaining_counts(&self) -> u64 {
        u64::from(self.ticks_left) * u64::from(self.period)
    }

    /// Exact position in steps of every axis, counting the steps already made in the running segment.
    pub fn position(&self) -> [i64; MAX_AXES] {
        let mut p = self.base;
        for (i, d) in self.done.iter().enumerate() {
            if self.dir & (1 << i) != 0 {
                p[i] -= *d as i64;
            } else {
                p[i] += *d as i64;
            }
        }
        p
    }

    /// Sets the step position (homing, or reset after an abort); drops the running segment.
    pub fn set_position(&mut self, steps: [i64; MAX_AXES]) {
        self.base = steps;
        self.done = [0; MAX_AXES];
        self.ticks_left = 0;
        self.axes = 0;
    }

    /// Drops the running segment (abort); the position keeps the steps already made.
    pub fn flush(&mut self) {
        self.fold_position();
        self.ticks_left = 0;
        self.axes = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Queue<'a>(&'a [Segment], usize);
    impl SegmentSource for Queue<'_> {
        fn next_segment(&mut self) -> Option<Segment> {
            let s = self.0.get(self.1).copied();
            self.1 += 1;
            s
        }
    }

    fn seg(steps: [u32; 6], ticks: u32, dir: u8) -> Segment {
        Segment {
            steps,
            ticks,
            period: 100,
            dir,
            output: OutputEvent::NONE,
            power: KEEP_DUTY,
        }
    }

    #[test]
    fn counts_are_exact_and_spread() {
        let segs = [
            seg([10, 7, 3, 0, 0, 1], 10, 0b10),
            seg([80, 0, 0, 0, 0, 0], 80, 0),
        ];
        let mut q = Queue(&segs, 0);
        let mut k = StepKernel::new();
        let mut counts = [0u32; 6];
        let mut ticks = 0;
        let mut last_y = None;
        loop {
            let out = k.tick(&mut q, false, false);
            if out.period == 0 {
                break;
            }
            assert_eq!(out.period, 100);
            for (i, c) in counts.iter_mut().enumerate() {
                if out.step & (1 << i) != 0 {
                    *c += 1;
                    if i == 1 {
                        // No two Y steps in adjacent ticks when 7 steps share 10 ticks... at most 2 apart.
                        if let Some(l) = last_y {
                            assert!(ticks - l <= 2);
                        }
                        last_y = Some(ticks);
                        assert_eq!(out.dir, 0b10);
                    }
                }
            }
            ticks += 1;
        }
        assert_eq!(ticks, 90);
        assert_eq!(counts, [90, 7, 3, 0, 0, 1]);
        assert_eq!(k.position(), [90, -7, 3, 0, 0, 1]);
        assert!(!k.is_busy());
    }

    #[test]
    fn idle_without_segment() {
        let mut q = Queue(&[], 0);
        let mut k = StepKernel::new();
        assert_eq!(k.tick(&mut q, false, false).period, 0);
    }

    #[test]
    fn stop_latches_and_keeps_exact_position() {
        let segs = [seg([100, 50, 0, 0, 0, 0], 100, 0)];
        let mut q = Queue(&segs, 0);
        let mut k = StepKernel::new();
        for _ in 0..10 {
            k.tick(&mut q, false, false);
        }
        assert_eq!(k.position(), [10, 5, 0, 0, 0, 0]);
        let out = k.tick(&mut q, true, false);
        assert_eq!((out.step, out.period), (0, 0));
        let out = k.tick(&mut q, false, false);
        assert_eq!((out.step, out.period), (0, 0));
        assert!(k.is_stopped());
        assert_eq!(k.position(), [10, 5, 0, 0, 0, 0]);
        k.clear_stop();
        assert_eq!(k.tick(&mut q, false, false).period, 0);
    }

    #[test]
    fn an_output_event_is_reported_by_the_tick_that_starts_its_segment() {
        let on = OutputEvent::new(1, true).unwrap();
        let off = OutputEvent::new(1, false).unwrap();
        let mut second = seg([5, 0, 0, 0, 0, 0], 5, 0);
        second.output = on;
        let mut third = seg([3, 0, 0, 0, 0, 0], 3, 0);
        third.output = off;
        let segs = [seg([10, 0, 0, 0, 0, 0], 10, 0), second, third];
        let mut q = Queue(&segs, 0);
        let mut k = StepKernel::new();
        let mut edges = heapless::Vec::<(u32, i64, OutputEvent, u16), 4>::new();
        for t in 0..18 {
            // Position before this tick's step, as the output edge sees it.
            let before = k.position()[0];
            let out = k.tick(&mut q, false, false);
            if out.output.is_some() {
                edges.push((t, before, out.output, k.outputs())).unwrap();
                // The output and the segment's first step come out of the same tick.
                assert_eq!(out.step, 1);
            }
        }
        // On after exactly 10 steps, off after 15, each reported once.
        assert_eq!(edges.as_slice(), &[(10, 10, on, 0b10), (15, 15, off, 0)]);
        assert_eq!(k.position()[0], 18);
        k.set_outputs(0b1001);
        assert_eq!(k.outputs(), 0b1001);
    }

    #[test]
    fn the_probe_latch_records_the_position_of_the_tick_that_sees_the_pin() {
        let segs = [seg([100, 0, 40, 0, 0, 0], 100, 0b100)];
        let mut q = Queue(&segs, 0);
        let mut k = StepKernel::new();
        // Unarmed, the pin is ignored.
        for _ in 0..10 {
            k.tick(&mut q, false, true);
        }
        assert_eq!(k.probe_latch(), ProbeLatch::Off);
        // Armed for a low pin: the high pin does nothing, the first low one latches.
        k.arm_probe(false);
        for _ in 0..10 {
            k.tick(&mut q, false, true);
        }
        assert_eq!(k.probe_latch(), ProbeLatch::Armed { trips_at: false });
        let before = k.position();
        assert_eq!(before, [20, 0, -8, 0, 0, 0]);
        k.tick(&mut q, false, false);
        assert_eq!(k.probe_latch(), ProbeLatch::Tripped { steps: before });
        // The kernel keeps stepping; later levels change nothing.
        for _ in 0..10 {
            k.tick(&mut q, false, true);
        }
        assert_eq!(k.position()[0], 31);
        assert_eq!(k.probe_latch(), ProbeLatch::Tripped { steps: before });
        k.disarm_probe();
        assert_eq!(k.probe_latch(), ProbeLatch::Off);
    }

    #[test]
    fn amass_overdrive_keeps_dominant_rate() {
        // 4 dominant steps over-driven ×8 (32 ticks): the X steps land every 8 ticks.
        let segs = [seg([4, 3, 0, 0, 0, 0], 32, 0)];
        let mut q = Queue(&segs, 0);
        let mut k = StepKernel::new();
        let mut x_ticks = heapless::Vec::<u32, 8>::new();
        for t in 0..32 {
            if k.tick(&mut q, false, false).step & 1 != 0 {
                x_ticks.push(t).unwrap();
            }
        }
        assert_eq!(x_ticks.as_slice(), &[3, 11, 19, 27]);
        assert_eq!(k.position()[1], 3);
    }
}

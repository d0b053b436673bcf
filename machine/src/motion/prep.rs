//! Segment preparation (main context): cuts the head block into short constant-rate segments.
//!
//! Each segment covers a whole number of dominant-axis steps chosen to last about
//! [`SEGMENT_COUNTS`] (2 ms); the last one before the block's end (or a hold's stopping point)
//! takes what remains when less than half a segment would be left, so it lasts up to ~3 ms
//! ([`segment_steps`]). Step counts are *cumulative*: after dominant step `c` of `N`, axis
//! `i` has made `round(steps_i · c / N)` steps, so a block always ends with exactly its step counts
//! and a job with the rational conversion of its end point. The segment's duration comes from the
//! closed-form [`Profile`] time at the segment's end, minus the time already emitted, so the
//! rounding of tick periods never drifts; what a block's last segment leaves out is paid in the
//! next block's first segment (`owed`), so it does not drift across blocks either. At low step
//! rates the tick is over-driven 2×, 4× or 8× (AMASS) so the other axes place their steps more
//! finely.
//!
//! A block's on-the-fly output event goes on the block's first segment only (a hold that stops
//! and resumes inside the block does not repeat it).
//!
//! In laser mode every segment carries the PWM duty of its block's [`super::laser::LaserPower`]
//! at the segment's average speed ([`PwmMap::segment_duty`]: M4 follows the speed segment by
//! segment, through ramps, corners, holds and resumes); dwell segments carry 0.
//!
//! On a plasma machine with torch height control, a segment of a move without Z motion that
//! runs at cruise speed, at or above the anti-dive share of the programmed feed, also carries
//! the Z steps [`super::thc::Thc`] adds for the height controller's inputs.

mod jerk_line;

pub use jerk_line::JerkSetup;

use super::history::{Handed, History, Stand};
use super::jerk::{Limits, Tracker};
use super::laser::PwmMap;
use super::planner::{Block, BlockKind, Planner};
use super::profile::Profile;
use super::thc::{with_z_dir, Thc, ThcConfig, THC_AXIS};
use crate::arith::{div_u64, isqrt_u64, mul_div, sat_mul};
use crate::step::kernel::{Segment, KEEP_DUTY, KERNEL_TIMER_HZ};
use crate::step::output_event::OutputEvent;
use crate::units::MAX_AXES;

/// Target segment duration in kernel timer counts (2 ms).
pub(crate) const SEGMENT_COUNTS: u64 = KERNEL_TIMER_HZ as u64 / SEGMENTS_PER_SECOND;

/// Segments per second at the target duration (a whole divisor of the timer rate, so a speed's
/// nm per segment is one division).
const SEGMENTS_PER_SECOND: u64 = 500;
const _: () = assert!((KERNEL_TIMER_HZ as u64).is_multiple_of(SEGMENTS_PER_SECOND));

/// Dominant step periods above which AMASS over-drives the tick ×2, ×4, ×8 (8, 4, 2 kHz).
const AMASS_PERIODS: [u64; 3] = [
    KERNEL_TIMER_HZ as u64 / 8_000,
    KERNEL_TIMER_HZ as u64 / 4_000,
    KERNEL_TIMER_HZ as u64 / 2_000,
];

/// Run / hold state of segment preparation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PrepState {
    Running,
    /// Decelerating on the path towards a stop.
    Holding,
    /// Stopped by a hold; nothing is prepared until resumed.
    Held,
}

/// What happened to one finished block (for `gantry simulate` and status reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BlockReport {
    pub line: u32,
    pub rapid: bool,
    /// Path length, nm.
    pub length: u64,
    /// Entry, highest and exit speeds, nm/s.
    pub entry: u64,
    pub peak: u64,
    pub exit: u64,
    /// Duration, kernel timer counts.
    pub counts: u64,
    /// Highest path acceleration (nm/s², either sign) and jerk (nm/s³; [`STEP_JERK`]: the
    /// acceleration switched at once, the trapezoid) while the block ran.
    pub accel: u64,
    pub jerk: u64,
}

/// [`BlockReport::jerk`] of a trapezoid ramp: the acceleration steps from 0 to its limit.
pub const STEP_JERK: u64 = u64::MAX;

impl BlockReport {
    /// A trapezoid block's peaks: its acceleration, switched at once, if its speed changed.
    fn trapezoid(&mut self, accel: u64) {
        if self.entry != self.peak || self.exit != self.peak {
            self.accel = accel;
            self.jerk = STEP_JERK;
        }
    }
}

/// Result of one preparation step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PrepOut {
    Segment(Segment),
    /// The head block is a sync point: wait for the kernel to drain, act, then pop it.
    Sync,
    /// Nothing to prepare (empty, held).
    Idle,
}

/// Result of [`Prep::next_block`]: one whole block in closed form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BlockOut {
    /// A line or dwell block finished; its duration in kernel timer counts.
    Time(u64),
    /// The head block is a sync point (as [`PrepOut::Sync`]).
    Sync,
    /// Nothing to prepare (empty, or not running).
    Idle,
}

/// Segment preparation state for the head block.
#[derive(Clone, Debug)]
pub(crate) struct Prep {
    pub state: PrepState,
    /// The head block is checked out.
    active: bool,
    /// Dominant steps done in the head block, and the path position (nm) they reach.
    done: u32,
    s_now: u64,
    /// Speed at `s_now` under `profile` (`profile.speed_at(s_now)`, kept instead of recomputed:
    /// a square root in the ramps), nm/s.
    v_now: u64,
    /// Steps done per axis in the head block.
    cum: [u32; MAX_AXES],
    /// The head block's output event, until its first segment carries it.
    output: OutputEvent,
    profile: Profile,
    /// Counts emitted since the profile's origin.
    emitted: u64,
    /// Profile time of the block before that its last segment's whole tick period left out
    /// (under one tick period), paid in this block's first segment so block ends do not drift;
    /// 0 after a stop, a sync point or a dwell, and from a re-profile inside a block.
    owed: u64,
    /// The same for the block just finished, until the next one starts.
    owed_next: u64,
    /// Exit target and cruise speed the profile was built with.
    exit_sq: u64,
    nominal: u64,
    /// The planner's [`Planner::revision`] when `exit_sq` and `nominal` were last checked.
    revision: u32,
    holding: bool,
    /// Speed carried into the next block, nm/s.
    carry: u64,
    dwell_left: u64,
    /// Step position after every prepared segment.
    position: [i64; MAX_AXES],
    report: BlockReport,
    finished: Option<BlockReport>,
    /// The segments handed out lately, to take back the ones the kernel has not started.
    history: History,
    /// Laser mode's S → duty map (`None`: segments leave the PWM alone).
    laser: Option<PwmMap>,
    /// The spindle override, percent, scaling S in laser mode.
    pub laser_override: u16,
    /// Torch height control: the Z steps it adds and the correction made.
    pub thc: Thc,
    /// The jerk limit (`None`: trapezoid ramps, `motion/prep/jerk_line.rs` otherwise).
    jerk: Option<JerkSetup>,
    /// Jerk-limited mode: the tracker at the end of its current step (head-block coordinates),
    /// the prepared position (SUB-ths of a nm) and the step's counts not yet handed out.
    trk: Tracker,
    p_sub: u64,
    rem_counts: u64,
    /// Counts of the steps without a dominant step so far, for the next segment.
    owed_j: u64,
    /// A hold's stopping point, nm from the head block's start.
    hold_at: Option<u64>,
    /// The last reach of the limits' scan (`jerk_line.rs`, `Prep::ahead`): the same speed,
    /// acceleration and limits at cruise, step after step.
    reach: Option<((u64, i64, Limits), u64)>,
    /// The run of open junctions the last scan found (`jerk_line.rs`).
    open_run: Option<jerk_line::OpenRun>,
    /// The last two path accelerations asked for and their limits (`Prep::path_limits`).
    path_limits: [(u64, Limits); 2],
}

impl Default for Prep {
    fn default() -> Self {
        Self::new()
    }
}

impl Prep {
    pub const fn new() -> Self {
        Prep {
            state: PrepState::Running,
            active: false,
            done: 0,
            s_now: 0,
            v_now: 0,
            cum: [0; MAX_AXES],
            output: OutputEvent::NONE,
            profile: Profile::ZERO,
            emitted: 0,
            owed: 0,
            owed_next: 0,
            exit_sq: 0,
            nominal: 0,
            revision: 0,
            holding: false,
            carry: 0,
            dwell_left: 0,
            position: [0; MAX_AXES],
            report: BlockReport {
                line: 0,
                rapid: false,
                length: 0,
                entry: 0,
                peak: 0,
                exit: 0,
                counts: 0,
                accel: 0,
                jerk: 0,
            },
            finished: None,
            history: History::new(),
            laser: None,
            laser_override: 100,
            thc: Thc::new(None),
            jerk: None,
            trk: jerk_line::REST,
            p_sub: 0,
            rem_counts: 0,
            owed_j: 0,
            hold_at: None,
            reach: None,
            open_run: None,
            path_limits: [(0, Limits { accel: 0, jerk: 0 }); 2],
        }
    }

    /// Forgets the head block (after an abort); the step position, the laser map and the
    /// height control's setup stay (its correction is part of that position now).
    pub fn reset(&mut self) {
        let (position, laser, pct) = (self.position, self.laser, self.laser_override);
        let jerk = self.jerk;
        let mut thc = self.thc;
        thc.absorbed();
        *self = Prep::new();
        self.jerk = jerk;
        self.position = position;
        self.laser = laser;
        self.laser_override = pct;
        self.thc = thc;
    }

    /// Sets torch height control's rate and travel (`None`: no height control).
    pub(crate) fn set_thc(&mut self, cfg: Option<ThcConfig>) {
        self.thc = Thc::new(cfg);
    }

    /// A Z-only segment taking the height correction back towards 0 (`None` once it is 0); only
    /// with no block in progress (the board asks at a sync point).
    pub(crate) fn thc_return(&mut self) -> Option<Segment> {
        if self.active {
            return None;
        }
        let (seg, z) = self.thc.return_segment(SEGMENT_COUNTS)?;
        self.position[THC_AXIS] += i64::from(z);
        Some(seg)
    }

    /// A new prep for a machine with laser map `laser` (`None`: not a laser machine) and torch
    /// height control `thc` (`None`: none).
    pub(crate) const fn with_laser(laser: Option<PwmMap>, thc: Option<ThcConfig>) -> Self {
        let mut p = Prep::new();
        p.laser = laser;
        p.thc = Thc::new(thc);
        p
    }

    /// The same prep with jerk limit `jerk`.
    pub fn with_jerk(mut self, jerk: Option<JerkSetup>) -> Self {
        self.jerk = jerk;
        self
    }

    /// Sets the jerk limit (`None`: the trapezoid's ramps); only at rest.
    pub fn set_jerk(&mut self, jerk: Option<JerkSetup>) {
        self.jerk = jerk;
        self.reach = None;
        self.open_run = None;
        self.path_limits = Prep::new().path_limits;
    }

    /// Sets laser mode's S → duty map (`None`: not a laser machine).
    pub(crate) fn set_laser(&mut self, laser: Option<PwmMap>) {
        self.laser = laser;
    }

    /// Step position at the end of everything prepared so far.
    pub fn position(&self) -> [i64; MAX_AXES] {
        self.position
    }

    /// Sets the step position; what was handed out before can no longer be taken back.
    pub fn set_position(&mut self, steps: [i64; MAX_AXES]) {
        self.position = steps;
        self.history = History::new();
    }

    /// True while the head block is partly prepared.
    pub(crate) fn is_active(&self) -> bool {
        self.active
    }

    /// Path position (nm into the head block) at the end of what is prepared.
    pub(crate) fn path_position(&self) -> u64 {
        self.s_now
    }

    /// Ends the block in progress where prep stands (a jog bending to a new direction): the
    /// caller drops it from the planner and queues the continuation, which starts at the current
    /// speed.
    pub fn cut(&mut self) {
        if self.active {
            self.carry = self.speed();
            self.active = false;
            self.history.end_block();
            // The tracker goes on from here along the new block, at its speed and acceleration.
            self.trk.s = 0;
            self.p_sub = 0;
            self.rem_counts = 0;
        }
    }

    /// Speed at the end of what is prepared, nm/s.
    pub fn speed(&self) -> u64 {
        if self.active {
            self.v_now
        } else {
            self.carry
        }
    }

    /// The report of the last finished block, once.
    pub(crate) fn take_report(&mut self) -> Option<BlockReport> {
        self.finished.take()
    }

    /// Prepares the next segment of the planner's head block.
    pub fn next<const N: usize>(&mut self, planner: &mut Planner<N>) -> PrepOut {
        loop {
            if self.state == PrepState::Held {
                return PrepOut::Idle;
            }
            // Only the head's kind and number here: the block itself stays in the ring (a copy
            // of it cost a 120-byte `memcpy` per call on the MCU).
            let Some((kind, seq)) = planner.head().map(|b| (b.kind(), b.seq)) else {
                if self.state == PrepState::Holding {
                    self.state = PrepState::Held;
                }
                self.carry = 0;
                return PrepOut::Idle;
            };
            match kind {
                BlockKind::Sync => {
                    self.carry = 0;
                    if self.state == PrepState::Holding {
                        self.state = PrepState::Held;
                        return PrepOut::Idle;
                    }
                    return PrepOut::Sync;
                }
                BlockKind::Dwell { counts } => {
                    self.carry = 0;
                    if self.state == PrepState::Holding {
                        self.state = PrepState::Held;
                        return PrepOut::Idle;
                    }
                    if !self.active {
                        self.active = true;
                        self.dwell_left = counts;
                    }
                    if self.dwell_left == 0 {
                        self.active = false;
                        planner.pop();
                        continue;
                    }
                    let p = self.dwell_left.min(SEGMENT_COUNTS);
                    self.dwell_left -= p;
                    self.history.record(Handed {
                        steps: [0; MAX_AXES],
                        seq,
                        done: 0,
                        speed: 0,
                        stand: if self.dwell_left == 0 {
                            Stand::BlockEnd
                        } else {
                            Stand::Dwelling
                        },
                    });
                    let power = if self.laser.is_some() { 0 } else { KEEP_DUTY };
                    return PrepOut::Segment(Segment::idle(1, p as u32).with_power(power));
                }
                BlockKind::Line { output } => {
                    let seg = match self.jerk {
                        Some(js) if cfg!(feature = "jerk") => {
                            self.jerk_segment(output, planner, js)
                        }
                        _ => self.line_segment(output, planner),
                    };
                    if let Some(seg) = seg {
                        return PrepOut::Segment(seg);
                    }
                    if self.state == PrepState::Held {
                        return PrepOut::Idle;
                    }
                }
            }
        }
    }

    /// Host planning tools (`gantry check`, `simulate`, `preview`): finishes the head block at
    /// once instead of cutting it into segments, and returns what [`Self::next`] would have
    /// returned for it with the duration in closed form: a line block's rest from the profile prep
    /// builds for it ([`Profile::duration`], the profile the board runs), a dwell's counts whole.
    /// The step position, the carried speed and the block report end as after its last segment.
    /// Only while running (a hold is never planned this way); segments handed out before can no
    /// longer be taken back.
    pub(crate) fn next_block<const N: usize>(&mut self, planner: &mut Planner<N>) -> BlockOut {
        if self.state != PrepState::Running {
            return BlockOut::Idle;
        }
        let Some(head) = planner.head().copied() else {
            self.carry = 0;
            return BlockOut::Idle;
        };
        self.history = History::new();
        self.owed_next = 0;
        match head.kind() {
            BlockKind::Sync => {
                self.carry = 0;
                BlockOut::Sync
            }
            BlockKind::Dwell { counts } => {
                let left = if self.active { self.dwell_left } else { counts };
                self.carry = 0;
                self.active = false;
                self.dwell_left = 0;
                planner.pop();
                BlockOut::Time(left)
            }
            BlockKind::Line { output } if cfg!(feature = "jerk") && self.jerk.is_some() => {
                // Jerk-limited: the block's segments, timed.
                let js = self.jerk.unwrap_or(JerkSetup {
                    jerk: 1,
                    accel: 1,
                    floor: 1,
                });
                let seq = head.seq;
                let mut counts = 0u64;
                while planner.head().is_some_and(|b| b.seq == seq) {
                    match self.jerk_segment(output, planner, js) {
                        Some(seg) => counts += u64::from(seg.ticks) * u64::from(seg.period),
                        None if self.active => break,
                        None => {}
                    }
                }
                self.history = History::new();
                BlockOut::Time(counts)
            }
            BlockKind::Line { output } => {
                if !self.active {
                    // Starts the block exactly as `line_segment` does.
                    self.active = true;
                    self.done = 0;
                    self.s_now = 0;
                    self.cum = [0; MAX_AXES];
                    self.output = output;
                    let v_in = if head.stop_before { 0 } else { self.carry };
                    self.reprofile(&head, planner, 0, v_in);
                    self.report = BlockReport {
                        line: head.line,
                        rapid: head.rapid,
                        length: head.length,
                        entry: self.profile.v0,
                        peak: self.profile.v0,
                        exit: 0,
                        counts: 0,
                        accel: 0,
                        jerk: 0,
                    };
                } else if planner.exit_sq(0) != self.exit_sq
                    || planner.nominal(&head) != self.nominal
                {
                    self.reprofile(&head, planner, self.s_now, self.v_now);
                }
                let counts = self.profile.duration().saturating_sub(self.emitted);
                for i in 0..MAX_AXES {
                    let left = i64::from(head.steps[i] - self.cum[i]);
                    self.position[i] += if head.dir & (1 << i) != 0 {
                        -left
                    } else {
                        left
                    };
                }
                self.output = OutputEvent::NONE;
                self.done = head.events;
                self.s_now = head.length;
                self.carry = self.profile.speed_at(head.length);
                self.v_now = self.carry;
                self.report.counts += counts;
                self.report.peak = self.report.peak.max(self.profile.peak());
                self.report.exit = self.carry;
                self.report.trapezoid(head.accel);
                self.finished = Some(self.report);
                self.active = false;
                planner.pop();
                BlockOut::Time(counts)
            }
        }
    }

    /// Builds the head block's profile from path position `s` at speed `v`.
    fn reprofile<const N: usize>(&mut self, b: &Block, planner: &Planner<N>, s: u64, v: u64) {
        self.emitted = 0;
        self.owed = 0;
        if self.state == PrepState::Holding {
            self.profile = Profile::hold(s, v, b.length, b.accel);
            self.v_now = self.profile.v0;
            self.holding = true;
            return;
        }
        let exit_sq = planner.exit_sq(0);
        let nominal = planner.nominal(b);
        let v0 = if v == 0 {
            // From rest the speed may jump to the start speed, if the block can still stop.
            let reach_sq = exit_sq
                .min(nominal * nominal)
                .saturating_add(sat_mul(b.accel.saturating_mul(2), b.length - s));
            u64::from(b.start_speed)
                .min(nominal)
                .min(isqrt_u64(reach_sq))
        } else {
            v
        };
        self.profile
            .replan(s, v0, b.length, nominal, exit_sq, b.accel);
        // At its origin a profile's speed is `v0` (`Profile::speed_at`).
        self.v_now = v0;
        self.exit_sq = exit_sq;
        self.nominal = nominal;
        self.revision = planner.revision();
        self.holding = false;
    }

    /// How many of the newest segments handed out can be taken back now ([`History::droppable`]):
    /// segments of the line block in progress.
    pub(crate) fn droppable<const N: usize>(&self, planner: &Planner<N>) -> usize {
        if cfg!(feature = "jerk") && self.jerk.is_some() {
            // The tracker's state at an earlier segment is not kept: nothing is taken back.
            return 0;
        }
        let active = planner
            .head()
            .filter(|b| self.active && b.is_line())
            .map(|b| b.seq);
        self.history.droppable(active)
    }

    /// The kernel's owner dropped the newest `k` segments handed out (at most
    /// [`Self::droppable`]) before the kernel started them. Prep continues from its state after
    /// the last segment kept: that exact step position, place in the block and speed, with a new
    /// profile (so a hold decelerates from there at once, a new speed ramps from there).
    pub fn rewind<const N: usize>(&mut self, k: usize, planner: &Planner<N>) {
        let allowed = self.droppable(planner);
        debug_assert!(k <= allowed, "dropped {k} segments, {allowed} allowed");
        let k = k.min(allowed);
        if k == 0 {
            return;
        }
        let (at, steps) = self.history.take_back(k);
        for (p, s) in self.position.iter_mut().zip(steps) {
            *p -= s;
        }
        if planner.head().is_some_and(|b| b.steps[THC_AXIS] == 0) {
            // The dropped segments are of the head block: its Z steps were all corrections.
            self.thc.taken_back(steps[THC_AXIS] as i32);
        }
        if self.state == PrepState::Held {
            // The stop prepared so far was dropped with the segments: decelerate again.
            self.state = PrepState::Holding;
        }
        match planner.head().copied() {
            Some(b) if b.seq == at.seq && matches!(at.stand, Stand::Inside | Stand::BlockEnd) => {
                self.done = at.done;
                self.s_now = Self::s_of(&b, at.done);
                for i in 0..MAX_AXES {
                    self.cum[i] = cum_at(&b, i, at.done);
                }
                self.reprofile(&b, planner, self.s_now, u64::from(at.speed));
            }
            _ => {
                // At the end of the block before: the head block starts again from its start.
                self.active = false;
                self.carry = u64::from(at.speed);
                self.owed_next = 0;
            }
        }
    }

    /// Path position (nm) of dominant step `c` of the block (the block's end without dividing).
    fn s_of(b: &Block, c: u32) -> u64 {
        if c == b.events {
            b.length
        } else {
            mul_div(c as u64, b.length, b.events as u64)
        }
    }

    /// Next segment of a line block, or `None` when the block finished or a hold stopped.
    fn line_segment<const N: usize>(
        &mut self,
        output: OutputEvent,
        planner: &mut Planner<N>,
    ) -> Option<Segment> {
        // The caller found a line block at the head.
        let b = planner.head()?;
        if !self.active {
            self.active = true;
            self.done = 0;
            self.s_now = 0;
            self.cum = [0; MAX_AXES];
            self.output = output;
            if let Some(on) = output.thc_switch() {
                // `M62 P2` / `M63 P2`: height control off / on from this block's first step.
                self.thc.enabled = on;
                self.output = OutputEvent::NONE;
            }
            let v_in = if b.stop_before { 0 } else { self.carry };
            self.reprofile(b, planner, 0, v_in);
            self.owed = if v_in == 0 {
                0
            } else {
                core::mem::take(&mut self.owed_next)
            };
            self.report = BlockReport {
                line: b.line,
                rapid: b.rapid,
                length: b.length,
                entry: self.profile.v0,
                peak: self.profile.v0,
                exit: 0,
                counts: 0,
                accel: 0,
                jerk: 0,
            };
        } else {
            let hold = self.state == PrepState::Holding;
            let stale = if hold {
                !self.holding
            } else if self.holding {
                true
            } else if planner.revision() == self.revision {
                // Nothing changed in the planner since the last check: the same exit and speed.
                false
            } else {
                self.revision = planner.revision();
                planner.exit_sq(0) != self.exit_sq || planner.nominal(b) != self.nominal
            };
            if stale {
                self.reprofile(b, planner, self.s_now, self.v_now);
            }
        }
        let end = if self.holding && self.profile.s3 < b.length {
            (mul_div(self.profile.s3, b.events as u64, b.length) as u32).max(self.done)
        } else {
            b.events
        };
        if self.done >= end {
            if self.done < b.events {
                // A hold came to rest inside the block.
                self.state = PrepState::Held;
                return None;
            }
            self.carry = if self.s_now == b.length {
                self.v_now
            } else {
                self.profile.speed_at(b.length)
            };
            self.report.exit = self.carry;
            self.report.trapezoid(b.accel);
            self.finished = Some(self.report);
            self.active = false;
            planner.pop();
            if self.holding && self.carry == 0 {
                self.state = PrepState::Held;
            }
            return None;
        }
        // Dominant steps for about one segment time at the current speed.
        let v = self.v_now;
        // v · SEGMENT_COUNTS / HZ, exactly: HZ is a whole multiple of SEGMENT_COUNTS.
        let nm = div_u64(v, SEGMENTS_PER_SECOND);
        let n = segment_steps(mul_div(nm, b.events as u64, b.length), end - self.done);
        let c = self.done + n;
        let s = Self::s_of(b, c);
        let (t, speed) = self.profile.time_speed_at(s);
        let dt = (t + self.owed).saturating_sub(self.emitted).max(1);
        // AMASS level from the dominant step period dt / n, compared without dividing.
        let level = AMASS_PERIODS.iter().filter(|&&p| dt > p * n as u64).count() as u32;
        let ticks = n << level;
        let period = div_u64(dt, ticks as u64).max(1).min(u32::MAX as u64) as u32;
        let duration = ticks as u64 * period as u64;
        self.emitted += duration;
        self.owed_next = if c == b.events {
            (t + self.owed).saturating_sub(self.emitted)
        } else {
            0
        };
        let mut steps = [0u32; MAX_AXES];
        let mut signed = [0i32; MAX_AXES];
        for i in 0..MAX_AXES {
            if b.steps[i] == 0 {
                continue;
            }
            let total = cum_at(b, i, c);
            steps[i] = total - self.cum[i];
            self.cum[i] = total;
            // A segment lasts about 2 ms: its step counts are far below i32::MAX.
            signed[i] = if b.dir & (1 << i) != 0 {
                -(steps[i] as i32)
            } else {
                steps[i] as i32
            };
            self.position[i] += i64::from(signed[i]);
        }
        let mut dir = b.dir;
        if self.thc.cfg.is_some() && b.steps[THC_AXIS] == 0 {
            // Cruise: the whole segment inside the profile's cruise at the move's own speed
            // (not a ramp, a corner's slow-down or a hold), and anti-dive: that speed at least
            // the set share of the programmed feed.
            let p = &self.profile;
            let pct = self.thc.cfg.map_or(0, |c| u64::from(c.anti_dive));
            let cruise = !self.holding
                && self.s_now >= p.s1
                && s <= p.s2
                && p.vm == self.nominal
                && p.vm * 100 >= u64::from(b.programmed) * pct;
            let z = self.thc.steps(cruise, duration, ticks);
            if z != 0 {
                steps[THC_AXIS] = z.unsigned_abs();
                signed[THC_AXIS] = z;
                self.position[THC_AXIS] += i64::from(z);
                dir = with_z_dir(dir, z);
            }
        }
        let power = match self.laser {
            None => KEEP_DUTY,
            // The segment's average speed: its path length over its duration.
            Some(map) => map.segment_duty(
                b.laser.scaled(self.laser_override),
                mul_div(s - self.s_now, KERNEL_TIMER_HZ as u64, duration.max(1)),
                b.programmed,
            ),
        };
        self.done = c;
        self.s_now = s;
        // `time_speed_at`'s speed is `speed_at(s)`.
        self.v_now = speed;
        self.report.counts += duration;
        self.report.peak = self.report.peak.max(speed);
        self.history.record(Handed {
            steps: signed,
            seq: b.seq,
            done: c,
            speed: speed.min(u64::from(u32::MAX)) as u32,
            stand: if c == b.events {
                Stand::BlockEnd
            } else {
                Stand::Inside
            },
        });
        Some(Segment {
            steps,
            ticks,
            period,
            dir,
            output: core::mem::take(&mut self.output),
            power,
        })
    }
}

/// Dominant steps of the next segment: `nominal` (about [`SEGMENT_COUNTS`] at the current speed,
/// at least 1), or all `left` steps up to `end` (the block's end or a hold's stopping point) when
/// fewer would remain than half a segment. So a segment lasts at most about 1.5× its nominal
/// 2 ms, and a block is never split into a long segment and a tiny remainder (a 64-step line
/// used to end with a 1-step segment of its own: a whole preparation and a kernel segment load
/// for one step). The duration stays exact: it comes from the profile at the segment's end.
fn segment_steps(nominal: u64, left: u32) -> u32 {
    let nominal = nominal.max(1);
    let left64 = u64::from(left);
    // `left - nominal < nominal / 2`, without dividing; true whenever `nominal >= left`.
    if left64.saturating_sub(nominal) * 2 < nominal {
        left
    } else {
        // nominal < left here: it fits in u32.
        nominal as u32
    }
}

/// Steps axis `i` has made after dominant step `c` of block `b`: round(steps_i · c / N), cumulative,
/// so the block ends exactly on its step counts.
fn cum_at(b: &Block, i: usize, c: u32) -> u32 {
    match b.steps[i] {
        0 => 0,
        s if s == b.events => c,
        s if c == b.events => s,
        s => div_u64(s as u64 * c as u64 + b.events as u64 / 2, b.events as u64) as u32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_takes_short_remainders_only() {
        assert_eq!(segment_steps(64, 65), 65);
        assert_eq!(segment_steps(64, 95), 95);
        assert_eq!(segment_steps(64, 96), 64);
        assert_eq!(segment_steps(64, 30), 30);
        assert_eq!(segment_steps(0, 5), 1);
        assert_eq!(segment_steps(1, 2), 1);
        assert_eq!(segment_steps(3, 4), 4);
    }
}

//! Segment preparation with a jerk limit: the [`Tracker`] (`motion/jerk.rs`) moves along the
//! path in 2 ms steps, and each step is cut into one segment per block it crosses.
//!
//! The tracker's limits come from the planner's ring, cheaply: the junction limits
//! (`max_entry_sq` of the block after each junction, with the nominal speeds), a stop at the end
//! of what is buffered or before a stop (`stop_after`, `stop_before`: the jerk-limited ramp ends at
//! rest there, not at the start speed, so no speed is ever jumped) and a hold's stopping point.
//! Only limits within reach matter: the scan ends past the braking distance from the highest
//! speed the next step can reach, and of the limits found only a staircase is kept (a limit at
//! or above the speed of a nearer one kept is implied by it, braking distances growing with
//! the speed difference), plus those the step may pass. The path's acceleration for a step is
//! the least of the blocks in reach, its jerk that acceleration times the setup's least ratio
//! of an axis's jerk to its acceleration (exact when every axis has the same ratio, and never
//! more than any axis allows: [`JerkSetup`]).
//!
//! A tracker step's time is split between the blocks it crosses in proportion to the distance
//! in each (the speed changes by at most `A·2 ms` inside a step); a segment ends on whole dominant
//! steps, and time without a step is carried to the next segment. A hold places a stop at the
//! jerk-limited stopping distance from where the tracker stands and brakes to it with the same
//! jerk limit; the segments already queued in the kernel are not taken back (a hold starts
//! after them, at most the owner's queue of 2 ms segments later).

use super::{BlockReport, Prep, PrepState, SEGMENTS_PER_SECOND};
use crate::arith::{isqrt_u64, mul_div};
use crate::motion::config::MotionConfig;
use crate::motion::history::{Handed, Stand};
use crate::motion::jerk::{brake_distance, Limit, Limits, Tracker, SUB};
use crate::motion::planner::{Block, Planner};
use crate::step::kernel::{Segment, KEEP_DUTY};
use crate::step::output_event::OutputEvent;
use crate::units::MAX_AXES;

/// Most limits one tracker step checks.
const MAX_LIMITS: usize = 8;

/// The jerk limit of a machine whose every axis in use has one: the axis with the least ratio
/// of jerk to acceleration, `jerk / accel`. A block's path jerk is its path acceleration times
/// that ratio: `J_i·L/d_i = (J_i/A_i)·(A_i·L/d_i) ≥ ratio · min_i(A_i·L/d_i)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JerkSetup {
    /// The least ratio `jerk / accel` (s⁻¹) in lowest terms, so a path acceleration times
    /// `jerk` stays in 64 bits (25/1 for 5,000 mm/s³ at 200 mm/s²) and the path jerk costs one
    /// hardware-assisted division a step, not a 128-bit one.
    pub jerk: u64,
    pub accel: u64,
    /// The least acceleration of an axis in use, nm/s²: no path acceleration is lower.
    pub floor: u64,
}

impl JerkSetup {
    /// The setup's jerk limit, `None` unless every axis in use has one.
    pub fn of(cfg: &MotionConfig) -> Option<JerkSetup> {
        let axes = &cfg.axes[..cfg.axis_count_in_bounds()];
        if axes.is_empty() || axes.iter().any(|a| a.jerk == 0) {
            return None;
        }
        let floor = axes.iter().map(|a| a.accel.max(1)).min().unwrap_or(1);
        axes.iter()
            .map(|a| (a.jerk, a.accel.max(1)))
            .min_by(|x, y| {
                (u128::from(x.0) * u128::from(y.1)).cmp(&(u128::from(y.0) * u128::from(x.1)))
            })
            .map(|(jerk, accel)| {
                let g = crate::arith::gcd_u64(jerk, accel);
                JerkSetup {
                    jerk: jerk / g,
                    accel: accel / g,
                    floor,
                }
            })
    }

    /// Path limits for path acceleration `accel`, nm/s².
    fn limits(&self, accel: u64) -> Limits {
        let jerk = mul_div(accel, self.jerk, self.accel).max(crate::motion::jerk::STEPS_PER_SECOND);
        Limits {
            accel: accel.max(1),
            jerk,
        }
    }
}

/// A run of consecutive blocks whose junctions after each are open (never bind, see
/// `Prep::ahead`), kept from one step's scan to the next: the scan jumps over it instead of
/// visiting its blocks again (on fine contours some 70-130 blocks every 2 ms step).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct OpenRun {
    /// Sequence numbers of its first and last block.
    first: u32,
    last: u32,
    /// Their summed length, nm.
    length: u64,
    /// Their least path acceleration, nm/s², or less: when the block that had it leaves, the
    /// run keeps it (lower than needed, never higher) for at most [`STALE_POPS`] more blocks
    /// and is then found again.
    accel: u64,
    least: Option<u32>,
    stale: u8,
    /// The feed and rapid overrides it was found under (they move cruise and junction speeds).
    overrides: (u16, u16),
}

impl OpenRun {
    /// The run once its first block `head` (`length` nm) has left: `None` when nothing is left
    /// or its least acceleration has been stale for more than [`STALE_POPS`] blocks.
    pub(super) fn after_pop(self, head: u32, length: u64) -> Option<OpenRun> {
        if self.first != head {
            return Some(self);
        }
        let (least, stale) = match self.least {
            Some(l) if l != head => (Some(l), self.stale),
            _ => (None, self.stale + 1),
        };
        (self.last != head && stale <= STALE_POPS).then(|| OpenRun {
            first: head.wrapping_add(1),
            length: self.length - length,
            least,
            stale,
            ..self
        })
    }
}

/// Blocks an [`OpenRun`] may keep a stale least acceleration for.
const STALE_POPS: u8 = 32;

/// The limits ahead of the tracker for one step.
struct Ahead {
    limits: heapless::Vec<Limit, MAX_LIMITS>,
    /// Least path acceleration of the blocks in reach, nm/s².
    accel: u64,
}

/// At least the braking distance (nm) to rest from speed `v` (pm/s) and acceleration `a`
/// (nm/s², ≥ 0) under `lim` (`jerk::brake_distance`), in 64-bit arithmetic: releasing `a`
/// (at most `a/J` s at the speed it ends at, `v₁ = v + a²/2J`), then from `v₁` at most
/// `v₁²/2A + v₁·A/J` (the jerk-limited stop's `v₁²/2A + v₁·A/2J` when it reaches `A`, and
/// `v₁·√(v₁/J) < v₁·A/J` when it does not). Only how far the limits are read depends on it.
fn reach_bound(v: u64, a: u64, lim: Limits) -> u64 {
    let (accel, jerk) = (lim.accel.max(1), lim.jerk.max(1));
    let v1 = (v / 1000 + 1).saturating_add(mul_div(a, a, 2 * jerk));
    mul_div(v1, a, jerk)
        .saturating_add(mul_div(v1, v1, 2 * accel))
        .saturating_add(mul_div(v1, accel, jerk))
        .saturating_add(2)
        .min(u64::MAX / 4)
}

impl Prep {
    /// The path limits for path acceleration `accel` (nm/s²), from the last two asked for
    /// when one is the same (the head block's and the floor's, step after step).
    fn path_limits(&mut self, js: &JerkSetup, accel: u64) -> Limits {
        if let Some(&(_, l)) = self.path_limits.iter().find(|(a, _)| *a == accel) {
            return l;
        }
        let l = js.limits(accel);
        self.path_limits = [(accel, l), self.path_limits[0]];
        l
    }

    /// Collects the limits of the head block and the blocks after it within reach of the
    /// tracker's next step (nm from the head block's start; speeds pm/s).
    fn ahead<const N: usize>(&mut self, planner: &Planner<N>, js: &JerkSetup) -> Ahead {
        let mut accel = planner.head().map_or(1, |b| b.accel);
        let t = self.trk;
        let here = t.position_nm();
        // Reach: the braking distance from the highest speed and acceleration of the step's
        // end at the lowest limits any block can have. A block's lower acceleration enters the
        // step's limits as soon as the junction before it is in reach, so the tracker can still
        // brake for everything at the lowered limits (braking for the junction itself happens
        // in the block before, but at the lower limits it only takes longer).
        let q = self.path_limits(js, accel).step_accel();
        let low = self.path_limits(js, js.floor);
        let a_hi = (t.a.unsigned_abs() + q).max(low.accel).min(i64::MAX as u64) as i64;
        let v_hi = t.v + (t.a.unsigned_abs() + q) * 1000 / SEGMENTS_PER_SECOND * 2;
        let pass = v_hi / 1000 / SEGMENTS_PER_SECOND + 1;
        let key = (v_hi, a_hi, low);
        let stop = match self.reach {
            Some((k, d)) if k == key => d,
            _ => {
                let d = reach_bound(v_hi, a_hi.unsigned_abs(), low);
                self.reach = Some((key, d));
                d
            }
        };
        let reach = here + pass + stop;
        let mut out = Ahead {
            limits: heapless::Vec::new(),
            accel,
        };
        let hold = self.hold_at;
        let mut end = 0u64;
        let mut floor = u64::MAX;
        let Some(mut b) = planner.head().filter(|b| b.is_line()) else {
            return out;
        };
        let overrides = (planner.feed_override(), planner.rapid_override());
        let cached = self.open_run.filter(|r| r.overrides == overrides);
        // The run being found in this scan (the first one), kept for the next step.
        let mut found: Option<OpenRun> = None;
        let mut k = 0;
        loop {
            // Jump over the run kept from the last step: no limit and no stop in it, so only its
            // length and least acceleration count. Not when it reaches past `reach` or a hold's
            // stop (the scan would have ended inside it, before some of its accelerations).
            let skip = cached.filter(|r| {
                r.first == b.seq
                    && end + r.length <= reach
                    && hold.is_none_or(|h| h > end + r.length)
                    && planner
                        .get(k + r.last.wrapping_sub(r.first) as usize)
                        .map(|x| x.seq)
                        == Some(r.last)
            });
            if let Some(r) = skip {
                end += r.length;
                accel = accel.min(r.accel);
                k += r.last.wrapping_sub(r.first) as usize;
                b = planner.get(k).unwrap_or(b);
                if found.is_none() {
                    found = Some(r);
                }
            } else {
                end += b.length;
            }
            let next = planner
                .get(k + 1)
                .filter(|n| n.is_line() && !n.stop_before && !b.stop_after);
            if let Some(h) = hold {
                if h <= end && floor > 0 {
                    push_limit(
                        &mut out.limits,
                        Limit {
                            at: h,
                            speed: 0,
                            cap: 0,
                        },
                    );
                    floor = 0;
                }
            }
            let (speed_sq, cap) = match next {
                Some(n) => (n.max_entry_sq, u64::from(n.nominal) * 1000),
                None => (0, 0),
            };
            // A junction at the cruise speed of the block before it never binds: the tracker
            // is under that speed in that block, and the block after is no slower (a
            // junction's speed is at most either block's cruise speed, `Planner::max_entry_sq`).
            let nominal = u64::from(b.nominal);
            let open = next.is_some() && speed_sq >= nominal * nominal;
            if open && skip.is_none() && end <= reach {
                // Grow the run found (the first of this scan) while it continues here, within
                // reach (so the next step, as far or farther, may jump it).
                found = match found {
                    None => Some(OpenRun {
                        first: b.seq,
                        last: b.seq,
                        length: b.length,
                        accel: b.accel,
                        least: Some(b.seq),
                        stale: 0,
                        overrides,
                    }),
                    Some(r) if r.last.wrapping_add(1) == b.seq => Some(OpenRun {
                        last: b.seq,
                        length: r.length + b.length,
                        accel: r.accel.min(b.accel),
                        least: if b.accel < r.accel {
                            Some(b.seq)
                        } else {
                            r.least
                        },
                        ..r
                    }),
                    other => other,
                };
            }
            // A staircase of falling speeds, and everything the step may pass.
            let binding = !open && (speed_sq < floor || end <= here + pass);
            if binding && end > here {
                let speed = if speed_sq == 0 {
                    0
                } else {
                    isqrt_u64(speed_sq) * 1000
                };
                push_limit(
                    &mut out.limits,
                    Limit {
                        at: end,
                        speed,
                        cap,
                    },
                );
                floor = floor.min(speed_sq);
            }
            match next {
                Some(n) if end <= reach && floor > 0 => {
                    accel = accel.min(n.accel);
                    b = n;
                    k += 1;
                }
                _ => break,
            }
        }
        self.open_run = found;
        out.accel = accel;
        out
    }

    /// Next segment of the head line block in jerk-limited mode, or `None` when the block
    /// finished or a hold stopped.
    pub(super) fn jerk_segment<const N: usize>(
        &mut self,
        output: OutputEvent,
        planner: &mut Planner<N>,
        js: JerkSetup,
    ) -> Option<Segment> {
        let b = *planner.head()?;
        if !self.active {
            self.start_jerk_block(&b, output);
        }
        if self.state == PrepState::Running {
            self.hold_at = None;
        }
        let len_sub = b.length * SUB;
        loop {
            if self.done >= b.events {
                return self.finish_jerk_block(&b, planner);
            }
            if self.rem_counts == 0 {
                // A new tracker step.
                if self.state == PrepState::Holding && self.hold_at.is_none() {
                    // The stop at the jerk-limited stopping distance, at the limits of the
                    // blocks in reach.
                    let accel = self.ahead(planner, &js).accel;
                    let lim = self.path_limits(&js, accel);
                    let d = brake_distance(self.trk.v, self.trk.a, 0, lim);
                    // u64::MAX: already bound to stop before (the end of the buffer).
                    self.hold_at = (d < u64::MAX).then(|| self.trk.position_nm() + d);
                }
                let ahead = self.ahead(planner, &js);
                let lim = self.path_limits(&js, ahead.accel);
                let cap = planner.nominal(&b) * 1000;
                let a0 = self.trk.a;
                let st = self.trk.step(cap, &ahead.limits, lim);
                // The step's peaks for the block report (host tools; one division a step).
                self.report.accel = self.report.accel.max(st.a.unsigned_abs());
                if st.counts > 0 {
                    let jerk = mul_div(
                        st.a.abs_diff(a0),
                        crate::step::kernel::KERNEL_TIMER_HZ as u64,
                        st.counts,
                    );
                    self.report.jerk = self.report.jerk.max(jerk);
                }
                if st.counts == 0 {
                    // At rest on a stop.
                    if self.trk.position_nm() + crate::motion::jerk::ARRIVED_NM >= b.length
                        && self.hold_at.is_none_or(|h| h >= b.length)
                    {
                        // On the block's end (the end of the buffer): its last steps.
                        self.trk.s = self.trk.s.max(len_sub);
                        self.rem_counts = 0;
                        let left = b.events - self.done;
                        let dt = self.owed_j.max(1);
                        self.owed_j = 0;
                        return Some(self.jerk_emit(&b, b.events, left, dt, 0));
                    }
                    if self.state == PrepState::Holding {
                        self.state = PrepState::Held;
                    }
                    return None;
                }
                self.rem_counts = st.counts;
            }
            // The part of the step inside this block.
            let take_end = self.trk.s.min(len_sub);
            let counts = if self.trk.s <= len_sub {
                self.rem_counts
            } else {
                mul_div(
                    self.rem_counts,
                    take_end - self.p_sub,
                    self.trk.s - self.p_sub,
                )
            };
            self.rem_counts -= counts;
            self.p_sub = take_end;
            let c = if take_end >= len_sub {
                b.events
            } else {
                (mul_div(take_end / SUB, u64::from(b.events), b.length) as u32).min(b.events)
            }
            .max(self.done);
            let dt = counts + self.owed_j;
            let n = c - self.done;
            if n == 0 {
                self.owed_j = dt;
                continue;
            }
            self.owed_j = 0;
            let speed = self.trk.v / 1000;
            return Some(self.jerk_emit(&b, c, n, dt.max(1), speed));
        }
    }

    fn start_jerk_block(&mut self, b: &Block, output: OutputEvent) {
        self.active = true;
        self.done = 0;
        self.s_now = 0;
        self.cum = [0; MAX_AXES];
        self.output = output;
        if let Some(on) = output.thc_switch() {
            self.thc.enabled = on;
            self.output = OutputEvent::NONE;
        }
        if b.stop_before {
            // The tracker comes to rest before a stop; any speed left is dropped with it.
            self.trk.v = 0;
            self.trk.a = 0;
        }
        self.report = BlockReport {
            line: b.line,
            rapid: b.rapid,
            length: b.length,
            entry: self.trk.v / 1000,
            peak: self.trk.v / 1000,
            exit: 0,
            counts: 0,
            accel: 0,
            jerk: 0,
        };
    }

    fn finish_jerk_block<const N: usize>(
        &mut self,
        b: &Block,
        planner: &mut Planner<N>,
    ) -> Option<Segment> {
        let len_sub = b.length * SUB;
        self.trk.s = self.trk.s.saturating_sub(len_sub);
        self.p_sub = self.p_sub.saturating_sub(len_sub);
        self.hold_at = self.hold_at.map(|h| h.saturating_sub(b.length));
        self.open_run = self.open_run.and_then(|r| r.after_pop(b.seq, b.length));
        self.carry = self.trk.v / 1000;
        self.report.exit = self.carry;
        self.finished = Some(self.report);
        self.active = false;
        planner.pop();
        if self.state == PrepState::Holding
            && self.trk.v == 0
            && self.trk.a == 0
            && self.rem_counts == 0
        {
            self.state = PrepState::Held;
        }
        None
    }

    /// Emits the segment to dominant step `c` (`n` steps) lasting `dt` counts.
    fn jerk_emit(&mut self, b: &Block, c: u32, n: u32, dt: u64, speed: u64) -> Segment {
        let level = super::AMASS_PERIODS
            .iter()
            .filter(|&&p| dt > p * n as u64)
            .count() as u32;
        let ticks = n << level;
        let period = crate::arith::div_u64(dt, ticks as u64)
            .max(1)
            .min(u32::MAX as u64) as u32;
        let duration = ticks as u64 * period as u64;
        // What the whole tick periods leave out goes to the next segment.
        self.owed_j += dt.saturating_sub(duration);
        let mut steps = [0u32; MAX_AXES];
        let mut signed = [0i32; MAX_AXES];
        for i in 0..MAX_AXES {
            if b.steps[i] == 0 {
                continue;
            }
            let total = super::cum_at(b, i, c);
            steps[i] = total - self.cum[i];
            self.cum[i] = total;
            signed[i] = if b.dir & (1 << i) != 0 {
                -(steps[i] as i32)
            } else {
                steps[i] as i32
            };
            self.position[i] += i64::from(signed[i]);
        }
        let s = Self::s_of(b, c);
        let power = match self.laser {
            None => KEEP_DUTY,
            Some(map) => map.segment_duty(
                b.laser.scaled(self.laser_override),
                mul_div(
                    s - self.s_now,
                    crate::step::kernel::KERNEL_TIMER_HZ as u64,
                    duration.max(1),
                ),
                b.programmed,
            ),
        };
        self.done = c;
        self.s_now = s;
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
        Segment {
            steps,
            ticks,
            period,
            dir: b.dir,
            output: core::mem::take(&mut self.output),
            power,
        }
    }
}

fn push_limit(v: &mut heapless::Vec<Limit, MAX_LIMITS>, l: Limit) {
    if v.push(l).is_err() {
        // Full: the farthest kept gives way to a nearer, lower one (the list stays a staircase
        // ending at the lowest limit in reach).
        if let Some(last) = v.last_mut() {
            *last = l;
        }
    }
}

/// The tracker's state for a new prep.
pub(super) const REST: Tracker = Tracker { s: 0, v: 0, a: 0 };

#[cfg(test)]
mod tests {
    extern crate std;
    use crate::canon::Canon;
    use crate::gcode::{InterpConfig, Interpreter, MemorySource};
    use crate::motion::config::MotionConfig;
    use crate::motion::sim::{Sim, SimEvent};
    use std::boxed::Box;
    use std::vec::Vec;

    fn canon(program: &str) -> Vec<Canon> {
        let mut interp = Interpreter::new(&InterpConfig::default());
        let mut src = MemorySource::new(program.as_bytes());
        core::iter::from_fn(|| interp.next(&mut src))
            .map(|c| c.unwrap())
            .collect()
    }

    fn config(jerk_mm: u64) -> MotionConfig {
        let mut cfg = MotionConfig::from_setup(&crate::setup::Setup::default());
        for a in cfg.axes.iter_mut() {
            a.jerk = jerk_mm * 1_000_000;
        }
        cfg
    }

    /// (virtual time, step counts per axis signed, steps) of a program stepped.
    fn run(program: &str, jerk_mm: u64) -> (u64, [i64; 3], Vec<(u64, u8, u8)>) {
        let actions = canon(program);
        let mut sim = Box::new(Sim::<128>::new(config(jerk_mm)));
        let mut pos = [0i64; 3];
        let mut steps = Vec::new();
        sim.run(actions.iter().copied(), &mut |e| {
            if let SimEvent::Step(s) = e {
                for i in 0..3 {
                    if s.step & (1 << i) != 0 {
                        pos[i] += if s.dir & (1 << i) != 0 { -1 } else { 1 };
                    }
                }
                steps.push((s.time, s.step, s.dir));
            }
        })
        .unwrap();
        (sim.now, pos, steps)
    }

    #[test]
    fn a_jerk_limited_program_ends_on_its_steps() {
        let program = "G1 X20 F3000\nG1 X20.03 Y0.01\nG1 X20.06 Y0.03\nG1 X30 Y5\nG0 Z-3\nG1 X0 Y0 Z0 F2000\n";
        let (trap, trap_pos, _) = run(program, 0);
        let (jerk, pos, _) = run(program, 5_000);
        assert_eq!(pos, trap_pos);
        std::println!(
            "trapezoid {trap} jerk {jerk} ratio {}",
            jerk as f64 / trap as f64
        );
        assert!(jerk > trap && jerk < trap * 3 / 2);
    }
}

#[cfg(test)]
mod junction_tests {
    use super::tests_support::*;

    #[test]
    fn a_rapid_into_a_slow_plunge_enters_it_under_its_feed_at_the_plunges_limits() {
        // A diagonal rapid (path acceleration 282 mm/s², √2 × the axes') into a Z plunge at
        // 5 in/min (200 mm/s²): the lower limits apply from when the junction is in reach, so
        // the braking for it never has to be forced (a forced step shows as a jerk far over).
        let reports = blocks(
            "G20 G90\nG0 Z0.125\nG0 X0.125 Y0.125\nG1 Z0 F5\nG1 X0.125 Y0\nM2\n",
            5_000,
        );
        assert_eq!(reports.len(), 4);
        for r in &reports {
            if !r.rapid {
                assert!(r.entry <= 2_116_667 && r.peak <= 2_116_667, "{r:?}");
            }
            // At most √2 × 5,000 mm/s³ along the diagonal.
            assert!(r.jerk <= 7_071_068_000 && r.accel <= 282_842_713, "{r:?}");
        }
    }
}

#[cfg(test)]
mod tests_support {
    extern crate std;
    use crate::canon::Canon;
    use crate::gcode::{InterpConfig, Interpreter, MemorySource};
    use crate::motion::config::MotionConfig;
    use crate::motion::prep::BlockReport;
    use crate::motion::sim::{Sim, SimEvent};
    use std::boxed::Box;
    use std::vec::Vec;

    pub fn blocks(program: &str, jerk_mm: u64) -> Vec<BlockReport> {
        let mut interp = Interpreter::new(&InterpConfig::default());
        let mut src = MemorySource::new(program.as_bytes());
        let actions: Vec<Canon> = core::iter::from_fn(|| interp.next(&mut src))
            .map(|c| c.unwrap())
            .collect();
        let mut cfg = MotionConfig::from_setup(&crate::setup::Setup::default());
        for a in cfg.axes.iter_mut() {
            a.jerk = jerk_mm * 1_000_000;
        }
        let mut sim = Box::new(Sim::<128>::new(cfg));
        let mut out = Vec::new();
        sim.run_planned(actions.iter().copied(), &mut |e| {
            if let SimEvent::Block { report, .. } = e {
                out.push(report);
            }
        })
        .unwrap();
        out
    }
}

#[cfg(test)]
mod reach_tests {
    use super::reach_bound;
    use crate::arith::XorShift;
    use crate::motion::jerk::{brake_distance, Limits};

    #[test]
    fn the_scans_reach_is_never_short_of_the_braking_distance() {
        // Speeds up to 2 m/s (pm/s), accelerations to 10 m/s², jerks 50-10^6 mm/s³: the scan
        // must read every limit the tracker could have to brake for.
        let mut rng = XorShift(0xD1B5_4A32_D192_ED03);
        for _ in 0..20_000 {
            let accel = 1_000_000 + rng.next() % 10_000_000_000;
            let jerk = 50_000_000 + rng.next() % 1_000_000_000_000_000;
            let lim = Limits { accel, jerk };
            let v = rng.next() % 2_000_000_000_000;
            let a = rng.next() % (accel + lim.step_accel() + 1);
            let exact = brake_distance(v, a as i64, 0, lim);
            let bound = reach_bound(v, a, lim);
            assert!(bound >= exact, "v {v} a {a} {lim:?}: {bound} < {exact}");
        }
    }
}

//! The step interrupt's body measured and checked on a Cortex-M4 (QEMU `mps2-an386`).
//!
//! The body is the core's (`gantry_machine::step`, machine/src/step/isr.rs), the one the firmware
//! and the emulated board run, compiled here with the firmware's code generation and run over
//! [`FakeHardware`]: its registers are
//! words in RAM read and written exactly like TIM2's and the GPIO's (one `ldr`/`str` to a fixed
//! address each), so the instructions counted are those of the firmware's interrupt.
//!
//! 1. Check: a model of TIM2 and its three DMA streams (`firmware/src/step_dma.rs`) runs the body
//!    through a few thousand periods in which the interrupt starts on time, late, or more than a
//!    period late. Every step the kernel counted must reach the step pins exactly once, on the
//!    dir level it was computed with, with the dir pins unchanged for at least the set-up time
//!    before the edge; the run fails otherwise.
//!    Then the goal rates with 1 µs pulses and dir set-up (1 axis at 500 kHz, 3 axes at 300 kHz,
//!    reversals every third segment, every interrupt on time): no late run, the exact steps, and
//!    every gap between steps exactly `StepTiming::period` ([`check_goal_rate`]).
//! 2. Measure: instructions per step event (one run of the handler) for 1, 3 and 6 axes stepping,
//!    from SysTick under `-icount shift=0,sleep=off` (one instruction per virtual nanosecond;
//!    run it as `bench_motion`, target-tests/README.md), minus the loop and call overhead; then
//!    the step rates at 96 MHz with the interrupt's entry and exit added.
//!
//! With `--features step-window` it also measures the instructions from the handler's entry to
//! its counter read and to its reload write (`StepTiming::ENTRY_COUNTS` / `WRITE_GUARD`).
//!
//! The figures are printed on the last line.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::SYST;
use cortex_m_rt::entry;
use gantry_machine::setup::DriverSetup;
use gantry_machine::step::kernel::{Segment, SegmentSource, StepTiming, KERNEL_TIMER_HZ};
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::step::{PinWords, Run, StepHardware, StepIsr, IDLE_PERIOD_COUNTS};
use gantry_target_tests::clock::{self, now};
use gantry_target_tests::{exit, println};

/// Step pins on bits 10..16 and dir pins on bits 0..6 of their ports, as on a board.
static WORDS: PinWords = PinWords::new(
    &[1 << 10, 1 << 11, 1 << 12, 1 << 13, 1 << 14, 1 << 15],
    &[1 << 0, 1 << 1, 1 << 2, 1 << 3, 1 << 4, 1 << 5],
);

/// The fake registers: TIM2's counter, reload (preload register) and CCR3 (step word), the dir
/// port's BSRR (the last word written), the last user output event, the probe port's input.
static CNT: AtomicU32 = AtomicU32::new(0);
static ARR: AtomicU32 = AtomicU32::new(0);
static STEP_WORD: AtomicU32 = AtomicU32::new(0);
static DIR_BSRR: AtomicU32 = AtomicU32::new(0);
static OUTPUT: AtomicU32 = AtomicU32::new(0);
/// The probe port's input register (IDR); the probe pin is bit 0, high = open.
static PROBE_IDR: AtomicU32 = AtomicU32::new(1);

/// Registers in RAM, reached as the firmware reaches TIM2 and the GPIO ports. With `STAMP`, it
/// also notes SysTick at the counter read and at the reload write (the write-window
/// measurement); without, the notes compile away.
struct FakeHardware<const STAMP: bool = false>;

impl<const STAMP: bool> StepHardware for FakeHardware<STAMP> {
    #[inline(always)]
    fn count(&self) -> u32 {
        if STAMP {
            READ_AT.store(SYST::get_current(), Ordering::Relaxed);
        }
        CNT.load(Ordering::Relaxed)
    }
    #[inline(always)]
    fn reload(&self) -> u32 {
        ARR.load(Ordering::Relaxed)
    }
    #[inline(always)]
    fn set_reload(&mut self, reload: u32) {
        ARR.store(reload, Ordering::Relaxed);
        if STAMP {
            WRITE_AT.store(SYST::get_current(), Ordering::Relaxed);
        }
    }
    #[inline(always)]
    fn write_dir(&mut self, bsrr: u32) {
        DIR_BSRR.store(bsrr, Ordering::Relaxed);
    }
    #[inline(always)]
    fn set_step_word(&mut self, bsrr: u32) {
        STEP_WORD.store(bsrr, Ordering::Relaxed);
    }
    #[inline(always)]
    fn write_output(&mut self, event: OutputEvent) {
        OUTPUT.store(u32::from(event.index() as u8) | 0x100, Ordering::Relaxed);
    }
    #[inline(always)]
    fn write_power(&mut self, duty: u16) {
        OUTPUT.store(u32::from(duty) << 16, Ordering::Relaxed);
    }
    #[inline(always)]
    fn probe_closed(&self) -> bool {
        PROBE_IDR.load(Ordering::Relaxed) & 1 == 0
    }
}

/// A segment source that hands out the same segment for ever (the benchmark).
struct Repeat(Segment);

impl SegmentSource for Repeat {
    fn next_segment(&mut self) -> Option<Segment> {
        Some(self.0)
    }
}

/// The firmware's handler (`firmware/src/step.rs`, `TIM2`) around the body: the flag clear (a
/// register write), the state check, the body, the late count.
#[inline(never)]
fn handler(state: &mut Option<StepIsr<Repeat>>) {
    SR.store(!2, Ordering::Relaxed); // stands for the status flag clear
    let Some(isr) = state.as_mut() else {
        return;
    };
    if isr.on_pulse_end(&WORDS, &mut FakeHardware::<false>, black_box(false)) == Run::Late {
        LATE.store(LATE.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
    }
}

/// The same call shape with an empty body (loop and call overhead).
#[inline(never)]
fn empty_handler(state: &mut Option<StepIsr<Repeat>>) {
    black_box(state);
}

static LATE: AtomicU32 = AtomicU32::new(0);
/// Stands for TIM2's status register.
static SR: AtomicU32 = AtomicU32::new(0);

const RUNS: u32 = 20_000;

/// SysTick counts per handler run × 1000 with a segment stepping `axes` axes.
fn run_cost(axes: usize, body: fn(&mut Option<StepIsr<Repeat>>)) -> u64 {
    let mut steps = [0u32; 6];
    let shares = [1000, 731, 457, 999, 123, 611];
    steps[..axes].copy_from_slice(&shares[..axes]);
    let timing = StepTiming::from_setup(&DriverSetup::DEFAULT);
    let mut state = Some(StepIsr::new(
        Repeat(Segment {
            steps,
            ticks: 1000,
            period: 240,
            dir: 0b101,
            output: OutputEvent::NONE,
            power: gantry_machine::step::kernel::KEEP_DUTY,
        }),
        timing,
    ));
    // Every run finds itself just after the pulse end with the period's time ahead.
    CNT.store(timing.pulse + 3, Ordering::Relaxed);
    ARR.store(239, Ordering::Relaxed);
    LATE.store(0, Ordering::Relaxed);
    let t0 = now();
    for _ in 0..RUNS {
        body(black_box(&mut state));
    }
    let counts = now() - t0;
    if LATE.load(Ordering::Relaxed) != 0 {
        println!("FAIL benchmark runs were late");
        exit(false);
    }
    counts * 1000 / RUNS as u64
}

/// Instructions per SysTick count × 1000, from a loop of known length.
fn calibrate() -> u64 {
    const N: u32 = 200_000;
    let t0 = now();
    let mut i = N;
    while black_box(i) != 0 {
        i -= 1;
    }
    let counts = now() - t0;
    // The loop body: black_box store and load, `subs`, `cmp`, `bne` (as in bench_motion).
    5 * N as u64 * 1000 / counts.max(1)
}

/// SysTick's value when the body read the timer's counter, and when it wrote the reload (its
/// last write before the update): the write-window measurement (`FakeHardware<true>`).
static READ_AT: AtomicU32 = AtomicU32::new(0);
static WRITE_AT: AtomicU32 = AtomicU32::new(0);

#[cfg(feature = "step-window")]
/// [`handler`] over `FakeHardware<true>`.
#[inline(never)]
fn stamped_handler(state: &mut Option<StepIsr<Repeat>>) {
    SR.store(!2, Ordering::Relaxed);
    let Some(isr) = state.as_mut() else {
        return;
    };
    if isr.on_pulse_end(&WORDS, &mut FakeHardware::<true>, black_box(false)) == Run::Late {
        LATE.store(LATE.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
    }
}

#[cfg(feature = "step-window")]
/// The reference: the same call, noting SysTick first thing.
#[inline(never)]
fn stamp_at_entry(state: &mut Option<StepIsr<Repeat>>) {
    READ_AT.store(SYST::get_current(), Ordering::Relaxed);
    WRITE_AT.store(READ_AT.load(Ordering::Relaxed), Ordering::Relaxed);
    black_box(state);
}

#[cfg(feature = "step-window")]
/// Instructions × 10 from the handler's first instruction to the counter read and to the
/// reload write (one-axis segment, no dir change, no output), averaged over many runs: SysTick
/// ticks every 40 instructions, and the runs fall at every phase of it. The stamps add 2-3
/// instructions each to the body.
fn write_window() -> (u64, u64) {
    let timing = StepTiming::from_setup(&DriverSetup::DEFAULT);
    let mut steps = [0u32; 6];
    steps[0] = 1000;
    let mut state = Some(StepIsr::new(
        Repeat(seg(steps, 1000, 240, 0, OutputEvent::NONE)),
        timing,
    ));
    CNT.store(timing.pulse + 3, Ordering::Relaxed);
    ARR.store(239, Ordering::Relaxed);
    let mut sums = [[0u64; 2]; 2];
    for (n, body) in [stamp_at_entry as fn(&mut _), stamped_handler]
        .into_iter()
        .enumerate()
    {
        for _ in 0..RUNS {
            let t0 = SYST::get_current();
            body(black_box(&mut state));
            // SysTick counts down from RELOAD.
            let ticks = |at: u32| {
                u64::from(if at <= t0 {
                    t0 - at
                } else {
                    t0 + gantry_target_tests::clock::RELOAD + 1 - at
                })
            };
            sums[n][0] += ticks(READ_AT.load(Ordering::Relaxed));
            sums[n][1] += ticks(WRITE_AT.load(Ordering::Relaxed));
        }
    }
    let instr_x10 = |i: usize| (sums[1][i] - sums[0][i]) * 40 * 10 / u64::from(RUNS);
    (instr_x10(0), instr_x10(1))
}

/// A queue of segments for the check.
struct Segments<'a>(&'a [Segment], usize);

impl SegmentSource for Segments<'_> {
    fn next_segment(&mut self) -> Option<Segment> {
        let s = self.0.get(self.1).copied();
        self.1 += 1;
        s
    }
}

/// Where the axes end after `segs`, in steps (the kernel's count, signed by each dir bit).
fn end_position(segs: &[Segment]) -> [i64; 6] {
    let mut end = [0i64; 6];
    for s in segs {
        for (axis, e) in end.iter_mut().enumerate() {
            let n = i64::from(s.steps[axis]);
            *e += if s.dir & (1 << axis) != 0 { -n } else { n };
        }
    }
    end
}

/// The registers at power-up: the idle period, the reset word in CCR3, dir and output pins low.
fn power_up() {
    ARR.store(IDLE_PERIOD_COUNTS - 1, Ordering::Relaxed);
    STEP_WORD.store(WORDS.step_reset, Ordering::Relaxed);
    DIR_BSRR.store(0, Ordering::Relaxed);
    OUTPUT.store(0, Ordering::Relaxed);
}

/// A small deterministic generator for interrupt delays.
struct Lcg(u32);

impl Lcg {
    fn next(&mut self) -> u32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        self.0 >> 8
    }
}

/// Runs the body against a model of TIM2 and its DMA streams with interrupts delayed at random;
/// fails unless every counted step reaches the pins once, on the right dir, after the set-up.
fn check_against_timer_model() {
    let timing = StepTiming::from_setup(&DriverSetup::DEFAULT);
    let min = timing.min_period;
    let on = OutputEvent::new(2, true).unwrap();
    let mut rng = Lcg(7);
    // Segments of 1-40 ticks at or near the shortest period, random steps and directions (every
    // segment may reverse axes), one idle segment, the output switched by the second segment.
    let mut segs = [Segment::idle(3, 500); 300];
    for (n, s) in segs.iter_mut().enumerate() {
        if n == 2 {
            continue;
        }
        let ticks = 1 + rng.next() % 40;
        let mut steps = [0u32; 6];
        for st in steps.iter_mut() {
            *st = rng.next() % (ticks + 1);
        }
        // Half of them at the shortest period.
        let period = min + (rng.next() % 2) * (rng.next() % 200);
        let dir = rng.next() as u8 & 63;
        *s = seg(steps, ticks, period, dir, OutputEvent::NONE);
    }
    segs[0].steps[0] = segs[0].ticks;
    segs[0].dir &= !1;
    segs[1].output = on;
    let expected = end_position(&segs);
    let mut state = Some(StepIsr::new(Segments(&segs, 0), timing));
    let isr = state.as_mut().unwrap();
    power_up();
    let mut dir_pins = 0u32; // the dir port's levels
    let mut pins = [0i64; 6];
    let mut t_update = 0u64; // absolute counts of the running period's update
    let mut due: Option<u64> = None; // when the pending interrupt runs
    let mut dir_changed_at = 0u64;
    let mut output_at = None;
    let (mut late, mut scheduled, mut steps) = (0u32, 0u32, 0u32);
    // One interrupt at `t`; returns whether it changed a dir pin and switched an output.
    let mut run = |isr: &mut StepIsr<Segments>, t: u64, t_update: u64, dir_pins: &mut u32| {
        CNT.store((t - t_update) as u32, Ordering::Relaxed);
        DIR_BSRR.store(0, Ordering::Relaxed);
        OUTPUT.store(0, Ordering::Relaxed);
        match isr.on_pulse_end(&WORDS, &mut FakeHardware::<false>, false) {
            Run::Late => late += 1,
            Run::Scheduled => scheduled += 1,
        }
        // The BSRR write as the GPIO applies it.
        let bsrr = DIR_BSRR.load(Ordering::Relaxed);
        let before = *dir_pins;
        *dir_pins = (before | (bsrr & 0xFFFF)) & !(bsrr >> 16);
        (*dir_pins != before, OUTPUT.load(Ordering::Relaxed) != 0)
    };
    for _period in 0..40_000 {
        // The update: the preloaded reload takes effect, the update stream copies CCR3.
        let arr = ARR.load(Ordering::Relaxed);
        let word = STEP_WORD.load(Ordering::Relaxed);
        let dir = dir_pins;
        for (axis, p) in pins.iter_mut().enumerate() {
            if word & (1 << (10 + axis)) != 0 {
                steps += 1;
                if t_update - dir_changed_at < u64::from(timing.dir_setup) {
                    println!(
                        "FAIL dir changed {} counts before a step",
                        t_update - dir_changed_at
                    );
                    exit(false);
                }
                *p += if dir & (1 << axis) != 0 { -1 } else { 1 };
            }
        }
        let t_compare = t_update + u64::from(timing.pulse);
        let t_next = t_update + u64::from(arr) + 1;
        // An interrupt still pending from before runs first (it finds itself too early).
        if let Some(t) = due.filter(|t| *t < t_compare) {
            run(isr, t, t_update, &mut dir_pins);
            due = None;
        }
        // Compare 1 and 2: pulse end, CCR3 cleared, interrupt pending (merged with a pending one).
        STEP_WORD.store(WORDS.step_reset, Ordering::Relaxed);
        if due.is_none() {
            let delay = match rng.next() % 100 {
                0..=79 => 2,
                80..=94 => rng.next() % (arr + 1),
                _ => rng.next() % (3 * (arr + 1)),
            };
            due = Some(t_compare.max(t_update + 1) + u64::from(delay));
        }
        if let Some(t) = due.filter(|t| *t < t_next) {
            let (dir_changed, output) = run(isr, t, t_update, &mut dir_pins);
            if dir_changed {
                dir_changed_at = t;
            }
            if output {
                output_at = Some(pins);
            }
            due = None;
        }
        t_update = t_next;
    }
    let kernel = isr.kernel.position();
    println!(
        "check: {} steps on the pins, {} runs scheduled, {} late (retried); pins {:?}, kernel {:?}",
        steps, scheduled, late, pins, kernel
    );
    if pins != expected || kernel != expected || late == 0 || !isr.idle {
        println!("FAIL pins and kernel must both reach {:?}", expected);
        exit(false);
    }
    // The on-the-fly output switched after the first segment's steps (X steps on every tick),
    // before the second's.
    if output_at.map(|p| p[0]) != Some(i64::from(segs[0].ticks)) {
        println!("FAIL output event at {:?}", output_at);
        exit(false);
    }
}

/// Pulse shape of the goal: 1 µs pulses, 1 µs dir set-up (A4988-class drivers).
const FAST_DRIVERS: DriverSetup = DriverSetup {
    step_pulse_ns: 1_000,
    dir_setup_ns: 1_000,
};

/// The goal rates on the same timer model, with every interrupt on time: its timer read comes
/// [`StepTiming::ENTRY_COUNTS`] after the pulse end (the entry figure the shortest periods are
/// built on) and its dir write [`StepTiming::WRITE_GUARD`] later. Segments of `ticks` ticks at
/// `period` counts step the first `axes` axes on every tick, reversing them every third segment.
/// Fails unless no run is late, every step reaches the pins once on its dir, every dir change
/// leads its step by the set-up, and only the periods before a reversal are stretched, each to
/// exactly as [`StepTiming::period`] says. Returns the steps and the reversals seen.
fn check_goal_rate(axes: usize, period: u32) -> (u32, u32) {
    let timing = StepTiming::from_setup(&FAST_DRIVERS);
    const SEGS: usize = 40;
    const TICKS: u32 = 50;
    let mut segs = [Segment::idle(1, 1); SEGS];
    let mut reversals = 0;
    let mut last_dir = 0u8;
    for (n, s) in segs.iter_mut().enumerate() {
        let mut steps = [0u32; 6];
        steps[..axes].fill(TICKS);
        let dir = if (n / 3) % 2 == 1 { 0b0011_1111 } else { 0 };
        if dir != last_dir {
            reversals += 1;
        }
        last_dir = dir;
        *s = seg(steps, TICKS, period, dir, OutputEvent::NONE);
    }
    let expected = end_position(&segs);
    let mut state = Some(StepIsr::new(Segments(&segs, 0), timing));
    let isr = state.as_mut().unwrap();
    power_up();
    let mut dir_pins = 0u32;
    let mut pins = [0i64; 6];
    let mut t_update = 0u64;
    let mut dir_changed_at = 0u64;
    let mut last_step_at: Option<u64> = None;
    let (mut late, mut steps, mut stretched, mut seen_reversals) = (0u32, 0u32, 0u32, 0u32);
    let mut step_dir = 0u32;
    let total_ticks = SEGS as u32 * TICKS;
    for _period in 0..total_ticks + 10 {
        let arr = ARR.load(Ordering::Relaxed);
        let word = STEP_WORD.load(Ordering::Relaxed);
        let mut stepped = false;
        for (axis, p) in pins.iter_mut().enumerate() {
            if word & (1 << (10 + axis)) != 0 {
                steps += 1;
                stepped = true;
                if t_update - dir_changed_at < u64::from(timing.dir_setup) {
                    println!(
                        "FAIL dir changed {} counts before a step",
                        t_update - dir_changed_at
                    );
                    exit(false);
                }
                *p += if dir_pins & (1 << axis) != 0 { -1 } else { 1 };
            }
        }
        if stepped {
            // The period since the last step: the kernel's, or the turn period before a
            // reversal, nothing else.
            if let Some(t) = last_step_at {
                let gap = t_update - t;
                let turned = dir_pins != step_dir;
                let want = timing.period(period, turned);
                if gap != u64::from(want) {
                    println!(
                        "FAIL {} counts between steps, want {} (reversal: {})",
                        gap, want, turned
                    );
                    exit(false);
                }
                if turned {
                    seen_reversals += 1;
                }
                if gap > u64::from(period) {
                    stretched += 1;
                }
            }
            last_step_at = Some(t_update);
            step_dir = dir_pins;
        }
        // The pulse end, then the interrupt's timer read on time.
        STEP_WORD.store(WORDS.step_reset, Ordering::Relaxed);
        let read = u64::from(timing.pulse + StepTiming::ENTRY_COUNTS);
        CNT.store(read as u32, Ordering::Relaxed);
        DIR_BSRR.store(0, Ordering::Relaxed);
        if isr.on_pulse_end(&WORDS, &mut FakeHardware::<false>, false) == Run::Late {
            late += 1;
        }
        let bsrr = DIR_BSRR.load(Ordering::Relaxed);
        let before = dir_pins;
        dir_pins = (before | (bsrr & 0xFFFF)) & !(bsrr >> 16);
        if dir_pins != before {
            // The latest the dir write lands.
            dir_changed_at = t_update + read + u64::from(StepTiming::WRITE_GUARD);
        }
        t_update += u64::from(arr) + 1;
    }
    let kernel = isr.kernel.position();
    // A reversal's period is stretched only where the turn period is the longer.
    let expect_stretched = if timing.turn_period > period {
        reversals
    } else {
        0
    };
    if late != 0
        || pins != expected
        || kernel != expected
        || steps != total_ticks * axes as u32
        || seen_reversals != reversals
        || stretched != expect_stretched
    {
        println!(
            "FAIL goal rate {} axes: {} late, {} steps, pins {:?}, kernel {:?}, want {:?}, {} reversals ({} stretched)",
            axes, late, steps, pins, kernel, expected, seen_reversals, stretched
        );
        exit(false);
    }
    (steps, seen_reversals)
}

fn seg(steps: [u32; 6], ticks: u32, period: u32, dir: u8, output: OutputEvent) -> Segment {
    Segment {
        steps,
        ticks,
        period,
        dir,
        output,
        power: gantry_machine::step::kernel::KEEP_DUTY,
    }
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap();
    clock::start(&mut cp.SYST);

    check_against_timer_model();
    let fast = StepTiming::from_setup(&FAST_DRIVERS);
    for (axes, khz) in [(1, 500), (3, 300)] {
        let period = KERNEL_TIMER_HZ / 1000 / khz;
        let (steps, reversals) = check_goal_rate(axes, period);
        println!(
            "goal rate: {} axes at {} kHz ({} counts, 1 us pulse and dir set-up): {} steps, {} reversals ({} counts before each), 0 late",
            axes, khz, period, steps, reversals, fast.turn_period
        );
    }

    let ipc = calibrate(); // instructions per count × 1000
    println!(
        "calibration: {}.{:03} instructions per SysTick count",
        ipc / 1000,
        ipc % 1000
    );
    let to_instr = |milli_counts: u64| milli_counts * 40 / 1000;
    let base = to_instr(run_cost(1, empty_handler));
    let i1 = to_instr(run_cost(1, handler)).saturating_sub(base);
    let i3 = to_instr(run_cost(3, handler)).saturating_sub(base);
    let i6 = to_instr(run_cost(6, handler)).saturating_sub(base);
    println!(
        "loop+call overhead: {} instructions per run (subtracted)",
        base
    );
    #[cfg(feature = "step-window")]
    {
        let (to_read, to_write) = write_window();
        println!(
        "write window: {}.{} instructions from the handler's entry to the counter read, {}.{} to the reload write (F411 TIM2: 22 and 35; StepTiming::ENTRY_COUNTS {} + WRITE_GUARD {} counts = {} cycles at 96 MHz with the 12-cycle entry)",
        to_read / 10,
        to_read % 10,
        to_write / 10,
        to_write % 10,
        StepTiming::ENTRY_COUNTS,
        StepTiming::WRITE_GUARD,
        8 * StepTiming::WRITE_WINDOW
    );
    }
    // Exception entry 12 cycles and return 10 (Cortex-M4 with zero-wait-state memory and lazy FP
    // stacking: ARM Cortex-M4 Technical Reference Manual, "Exception model" / interrupt latency),
    // at one instruction per cycle. One run per step event: every axis can step on each.
    const ENTRY_EXIT: u64 = 12 + 10;
    let khz = |instr: u64| 96_000 / (instr + ENTRY_EXIT);
    println!(
        "step interrupt instructions/step event: 1 axis {}, 3 axes {}, 6 axes {}; +{} entry/exit cycles; F411@96MHz ceiling (100% CPU) {} / {} / {} kHz per axis",
        i1, i3, i6, ENTRY_EXIT, khz(i1), khz(i3), khz(i6)
    );
    // For scripts/bench-mcu.sh (emulator/src/cpu_model_f411.rs, firmware/README.md).
    println!(
        "figures step_event_1={} step_event_3={} step_event_6={} step_entry_exit_cycles={}",
        i1, i3, i6, ENTRY_EXIT
    );
    exit(true)
}

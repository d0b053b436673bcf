//! MCU cost of the motion core: instructions per step-kernel tick (1, 3 and 6 axes stepping), per
//! short G1 block (plan + segment prep) and per short G1 line streamed through the interpreter
//! (lex + parse, execute, plan, prepare), read from SysTick on QEMU `mps2-an386`.
//!
//! Run with one virtual nanosecond per instruction:
//! `qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -icount shift=0,sleep=off -semihosting-config
//! enable=on,target=native -nographic -kernel target/thumbv7em-none-eabihf/release/bench_motion`.
//! (`sleep=off`: virtual time never advances with the host clock, only with instructions.)
//! SysTick counts the 25 MHz system clock, so one count is 40 instructions; a calibration loop of
//! known length checks that ratio. The figures are printed on the last line.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use gantry_machine::board::line_ring::RECORD_MAX;
use gantry_machine::board::StreamSource;
use gantry_machine::canon::{Action, Canon};
use gantry_machine::gcode::block::parse_block;
use gantry_machine::gcode::lexer::Lexer;
use gantry_machine::gcode::{InterpConfig, Interpreter};
use gantry_machine::motion::config::MotionConfig;
use gantry_machine::motion::pipeline::{Motion, PushError};
use gantry_machine::step::kernel::{Segment, SegmentSource, StepKernel, TickOut};
use gantry_machine::step::output_event::OutputEvent;
use gantry_target_tests::clock::{self, now, timer_overhead};
use gantry_target_tests::program::{contour_line, program_line, TextLine};
use gantry_target_tests::{exit, println};

/// A segment source that hands out the same segment for ever.
struct Repeat(Segment);

impl SegmentSource for Repeat {
    fn next_segment(&mut self) -> Option<Segment> {
        Some(self.0)
    }
}

/// The step interrupt's body: one kernel tick.
#[inline(never)]
fn isr_body(k: &mut StepKernel, src: &mut Repeat) -> TickOut {
    k.tick(src, false, false)
}

/// An empty body with the same call shape (loop and call overhead).
#[inline(never)]
fn empty_body(_k: &mut StepKernel, src: &mut Repeat) -> TickOut {
    TickOut {
        step: src.0.dir,
        dir: 0,
        period: 1,
        output: OutputEvent::NONE,
        power: gantry_machine::step::kernel::KEEP_DUTY,
    }
}

const TICKS: u32 = 20_000;

/// Counts per tick × 1000 for a segment stepping `axes` axes.
fn tick_cost(axes: usize, body: fn(&mut StepKernel, &mut Repeat) -> TickOut) -> u64 {
    let mut steps = [0u32; 6];
    let shares = [1000, 731, 457, 999, 123, 611];
    steps[..axes].copy_from_slice(&shares[..axes]);
    let mut src = Repeat(Segment {
        steps,
        ticks: 1000,
        period: 240,
        dir: 0b101,
        output: OutputEvent::NONE,
        power: gantry_machine::step::kernel::KEEP_DUTY,
    });
    let mut k = StepKernel::new();
    let t0 = now();
    for _ in 0..TICKS {
        black_box(body(black_box(&mut k), black_box(&mut src)));
    }
    (now() - t0) * 1000 / TICKS as u64
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
    println!("calibration loop: {} iterations in {} counts", N, counts);
    // The loop body: black_box store and load, `subs`, `cmp`, `bne` (see the disassembly).
    let per_iter = 5;
    per_iter * N as u64 * 1000 / counts.max(1)
}

/// Counts per short G1 block × 1000: push (plan) + prepare all its segments, streaming steady state.
/// `blend`: under `G64 P0.01` (chains of these moves merge into chords, machine/src/motion/blend.rs).
fn block_cost(blend: bool) -> (u64, u64) {
    // Merged into chords, the ring's 128 blocks hold 4096 of these moves: past the travel box.
    let cfg = MotionConfig {
        soft_limits: !blend,
        ..MotionConfig::default()
    };
    let mut motion: Motion<128> = Motion::new(cfg);
    if blend {
        let g64 = Action::PathMode(gantry_machine::canon::PathMode::Blend { tolerance: 10_000 });
        if motion
            .push(&Canon {
                line: 0,
                action: g64,
            })
            .is_err()
        {
            exit(false);
        }
    }
    let mut line = 0u32;
    let next_canon = |line: &mut u32| {
        *line += 1;
        // 0.1 mm steps along a gentle zigzag (0.06° corners, like a fine CAM polyline) at F3000.
        let x = *line as i64 * 100_000;
        let y = if (*line).is_multiple_of(2) { 0 } else { 100 };
        Canon {
            line: *line,
            action: Action::Feed {
                to: [x - 100_000_000, y, 0, 0, 0, 0],
                feed: 3_000_000_000,
            },
        }
    };
    // Fill the ring first.
    while motion.push(&next_canon(&mut line)).is_ok() {}
    const BLOCKS: u32 = 2000;
    let mut push_counts = 0u64;
    let t0 = now();
    for _ in 0..BLOCKS {
        let c = next_canon(&mut line);
        loop {
            let p0 = now();
            let r = motion.push(&c);
            push_counts += now() - p0;
            match r {
                Ok(()) => break,
                Err(PushError::Full) => {
                    black_box(motion.next_segment());
                }
                Err(_) => exit(false),
            }
        }
    }
    let total = now() - t0;
    (
        total * 1000 / BLOCKS as u64,
        push_counts * 1000 / BLOCKS as u64,
    )
}

/// Per short G1 line streamed through the board's path (`StreamSource` → `Interpreter::next` →
/// `Motion::push`, segments taken when the ring is full), counts × 1000 per line for: lex +
/// parse alone (`Lexer` + `parse_block` on the same text), the whole `Interpreter::next` (lex,
/// parse and execute), `Motion::push` (plan) and `Motion::next_segment` (prepare).
fn line_cost() -> [u64; 4] {
    let [parse, interpret, plan, prepare, _] =
        line_cost_with(MotionConfig::default(), program_line);
    [parse, interpret, plan, prepare]
}

/// [`line_cost`] on machine `cfg`, and last the prepare counts × 1000 per segment.
fn line_cost_with(cfg: MotionConfig, program_line: fn(u32) -> TextLine) -> [u64; 5] {
    // Fewer lines when profiling: every instruction is logged then.
    const LINES: u32 = if cfg!(feature = "profile-lines") {
        200
    } else {
        2000
    };
    let overhead = timer_overhead();
    let config = InterpConfig::default();
    // Lex + parse on their own.
    let mut parse = 0u64;
    for i in 0..LINES {
        let l = program_line(i);
        let p0 = now();
        let mut lexer = Lexer::new(black_box(l.as_bytes()), true);
        lexer.start();
        let b = parse_block(&mut lexer, &config);
        black_box(&b);
        parse += now() - p0;
        if b.is_err() {
            exit(false);
        }
    }
    let mut interp = Interpreter::new(&config);
    // Room for one line at a time (it is pushed, then interpreted).
    let mut source: StreamSource<{ 2 * RECORD_MAX }> = StreamSource::new();
    let mut motion: Motion<128> = Motion::new(cfg);
    // Counts and timed calls per stage: interpret, plan, prepare.
    let mut sums = [(0u64, 0u64); 3];
    let mut line = 0u32;
    let mut run = |line: &mut u32, sums: &mut [(u64, u64); 3]| {
        *line += 1;
        let text = program_line(*line);
        if !source.push(0, *line, text.as_str()) {
            exit(false);
        }
        let p0 = now();
        let next = interp.next(&mut source);
        sums[0].0 += now() - p0;
        sums[0].1 += 1;
        let Some(Ok(canon)) = next else {
            exit(false);
        };
        loop {
            let p0 = now();
            let r = motion.push(&canon);
            sums[1].0 += now() - p0;
            sums[1].1 += 1;
            match r {
                Ok(()) => return,
                Err(PushError::Full) => {
                    let p0 = now();
                    black_box(motion.next_segment());
                    sums[2].0 += now() - p0;
                    sums[2].1 += 1;
                }
                Err(_) => exit(false),
            }
        }
    };
    // Fill the ring first.
    for _ in 0..200 {
        run(&mut line, &mut sums);
    }
    let mut sums = [(0u64, 0u64); 3];
    for _ in 0..LINES {
        run(&mut line, &mut sums);
    }
    let per_line = |(counts, calls): (u64, u64)| {
        (counts * 1000).saturating_sub(calls * overhead) / LINES as u64
    };
    let (counts, calls) = sums[2];
    [
        per_line((parse, LINES as u64)),
        per_line(sums[0]),
        per_line(sums[1]),
        per_line(sums[2]),
        (counts * 1000).saturating_sub(calls * overhead) / calls.max(1),
    ]
}

/// Instructions per call of a few core helpers (for finding where block time goes).
fn helper_costs() {
    use gantry_machine::arith::{isqrt_u64, mul_div};
    use gantry_machine::motion::profile::Profile;
    const N: u64 = 1000;
    let t0 = now();
    let mut acc = 0u64;
    for i in 0..N {
        acc = acc.wrapping_add(isqrt_u64(black_box(2_500_000_000_000_000 + i * 7919)));
    }
    let sqrt = (now() - t0) * 40 / N;
    let t0 = now();
    for i in 0..N {
        acc = acc.wrapping_add(mul_div(
            black_box(50_000_000 + i),
            24_000_000,
            black_box(200_000_000),
        ));
    }
    let md = (now() - t0) * 40 / N;
    let t0 = now();
    for i in 0..N {
        let p = Profile::plan(
            0,
            black_box(40_000_000 + i),
            100_000,
            50_000_000,
            1_600_000_000_000_000,
            200_000_000,
        );
        acc = acc.wrapping_add(p.time_at(black_box(50_000)));
    }
    let plan = (now() - t0) * 40 / N;
    // One braking distance as the jerk-limited tracker's probes ask for it: from 35 mm/s and a
    // small acceleration to rest at 200 mm/s², 5,000 mm/s³ (motion/jerk.rs).
    let lim = gantry_machine::motion::jerk::Limits {
        accel: 200_000_000,
        jerk: 5_000_000_000_000,
    };
    let t0 = now();
    for i in 0..N {
        acc = acc.wrapping_add(gantry_machine::motion::jerk::brake_distance(
            black_box(35_000_000_000 + i * 1_000),
            black_box(1_000_000),
            0,
            lim,
        ));
    }
    let brake = (now() - t0) * 40 / N;
    black_box(acc);
    println!(
        "helpers: isqrt_u64 {} instr, mul_div {} instr, Profile::plan + time_at {} instr, jerk brake_distance {} instr",
        sqrt, md, plan, brake
    );
}

#[entry]
fn main() -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap();
    clock::start(&mut cp.SYST);

    let ipc = calibrate(); // instructions per count × 1000
    println!(
        "calibration: {}.{:03} instructions per SysTick count",
        ipc / 1000,
        ipc % 1000
    );
    let to_instr = |milli_counts: u64| milli_counts * 40 / 1000;
    if cfg!(feature = "profile-lines") {
        let [parse, interpret, plan, prepare] = line_cost().map(to_instr);
        println!("lines: parse {parse} interpret {interpret} plan {plan} prepare {prepare}");
        exit(true);
    }
    let base = to_instr(tick_cost(1, empty_body));
    let t1 = to_instr(tick_cost(1, isr_body)).saturating_sub(base);
    let t3 = to_instr(tick_cost(3, isr_body)).saturating_sub(base);
    let t6 = to_instr(tick_cost(6, isr_body)).saturating_sub(base);
    println!(
        "loop+call overhead: {} instructions per tick (subtracted)",
        base
    );
    helper_costs();
    let (blended, blended_push) = block_cost(true);
    let (blended, blended_push) = (to_instr(blended), to_instr(blended_push));
    println!(
        "short G1 block under G64 P0.01: {} instructions (plan {})",
        blended, blended_push
    );
    let [parse, interpret, plan, prepare] = line_cost().map(to_instr);
    println!(
        "short G1 line (G1 X-99.893 Y-6.789 F3000 style): lex+parse {}, execute {}, interpret total {}, plan {}, prepare {}; line total {} instructions",
        parse,
        interpret.saturating_sub(parse),
        interpret,
        plan,
        prepare,
        interpret + plan + prepare
    );
    // Jerk-limited (5,000 mm/s³ on every axis) against the trapezoid, same lines.
    let mut jerk_cfg = MotionConfig::default();
    for a in jerk_cfg.axes.iter_mut() {
        a.jerk = 5_000_000_000;
    }
    let [_, _, _, trap_line, trap_seg] =
        line_cost_with(MotionConfig::default(), program_line).map(to_instr);
    let [_, _, _, jerk_line, jerk_seg] = line_cost_with(jerk_cfg, program_line).map(to_instr);
    println!(
        "segment prep per line / per segment: trapezoid {} / {}, jerk-limited {} / {} instructions",
        trap_line, trap_seg, jerk_line, jerk_seg
    );
    // The same on a contour the look-ahead bounds (0.03 mm chords): the jerk-limited tracker
    // brakes for the end of the buffer every step.
    let [_, _, _, trap_c_line, trap_c_seg] =
        line_cost_with(MotionConfig::default(), contour_line).map(to_instr);
    let [_, _, _, jerk_c_line, jerk_c_seg] = line_cost_with(jerk_cfg, contour_line).map(to_instr);
    println!(
        "0.03 mm contour, segment prep per line / per segment: trapezoid {} / {}, jerk-limited {} / {} instructions",
        trap_c_line, trap_c_seg, jerk_c_line, jerk_c_seg
    );
    let (block, push) = block_cost(false);
    let (block, push) = (to_instr(block), to_instr(push));
    println!(
        "short G1 block: {} instructions (plan {}); RAM: Motion<128> {} bytes, StepKernel {} bytes",
        block,
        push,
        core::mem::size_of::<Motion<128>>(),
        core::mem::size_of::<StepKernel>()
    );
    // F411 at 96 MHz: ISR = tick + 12 entry + 10 exit + ~8 for the GPIO/timer writes, CPI ≈ 1.
    let isr = t3 + 30;
    let rate_khz = 96_000 / isr;
    println!(
        "kernel instructions/tick: 1 axis {}, 3 axes {}, 6 axes {}; block {}; F411@96MHz 3-axis tick ceiling {} kHz (100% CPU, {} cycles/ISR), {} kHz at 25% CPU",
        t1, t3, t6, block, rate_khz, isr, rate_khz / 4
    );
    // For scripts/bench-mcu.sh (emulator/src/cpu_model_f411.rs, firmware/README.md).
    println!(
        "figures interpret_line={} plan_block={} prepare_segment={} prepare_jerk_segment={} kernel_tick_1={} kernel_tick_3={} kernel_tick_6={}",
        interpret, plan, prepare, jerk_seg, t1, t3, t6
    );
    exit(true)
}

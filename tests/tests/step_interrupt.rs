//! The step interrupt written once (machine/src/step/): the emulated board's timer
//! (emulator/src/step_clock.rs) and a register-level stand-in for the firmware's TIM2 and DMA
//! streams (the registers as memory words, as target-tests/src/bin/bench_step.rs has them, with
//! another pin map) run the same scenario — moves with idle gaps between them, a probe move that
//! trips the probe latch, a move into a limit switch — and must put out the same step edges at
//! the same timer counts. The emulated board's start-up timing (the 1 ms idle poll and the two
//! kernel ticks ahead of the pins) is tested with the other step timing, tests/tests/step_timing.rs.

use gantry_emulator::step_clock::{ClockEvent, StepClock};
use gantry_machine::motion::sim::SegmentFifo;
use gantry_machine::setup::DriverSetup;
use gantry_machine::step::kernel::{ProbeLatch, Segment, StepTiming};
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::step::{PinWords, Run, StepHardware, StepIsr, IDLE_PERIOD_COUNTS, TICKS_AHEAD};

/// 1 µs pulses and dir set-up: short periods, so the set-up shows in the timing.
const FAST: DriverSetup = DriverSetup {
    step_pulse_ns: 1_000,
    dir_setup_ns: 1_000,
};

fn seg(x_steps: u32, ticks: u32, period: u32, dir: u8) -> Segment {
    Segment {
        steps: [x_steps, x_steps / 2, 0, 0, 0, 0],
        ticks,
        period,
        dir,
        output: OutputEvent::NONE,
        power: gantry_machine::step::kernel::KEEP_DUTY,
    }
}

/// The machine around the pins: X and Y positions from the step edges, a probe that closes at X
/// 130 and a limit switch at X 240 (steps).
#[derive(Clone, Copy, Debug, Default)]
struct World {
    pos: [i64; 2],
}

impl World {
    const PROBE_AT: i64 = 130;
    const LIMIT_AT: i64 = 240;

    fn step(&mut self, step: u8, dir: u8) {
        for axis in 0..2 {
            if step >> axis & 1 != 0 {
                self.pos[axis] += if dir >> axis & 1 != 0 { -1 } else { 1 };
            }
        }
    }

    fn probe(&self) -> bool {
        self.pos[0] >= Self::PROBE_AT
    }

    fn limit(&self) -> bool {
        self.pos[0] >= Self::LIMIT_AT
    }
}

/// When the main loop queues what: the scenario both timers run.
enum Action {
    Push(Segment),
    ArmProbe,
}

/// X out 100 steps and back 40 (a reversal), a gap, the probe move (armed first) out through
/// the probe, another gap, then a move into the limit switch (stopped two steps past it).
fn scenario() -> Vec<(u64, Action)> {
    vec![
        (3_000, Action::Push(seg(100, 100, 40, 0b00))),
        (3_000, Action::Push(seg(40, 40, 60, 0b11))),
        (50_000, Action::ArmProbe),
        (50_000, Action::Push(seg(120, 240, 30, 0b00))),
        (100_000, Action::Push(seg(200, 200, 50, 0b00))),
    ]
}

/// What a run put out: every step edge (timer count, step byte, dir byte), the kernel's end
/// position and probe latch, and the late runs.
#[derive(Debug, PartialEq, Eq)]
struct Outcome {
    edges: Vec<(u64, u8, u8)>,
    kernel: [i64; 6],
    latch: ProbeLatch,
    world: [i64; 2],
    late: u32,
}

const END: u64 = 180_000;

/// The emulated board's timer ([`StepClock`]) and pins.
fn run_emulated_timer() -> Outcome {
    let timing = StepTiming::from_setup(&FAST);
    let mut isr = StepIsr::new(SegmentFifo::<15>::default(), timing);
    let mut clock = StepClock::start(0, &timing);
    let mut world = World::default();
    let mut edges = Vec::new();
    let mut actions = scenario().into_iter().peekable();
    loop {
        let now = clock.next_event();
        while let Some((_, a)) = actions.next_if(|(at, _)| *at <= now) {
            match a {
                Action::Push(s) => isr.source.0.push_back(s).unwrap(),
                Action::ArmProbe => isr.arm_probe(Some(true)),
            }
        }
        if now > END {
            break;
        }
        clock.regs.probe = world.probe();
        if let ClockEvent::Update { step, .. } = clock.advance(now, &mut isr, world.limit()) {
            if step != 0 {
                world.step(step, clock.regs.dir_pins);
                edges.push((now, step, clock.regs.dir_pins));
            }
        }
    }
    Outcome {
        edges,
        kernel: isr.kernel.position(),
        latch: isr.kernel.probe_latch(),
        world: world.pos,
        late: clock.late,
    }
}

/// Step pins on bits 10..16 of their port and dir pins on bits 4..10 of theirs; the probe on
/// bit 3 of its input register, active low (open = high).
static WORDS: PinWords = PinWords::new(
    &[1 << 10, 1 << 11, 1 << 12, 1 << 13, 1 << 14, 1 << 15],
    &[1 << 4, 1 << 5, 1 << 6, 1 << 7, 1 << 8, 1 << 9],
);
const PROBE_PIN: u32 = 1 << 3;

/// TIM2's counter, auto-reload and CCR3, the dir port's output register (written through its
/// BSRR), the user output port and the probe port's input register, as plain words.
#[derive(Default)]
struct Registers {
    cnt: u32,
    arr: u32,
    ccr3: u32,
    dir_odr: u32,
    out_odr: u32,
    probe_idr: u32,
}

impl StepHardware for Registers {
    fn count(&self) -> u32 {
        self.cnt
    }
    fn reload(&self) -> u32 {
        self.arr
    }
    fn set_reload(&mut self, reload: u32) {
        self.arr = reload;
    }
    fn write_dir(&mut self, bsrr: u32) {
        self.dir_odr = (self.dir_odr | (bsrr & 0xFFFF)) & !(bsrr >> 16);
    }
    fn set_step_word(&mut self, bsrr: u32) {
        self.ccr3 = bsrr;
    }
    fn write_output(&mut self, event: OutputEvent) {
        self.out_odr = event.apply(self.out_odr as u16).into();
    }
    fn write_power(&mut self, _duty: u16) {}
    fn probe_closed(&self) -> bool {
        self.probe_idr & PROBE_PIN == 0
    }
}

/// The register stand-in with its own timer model: each period starts with an update (ARR's
/// preload takes effect, the update DMA copies CCR3 to the step port), then at `pulse` the
/// compare DMA resets CCR3 and the interrupt runs `ENTRY_COUNTS` later.
fn run_registers() -> Outcome {
    let timing = StepTiming::from_setup(&FAST);
    let mut isr = StepIsr::new(SegmentFifo::<15>::default(), timing);
    let mut regs = Registers {
        arr: IDLE_PERIOD_COUNTS - 1,
        ccr3: WORDS.step_reset,
        probe_idr: PROBE_PIN,
        ..Registers::default()
    };
    let mut world = World::default();
    let mut edges = Vec::new();
    let mut actions = scenario().into_iter().peekable();
    let mut late = 0;
    // The timer starts at 0 with the idle period loaded and nothing to copy.
    let mut update = 0u64;
    let mut first = true;
    while update <= END {
        let period = regs.arr + 1;
        if !first {
            let word = regs.ccr3;
            if word & 0xFFFF != 0 {
                // Step bits back to axis order, dir pins likewise.
                let step = (word >> 10 & 0x3F) as u8;
                let dir = (regs.dir_odr >> 4 & 0x3F) as u8;
                world.step(step, dir);
                edges.push((update, step, dir));
            }
        }
        first = false;
        regs.ccr3 = WORDS.step_reset;
        let isr_at = update + u64::from(timing.pulse + StepTiming::ENTRY_COUNTS);
        while let Some((_, a)) = actions.next_if(|(at, _)| *at <= isr_at) {
            match a {
                Action::Push(s) => isr.source.0.push_back(s).unwrap(),
                Action::ArmProbe => isr.arm_probe(Some(true)),
            }
        }
        regs.cnt = (isr_at - update) as u32;
        regs.probe_idr = if world.probe() { 0 } else { PROBE_PIN };
        if isr.on_pulse_end(&WORDS, &mut regs, world.limit()) == Run::Late {
            late += 1;
        }
        update += u64::from(period);
    }
    Outcome {
        edges,
        kernel: isr.kernel.position(),
        latch: isr.kernel.probe_latch(),
        world: world.pos,
        late,
    }
}

#[test]
fn the_emulated_timer_and_the_register_model_put_out_the_same_steps_at_the_same_counts() {
    let emulated = run_emulated_timer();
    let registers = run_registers();
    assert_eq!(emulated, registers);
    let o = emulated;
    let timing = StepTiming::from_setup(&FAST);
    // Every step of the first two moves and of the probe move, then the limit: the switch at X
    // 240 stopped the kernel with the two ticks it had prepared still going out.
    let x_steps = o.edges.iter().filter(|e| e.1 & 1 != 0).count() as i64;
    assert_eq!(
        x_steps,
        100 + 40 + 120 + (240 - 180) + i64::from(TICKS_AHEAD)
    );
    assert_eq!(o.world[0], World::LIMIT_AT + i64::from(TICKS_AHEAD));
    assert_eq!(o.kernel[0], o.world[0]);
    assert_eq!(o.kernel[1], o.world[1]);
    assert_eq!(o.late, 0);
    // Each move starts from idle: the poll after it was queued (every 1 ms from 0, at the pulse
    // end plus the entry) finds it; the rest of that period, the 1 ms period set by the poll
    // before, the turn period set by this one, then the step.
    let poll = u64::from(timing.pulse + StepTiming::ENTRY_COUNTS);
    let idle = u64::from(IDLE_PERIOD_COUNTS);
    let first_after = |t: u64| o.edges.iter().find(|e| e.0 > t).unwrap().0;
    // The polls run every 1 ms from 0 until the first move: exactly.
    let queued = 3_000;
    let found_at = (queued - poll).div_ceil(idle) * idle;
    let turn = u64::from(timing.turn_period);
    assert_eq!(first_after(queued), found_at + 2 * idle + turn);
    // After a move they run every 1 ms from its last period: the poll comes within 1 ms.
    for queued in [50_000, 100_000] {
        let wait = first_after(queued) - queued;
        assert!(
            2 * idle + turn - poll < wait && wait <= 3 * idle + turn - poll,
            "the first step {wait} counts after the move queued at {queued}"
        );
    }
    // The reversal after 100 steps at 40 counts holds the turn period before the first step
    // back (X and Y both reverse).
    let back = o.edges.iter().position(|e| e.2 == 0b11).unwrap();
    assert_eq!(back, 100);
    assert_eq!(
        o.edges[back].0 - o.edges[back - 1].0,
        u64::from(timing.period(40, true))
    );
    // The probe closed at X 130 (the pins); the kernel's next tick latched its own count: the
    // contact plus the ticks it had computed ahead (one step every second tick of that move).
    let ProbeLatch::Tripped { steps } = o.latch else {
        panic!("the probe latch did not trip: {:?}", o.latch);
    };
    assert_eq!(steps[0], World::PROBE_AT + 1);
}

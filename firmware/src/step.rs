//! Step timer: TIM2 (32-bit) at NVIC priority P0 runs the core's step kernel once per tick.
//!
//! The update interrupt starts a tick: it raises the step pins computed on the previous tick (one
//! BSRR write), runs `StepKernel::tick`, and loads the kernel's period into the preloaded ARR, so it
//! times the period after the step just emitted. It also points compare channel 1 at the setup's
//! pulse width ([`StepTiming::pulse`], from `Setup::drivers`) after the moment the pins rose; that
//! interrupt drops the step pins (one BSRR write) and sets the dir pins for the next step (one BSRR
//! write), so a direction changes a full period minus the pulse before the step that needs it.
//! Periods shorter than [`StepTiming::min_period`] (pulse + the longer of pulse and dir set-up)
//! are stretched to it, so that is at least the setup's dir set-up time; `Setup::is_valid` refuses
//! axes whose max rate would need such periods. Pin words come from 64-entry tables built at
//! compile time from the board's pin numbers, so the ISR does lookups, no loops.
//!
//! On-the-fly outputs: a segment's [`OutputEvent`] comes out of the tick that starts the segment
//! and is emitted with that tick's steps, at the next update: one BSRR write of the user output's
//! port (port and pin mask from a table built at compile time from the board's user output pins),
//! just before the step pins rise. [`sync_user_outputs`] is the only other writer of those pins.
//!
//! If the ISR starts so late that the pulse and the dir set-up could not both fit before the next
//! update, it emits nothing and retries on the next update (counted in [`LATE_TICKS`]), so no edge
//! is ever lost and no step follows a direction change sooner than the setup allows.
//! A stop seen by the kernel takes effect at that tick; the step computed on the tick before is
//! still emitted, so the kernel's position count stays exact. When the kernel is idle the timer
//! keeps polling the queue every millisecond.

use crate::board::{gpio_block, PinId};
use crate::board_def::{AXES, DIR, PROBE, STEP, USER_OUTPUTS, USER_PINS};
use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::pac;
use embassy_stm32::pac::timer::regs::SrGp16;
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Peri;
use gantry_machine::board::main_loop::KernelSnapshot;
use gantry_machine::motion::kernel::{
    ProbeLatch, Segment, SegmentSource, StepKernel, StepTiming, TickOut, KERNEL_TIMER_HZ,
};
use gantry_machine::motion::output_event::OutputEvent;
use gantry_machine::units::MAX_AXES;
use heapless::spsc::{Consumer, Producer, Queue};
use static_cell::StaticCell;

/// Tick period while the kernel is idle (1 ms), i.e. how often an empty queue is polled.
pub const IDLE_PERIOD_COUNTS: u32 = KERNEL_TIMER_HZ / 1_000;
/// Slots in the segment queue: the core's one figure (`gantry_machine::board::main_loop`), so the
/// emulated board queues exactly as many segments. heapless 0.9's SPSC queue holds N - 1: 15
/// segments of about 2 ms, 30 ms of motion ahead of the kernel, every one of which a stop can
/// take back ([`drop_newest`]).
pub const SEGMENT_QUEUE_LEN: usize = gantry_machine::board::main_loop::SEGMENT_QUEUE_SLOTS;

/// An armed limit switch is active: set by the input task (EXTI, microseconds after the edge) and
/// the main loop, cleared only by the main loop when it re-arms the kernel. The kernel latches
/// it on its next tick.
pub static STOP: AtomicBool = AtomicBool::new(false);
/// Ticks deferred because the ISR started too late to fit the step pulse (should stay 0).
pub static LATE_TICKS: AtomicU32 = AtomicU32::new(0);

/// BSRR word raising the step pins of each 6-bit step mask.
static STEP_SET: [u32; 64] = step_set_table(&STEP);
/// BSRR word dropping every step pin.
const STEP_RESET: u32 = mask(&STEP) << 16;
/// BSRR word setting every dir pin for each 6-bit dir mask (bit set = negative = pin high).
static DIR_WORD: [u32; 64] = dir_table(&DIR);
/// Port and pin mask of each user output (16 slots; outputs the board does not have have mask 0,
/// so switching them changes no pin).
const USER_GPIO: [pac::gpio::Gpio; 16] = output_ports(&USER_PINS);
static USER_MASK: [u16; 16] = output_masks(&USER_PINS);

const _: () = {
    assert!(
        STEP_SET[0] == 0 && STEP_SET[63] == mask(&STEP),
        "step table covers the step pins"
    );
    assert!(
        DIR_WORD[0] == mask(&DIR) << 16 && DIR_WORD[63] == mask(&DIR),
        "dir table"
    );
};

const STEP_GPIO: pac::gpio::Gpio = gpio_block(STEP[0].port);
/// The touch probe's port: the kernel gets its raw level every tick (bit set = pin low = closed,
/// as `inputs::PINS`), for its probe latch.
const PROBE_GPIO: pac::gpio::Gpio = gpio_block(PROBE.port);
const PROBE_MASK: u32 = PROBE.mask();
const DIR_GPIO: pac::gpio::Gpio = gpio_block(DIR[0].port);
const TIM: pac::timer::TimGp32 = pac::TIM2;

const fn mask(pins: &[PinId]) -> u32 {
    let mut m = 0;
    let mut i = 0;
    while i < pins.len() {
        m |= pins[i].mask();
        i += 1;
    }
    m
}

const fn step_set_table(pins: &[PinId; AXES]) -> [u32; 64] {
    let mut t = [0u32; 64];
    let mut bits = 0;
    while bits < 64 {
        let mut axis = 0;
        while axis < AXES {
            if bits & (1 << axis) != 0 {
                t[bits] |= pins[axis].mask();
            }
            axis += 1;
        }
        bits += 1;
    }
    t
}

const fn dir_table(pins: &[PinId; AXES]) -> [u32; 64] {
    let mut t = [0u32; 64];
    let mut bits = 0;
    while bits < 64 {
        let mut axis = 0;
        while axis < AXES {
            t[bits] |= if bits & (1 << axis) != 0 {
                pins[axis].mask()
            } else {
                pins[axis].mask() << 16
            };
            axis += 1;
        }
        bits += 1;
    }
    t
}

const fn output_ports(pins: &[PinId; USER_OUTPUTS]) -> [pac::gpio::Gpio; 16] {
    let mut t = [pac::GPIOA; 16];
    let mut n = 0;
    while n < USER_OUTPUTS {
        t[n] = gpio_block(pins[n].port);
        n += 1;
    }
    t
}

const fn output_masks(pins: &[PinId; USER_OUTPUTS]) -> [u16; 16] {
    let mut t = [0u16; 16];
    let mut n = 0;
    while n < USER_OUTPUTS {
        t[n] = pins[n].mask() as u16;
        n += 1;
    }
    t
}

/// Switches one user output pin (one BSRR write: the set half or the reset half of the word).
#[inline(always)]
fn write_output(event: OutputEvent) {
    let n = event.index();
    let mask = u32::from(USER_MASK[n]);
    let word = if event.level() { mask } else { mask << 16 };
    USER_GPIO[n].bsrr().write_value(pac::gpio::regs::Bsrr(word));
}

/// The ISR's end of the segment queue, as the kernel's segment source.
pub struct QueueSource(Consumer<'static, Segment>);

impl SegmentSource for QueueSource {
    #[inline(always)]
    fn next_segment(&mut self) -> Option<Segment> {
        self.0.dequeue()
    }
}

/// Everything the ISR owns.
struct StepIsr {
    kernel: StepKernel,
    source: QueueSource,
    /// Output of the previous tick, emitted at the next update.
    pending: TickOut,
    /// The last tick found no segment (period 0): the kernel waits for the queue.
    idle: bool,
    /// Pulse width, dir set-up and shortest period, from the setup.
    timing: StepTiming,
}

/// The ISR's state, shared with the main loop.
///
/// Access protocol (what makes the `unsafe` below sound): the TIM2 handler is the only interrupt
/// that touches the cell, and nothing can preempt it that touches it (TIM2 alone runs at P0;
/// NMI and faults don't). Every other access goes through [`with_kernel`], which holds a critical
/// section (PRIMASK: TIM2 cannot run meanwhile) and is never nested (the closures below don't
/// call it). So at most one `&mut` to the state exists at any time.
struct Shared(UnsafeCell<Option<StepIsr>>);

// SAFETY: see the access protocol above; the cell is only reached under it.
unsafe impl Sync for Shared {}

static SHARED: Shared = Shared(UnsafeCell::new(None));

/// Runs `f` on the ISR's state inside a critical section (TIM2 masked for its duration: keep
/// `f` to a few dozen instructions, it delays the next step edge by as much). `None` before
/// [`start`].
fn with_kernel<R>(f: impl FnOnce(&mut StepIsr) -> R) -> Option<R> {
    critical_section::with(|_cs| {
        // SAFETY: interrupts are masked, so the TIM2 handler is not running and cannot start;
        // this is the only other access path and it is not re-entered (see `Shared`).
        let state = unsafe { &mut *SHARED.0.get() };
        state.as_mut().map(f)
    })
}

/// Reads the kernel's position and state.
pub fn snapshot() -> KernelSnapshot {
    with_kernel(|s| KernelSnapshot {
        steps: s.kernel.position(),
        drained: s.idle && !s.kernel.is_busy() && !s.source.0.ready(),
        stopped: s.kernel.is_stopped(),
    })
    .unwrap_or(KernelSnapshot {
        steps: [0; MAX_AXES],
        drained: true,
        stopped: false,
    })
}

/// After a latched stop: drops every queued segment and the running one (the position keeps the
/// steps made). The kernel stays stopped until [`rearm`].
pub fn flush() {
    with_kernel(|s| {
        while s.source.0.dequeue().is_some() {}
        s.kernel.flush();
    });
}

/// Removes up to `max` of the *newest* queued segments the kernel has not started (a stop or a
/// speed change re-plans from the end of the running segment, `Board::drop_queued`); returns how
/// many it removed. The running segment and the older queued ones stay, in order.
///
/// Inside one critical section (TIM2 masked) so the ISR cannot take a segment between counting
/// and removing: the SPSC consumer only pops the oldest, so the `keep` oldest are rotated to the
/// back through the producer (both ends are ours while TIM2 is masked) and the rest popped. At
/// most 15 moves of a 36-byte segment, a few microseconds; normally `keep` is 0 (every queued
/// segment can be taken back) and only the pops remain.
pub fn drop_newest(max: usize, producer: &mut Producer<'static, Segment>) -> usize {
    with_kernel(|s| {
        let queued = s.source.0.len();
        let drop = max.min(queued);
        for _ in drop..queued {
            if let Some(seg) = s.source.0.dequeue() {
                // Cannot fail: one slot was just freed.
                let _ = producer.enqueue(seg);
            }
        }
        for _ in 0..drop {
            s.source.0.dequeue();
        }
        drop
    })
    .unwrap_or(0)
}

/// Re-arms a stopped kernel (after [`flush`] and the board's `limit_stop`).
pub fn rearm() {
    with_kernel(|s| s.kernel.clear_stop());
}

/// Exchanges the user output word between the board and the kernel (`Board::sync_user_outputs`):
/// `f` gets the kernel's word (the pins, with every on-the-fly event fired so far) and returns a
/// word to load, if the board switched outputs itself. That word goes into the kernel and onto
/// the pins inside the same critical section, so no event can fire in between, and an event
/// computed but not yet emitted is dropped with it.
pub fn sync_user_outputs(f: impl FnOnce(u16) -> Option<u16>) {
    with_kernel(|s| {
        let Some(word) = f(s.kernel.outputs()) else {
            return;
        };
        s.kernel.set_outputs(word);
        s.pending.output = OutputEvent::NONE;
        for n in 0..USER_OUTPUTS as u8 {
            if let Some(e) = OutputEvent::new(n, word >> n & 1 != 0) {
                write_output(e);
            }
        }
    });
}

/// Arms the kernel's probe latch for the raw probe level `trips_at` (`None`: off, forgetting a
/// latched position); an armed or tripped latch for the same level is left alone
/// (`BoardPort::arm_probe`).
pub fn arm_probe(trips_at: Option<bool>) {
    with_kernel(|s| match (s.kernel.probe_latch(), trips_at) {
        (ProbeLatch::Armed { trips_at: t }, Some(l)) if t == l => {}
        (ProbeLatch::Tripped { .. }, Some(_)) | (ProbeLatch::Off, None) => {}
        (_, Some(l)) => s.kernel.arm_probe(l),
        (_, None) => s.kernel.disarm_probe(),
    });
}

/// The step position the probe latch recorded, if it tripped.
pub fn probe_latched() -> Option<[i64; MAX_AXES]> {
    with_kernel(|s| match s.kernel.probe_latch() {
        ProbeLatch::Tripped { steps } => Some(steps),
        _ => None,
    })
    .flatten()
}

/// Loads a new step position (homing set home); the kernel is at rest then.
pub fn set_position(steps: [i64; MAX_AXES]) {
    with_kernel(|s| s.kernel.set_position(steps));
}

/// Takes a new pulse shape (a setup change; the machine is idle then).
pub fn set_timing(timing: StepTiming) {
    with_kernel(|s| s.timing = timing);
}

/// Configures TIM2 to tick the kernel with pulses shaped by `timing` and returns the producer end
/// of its segment queue.
pub fn start(
    tim2: Peri<'static, TIM2>,
    psc: u16,
    timing: StepTiming,
) -> Producer<'static, Segment> {
    static QUEUE: StaticCell<Queue<Segment, SEGMENT_QUEUE_LEN>> = StaticCell::new();
    static TIMER: StaticCell<Timer<'static, TIM2>> = StaticCell::new();
    let (producer, consumer) = QUEUE.init(Queue::new()).split();
    critical_section::with(|_cs| {
        // SAFETY: TIM2's interrupt is not enabled yet and interrupts are masked: nothing else
        // can hold a reference into the cell.
        unsafe {
            *SHARED.0.get() = Some(StepIsr {
                kernel: StepKernel::new(),
                source: QueueSource(consumer),
                pending: TickOut::default(),
                idle: true,
                timing,
            })
        }
    });

    // Kept in a static: dropping the driver would gate TIM2's clock.
    let timer = TIMER.init(Timer::new(tim2));
    timer.stop();
    TIM.psc().write_value(psc);
    TIM.arr().write_value(IDLE_PERIOD_COUNTS - 1);
    TIM.ccr(0).write_value(timing.pulse);
    timer.set_autoreload_preload(true);
    timer.generate_update_event(); // load PSC and ARR without an interrupt
    TIM.dier().modify(|w| {
        w.set_uie(true);
        w.set_ccie(0, true);
    });
    TIM.sr().write_value(SrGp16(0));
    interrupt::TIM2.set_priority(Priority::P0);
    // SAFETY: the TIM2 handler below only touches TIM2, the step/dir ports and the user output
    // pins (BSRR, write-only, atomic per bit) and state it owns; nothing else uses TIM2 or the
    // step/dir pins, and the user output pins are only written by BSRR here and in
    // `sync_user_outputs`, which holds TIM2 off.
    unsafe { interrupt::TIM2.enable() };
    timer.start();
    producer
}

/// Clears the given TIM2 status bits (rc_w0: writing 1 leaves a flag alone).
#[inline(always)]
fn clear_flags(bits: u32) {
    TIM.sr().write_value(SrGp16(!bits));
}

const UIF: u32 = 1 << 0;
const CC1IF: u32 = 1 << 1;

#[interrupt]
fn TIM2() {
    // SAFETY: this handler is the single interrupt-side user of `SHARED` and nothing that
    // touches it can preempt P0 (see `Shared`); thread code only reaches it with TIM2 masked.
    let state = unsafe { &mut *SHARED.0.get() };
    let Some(isr) = state.as_mut() else {
        clear_flags(UIF | CC1IF);
        return;
    };
    let sr = TIM.sr().read().0;
    if sr & CC1IF != 0 {
        clear_flags(CC1IF);
        STEP_GPIO
            .bsrr()
            .write_value(pac::gpio::regs::Bsrr(STEP_RESET));
        DIR_GPIO.bsrr().write_value(pac::gpio::regs::Bsrr(
            DIR_WORD[(isr.pending.dir & 63) as usize],
        ));
    }
    if sr & UIF != 0 {
        clear_flags(UIF);
        let t = isr.timing;
        // ARR still holds the running period's reload value (the new one is written below): the
        // next update comes ARR + 1 counts after this one. The pulse ends at `pulse_end`, the dir
        // pins for the next step change then, and that step starts at the next update.
        let pulse_end = TIM.cnt().read() + t.pulse;
        if pulse_end + t.dir_setup > TIM.arr().read() + 1 {
            // Too late to fit pulse and dir set-up in this period: keep `pending` for the next
            // update.
            LATE_TICKS.store(LATE_TICKS.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
            return;
        }
        TIM.ccr(0).write_value(pulse_end);
        if isr.pending.output.is_some() {
            // On-the-fly output: switched with the first step of its block.
            write_output(isr.pending.output);
        }
        STEP_GPIO.bsrr().write_value(pac::gpio::regs::Bsrr(
            STEP_SET[(isr.pending.step & 63) as usize],
        ));
        let out = isr.kernel.tick(
            &mut isr.source,
            STOP.load(Ordering::Relaxed),
            PROBE_GPIO.idr().read().0 & PROBE_MASK == 0,
        );
        let period = match out.period {
            0 => IDLE_PERIOD_COUNTS,
            p => t.stretch(p),
        };
        TIM.arr().write_value(period - 1);
        isr.idle = out.period == 0;
        isr.pending = out;
    }
}

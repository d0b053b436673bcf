//! Step timer: TIM2 (32-bit) times every step edge; the edges come from DMA, one interrupt per
//! step event does the rest.
//!
//! Each period starts with an update: DMA1 (`step_dma.rs`) copies the step word held in TIM2's
//! CCR3 to the step port's BSRR, so the step pins rise on the timer's edge, not when an
//! interrupt gets there. At compare 1 (`pulse` counts later, [`StepTiming::pulse`] from
//! `Setup::drivers`) a second stream drops the step pins (the pulse end) and, at compare 2 (the
//! same count), a third overwrites CCR3 with that reset word, so an update nobody prepared
//! raises nothing. Compare 1 also raises the one interrupt, at P0: the core's body
//! (`gantry_machine::step`, machine/src/step/isr.rs)
//! writes the dir pins of the step the next update emits, puts that step's word in CCR3 and the
//! period after it in the preloaded ARR, then runs `StepKernel::tick`; it keeps two computed
//! ticks, so it knows whether the step after the next one changes direction and gives the period
//! before that step the dir set-up ([`StepTiming::period`]); every other period is at least
//! [`StepTiming::min_period`] (the pulse, then the pin low as long again or as long as the
//! body's writes take). The body writes only when the timer shows time left before the next
//! update for its writes and, when a dir pin changes, for the dir set-up
//! ([`StepTiming::dir_setup`]); else it leaves everything for the next period (counted in
//! [`LATE_TICKS`]): no edge is lost or repeated and no step follows a direction change sooner
//! than the setup allows. The dir pins change after the pulse end, so they are held a pulse
//! width after each edge. `Setup::is_valid` refuses axes whose max rate would need periods
//! shorter than [`StepTiming::min_period`]. Pin words come from 64-entry tables built at compile
//! time from the board's pin numbers, so the ISR does lookups, no loops.
//!
//! On-the-fly outputs: a segment's [`OutputEvent`] comes out of the tick that starts the segment
//! and is switched (one BSRR write of the user output's port, port and pin mask from a table
//! built at compile time from the board's user output pins) when that tick's step is scheduled,
//! together with its dir pins: after the last step of the block before and before the first
//! step of its own block. [`sync_user_outputs`] is the only other writer of those pins.
//!
//! A stop seen by the kernel takes effect at that tick; the two steps computed on the ticks
//! before are still emitted, so the kernel's position count stays exact. When the kernel is
//! idle the timer keeps polling the queue every millisecond.

use crate::pin_map::{gpio_block, PinId};
use crate::pin_table::{AXES, DIR, PROBE, STEP, USER_OUTPUTS, USER_PINS};
use crate::step_dma::{self, StepDma};
use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::pac;
use embassy_stm32::pac::timer::regs::SrGp16;
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Peri;
use gantry_machine::step::kernel::{Segment, SegmentSource, StepTiming};
use gantry_machine::step::output_event::OutputEvent;
use gantry_machine::step::{
    KernelSnapshot, PinWords, Run, SegmentQueue, StepHardware, StepIsr, IDLE_PERIOD_COUNTS,
};
use gantry_machine::units::MAX_AXES;
use heapless::spsc::{Consumer, Producer, Queue};
use static_cell::StaticCell;

/// Slots in the segment queue: the core's one figure (`gantry_machine::device::main_loop`), so the
/// emulated board queues exactly as many segments. heapless 0.9's SPSC queue holds N - 1: 15
/// segments of about 2 ms, 30 ms of motion ahead of the kernel, every one of which a stop can
/// take back ([`drop_newest`]).
pub const SEGMENT_QUEUE_LEN: usize = gantry_machine::device::main_loop::SEGMENT_QUEUE_SLOTS;

/// An armed limit switch is active: set by the input task (EXTI, microseconds after the edge) and
/// the main loop, cleared only by the main loop when it re-arms the kernel. The kernel latches
/// it on its next tick.
pub static STOP: AtomicBool = AtomicBool::new(false);
/// Periods in which the interrupt started too late to schedule the next step with its dir set-up
/// (the step went out a period later; should stay 0).
pub static LATE_TICKS: AtomicU32 = AtomicU32::new(0);

/// BSRR words of the step and dir pins for every 6-bit step and dir mask.
static PIN_WORDS: PinWords = PinWords::new(&masks(&STEP), &masks(&DIR));
/// Port and pin mask of each user output (16 slots; outputs the board does not have have mask 0,
/// so switching them changes no pin).
const USER_GPIO: [pac::gpio::Gpio; 16] = output_ports(&USER_PINS);
static USER_MASK: [u16; 16] = output_masks(&USER_PINS);

const _: () = {
    assert!(
        PIN_WORDS.step_set[0] == 0 && PIN_WORDS.step_set[63] == mask(&STEP),
        "step table covers the step pins"
    );
    assert!(PIN_WORDS.step_reset == mask(&STEP) << 16, "step reset word");
    assert!(
        PIN_WORDS.dir[0] == mask(&DIR) << 16 && PIN_WORDS.dir[63] == mask(&DIR),
        "dir table"
    );
};

const STEP_GPIO: pac::gpio::Gpio = gpio_block(STEP[0].port);
const DIR_GPIO: pac::gpio::Gpio = gpio_block(DIR[0].port);
/// The touch probe's port: the kernel gets its raw level every tick (bit set = pin low = closed,
/// as `inputs::PINS`), for its probe latch.
const PROBE_GPIO: pac::gpio::Gpio = gpio_block(PROBE.port);
const PROBE_MASK: u32 = PROBE.mask();
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

const fn masks(pins: &[PinId; AXES]) -> [u32; AXES] {
    let mut m = [0; AXES];
    let mut i = 0;
    while i < AXES {
        m[i] = pins[i].mask();
        i += 1;
    }
    m
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

impl SegmentQueue for QueueSource {
    fn is_empty(&self) -> bool {
        !self.0.ready()
    }
}

/// The interrupt's hardware: TIM2's counter, reload and CCR3 (the step word the update DMA
/// copies), the dir port, the user output pins and, in laser mode, the spindle PWM's compare
/// register.
struct Tim2Dma;

impl StepHardware for Tim2Dma {
    #[inline(always)]
    fn count(&self) -> u32 {
        TIM.cnt().read()
    }
    #[inline(always)]
    fn reload(&self) -> u32 {
        TIM.arr().read()
    }
    #[inline(always)]
    fn set_reload(&mut self, reload: u32) {
        TIM.arr().write_value(reload);
    }
    #[inline(always)]
    fn write_dir(&mut self, bsrr: u32) {
        DIR_GPIO.bsrr().write_value(pac::gpio::regs::Bsrr(bsrr));
    }
    #[inline(always)]
    fn set_step_word(&mut self, bsrr: u32) {
        TIM.ccr(step_dma::STEP_WORD_CCR).write_value(bsrr);
    }
    #[inline(always)]
    fn write_output(&mut self, event: OutputEvent) {
        write_output(event);
    }
    #[inline(always)]
    fn write_power(&mut self, duty: u16) {
        crate::pin_table::spindle_pwm_compare(duty);
    }
    #[inline(always)]
    fn probe_closed(&self) -> bool {
        PROBE_GPIO.idr().read().0 & PROBE_MASK == 0
    }
}

/// The ISR's state, shared with the main loop.
///
/// Access protocol (what makes the `unsafe` below sound): the TIM2 handler is the only interrupt
/// that touches the cell, and nothing can preempt it that touches it (TIM2 alone runs at P0;
/// NMI and faults don't). Every other access goes through [`with_kernel`], which holds a critical
/// section (PRIMASK: TIM2 cannot run meanwhile) and is never nested (the closures below don't
/// call it). So at most one `&mut` to the state exists at any time.
struct Shared(UnsafeCell<Option<StepIsr<QueueSource>>>);

// SAFETY: see the access protocol above; the cell is only reached under it.
unsafe impl Sync for Shared {}

static SHARED: Shared = Shared(UnsafeCell::new(None));

/// Runs `f` on the ISR's state inside a critical section (TIM2 masked for its duration: keep
/// `f` to a few dozen instructions; the edges come from DMA on time, but an interrupt delayed
/// past its deadline sends its step a period later). `None` before [`start`].
fn with_kernel<R>(f: impl FnOnce(&mut StepIsr<QueueSource>) -> R) -> Option<R> {
    critical_section::with(|_cs| {
        // SAFETY: interrupts are masked, so the TIM2 handler is not running and cannot start;
        // this is the only other access path and it is not re-entered (see `Shared`).
        let state = unsafe { &mut *SHARED.0.get() };
        state.as_mut().map(f)
    })
}

/// Reads the kernel's position and state.
pub fn snapshot() -> KernelSnapshot {
    with_kernel(|s| s.snapshot()).unwrap_or(KernelSnapshot {
        steps: [0; MAX_AXES],
        drained: true,
        stopped: false,
        dry_runs: 0,
        laser_duty: 0,
    })
}

/// After a latched stop: drops every queued segment and the running one (the position keeps the
/// steps made). The kernel stays stopped until [`rearm`].
pub fn flush() {
    with_kernel(|s| s.flush());
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
    with_kernel(|s| s.rearm());
}

/// Exchanges the user output word between the board and the kernel (`Board::sync_user_outputs`):
/// `f` gets the kernel's word (the pins, with every on-the-fly event fired so far) and returns a
/// word to load, if the board switched outputs itself. That word goes into the kernel and onto
/// the pins inside the same critical section, so no event can fire in between, and an event
/// computed but not yet emitted is dropped with it.
pub fn sync_user_outputs(f: impl FnOnce(u16) -> Option<u16>) {
    with_kernel(|s| {
        let Some(word) = s.exchange_outputs(f) else {
            return;
        };
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
    with_kernel(|s| s.arm_probe(trips_at));
}

/// The step position the probe latch recorded, if it tripped.
pub fn probe_latched() -> Option<[i64; MAX_AXES]> {
    with_kernel(|s| s.probe_latched()).flatten()
}

/// Loads a new step position (homing set home); the kernel is at rest then.
pub fn set_position(steps: [i64; MAX_AXES]) {
    with_kernel(|s| s.kernel.set_position(steps));
}

/// Takes a new pulse shape (a setup change; the machine is idle then).
pub fn set_timing(timing: StepTiming) {
    with_kernel(|s| {
        s.timing = timing;
        step_dma::set_pulse(timing.pulse);
    });
}

/// Configures TIM2 and its DMA streams to emit steps with pulses shaped by `timing` and returns
/// the producer end of the segment queue.
pub fn start(
    tim2: Peri<'static, TIM2>,
    dma: StepDma,
    psc: u16,
    timing: StepTiming,
) -> Producer<'static, Segment> {
    static QUEUE: StaticCell<Queue<Segment, SEGMENT_QUEUE_LEN>> = StaticCell::new();
    static TIMER: StaticCell<Timer<'static, TIM2>> = StaticCell::new();
    let (producer, consumer) = QUEUE.init(Queue::new()).split();
    critical_section::with(|_cs| {
        // SAFETY: TIM2's interrupt is not enabled yet and interrupts are masked: nothing else
        // can hold a reference into the cell.
        unsafe { *SHARED.0.get() = Some(StepIsr::new(QueueSource(consumer), timing)) }
    });

    // Kept in a static: dropping the driver would gate TIM2's clock.
    let timer = TIMER.init(Timer::new(tim2));
    timer.stop();
    TIM.psc().write_value(psc);
    TIM.arr().write_value(IDLE_PERIOD_COUNTS - 1);
    timer.set_autoreload_preload(true);
    timer.generate_update_event(); // load PSC and ARR (no DMA request yet: UDE is off)
    step_dma::start(
        dma,
        PIN_WORDS.step_reset,
        STEP_GPIO.bsrr().as_ptr() as u32,
        timing.pulse,
    );
    TIM.dier().modify(|w| w.set_ccie(0, true));
    TIM.sr().write_value(SrGp16(0));
    interrupt::TIM2.set_priority(Priority::P0);
    // SAFETY: the TIM2 handler below only touches TIM2, the dir port and the user output pins
    // (BSRR, write-only, atomic per bit) and state it owns; nothing else uses TIM2 or the
    // step/dir pins, and the user output pins are only written by BSRR here and in
    // `sync_user_outputs`, which holds TIM2 off.
    unsafe { interrupt::TIM2.enable() };
    timer.start();
    producer
}

/// Compare 1 flag: the pulse end, the one interrupt per step event.
const CC1IF: u32 = 1 << 1;

#[interrupt]
fn TIM2() {
    // Cleared first, so the flag is down before the handler returns (rc_w0: writing 1 leaves
    // the other flags alone; nothing else raises this interrupt).
    TIM.sr().write_value(SrGp16(!CC1IF));
    // SAFETY: this handler is the single interrupt-side user of `SHARED` and nothing that
    // touches it can preempt P0 (see `Shared`); thread code only reaches it with TIM2 masked.
    let state = unsafe { &mut *SHARED.0.get() };
    let Some(isr) = state.as_mut() else {
        return;
    };
    if isr.on_pulse_end(&PIN_WORDS, &mut Tim2Dma, STOP.load(Ordering::Relaxed)) == Run::Late {
        LATE_TICKS.store(LATE_TICKS.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
    }
}

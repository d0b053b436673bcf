//! Step timer: TIM2 (32-bit) at NVIC priority P0 runs the core's step kernel once per tick.
//!
//! The update interrupt starts a tick: it raises the step pins computed on the previous tick (one
//! BSRR write), runs `StepKernel::tick`, and loads the kernel's period into the preloaded ARR, so it
//! times the period after the step just emitted. It also points compare channel 1 at
//! `STEP_PULSE_COUNTS` after the moment the pins rose; that interrupt drops the step pins (one BSRR
//! write) and sets the dir pins for the next step (one BSRR write), giving every step a full period
//! minus the pulse of dir set-up time. Pin words come from 64-entry tables built at compile time
//! from the board's pin numbers, so the ISR does lookups, no loops.
//!
//! If the ISR starts so late that the pulse could not end within the current period, it emits
//! nothing and retries on the next update (counted in [`LATE_TICKS`]), so no edge is ever lost.
//! A stop seen by the kernel takes effect at that tick; the step computed on the tick before is
//! still emitted, so the kernel's position count stays exact. When the kernel is idle the timer
//! keeps polling the queue every millisecond.

use crate::board::{gpio_block, PinId};
use crate::board_def::{AXES, DIR, STEP};
use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use critical_section::Mutex;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::pac;
use embassy_stm32::pac::timer::regs::SrGp16;
use embassy_stm32::peripherals::TIM2;
use embassy_stm32::timer::low_level::Timer;
use embassy_stm32::Peri;
use gantry_machine::motion::kernel::{
    Segment, SegmentSource, StepKernel, TickOut, KERNEL_TIMER_HZ,
};
use heapless::spsc::{Consumer, Producer, Queue};
use static_cell::StaticCell;

/// Step pulse width in timer counts (2 µs).
pub const STEP_PULSE_COUNTS: u32 = KERNEL_TIMER_HZ / 500_000;
/// Shortest tick period accepted: pulse plus 2 µs of dir set-up (250 kHz step rate at most).
pub const MIN_PERIOD_COUNTS: u32 = 2 * STEP_PULSE_COUNTS;
/// Tick period while the kernel is idle (1 ms), i.e. how often an empty queue is polled.
pub const IDLE_PERIOD_COUNTS: u32 = KERNEL_TIMER_HZ / 1_000;
/// Slots in the segment queue (heapless 0.9 SPSC holds N - 1).
pub const SEGMENT_QUEUE_LEN: usize = 32;

/// Set by the input task (limit or abort asserted); the kernel latches it on its next tick.
pub static STOP: AtomicBool = AtomicBool::new(false);
/// Ticks deferred because the ISR started too late to fit the step pulse (should stay 0).
pub static LATE_TICKS: AtomicU32 = AtomicU32::new(0);

/// BSRR word raising the step pins of each 6-bit step mask.
static STEP_SET: [u32; 64] = step_set_table(&STEP);
/// BSRR word dropping every step pin.
const STEP_RESET: u32 = mask(&STEP) << 16;
/// BSRR word setting every dir pin for each 6-bit dir mask (bit set = negative = pin high).
static DIR_WORD: [u32; 64] = dir_table(&DIR);

const _: () = {
    assert!(
        STEP_SET[0] == 0 && STEP_SET[63] == mask(&STEP),
        "step table covers the step pins"
    );
    assert!(
        DIR_WORD[0] == mask(&DIR) << 16 && DIR_WORD[63] == mask(&DIR),
        "dir table"
    );
    assert!(
        MIN_PERIOD_COUNTS > STEP_PULSE_COUNTS,
        "the pulse must end within the tick"
    );
};

const STEP_GPIO: pac::gpio::Gpio = gpio_block(STEP[0].port);
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
}

/// Hands the ISR state from `start` to the first interrupt, which keeps it from then on.
static HANDOFF: Mutex<RefCell<Option<StepIsr>>> = Mutex::new(RefCell::new(None));

/// Configures TIM2 to tick the kernel and returns the producer end of its segment queue.
pub fn start(tim2: Peri<'static, TIM2>, psc: u16) -> Producer<'static, Segment> {
    static QUEUE: StaticCell<Queue<Segment, SEGMENT_QUEUE_LEN>> = StaticCell::new();
    static TIMER: StaticCell<Timer<'static, TIM2>> = StaticCell::new();
    let (producer, consumer) = QUEUE.init(Queue::new()).split();
    critical_section::with(|cs| {
        HANDOFF.borrow_ref_mut(cs).replace(StepIsr {
            kernel: StepKernel::new(),
            source: QueueSource(consumer),
            pending: TickOut::default(),
        })
    });

    // Kept in a static: dropping the driver would gate TIM2's clock.
    let timer = TIMER.init(Timer::new(tim2));
    timer.stop();
    TIM.psc().write_value(psc);
    TIM.arr().write_value(IDLE_PERIOD_COUNTS - 1);
    TIM.ccr(0).write_value(STEP_PULSE_COUNTS);
    timer.set_autoreload_preload(true);
    timer.generate_update_event(); // load PSC and ARR without an interrupt
    TIM.dier().modify(|w| {
        w.set_uie(true);
        w.set_ccie(0, true);
    });
    TIM.sr().write_value(SrGp16(0));
    interrupt::TIM2.set_priority(Priority::P0);
    // SAFETY: the TIM2 handler below only touches TIM2, the step/dir ports (BSRR, write-only,
    // atomic per bit) and state it owns; nothing else uses TIM2 or those pins.
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
    static mut ISR: Option<StepIsr> = None;
    if ISR.is_none() {
        *ISR = critical_section::with(|cs| HANDOFF.borrow_ref_mut(cs).take());
    }
    let Some(isr) = ISR.as_mut() else {
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
        // ARR still holds the running period's reload value (the new one is written below).
        let pulse_end = TIM.cnt().read() + STEP_PULSE_COUNTS;
        if pulse_end > TIM.arr().read() {
            // Too late to fit the pulse in this period: keep `pending` for the next update.
            LATE_TICKS.store(LATE_TICKS.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
            return;
        }
        TIM.ccr(0).write_value(pulse_end);
        STEP_GPIO.bsrr().write_value(pac::gpio::regs::Bsrr(
            STEP_SET[(isr.pending.step & 63) as usize],
        ));
        let out = isr
            .kernel
            .tick(&mut isr.source, STOP.load(Ordering::Relaxed));
        let period = match out.period {
            0 => IDLE_PERIOD_COUNTS,
            p if p < MIN_PERIOD_COUNTS => MIN_PERIOD_COUNTS,
            p => p,
        };
        TIM.arr().write_value(period - 1);
        isr.pending = out;
    }
}

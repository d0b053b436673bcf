//! Gantry firmware: embassy glue around the `gantry-machine` core.
//!
//! Interrupt priorities (lower number = more urgent): TIM2 step ISR P0 alone; EXTI lines and the
//! fast executor (inputs) P1; embassy's time driver (TIM4) and DMA P2; USB OTG FS P3; everything
//! else runs in the thread-mode executor.
#![no_std]
#![no_main]

#[macro_use]
mod board;
mod analog;
mod clocks;
mod inputs;
mod step;
mod usb;

#[cfg(all(feature = "board-f411", feature = "board-f446"))]
compile_error!("choose exactly one board feature");

/// The board table chosen by the `board-*` feature, expanded by `board::gantry_board!`.
#[cfg(feature = "board-f411")]
#[path = "../../boards/blackpill_f411.rs"]
mod board_def;
#[cfg(all(feature = "board-f446", not(feature = "board-f411")))]
#[path = "../../boards/nucleo_f446.rs"]
mod board_def;

use defmt_rtt as _;
use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::gpio::Output;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use panic_probe as _;
use static_cell::StaticCell;

/// Runs tasks that must react within microseconds (inputs), on a spare USART6 vector at P1.
static EXECUTOR_FAST: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn USART6() {
    // SAFETY: USART6's vector is used by nothing but this executor.
    unsafe { EXECUTOR_FAST.on_interrupt() }
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks::config());
    defmt::info!(
        "Gantry on {} ({}), SYSCLK {} Hz",
        board_def::NAME,
        board_def::PROBE_CHIP,
        clocks::SYSCLK_HZ
    );
    let (pins, rest) = board_def::split(p);
    let board_def::Pins {
        step_dir,
        inputs,
        analog,
        outputs,
    } = pins;
    // Never dropped: step/dir stay configured for the ISR's register writes.
    static STEP_DIR: StaticCell<[Output<'static>; 2 * board_def::AXES]> = StaticCell::new();
    STEP_DIR.init(step_dir);

    // embassy leaves its interrupts at reset priority 0; only the step timer may have that.
    interrupt::TIM4.set_priority(Priority::P2);
    for irq in [
        interrupt::EXTI0,
        interrupt::EXTI1,
        interrupt::EXTI2,
        interrupt::EXTI3,
        interrupt::EXTI4,
        interrupt::EXTI9_5,
        interrupt::EXTI15_10,
    ] {
        irq.set_priority(Priority::P1);
    }
    interrupt::USART6.set_priority(Priority::P1);

    let (device, class) = usb::build(rest.usb, rest.usb_dp, rest.usb_dm);
    interrupt::OTG_FS.set_priority(Priority::P3);

    let _segments = step::start(rest.tim2, clocks::TIM2_PSC);

    let fast = EXECUTOR_FAST.start(interrupt::USART6);
    fast.spawn(defmt::unwrap!(inputs::run(inputs, outputs)));
    spawner.spawn(defmt::unwrap!(usb::run_device(device)));
    spawner.spawn(defmt::unwrap!(usb::run_link(class)));
    spawner.spawn(defmt::unwrap!(analog::run(rest.adc1, analog)));
    defmt::info!("ready");
}

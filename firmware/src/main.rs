//! Gantry firmware: embassy glue around the `gantry-machine` core.
//!
//! Interrupt priorities (lower number = more urgent; reviewed table in firmware/README.md): TIM2
//! step ISR P0 alone; EXTI lines and the fast executor (inputs) P1; embassy's time driver (TIM4)
//! and DMA P2; USB OTG FS and FLASH P3; the main loop, USB and ADC tasks run in the thread-mode
//! executor.
#![no_std]
#![no_main]

#[macro_use]
mod pin_map;
mod analog;
mod clocks;
mod control;
mod inputs;
mod reset_marker;
mod safety;
mod settings;
mod step;
mod step_dma;
mod usb;
mod watchdog;

#[cfg(any(
    all(feature = "board-f411", feature = "board-f446"),
    all(feature = "board-f411", feature = "board-f411-plasma"),
    all(feature = "board-f411-plasma", feature = "board-f446"),
))]
compile_error!("choose exactly one board feature");

/// The board table (pin map) chosen by the `board-*` feature, expanded by `pin_map::gantry_board!`.
#[cfg(feature = "board-f411")]
#[path = "../../boards/blackpill_f411.rs"]
mod pin_table;
#[cfg(all(feature = "board-f411-plasma", not(feature = "board-f411")))]
#[path = "../../boards/blackpill_f411_plasma.rs"]
mod pin_table;
#[cfg(all(
    feature = "board-f446",
    not(any(feature = "board-f411", feature = "board-f411-plasma"))
))]
#[path = "../../boards/nucleo_f446.rs"]
mod pin_table;

use defmt_rtt as _;
use embassy_executor::{InterruptExecutor, SpawnError, SpawnToken, Spawner};
use embassy_stm32::gpio::Output;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use gantry_machine::step::kernel::StepTiming;
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
    // Before anything else: how the previous run ended (reset flags, motion marker in RAM).
    let (power_up, reset_cause) = reset_marker::power_up();
    let p = embassy_stm32::init(clocks::config());
    // First: a hang anywhere below (clock, USB or flash init) resets the board.
    watchdog::start();
    defmt::info!(
        "Gantry on {} ({}), SYSCLK {} Hz",
        pin_table::NAME,
        pin_table::PROBE_CHIP,
        clocks::SYSCLK_HZ
    );
    let (cause, how) = reset_marker::describe(power_up, reset_cause);
    defmt::info!("reset: {=str}, {=str}", cause, how);
    let (pins, rest) = pin_table::split(p);
    let pin_table::Pins {
        step_dir,
        inputs,
        analog,
        outputs,
    } = pins;
    // Never dropped: step/dir stay configured for the ISR's register writes.
    static STEP_DIR: StaticCell<[Output<'static>; 2 * pin_table::AXES]> = StaticCell::new();
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

    // The setup from flash (defaults when absent or invalid) and this power-up's boot id. Flash
    // writes here (the boot counter) stall the CPU briefly; nothing moves yet.
    let (store, setup, boot_id) = {
        let mut store = settings::open(rest.flash);
        // Loading may repair a store a power cut left half-written, and counting the boot may
        // erase a sector (1-2 s of stalled CPU): the watchdog's long timeout covers both, or a
        // reset in the middle of the erase would repeat at every boot.
        watchdog::long();
        let (loaded, boots) = settings::load(&mut store);
        defmt::info!("settings: {}", loaded.describe());
        watchdog::normal();
        let uid = embassy_stm32::uid::uid();
        let uid_hash = uid.iter().fold(0x811c_9dc5u32, |h, b| {
            (h ^ u32::from(*b)).wrapping_mul(0x0100_0193)
        });
        let boot_id = boots ^ uid_hash.rotate_left(16);
        defmt::info!("boot {} (id {=u32:#010x})", boots, boot_id);
        watchdog::feed();
        (store, loaded.into_setup(), boot_id)
    };

    let (device, class) = usb::build(rest.usb, rest.usb_dp, rest.usb_dm);
    interrupt::OTG_FS.set_priority(Priority::P3);
    let (tx, rx, control) = class.split_with_control();
    static RX_PIPE: StaticCell<usb::LinkPipe> = StaticCell::new();
    static TX_PIPE: StaticCell<usb::LinkPipe> = StaticCell::new();
    let rx_pipe: &'static usb::LinkPipe = RX_PIPE.init(usb::LinkPipe::new());
    let tx_pipe: &'static usb::LinkPipe = TX_PIPE.init(usb::LinkPipe::new());
    static RX_WAKE: StaticCell<usb::RxWake> = StaticCell::new();
    let rx_wake: &'static usb::RxWake = RX_WAKE.init(usb::RxWake::new());

    let timing = StepTiming::from_setup(&setup.drivers);
    let segments = step::start(rest.tim2, rest.step_dma, clocks::TIM2_PSC, timing);

    let fast = EXECUTOR_FAST.start(interrupt::USART6);
    fast.spawn(token(inputs::run(inputs)));
    spawner.spawn(token(usb::run_device(device)));
    spawner.spawn(token(usb::run_rx(rx, rx_pipe, rx_wake)));
    spawner.spawn(token(usb::run_tx(tx, tx_pipe)));
    spawner.spawn(token(usb::run_control(control)));
    spawner.spawn(token(analog::run(rest.adc1, analog)));
    let board = controller_board(setup, power_up);
    let link = controller_link(boot_id);
    spawner.spawn(token(control::run(
        control::Io {
            outputs,
            segments,
            rx: rx_pipe,
            rx_wake,
            tx: tx_pipe,
            store,
        },
        board,
        link,
    )));
    defmt::info!("ready");
}

/// A task's spawn token. Each task is spawned once into its own pool, so this never fails; if it
/// did, the board would halt with "task not spawned" over defmt (one shared out-of-line path: a
/// `defmt::unwrap!` per task cost 80 B more flash).
fn token<S>(t: Result<SpawnToken<S>, SpawnError>) -> SpawnToken<S> {
    match t {
        Ok(t) => t,
        Err(_) => spawn_failed(),
    }
}

#[inline(never)]
fn spawn_failed() -> ! {
    defmt::panic!("task not spawned")
}

/// The board, built once into its static, powered up as the reset left it (alarm 3 after a reset
/// during motion). A function of its own (never inlined) so that the temporary it may need on
/// the stack exists only during this call, not in every poll of `main` nor together with the
/// link's.
#[inline(never)]
fn controller_board(
    setup: gantry_machine::setup::Setup,
    how: gantry_machine::board::power_up::PowerUp,
) -> &'static mut gantry_machine::board::Board {
    static BOARD: StaticCell<gantry_machine::board::Board> = StaticCell::new();
    BOARD.init_with(|| gantry_machine::board::Board::power_up(setup, how))
}

/// The link endpoint, built once into its static (see [`controller_board`]).
#[inline(never)]
fn controller_link(boot_id: u32) -> &'static mut gantry_machine::device::link::BoardLink {
    static LINK: StaticCell<gantry_machine::device::link::BoardLink> = StaticCell::new();
    LINK.init_with(|| gantry_machine::device::link::BoardLink::new(boot_id))
}

//! The setup in flash: `gantry-settings` on the last two 128 KiB sectors (memory.x keeps them
//! out of the program).
//!
//! Flash region 3 of the F411CE/F446RE is the three 128 KiB sectors from 0x0802_0000; offsets
//! are relative to that base, so 0x2_0000..0x6_0000 is 0x0804_0000..0x0807_FFFF (sectors 6, 7).
//!
//! **Writing stalls the CPU**: both chips have a single flash bank, and every instruction fetch
//! waits while a word is programmed (~16 µs) or a sector erased (1-2 s for 128 KiB). The step
//! interrupt, USB and the main loop all freeze meanwhile, so the core main loop
//! (`MainLoop::pass`, machine/src/device/main_loop.rs) asks for a save only with the controller
//! idle and the kernel drained, and the port raises the watchdog timeout around it.
//!
//! Loading and saving run to completion here (`block_on`) rather than as awaits in the tasks:
//! the CPU stalls during flash writes anyway, and this way the store's futures and its 2 KiB
//! working buffer live on the stack for the call instead of in the static task storage.

use crate::pin_map::Irqs;
use embassy_futures::block_on;
use embassy_stm32::flash::{Async, Bank1Region3, Flash};
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use gantry_machine::setup::Setup;
use gantry_settings::{range_ok, DataBuffer, Loaded, SaveError, SettingsStore};

/// The settings sectors, as offsets in flash region 3 (see memory.x).
pub const RANGE: core::ops::Range<u32> = 0x2_0000..0x6_0000;

pub type Region = Bank1Region3<'static, Async>;
pub type Store = SettingsStore<Region>;

const _: () = assert!(
    range_ok::<Region>(RANGE),
    "settings range: two whole 128 KiB sectors"
);

/// Opens the store.
pub fn open(flash: Peri<'static, FLASH>) -> Store {
    let region = Flash::new(flash, Irqs).into_regions().bank1_region3;
    // `Flash::new` enabled the flash interrupt at reset priority 0, which is the step timer's.
    interrupt::FLASH.set_priority(Priority::P3);
    Store::new(region, RANGE)
}

/// Reads the stored setup and counts this power-up (the count is the link's boot id).
#[inline(never)]
pub fn load(store: &mut Store) -> (Loaded, u32) {
    let mut buf = DataBuffer::new();
    let loaded = block_on(store.load(&mut buf));
    let boots = block_on(store.next_boot_count(&mut buf));
    (loaded, boots)
}

/// Writes `setup` (only with the controller idle and the kernel drained: stalls the CPU).
#[inline(never)]
pub fn save(store: &mut Store, setup: &Setup) -> Result<(), SaveError> {
    let mut buf = DataBuffer::new();
    block_on(store.save(setup, &mut buf))
}

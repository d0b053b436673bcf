//! Host tests: encoding round trip through sequential-storage on a RAM NOR flash, and power cuts
//! at every word write and erase of a save.

extern crate std;

use super::*;
use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use embedded_storage_async::nor_flash::{
    ErrorType, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use std::vec;
use std::vec::Vec;

/// Runs a future that never waits (the RAM flash completes every operation at once).
fn block_on<T>(f: impl Future<Output = T>) -> T {
    let mut f = pin!(f);
    let mut cx = Context::from_waker(Waker::noop());
    for _ in 0..1000 {
        if let Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
    panic!("future did not complete");
}

const WORD: usize = 4; // STM32F4 with PSIZE x32
const PAGE: usize = 2048;
const PAGES: usize = 2; // as on the boards: two erase pages

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FlashError {
    OutOfBounds,
    NotAligned,
    /// Power was cut: this and every later operation did not (fully) happen.
    PowerCut,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::PowerCut => NorFlashErrorKind::Other,
        }
    }
}

/// RAM NOR flash: erase sets 0xFF, writes can only clear bits, each word may be written once
/// per erase (as on the F4 without multiwrite). `budget` counts word writes and page erases
/// left before the power fails; with `tear`, the operation the power fails in is half done.
struct RamFlash {
    mem: Vec<u8>,
    budget: Option<usize>,
    tear: bool,
    dead: bool,
    /// Writes to a word that was not erased (must stay 0).
    rewrites: usize,
    ops: usize,
}

impl RamFlash {
    fn new() -> Self {
        RamFlash {
            mem: vec![0xff; PAGE * PAGES],
            budget: None,
            tear: false,
            dead: false,
            rewrites: 0,
            ops: 0,
        }
    }

    /// The same cells after a power-up (no budget).
    fn reboot(mem: Vec<u8>) -> Self {
        RamFlash {
            mem,
            ..RamFlash::new()
        }
    }

    /// Takes one operation from the budget; false when the power fails now.
    fn step(&mut self) -> bool {
        self.ops += 1;
        if self.dead {
            return false;
        }
        match self.budget.as_mut() {
            Some(0) => {
                self.dead = true;
                false
            }
            Some(n) => {
                *n -= 1;
                true
            }
            None => true,
        }
    }
}

impl ErrorType for RamFlash {
    type Error = FlashError;
}

impl ReadNorFlash for RamFlash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let o = offset as usize;
        let src = self
            .mem
            .get(o..o + bytes.len())
            .ok_or(FlashError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl NorFlash for RamFlash {
    const WRITE_SIZE: usize = WORD;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE) || !to.is_multiple_of(PAGE) {
            return Err(FlashError::NotAligned);
        }
        if to > self.mem.len() || from > to {
            return Err(FlashError::OutOfBounds);
        }
        for page in (from..to).step_by(PAGE) {
            let was_dead = self.dead;
            if !self.step() {
                if self.tear && !was_dead {
                    // Cut half way through the erase: the first half of the page is blank.
                    self.mem[page..page + PAGE / 2].fill(0xff);
                }
                return Err(FlashError::PowerCut);
            }
            self.mem[page..page + PAGE].fill(0xff);
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let o = offset as usize;
        if !o.is_multiple_of(WORD) || !bytes.len().is_multiple_of(WORD) {
            return Err(FlashError::NotAligned);
        }
        if o + bytes.len() > self.mem.len() {
            return Err(FlashError::OutOfBounds);
        }
        for (i, word) in bytes.chunks(WORD).enumerate() {
            let at = o + i * WORD;
            let was_dead = self.dead;
            if !self.step() {
                if self.tear && !was_dead {
                    // Cut while programming: only some of the word's bits are cleared.
                    for (cell, b) in self.mem[at..at + WORD].iter_mut().zip(word) {
                        *cell &= *b | 0x5a;
                    }
                }
                return Err(FlashError::PowerCut);
            }
            if self.mem[at..at + WORD].iter().any(|&c| c != 0xff) {
                self.rewrites += 1;
            }
            for (cell, b) in self.mem[at..at + WORD].iter_mut().zip(word) {
                *cell &= *b;
            }
        }
        Ok(())
    }
}

fn store(flash: RamFlash) -> SettingsStore<RamFlash> {
    SettingsStore::new(flash, 0..(PAGE * PAGES) as u32)
}

/// A setup that differs from the defaults (and from `variant(j)`, j ≠ i) in a few fields.
fn variant(i: u32) -> Setup {
    let mut s = Setup::default();
    s.inputs.debounce_ms = (i % 200) as u8 + 1;
    s.inputs.adc_max = 1000 + (i.wrapping_mul(37) % 60_000) as u16;
    s.inputs.invert = i.wrapping_mul(0x9e37_79b9) & 0x3f_ffff;
    s.jog.nudge_interval_ms = 100 + (i % 1000) as u16;
    assert!(s.is_valid(), "variant {i} is a valid setup");
    s
}

#[test]
fn the_range_check_wants_two_whole_pages() {
    assert!(range_ok::<RamFlash>(0..(2 * PAGE) as u32));
    assert!(!range_ok::<RamFlash>(0..PAGE as u32), "one page");
    assert!(!range_ok::<RamFlash>(4..(2 * PAGE + 4) as u32), "unaligned");
}

#[test]
fn a_fresh_store_loads_nothing_and_the_defaults() {
    let mut st = store(RamFlash::new());
    let mut buf = DataBuffer::new();
    let loaded = block_on(st.load(&mut buf));
    assert_eq!(loaded, Loaded::Absent);
    assert_eq!(loaded.into_setup(), Setup::default());
}

#[test]
fn setups_round_trip_through_the_map_across_page_changes() {
    let mut st = store(RamFlash::new());
    let mut buf = DataBuffer::new();
    let mut blob = [0u8; SETUP_BLOB_MAX];
    let len = variant(1).to_blob(&mut blob).unwrap().len();
    // Enough saves to fill both pages several times over (the map migrates and erases).
    let saves = 4 * PAGES * PAGE / len + 3;
    for i in 0..saves as u32 {
        block_on(st.save(&variant(i), &mut buf)).expect("save");
        assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(variant(i)));
    }
    // And after a power-up, with a fresh map over the same cells.
    let flash = st.into_flash();
    assert_eq!(flash.rewrites, 0, "no word written twice without an erase");
    let mut st = store(RamFlash::reboot(flash.mem));
    assert_eq!(
        block_on(st.load(&mut buf)),
        Loaded::Stored(variant(saves as u32 - 1))
    );
}

#[test]
fn the_boot_counter_counts_and_leaves_the_setup_alone() {
    let mut st = store(RamFlash::new());
    let mut buf = DataBuffer::new();
    block_on(st.save(&variant(7), &mut buf)).unwrap();
    for n in 1..=50 {
        assert_eq!(block_on(st.next_boot_count(&mut buf)), n);
    }
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(variant(7)));
}

#[test]
fn a_foreign_item_under_the_setup_key_loads_as_invalid_and_gives_defaults() {
    let mut st = store(RamFlash::new());
    let mut buf = DataBuffer::new();
    let junk: &[u8] = &[0xde, 0xad, 0xbe, 0xef, 1, 2, 3];
    block_on(st.map.store_item(&mut buf.0, &SETUP_KEY, &junk)).unwrap();
    let loaded = block_on(st.load(&mut buf));
    assert_eq!(loaded, Loaded::Invalid);
    assert_eq!(loaded.into_setup(), Setup::default());
    // A save replaces it.
    block_on(st.save(&variant(3), &mut buf)).unwrap();
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(variant(3)));
    // Four bytes read as a boot count, which is no setup either; and a setup-sized item under
    // the boot key is no count (counting starts again).
    let four: &[u8] = &[1, 0, 0, 0];
    block_on(st.map.store_item(&mut buf.0, &SETUP_KEY, &four)).unwrap();
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Invalid);
    block_on(st.map.store_item(&mut buf.0, &BOOT_KEY, &junk)).unwrap();
    assert_eq!(block_on(st.next_boot_count(&mut buf)), 1);
}

/// A setup saved by the firmware before the serde encoding (key 3, format byte 2: the default
/// setup as that firmware wrote it) is not read: the board starts with the defaults. Under the
/// current key, the same bytes are refused by their format byte.
#[test]
fn a_setup_stored_by_older_firmware_gives_defaults() {
    let old: &[u8] = include_bytes!("testdata/setup_format2_default.bin");
    assert_eq!(old[0], 2, "format byte of the hand-written encoding");
    assert_eq!(Setup::from_blob(old), None);
    let mut st = store(RamFlash::new());
    let mut buf = DataBuffer::new();
    block_on(st.map.store_item(&mut buf.0, &3u8, &old)).unwrap();
    let loaded = block_on(st.load(&mut buf));
    assert_eq!(loaded, Loaded::Absent);
    assert_eq!(loaded.into_setup(), Setup::default());
    block_on(st.map.store_item(&mut buf.0, &SETUP_KEY, &old)).unwrap();
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Invalid);
    // A save in the current format replaces it.
    block_on(st.save(&variant(5), &mut buf)).unwrap();
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(variant(5)));
}

#[test]
fn garbage_cells_give_defaults_and_the_next_save_recovers() {
    let mut mem = vec![0u8; PAGE * PAGES];
    for (i, b) in mem.iter_mut().enumerate() {
        *b = (i as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3];
    }
    let mut st = store(RamFlash::reboot(mem));
    let mut buf = DataBuffer::new();
    let loaded = block_on(st.load(&mut buf));
    assert!(!matches!(loaded, Loaded::Stored(_)), "{loaded:?}");
    assert_eq!(loaded.into_setup(), Setup::default());
    block_on(st.save(&variant(9), &mut buf)).expect("save after garbage");
    assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(variant(9)));
}

/// Cuts the power at every word write and erase of every save in a long sequence (crossing page
/// changes), with clean and torn cuts: after the power comes back, loading gives exactly the
/// old or the new setup, and the next save works.
#[test]
fn a_power_cut_anywhere_in_a_save_leaves_the_old_or_the_new_setup() {
    let mut buf = DataBuffer::new();
    let mut blob = [0u8; SETUP_BLOB_MAX];
    let len = variant(1).to_blob(&mut blob).unwrap().len();
    let saves = 2 * PAGES * PAGE / len + 2;
    // The cells before save i (uninterrupted history).
    let mut history = RamFlash::new();
    let mut cuts = 0;
    let mut saw_new = 0;
    let mut saw_old = 0;
    for i in 0..saves as u32 {
        let before = history.mem.clone();
        let old = (i > 0).then(|| variant(i - 1));
        let new = variant(i);
        // Operations an uninterrupted save takes from this state.
        let mut probe = store(RamFlash::reboot(before.clone()));
        block_on(probe.save(&new, &mut buf)).unwrap();
        let ops = probe.into_flash().ops;
        for n in 0..=ops {
            for tear in [false, true] {
                let mut flash = RamFlash::reboot(before.clone());
                flash.budget = Some(n);
                flash.tear = tear;
                let mut st = store(flash);
                let result = block_on(st.save(&new, &mut buf));
                let flash = st.into_flash();
                if n < ops {
                    assert!(
                        result.is_err(),
                        "save {i} cut after {n} of {ops} ops succeeded"
                    );
                }
                cuts += 1;
                // Power back on.
                let mut st = store(RamFlash::reboot(flash.mem));
                let loaded = block_on(st.load(&mut buf));
                match (&loaded, &old) {
                    (Loaded::Stored(s), _) if *s == new => saw_new += 1,
                    (Loaded::Stored(s), Some(o)) if s == o => saw_old += 1,
                    (Loaded::Absent, None) => saw_old += 1,
                    _ => {
                        panic!("save {i}, cut after {n}/{ops} ops (torn {tear}): loaded {loaded:?}")
                    }
                }
                // The store works on: a further save is read back.
                let next = variant(10_000 + i);
                block_on(st.save(&next, &mut buf)).unwrap_or_else(|e| {
                    panic!("save {i}, cut after {n}/{ops} (torn {tear}): next save {e:?}")
                });
                assert_eq!(block_on(st.load(&mut buf)), Loaded::Stored(next));
                assert_eq!(st.into_flash().rewrites, 0, "no word written twice");
            }
        }
        let mut st = store(RamFlash::reboot(history.mem));
        block_on(st.save(&new, &mut buf)).unwrap();
        history = RamFlash::reboot(st.into_flash().mem);
    }
    assert!(saw_old > 0 && saw_new > 0, "both outcomes occur");
    std::println!(
        "{saves} saves of a {len}-byte setup, {cuts} power cuts: {saw_old} kept the old setup, {saw_new} the new one"
    );
}
